// granflow-study: compare runs and derive layouts from their profiles.csv.
//
//   granflow-study compare REF_RUN TEST_RUN [--times T ...] [--h-min H] [--u-min U]
//                  [--average-length L] [--out DIR]
//       The paper's relative error r = |v_test - v_ref| / |v_ref| of h and u_mean (max and L2
//       over the flowing part) at each common output time, and the velocity averaged over
//       [0, L] against time (Fig. 14). Writes DIR/compare_errors.csv,
//       DIR/average_velocity.csv and, when python3 with matplotlib is present, DIR/compare.png.
//       Where the reference has no flowing point (or averages 0 over [0, L]) the relative
//       errors are undefined: their CSV fields stay empty and the table prints "-".
//   granflow-study layout RUN [--length L] [--threshold E] [--margin M] [--min-length S]
//                  [--h-min H]
//       A priori 2D/1D layout from a (fast, 1D) run: 2D wherever eps >= E at any output time
//       on cells deeper than H, widened by M on both sides (paper section 4.1). The defaults
//       are those of the scene's Decomposition (analysis::LayoutCriteria, and H = the wet-depth
//       cut of a DAM with the default dry depth), so the command gives the layout that
//       Decomposition->Layout = A priori builds from the same run.
//   granflow-study budget RUN [--from T0] [--to T1] [--stretch XA XB] [--dam DAM_RUN]
//                  [--cell-weights] [--out DIR]
//       The depth-averaged x-momentum budget of a full 2D (N-DAM) run from its fields.h5 and
//       profiles.csv (analysis/budget.hpp): d(h u)/dt + d(alpha h u^2)/dx against gravity, the
//       depth-integrated pressure gradient, the viscous/plastic normal stress divergence and the
//       bed friction (the Coulomb stress the model applies, and tan(delta) p_b), time-averaged
//       over the snapshots in [T0, T1]; the residual along x, and the terms summed over the
//       stretch [XA, XB] as the velocity change each gives the flow there. With --dam, the same
//       budget of a DAM run of the scene with the DAM's closure, side by side. Writes
//       DIR/budget.csv (and DIR/budget_dam.csv). --cell-weights: the column integrals over the
//       material cells whole (the column the 2D momentum equation moves) instead of the
//       markers' depth (profiles.csv's u_mean).
#include "granflow/analysis/budget.hpp"
#include "granflow/analysis/profiles.hpp"
#include "granflow/core/material.hpp"
#include "granflow/dam/dam_solver.hpp"
#include "granflow/io/output.hpp"
#include "granflow/params/parameters.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace {
using namespace granflow::analysis;

// compare: the paper's relative errors are taken over the flowing part of the reference run,
// where h > 1 mm (1/60 of the 6 cm gate opening) and |u_mean| > 1 mm/s; below that the
// relative error of u is dominated by the front position and the resting deposit.
constexpr double kFlowingDepth = 1e-3;     // [m]
constexpr double kFlowingVelocity = 1e-3;  // [m/s]
// The paper's l of the velocity average u(l) = 1/l int_0^l u_mean dx (Fig. 14: the flow near
// the silo inlet) [m].
constexpr double kAverageLength = 0.2;

int usage(std::ostream& os, int code) {
  os << "usage: granflow-study compare REF_RUN TEST_RUN [--times T ...] [--h-min H] [--u-min U]\n"
        "                      [--average-length L] [--out DIR]\n"
        "       granflow-study layout RUN [--length L] [--threshold E] [--margin M]\n"
        "                      [--min-length S] [--h-min H]\n"
        "       granflow-study budget RUN [--from T0] [--to T1] [--stretch XA XB]\n"
        "                      [--dam DAM_RUN] [--cell-weights] [--out DIR]\n"
        "RUN is a granflow output directory (it holds profiles.csv).\n";
  return code;
}

// A decimal number (as granflow reads its scene: no hex, no nan/inf) that a double holds:
// strtod reads 1e-400 as 0 and 1e999 as inf with ERANGE, numbers other than the ones written
// (a denormal such as 1e-320, also flagged ERANGE, is held and taken).
bool parse_number(const char* v, double& d) {
  char* end = nullptr;
  errno = 0;
  d = std::strtod(v, &end);
  const std::string text(v);
  const bool hex = text.find_first_of("xX") != std::string::npos;
  const bool lost = errno == ERANGE && (d == 0.0 || !std::isfinite(d));
  return end != v && *end == '\0' && std::isfinite(d) && !hex && !lost;
}

