#include "granflow/params/parameters.hpp"

#include <Teuchos_StandardParameterEntryValidators.hpp>
#include <Teuchos_StringInputSource.hpp>

#include <algorithm>
#include <utility>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <cctype>
#include <map>
#include <set>
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

std::string str(const std::vector<double>& v) {
  std::string s;
  for (double x : v) s += (s.empty() ? "" : ", ") + str(x);
  return "{" + s + "}";
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

void fail_if_given(const ParameterList& pl, const ParameterList* user, const std::string& name,
                   const std::string& why) {
  if (!user || !user->isParameter(name)) return;
  const auto& any = user->getEntry(name).getAny(false);
  std::string value;
  if (any.type() == typeid(bool)) value = Teuchos::any_cast<bool>(any) ? "true" : "false";
  else if (any.type() == typeid(double)) value = str(Teuchos::any_cast<double>(any));
  else if (any.type() == typeid(Teuchos::Array<double>)) {
    const auto& a = Teuchos::any_cast<Teuchos::Array<double>>(any);
    value = str(std::vector<double>(a.begin(), a.end()));
  } else value = Teuchos::toString(any);
  fail(pl, name, value, why);
}

void fail_unused(const ParameterList& pl, const ParameterList* user,
                 const std::vector<std::string>& used, const std::string& selector,
                 const std::string& owner) {
  if (!user) return;
  std::vector<std::pair<std::string, std::string>> unused;  // (name, value as written)
  for (auto it = user->begin(); it != user->end(); ++it) {
    const auto& n = user->name(it);
    if (n == selector || std::find(used.begin(), used.end(), n) != used.end()) continue;
    unused.emplace_back(n, Teuchos::toString(user->entry(it).getAny(false)));
  }
  if (unused.empty()) return;
  std::string reads, also;
  for (const auto& u : used) reads += (reads.empty() ? "" : ", ") + u;
  for (std::size_t q = 1; q < unused.size(); ++q)
    also += (also.empty() ? "; also not used: '" : ", '") + path(pl, unused[q].first) + "' = " +
            unused[q].second;
  fail(pl, unused[0].first, unused[0].second,
       "not used by " + owner + " (it reads: " + (reads.empty() ? std::string("nothing") : reads) +
           ")" + also);
}

namespace {
// What a validator allows, as the reference and the messages print it: "[min, max]" for
// numbers, the values of an enum (`quoted` in Markdown), "each entry ..." for arrays.
std::string allowed(const Teuchos::RCP<const Teuchos::ParameterEntryValidator>& v, bool md) {
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
  if (auto a = Teuchos::rcp_dynamic_cast<const Teuchos::ArrayNumberValidator<double>>(v);
      !a.is_null())
    return "each entry in " + allowed(a->getPrototype(), md);
  if (auto a = Teuchos::rcp_dynamic_cast<const Teuchos::ArrayStringValidator>(v); !a.is_null())
    return "each entry one of " + allowed(a->getPrototype(), md);
  if (auto values = v->validStringValues(); !values.is_null()) {
    std::string s;
    for (const auto& x : *values)
      s += (s.empty() ? "" : ", ") + (md ? "`" + x + "`" : x);
    return s;
  }
  return "";
}
std::string allowed(const Teuchos::ParameterEntry& e) { return allowed(e.validator(), true); }

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
    if (e.isType<Teuchos::Array<double>>()) {  // as written in a scene, not 17 digits
      def << str(Teuchos::getValue<Teuchos::Array<double>>(e).toVector());
    } else if (e.isType<bool>()) {  // as a scene writes it: 1 and 0 are refused there
      def << (Teuchos::getValue<bool>(e) ? "true" : "false");
    } else {
      def << e.getAny(false);
    }
    table << "| `" << name << "` | " << e.getAny(false).typeName() << " | `" << def.str() << "` | "
          << escape_md(allowed(e)) << " | " << escape_md(e.docString()) << " |\n";
  }
  os << table.str();
  for (auto it = valid.begin(); it != valid.end(); ++it) {
    const auto& e = valid.entry(it);
    if (!e.isList()) continue;
    const auto& sub = valid.sublist(valid.name(it));
    // its path as a scene writes it: a list set under another key keeps its own name (N-DAM->
    // Pressure Newton holds the NonlinearSystem list "Nonlinear solver"), so the key is used
    const std::string key = valid.name(it), own = sub.name();
    const bool named_by_key = own == key || (own.size() > key.size() + 2 &&
                                             own.compare(own.size() - key.size() - 2,
                                                         std::string::npos, "->" + key) == 0);
    const std::string heading =
        named_by_key ? own : (valid.name().empty() ? key : valid.name() + "->" + key);
    os << "\n" << std::string(static_cast<std::size_t>(level), '#') << " `" << heading << "`\n\n";
    if (!e.docString().empty()) os << e.docString() << "\n\n";
    os << reference_markdown(sub, level + 1);
  }
  return os.str();
}


