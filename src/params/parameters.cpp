#include "granflow/params/parameters.hpp"

#include <Teuchos_StandardParameterEntryValidators.hpp>
#include <Teuchos_XMLParameterListHelpers.hpp>

#include <fstream>
#include <limits>
#include <sstream>

namespace granflow::params {

using Teuchos::rcp;

void add_double(ParameterList& pl, const std::string& name, double def, const std::string& doc,
                double min, double max) {
  auto v = rcp(new Teuchos::EnhancedNumberValidator<double>(min, max));
  pl.set(name, def, doc, v);
}

void add_int(ParameterList& pl, const std::string& name, int def, const std::string& doc, int min,
             int max) {
  auto v = rcp(new Teuchos::EnhancedNumberValidator<int>(min, max));
  pl.set(name, def, doc, v);
}

void add_enum(ParameterList& pl, const std::string& name, const std::string& def,
              const std::string& doc, const std::vector<std::string>& values) {
  Teuchos::Array<std::string> a(values.begin(), values.end());
  auto v = rcp(new Teuchos::StringValidator(a));
  pl.set(name, def, doc, v);
}

void add_string(ParameterList& pl, const std::string& name, const std::string& def,
                const std::string& doc) {
  pl.set(name, def, doc);
}

void add_bool(ParameterList& pl, const std::string& name, bool def, const std::string& doc) {
  pl.set(name, def, doc);
}

RCP<ParameterList> read_xml(const std::string& file) {
  std::ifstream probe(file);
  if (!probe) throw InputError("cannot open scene file '" + file + "' (no such file or not readable)");
  try {
    auto pl = Teuchos::getParametersFromXmlFile(file);
    pl->setName("granflow");
    name_sublists(*pl);
    return pl;
  } catch (const std::exception& e) {
    throw InputError("scene file '" + file + "' is not a valid ParameterList XML file:\n" +
                     std::string(e.what()));
  }
}

namespace {
// Teuchos messages start with the source location and the failed internal test of the throw;
// keep only the lines that name the parameter, its list, and the allowed values.
std::string trim_teuchos(const std::string& what) {
  std::istringstream in(what);
  std::string line, out;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '/' || line.rfind("./", 0) == 0 ||
        line.rfind("Throw number", 0) == 0 || line.rfind("Throw test", 0) == 0)
      continue;
    // Teuchos's own typo ("sublist is has an error")
    const auto p = line.find(" is has an error");
    if (p != std::string::npos) line.replace(p, 16, " has an error");
    const auto q = line.find("validator.Parameter:");
    if (q != std::string::npos) line.replace(q, 20, "validator.\nParameter:");
    out += "  " + line + "\n";
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out;
}
}  // namespace

void name_sublists(ParameterList& pl) {
  for (auto it = pl.begin(); it != pl.end(); ++it) {
    if (!pl.entry(it).isList()) continue;
    auto& sub = pl.sublist(pl.name(it));
    sub.setName(pl.name() + "->" + pl.name(it));
    name_sublists(sub);
  }
}

std::string str(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

void validate_and_set_defaults(ParameterList& user, const ParameterList& valid,
                               const std::string& source) {
  name_sublists(user);
  try {
    user.validateParametersAndSetDefaults(valid);
  } catch (const Teuchos::Exceptions::InvalidParameterName& e) {
    throw InputError(source + ": unknown parameter name (misspelt, or not used by this model):\n" +
                     trim_teuchos(e.what()));
  } catch (const Teuchos::Exceptions::InvalidParameterType& e) {
    throw InputError(source + ": parameter has the wrong type:\n" + trim_teuchos(e.what()));
  } catch (const Teuchos::Exceptions::InvalidParameterValue& e) {
    throw InputError(source + ": parameter value not allowed:\n" + trim_teuchos(e.what()));
  } catch (const Teuchos::Exceptions::InvalidParameter& e) {
    throw InputError(source + ": invalid parameter:\n" + trim_teuchos(e.what()));
  }
}

std::string path(const ParameterList& pl, const std::string& name) {
  return pl.name() + "->" + name;
}

void fail(const ParameterList& pl, const std::string& name, const std::string& value,
          const std::string& why) {
  throw InputError("parameter '" + path(pl, name) + "' = " + value + ": " + why);
}

namespace {
std::string allowed(const Teuchos::ParameterEntry& e) {
  auto v = e.validator();
  if (v.is_null()) return "";
  if (auto d = Teuchos::rcp_dynamic_cast<const Teuchos::EnhancedNumberValidator<double>>(v);
      !d.is_null()) {
    std::ostringstream os;
    os << "[" << d->getMin() << ", ";
    if (d->getMax() >= std::numeric_limits<double>::max()) os << "inf";
    else os << d->getMax();
    os << "]";
    return os.str();
  }
  if (auto i = Teuchos::rcp_dynamic_cast<const Teuchos::EnhancedNumberValidator<int>>(v);
      !i.is_null()) {
    std::ostringstream os;
    os << "[" << i->getMin() << ", " << i->getMax() << "]";
    return os.str();
  }
  if (auto values = v->validStringValues(); !values.is_null()) {
    std::string s;
    for (const auto& x : *values) s += (s.empty() ? "" : ", ") + std::string("`") + x + "`";
    return s;
  }
  return "";
}

std::string escape_md(std::string s) {
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s[i] == '|') { s.insert(i, "\\"); ++i; }
  for (auto& c : s) if (c == '\n') c = ' ';
  return s;
}
}  // namespace

std::string reference_markdown(const ParameterList& valid, int level) {
  std::ostringstream os;
  std::ostringstream table;
  bool any = false;
  for (auto it = valid.begin(); it != valid.end(); ++it) {
    const auto& name = valid.name(it);
    const auto& e = valid.entry(it);
    if (e.isList()) continue;
    if (!any) {
      table << "| parameter | type | default | allowed | description |\n|---|---|---|---|---|\n";
      any = true;
    }
    std::ostringstream def;
    def << e.getAny(false);
    table << "| `" << name << "` | " << e.getAny(false).typeName() << " | `" << def.str() << "` | "
          << escape_md(allowed(e)) << " | " << escape_md(e.docString()) << " |\n";
  }
  os << table.str();
  for (auto it = valid.begin(); it != valid.end(); ++it) {
    const auto& e = valid.entry(it);
    if (!e.isList()) continue;
    const auto& sub = valid.sublist(valid.name(it));
    os << "\n" << std::string(static_cast<std::size_t>(level), '#') << " `" << sub.name() << "`\n\n";
    if (!e.docString().empty()) os << e.docString() << "\n\n";
    os << reference_markdown(sub, level + 1);
  }
  return os.str();
}

}  // namespace granflow::params
