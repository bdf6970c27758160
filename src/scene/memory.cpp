// Memory estimate of a scene (see memory.hpp). The constants are measured peak resident sets
// (/usr/bin/time -f %M) of this code in a Release build, Max steps = 2 (the first steps
// allocate every solver structure; outputs at t = 0 and the end included):
//
//   per rank, libraries and MPI: 78 MB (smallest scenes)                          kBase
//   DAM: 148 B per cell (1e6 cells 221 MB, 1e7 cells 1551 MB): h, hu, their
//     tentative copies, the step's ~14 work arrays, the output's profile and fields  kDamCell
//   N-DAM, explicit momentum, CG pressure with MueLu: 1050 B per cell (cavity 512^2:
//     361 MB, 256^2: 156 MB; 645 B before the assembly's emission record of the repeat
//     path, about 50 B per matrix entry, linear_system.cpp, remeasured 2026-12-06): ~20
//     fields, pressure matrix, its record and its AMG hierarchy                    kNdamCell
//   implicit momentum (u, w interleaved, 2 rows per cell): 2080 B per cell for the
//     matrix, its record and its preconditioner (cavity 512^2: 1119 MB, 256^2: 341 MB;
//     1090 B before the record) plus the GMRES basis,
//     (restart + 1) x 2 x 8 B (restart 10 instead of 50: -118 MB measured,
//     -168 MB counted; Belos touches only the vectors it uses)                     kMomentumCell
//   markers: 132 B each (Setup II chute 800 x 120, 2/3 full, 12 x 12 instead of 4 x 4
//     markers per cell: +1056 MB for 8.2e6 more markers): the set, its sort and halo
//     buffers, the checkpoint's gathered copy; since the checkpoint is built in memory and
//     written as one image (io::write_checkpoint), two more copies of its 24 B per marker
//     on rank 0 while it is written (Setup II at 5 mm, 12 x 12 markers per cell, 7.7e4
//     markers: peak 100.3 -> 105.1 MB, 62 B per marker with HDF5's 1 MB growth): 180 B  kMarker
//   nonlinear pressure coupling (NOX): the Newton-Krylov basis (restart + 1) x 8 B and
//     ~500 B of Newton vectors and preconditioner per cell (Setup II 800 x 120: +82 MB
//     over the lagged run before it was stopped, a lower bound)                    kNewtonCell
//
// Every 2D cell is counted as fluid (the solvers' rows exist for all cells; an empty chute
// needs less: 110 MB measured for 800 x 120 against 459 MB estimated), so the estimate is an
// upper bound for the solver part; the markers are bounded by the material the run can hold.
#include "granflow/scene/memory.hpp"

#include "granflow/core/channel.hpp"
#include "granflow/params/parameters.hpp"

#include <Teuchos_Array.hpp>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace granflow::scene {

