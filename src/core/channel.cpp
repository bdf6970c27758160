#include "granflow/core/channel.hpp"

#include "granflow/core/material.hpp"
#include "granflow/params/parameters.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace granflow::core {

namespace {
// The gate's ranges, for the constant values and for every row of a series file.
constexpr double kMaxInflowDepth = 1e3;  // [m]
constexpr double kMaxInflowSpeed = 1e3;  // [m/s]
}  // namespace

std::string to_string(BoundaryType t) {
  switch (t) {
    case BoundaryType::Inflow: return "Inflow";
    case BoundaryType::Outflow: return "Outflow";
    case BoundaryType::Wall: return "Wall";
    case BoundaryType::Periodic: return "Periodic";
  }
  return "?";
}

std::string input_path(const std::string& file, const std::string& scene_dir) {
  return (file.empty() || file.front() == '/' || scene_dir.empty()) ? file : scene_dir + "/" + file;
}

InflowSeries::InflowSeries(double h, double u) : t_{0.0}, h_{h}, u_{u} {}

InflowSeries InflowSeries::from_csv(const std::string& file, const std::string& ppath) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec))
    throw params::InputError("parameter '" + ppath + "' = " + file +
                             ": is a directory (allowed: a readable CSV file with columns t,h,u)");
  // a device or a pipe (/dev/zero, a FIFO) would be read without end: only regular files
  if (std::filesystem::exists(file, ec) && !std::filesystem::is_regular_file(file, ec))
    throw params::InputError("parameter '" + ppath + "' = " + file +
                             ": not a regular file (a device, pipe or socket; allowed: a "
                             "readable CSV file with columns t,h,u)");
  std::ifstream in(file);
  if (!in)
    throw params::InputError("parameter '" + ppath + "' = " + file +
                             ": cannot open the file (allowed: a readable CSV file with columns "
                             "t,h,u)");
  InflowSeries s;
  s.file_ = file;
  s.t_.clear();
  s.h_.clear();
  s.u_.clear();
  std::string line;
  int lineno = 0;
  bool first_content = true;  // the first line that is not blank or a comment: data or the header
  while (std::getline(in, line)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();  // CRLF files
    if (lineno == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // a UTF-8 BOM
    // blank lines and comments (a '#' as the first character that is not a blank) are skipped;
    // an indented comment, or a header after a comment, was an error before (an independent run)
    const auto first_char = line.find_first_not_of(" \t");
    if (first_char == std::string::npos || line[first_char] == '#') continue;
    const bool header_allowed = first_content;
    first_content = false;
    // Exactly three fields t,h,u (commas, or blanks in a file without commas), each a whole
    // number by params::parse_double: "0.1abc" or a fourth column is an error, not 0.1.
    std::vector<std::string> f;
    if (line.find(',') != std::string::npos) {
      std::size_t a = 0, b;
      while ((b = line.find(',', a)) != std::string::npos) f.push_back(line.substr(a, b - a)), a = b + 1;
      f.push_back(line.substr(a));
    } else {
      std::istringstream ls(line);
      for (std::string w; ls >> w;) f.push_back(w);
    }
    double v[3];
    std::string why = "has " + std::to_string(f.size()) + " fields";
    bool ok = f.size() == 3;
    for (std::size_t k = 0; ok && k < 3; ++k)
      if (!params::parse_double(f[k], v[k], why)) {
        ok = false;
        why = "field " + std::to_string(k + 1) + " " + params::shown(f[k]) + " is " + why;
      }
    if (!ok) {
      if (s.t_.empty() && header_allowed) {
        // A header must name the columns in the order they are read, t,h,u (a unit may follow
        // a name: 't [s]'): a file headed t,u,h had its velocities read as depths (a
        // hostile-user run), and a header of two names over three columns went unnoticed.
        static const char* const kNames[3] = {"t", "h", "u"};
        bool named = f.size() == 3;
        for (std::size_t k = 0; named && k < 3; ++k) {
          const std::string& c = f[k];
          const auto b = c.find_first_not_of(" \t");
          const auto e = b == std::string::npos ? b : c.find_first_of(" \t[(", b);
          std::string name = b == std::string::npos ? "" : c.substr(b, e == std::string::npos ? e : e - b);
          for (char& ch : name) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
          named = name == kNames[k];
        }
        if (named) continue;
        // a field that is a number: a data row with a bad field or a wrong count, said as such (a
        // 50 MB number on line 1 was called "neither data nor the header"; an independent run)
        bool numeric = false;
        for (std::size_t k = 0; k < f.size() && !numeric; ++k) {
          double x = 0.0;
          std::string w;
          numeric = params::parse_double(f[k], x, w);
        }
        if (numeric)
          throw params::InputError("parameter '" + ppath + "' = " + file + ": line " +
                                   std::to_string(lineno) + " " + why +
                                   "; allowed: three numbers t,h,u separated by commas");
        throw params::InputError("parameter '" + ppath + "' = " + file + ": line " +
                                 std::to_string(lineno) + " " + params::shown(line) +
                                 " is neither data nor the header t,h,u; allowed: a first line "
                                 "t,h,u (the columns in the order they are read, a unit may "
                                 "follow each name) or none, then three numbers t,h,u per line "
                                 "(blank lines and lines starting with '#' are skipped)");
      }
      throw params::InputError("parameter '" + ppath + "' = " + file + ": line " +
                               std::to_string(lineno) + " " + why +
                               "; allowed: three numbers t,h,u separated by commas");
    }
    const double t = v[0], h = v[1], u = v[2];
    if (!std::isfinite(t) || !std::isfinite(h) || !std::isfinite(u) || h < 0.0 ||
        (!s.t_.empty() && t <= s.t_.back())) {
      // say which value is wrong (an independent run: "h = -0.06" was not named)
      const std::string what =
          !std::isfinite(t) || !std::isfinite(h) || !std::isfinite(u)
              ? "t = " + params::str(t) + ", h = " + params::str(h) + ", u = " + params::str(u) +
                    " is not finite"
          : h < 0.0 ? "depth h = " + params::str(h) + " is negative"
                    : "t = " + params::str(t) + " does not follow the previous row's t = " +
                          params::str(s.t_.back());
      throw params::InputError("parameter '" + ppath + "' = " + file + ": line " +
                               std::to_string(lineno) + ": " + what +
                               "; allowed: finite values, h >= 0 and strictly increasing t");
    }
    // Like the constant inflow ('Inflow velocity' must be > 0 with a depth > 0): the left end
    // takes material in, so u < 0 (material leaving through the gate) is refused on every row,
    // and a row with h > 0 needs u > 0. Between two accepted rows the interpolated u is then
    // > 0 wherever the interpolated h is > 0.
    // the ranges of the constant gate's 'Inflow depth' [0, 1e3] m and 'Inflow velocity' (|u|
    // <= 1e3 m/s): a row beyond them is a typo (2000 for 0.2), not an inflow
    if (h > kMaxInflowDepth || std::abs(u) > kMaxInflowSpeed) {
      std::ostringstream os;
      os << "parameter '" << ppath << "' = " << file << ": line " << lineno << ": "
         << (h > kMaxInflowDepth ? "depth h = " + params::str(h) : "velocity u = " + params::str(u))
         << " outside the range of 'Inflow depth' / 'Inflow velocity'; allowed: 0 <= h <= "
         << params::str(kMaxInflowDepth) << " m and |u| <= " << params::str(kMaxInflowSpeed)
         << " m/s";
      throw params::InputError(os.str());
    }
    if (u < 0.0 || (h > 0.0 && u <= 0.0)) {
      std::ostringstream os;
      os << "parameter '" << ppath << "' = " << file << ": line " << lineno << ": velocity u = "
         << params::str(u) << " with depth h = " << params::str(h)
         << ": an inflow needs a velocity into the channel; allowed: u >= 0 on every row and "
            "u > 0 where h > 0";
      throw params::InputError(os.str());
    }
    s.t_.push_back(t);
    s.h_.push_back(h);
    s.u_.push_back(u);
  }
  if (s.t_.empty())
    throw params::InputError("parameter '" + ppath + "' = " + file + ": no data rows");
  // Before its first row the series says nothing; holding the first row backwards (what the
  // interpolation would do) gave a silent inflow from t = 0 (a hostile-user run).
  if (s.t_.front() > 0.0)
    throw params::InputError("parameter '" + ppath + "' = " + file + ": the first row is at t = " +
                             params::str(s.t_.front()) +
                             " s; allowed: a first row at t <= 0 (runs start at t = 0; give "
                             "h = 0 rows for a gate that opens later)");
  return s;
}

