#include "granflow/core/run_record.hpp"

#include "granflow/core/channel.hpp"
#include "granflow/io/output.hpp"
#include "granflow/params/parameters.hpp"

#include <Teuchos_Array.hpp>
#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace granflow::core {

namespace fs = std::filesystem;

namespace {
std::string exact(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string quote_text(const std::string& s) {
  std::string q = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') q += '\\', q += c;
    else if (c == '\n') q += "\\n";
    else q += c;
  }
  return q + "\"";
}

template <class T, class F>
std::string array_text(const Teuchos::Array<T>& a, F f) {
  std::string s = "{";
  for (decltype(a.size()) i = 0; i < a.size(); ++i) s += (i ? ", " : "") + f(a[i]);
  return s + "}";
}

void walk(const Teuchos::ParameterList& pl, const std::string& prefix,
          std::vector<std::string>& out) {
  for (auto it = pl.begin(); it != pl.end(); ++it) {
    const std::string& name = pl.name(it);
    const auto& e = pl.entry(it);
    const std::string path = prefix.empty() ? name : prefix + "->" + name;
    if (e.isList()) {
      walk(pl.sublist(name), path, out);
      continue;
    }
    std::string type, value;
    if (e.isType<double>()) {
      type = "double", value = exact(e.getValue<double>(nullptr));
    } else if (e.isType<int>()) {
      type = "int", value = std::to_string(e.getValue<int>(nullptr));
    } else if (e.isType<bool>()) {
      type = "bool", value = e.getValue<bool>(nullptr) ? "true" : "false";
    } else if (e.isType<std::string>()) {
      type = "string", value = quote_text(e.getValue<std::string>(nullptr));
    } else if (e.isType<Teuchos::Array<double>>()) {
      type = "Array(double)",
      value = array_text(e.getValue<Teuchos::Array<double>>(nullptr), exact);
    } else if (e.isType<Teuchos::Array<int>>()) {
      type = "Array(int)",
      value = array_text(e.getValue<Teuchos::Array<int>>(nullptr),
                         [](int v) { return std::to_string(v); });
    } else if (e.isType<Teuchos::Array<std::string>>()) {
      type = "Array(string)",
      value = array_text(e.getValue<Teuchos::Array<std::string>>(nullptr), quote_text);
    } else {
      type = e.getAny(false).typeName(), value = Teuchos::toString(e.getAny(false));
    }
    out.push_back(path + " (" + type + ") = " + value);
  }
}

// "path (type) = value" -> path, "(type) = value"
std::pair<std::string, std::string> split(const std::string& line) {
  const auto open = line.find(" (");
  const auto eq = line.find(") = ", open == std::string::npos ? 0 : open);
  if (open == std::string::npos || eq == std::string::npos) return {line, ""};
  return {line.substr(0, open), line.substr(open + 1)};
}

std::string exact_value(const std::string& typed) {
  const auto eq = typed.find(") = ");
  return eq == std::string::npos ? typed : typed.substr(eq + 4);
}

// For messages: "(double) = 0.14999999999999999" -> "0.15" (10 significant digits, as users
// write numbers; the comparison itself uses the exact text).
std::string value_of(const std::string& typed) {
  const auto eq = typed.find(") = ");
  if (eq == std::string::npos) return typed;
  const std::string v = typed.substr(eq + 4);
  const bool scalar = typed.rfind("(double)", 0) == 0,
             array = typed.rfind("(Array(double))", 0) == 0;
  if (!scalar && !array) return v;
  std::string out;
  std::size_t i = 0;
  while (i < v.size()) {  // every number in the text, shortened
    char* end = nullptr;
    const double x = std::strtod(v.c_str() + i, &end);
    const auto used = static_cast<std::size_t>(end - (v.c_str() + i));
    if (used > 0 && (std::isdigit(static_cast<unsigned char>(v[i])) || v[i] == '-' || v[i] == '+' ||
                     v[i] == '.')) {
      out += params::str(x);
      i += used;
    } else {
      out += v[i++];
    }
  }
  return out;
}

std::uint64_t fnv1a(const std::string& s, std::uint64_t h = 1469598103934665603ULL) {
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ULL;
  return h;
}

std::string hex64(std::uint64_t h) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}
}  // namespace