// ---------------------------------------------------------------------------------------------
// Strict values
// ---------------------------------------------------------------------------------------------
namespace {
std::string trim(const std::string& s) {
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; };
  std::size_t a = 0, b = s.size();
  while (a < b && blank(s[a])) ++a;
  while (b > a && blank(s[b - 1])) --b;
  return s.substr(a, b - a);
}
bool digit(char c) { return c >= '0' && c <= '9'; }

// Length of the UTF-8 sequence starting at s[i] (0 if it is not one; overlong forms, surrogates
// and code points above U+10FFFF are not).
std::size_t utf8_length(const std::string& s, std::size_t i) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned c = b(i);
  if (c < 0x80) return 1;
  std::size_t n = 0;
  unsigned cp = 0;
  if (c >= 0xC2 && c <= 0xDF) n = 2, cp = c & 0x1Fu;
  else if (c >= 0xE0 && c <= 0xEF) n = 3, cp = c & 0x0Fu;
  else if (c >= 0xF0 && c <= 0xF4) n = 4, cp = c & 0x07u;
  else return 0;
  if (i + n > s.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    if ((b(i + k) & 0xC0u) != 0x80u) return 0;
    cp = (cp << 6) | (b(i + k) & 0x3Fu);
  }
  if ((n == 3 && cp < 0x800) || (n == 4 && cp < 0x10000) || cp > 0x10FFFF ||
      (cp >= 0xD800 && cp <= 0xDFFF))
    return 0;
  return n;
}
bool control(unsigned char c) { return (c < 0x20 && c != '\t' && c != '\n' && c != '\r') || c == 0x7F; }
}  // namespace

bool parse_double(const std::string& text, double& value, std::string& why) {
  const std::string t = trim(text);
  // Decimal notation only: [+-] (digits [. [digits]] | . digits) [(e|E) [+-] digits]. strtod
  // alone would also take "0x10", "nan", "inf" and stop quietly at "50abc".
  std::size_t i = 0, n = t.size();
  if (i < n && (t[i] == '+' || t[i] == '-')) ++i;
  std::size_t mantissa = 0;
  while (i < n && digit(t[i])) ++i, ++mantissa;
  if (i < n && t[i] == '.') {
    ++i;
    while (i < n && digit(t[i])) ++i, ++mantissa;
  }
  bool ok = mantissa > 0;
  if (ok && i < n && (t[i] == 'e' || t[i] == 'E')) {
    ++i;
    if (i < n && (t[i] == '+' || t[i] == '-')) ++i;
    std::size_t e = 0;
    while (i < n && digit(t[i])) ++i, ++e;
    ok = e > 0;
  }
  if (!ok || i != n) {
    why = t.empty() ? "empty, not a number" : "not a decimal number (the whole text must be one "
                                               "number such as 0.25 or 1e-3; blanks around it are ignored)";
    return false;
  }
  errno = 0;
  const double v = std::strtod(t.c_str(), nullptr);
  if (errno == ERANGE || !std::isfinite(v)) {
    why = std::fabs(v) > 1.0 ? "too large for a double (|x| > 1.8e308)"
                             : "too small for a double (0 < |x| < 2.2e-308 would be rounded)";
    return false;
  }
  value = v;
  return true;
}

