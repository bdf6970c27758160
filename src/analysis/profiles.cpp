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
  // it is left out, with the output it belongs to (below). Taken, a row cut inside its eps field
  // passed as a point, and the output's missing columns were filled by interpolation's end
  // value (granflow-study compare of a live run: h L2 0.631 against 0.070; an independent run).
  bool cut_row = false;
  if (!text.empty() && text.back() != '\n') {
    cut_row = true;
    text.erase(text.find_last_of('\n') == std::string::npos ? 0 : text.find_last_of('\n') + 1);
  }
  std::istringstream in(text);
  std::string line;
  std::getline(in, line);
  if (line.rfind("t,x,h,u_mean,eps,model", 0) != 0)
    throw std::runtime_error("'" + file + "' line 1: expected the header t,x,h,u_mean,eps,model");
  std::map<double, ProfileAt> out;
  int lineno = 1;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty()) continue;
    std::istringstream ls(line);
    std::string f[6];
    for (auto& s : f) std::getline(ls, s, ',');
    try {
      if (f[5] != "1D" && f[5] != "2D") throw std::runtime_error("model");
      std::size_t used = 0;
      double v[5];
      for (int q = 0; q < 5; ++q) {
        v[q] = std::stod(f[q], &used);
        if (used != f[q].size()) throw std::runtime_error("number");
      }
      auto& p = out[v[0]];
      p.x.push_back(v[1]);
      p.h.push_back(v[2]);
      p.u.push_back(v[3]);
      p.eps.push_back(v[4]);
      p.model.push_back(f[5]);
    } catch (const std::exception&) {
      throw std::runtime_error("'" + file + "' line " + std::to_string(lineno) +
                               ": not t,x,h,u_mean,eps,model");
    }
  }
  // The last output is incomplete when its row was cut or when it ends before the channel's end
  // that the output before it reached (rows are written in x from the start of the channel).
  if (!out.empty()) {
    const auto last = std::prev(out.end());
    const double x_last = last->second.x.empty() ? 0.0 : last->second.x.back();
    bool short_output = false;
    if (out.size() >= 2) {
      const auto& before = std::prev(last)->second;
      const std::size_t n = before.x.size();
      const double cell = n >= 2 ? before.x[n - 1] - before.x[n - 2] : 0.0;
      short_output = !before.x.empty() && x_last < before.x.back() - 0.5 * std::abs(cell);
    }
    if (cut_row || short_output) {
      if (note) {
        std::ostringstream m;
        m << "'" << file << "': its last output (t = " << last->first << " s) is incomplete ("
          << last->second.x.size() << " rows, ending at x = " << x_last
          << " m; a run still writing it, or stopped inside it): left out";
        *note = m.str();
      }
      out.erase(last);
    }
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
  // close 1D gaps shorter than min_length (between 2D regions and at the channel ends). A gap
  // of round-off is no gap: with Margin 0 the faces of neighbouring flagged cells, x_i +- dx/2,
  // differ in the last bits (0.03 against 0.030000000000000006), and with 'Minimum length' 0
  // each such pair made a 1D subdomain of length 6e-18 m, whose stable step of 3e-18 s stopped
  // the run at t = 0 as diverged (an independent run); so gaps below a millionth of a cell
  // close whatever min_length is.
  const double tiny = 1e-6 * (x.size() > 1 ? std::abs(x[1] - x[0]) : length);
  const double close_below = std::max(min_length, tiny);
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
