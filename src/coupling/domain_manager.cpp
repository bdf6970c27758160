// The domain manager (domain_manager.hpp): evaluates the shallowness indicators along the
// channel and moves the 1D-2D interfaces.
#include "granflow/coupling/domain_manager.hpp"

#include "granflow/dam/dam_solver.hpp"
#include "granflow/io/fields.hpp"
#include "granflow/ndam/ndam_solver.hpp"
#include "granflow/params/parameters.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <sstream>

#include <mpi.h>

namespace granflow::coupling {

namespace {
using Clock = std::chrono::steady_clock;
constexpr int kMoveFields = 15;  // numbers per move in the checkpoint
// 'Deceleration indicator' (target): the window on either side of a slot as a share of
// 'Margin' (1 cm of the default 5 cm; at least two slots; a length of the scene, so that a
// Froude-scaled scene is the scaled run), and the relative slowing and deepening between the
// two windows' means that mark it
constexpr double kSlowingWindowOfMargin = 0.2;
constexpr double kSlowingFraction = 0.02;

std::string describe(const std::vector<Subdomain>& parts) {
  std::ostringstream os;
  for (std::size_t i = 0; i < parts.size(); ++i)
    os << (i ? " | " : "") << parts[i].kind << " " << parts[i].x0 << " " << parts[i].x1;
  return os.str();
}

// A slot-index interval of one model.
struct Run {
  bool two_d = false;
  int s0 = 0, s1 = 0;  // slots [s0, s1)
};

std::vector<Run> runs(const std::vector<char>& two_d) {
  std::vector<Run> r;
  for (int s = 0; s < static_cast<int>(two_d.size()); ++s) {
    if (r.empty() || r.back().two_d != (two_d[static_cast<std::size_t>(s)] != 0))
      r.push_back(Run{two_d[static_cast<std::size_t>(s)] != 0, s, s + 1});
    else
      r.back().s1 = s + 1;
  }
  return r;
}
}  // namespace

DomainManager::DomainManager(const Decomposition& d,
                             std::shared_ptr<const SubdomainFactory> factory)
    : d_(d), factory_(std::move(factory)) {
  const double L = factory_->length(), dx1 = factory_->dx_1d();
  const double dx2 = factory_->has_2d() ? factory_->dx_2d() : dx1;
  slot_ = slot_width(dx1, dx2);
  const double ratio = slot_ / std::min(dx1, dx2);
  if (std::abs(ratio - std::round(ratio)) > 1e-6)
    throw params::InputError(
        "parameter 'granflow->Decomposition->Layout' = Dynamic needs grids with common nodes: "
        "the 2D column width L / (N-DAM->Cells x) = " + params::str(dx2) +
        " m and the 1D cell width L / (DAM->Cells) = " + params::str(dx1) +
        " m must be multiples of one another; allowed: e.g. DAM->Cells = 2 x N-DAM->Cells x");
  nslots_ = static_cast<int>(std::lround(L / slot_));
  // a length of the layout that must span at least n slots
  auto at_least_slots = [&](const char* name, double value, int n, const char* count,
                            const std::string& why) {
    if (value < n * slot_ - 1e-12)
      throw params::InputError("parameter 'granflow->Decomposition->" + std::string(name) +
                               "' = " + params::str(value) + " m is below " + count +
                               " slots of the Dynamic layout (" + std::to_string(n) + " x " +
                               params::str(slot_) + " m" + why + "); allowed: >= " +
                               params::str(n * slot_) + " m");
  };
  at_least_slots("Minimum length", d_.min_length, 4, "four",
                 ", the smallest subdomain either model is built with");
  // The DAM's two ghost cells at a 1D -> 2D interface take the 2D columns' state there, so a
  // margin below two slots lets the edge the margin is measured from (a shock, a deposit's toe)
  // into the DAM's stencil: an independent run (a gate pulse against a wall on 40 deg, 10 mm,
  // all-1D start) with Margin 0 or one slot had the thin tail's last DAM cell read the toe's
  // columns, gain their momentum (h 0.8 mm at 10.8 m/s, then 57 m/s) and stop with exit 3;
  // from two slots on it completed at the impact's 3.3 m/s.
  at_least_slots("Margin", d_.margin, 2, "two",
                 ": the DAM's two ghost cells at an interface read the 2D side, and a shock or a "
                 "deposit's toe inside them stops the run");
  // every interface on a node common to both grids (the scene snaps them): a move between an
  // interface off a node and the slot the manager rounds it to converts a sliver twice or not
  // at all, and the mass that made went unnoticed
  for (const double x : d_.interfaces)
    if (std::abs(x - std::round(x / slot_) * slot_) > 1e-12 * std::max(1.0, L))
      throw std::logic_error("domain manager: the initial interface at x = " + params::str(x) +
                             " m is not on a node common to both grids (multiples of " +
                             params::str(slot_) + " m)");
  calm_since_.assign(static_cast<std::size_t>(nslots_), -1.0);
  released_at_.assign(static_cast<std::size_t>(nslots_), -1.0);
  released_before_.assign(static_cast<std::size_t>(nslots_), -1.0);
}

// The hysteresis (the band between 'Lower threshold' and 'Shallowness threshold', and 'Hold
// time') is what keeps an interface from flickering, and a user may set it narrower than the
// indicator's noise: in steady flow the markers' depth scatters eps by a few per cent from
// column to column and check to check. An independent run with the band 0.09 - 0.1 and 'Hold
// time' = 'Check interval' moved the gate part's interface 0.16 <-> 0.165 m every 2-3 checks
// (61 moves in steady flow, each conserving mass), without a word. Such a run is counted and
// warned of, not refused: the thresholds are the user's to choose. A flicker is a column given
// back to the DAM (the change the hold governs) for the third time within kFlickerHolds hold
// times: a layout that follows the flow may give a column back and take it again once or
// twice (a gate part growing behind a front took a column, gave it back and took it again
// within 0.3 s in the suite's scenes), a flickering one does it again and again.
void DomainManager::book_changes(const std::vector<char>& cur, const std::vector<char>& tgt,
                                 double t) {
  for (int s = 0; s < nslots_; ++s) {
    const auto q = static_cast<std::size_t>(s);
    if (cur[q] == tgt[q] || tgt[q]) continue;  // only a release (2D -> 1D)
    const bool flicker =
        released_before_[q] >= 0.0 && t - released_before_[q] <= kFlickerHolds * d_.hold_time;
    released_before_[q] = released_at_[q];
    released_at_[q] = t;
    if (!flicker) continue;
    ++flickers_;
    if (flicker_t_ >= 0.0) continue;
    flicker_t_ = t;
    flicker_x_ = (s + 0.5) * slot_;
    int init = 0, rank = 0;
    MPI_Initialized(&init);
    if (init) MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    if (rank != 0) continue;
    std::ostringstream os;
    os << "granflow: warning: domain manager: the column at x = " << flicker_x_
       << " m went back to the 1D model for the third time within "
       << kFlickerHolds * d_.hold_time << " s at t = " << t
       << " s: the interface there flickers. The hysteresis between 'Lower threshold' ("
       << d_.eps_lower << ") and 'Shallowness threshold' (" << d_.eps_threshold
       << ") held for 'Hold time' (" << d_.hold_time
       << " s) is narrower than the indicator's noise; widen the band or raise 'Hold time' (the "
          "shipped scenes: 0.05 and 0.1, 0.05 s). summary.json counts these changes "
          "(domain_manager.flickers)\n";
    std::cerr << os.str();
  }
}

// beta = g cos(zeta) K_act: the DAM's wave speed is sqrt(beta h), eps = beta h / u^2
double DomainManager::wave_beta() const {
  const auto& ph = factory_->dam_physics();
  return ph.g_cos * ph.K_act;
}

std::vector<Piece> DomainManager::target(const CoupledModel& model) {
  const auto& parts = model.parts();
  const double t = model.time(), L = factory_->length();
  const ChannelField f = channel_field(parts, 0, parts.size());
  const double beta = wave_beta();
  // Material is where the depth reaches one row of 2D markers (a thinner layer, e.g. the tip
  // of a front, cannot be represented by the 2D model, and its eps says nothing about the
  // flow), and at least ten dry depths of the DAM (as the a priori layout).
  double h_wet = 10.0 * factory_->dam_config().dry_depth;
  if (factory_->has_2d()) {
    const auto& c = factory_->two_d().cfg;
    h_wet = std::max(h_wet, c.grid.dz() / c.markers_per_cell);
  }
  std::vector<core::Profile> prof(parts.size());
  for (std::size_t p = 0; p < parts.size(); ++p)
    if (parts[p].ndam) prof[p] = parts[p].ndam->profile();
  slots_.assign(static_cast<std::size_t>(nslots_), SlotState{});
  std::vector<char> wet(slots_.size(), 0);
  for (int s = 0; s < nslots_; ++s) {
    SlotState& q = slots_[static_cast<std::size_t>(s)];
    q.x0 = s * slot_;
    q.x1 = s + 1 == nslots_ ? L : (s + 1) * slot_;
    const double xc = 0.5 * (q.x0 + q.x1);
    const auto v = f.average(q.x0, q.x1);
    q.h = v[0];
    wet[static_cast<std::size_t>(s)] = q.h > h_wet;
    q.u_mean = wet[static_cast<std::size_t>(s)] ? v[1] / q.h : 0.0;
    std::size_t p = 0;
    while (p + 1 < parts.size() && xc > parts[p].x1) ++p;
    q.two_d = parts[p].ndam != nullptr;
    if (!wet[static_cast<std::size_t>(s)]) continue;
    q.eps = q.u_mean != 0.0 ? beta * q.h / (q.u_mean * q.u_mean)
                            : std::numeric_limits<double>::infinity();
    if (q.two_d) {
      // the paper's eps of the 2D model, |w_mean| / |u_mean| of the column at xc
      const auto& pr = prof[p];
      const double dx = parts[p].ndam->grid().dx();
      const auto c = static_cast<std::size_t>(
          std::clamp(static_cast<int>(std::floor((xc - parts[p].x0) / dx)), 0,
                     static_cast<int>(pr.eps.size()) - 1));
      q.eps = std::max(q.eps, pr.eps[c]);
    }
  }
  // shocks on the 1D side: u_mean drops across the slot by more than the wave speed
  for (int s = 1; s + 1 < nslots_; ++s) {
    SlotState& q = slots_[static_cast<std::size_t>(s)];
    // a front (a dry neighbour) is not a shock
    if (!d_.shock_indicator || q.two_d || !wet[static_cast<std::size_t>(s)] ||
        !wet[static_cast<std::size_t>(s - 1)] ||
        !wet[static_cast<std::size_t>(s + 1)])
      continue;
    const double du = slots_[static_cast<std::size_t>(s - 1)].u_mean -
                      slots_[static_cast<std::size_t>(s + 1)].u_mean;
    // a jump, not the gentle deceleration of roll waves: more than the wave speed, and to
    // less than half the upstream speed
    q.shock = du > std::sqrt(beta * q.h) &&
              std::abs(slots_[static_cast<std::size_t>(s + 1)].u_mean) <
                  0.5 * std::abs(slots_[static_cast<std::size_t>(s - 1)].u_mean);
  }
  // The upstream reach of a shock on the 2D side. Upstream of a jump the 2D model's pressure
  // slows the supercritical flow and deepens it over several depths of the deposit (a 42 deg
  // chute of 1.3 m/s: from 0.1 m upstream of the jump's steep face, where eps is still 0.02),
  // while the DAM, whose characteristics there all run downstream, carries the flow on at its
  // own speed into the interface: with 'Margin' 0.05 m the dynamic layout's u_mean was 4-7 %
  // off full 2D at 2.5 mm (an independent run, session 44; docs/validation.md). A steady flow
  // that slows keeps its discharge and so deepens, which the DAM does as well on a slope where
  // friction exceeds gravity; so the test applies only on slopes that accelerate a sliding
  // layer, where the DAM's supercritical flow speeds up and only the jump ahead slows it. A
  // front is not it (it thins towards its tip). Means over a window on either side of the slot
  // (a fifth of 'Margin', at least two slots: the markers' scatter of a single column's h is a
  // few per cent), inside one 2D subdomain and at least two slots from its upstream end (the
  // first 2D columns adjust to the DAM's inflow by about a per cent). The flow runs downslope
  // (+x) where the slope drives it.
  if (d_.deceleration_indicator) {
    const auto& ph = factory_->dam_physics();
    const bool driving = ph.g_sin > ph.g_cos * ph.tan_delta;
    const int w =
        std::max(2, static_cast<int>(std::lround(kSlowingWindowOfMargin * d_.margin / slot_)));
    auto part_of = [&](int s) {
      const double xc = (s + 0.5) * slot_;
      std::size_t p = 0;
      while (p + 1 < parts.size() && xc > parts[p].x1) ++p;
      return p;
    };
    for (int s = w + 2; driving && s + w <= nslots_; ++s) {
      const std::size_t p = part_of(s);
      if (!parts[p].ndam || part_of(s - w - 2) != p || part_of(s + w - 1) != p) continue;
      double u_up = 0.0, h_up = 0.0, u_dn = 0.0, h_dn = 0.0;
      bool all_wet = true;
      for (int r = s - w; r < s + w && all_wet; ++r) {
        const auto& q = slots_[static_cast<std::size_t>(r)];
        all_wet = wet[static_cast<std::size_t>(r)] != 0;
        (r < s ? u_up : u_dn) += q.u_mean;
        (r < s ? h_up : h_dn) += q.h;
      }
      if (!all_wet || !(u_up > w * d_.rest_speed)) continue;
      slots_[static_cast<std::size_t>(s)].slowing =
          u_dn < (1.0 - kSlowingFraction) * u_up && h_dn > (1.0 + kSlowingFraction) * h_up;
    }
  }
  std::vector<char> need(slots_.size(), 0), want(slots_.size(), 0), rest(slots_.size(), 0);
  for (int s = 0; s < nslots_; ++s) {
    SlotState& q = slots_[static_cast<std::size_t>(s)];
    rest[static_cast<std::size_t>(s)] =
        wet[static_cast<std::size_t>(s)] && std::abs(q.u_mean) < d_.rest_speed;
    q.needs_2d = wet[static_cast<std::size_t>(s)] &&
                 (q.eps >= d_.eps_threshold || rest[static_cast<std::size_t>(s)] || q.shock ||
                  q.slowing);
    need[static_cast<std::size_t>(s)] = q.needs_2d;
    want[static_cast<std::size_t>(s)] = q.two_d;
  }
  // 2D within 'Margin' of every slot that needs it
  const int reach = static_cast<int>(std::ceil(d_.margin / slot_ - 1e-9));
  std::vector<char> near(slots_.size(), 0);
  for (int s = 0; s < nslots_; ++s)
    if (need[static_cast<std::size_t>(s)])
      for (int r = std::max(0, s - reach); r <= std::min(nslots_ - 1, s + reach); ++r)
        near[static_cast<std::size_t>(r)] = 1;
  // calm: wet, outside the margin and eps below the lower threshold; a dry column is neither
  // (it keeps its model)
  for (int s = 0; s < nslots_; ++s) {
    SlotState& q = slots_[static_cast<std::size_t>(s)];
    const bool calm = wet[static_cast<std::size_t>(s)] && !near[static_cast<std::size_t>(s)] &&
                      q.eps < d_.eps_lower;
    double& since = calm_since_[static_cast<std::size_t>(s)];
    since = calm ? (since < 0.0 ? t : since) : -1.0;
  }
  for (int s = 0; s < nslots_; ++s)
    if (near[static_cast<std::size_t>(s)]) want[static_cast<std::size_t>(s)] = 1;
  // A 2D subdomain gives up calm columns from its ends only (its interfaces move; it does not
  // split where a calm column lies inside it), and is never cut below 'Minimum length'; one
  // that is calm all over becomes 1D as a whole.
  const int min_slots = static_cast<int>(std::ceil(d_.min_length / slot_ - 1e-9));
  auto releasable = [&](int s) {
    const auto q = static_cast<std::size_t>(s);
    return !near[q] && calm_since_[q] >= 0.0 && t - calm_since_[q] >= d_.hold_time - 1e-12;
  };
  // A 2D subdomain that holds a deposit (material at rest) or ends at a wall of the channel is
  // anchored: it gives back no columns on its upstream side (the side the flow comes from),
  // because the deposit grows upstream and the shock it reflects runs upstream through exactly
  // those columns. Giving them back makes the front meet the wall, and the shock start, through
  // a 1D-to-2D interface a few centimetres upstream of it (Setup II: the calm supercritical
  // layer in front of the wall went back to 1D before the impact, and behind the shock after
  // it, and each of those moves put the inflow's adjustment zone next to the shock;
  // docs/validation.md, "Runtime domain manager"). Its downstream end may still shrink.
  const auto& ch = factory_->channel();
  const bool wall_left = ch.left.type == core::BoundaryType::Wall;
  const bool wall_right = ch.right.type == core::BoundaryType::Wall;
  for (const Run& r : runs(want)) {
    if (!r.two_d) continue;
    bool anchored = (wall_left && r.s0 == 0) || (wall_right && r.s1 == nslots_);
    for (int q = r.s0; q < r.s1 && !anchored; ++q) anchored = rest[static_cast<std::size_t>(q)];
    bool all = !anchored;  // a subdomain calm all over goes as a whole
    for (int q = r.s0; q < r.s1 && all; ++q) all = releasable(q);
    if (all) {
      for (int q = r.s0; q < r.s1; ++q) want[static_cast<std::size_t>(q)] = 0;
      continue;
    }
    // the upstream side: where the mean flow at the subdomain's ends comes from
    const double u_lo = slots_[static_cast<std::size_t>(r.s0)].u_mean;
    const double u_hi = slots_[static_cast<std::size_t>(r.s1 - 1)].u_mean;
    const bool keep_lo = anchored && u_lo + u_hi >= 0.0;
    const bool keep_hi = anchored && u_lo + u_hi < 0.0;
    // 'Minimum length' counts the material the subdomain keeps (its wet slots), not only its
    // extent: a 2D part that a front has just entered holds the front and the dry box ahead of
    // it, and giving back the calm layer behind the front slot by slot left the 1D-to-2D
    // interface one or two columns behind the front, whose inflow profile (eq. 25) then came
    // from the front's own distorted column (with gravity 0, a layer that must translate at
    // the gate's 0.37 m/s reached 0.64 m/s; an independent run, docs/validation.md)
    int lo = r.s0, hi = r.s1;
    int wet_kept = 0;
    for (int q = lo; q < hi; ++q) wet_kept += wet[static_cast<std::size_t>(q)] ? 1 : 0;
    while (!keep_hi && hi - lo > min_slots && wet_kept > min_slots && releasable(hi - 1)) {
      want[static_cast<std::size_t>(--hi)] = 0;
      --wet_kept;  // (a releasable slot is wet)
    }
    while (!keep_lo && hi - lo > min_slots && wet_kept > min_slots && releasable(lo)) {
      want[static_cast<std::size_t>(lo++)] = 0;
      --wet_kept;
    }
  }
  // Minimum length: short 1D gaps and end pieces next to 2D become 2D; short new 2D subdomains
  // grow to the minimum (keeping the slots they have).
  for (int pass = 0; pass < 3; ++pass) {
    const auto rs = runs(want);
    for (std::size_t i = 0; i < rs.size(); ++i) {
      const Run& r = rs[i];
      if (r.s1 - r.s0 >= min_slots || rs.size() == 1) continue;
      if (!r.two_d) {
        for (int s = r.s0; s < r.s1; ++s) want[static_cast<std::size_t>(s)] = 1;
      } else {
        int lo = r.s0, hi = r.s1;
        while (hi - lo < min_slots) {
          if (lo > 0) --lo;
          if (hi - lo < min_slots && hi < nslots_) ++hi;
          if (lo == 0 && hi == nslots_) break;
        }
        for (int s = lo; s < hi; ++s) want[static_cast<std::size_t>(s)] = 1;
      }
    }
  }
  std::vector<Piece> out;
  for (const Run& r : runs(want))
    out.push_back(Piece{r.two_d ? "2D" : "1D", r.s0 * slot_, r.s1 == nslots_ ? L : r.s1 * slot_});
  return out;
}

bool DomainManager::adapt(CoupledModel& model) {
  const double t = model.time();
  if (t < next_check_ - 1e-12 * (1.0 + t)) return false;
  const auto t0 = Clock::now();
  next_check_ = (std::floor(t / d_.check_interval + 1e-9) + 1.0) * d_.check_interval;
  ++checks_;
  const std::vector<Piece> plan = target(model);
  // The next check comes before any signal can cross the margin that keeps a shock or a rise
  // of eps inside 2D: no wave (and no shock, whose speed lies between the characteristic
  // speeds) moves faster than |u_mean| + sqrt(beta h) of the channel, so a point can travel at
  // most max(Margin, one slot) before the next check. 'Check interval' is the longest gap. Before,
  // a long interval (0.2 s, allowed) let the reflected shock reach a 1D-to-2D interface and
  // pile up there unnoticed (u_mean L2 26 % against full 2D at 1.5 s; an independent run). At
  // the shipped scenes' margin of 5 cm the signal needs 10-15 ms, the interval is 5 ms.
  // The gate counts as well, with the fastest and deepest rows of its series: on a chute that
  // is still empty at a check nothing else bounds the next one, and a long interval (10 s,
  // allowed) then held the layout of t = 0 for the whole run while the shock piled up at an
  // interface (eps 0.14 in the last 1D cell against the threshold 0.1; an independent run).
  {
    const double beta = wave_beta();
    double s_max = 0.0;
    for (const SlotState& q : slots_)
      if (q.h > 0.0) s_max = std::max(s_max, std::abs(q.u_mean) + std::sqrt(beta * q.h));
    const core::BoundarySpec& gate = factory_->channel().left;
    if (gate.type == core::BoundaryType::Inflow)
      s_max = std::max(s_max, gate.inflow.max_speed() +
                                  std::sqrt(beta * std::max(0.0, gate.inflow.max_depth())));
    if (s_max > 0.0) {
      const double by_speed = t + std::max(d_.margin, slot_) / s_max;
      if (by_speed < next_check_) {
        next_check_ = by_speed;
        ++checks_by_speed_;
      }
    }
  }
  const auto& parts = model.parts();
  // current and target model per slot
  auto slot_of = [&](double x) { return static_cast<int>(std::lround(x / slot_)); };
  std::vector<char> cur(static_cast<std::size_t>(nslots_), 0), tgt(cur.size(), 0);
  for (const auto& p : parts)
    for (int s = slot_of(p.x0); s < slot_of(p.x1); ++s) cur[static_cast<std::size_t>(s)] = p.ndam != nullptr;
  for (const auto& p : plan)
    for (int s = slot_of(p.x0); s < slot_of(p.x1); ++s) tgt[static_cast<std::size_t>(s)] = p.kind == "2D";
  int sa = -1, sb = -1;
  for (int s = 0; s < nslots_; ++s)
    if (cur[static_cast<std::size_t>(s)] != tgt[static_cast<std::size_t>(s)]) {
      if (sa < 0) sa = s;
      sb = s;
    }
  seconds_checks_ += std::chrono::duration<double>(Clock::now() - t0).count();
  if (sa < 0) return false;
  const auto t1 = Clock::now();
  // the parts that hold the changed slots, and neighbours they merge with
  auto part_of = [&](int s) {
    std::size_t p = 0;
    while (p + 1 < parts.size() && slot_of(parts[p].x1) <= s) ++p;
    return p;
  };
  std::size_t first = part_of(sa), last = part_of(sb);
  std::vector<Piece> sub;
  for (;;) {
    const int s0 = slot_of(parts[first].x0), s1 = slot_of(parts[last].x1);
    sub.clear();
    for (const Run& r : runs(tgt)) {
      const int a = std::max(r.s0, s0), b = std::min(r.s1, s1);
      if (b > a) sub.push_back(Piece{r.two_d ? "2D" : "1D", a * slot_, b * slot_});
    }
    // the ends keep the exact positions of the parts they replace
    sub.front().x0 = parts[first].x0;
    sub.back().x1 = parts[last].x1;
    for (auto& p : sub)
      for (const auto& q : parts) {
        if (slot_of(q.x0) == slot_of(p.x0)) p.x0 = q.x0;
        if (slot_of(q.x1) == slot_of(p.x1)) p.x1 = q.x1;
      }
    bool grown = false;
    if (first > 0 && (parts[first - 1].ndam != nullptr) == (sub.front().kind == "2D")) {
      --first;
      grown = true;
    }
    if (last + 1 < parts.size() && (parts[last + 1].ndam != nullptr) == (sub.back().kind == "2D")) {
      ++last;
      grown = true;
    }
    if (!grown) break;
  }
  Move mv;
  mv.t = t;
  mv.before = describe(parts);
  model.settle_interfaces();  // the reconnected interfaces start with nothing carried
  // A 2D gate part holds the gate's fractional markers: inflow that has passed the gate but is
  // not yet in the fields nor in the part's booked inflow. If the rebuilt gate part is not a 2D
  // part from the same gate, the conversion hands that mass on (to the next 2D part's inflow or
  // into a DAM), and the run books it as inflow here. Found by a hostile-user run: the gate
  // part turned 1D and the ledger was 3.0e-5 m^2 (1.7e-3) short of the fields, which held
  // h_in u_in t exactly.
  const double gate_pending =
      first == 0 && parts.front().ndam ? parts.front().ndam->inflow_pending() : 0.0;
  auto rebuilt = rebuild(parts, first, last - first + 1, sub, *factory_, mv.record);
  // a 2D part at the gate again keeps the old one's accumulators (the rebuilt ends keep their
  // positions): nothing was handed on
  const bool gate_kept = rebuilt.front().ndam != nullptr;
  const double xa = parts[first].x0, xb = parts[last].x1;
  const std::size_t built = rebuilt.size();
  model.replace_parts(first, last - first + 1, std::move(rebuilt));
  // the rebuilt 2D parts, their interfaces connected: divergence-free before the next step
  for (std::size_t p = first; p < first + built; ++p)
    if (model.parts()[p].ndam)
      mv.record.divergence_removed =
          std::max(mv.record.divergence_removed, model.parts()[p].ndam->remove_divergence());
  if (first == 0 && !gate_kept) model.book_gate_inflow(gate_pending);
  model.place_settle_leftovers();
  // The momentum after the move, of the parts as they now run: rebuild() measured the new 2D
  // parts before their interfaces were connected, when a new part's inflow face still held 0,
  // so a column next to it counted half its momentum (-0.5 to -0.9 % per move in the ledger
  // while profiles.csv at the move's time said -0.014 %; an independent run).
  mv.record.momentum_after =
      channel_field(model.parts(), 0, model.parts().size()).integral(xa, xb)[1];
  // what no part took stays in the run's ledger
  model.book_unplaced(mv.record.remainder_unplaced + mv.record.pending_lost);
  mv.after = describe(model.parts());
  mv.seconds = std::chrono::duration<double>(Clock::now() - t1).count();
  log_.push_back(mv);
  book_changes(cur, tgt, t);
  // A move conserves mass to round-off once its remainders are booked (docs/numerics.md,
  // "Conversion"); anything more is a fault of the conversion, and a run that went on would
  // report a wrong ledger as "completed". 1e-9 of the channel's mass is far above the round-off
  // of summing its markers (1e-17 m^2 per move measured) and far below one marker.
  const double total = std::abs(model.mass_balance().current);
  if (!(std::abs(mv.record.defect()) <= 1e-9 * total + 1e-15))
    throw std::runtime_error("domain manager: the move at t = " + params::str(t) + " s from '" +
                             mv.before + "' to '" + mv.after + "' changed the mass by " +
                             params::str(mv.record.defect()) + " m^2 (" +
                             params::str(mv.record.defect() / std::max(total, 1e-300)) +
                             " of the channel's); a move must conserve it to round-off");
  return true;
}

void DomainManager::save(io::Checkpoint& c) const {
  c.set("manager/calm_since", calm_since_);
  c.set("manager/released_at", released_at_);
  c.set("manager/released_before", released_before_);
  c.set("manager/flickers", static_cast<double>(flickers_));
  c.set("manager/flicker_t", flicker_t_);
  c.set("manager/flicker_x", flicker_x_);
  c.set("manager/next_check", next_check_);
  c.set("manager/checks", static_cast<double>(checks_));
  c.set("manager/checks_brought_forward", static_cast<double>(checks_by_speed_));
  std::vector<double> rec;
  for (const auto& m : log_)
    rec.insert(rec.end(), {m.t, m.record.mass_before, m.record.mass_after,
                           m.record.momentum_before, m.record.momentum_after, m.record.remainder,
                           m.record.remainder_given_back, m.record.remainder_to_inflow,
                           static_cast<double>(m.record.columns_to_2d),
                           static_cast<double>(m.record.columns_to_1d), m.seconds,
                           m.record.pending_to_1d, m.record.pending_lost,
                           m.record.remainder_unplaced, m.record.divergence_removed});
  c.set("manager/moves", rec);
  c.set("manager/move_fields", static_cast<double>(kMoveFields));
  // the layouts before and after each move, one line each (a restart read "(before the
  // restart)" for them)
  std::string before, after;
  for (const auto& m : log_) {
    before += m.before + "\n";
    after += m.after + "\n";
  }
  c.set_text("manager/moves_before", before);
  c.set_text("manager/moves_after", after);
}

void DomainManager::load(const io::Checkpoint& c) {
  calm_since_ = c.array("manager/calm_since");
  if (calm_since_.size() != static_cast<std::size_t>(nslots_))
    throw params::InputError("checkpoint: the domain manager's slots (" +
                             std::to_string(calm_since_.size()) + ") do not match the scene (" +
                             std::to_string(nslots_) + ")");
  // checkpoints written before the flicker count have none of it (a restart from one counts
  // from the restart on)
  if (c.has_scalar("manager/flickers")) {
    released_at_ = c.array("manager/released_at");
    released_before_ = c.array("manager/released_before");
    if (released_at_.size() != calm_since_.size() || released_before_.size() != calm_since_.size())
      throw params::InputError("checkpoint: the domain manager's release times do not match "
                               "its slots");
    flickers_ = static_cast<long>(c.scalar("manager/flickers"));
    flicker_t_ = c.scalar("manager/flicker_t");
    flicker_x_ = c.scalar("manager/flicker_x");
  }
  next_check_ = c.scalar("manager/next_check");
  checks_ = static_cast<long>(c.scalar("manager/checks"));
  checks_by_speed_ = c.has_scalar("manager/checks_brought_forward")
                         ? static_cast<long>(c.scalar("manager/checks_brought_forward"))
                         : 0;
  const auto& rec = c.array("manager/moves");
  log_.clear();
  // checkpoints written before the pending-inflow fields have 11 numbers per move
  const auto stride = static_cast<std::size_t>(
      c.has_scalar("manager/move_fields") ? c.scalar("manager/move_fields") : 11.0);
  for (std::size_t i = 0; i + stride <= rec.size(); i += stride) {
    Move m;
    m.t = rec[i];
    m.record.mass_before = rec[i + 1];
    m.record.mass_after = rec[i + 2];
    m.record.momentum_before = rec[i + 3];
    m.record.momentum_after = rec[i + 4];
    m.record.remainder = rec[i + 5];
    m.record.remainder_given_back = rec[i + 6];
    m.record.remainder_to_inflow = rec[i + 7];
    m.record.columns_to_2d = static_cast<int>(rec[i + 8]);
    m.record.columns_to_1d = static_cast<int>(rec[i + 9]);
    m.seconds = rec[i + 10];
    if (stride >= 13) {
      m.record.pending_to_1d = rec[i + 11];
      m.record.pending_lost = rec[i + 12];
    }
    if (stride >= 14) m.record.remainder_unplaced = rec[i + 13];
    if (stride >= 15) m.record.divergence_removed = rec[i + 14];
    m.before = m.after = "(before the restart)";
    log_.push_back(m);
  }
  if (c.has_text("manager/moves_before") && c.has_text("manager/moves_after")) {
    std::istringstream b(c.text("manager/moves_before")), a(c.text("manager/moves_after"));
    for (auto& m : log_) {
      std::string lb, la;
      if (!std::getline(b, lb) || !std::getline(a, la)) break;
      m.before = lb;
      m.after = la;
    }
  }
}

void DomainManager::report(nlohmann::json& s) const {
  nlohmann::json moves = nlohmann::json::array();
  double sec = 0.0, worst = 0.0;
  for (const auto& m : log_) {
    const double defect = m.record.defect();
    worst = std::max(worst, std::abs(defect));
    sec += m.seconds;
    moves.push_back({{"t", m.t},
                     {"before", m.before},
                     {"after", m.after},
                     {"mass_before", m.record.mass_before},
                     {"mass_after", m.record.mass_after},
                     {"mass_defect", m.record.defect()},
                     {"momentum_before", m.record.momentum_before},
                     {"momentum_after", m.record.momentum_after},
                     {"marker_remainder", m.record.remainder},
                     {"remainder_given_back", m.record.remainder_given_back},
                     {"remainder_to_inflow", m.record.remainder_to_inflow},
                     {"remainder_unplaced", m.record.remainder_unplaced},
                     {"pending_inflow_to_1d", m.record.pending_to_1d},
                     {"pending_inflow_lost", m.record.pending_lost},
                     {"columns_to_2d", m.record.columns_to_2d},
                     {"columns_to_1d", m.record.columns_to_1d},
                     {"divergence_removed", m.record.divergence_removed},
                     {"seconds", m.seconds}});
  }
  s["domain_manager"] = {{"slot_width", slot_},
                         {"checks", checks_},
                         {"checks_brought_forward", checks_by_speed_},
                         {"moves", static_cast<long long>(log_.size())},
                         {"largest_mass_defect_of_a_move", worst},
                         {"flickers", flickers_},
                         {"first_flicker",
                          flicker_t_ >= 0.0
                              ? nlohmann::json{{"t", flicker_t_}, {"x", flicker_x_}}
                              : nlohmann::json(nullptr)},
                         {"seconds_checks", seconds_checks_},
                         {"seconds_moves", sec},
                         {"log", moves}};
}

}  // namespace granflow::coupling