bool parse_int(const std::string& text, int& value, std::string& why) {
  const std::string t = trim(text);
  std::size_t i = 0;
  if (i < t.size() && (t[i] == '+' || t[i] == '-')) ++i;
  const std::size_t d0 = i;
  while (i < t.size() && digit(t[i])) ++i;
  if (i == d0 || i != t.size()) {
    double d;
    std::string ignored;
    why = t.empty() ? "empty, not an integer"
          : parse_double(t, d, ignored)
              ? "not an integer (no fraction or exponent: write the whole number, e.g. 400)"
              : "not an integer (the whole text must be one whole number such as 400; blanks "
                "around it are ignored)";
    return false;
  }
  errno = 0;
  const long long v = std::strtoll(t.c_str(), nullptr, 10);
  if (errno == ERANGE || v < INT_MIN || v > INT_MAX) {
    why = "outside the range of an int [" + std::to_string(INT_MIN) + ", " +
          std::to_string(INT_MAX) + "]";
    return false;
  }
  value = static_cast<int>(v);
  return true;
}

bool parse_bool(const std::string& text, bool& value, std::string& why) {
  const std::string t = trim(text);
  if (t == "true" || t == "false") {
    value = t == "true";
    return true;
  }
  why = "not a bool";
  return false;
}

bool check_text(const std::string& text, std::string& why) {
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t n = utf8_length(text, i);
    if (n == 0) {
      std::ostringstream os;
      os << "not valid UTF-8 text (byte 0x" << std::hex
         << static_cast<unsigned>(static_cast<unsigned char>(text[i])) << std::dec
         << " at position " << i + 1 << ")";
      why = os.str();
      return false;
    }
    if (n == 1 && control(static_cast<unsigned char>(text[i]))) {
      why = "contains a control character (byte " + std::to_string(static_cast<unsigned char>(text[i])) +
            " at position " + std::to_string(i + 1) + ")";
      return false;
    }
    i += n;
  }
  return true;
}

std::string shown(const std::string& text) {
  std::string out = "\"";
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t n = utf8_length(text, i);
    const auto c = static_cast<unsigned char>(text[i]);
    if (n == 0 || (n == 1 && control(c))) {
      static const char* hex = "0123456789abcdef";
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
      ++i;
    } else {
      out.append(text, i, n);
      i += n;
    }
  }
  // a value is shown in full unless it is very long (a fuzzed or pasted one)
  if (out.size() > 201) out = out.substr(0, 200) + "...";
  return out + "\"";
}

// ---------------------------------------------------------------------------------------------
// Scene files
// ---------------------------------------------------------------------------------------------
namespace {
std::size_t line_of(const std::string& text, std::size_t pos) {
  return 1 + static_cast<std::size_t>(
                 std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(pos), '\n'));
}

// Depth of the element nesting, from the raw text (comments, CDATA, declarations and quoted
// attribute values skipped). The XML parser builds the tree without recursion, but Teuchos
// copies nested lists recursively, so a deep file must be refused before either sees it.
void check_nesting(const std::string& text, const std::string& file) {
  int depth = 0, elements = 0;
  std::size_t i = 0;
  const auto skip_to = [&](const char* end, std::size_t from) {
    const auto e = text.find(end, from);
    return e == std::string::npos ? text.size() : e + std::char_traits<char>::length(end);
  };
  while ((i = text.find('<', i)) != std::string::npos) {
    if (text.compare(i, 4, "<!--") == 0) { i = skip_to("-->", i + 4); continue; }
    if (text.compare(i, 9, "<![CDATA[") == 0) { i = skip_to("]]>", i + 9); continue; }
    if (text.compare(i, 2, "<?") == 0) { i = skip_to("?>", i + 2); continue; }
    if (text.compare(i, 2, "<!") == 0 || text.compare(i, 2, "</") == 0) {
      if (text[i + 1] == '/') --depth;
      i = skip_to(">", i + 2);
      continue;
    }
    std::size_t j = i + 1;
    char quote = 0;
    for (; j < text.size(); ++j) {
      const char c = text[j];
      if (quote) { if (c == quote) quote = 0; }
      else if (c == '"' || c == '\'') quote = c;
      else if (c == '>') break;
    }
    if (j >= text.size()) return;  // an unterminated tag: the parser reports it with its line
    ++elements;
    if (text[j - 1] != '/' && ++depth > kMaxNesting)
      throw InputError("scene file '" + file + "' line " + std::to_string(line_of(text, i)) +
                       ": lists are nested more than " + std::to_string(kMaxNesting) +
                       " levels deep; allowed: at most " + std::to_string(kMaxNesting) +
                       " (a scene needs 5)");
    i = j + 1;
  }
  if (elements == 0)
    throw InputError("scene file '" + file + "' line " + std::to_string(line_of(text, text.size())) +
                     ": holds no XML element (empty, or only comments); allowed: "
                     "<ParameterList name=\"granflow\"> ... </ParameterList>");
}

