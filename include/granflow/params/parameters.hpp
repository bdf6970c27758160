#pragma once
// Parameter handling shared by every component.
//
// Each component declares its valid parameters once, in its own getValidParameters(), with the
// helpers below (default, doc string and validator in one call). Scenes are Teuchos
// ParameterList XML files; read_scene() validates them against the assembled valid list and
// turns every Teuchos validation failure into one InputError that names the file, the
// parameter, the value and what is allowed.
#include <Teuchos_ParameterList.hpp>
#include <Teuchos_RCP.hpp>
#include <Teuchos_XMLObject.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace granflow::params {

using Teuchos::ParameterList;
using Teuchos::RCP;

/// Bad input: the message names the parameter, the value and what is allowed.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Declare a double parameter with an inclusive range [min, max].
void add_double(ParameterList& pl, const std::string& name, double def, const std::string& doc,
                double min, double max);
/// Declare an int parameter with an inclusive range [min, max].
void add_int(ParameterList& pl, const std::string& name, int def, const std::string& doc, int min,
             int max);
/// Declare a string parameter restricted to one of `values` (an enum).
void add_enum(ParameterList& pl, const std::string& name, const std::string& def,
              const std::string& doc, const std::vector<std::string>& values);
/// Declare a free string parameter (file names, labels).
void add_string(ParameterList& pl, const std::string& name, const std::string& def,
                const std::string& doc);
void add_bool(ParameterList& pl, const std::string& name, bool def, const std::string& doc);

// ---------------------------------------------------------------------------------------------
// Strict reading of values as written in a scene. Teuchos's XML reader converts a value itself
// with std::stod-like leniency ("50abc" -> 50, "abc" -> 0, "0x10" -> 16, "{0.5 0.7}" -> {0.5})
// before any validator sees it, so scenes are converted here instead: the whole text must be
// the number (blanks around it aside), finite and representable; an integer has no fraction or
// exponent and fits an int. On failure the functions return false and say why in `why`.
// ---------------------------------------------------------------------------------------------
bool parse_double(const std::string& text, double& value, std::string& why);
bool parse_int(const std::string& text, int& value, std::string& why);
/// "true" or "false" (what Teuchos writes); nothing else.
bool parse_bool(const std::string& text, bool& value, std::string& why);
/// Valid UTF-8 without control characters (tab and line breaks aside): names and free text end up
/// in summary.json and in messages.
bool check_text(const std::string& text, std::string& why);
/// Text for a message: quoted, with bytes that are not printable UTF-8 written as \xNN.
std::string shown(const std::string& text);

/// Lists nested deeper than this in a scene file are refused before the XML is parsed (Teuchos
/// copies nested lists recursively; 10000 levels overflow the stack). Scenes need at most 5.
constexpr int kMaxNesting = 32;

/// The XML tree of a scene file: well-formed, nested at most kMaxNesting deep; no value
/// converted yet. Throws InputError naming the file (and the line) otherwise.
struct XmlDocument {
  std::string file;
  Teuchos::XMLObject root;
};
XmlDocument parse_xml(const std::string& file);

/// Convert the document into a ParameterList, strictly. Every element must be a <Parameter> or a
/// <ParameterList> with a name unique in its list. With `valid` (the scene's valid list), each
/// parameter must have the type of its valid entry, its text must parse strictly as that type
/// and pass the entry's Teuchos validator, and names must be valid (except inside pass-through
/// lists such as MueLu's, which Teuchos does not validate); without it (or for names `valid`
/// does not declare) the declared type must be int, double, bool, string or an Array of those
/// three and the text must parse strictly. Throws InputError("<file>: parameter '<path>' = "
/// "<text as entered>: <why>; allowed: <what>").
RCP<ParameterList> to_parameter_list(const XmlDocument& doc, const ParameterList* valid);

/// parse_xml + to_parameter_list without a valid list.
RCP<ParameterList> read_xml(const std::string& file);

/// Validate `user` against `valid` (recursively) and fill in defaults. Teuchos exceptions are
/// rewritten into an InputError that names `source` (file name) and the parameter path.
void validate_and_set_defaults(ParameterList& user, const ParameterList& valid,
                               const std::string& source);

/// Give every sublist its full path as name ("granflow->Channel->Left boundary"), so that
/// Teuchos's messages and ours say where a parameter lives.
void name_sublists(ParameterList& pl);

/// A number as users wrote it (up to 10 significant digits), for messages.
std::string str(double v);
/// A list of numbers as a scene writes it, "{0.2, 0.7}".
std::string str(const std::vector<double>& v);

/// "Sublist->Parameter" path used in messages.
std::string path(const ParameterList& pl, const std::string& name);

/// Throw InputError("<source>: parameter '<path>' = <value>: <why>").
[[noreturn]] void fail(const ParameterList& pl, const std::string& name, const std::string& value,
                       const std::string& why);

/// fail() for a parameter the scene gives (`user`, the list as written, before the defaults)
/// where its configuration does not use it; nothing when `user` is null or does not set it.
/// The value is shown as written: true/false, numbers as str().
void fail_if_given(const ParameterList& pl, const ParameterList* user, const std::string& name,
                   const std::string& why);

/// fail() for the parameters the scene gives (`user`) that `owner` (e.g. "the rheology Model
/// 'Newtonian'") does not read: every such parameter in one message, the first one named as
/// fail() names it and the others after "also not used" (an independent run: a user who
/// switched the model was refused one parameter per attempt). `selector` (e.g. "Model") is
/// never unused; nothing when `user` is null or gives only used parameters.
void fail_unused(const ParameterList& pl, const ParameterList* user,
                 const std::vector<std::string>& used, const std::string& selector,
                 const std::string& owner);

/// A Trilinos exception's text without its source locations and internal test lines: the
/// lines that name the parameter, its list and the allowed values, each indented by two spaces.
std::string trim_teuchos(const std::string& what);

/// Markdown reference of a valid list (name, type, default, allowed values, doc), recursive.
std::string reference_markdown(const ParameterList& valid, int heading_level = 2);

}  // namespace granflow::params