double number(const std::string& opt, const char* v) {
  double d = 0.0;
  if (!parse_number(v, d)) {
    std::cerr << "granflow-study: option " << opt << " needs a decimal number a double can "
              << "hold, got '" << v << "'\n";
    std::exit(2);
  }
  return d;
}

const ProfileAt* at_time(const std::map<double, ProfileAt>& run, double t) {
  const ProfileAt* best = nullptr;
  double dist = 1e-6;  // output times are written with 10 significant digits
  for (const auto& [ti, p] : run)
    if (std::abs(ti - t) <= dist) dist = std::abs(ti - t), best = &p;
  return best;
}

// Runs of two scenes (another slope, material, inflow or initial condition) are compared as
// asked, with a note per difference: their table measures the scenes' difference, not a
// discretisation's (an independent run compared 45 with 50 deg without a word). The models and
// grids may differ: that is what compare is for. From the runs' summary.json (none: no notes).
std::vector<std::string> scene_differences(const std::string& ref_dir, const std::string& test_dir) {
  auto params = [](const std::string& dir) {
    std::ifstream in(dir + "/summary.json");
    const auto j = in ? nlohmann::json::parse(in, nullptr, false) : nlohmann::json();
    return (!j.is_discarded() && j.is_object() && j.contains("parameters")) ? j["parameters"]
                                                                            : nlohmann::json();
  };
  std::vector<std::string> notes;
  std::function<void(const nlohmann::json&, const nlohmann::json&, const std::string&)> diff =
      [&](const nlohmann::json& a, const nlohmann::json& b, const std::string& name) {
        if (a.is_object() && b.is_object()) {
          for (const auto& [k, v] : a.items()) {
            // a series file is named by its path: the same data elsewhere is the same scene
            if (k == "Inflow series file") continue;
            if (b.contains(k)) diff(v, b[k], name + "->" + k);
            else notes.push_back(name + "->" + k + " is set in " + ref_dir + " only");
          }
          for (const auto& [k, v] : b.items())
            if (!a.contains(k) && k != "Inflow series file")
              notes.push_back(name + "->" + k + " is set in " + test_dir + " only");
          return;
        }
        if (a != b)
          notes.push_back("the runs' scenes differ in " + name + " (" + a.dump() + " against " +
                          b.dump() + ")");
      };
  const auto pr = params(ref_dir), pt = params(test_dir);
  for (const char* list : {"Channel", "Material", "Initial condition"})
    if (pr.contains(list) && pt.contains(list)) diff(pr[list], pt[list], list);
  return notes;
}

