// granflow-study: compare runs and derive layouts from their profiles.csv.
//
//   granflow-study compare REF_RUN TEST_RUN [--times T ...] [--h-min H] [--u-min U]
//                  [--average-length L] [--out DIR]
//       The paper's relative error r = |v_test - v_ref| / |v_ref| of h and u_mean (max and L2
//       over the flowing part) at each common output time, and the velocity averaged over
//       [0, L] against time (Fig. 14). Writes DIR/compare_errors.csv,
//       DIR/average_velocity.csv and, when python3 with matplotlib is present, DIR/compare.png.
//   granflow-study layout RUN --length L [--threshold E] [--margin M] [--min-length S]
//                  [--h-min H]
//       A priori 2D/1D layout from a (fast, 1D) run: 2D wherever eps >= E at any output time
//       on cells deeper than H, widened by M on both sides (paper section 4.1). The defaults
//       are those of the scene's Decomposition (analysis::LayoutCriteria, and H = the wet-depth
//       cut of a DAM with the default dry depth), so the command gives the layout that
//       Decomposition->Layout = A priori builds from the same run.
#include "granflow/analysis/profiles.hpp"
#include "granflow/dam/dam_solver.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
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
        "       granflow-study layout RUN --length L [--threshold E] [--margin M]\n"
        "                      [--min-length S] [--h-min H]\n"
        "RUN is a granflow output directory (it holds profiles.csv).\n";
  return code;
}

double number(const std::string& opt, const char* v) {
  char* end = nullptr;
  const double d = std::strtod(v, &end);
  if (end == v || *end != '\0' || !std::isfinite(d)) {
    std::cerr << "granflow-study: option " << opt << " needs a number, got '" << v << "'\n";
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

int compare_cmd(int argc, char** argv) {
  if (argc < 4) return usage(std::cerr, 1);
  const std::string ref_dir = argv[2], test_dir = argv[3];
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
      while (i + 1 < argc && argv[i + 1][0] != '-') times.push_back(number(a, argv[++i]));
    } else if (a == "--h-min") h_min = number(a, next());
    else if (a == "--u-min") u_min = number(a, next());
    else if (a == "--average-length") l = number(a, next());
    else if (a == "--out") out = next();
    else { std::cerr << "granflow-study: unknown option '" << a << "'\n"; return usage(std::cerr, 1); }
  }
  const auto ref = read_profiles(ref_dir + "/profiles.csv");
  const auto test = read_profiles(test_dir + "/profiles.csv");
  if (times.empty())
    for (const auto& [t, p] : ref)
      if (at_time(test, t)) times.push_back(t);
  std::filesystem::create_directories(out);
  std::ofstream ce(out + "/compare_errors.csv"), av(out + "/average_velocity.csv");
  ce << "t,quantity,max_rel,l2_rel,points\n" << std::setprecision(8);
  av << "t,u_avg_ref,u_avg_test,rel_error\n" << std::setprecision(8);
  std::cout << "reference " << ref_dir << ", test " << test_dir << " (flowing: h > " << h_min
            << " m, |u| > " << u_min << " m/s)\n"
            << "     t [s] |  h max rel |   h L2 rel |  u max rel |   u L2 rel | pts | u(" << l
            << ") rel\n";
  for (double t : times) {
    const ProfileAt* r = at_time(ref, t);
    const ProfileAt* s = at_time(test, t);
    if (!r || !s) {
      std::cerr << "granflow-study: time " << t << " s is not an output time of both runs\n";
      return 2;
    }
    const auto e = compare(*r, *s, h_min, u_min);
    const double ar = average_velocity(*r, l), as = average_velocity(*s, l);
    const double ra = ar != 0.0 ? std::abs(as - ar) / std::abs(ar) : 0.0;
    ce << t << ",h," << e.h.max_rel << ',' << e.h.l2_rel << ',' << e.h.points << '\n';
    ce << t << ",u_mean," << e.u.max_rel << ',' << e.u.l2_rel << ',' << e.u.points << '\n';
    av << t << ',' << ar << ',' << as << ',' << ra << '\n';
    std::cout << std::setw(10) << t << " | " << std::setw(10) << e.h.max_rel << " | "
              << std::setw(10) << e.h.l2_rel << " | " << std::setw(10) << e.u.max_rel << " | "
              << std::setw(10) << e.u.l2_rel << " | " << std::setw(3) << e.h.points << " | "
              << ra << "\n";
  }
  ce.close();
  av.close();
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

int layout_cmd(int argc, char** argv) {
  if (argc < 3) return usage(std::cerr, 1);
  const std::string run = argv[2];
  const LayoutCriteria d;
  double length = -1, threshold = d.threshold, margin = d.margin, min_length = d.min_length;
  double h_min = layout_wet_depth(granflow::dam::DamConfig{}.dry_depth);
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) { std::cerr << "granflow-study: " << a << " needs a value\n"; return 1; }
    const double v = number(a, argv[++i]);
    if (a == "--length") length = v;
    else if (a == "--threshold") threshold = v;
    else if (a == "--margin") margin = v;
    else if (a == "--min-length") min_length = v;
    else if (a == "--h-min") h_min = v;
    else { std::cerr << "granflow-study: unknown option '" << a << "'\n"; return usage(std::cerr, 1); }
  }
  if (!(length > 0)) {
    std::cerr << "granflow-study: layout needs --length L (> 0), the channel length\n";
    return 1;
  }
  const auto p = read_profiles(run + "/profiles.csv");
  const auto lay = propose_layout(p, length, threshold, margin, min_length, h_min);
  std::cout << "a priori layout from " << run << " (2D where eps >= " << threshold
            << ", margin " << margin << " m):\n";
  for (const auto& s : lay)
    std::cout << "  " << s.model << "  [" << s.x0 << ", " << s.x1 << "] m\n";
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage(std::cerr, 1);
  const std::string cmd = argv[1];
  try {
    if (cmd == "compare") return compare_cmd(argc, argv);
    if (cmd == "layout") return layout_cmd(argc, argv);
    if (cmd == "--help" || cmd == "-h") return usage(std::cout, 0);
  } catch (const std::exception& e) {
    std::cerr << "granflow-study: " << e.what() << "\n";
    return 2;
  }
  std::cerr << "granflow-study: unknown command '" << cmd << "'\n";
  return usage(std::cerr, 1);
}
