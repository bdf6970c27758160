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

/// Read an XML file into a ParameterList (no validation). Throws InputError on a missing file or
/// malformed XML.
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

/// "Sublist->Parameter" path used in messages.
std::string path(const ParameterList& pl, const std::string& name);

/// Throw InputError("<source>: parameter '<path>' = <value>: <why>").
[[noreturn]] void fail(const ParameterList& pl, const std::string& name, const std::string& value,
                       const std::string& why);

/// Markdown reference of a valid list (name, type, default, allowed values, doc), recursive.
std::string reference_markdown(const ParameterList& valid, int heading_level = 2);

}  // namespace granflow::params