int compare_cmd(int argc, char** argv) {
  if (argc < 4) return usage(std::cerr, 1);
  const std::string ref_dir = argv[2], test_dir = argv[3];
  // 'compare RUN --times 0.25' took --times for the test run and said "unknown option '0.25'"
  // (an independent run)
  for (const std::string& d : {ref_dir, test_dir})
    if (d.rfind("--", 0) == 0) {
      std::cerr << "granflow-study: compare needs two run directories before its options "
                   "(REF_RUN TEST_RUN [--times ...]); got '" << d << "' as a run\n";
      return 1;
    }
  std::vector<double> times;
  double h_min = kFlowingDepth, u_min = kFlowingVelocity, l = kAverageLength;
  std::string out = test_dir;
  for (int i = 4; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) { std::cerr << "granflow-study: " << a << " needs a value\n"; std::exit(1); }
      return argv[++i];
    };
    if (a == "--times") {
      // the values up to the next option (a negative time is a value, refused below; it was
      // taken for an unknown option '-0.2')
      double d = 0.0;
      const std::size_t before = times.size();
      while (i + 1 < argc && (argv[i + 1][0] != '-' || parse_number(argv[i + 1], d)))
        times.push_back(number(a, argv[++i]));
      // (without a value it compared every common output time, as if --times were not given;
      // an independent run)
      if (times.size() == before) {
        std::cerr << "granflow-study: --times needs one or more output times [s]; allowed: "
                     "--times T1 [T2 ...], or leave it out to compare every common output time\n";
        return 2;
      }
    } else if (a == "--h-min") h_min = number(a, next());
    else if (a == "--u-min") u_min = number(a, next());
    else if (a == "--average-length") l = number(a, next());
    else if (a == "--out") out = next();
    else { std::cerr << "granflow-study: unknown option '" << a << "'\n"; return usage(std::cerr, 1); }
  }
  std::string ref_note, test_note;
  const auto ref = read_profiles(ref_dir + "/profiles.csv", &ref_note);
  const auto test = read_profiles(test_dir + "/profiles.csv", &test_note);
  for (const std::string& n : {ref_note, test_note})
    if (!n.empty()) std::cout << "note: " << n << "\n";
  // (printed after the channel check below, which refuses runs of two channels outright)
  const std::vector<std::string> scene_notes = scene_differences(ref_dir, test_dir);
  for (const auto* run : {&ref, &test})
    if (run->empty()) {
      std::cerr << "granflow-study: " << (run == &ref ? ref_dir : test_dir)
                << "/profiles.csv holds no complete output; nothing to compare\n";
      return 2;
    }
  // Runs of different channels have no common profile to compare (a 1 m chute against the 2 m
  // lab chute gave a table of errors and exit 0): their ends must agree to half a cell.
  // (start, end, widest end cell) of a run's channel from its profile points
  auto ends = [](const ProfileAt& p) {
    const std::size_t n = p.x.size();
    if (n < 2) return std::array<double, 3>{0.0, 0.0, 0.0};
    const double d0 = p.x[1] - p.x[0], d1 = p.x[n - 1] - p.x[n - 2];
    return std::array<double, 3>{p.x[0] - 0.5 * d0, p.x[n - 1] + 0.5 * d1, std::max(d0, d1)};
  };
  if (!ref.empty() && !test.empty()) {
    const auto er = ends(ref.begin()->second), et = ends(test.begin()->second);
    const double tol = 0.5 * std::max(er[2], et[2]);
    if (std::abs(er[0] - et[0]) > tol || std::abs(er[1] - et[1]) > tol) {
      std::cerr << "granflow-study: the runs cover different channels: " << ref_dir << " ["
                << er[0] << ", " << er[1] << "] m, " << test_dir << " [" << et[0] << ", " << et[1]
                << "] m; compare needs the same channel (its ends within half a cell)\n";
      return 2;
    }
  }
  for (const auto& n : scene_notes)
    std::cout << "note: " << n << ": the table compares two scenes, not two discretisations\n";
  // The options' ranges (an independent run: --average-length 5 on a 1 m channel divided the
  // integral over [0, 1] m by 5 m, 0 and -1 gave averages of 0 with a relative error of 0, and
  // a negative --h-min was taken).
  auto refuse = [](const std::string& opt, double v, const std::string& allowed) {
    std::cerr << "granflow-study: " << opt << " " << granflow::params::str(v) << ": allowed: "
              << allowed << "\n";
    return 2;
  };
  if (!(h_min >= 0.0)) return refuse("--h-min", h_min, "a depth >= 0 m");
  if (!(u_min >= 0.0)) return refuse("--u-min", u_min, "a speed >= 0 m/s");
  if (!ref.empty()) {
    const double x_end = ends(ref.begin()->second)[1];
    if (!(l > 0.0) || l > x_end * (1.0 + 1e-9))
      return refuse("--average-length", l,
                    "a length in (0, " + granflow::params::str(x_end) + "] m (the channel)");
  }
  for (double t : times)
    if (!(t >= 0.0)) return refuse("--times", t, "output times >= 0 s");
  if (times.empty()) {
    for (const auto& [t, p] : ref)
      if (at_time(test, t)) times.push_back(t);
    if (times.empty()) {
      std::cerr << "granflow-study: the runs have no output time in common; nothing to compare\n";
      return 2;
    }
  }
  // every time before any file is written (a refused time left header-only CSVs behind)
  for (double t : times)
    if (!at_time(ref, t) || !at_time(test, t)) {
      std::cerr << "granflow-study: time " << t << " s is not an output time of both runs\n";
      return 2;
    }
  std::filesystem::create_directories(out);
  std::ofstream ce(out + "/compare_errors.csv"), av(out + "/average_velocity.csv");
  ce << "t,quantity,max_rel,l2_rel,points\n" << std::setprecision(8);
  av << "t,u_avg_ref,u_avg_test,rel_error\n" << std::setprecision(8);
  // A run that stopped before its end time has outputs up to the stop only; the table says so
  // (an independent run: a test run stopped by exit 3 at 0.74 s gave a table ending at 0.7 s
  // without a word).
  for (const std::string& dir : {ref_dir, test_dir}) {
    std::ifstream in(dir + "/summary.json");
    if (!in) {  // no summary: a run still running (run.json says so), or one killed
      std::ifstream rj(dir + "/run.json");
      const auto r = rj ? nlohmann::json::parse(rj, nullptr, false) : nlohmann::json();
      if (!r.is_discarded() && r.is_object() && r.value("status", std::string()) == "running")
        std::cout << "note: " << dir << ": run.json says the run is still running (or was "
                     "killed); its complete outputs so far are compared\n";
      continue;
    }
    const auto sj = nlohmann::json::parse(in, nullptr, false);
    if (sj.is_discarded() || sj.value("status", std::string("completed")) == "completed") continue;
    std::cout << "note: " << dir << " " << sj.value("status", std::string("?")) << " at t = "
              << sj.value("final_time", 0.0) << " s (" << sj.value("reason", std::string())
              << "): it has no outputs after that\n";
  }
  std::cout << "reference " << ref_dir << ", test " << test_dir << " (flowing: h > " << h_min
            << " m, |u| > " << u_min << " m/s)\n"
            << "     t [s] |  h max rel |   h L2 rel |  u max rel |   u L2 rel | pts | u(" << l
            << ") rel\n";
  for (double t : times) {
    const ProfileAt* r = at_time(ref, t);  // both exist: checked above
    const ProfileAt* s = at_time(test, t);
    const auto e = compare(*r, *s, h_min, u_min);
    const double ar = average_velocity(*r, l), as = average_velocity(*s, l);
    // No flowing point of the reference (e.g. t = 0, or --h-min above every depth): the
    // relative errors are undefined, not 0; the CSV leaves them empty and the table prints "-".
    // The same for the averaged velocity where the reference's average is 0.
    auto shown = [](bool defined, double v, int precision, const char* undefined) {
      std::ostringstream os;
      os << std::setprecision(precision);
      if (defined) os << v;
      else os << undefined;
      return os.str();
    };
    const bool flowing = e.h.points > 0, averaged = ar != 0.0;
    const double ra = averaged ? std::abs(as - ar) / std::abs(ar) : 0.0;
    ce << t << ",h," << shown(flowing, e.h.max_rel, 8, "") << ','
       << shown(flowing, e.h.l2_rel, 8, "") << ',' << e.h.points << '\n';
    ce << t << ",u_mean," << shown(flowing, e.u.max_rel, 8, "") << ','
       << shown(flowing, e.u.l2_rel, 8, "") << ',' << e.u.points << '\n';
    av << t << ',' << ar << ',' << as << ',' << shown(averaged, ra, 8, "") << '\n';
    std::cout << std::setw(10) << t << " | " << std::setw(10) << shown(flowing, e.h.max_rel, 6, "-")
              << " | " << std::setw(10) << shown(flowing, e.h.l2_rel, 6, "-") << " | "
              << std::setw(10) << shown(flowing, e.u.max_rel, 6, "-") << " | " << std::setw(10)
              << shown(flowing, e.u.l2_rel, 6, "-") << " | " << std::setw(3) << e.h.points
              << " | ";
    if (averaged) std::cout << ra << "\n";
    else std::cout << "- (reference average 0)\n";
  }
  ce.close();
  av.close();
  // A plot of an earlier comparison in the same directory would sit beside these CSVs as if it
  // showed them (when the plot below fails or python3 is missing): it goes first.
  std::error_code gone;
  std::filesystem::remove(out + "/compare.png", gone);
  const std::string script = std::string(GRANFLOW_SCRIPTS_DIR) + "/plot_compare.py";
  std::cout.flush();
  if (std::filesystem::exists("/usr/bin/python3") && std::filesystem::exists(script)) {
    const std::string cmd = "/usr/bin/python3 '" + script + "' '" + out + "' '" + ref_dir +
                            "' '" + test_dir + "'";
    if (std::system(cmd.c_str()) != 0)
      std::cerr << "granflow-study: plotting failed (CSV files are written)\n";
  }
  std::cout << "wrote " << out << "/compare_errors.csv, " << out << "/average_velocity.csv\n";
  return 0;
}