namespace {
constexpr double kBase = 80e6;
constexpr double kDamCell = 150.0;
constexpr double kNdamCell = 1050.0;
constexpr double kMomentumCell = 2080.0;
constexpr double kMarker = 180.0;
constexpr double kNewtonCell = 500.0;
// [B] per row of an inflow series on every rank: the parsed rows and the copies the models hold.
// A 2e6-row file: peaks of 353 MB in the DAM and 364 MB in 2D against 71 / 89 MB without it (140
// B per row), 724 MB coupled against 84 MB (320 B per row: the parts and the factory keep copies);
// the estimate left it out (an independent run and a review)
constexpr double kSeriesRow = 150.0;
constexpr double kSeriesRowCoupled = 340.0;

// Volume (per unit width, m^2) that can enter through `b` on [0, T]: the integral of h u
// (trapezoidal rule on 2000 intervals; the series are piecewise linear, h u piecewise
// quadratic, so this is within 1e-6 relative of exact for series of up to a few hundred rows).
double inflow_area(const core::BoundarySpec& b, double T) {
  if (b.type != core::BoundaryType::Inflow || T <= 0) return 0.0;
  const int n = b.inflow.is_constant() ? 1 : 2000;
  double a = 0.0;
  for (int i = 0; i < n; ++i) {
    const double t0 = T * i / n, t1 = T * (i + 1) / n;
    a += 0.5 * (t1 - t0) *
         (std::abs(b.inflow.depth(t0) * b.inflow.velocity(t0)) +
          std::abs(b.inflow.depth(t1) * b.inflow.velocity(t1)));
  }
  return a;
}

// The N-DAM part: `cells` of a box of nx x nz (a fraction of it for a coupled channel) and
// the markers of `material_cells` cells.
void add_ndam(MemoryEstimate& e, const Teuchos::ParameterList& nd, double cells,
              double material_cells, bool nonlinear) {
  const auto& mom = nd.sublist("Momentum solver");
  const auto& pre = nd.sublist("Pressure solver");
  double per_cell = kNdamCell;
  if (pre.get<std::string>("Solver") != "CG")
    per_cell += (pre.get<int>("GMRES restart") + 1) * 8.0;
  if (nd.get<std::string>("Momentum") == "Implicit") {
    per_cell += kMomentumCell;
    if (mom.get<std::string>("Solver") != "CG")
      per_cell += (mom.get<int>("GMRES restart") + 1) * 2 * 8.0;
  }
  if (nonlinear) {
    const auto& nl = nd.sublist("Pressure Newton");
    per_cell += kNewtonCell + (nl.get<int>("GMRES restart") + 1) * 8.0;
  }
  e.parts.emplace_back("2D fields and solvers", cells * per_cell);
  if (nd.get<bool>("Free surface")) {
    const int m = nd.get<int>("Markers per cell");
    e.parts.emplace_back("markers", material_cells * m * m * kMarker);
  }
}
}  // namespace

std::string format_bytes(double b) {
  char buf[64];
  if (b >= 1e12) std::snprintf(buf, sizeof buf, "%.3g TB", b / 1e12);
  else if (b >= 1e9) std::snprintf(buf, sizeof buf, "%.3g GB", b / 1e9);
  else std::snprintf(buf, sizeof buf, "%.3g MB", b / 1e6);
  return buf;
}

std::string MemoryEstimate::summary() const {
  std::string s = format_bytes(bytes) + " (";
  for (std::size_t i = 0; i < parts.size(); ++i)
    s += (i ? ", " : "") + parts[i].first + " " + format_bytes(parts[i].second);
  return s + ")";
}

MemoryEstimate estimate_memory(const Scene& s, int ranks, int node_ranks) {
  const auto& p = *s.params;
  MemoryEstimate e;
  const auto channel = core::Channel::from_parameters(
      p.sublist("Channel"),
      s.user->isSublist("Channel") ? s.user->sublist("Channel") : Teuchos::ParameterList("Channel"),
      s.dir);
  const double T = p.sublist("Time").get<double>("End time");
  const double inflow = inflow_area(channel.left, T) + inflow_area(channel.right, T);
  if (s.model == "DAM" || s.model == "Coupled")
    e.parts.emplace_back("1D fields", kDamCell * p.sublist("DAM").get<int>("Cells"));
  if (s.model == "N-DAM" || s.model == "Coupled") {
    const auto& nd = p.sublist("N-DAM");
    const double nx = nd.get<int>("Cells x"), nz = nd.get<int>("Cells z");
    const double H = nd.get<double>("Height"), L = channel.length;
    double fraction = 1.0;  // of the channel in 2D
    if (s.model == "Coupled") {
      const auto& d = p.sublist("Decomposition");
      if (d.get<std::string>("Layout") == "Static") {
        const auto ma = d.get<Teuchos::Array<std::string>>("Models");
        const auto ia = d.get<Teuchos::Array<double>>("Interfaces");
        const std::vector<std::string> models(ma.begin(), ma.end());
        const std::vector<double> ifs(ia.begin(), ia.end());
        fraction = 0.0;
        for (std::size_t i = 0; i < models.size(); ++i) {
          // (a count mismatch is reported when the model is built; bound it here)
          const double a = i == 0 || ifs.size() < i ? 0.0 : std::clamp(ifs[i - 1], 0.0, L);
          const double b = i < ifs.size() ? std::clamp(ifs[i], 0.0, L) : L;
          if (models[i] == "2D") fraction += std::max(0.0, b - a) / L;
        }
      }  // A priori: the layout is known only after the DAM run; bound it by the channel
    }
    const double cells = fraction * nx * nz;
    // Material the boxes can hold: the initial layer (N-DAM) plus everything that flows in;
    // a coupled channel's 2D parts are bounded by their boxes.
    double material = cells;
    if (s.model == "N-DAM") {
      const double x0 = std::clamp(nd.get<double>("Initial x0"), 0.0, L);
      const double x1 = std::clamp(nd.get<double>("Initial x1"), 0.0, L);
      const double a0 = std::min(nd.get<double>("Initial depth"), H) * std::max(0.0, x1 - x0);
      material = std::min(cells, (a0 + inflow) / ((L / nx) * (H / nz)));
    }
    add_ndam(e, nd, cells, material, nd.get<std::string>("Pressure coupling") == "Nonlinear");
  }
  // The distributed parts are split over the ranks; each rank loads the libraries.
  double dist = 0.0;
  for (const auto& part : e.parts) dist += part.second;
  const double share = static_cast<double>(node_ranks) / std::max(ranks, 1);
  for (auto& part : e.parts) part.second *= share;
  e.parts.emplace_back(node_ranks > 1 ? "libraries (" + std::to_string(node_ranks) + " ranks)"
                                      : std::string("libraries"),
                       kBase * node_ranks);
  e.bytes = dist * share + kBase * node_ranks;
  const double rows = static_cast<double>(channel.left.inflow.rows() + channel.right.inflow.rows());
  if (rows > 2.0) {  // (constant ends: one row each)
    const double per_row = s.model == "Coupled" ? kSeriesRowCoupled : kSeriesRow;
    e.parts.emplace_back("inflow series", per_row * rows * node_ranks);
    e.bytes += per_row * rows * node_ranks;
  }
  return e;
}