double InflowSeries::interp(const std::vector<double>& v, double t) const {
  if (t <= t_.front()) return v.front();
  if (t >= t_.back()) return v.back();
  const auto it = std::upper_bound(t_.begin(), t_.end(), t);
  const std::size_t i = static_cast<std::size_t>(it - t_.begin());
  const double w = (t - t_[i - 1]) / (t_[i] - t_[i - 1]);
  return (1.0 - w) * v[i - 1] + w * v[i];
}
double InflowSeries::depth(double t) const { return interp(h_, t); }
double InflowSeries::velocity(double t) const { return interp(u_, t); }
double InflowSeries::discharge(double t0, double t1) const {
  if (!(t1 > t0)) return 0.0;
  auto q = [&](double t) { return depth(t) * velocity(t); };
  double sum = 0.0, a = t0;
  // the rows strictly inside (t0, t1) split the interval into pieces where h and u are linear
  for (auto it = std::upper_bound(t_.begin(), t_.end(), t0); it != t_.end() && *it < t1; ++it) {
    sum += (*it - a) / 6.0 * (q(a) + 4.0 * q(0.5 * (a + *it)) + q(*it));
    a = *it;
  }
  sum += (t1 - a) / 6.0 * (q(a) + 4.0 * q(0.5 * (a + t1)) + q(t1));
  return sum;
}
std::vector<double> InflowSeries::rows_between(double t0, double t1) const {
  std::vector<double> out;
  for (auto it = std::upper_bound(t_.begin(), t_.end(), t0); it != t_.end() && *it < t1; ++it)
    out.push_back(*it);
  return out;
}
double InflowSeries::max_depth() const { return *std::max_element(h_.begin(), h_.end()); }
double InflowSeries::max_speed() const {
  double m = 0.0;
  for (double u : u_) m = std::max(m, std::abs(u));
  return m;
}