nlohmann::json run_parameters(const std::string& run);
double param(const nlohmann::json& s, std::initializer_list<const char*> path);

int layout_cmd(int argc, char** argv) {
  if (argc < 3) return usage(std::cerr, 1);
  const std::string run = argv[2];
  const LayoutCriteria d;
  double length = -1, threshold = d.threshold, margin = d.margin, min_length = d.min_length;
  double h_min = layout_wet_depth(granflow::dam::DamConfig{}.dry_depth);
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    // an option layout does not have was asked for a number ("--out needs a decimal number")
    if (a != "--length" && a != "--threshold" && a != "--margin" && a != "--min-length" &&
        a != "--h-min") {
      std::cerr << "granflow-study: unknown option '" << a << "' of layout\n";
      return usage(std::cerr, 1);
    }
    if (i + 1 >= argc) { std::cerr << "granflow-study: " << a << " needs a value\n"; return 1; }
    const double v = number(a, argv[++i]);
    if (a == "--length") length = v;
    else if (a == "--threshold") threshold = v;
    else if (a == "--margin") margin = v;
    else if (a == "--min-length") min_length = v;
    else if (a == "--h-min") h_min = v;
    else { std::cerr << "granflow-study: unknown option '" << a << "'\n"; return usage(std::cerr, 1); }
  }
  // The channel length is the run's (summary.json): a --length that differs from it laid the
  // profiles' columns on another channel and printed reversed intervals and intervals beyond
  // the channel with exit 0 (an independent run); it is still accepted when it agrees.
  const double run_length = param(run_parameters(run), {"Channel", "Length"});
  if (length < 0) length = run_length;
  if (std::abs(length - run_length) > 1e-9 * std::max(1.0, run_length))
    throw std::runtime_error("--length " + granflow::params::str(length) + ": the run's channel is " +
           granflow::params::str(run_length) + " m long; allowed: its length (or no --length)");
  if (!(margin >= 0.0))
    throw std::runtime_error("--margin " + granflow::params::str(margin) + ": allowed: a length >= 0 m");
  if (!(min_length >= 0.0))
    throw std::runtime_error("--min-length " + granflow::params::str(min_length) + ": allowed: a length >= 0 m");
  if (!(threshold > 0.0))
    throw std::runtime_error("--threshold " + granflow::params::str(threshold) + ": allowed: eps > 0");
  if (!(h_min >= 0.0))
    throw std::runtime_error("--h-min " + granflow::params::str(h_min) + ": allowed: a depth >= 0 m");
  std::string note;
  const auto p = read_profiles(run + "/profiles.csv", &note);
  if (!note.empty()) std::cout << "note: " << note << "\n";
  if (p.empty())
    throw std::runtime_error(run + "/profiles.csv holds no complete output; no layout from it");
  const auto lay = propose_layout(p, length, threshold, margin, min_length, h_min);
  std::cout << "a priori layout from " << run << " (2D where eps >= " << threshold
            << ", margin " << margin << " m):\n";
  // The eps column of 2D rows is |w_mean| / |u_mean|, not 1/Fr^2 (an independent
  // run applied the threshold to a full 2D run without being told)
  bool two_d = false;
  for (const auto& [t, q] : p)
    for (const auto& m : q.model) two_d = two_d || m == "2D";
  if (two_d)
    std::cout << "  (note: this run has 2D columns; their eps in profiles.csv is |w_mean| / "
                 "|u_mean|, not 1/Fr^2: the layout is meant to be derived from a 1D "
                 "run)\n";
  for (const auto& s : lay)
    std::cout << "  " << s.model << "  [" << s.x0 << ", " << s.x1 << "] m\n";
  return 0;
}