// Does Teuchos validate the names inside this valid list? Not when it was declared as a
// pass-through list (disableRecursiveValidation(), e.g. MueLu's parameters), and the flag has
// no getter: ask Teuchos with an unknown name in a one-entry probe.
bool validates_names(const ParameterList& valid_sub) {
  ParameterList valid_parent("probe"), user_parent("probe");
  valid_parent.set("list", valid_sub);
  user_parent.sublist("list").set("granflow probe: not a parameter", 0);
  try {
    user_parent.validateParameters(valid_parent);
  } catch (const Teuchos::Exceptions::InvalidParameterName&) {
    return true;
  } catch (const std::exception&) {
    return true;
  }
  return false;
}

const char* const kTypes = "int, double, bool, string, Array(int), Array(double), Array(string)";

// What a value of this type (and validator) may be, for messages.
std::string describe(const std::string& type, const Teuchos::ParameterEntry* valid) {
  const std::string range = valid ? allowed(valid->validator(), false) : "";
  if (type == "double") return "a decimal number" + (range.empty() ? "" : " in " + range);
  if (type == "int") return "an integer" + (range.empty() ? "" : " in " + range);
  if (type == "bool") return "true or false";
  if (type == "string") return range.empty() ? "UTF-8 text" : "one of " + range;
  if (type.rfind("Array(", 0) == 0)
    return "{a, b, ...}: " + type.substr(6, type.size() - 7) + " entries separated by commas" +
           (range.empty() ? "" : ", " + range);
  return type;
}

bool split_array(const std::string& text, std::vector<std::string>& items, std::string& why) {
  const std::string t = trim(text);
  if (t.size() < 2 || t.front() != '{' || t.back() != '}') {
    why = "not an array (write {a, b, c})";
    return false;
  }
  items.clear();
  const std::string inner = t.substr(1, t.size() - 2);
  if (trim(inner).empty()) return true;
  std::size_t a = 0;
  while (true) {
    const std::size_t b = inner.find(',', a);
    items.push_back(trim(inner.substr(a, b == std::string::npos ? std::string::npos : b - a)));
    if (items.back().empty()) {
      why = "entry " + std::to_string(items.size()) + " is empty";
      return false;
    }
    if (b == std::string::npos) break;
    a = b + 1;
  }
  return true;
}