namespace {
const std::vector<std::string> kLeftTypes{"Inflow", "Outflow", "Wall", "Periodic"};
const std::vector<std::string> kRightTypes{"Outflow", "Wall", "Periodic"};

BoundaryType parse_type(const std::string& s) {
  if (s == "Inflow") return BoundaryType::Inflow;
  if (s == "Outflow") return BoundaryType::Outflow;
  if (s == "Wall") return BoundaryType::Wall;
  return BoundaryType::Periodic;
}
}  // namespace

Teuchos::RCP<const Teuchos::ParameterList> Channel::getValidParameters() {
  static Teuchos::RCP<const Teuchos::ParameterList> valid = [] {
    using namespace params;
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("Channel"));
    const Channel d;
    add_double(*pl, "Length", d.length, "L [m]: channel length along the slope", 1e-6, 1e6);
    add_double(*pl, "Slope angle", d.slope_deg, "zeta [deg]: inclination of the channel bed",
               0.0, 89.0);
    auto& left = pl->sublist("Left boundary", false,
                             "Upstream end x = 0 (the silo gate in the paper's setups)");
    add_enum(left, "Type", to_string(d.left.type),
             "Inflow: prescribed depth and mean velocity (constant or series file); Outflow: "
             "open end (zero gradient: the channel continues beyond the end with the end "
             "cell's state, so where the flow there points into the channel material enters, "
             "as from the endless reservoir of a dam break on an incline; a finite release "
             "whose tail leaves the end needs a Wall there); Wall: rigid closed end; Periodic: "
             "both ends periodic",
             kLeftTypes);
    add_double(left, "Inflow depth", d.left.inflow.depth(0.0),
               "h_in [m]: opening of the silo gate (Inflow only)", 0.0, kMaxInflowDepth);
    add_double(left, "Inflow velocity", d.left.inflow.velocity(0.0),
               "u_in [m/s]: mean inflow velocity through the gate (Inflow only). The discharge "
               "h_in u_in enters exactly (in 2D as whole markers: each open marker row carries its "
               "fraction of a marker to the next step, summary.json "
               "mass_balance.pending_at_left_end); in the DAM a subcritical gate (u_in below the wave "
               "speed sqrt(g cos(zeta) K(0) h_in) of h_in, with the earth-pressure coefficient "
               "K(0) of the tanh switch at u_x = 0, the mean of K_act and K_pas, not K_act) "
               "prescribes only that discharge and takes its depth from the "
               "channel: the critical depth over a dry or accelerating channel "
               "(docs/numerics.md)", -kMaxInflowSpeed, kMaxInflowSpeed);
    add_string(left, "Inflow series file", "",
               "CSV file with columns t,h,u (a first line may name them, t,h,u in this order, a "
               "unit may follow each name; blank lines and lines whose first character that is "
               "not a blank is '#' are skipped) giving a time-dependent inflow, "
               "linear in time and held after its last row; relative to the scene file. "
               "Replaces 'Inflow depth' and 'Inflow velocity' (Inflow only)");
    auto& right = pl->sublist("Right boundary", false, "Downstream end x = L");
    add_enum(right, "Type", to_string(d.right.type),
             "Outflow: open end (zero gradient: the channel continues beyond the end with the "
             "end cell's state, so a flow turned back into the channel there takes material "
             "in); Wall: rigid perpendicular wall; Periodic: both ends periodic",
             kRightTypes);
    return pl;
  }();
  return valid;
}