std::vector<std::string> canonical_parameters(const Teuchos::ParameterList& validated,
                                              const std::string& scene_dir) {
  std::vector<std::string> out;
  walk(validated, "", out);
  // The inflow series is part of the scene by its content, not only its name (a hostile-user
  // run restarted a checkpoint after editing the CSV, and the run went on under an inflow
  // history that contradicted its state).
  if (validated.isSublist("Channel") && validated.sublist("Channel").isSublist("Left boundary")) {
    const auto& left = validated.sublist("Channel").sublist("Left boundary");
    if (left.isType<std::string>("Inflow series file")) {
      const std::string file = left.get<std::string>("Inflow series file");
      if (!file.empty()) {
        std::ifstream in(input_path(file, scene_dir), std::ios::binary);
        std::ostringstream bytes;
        bytes << in.rdbuf();
        out.push_back("Channel->Left boundary->Inflow series file content (fnv1a) = " +
                      hex64(fnv1a(bytes.str())));
      }
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

bool restart_may_change(const std::string& path) {
  if (path == "Name" || path == "Description") return true;
  if (path.rfind("Time->", 0) == 0 || path.rfind("Output->", 0) == 0) return true;
  // Solver tolerances, iteration limits and verbosity (the leaf name, in any solver list):
  // they change how closely the same equations are solved, not which equations.
  static const std::set<std::string> solver_leaves{
      "Tolerance",          "Max iterations",        "Absolute tolerance",
      "Relative tolerance", "Krylov tolerance",      "Max Newton iterations",
      "Max Krylov iterations", "Verbose",            "verbosity"};
  const auto k = path.rfind("->");
  const std::string leaf = k == std::string::npos ? path : path.substr(k + 2);
  return k != std::string::npos && solver_leaves.count(leaf) != 0;
}

std::string scene_identity(const std::vector<std::string>& canonical) {
  std::uint64_t h = 1469598103934665603ULL;
  for (const auto& line : canonical) {
    if (restart_may_change(split(line).first)) continue;
    h = fnv1a(line + "\n", h);
  }
  return hex64(h);
}

std::vector<std::string> scene_differences(const std::vector<std::string>& theirs,
                                           const std::vector<std::string>& ours) {
  std::map<std::string, std::string> a, b;
  for (const auto& l : theirs) a.insert(split(l));
  for (const auto& l : ours) b.insert(split(l));
  std::vector<std::string> d;
  // The model first: with another model most other parameters differ too.
  auto ma = a.find("Model"), mb = b.find("Model");
  if (ma != a.end() && mb != b.end() && ma->second != mb->second)
    return {"'Model' = " + value_of(ma->second) + " there, " + value_of(mb->second) + " here"};
  for (const auto& [path, v] : b) {
    if (path == "Model" || restart_may_change(path)) continue;
    const auto it = a.find(path);
    if (it == a.end())
      d.push_back("'" + path + "' = " + value_of(v) + " here, not a parameter there");
    else if (it->second != v) {
      std::string there = value_of(it->second), here = value_of(v);
      if (there == here) there = exact_value(it->second), here = exact_value(v);  // 11th digit on
      d.push_back("'" + path + "' = " + there + " there, " + here + " here");
    }
  }
  for (const auto& [path, v] : a)
    if (!restart_may_change(path) && path != "Model" && b.find(path) == b.end())
      d.push_back("'" + path + "' = " + value_of(v) + " there, not a parameter here");
  return d;
}

namespace {
std::string join_differences(const std::vector<std::string>& d) {
  // Name the first few; a different model can differ in a hundred parameters.
  const std::size_t shown = std::min<std::size_t>(d.size(), 8);
  std::string s;
  for (std::size_t i = 0; i < shown; ++i) s += (i ? "; " : "") + d[i];
  if (d.size() > shown) s += "; and " + std::to_string(d.size() - shown) + " more";
  return s;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> v;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);)
    if (!l.empty()) v.push_back(l);
  return v;
}
}  // namespace

double check_restart(const io::Checkpoint& c, const std::string& file,
                     const std::vector<std::string>& ours, double end_time) {
  const std::string param =
      "parameter 'granflow->Output->Restart from' = " + params::shown(file) + ": ";
  if (!c.has_text(kSceneKey) || !c.has_scalar("run/time"))
    throw params::InputError(param + "the checkpoint has no scene record; allowed: a checkpoint "
                             "written by this granflow");
  const auto theirs = lines_of(c.text(kSceneKey));
  const auto d = scene_differences(theirs, ours);
  if (!d.empty())
    throw params::InputError(
        param + "the checkpoint belongs to a different scene: " + join_differences(d) +
        ". A restart may change only the Time and Output parameters, Name, Description and "
        "the solvers' tolerances, iteration limits and verbosity; run a changed scene from "
        "its start");
  const double t = c.scalar("run/time");
  if (!(end_time > t + 1e-9 * std::max(1.0, std::abs(t))))
    throw params::InputError("parameter 'granflow->Time->End time' = " + params::str(end_time) +
                             ": the checkpoint " + file + " is at t = " + params::str(t) +
                             " s; allowed: an end time after it");
  return t;
}

std::vector<ParameterChange> restart_changes(const io::Checkpoint& c,
                                             const std::vector<std::string>& ours) {
  std::map<std::string, std::string> a, b;
  if (c.has_text(kSceneKey))
    for (const auto& l : lines_of(c.text(kSceneKey))) a.insert(split(l));
  for (const auto& l : ours) b.insert(split(l));
  std::vector<ParameterChange> d;
  auto note = [&](const std::string& path) {
    if (!restart_may_change(path) || path == "Output->Restart from") return;
    const auto ia = a.find(path), ib = b.find(path);
    auto shown = [](const std::string& v) {  // a string without its quotes (JSON has its own)
      return v.size() >= 2 && v.front() == '"' && v.back() == '"' ? v.substr(1, v.size() - 2) : v;
    };
    const std::string before = ia == a.end() ? "" : shown(value_of(ia->second));
    const std::string after = ib == b.end() ? "" : shown(value_of(ib->second));
    if ((ia == a.end()) != (ib == b.end()) || (ia != a.end() && ia->second != ib->second))
      d.push_back({path, before, after});
  };
  for (const auto& [path, v] : b) note(path);
  for (const auto& [path, v] : a)
    if (b.find(path) == b.end()) note(path);
  return d;
}

const std::vector<std::string>& output_file_names() {
  static const std::vector<std::string> names{
      "run.json",      "summary.json",     "profiles.csv",  "profiles.csv.tmp", "fields.h5",
      "fields.h5.tmp", "fields.h5.d",      "fields.xdmf",   "fields.xdmf.tmp",  "checkpoint.h5",
      "checkpoint.h5.tmp", "run.json.tmp", "wall.csv",      "wall.csv.tmp",     "summary.json.tmp"};
  return names;
}

nlohmann::json parameters_json(const Teuchos::ParameterList& pl) {
  nlohmann::json j = nlohmann::json::object();
  for (auto it = pl.begin(); it != pl.end(); ++it) {
    const auto& name = pl.name(it);
    const auto& e = pl.entry(it);
    if (e.isList()) {
      j[name] = parameters_json(pl.sublist(name));
    } else if (e.isType<double>()) {
      j[name] = e.getValue<double>(nullptr);
    } else if (e.isType<int>()) {
      j[name] = e.getValue<int>(nullptr);
    } else if (e.isType<bool>()) {
      j[name] = e.getValue<bool>(nullptr);
    } else {
      j[name] = Teuchos::toString(e.getAny(false));
    }
  }
  return j;
}

namespace {
// The parameters of summary.json without the ones a restart may change (for directories of a
// granflow before run.json, whose summary.json holds parameters_json() of their scene).
void strip_changeable(nlohmann::json& j, const std::string& prefix) {
  for (auto it = j.begin(); it != j.end();) {
    const std::string path = prefix.empty() ? it.key() : prefix + "->" + it.key();
    if (restart_may_change(path)) {
      it = j.erase(it);
    } else {
      if (it->is_object()) strip_changeable(*it, path);
      ++it;
    }
  }
}

bool legacy_same_scene(const fs::path& summary, const Teuchos::ParameterList& validated) {
  try {
    std::ifstream in(summary);
    auto theirs = nlohmann::json::parse(in).at("parameters");
    auto ours = parameters_json(validated);
    strip_changeable(theirs, "");
    strip_changeable(ours, "");
    return theirs == ours;
  } catch (const std::exception&) {
    return false;
  }
}
}  // namespace

DirectoryPlan plan_directory(const std::string& dir, const std::string& ours,
                             const std::vector<std::string>& lines, bool overwrite, bool restart,
                             const std::string& keep, const Teuchos::ParameterList& validated) {
  DirectoryPlan plan;
  const std::string param =
      "parameter 'granflow->Output->Directory' = " + params::shown(dir) + ": ";
  std::error_code ec;
  if (!fs::exists(dir, ec)) return plan;
  if (!fs::is_directory(dir, ec))
    throw params::InputError(param + "exists and is not a directory; allowed: a directory "
                             "(created if missing)");
  auto kept = [&](const fs::path& p) {
    std::error_code e;
    return !keep.empty() && fs::exists(keep, e) && fs::equivalent(p, keep, e);
  };
  // A fields.h5.d that links nowhere, or into another run's snapshots (a copied run
  // directory): refused before anything is removed (a fresh run removed fields.h5 first and
  // then failed on the link).
  try {
    io::check_field_snapshots(dir);
  } catch (const std::runtime_error& e) {
    throw params::InputError(param + e.what());
  }
  // Files granflow writes that are there now.
  std::vector<std::string> present;
  for (const auto& n : output_file_names()) {
    const fs::path p = fs::path(dir) / n;
    // an empty fields.h5.d (or a link to an empty directory elsewhere) holds no output
    if (fs::exists(p, ec) && !(fs::is_directory(p, ec) && fs::is_empty(p, ec)))
      present.push_back(n);
  }
  if (present.empty()) return plan;

  RunManifest earlier;
  bool have_manifest = false;
  const fs::path mpath = fs::path(dir) / "run.json";
  if (fs::exists(mpath, ec)) {
    try {
      std::ifstream in(mpath);
      const auto j = nlohmann::json::parse(in);
      earlier.scene = j.at("scene").get<std::string>();
      earlier.identity = j.at("identity").get<std::string>();
      earlier.parameters = j.at("parameters").get<std::vector<std::string>>();
      earlier.files = j.at("files").get<std::vector<std::string>>();
      have_manifest = true;
    } catch (const std::exception&) {
      have_manifest = false;  // unreadable: treated like a directory without a record
    }
  }
  std::string files;
  for (const auto& n : present) files += (files.empty() ? "" : ", ") + n;

  plan.same_scene = have_manifest ? earlier.identity == ours
                                  : legacy_same_scene(fs::path(dir) / "summary.json", validated);
  if (!have_manifest && plan.same_scene) earlier.files = present;
  if (!plan.same_scene && !overwrite) {
    std::string why;
    if (have_manifest) {
      const auto d = scene_differences(earlier.parameters, lines);
      why = "it holds the run of a different scene ('" + earlier.scene + "'; " +
            (d.empty() ? std::string("identity ") + earlier.identity : join_differences(d)) +
            ")";
    } else {
      why = "it holds granflow output files without a run record (run.json), from an older "
            "granflow or an interrupted start";
    }
    throw params::InputError(param + why + ": " + files +
                             ". Allowed: another directory, or the option --overwrite to "
                             "replace those files");
  }
  have_manifest = have_manifest || plan.same_scene;
  // A restart continues the directory's history only when its checkpoint is that history's
  // (it lies in the directory). A restart from elsewhere into a directory that holds another
  // run of the same scene kept that run's rows up to the checkpoint time, joined to a
  // continuation of a different trajectory (a hostile-user run): its files start afresh.
  std::error_code ee;
  bool own = restart && !keep.empty() && fs::exists(dir, ee) &&
             fs::equivalent(fs::absolute(keep, ee).parent_path(), dir, ee);
  // A checkpoint lying in the directory is the directory's own unless its field output's run id
  // is none of the directory's: a checkpoint copied in from a sibling run of the scene joined
  // that run's continuation to this directory's earlier outputs (u 0.69 m/s apart at the joint;
  // an independent run).
  bool sibling = false;
  if (own && plan.same_scene) {
    std::string ck_id;
    try {
      const auto c = io::read_checkpoint(keep);
      if (c.has_text(kFieldsIdKey)) ck_id = c.text(kFieldsIdKey);
    } catch (const std::exception&) {
      ck_id.clear();  // check_restart reports a damaged checkpoint
    }
    bool any_id = false;
    if (!ck_id.empty() && !io::field_output_has_id(dir, ck_id, any_id)) {
      sibling = any_id;
      own = !sibling;
    }
  }
  if (plan.same_scene && own) {  // continued: the driver cuts back, keeps
    plan.continued = true;
    plan.earlier_files = earlier.files;
    return plan;
  }
  // A fresh run of the same scene, or --overwrite: remove the earlier run's files (the ones
  // its manifest lists and any other granflow output names), never the checkpoint we read.
  std::set<std::string> names(present.begin(), present.end());
  if (have_manifest)
    for (const auto& f : earlier.files)
      if (fs::path(f).filename() == f && fs::exists(fs::path(dir) / f, ec)) names.insert(f);
  for (const auto& n : names) {
    const fs::path p = fs::path(dir) / n;
    if (!kept(p)) plan.remove.push_back(p.string());
  }
  // A copy of the directory's own checkpoint restarted from elsewhere is that rule's case too,
  // and its history went without a word (an independent run: 4000 rows of profiles.csv).
  if (restart && plan.same_scene && !plan.remove.empty()) {
    std::string gone;
    for (const auto& p : plan.remove) gone += (gone.empty() ? "" : ", ") + fs::path(p).filename().string();
    plan.note = "the restart's checkpoint " + params::shown(keep) +
                (sibling ? " was written by another run of this scene (its field output's "
                           "run id is none of the directory's), and " +
                               params::shown(dir) + " holds this directory's own run"
                         : " lies outside " + params::shown(dir) +
                               ", which holds a run of this scene") +
                ": its files (" + gone +
                ") are replaced, not continued, since they may be another trajectory's; to "
                "continue them, restart from the checkpoint.h5 " +
                (sibling ? "that run wrote there" : "in that directory");
  }
  return plan;
}

void create_run_directories(const std::string& dir) {
  // Runs started side by side (a study, ctest -j) may share a parent that one of them has just
  // created and another's probe removes again (probe_directory's undo): create_directories then
  // finds the parent gone between its check and its mkdir (ENOENT). Try again a few times; any
  // other error, or a parent that keeps vanishing, is reported.
  for (int attempt = 0;; ++attempt) {
    try {
      fs::create_directories(dir);
      return;
    } catch (const fs::filesystem_error& e) {
      if (e.code() != std::errc::no_such_file_or_directory || attempt == 7) throw;
    }
  }
}

void probe_directory(const std::string& dir) {
  const std::string param =
      "parameter 'granflow->Output->Directory' = " + params::shown(dir) + ": ";
  std::error_code ec;
  // the part of the path that is missing now (deepest first), removed again after the probe
  std::vector<fs::path> missing;
  for (fs::path q = fs::absolute(dir, ec); !q.empty() && !fs::exists(q, ec);
       q = q.parent_path()) {
    missing.push_back(q);
    if (q == q.parent_path()) break;
  }
  auto undo = [&] {
    std::error_code e;
    for (const auto& q : missing) fs::remove(q, e);  // only what this probe created (empty)
  };
  try {
    create_run_directories(dir);
  } catch (const fs::filesystem_error& e) {
    undo();
    throw params::InputError(param + "the run cannot create it (" + e.code().message() +
                             "); allowed: a directory that can be created and written");
  }
  const int err = io::write_probe(dir);
  undo();
  if (err != 0)
    throw params::InputError(param + "the run cannot write into it (" +
                             std::error_code(err, std::generic_category()).message() +
                             "); allowed: a directory that can be created and written");
}

DirectoryLock::DirectoryLock(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;
  fd_ = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd_ < 0) return;  // unreadable: creating files there fails with its own message
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    ::close(fd_);
    fd_ = -1;
    if (e == EWOULDBLOCK)
      throw params::InputError("parameter 'granflow->Output->Directory' = " + params::shown(dir) +
                               ": another granflow run is writing into it now; allowed: a "
                               "directory no other run uses");
  }
}

DirectoryLock::~DirectoryLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the descriptor releases the flock
}

void write_manifest(const std::string& dir, const RunManifest& m) {
  nlohmann::json j;
  j["granflow_run"] = 1;
  j["scene"] = m.scene;
  j["model"] = m.model;
  j["identity"] = m.identity;
  j["status"] = m.status;
  j["files"] = m.files;
  j["parameters"] = m.parameters;
  io::write_file_atomic(dir + "/run.json",
                        j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

}  // namespace granflow::core