// The entry of type `type` holding `text`, strictly converted; false (and why) otherwise.
// `supported` is set false for a type this reader does not convert.
// An array's validator says only that some entry is not allowed: each entry is checked here with
// the array validator's prototype (the validator of one entry) to say which.
bool make_entry(const std::string& type, const std::string& text, Teuchos::ParameterEntry& e,
                std::string& why, bool& supported,
                const Teuchos::RCP<const Teuchos::ParameterEntryValidator>& validator) {
  supported = true;
  if (type == "double") {
    double v;
    if (!parse_double(text, v, why)) return false;
    e.setValue(v);
  } else if (type == "int") {
    int v;
    if (!parse_int(text, v, why)) return false;
    e.setValue(v);
  } else if (type == "bool") {
    bool v;
    if (!parse_bool(text, v, why)) return false;
    e.setValue(v);
  } else if (type == "string") {
    if (!check_text(text, why)) return false;
    e.setValue(text);
  } else if (type == "Array(double)" || type == "Array(int)" || type == "Array(string)") {
    std::vector<std::string> items;
    if (!check_text(text, why) || !split_array(text, items, why)) return false;
    const auto entry_failed = [&](std::size_t k, const std::string& w) {
      why = "entry " + std::to_string(k + 1) + " (" + shown(items[k]) + ") is " + w +
            (items[k].find_first_of(" \t") != std::string::npos
                 ? " (entries are separated by commas)"
                 : "");
      return false;
    };
    Teuchos::RCP<const Teuchos::ParameterEntryValidator> one;  // validator of one entry
    if (auto a = Teuchos::rcp_dynamic_cast<const Teuchos::ArrayNumberValidator<double>>(validator);
        !a.is_null())
      one = a->getPrototype();
    if (auto a = Teuchos::rcp_dynamic_cast<const Teuchos::ArrayStringValidator>(validator);
        !a.is_null())
      one = a->getPrototype();
    const auto entry_allowed = [&](std::size_t k, const Teuchos::ParameterEntry& x) {
      if (one.is_null()) return true;
      try {
        one->validate(x, "entry", "array");
      } catch (const std::exception&) {
        entry_failed(k, x.isType<std::string>() ? "not an allowed value" : "out of range");
        return false;
      }
      return true;
    };
    if (type == "Array(double)") {
      Teuchos::Array<double> a;
      for (std::size_t k = 0; k < items.size(); ++k) {
        double v;
        if (!parse_double(items[k], v, why)) return entry_failed(k, why);
        if (!entry_allowed(k, Teuchos::ParameterEntry(v))) return false;
        a.push_back(v);
      }
      e.setValue(a);
    } else if (type == "Array(int)") {
      Teuchos::Array<int> a;
      for (std::size_t k = 0; k < items.size(); ++k) {
        int v;
        if (!parse_int(items[k], v, why)) return entry_failed(k, why);
        a.push_back(v);
      }
      e.setValue(a);
    } else {
      for (std::size_t k = 0; k < items.size(); ++k)
        if (!entry_allowed(k, Teuchos::ParameterEntry(items[k]))) return false;
      Teuchos::Array<std::string> a(items.begin(), items.end());
      e.setValue(a);
    }
  } else {
    supported = false;
    why = "type " + shown(type) + " is not read by granflow";
    return false;
  }
  return true;
}

// The text without the white space at its ends.
std::string trimmed(const std::string& s) {
  const auto a = s.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t\r\n") - a + 1);
}

struct Reader {
  const std::string& file;

  [[noreturn]] void fail(const std::string& where, const std::string& what) const {
    throw InputError(file + ": " + where + ": " + what);
  }
  static std::string param(const std::string& p) { return "parameter '" + p + "'"; }

  std::string valid_names(const ParameterList& valid) const {
    std::string params, lists;
    for (auto it = valid.begin(); it != valid.end(); ++it) {
      auto& s = valid.entry(it).isList() ? lists : params;
      s += (s.empty() ? "" : ", ") + valid.name(it);
    }
    std::string out;
    if (!params.empty()) out += "parameters " + params;
    if (!lists.empty()) out += (out.empty() ? "lists " : "; lists ") + lists;
    return out.empty() ? "none" : out;
  }

  // Attributes other than those Teuchos reads would be ignored silently (a second value
  // written as vlaue="45", say). XMLObject lists no attributes, but its header holds them all,
  // sorted by name, as <Tag a="raw value" b="raw value">; the value of a known attribute is
  // skipped by its length (it may contain a quote), so the first unknown one is found.
  void check_attributes(const Teuchos::XMLObject& x, const std::string& where) const {
    static const std::set<std::string> parameter{"name", "type", "value", "docString",
                                                 "isDefault", "isUsed", "id"};
    static const std::set<std::string> list{"name", "id"};
    const auto& known = x.getTag() == "Parameter" ? parameter : list;
    const std::string h = x.header();
    std::size_t i = 1 + x.getTag().size();
    while (i < h.size() && h[i] == ' ') {
      const std::size_t eq = h.find("=\"", i + 1);
      if (eq == std::string::npos) return;
      const std::string a = h.substr(i + 1, eq - i - 1);
      if (!known.count(a) || !x.hasAttribute(a)) {
        std::string allowed;
        for (const auto& k : known) allowed += (allowed.empty() ? "" : ", ") + k;
        fail(where, "attribute " + shown(a) + " of <" + x.getTag() +
                        "> is not read by granflow; allowed: " + allowed);
      }
      i = eq + 2 + x.getAttribute(a).size() + 1;  // past the closing quote
    }
  }