// --- budget ---------------------------------------------------------------------------------
nlohmann::json run_parameters(const std::string& run) {
  std::ifstream in(run + "/summary.json");
  if (!in) throw std::runtime_error("no " + run + "/summary.json (a granflow run directory?)");
  const auto s = nlohmann::json::parse(in);
  return s;
}

double param(const nlohmann::json& s, std::initializer_list<const char*> path) {
  const nlohmann::json* j = &s.at("parameters");
  std::string name;
  for (const char* p : path) {
    j = &j->at(p);
    name += (name.empty() ? "" : "->") + std::string(p);
  }
  if (!j->is_number()) throw std::runtime_error("summary.json parameter " + name + " is no number");
  return j->get<double>();
}

// The profile of a run at time t (output times: 10 significant digits in profiles.csv).
const ProfileAt& profile_at(const std::map<double, ProfileAt>& run, double t,
                            const std::string& what) {
  const ProfileAt* p = at_time(run, t);
  if (!p) {
    std::ostringstream os;
    os << what << "/profiles.csv has no output at t = " << t << " s (its fields.h5 has)";
    throw std::runtime_error(os.str());
  }
  return *p;
}

void write_budget(const std::string& file, const ColumnBudget& b) {
  std::ofstream o(file);
  o << "x,h,u_mean,alpha,dQdt,flux,gravity,pressure,viscous,friction,friction_bound,residual,"
       "residual_bound,p_b\n"
    << std::setprecision(8);
  for (std::size_t i = 0; i < b.x.size(); ++i)
    o << b.x[i] << ',' << b.h[i] << ',' << b.u_mean[i] << ',' << b.alpha[i] << ',' << b.dQdt[i]
      << ',' << b.flux[i] << ',' << b.gravity[i] << ',' << b.pressure[i] << ',' << b.viscous[i]
      << ',' << b.friction[i] << ',' << b.friction_bound[i] << ',' << b.residual[i] << ','
      << b.residual_bound[i] << ',' << b.p_b[i] << '\n';
}

