#include "granflow/analysis/profiles.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

namespace granflow::analysis {

std::map<double, ProfileAt> read_profiles(const std::string& file, std::string* note) {
  if (note) note->clear();
  std::ifstream raw(file, std::ios::binary);
  if (!raw) throw std::runtime_error("cannot open '" + file + "'");
  std::string text((std::istreambuf_iterator<char>(raw)), std::istreambuf_iterator<char>());
  // A last line without its newline is a row still being written (granflow writes whole rows):
  // it is left out, and with it the output it belongs to when that output is the last one
  // read (below); the first row of a next output, cut, leaves the output before it whole.
  // Taken, a row cut inside its eps field passed as a point, and the output's missing columns
  // were filled by interpolation's end value (granflow-study compare of a live run: h L2 0.631
  // against 0.070; an independent run).
  std::string fragment;
  if (!text.empty() && text.back() != '\n') {
    const auto nl = text.find_last_of('\n');
    const std::size_t from = nl == std::string::npos ? 0 : nl + 1;
    fragment = text.substr(from);
    text.erase(from);
  }
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);
  if (!line.empty() && line.back() == '\r') line.pop_back();  // (a copy with CRLF line ends)
  if (line.rfind("t,x,h,u_mean,eps,model", 0) != 0)
    throw std::runtime_error("'" + file + "' line 1: expected the header t,x,h,u_mean,eps,model");
  std::map<double, ProfileAt> out;
  int lineno = 1;
  while (std::getline(in, line)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::istringstream ls(line);
    std::string f[6];
    for (auto& s : f) std::getline(ls, s, ',');
    const std::string where = "'" + file + "' line " + std::to_string(lineno) + ": ";
    if (f[5] != "1D" && f[5] != "2D")
      throw std::runtime_error(where + "model '" + f[5] + "' is neither 1D nor 2D (columns t,x,h,u_mean,eps,model)");
    double v[5];
    static const char* names[5] = {"t", "x", "h", "u_mean", "eps"};
    for (int q = 0; q < 5; ++q) {
      std::size_t used = 0;
      try {
        v[q] = std::stod(f[q], &used);
      } catch (const std::exception&) {
        used = std::string::npos;
      }
      if (used != f[q].size())
        throw std::runtime_error(where + names[q] + " '" + f[q] + "' is not a number (columns t,x,h,u_mean,eps,model)");
    }
    auto& p = out[v[0]];
    p.x.push_back(v[1]);
    p.h.push_back(v[2]);
    p.u.push_back(v[3]);
    p.eps.push_back(v[4]);
    p.model.push_back(f[5]);
  }
  if (out.empty()) return out;
  // The last output is incomplete when the cut row was one of it (its t, read up to the first
  // comma, is the output's time; a fragment without a comma cannot say) or when it ends before
  // the channel's end that the output before it reached. The ends are the last centre plus half
  // the last cell, so that a dynamic layout whose last part changes between a 2D and a 1D grid
  // of another cell size keeps its outputs (rows are written in x from the channel's start).
  const auto last = std::prev(out.end());
  bool cut_last = false;
  if (const auto comma = fragment.find(','); comma != std::string::npos) {
    std::size_t used = 0;
    try {
      const double tf = std::stod(fragment.substr(0, comma), &used);
      cut_last = used == comma && tf == last->first;
    } catch (const std::exception&) {
    }
  }
  auto channel_end = [](const ProfileAt& p) {
    const std::size_t n = p.x.size();
    return n == 0 ? 0.0 : p.x[n - 1] + (n >= 2 ? 0.5 * (p.x[n - 1] - p.x[n - 2]) : 0.0);
  };
  auto last_cell = [](const ProfileAt& p) {
    const std::size_t n = p.x.size();
    return n >= 2 ? p.x[n - 1] - p.x[n - 2] : 0.0;
  };
  bool short_output = false;
  if (out.size() >= 2) {
    const auto& before = std::prev(last)->second;
    double cell = last_cell(before);  // the tolerance: half the smaller of the two end cells
    if (last->second.x.size() >= 2) cell = std::min(cell, last_cell(last->second));
    short_output = channel_end(last->second) < channel_end(before) - 0.5 * cell;
  }
  if (cut_last || short_output) {
    if (note) {
      std::ostringstream m;
      m << "'" << file << "': its last output (t = " << last->first << " s) is incomplete ("
        << last->second.x.size() << " rows, ending at x = "
        << (last->second.x.empty() ? 0.0 : last->second.x.back())
        << " m; a run still writing it, or stopped inside it): left out";
      *note = m.str();
    }
    out.erase(last);
  }
  return out;
}

namespace {
double interp(const std::vector<double>& x, const std::vector<double>& v, double xi) {
  if (x.empty()) return 0.0;
  if (xi <= x.front()) return v.front();
  if (xi >= x.back()) return v.back();
  const auto it = std::upper_bound(x.begin(), x.end(), xi);
  const auto i = static_cast<std::size_t>(it - x.begin());
  const double w = (xi - x[i - 1]) / (x[i] - x[i - 1]);
  return (1 - w) * v[i - 1] + w * v[i];
}
}  // namespace