  void read_list(const Teuchos::XMLObject& x, const std::string& path, ParameterList& out,
                 const ParameterList* valid, bool names_checked) const {
    // Text inside a list is no parameter, and Teuchos drops it: a value written as the
    // element's text (<ParameterList name="Time"> 2.0 </ParameterList>, or a stray word) was
    // ignored silently and the scene called valid.
    for (int l = 0; l < x.numContentLines(); ++l)
      if (const std::string t = trimmed(x.getContentLine(l)); !t.empty())
        fail("list '" + path + "'", "text " + shown(t) +
                                        " between its elements; allowed: only <Parameter> and "
                                        "<ParameterList> elements (and comments)");
    std::map<std::string, std::string> seen;  // name -> text of its first value
    for (int c = 0; c < x.numChildren(); ++c) {
      const auto& child = x.getChild(c);
      const std::string& tag = child.getTag();
      if (tag != "Parameter" && tag != "ParameterList")
        fail("list '" + path + "'", "element <" + tag +
                                        "> is not allowed here; allowed: <Parameter> and "
                                        "<ParameterList>");
      if (!child.hasAttribute("name")) {
        std::string seen_attrs;  // what there is of the element, to find it in the file
        for (const char* a : {"type", "value"})
          if (child.hasAttribute(a)) seen_attrs += std::string(" ") + a + "=" + shown(child.getAttribute(a));
        fail("list '" + path + "'", "element " + std::to_string(c + 1) + ", <" + tag +
                                        seen_attrs + ">, has no name; allowed: name=\"...\"");
      }
      const std::string& name = child.getAttribute("name");
      const std::string p = path + "->" + name;
      std::string why;
      check_attributes(child, param(p));
      if (tag == "Parameter")
        for (int l = 0; l < child.numContentLines(); ++l)
          if (const std::string t = trimmed(child.getContentLine(l)); !t.empty())
            fail(param(p), "text " + shown(t) +
                               " inside the element; allowed: the value in value=\"...\" and "
                               "nothing between <Parameter ...> and </Parameter>");
      if (!check_text(name, why)) fail(param(path + "->" + shown(name)), "the name is " + why);
      const std::string text_here =
          tag == "Parameter" && child.hasAttribute("value") ? child.getAttribute("value") : "";
      if (const auto [it, fresh] = seen.emplace(name, text_here); !fresh)
        fail(param(p) + (tag == "Parameter" ? " = " + shown(text_here) : ""),
             "given twice in list '" + path + "'" +
                 (tag == "Parameter" ? " (first = " + shown(it->second) + ")" : "") +
                 "; allowed: once");
      const Teuchos::ParameterEntry* ve = valid ? valid->getEntryPtr(name) : nullptr;
      if (valid && names_checked && !ve)
        fail(param(p), std::string(tag == "Parameter" ? "unknown parameter" : "unknown list") +
                           " (misspelt, or not used by this model); valid in '" + path +
                           "': " + valid_names(*valid));
      if (tag == "ParameterList") {
        if (ve && !ve->isList())
          fail(param(p), "is a parameter of type " + ve->getAny(false).typeName() +
                             ", given as a list; allowed: <Parameter name=\"" + name +
                             "\" type=\"" + ve->getAny(false).typeName() + "\" value=\"...\"/>");
        const ParameterList* vsub = ve ? &Teuchos::getValue<ParameterList>(*ve) : nullptr;
        read_list(child, p, out.sublist(name), vsub, vsub && validates_names(*vsub));
        continue;
      }
      if (ve && ve->isList())
        fail(param(p), "is a list, given as a parameter; allowed: <ParameterList name=\"" + name +
                           "\">...</ParameterList>");
      if (!child.hasAttribute("type"))
        fail(param(p), "has no type; allowed: type=\"" +
                           (ve ? ve->getAny(false).typeName() : std::string("...")) + "\"");
      if (!child.hasAttribute("value")) fail(param(p), "has no value; allowed: value=\"...\"");
      const std::string& type = child.getAttribute("type");
      const std::string& text = child.getAttribute("value");
      const std::string entered = param(p) + " = " + shown(text);
      if (ve) {
        const std::string want = ve->getAny(false).typeName();
        if (type != want)
          fail(entered, "given as type " + shown(type) + "; allowed: type \"" + want + "\" (" +
                            describe(want, ve) + ")");
      }
      Teuchos::ParameterEntry e;
      bool supported = true;
      if (!make_entry(type, text, e, why, supported,
                      ve ? ve->validator() : Teuchos::RCP<const Teuchos::ParameterEntryValidator>()))
        fail(entered, why + "; allowed: " +
                          (supported ? describe(type, ve) : std::string("one of ") + kTypes));
      // A line break (&#10; or &#13; in the XML) in a name, path or choice breaks the log lines
      // and file names it goes into (a hostile-user run named a scene "a&#10;b"); only the free
      // text of 'Description' may span lines.
      if (type == "string" && name != "Description") {
        const std::size_t nl = text.find_first_of("\n\r");
        if (nl != std::string::npos)
          fail(entered, "contains a line break (at position " + std::to_string(nl + 1) +
                            "); allowed: one line of text (only 'Description' may span lines)");
      }
      if (ve && !ve->validator().is_null()) {
        try {
          ve->validator()->validate(e, name, path);
        } catch (const std::exception&) {
          const bool number = type == "double" || type == "int";
          // numbers are read with blanks around them, names are not: say so where it is the
          // cause ("Minmod " looked like an allowed value; an independent run)
          const bool blanks =
              type == "string" && !text.empty() &&
              (std::isspace(static_cast<unsigned char>(text.front())) ||
               std::isspace(static_cast<unsigned char>(text.back())));
          fail(entered, std::string(number ? "out of range" : type == "string"
                                                                  ? "not an allowed value"
                                                                  : "an entry is not allowed") +
                            (blanks ? " (the blanks around it count; write it without them)"
                                    : "") +
                            "; allowed: " + describe(type, ve));
        }
      }
      out.setEntry(name, e);
    }
  }
};
}  // namespace

