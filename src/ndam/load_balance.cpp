// x-slabs by the work of the columns (issue 14 item 4): on several ranks, each rank owns a
// contiguous range of columns of the box (grid.hpp, Slab). The work of a step lies in the
// material cells (the momentum and pressure unknowns, the markers), so an equal split of the
// columns leaves one rank idle while the chute fills from the gate or the deposit grows at the
// wall. Here the box is split anew by the work of each column,
//
//     W_i = m_i + c_empty (nz - m_i),      m_i: Fluid and Surface cells of column i,
//
// (c_empty: the share of a cell's work that every cell costs, material or not: the flag rule,
// the viscosity and ghost loops), as prefix sums cut at r/R of the total. Every
// kBalanceInterval steps the load of the most loaded rank over the mean, max_r L_r / mean L, is
// measured; above kImbalanceTolerance the box is rebuilt on the new slabs from its own state
// (NdamState: the same export and import as a restart or a subdomain the domain manager
// resizes, so the step after a rebuild is the step after a restart). The decision reads only the
// flags (the same on every rank) and the step count, so a restart from a checkpoint (which holds
// the slab starts) repeats the straight run's rebuilds.
#include "stencil.hpp"

#include <algorithm>
#include <cmath>

namespace granflow::ndam {

using detail::Clock;
using detail::seconds_since;

namespace {
constexpr long kBalanceInterval = 10;       // steps between two checks
constexpr double kImbalanceTolerance = 1.1;  // rebuild when max load > 1.1 x the mean
// An empty cell costs this share of a material cell's work: an estimate, not a measurement
// (the solves and the markers, most of a step, run on the material cells only; the loops over
// all cells are a small part of the 'other' phase). The imbalance of the material cells alone
// that results is what summary.json reports.
constexpr double kEmptyCellWork = 0.05;

// max_r L_r / mean L of the split `starts` for the column work `w`
double imbalance(const std::vector<double>& w, const std::vector<int>& starts) {
  const int ranks = static_cast<int>(starts.size()) - 1;
  double total = 0.0, worst = 0.0;
  for (int r = 0; r < ranks; ++r) {
    double l = 0.0;
    for (int i = starts[static_cast<std::size_t>(r)]; i < starts[static_cast<std::size_t>(r) + 1]; ++i)
      l += w[static_cast<std::size_t>(i)];
    total += l;
    worst = std::max(worst, l);
  }
  return total > 0.0 ? worst * ranks / total : 1.0;
}
}  // namespace

std::vector<double> NdamSolver::column_work() const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  std::vector<double> w(static_cast<std::size_t>(nx), 0.0);
  for (int gi = 0; gi < nx; ++gi) {
    int m = 0;
    for (int k = 0; k < nz; ++k) m += mac_.fluid(gi, k) ? 1 : 0;
    w[static_cast<std::size_t>(gi)] = m + kEmptyCellWork * (nz - m);
  }
  return w;
}

// Cut the prefix sums of the work at r/R of the total, each rank keeping at least
// MacLayout::kMinColumns columns (the halo comes from the neighbour's owned columns).
std::vector<int> NdamSolver::balanced_starts(const std::vector<double>& w) const {
  const int nx = cfg_.grid.nx, ranks = mac_.slab.ranks, minc = MacLayout::kMinColumns;
  double total = 0.0;
  for (double x : w) total += x;
  std::vector<int> s(static_cast<std::size_t>(ranks) + 1, 0);
  s.back() = nx;
  double acc = 0.0;
  int i = 0;
  for (int r = 1; r < ranks; ++r) {
    const double target = total * r / ranks;
    // take columns while the prefix is closer to the target with the next one than without
    while (i < nx && acc + 0.5 * w[static_cast<std::size_t>(i)] < target) acc += w[static_cast<std::size_t>(i++)];
    const int lo = s[static_cast<std::size_t>(r) - 1] + minc, hi = nx - (ranks - r) * minc;
    s[static_cast<std::size_t>(r)] = std::clamp(i, lo, hi);
    while (i < s[static_cast<std::size_t>(r)]) acc += w[static_cast<std::size_t>(i++)];
    while (i > s[static_cast<std::size_t>(r)]) acc -= w[static_cast<std::size_t>(--i)];
  }
  return s;
}

bool NdamSolver::adapt() {
  const int ranks = mac_.slab.ranks;
  // the imbalance is measured with either 'Load balance' (summary.json), acted on with Material
  if (ranks == 1 || steps_ % kBalanceInterval != 0) return false;
  const auto t0 = Clock::now();
  const auto w = column_work();
  std::vector<int> now = slab_starts_;
  if (now.empty()) {
    now.assign(static_cast<std::size_t>(ranks) + 1, cfg_.grid.nx);
    for (int r = 0; r < ranks; ++r)
      now[static_cast<std::size_t>(r)] = Slab::split(cfg_.grid.nx, r, ranks).i0;
  }
  const double before = imbalance(w, now);
  ++stats_.balance_checks;
  stats_.imbalance_sum += before;
  stats_.imbalance_max = std::max(stats_.imbalance_max, before);
  bool rebuilt = false;
  if (cfg_.balance_material && before > kImbalanceTolerance &&
      cfg_.grid.nx >= MacLayout::kMinColumns * ranks) {
    const auto next = balanced_starts(w);
    // only a split that is clearly better (hysteresis: no rebuilds that win nothing)
    if (next != now && imbalance(w, next) < before - 0.5 * (kImbalanceTolerance - 1.0)) {
      rebuild_slabs(next);
      ++stats_.rebalances;
      rebuilt = true;
    }
  }
  stats_.rebalance_seconds += seconds_since(t0);
  return rebuilt;
}

// The same state on other slabs: what a restart does (export the state, build the layout and
// its linear systems, import the state), with the run's counters handed on.
void NdamSolver::rebuild_slabs(const std::vector<int>& starts) {
  const NdamState s = export_state();
  stats_ = statistics();  // the retiring linear systems' preconditioner work
  relayout(starts);
  import_state(s);
  assemble_pressure();
  flags_changed_ = false;
}

// The layout, fields, markers and linear systems of the slabs `starts` (empty: the equal split),
// without a state: import_state() follows.
void NdamSolver::relayout(const std::vector<int>& starts) {
  slab_starts_ = starts;
  mac_ = MacLayout(comm_, cfg_.grid, cfg_.periodic_x(), slab_starts_);
  has_obstacles_ = false;
  newton_.reset();  // built on the old map at the next step that needs it
  q_evaluated_.clear();
  setup();
}

}  // namespace granflow::ndam