ProfileErrors compare(const ProfileAt& ref, const ProfileAt& test, double h_min, double u_min) {
  ProfileErrors e;
  double sh = 0, sh_ref = 0, su = 0, su_ref = 0;
  for (std::size_t i = 0; i < ref.x.size(); ++i) {
    if (ref.h[i] <= h_min || std::abs(ref.u[i]) <= u_min) continue;
    const double ht = interp(test.x, test.h, ref.x[i]);
    const double ut = interp(test.x, test.u, ref.x[i]);
    e.h.max_rel = std::max(e.h.max_rel, std::abs(ht - ref.h[i]) / ref.h[i]);
    e.u.max_rel = std::max(e.u.max_rel, std::abs(ut - ref.u[i]) / std::abs(ref.u[i]));
    sh += (ht - ref.h[i]) * (ht - ref.h[i]);
    sh_ref += ref.h[i] * ref.h[i];
    su += (ut - ref.u[i]) * (ut - ref.u[i]);
    su_ref += ref.u[i] * ref.u[i];
    ++e.h.points;
  }
  e.u.points = e.h.points;
  e.h.l2_rel = sh_ref > 0 ? std::sqrt(sh / sh_ref) : 0.0;
  e.u.l2_rel = su_ref > 0 ? std::sqrt(su / su_ref) : 0.0;
  return e;
}

double average_velocity(const ProfileAt& p, double l) {
  // cell widths from the spacing of the profile points (uniform per model region)
  double s = 0.0, covered = 0.0;
  for (std::size_t i = 0; i < p.x.size(); ++i) {
    const double left = i == 0 ? p.x[0] - 0.5 * (p.x[1] - p.x[0]) : 0.5 * (p.x[i - 1] + p.x[i]);
    const double right = i + 1 == p.x.size() ? p.x[i] + 0.5 * (p.x[i] - p.x[i - 1])
                                             : 0.5 * (p.x[i] + p.x[i + 1]);
    const double a = std::max(left, 0.0), b = std::min(right, l);
    if (b <= a) continue;
    s += p.u[i] * (b - a);
    covered += b - a;
  }
  return covered > 0 ? s / l : 0.0;
}

std::vector<Subdomain> propose_layout(const std::map<double, ProfileAt>& run, double length,
                                      double threshold, double margin, double min_length,
                                      double h_min) {
  if (run.empty()) return {{"1D", 0.0, length}};
  const auto& x = run.begin()->second.x;
  std::vector<char> deep(x.size(), 0);
  for (const auto& [t, p] : run)
    for (std::size_t i = 0; i < p.x.size() && i < x.size(); ++i)
      if (p.h[i] > h_min && p.eps[i] >= threshold) deep[i] = 1;
  // 2D intervals: cells flagged at any time, widened by the margin
  std::vector<std::pair<double, double>> iv;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (!deep[i]) continue;
    const double half = 0.5 * (x.size() > 1 ? (i + 1 < x.size() ? x[i + 1] - x[i] : x[i] - x[i - 1]) : length);
    const double a = std::max(0.0, x[i] - half - margin), b = std::min(length, x[i] + half + margin);
    if (!iv.empty() && a <= iv.back().second) iv.back().second = std::max(iv.back().second, b);
    else iv.emplace_back(a, b);
  }
  // close 1D gaps shorter than min_length (between 2D regions and at the channel ends), and
  // shorter than one cell whatever min_length is: with Margin 0 the faces of neighbouring
  // flagged cells, x_i +- dx/2, differ in the last bits (0.03 against 0.030000000000000006),
  // and with 'Minimum length' 0 each such pair made a 1D subdomain of 6e-18 m, whose stable
  // step of 3e-18 s stopped the run at t = 0 as diverged (an independent run); a margin that is
  // no multiple of half a cell left gaps of 2e-7 m the same way (a review). A 1D part holds at
  // least one cell of the profile's grid.
  const double cell = x.size() > 1 ? std::abs(x[1] - x[0]) : length;
  const double close_below = std::max(min_length, cell * (1.0 - 1e-9));
  std::vector<std::pair<double, double>> merged;
  for (const auto& v : iv) {
    if (!merged.empty() && v.first - merged.back().second < close_below)
      merged.back().second = std::max(merged.back().second, v.second);
    else
      merged.push_back(v);
  }
  if (!merged.empty() && merged.front().first < close_below) merged.front().first = 0.0;
  if (!merged.empty() && length - merged.back().second < close_below) merged.back().second = length;
  std::vector<Subdomain> out;
  double pos = 0.0;
  for (const auto& [a, b] : merged) {
    if (a > pos) out.push_back({"1D", pos, a});
    out.push_back({"2D", a, b});
    pos = b;
  }
  if (pos < length) out.push_back({"1D", pos, length});
  return out;
}

}  // namespace granflow::analysis