namespace {
// Numeric character references as XML 1.0 has them, for Teuchos' reader: it turns &#233; into
// the single byte 0xE9 (Latin-1, then not UTF-8 text) and refuses hex references with letters
// (&#xE9;) and code points above 255 (a hostile-user run: a Name written with entities). A
// reference to a character above U+007F becomes its UTF-8 bytes (never markup), one to an ASCII
// character in hex its decimal form (&#x41; -> &#65;, which Teuchos reads; &#x3C; stays a
// reference to '<'). References to characters XML does not allow (0, surrogates, U+FFFE/FFFF,
// beyond U+10FFFF) are left for the reader to refuse.
std::string expand_character_references(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  std::size_t i = 0;
  while (i < text.size()) {
    const std::size_t amp = text.find("&#", i);
    if (amp == std::string::npos) break;
    out.append(text, i, amp - i);
    i = amp;
    const bool hex = amp + 2 < text.size() && text[amp + 2] == 'x';
    std::size_t j = amp + (hex ? 3 : 2);
    unsigned long cp = 0;
    bool ok = j < text.size();
    const std::size_t first = j;
    for (; j < text.size() && text[j] != ';'; ++j) {
      const char c = text[j];
      int d = -1;
      if (c >= '0' && c <= '9') d = c - '0';
      else if (hex && c >= 'a' && c <= 'f') d = c - 'a' + 10;
      else if (hex && c >= 'A' && c <= 'F') d = c - 'A' + 10;
      if (d < 0 || j - first > 8) {
        ok = false;
        break;
      }
      cp = cp * (hex ? 16 : 10) + static_cast<unsigned long>(d);
    }
    ok = ok && j < text.size() && text[j] == ';' && j > first;
    const bool allowed = cp == 0x9 || cp == 0xA || cp == 0xD || (cp >= 0x20 && cp <= 0xD7FF) ||
                         (cp >= 0xE000 && cp <= 0xFFFD) || (cp >= 0x10000 && cp <= 0x10FFFF);
    if (!ok || !allowed || (cp < 0x80 && !hex)) {  // left as it is
      out += text[i];
      ++i;
      continue;
    }
    if (cp < 0x80) {
      out += "&#" + std::to_string(cp) + ";";
    } else if (cp < 0x800) {
      out += static_cast<char>(0xC0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
      out += static_cast<char>(0xE0 | (cp >> 12));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (cp >> 18));
      out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    }
    i = j + 1;
  }
  out.append(text, i, std::string::npos);
  return out;
}
}  // namespace