// Means of the per-column terms over the columns with centres in [x - w/2, x + w/2].
std::vector<double> bin(const ColumnBudget& b, double x, double w) {
  std::vector<const std::vector<double>*> f{&b.h,       &b.u_mean,   &b.alpha,    &b.dQdt,
                                            &b.flux,    &b.gravity,  &b.pressure, &b.viscous,
                                            &b.friction, &b.friction_bound, &b.residual, &b.p_b};
  std::vector<double> m(f.size(), 0.0);
  int n = 0;
  for (std::size_t i = 0; i < b.x.size(); ++i) {
    if (std::abs(b.x[i] - x) > 0.5 * w + 1e-12) continue;
    ++n;
    for (std::size_t q = 0; q < f.size(); ++q) m[q] += (*f[q])[i];
  }
  for (auto& v : m) v = n > 0 ? v / n : 0.0;
  return m;
}

int budget_cmd(int argc, char** argv) {
  if (argc < 3) return usage(std::cerr, 1);
  const std::string run = argv[2];
  double t0 = -1e300, t1 = 1e300, xa = 0.3, xb = 1.2;
  std::string dam_run, out = run;
  bool cells = false, stretch_given = false;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) { std::cerr << "granflow-study: " << a << " needs a value\n"; std::exit(1); }
      return argv[++i];
    };
    if (a == "--from") t0 = number(a, next());
    else if (a == "--to") t1 = number(a, next());
    else if (a == "--stretch") {
      xa = number(a, next());
      xb = number(a, next());
      stretch_given = true;
    } else if (a == "--dam") dam_run = next();
    else if (a == "--cell-weights") cells = true;
    else if (a == "--out") out = next();
    else { std::cerr << "granflow-study: unknown option '" << a << "'\n"; return usage(std::cerr, 1); }
  }
  // a negative time was taken as 0 without a word (an independent run)
  for (const auto& [opt, v] : {std::pair<const char*, double>{"--from", t0}, {"--to", t1}})
    if (v != -1e300 && v != 1e300 && !(v >= 0.0)) {
      std::cerr << "granflow-study: " << opt << " " << v << " s: allowed: a time >= 0 s\n";
      return 2;
    }
  // a reversed window said only "fewer than two field snapshots" (an independent run)
  if (!(t0 < t1)) {
    std::cerr << "granflow-study: --from " << t0 << " s is not before --to " << t1
              << " s; the budget averages the snapshots in [--from, --to]\n";
    return 2;
  }
  const auto sum = run_parameters(run);
  if (sum.at("model") != "N-DAM")
    throw std::runtime_error(run + " is a " + sum.at("model").get<std::string>() +
                             " run; the budget needs a full 2D (N-DAM) run");
  // a run that stopped before its end time: its snapshots end at the stop (as compare says)
  if (sum.is_object() && sum.value("status", std::string("completed")) != "completed")
    std::cout << "note: " << run << " " << sum.value("status", std::string("?")) << " at t = "
              << sum.value("final_time", 0.0) << " s (" << sum.value("reason", std::string())
              << "): its snapshots end there\n";
  // the stretch lies on the channel: the default [0.3, 1.2] m (Setup I's steady part) is cut
  // at a shorter channel's end (the whole channel when that leaves nothing), a stretch the user
  // gives must fit
  const double length = param(sum, {"Channel", "Length"});
  if (!stretch_given) {
    xb = std::min(xb, length);
    if (xa >= xb) xa = 0.0;  // a channel of 0.3 m or less: the whole of it
  }
  if (!(xa >= 0.0 && xb <= length + 1e-12 && xa < xb))
    throw std::runtime_error("--stretch " + granflow::params::str(xa) + " " +
                             granflow::params::str(xb) + ": allowed: 0 <= XA < XB <= L = " +
                             granflow::params::str(length) + " m (the run's channel)");
  BudgetPhysics ph;
  ph.g = param(sum, {"Material", "Gravity"});
  ph.zeta = param(sum, {"Channel", "Slope angle"}) * M_PI / 180.0;
  ph.tan_delta = std::tan(param(sum, {"Material", "Bed friction angle"}) * M_PI / 180.0);
  ph.m_c = param(sum, {"N-DAM", "Friction regularisation"});
  ph.bed = sum.at("parameters").at("N-DAM").at("Boundaries").at("Bottom").get<std::string>();
  ph.cell_weights = cells;
  std::string prof_note;
  const auto prof = read_profiles(run + "/profiles.csv", &prof_note);
  if (!prof_note.empty()) std::cout << "note: " << prof_note << "\n";
  const granflow::io::FieldReader fields(run + "/fields.h5");
  std::vector<ColumnIntegrals> cols;
  std::vector<double> times;
  double x0 = 0.0, dx = 0.0;
  for (std::size_t j = 0; j < fields.size(); ++j) {
    const double t = fields.time(j);
    if (t < t0 - 1e-9 || t > t1 + 1e-9) continue;
    const auto meshes = fields.read(j);
    const auto m = std::find_if(meshes.begin(), meshes.end(),
                                [](const auto& q) { return q.name == "ndam"; });
    if (m == meshes.end()) throw std::runtime_error("fields.h5 snapshot without an 'ndam' mesh");
    Snapshot2D s;
    s.t = t;
    s.nx = static_cast<int>(m->x_nodes.size()) - 1;
    s.nz = static_cast<int>(m->z_nodes.size()) - 1;
    s.x0 = m->x_nodes.front();
    s.dx = m->x_nodes[1] - m->x_nodes[0];
    s.dz = m->z_nodes[1] - m->z_nodes[0];
    for (const auto& [name, v] : m->cell_fields) {
      if (name == "u") s.u = v;
      else if (name == "p") s.p = v;
      else if (name == "nu_eff") s.nu = v;
      else if (name == "flag") s.flag = v;
    }
    s.h = profile_at(prof, t, run).h;
    cols.push_back(column_integrals(s, ph));
    times.push_back(t);
    x0 = s.x0;
    dx = s.dx;
  }
  if (times.size() < 2)
    throw std::runtime_error("fewer than two field snapshots of " + run + " in [--from, --to]: "
                             "the budget needs the time derivative (write fields more often)");
  const ColumnBudget b = momentum_budget(cols, times, x0, dx, ph);
  std::filesystem::create_directories(out);
  write_budget(out + "/budget.csv", b);

  std::optional<ColumnBudget> d;
  if (!dam_run.empty()) {
    const auto ds = run_parameters(dam_run);
    if (ds.at("model") != "DAM")
      throw std::runtime_error("--dam " + dam_run + " is not a DAM run");
    // The DAM run must be of the same channel: a Setup II DAM run (1 m, a wall) beside a Setup
    // I 2D run (1.5 m) gave a budget over the stretch cut at 1 m, with exit 0 (an independent
    // run, 2026-12-06). Length, slope and gravity must agree to round-off of their decimal form.
    auto same = [&](const char* list, const char* name) {
      const double a = param(sum, {list, name}), b = param(ds, {list, name});
      if (std::abs(a - b) > 1e-12 * std::max({1.0, std::abs(a), std::abs(b)}))
        throw std::runtime_error("--dam " + dam_run + " is a run of another channel: " + list +
                                 "->" + name + " = " + granflow::params::str(b) + " against " +
                                 granflow::params::str(a) + " in " + run +
                                 "; allowed: a DAM run of the same scene");
    };
    same("Channel", "Length");
    same("Channel", "Slope angle");
    same("Material", "Gravity");
    granflow::core::Material mat;
    mat.gravity = param(ds, {"Material", "Gravity"});
    mat.internal_friction_deg = param(ds, {"Material", "Internal friction angle"});
    mat.bed_friction_deg = param(ds, {"Material", "Bed friction angle"});
    if (const double d1 = param(ds, {"DAM", "Bed friction angle"}); d1 >= 0.0)
      mat.bed_friction_deg = d1;
    granflow::dam::DamPhysics dp;
    dp.K_act = mat.K_active();
    dp.K_pas = mat.K_passive();
    const std::string ep = ds.at("parameters").at("DAM").at("Earth pressure").get<std::string>();
    using granflow::dam::EarthPressure;
    dp.model = ep == "Active" ? EarthPressure::Active
               : ep == "Passive" ? EarthPressure::Passive
               : ep == "Isotropic" ? EarthPressure::Isotropic : EarthPressure::SavageHutter;
    dp.k_smoothing = param(ds, {"DAM", "Earth pressure smoothing"});
    BudgetPhysics dph = ph;
    dph.tan_delta = mat.tan_delta();
    std::string dprof_note;
    const auto dprof = read_profiles(dam_run + "/profiles.csv", &dprof_note);
    if (!dprof_note.empty()) std::cout << "note: " << dprof_note << "\n";
    std::vector<std::vector<double>> hs, us;
    std::vector<double> dt;
    double dx0 = 0.0, ddx = 0.0;
    for (double t : times) {
      const auto& p = profile_at(dprof, t, dam_run);
      hs.push_back(p.h);
      us.push_back(p.u);
      dt.push_back(t);
      ddx = p.x[1] - p.x[0];
      dx0 = p.x[0] - 0.5 * ddx;
    }
    d = dam_budget(hs, us, dt, dx0, ddx, dph, [&](double ux) { return dp.K(ux); });
    write_budget(out + "/budget_dam.csv", *d);
  }

  std::cout << std::fixed;
  std::cout << "x-momentum budget of " << run << " over " << b.snapshots << " snapshots in ["
            << std::setprecision(3) << b.t0 << ", " << b.t1 << "] s (time means, per unit "
            << "density, m^2/s^2; x rho = N/m^2)\n"
            << "  residual = d(hu)/dt + d(alpha h u^2)/dx - gravity - pressure - viscous - "
               "friction (applied)\n"
            << "    x |      h  u_mean  alpha | d(hu)/dt    flux  gravity pressure  viscous "
               "friction tan.d*p_b | residual  % grav\n";
  for (double x = std::ceil(xa * 10.0 - 1e-9) / 10.0 + 0.0; x <= xb + 1e-9; x += 0.1) {  // + 0.0: no -0.00
    const auto v = bin(b, x, 0.05);
    std::cout << std::setprecision(2) << std::setw(5) << x << " | " << std::setprecision(4)
              << std::setw(6) << v[0] << ' ' << std::setprecision(3) << std::setw(7) << v[1]
              << ' ' << std::setw(6) << v[2] << " | " << std::setprecision(4);
    for (int q = 3; q <= 10; ++q) std::cout << std::setw(8) << v[static_cast<std::size_t>(q)] << ' ';
    std::cout << "| ";
    if (v[5] != 0.0) std::cout << std::setprecision(1) << std::setw(7) << 100.0 * v[10] / v[5] << "\n";
    else std::cout << std::setw(7) << "-" << "\n";  // a dry bin: no gravity to compare with
  }
  auto show = [&](const char* name, const ColumnBudget& cb) {
    const StretchBudget st = stretch(cb, xa, xb);
    std::cout << std::setprecision(3) << name << ": stretch [" << xa << ", " << xb << "] m ("
              << st.columns << " columns), q = " << std::setprecision(5) << st.q
              << " m^2/s; sum of term dx [m^3/s^2] and term dx / q [m/s]:\n";
    const std::pair<const char*, double> terms[] = {
        {"d(hu)/dt", st.dQdt},       {"flux d(alpha h u^2)/dx", st.flux},
        {"gravity", st.gravity},     {"pressure -d/dx int p", st.pressure},
        {"viscous d/dx int 2nu u_x", st.viscous}, {"friction (applied)", st.friction},
        {"friction tan(delta) p_b", st.friction_bound}, {"residual", st.residual},
        {"residual (with tan(delta) p_b)", st.residual_bound}};
    for (const auto& [n, v] : terms) {
      std::cout << "  " << std::setw(32) << std::left << n << std::right << std::setprecision(6)
                << std::setw(11) << v << "  " << std::setprecision(4) << std::setw(8);
      if (st.q != 0.0) std::cout << v / st.q << "\n";
      else std::cout << "-" << "\n";  // no discharge on the stretch: no velocity change
    }
    return st;
  };
  show("2D", b);
  if (d) show("DAM", *d);
  std::cout << "wrote " << out << "/budget.csv" << (d ? ", " + out + "/budget_dam.csv" : "")
            << "\n";
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage(std::cerr, 1);
  const std::string cmd = argv[1];
  // help asked anywhere ('granflow-study compare --help' printed the usage as an error, exit 1)
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") return usage(std::cout, 0);
  try {
    if (cmd == "compare") return compare_cmd(argc, argv);
    if (cmd == "layout") return layout_cmd(argc, argv);
    if (cmd == "budget") return budget_cmd(argc, argv);
    if (cmd == "--help" || cmd == "-h") return usage(std::cout, 0);
  } catch (const std::exception& e) {
    std::cerr << "granflow-study: " << e.what() << "\n";
    return 2;
  }
  std::cerr << "granflow-study: unknown command '" << cmd << "'\n";
  return usage(std::cerr, 1);
}