namespace {
double meminfo_kb(const std::string& key) {
  std::ifstream in("/proc/meminfo");
  std::string k;
  double v = -1;
  std::string unit;
  while (in >> k >> v >> unit)
    if (k == key + ":") return v;
  return -1;
}

double read_number(const std::string& file) {
  std::ifstream in(file);
  std::string s;
  if (!(in >> s)) return -1;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  return (end == s.c_str() || *end) ? -1 : v;  // "max" (no limit) -> -1
}
}  // namespace

MachineMemory machine_memory() {
  MachineMemory m;
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  m.total = pages > 0 && page > 0 ? static_cast<double>(pages) * page : 0.0;
  const double avail = meminfo_kb("MemAvailable");
  m.available = avail >= 0 ? avail * 1024.0 : m.total;
  // A container's memory limit (cgroup v2, else v1) is what the kernel enforces for us.
  double limit = read_number("/sys/fs/cgroup/memory.max");
  double used = read_number("/sys/fs/cgroup/memory.current");
  if (limit < 0) {
    limit = read_number("/sys/fs/cgroup/memory/memory.limit_in_bytes");
    used = read_number("/sys/fs/cgroup/memory/memory.usage_in_bytes");
  }
  if (limit > 0 && limit < m.total) {
    m.total = limit;
    if (used >= 0) m.available = std::min(m.available, std::max(0.0, limit - used));
  }
  return m;
}

void check_memory(const Scene& s, const MemoryEstimate& e, const MachineMemory& m) {
  if (m.available <= 0 || e.bytes <= m.available) return;
  const auto& p = *s.params;
  std::ostringstream size;
  if (s.model != "N-DAM") size << "'DAM->Cells' = " << p.sublist("DAM").get<int>("Cells");
  if (s.model != "DAM") {
    const auto& nd = p.sublist("N-DAM");
    if (s.model != "N-DAM") size << ", ";
    size << "'N-DAM->Cells x' = " << nd.get<int>("Cells x")
         << ", 'N-DAM->Cells z' = " << nd.get<int>("Cells z");
    if (nd.get<bool>("Free surface"))
      size << ", 'N-DAM->Markers per cell' = " << nd.get<int>("Markers per cell");
  }
  throw params::InputError(
      s.file + ": the scene (" + size.str() + ") needs about " + e.summary() +
      " of memory; this machine has " + format_bytes(m.available) + " available (of " +
      format_bytes(m.total) + "); allowed: a scene that fits (fewer cells or markers, or more "
      "ranks on more nodes)");
}

}  // namespace granflow::scene