XmlDocument parse_xml(const std::string& file) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec))
    throw InputError("scene file '" + file + "' is a directory; allowed: a ParameterList XML file");
  // A device or a pipe (/dev/zero, a FIFO) would be read without end: only regular files, of a
  // size a scene can have (a hostile-user run: /dev/zero grew the process by 150 MB a second).
  constexpr std::uintmax_t kMaxSceneBytes = 64u << 20;
  if (std::filesystem::exists(file, ec) && !std::filesystem::is_regular_file(file, ec))
    throw InputError("scene file '" + file + "' is not a regular file (a device, pipe or "
                     "socket); allowed: a ParameterList XML file");
  if (const auto n = std::filesystem::file_size(file, ec); !ec && n > kMaxSceneBytes)
    throw InputError("scene file '" + file + "' has " + std::to_string(n) +
                     " bytes; allowed: a ParameterList XML file of at most 64 MiB");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError("cannot open scene file '" + file + "' (no such file or not readable)");
  std::ostringstream buf;
  buf << in.rdbuf();
  std::string raw = buf.str();
  // A UTF-8 byte-order mark (editors on Windows write one) is no character of the document;
  // Teuchos' reader took it for text outside the top element.
  if (raw.compare(0, 3, "\xEF\xBB\xBF") == 0) raw.erase(0, 3);
  const std::string text = expand_character_references(raw);
  check_nesting(text, file);
  XmlDocument doc{file, Teuchos::XMLObject()};
  try {
    doc.root = Teuchos::StringInputSource(text).getObject();
  } catch (const std::exception& e) {
    throw InputError("scene file '" + file + "' is not well-formed XML:\n" + trim_teuchos(e.what()));
  }
  if (doc.root.isEmpty() || doc.root.getTag() != "ParameterList")
    throw InputError("scene file '" + file + "' is not a ParameterList XML file: its top element "
                     "is " + (doc.root.isEmpty() ? std::string("missing") : "<" + doc.root.getTag() + ">") +
                     "; allowed: <ParameterList name=\"granflow\">");
  // Another program's parameter list (a MueLu or Belos file given by mistake) names its root
  // list after itself; read as a scene, its messages would say granflow->... of a list that is
  // not. A root without a name is Teuchos' own default and is read as granflow's.
  if (doc.root.hasAttribute("name") && doc.root.getAttribute("name") != "granflow")
    throw InputError("scene file '" + file + "': its top ParameterList is named " +
                     shown(doc.root.getAttribute("name")) +
                     "; allowed: <ParameterList name=\"granflow\"> (a granflow scene)");
  return doc;
}

RCP<ParameterList> to_parameter_list(const XmlDocument& doc, const ParameterList* valid) {
  auto pl = Teuchos::rcp(new ParameterList("granflow"));
  Reader{doc.file}.read_list(doc.root, "granflow", *pl, valid, valid != nullptr);
  name_sublists(*pl);
  return pl;
}

RCP<ParameterList> read_xml(const std::string& file) {
  return to_parameter_list(parse_xml(file), nullptr);
}

}  // namespace granflow::params