Channel Channel::from_parameters(const Teuchos::ParameterList& pl,
                                 const Teuchos::ParameterList& user, const std::string& scene_dir) {
  Channel c;
  c.length = pl.get<double>("Length");
  c.slope_deg = pl.get<double>("Slope angle");
  const auto& left = pl.sublist("Left boundary");
  const auto& right = pl.sublist("Right boundary");
  c.left.type = parse_type(left.get<std::string>("Type"));
  c.right.type = parse_type(right.get<std::string>("Type"));
  c.left.inflow = c.right.inflow = InflowSeries();  // set below for an Inflow end only

  // Inconsistent combinations: inflow data given for an end that is not an inflow.
  const Teuchos::ParameterList* uleft =
      user.isSublist("Left boundary") ? &user.sublist("Left boundary") : nullptr;
  if (uleft && c.left.type != BoundaryType::Inflow) {
    for (const char* n : {"Inflow depth", "Inflow velocity", "Inflow series file"})
      if (uleft->isParameter(n))
        params::fail(left, n, Teuchos::toString(uleft->getEntry(n).getAny(false)),
                     "inflow data on a boundary of Type '" + to_string(c.left.type) +
                         "' (a closed or open end takes no inflow); allowed only with Type = "
                         "Inflow");
  }
  if ((c.left.type == BoundaryType::Periodic) != (c.right.type == BoundaryType::Periodic))
    params::fail(right, "Type", to_string(c.right.type),
                 "periodic boundaries must be set at both ends (left is '" +
                     to_string(c.left.type) + "'); allowed: Periodic on both or on neither");

  if (c.left.type == BoundaryType::Inflow) {
    const std::string file = left.get<std::string>("Inflow series file");
    if (!file.empty()) {
      if (uleft && (uleft->isParameter("Inflow depth") || uleft->isParameter("Inflow velocity")))
        params::fail(left, "Inflow series file", file,
                     "given together with 'Inflow depth'/'Inflow velocity'; allowed: either a "
                     "series file or constant values");
      c.left.inflow = InflowSeries::from_csv(input_path(file, scene_dir),
                                             params::path(left, "Inflow series file"));
    } else {
      const double h = left.get<double>("Inflow depth");
      const double u = left.get<double>("Inflow velocity");
      if (h > 0.0 && u <= 0.0)
        params::fail(left, "Inflow velocity", params::str(u),
                     "an inflow with depth > 0 needs a velocity into the channel; allowed: > 0");
      c.left.inflow = InflowSeries(h, u);
    }
  }
  return c;
}

double Channel::g_sin(double g) const { return g * std::sin(deg2rad(slope_deg)); }
double Channel::g_cos(double g) const { return g * std::cos(deg2rad(slope_deg)); }

}  // namespace granflow::core
