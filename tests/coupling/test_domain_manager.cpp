// The runtime domain manager (Decomposition->Layout = Dynamic) and the conservative state
// conversion it moves interfaces with, on coarse chutes (10 mm cells) built through the XML scene
// interface.
#include "granflow/coupling/conversion.hpp"
#include "granflow/coupling/coupled_model.hpp"
#include "granflow/coupling/domain_manager.hpp"
#include "granflow/coupling/factory.hpp"
#include "granflow/dam/dam_solver.hpp"
#include "granflow/ndam/ndam_solver.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <functional>

#include "chute_scene.hpp"

using namespace granflow;
using namespace granflow::test;

namespace {

coupling::CoupledModel& coupled_mut(core::Stepper& s) {
  return dynamic_cast<coupling::CoupledModel&>(s);
}

// Moves the interfaces of `m` to the layout `plan` (the whole channel) as the manager does.
coupling::ConversionRecord move_to(coupling::CoupledModel& m, const std::vector<coupling::Piece>& plan) {
  coupling::ConversionRecord rec;
  auto parts = coupling::rebuild(m.parts(), 0, m.parts().size(), plan, *m.factory(), rec);
  m.replace_parts(0, m.parts().size(), std::move(parts));
  return rec;
}

// |u_mean| jump across each interface: first column downstream against last upstream, relative.
double interface_jump(const core::Stepper& s) {
  const auto& c = coupled(s);
  const auto p = s.profile();
  double worst = 0.0;
  for (std::size_t i = 0; i < c.interfaces(); ++i) {
    const double x = c.interface(i).x();
    std::size_t k = 0;
    while (k + 1 < p.x.size() && p.x[k + 1] < x) ++k;
    if (p.h[k] < 1e-3 || p.h[k + 1] < 1e-3) continue;
    worst = std::max(worst, std::abs(p.u_mean[k + 1] - p.u_mean[k]) / std::abs(p.u_mean[k]));
  }
  return worst;
}

// The driver's loop (core::Simulation): step, check, accept, then the layout may change.
void run_adaptive(core::Stepper& s, double t_end, const std::function<void()>& after_move = {}) {
  while (s.time() < t_end - 1e-12) {
    s.step(std::min(s.stable_dt(), t_end - s.time()));
    const auto h = s.check();
    ASSERT_TRUE(h.ok) << h.reason << " at x = " << h.x;
    s.accept();
    const bool moved = s.adapt();
    if (moved && after_move) after_move();
  }
}

Chute dynamic(const std::string& name, const std::string& extra = "") {
  Chute c;
  c.name = name;
  c.layout = "Dynamic";
  c.decomposition_extra = extra;
  return c;
}

std::string param(const std::string& name, const std::string& type, const std::string& value) {
  return "\n    <Parameter name=\"" + name + "\" type=\"" + type + "\" value=\"" + value + "\"/>";
}

// The manager's settings: thresholds (upper, lower), Margin, Minimum length, Hold time, Check
// interval.
std::string manager(const char* upper, const char* lower, const char* margin,
                    const char* min_length, const char* hold, const char* check) {
  return param("Shallowness threshold", "double", upper) +
         param("Lower threshold", "double", lower) + param("Margin", "double", margin) +
         param("Minimum length", "double", min_length) + param("Hold time", "double", hold) +
         param("Check interval", "double", check);
}

// The shock of Setup II: the upstream end of the material at rest (|u_mean| < 0.05 m/s, deeper
// than 1 mm) that reaches the wall; L when there is none yet.
double shock_position(const core::Profile& p, double L) {
  double x = L;
  for (std::size_t i = p.x.size(); i-- > 0;) {
    if (!(p.h[i] > 1e-3 && std::abs(p.u_mean[i]) < 0.05)) break;
    x = p.x[i] - 0.5 * (p.x[1] - p.x[0]);
  }
  return x;
}

}  // namespace

// Thresholds that never ask for a move (eps never reaches 1e6, never drops below 0, no rest
// speed, no shock or deceleration indicator) leave the static layout in place: the dynamic run
// IS the static run, operation for operation, so the profiles agree bit for bit.
TEST(DomainManager, NeverMovingThresholdsReproduceTheStaticRunBitForBit) {
  Chute st;
  st.name = "dm_static";
  st.wall = true;
  st.end_time = 0.6;
  Chute dy = dynamic("dm_never", param("Shallowness threshold", "double", "1e6") +
                                     param("Lower threshold", "double", "0") +
                                     param("Rest speed", "double", "0") +
                                     param("Shock indicator", "bool", "false") +
                                     param("Deceleration indicator", "bool", "false"));
  dy.wall = true;
  dy.end_time = 0.6;
  auto a = st.build();
  auto b = dy.build();
  ASSERT_NE(coupled(*b).domain_manager(), nullptr);
  b->adapt();
  run(*a, 0.6);
  run_adaptive(*b, 0.6);
  EXPECT_EQ(coupled(*b).domain_manager()->moves(), 0);
  EXPECT_GT(coupled(*b).domain_manager()->checks(), 100);  // it did look, every 5 ms
  const auto pa = a->profile(), pb = b->profile();
  ASSERT_EQ(pa.x.size(), pb.x.size());
  double hmax = 0.0;
  for (std::size_t i = 0; i < pa.x.size(); ++i) {
    EXPECT_EQ(pa.h[i], pb.h[i]) << "x = " << pa.x[i];
    EXPECT_EQ(pa.u_mean[i], pb.u_mean[i]) << "x = " << pa.x[i];
    hmax = std::max(hmax, pa.h[i]);
  }
  EXPECT_GT(hmax, 0.01);  // material has reached the wall: not an empty comparison
  EXPECT_EQ(a->steps(), b->steps());
}

// A margin as long as the channel makes every column 2D at the first check that sees material
// (the gate's first column, eps = 1/Fr^2 ~ 1.7): from then on the run is the full 2D model.
TEST(DomainManager, AllTwoDThresholdsReproduceTheFull2DRun) {
  Chute full;
  full.name = "dm_full";
  full.model = "N-DAM";
  full.wall = true;
  full.end_time = 0.6;
  Chute dy = dynamic("dm_all2d", param("Margin", "double", "2"));
  dy.wall = true;
  dy.end_time = 0.6;
  Chute other = full;  // the same full 2D run at another CFL number: the run-to-run spread
  other.name = "dm_full_cfl";
  other.cfl = 0.45;
  auto a = full.build();
  auto b = dy.build();
  auto o = other.build();
  b->adapt();
  run(*a, 0.6);
  run(*o, 0.6);
  run_adaptive(*b, 0.6);
  const auto po = o->profile(), pr = a->profile();
  // the chute upstream of the wall's last 0.1 m: the columns where the layer meets the wall at
  // this time are excluded (below)
  auto chute = [](const core::Profile& p) {
    std::vector<double> h = p.h;
    for (std::size_t q = 0; q < h.size(); ++q)
      if (p.x[q] >= 0.9) h[q] = 0.0;
    return h;
  };
  const double sh = rel_l2(pr.h, po.h, chute(pr), 1e-3),
               su = rel_l2(pr.u_mean, po.u_mean, chute(pr), 1e-3);
  std::printf("[measured] full 2D at CFL 0.45 vs 0.5 on x < 0.9 m: h L2 %.3e, u_mean L2 %.3e "
              "(whole channel %.3e, %.3e)\n",
              sh, su, rel_l2(pr.h, po.h, pr.h, 1e-3), rel_l2(pr.u_mean, po.u_mean, pr.h, 1e-3));
  ASSERT_EQ(coupled(*b).parts().size(), 1u);
  EXPECT_EQ(coupled(*b).parts()[0].kind, "2D");
  const auto pa = a->profile(), pb = b->profile();
  ASSERT_EQ(pa.x.size(), pb.x.size());
  const double eh = rel_l2(pa.h, pb.h, chute(pa), 1e-3),
               eu = rel_l2(pa.u_mean, pb.u_mean, chute(pa), 1e-3);
  std::printf("[measured] all-2D dynamic vs full 2D at t = 0.6 s on x < 0.9 m: h L2 %.3e, "
              "u_mean L2 %.3e (whole channel %.3e, %.3e); moves %ld\n",
              eh, eu, rel_l2(pa.h, pb.h, pa.h, 1e-3), rel_l2(pa.u_mean, pb.u_mean, pa.h, 1e-3),
              coupled(*b).domain_manager()->moves());
  // The two runs differ only in the first step before the check that turns everything 2D (the
  // gate part rebuilt once as the whole box). The marker method turns any difference into
  // whole markers crossing cell edges (one marker is 6 % of h in a 1 cm layer at 10 mm), so the
  // measure of "the same run" is the model's own spread under a change of time step: the
  // dynamic run must be at least as close to full 2D as full 2D at CFL 0.45 is (measured: h
  // 4.5 % against 7.4 %, u_mean 0.2 % against 0.7 %, on the whole channel). Since the bed
  // does not carry the surface's viscous traction (2026-12-06) the layer reaches the wall by
  // 0.6 s, and the wall-impact cells, whose speed moves with the step sequence (docs/
  // validation.md, "Stability suite"), made the whole channel's u_mean differ by 2.9 % against
  // a CFL spread of 1.3 %, the chute upstream agreeing to 0.1-0.5 % column by column: so the
  // comparison is the chute upstream of the wall's last 0.1 m.
  EXPECT_LE(eh, sh);
  EXPECT_LE(eu, su);
}

// Setup II with the dynamic layout, probed every millisecond: the moves and their mass
// defects, where the shock is against the parts, whether a check leaves a slot that needs 2D in
// 1D, and whether the 2D part at the wall ever gives columns back on its upstream side.
struct SetupTwoProbe {
  long moves = 0, uncovered = 0, shock_steps = 0, shock_in_1d = 0, wall_part_released = 0;
  long checks = 0;
  // probes whose last check asked for 2D somewhere, and at the wall's slot (the deposit)
  long probes_needing_2d = 0, probes_wall_needing_2d = 0;
  double worst_move_defect = 0.0, run_defect = 0.0, mass = 0.0;
  double worst_momentum_change = 0.0;  // |after - before| / |before| of a move's record
  double first_shock_t = -1.0, last_shock_in_1d_t = -1.0;  // [s]
  // first probe with material at rest at the wall deep enough for the manager to count it
  // (one row of 2D markers: dz / 4 = 2.5 mm on the 10 mm grid; a thinner layer is no material
  // to it, DomainManager::target) [s]
  double first_wet_rest_t = -1.0;
  double wall_part_x0 = 1.0;  // upstream end of the 2D part at the wall at the end [m]
};

// Setup II (wall at 1 m) with the dynamic layout from `models` / `interfaces`, to `end` s.
Chute setup_two_dynamic(const std::string& name, const std::string& models,
                        const std::string& interfaces, double end) {
  Chute dy = dynamic(name, param("Hold time", "double", "0.02"));
  dy.models = models;
  dy.interfaces = interfaces;
  dy.wall = true;
  dy.end_time = end;
  return dy;
}

SetupTwoProbe probe_setup_two(Chute dy) {
  SetupTwoProbe r;
  auto b = dy.build();
  auto& c = coupled_mut(*b);
  const auto* dm = c.domain_manager();
  EXPECT_NE(dm, nullptr);
  auto wall_x0 = [&] { return !c.parts().back().one_d() ? c.parts().back().x0 : 1.0; };
  r.wall_part_x0 = wall_x0();
  auto after_move = [&] {
    // the part at the wall is anchored: once it exists it only grows upstream
    if (wall_x0() > r.wall_part_x0 + 1e-9 && r.wall_part_x0 < 1.0) ++r.wall_part_released;
    r.wall_part_x0 = wall_x0();
    // every slot that needs 2D lies in a 2D part of the new layout
    for (const auto& q : dm->last_check()) {
      if (!q.needs_2d) continue;
      const double xc = 0.5 * (q.x0 + q.x1);
      for (const auto& p : c.parts())
        if (xc > p.x0 && xc < p.x1 && p.one_d()) ++r.uncovered;
    }
  };
  b->adapt();
  while (b->time() < dy.end_time - 1e-12) {
    run_adaptive(*b, std::min(dy.end_time, b->time() + 1e-3), after_move);
    // the layout between checks is the one the last check left: every slot that it found
    // needing 2D must lie in a 2D part now, whether or not that check moved anything (issue
    // 10 item 9: eps below the upper threshold in every 1D cell at every check; the checks
    // come every 5 ms, the probes every 1 ms)
    bool needing = false;
    for (const auto& q : dm->last_check()) {
      if (!q.needs_2d) continue;
      needing = true;
      if (q.x1 > 1.0 - 1e-9) ++r.probes_wall_needing_2d;
      const double xc = 0.5 * (q.x0 + q.x1);
      for (const auto& p : c.parts())
        if (xc > p.x0 && xc < p.x1 && p.one_d()) ++r.uncovered;
    }
    if (needing) ++r.probes_needing_2d;
    const auto prof = b->profile();
    const double xs = shock_position(prof, 1.0);
    if (r.first_wet_rest_t < 0.0 && prof.h.back() > 0.0025 && std::abs(prof.u_mean.back()) < 0.05)
      r.first_wet_rest_t = b->time();
    if (xs < 1.0) {
      if (r.first_shock_t < 0.0) r.first_shock_t = b->time();
      ++r.shock_steps;
      for (const auto& p : c.parts())
        if (p.one_d() && xs < p.x1 + 1e-9 && xs > p.x0 - 1e-9) {
          ++r.shock_in_1d;
          r.last_shock_in_1d_t = b->time();
        }
    }
  }
  nlohmann::json rep;
  b->report(rep);
  for (const auto& m : rep["coupled"]["domain_manager"]["log"]) {
    r.worst_move_defect = std::max(r.worst_move_defect, std::abs(m["mass_defect"].get<double>()));
    const double mb = m["momentum_before"].get<double>(), ma = m["momentum_after"].get<double>();
    if (std::abs(mb) > 0.0)
      r.worst_momentum_change = std::max(r.worst_momentum_change, std::abs(ma - mb) / std::abs(mb));
  }
  const auto mb = b->mass_balance();
  r.moves = dm->moves();
  r.checks = dm->checks();
  r.run_defect = mb.defect();
  r.mass = mb.current;
  std::printf("[measured] %s, 10 mm, %g s: %ld moves in %ld checks, largest mass defect of a move "
              "%.2e m^2, run defect %.3e of %.5f m^2; shock from %.3f s, seen at %ld probes, %ld "
              "of them in 1D (last at %.3f s; wall at rest and wet from %.3f s); wall part from %.3f m, "
              "released %ld times; largest momentum change of a move %.2e; 2D asked at %ld "
              "probes, at the wall's slot at %ld\n",
              dy.name.c_str(), dy.end_time, r.moves, dm->checks(), r.worst_move_defect,
              r.run_defect, r.mass, r.first_shock_t, r.shock_steps, r.shock_in_1d,
              r.last_shock_in_1d_t, r.first_wet_rest_t, r.wall_part_x0, r.wall_part_released,
              r.worst_momentum_change, r.probes_needing_2d, r.probes_wall_needing_2d);
  return r;
}

// From the paper's layout: the shock is inside 2D at every probe after the impact, no 1D column
// is left that the indicator asks to be 2D after a check, and the part at the wall keeps its
// upstream columns (before the impact the calm supercritical layer there would otherwise go back
// to 1D, and the front would meet the wall through an interface a few cm upstream of it).
// The shock stays inside the paper's wall part [0.7, 1] m to 0.75 s anyway (it is at 0.95 m then),
// so what makes this a test of the manager, and not of a manager that never acts: it checked
// every 5 ms (150 checks in 0.75 s), its indicator asked for 2D at the wall's slot once the
// deposit formed, every slot it asked for lay in 2D at every probe, and it made the scene's one
// move (the gate part gives back its calm columns at about 0.3 s; measured 1 move in 151 checks).
TEST(DomainManager, SetupTwoShockStaysInsideTwoD) {
  const auto r = probe_setup_two(setup_two_dynamic("dm_setup2", "2D, 1D, 2D", "0.2, 0.7", 0.75));
  EXPECT_GT(r.shock_steps, 50);  // the wall was hit and the shock travelled
  EXPECT_GE(r.checks, 149);      // 0.75 s / 5 ms, less the rounding of the last check time
  EXPECT_GE(r.moves, 1);
  EXPECT_GT(r.probes_wall_needing_2d, 50);  // from the front's arrival (0.57 s): measured 181
  EXPECT_EQ(r.shock_in_1d, 0);
  EXPECT_EQ(r.uncovered, 0);
  EXPECT_EQ(r.wall_part_released, 0);
  EXPECT_LE(r.wall_part_x0, 0.7 + 1e-9);
  EXPECT_LT(r.worst_move_defect, 1e-15);
}

// The upstream reach of a shock lies in 2D ('Deceleration indicator'). On an independent
// tester's chute (Setup II's material and gate on 42 deg, 0.6 m to a wall, box 0.25 m, the
// layout 2D [0, 0.15] / 1D / 2D [0.4, 0.6] m) the shock climbing from the wall is gradual: in
// full 2D the flow begins to slow about 0.1 m upstream of its steep face, where eps is still
// about 0.02, and the DAM, whose supercritical flow takes no information from downstream,
// carries its speed into the interface (at 2.5 mm u_mean 4.4 / 6.8 % off full 2D at 1.25 /
// 1.5 s; with the indicator 2.8 / 1.8 %). Asserted at 5 mm, probes every 0.05 s from 1.0 to
// 1.5 s (after the shock has formed), against full 2D of the same scene: the gap from the
// dynamic run's last 1D slot to where the full run's flow begins to slow (its fastest wet
// column beyond the gate part), its smallest value over the probes. With the Full cell (the
// default until session 45) the indicator kept that gap at 2.2-4.7 cm (-0.3 to +0.8 cm
// without it). With the Material share (the default since) the 2D chute is slower than the DAM
// and full 2D slows earlier: measured +1.8 / +1.8 / -0.3 / -2.3 / -1.8 / -0.8 cm at 1.0-1.25 s
// with the indicator (no 1D part from 1.3 s: the gap to the gate part fell below 'Minimum
// length'), -1.8 to -5.8 cm without it to 1.35 s. Asserted: with the indicator the 1D part
// reaches at most 2.5 cm (five columns) into the slowing, and at least 2 cm less far than
// without it (the scene needs the indicator: were its eps or margin to cover the slowing, this
// test would not test it). The reach that full 2D shows is not fully in 2D with the share
// (issue 10, docs/validation.md, "The material share as the default"). About 25 s.
TEST(DomainManager, UpstreamReachOfAShockLiesInTwoD) {
  auto scene = [](const std::string& name, const std::string& model, const std::string& extra) {
    Chute c = dynamic(name, extra);
    c.model = model;
    c.length = 0.6;
    c.slope = 42.0;
    c.cell = 0.005;
    c.height = 0.25;
    c.wall = true;
    c.interfaces = "0.15, 0.4";
    c.end_time = 1.5;
    return c;
  };
  std::vector<double> probes;
  for (int j = 0; j <= 10; ++j) probes.push_back(1.0 + 0.05 * j);
  // full 2D: where the flow begins to slow at each probe
  std::vector<double> slowing_from;
  {
    auto full = scene("dm_reach_full", "N-DAM", "").build();
    for (const double t : probes) {
      run(*full, t);
      const auto pr = full->profile();
      double umax = -1.0, x_peak = 0.0;
      for (std::size_t i = 0; i < pr.x.size(); ++i)
        if (pr.h[i] > 0.003 && pr.x[i] > 0.15 && pr.u_mean[i] > umax) {
          umax = pr.u_mean[i];
          x_peak = pr.x[i];
        }
      slowing_from.push_back(x_peak);
    }
  }
  // the smallest distance from the last 1D slot's downstream edge to it, over the probes
  auto closest = [&](bool indicator) {
    auto b = scene(indicator ? "dm_reach_on" : "dm_reach_off", "Coupled",
                   indicator ? "" : param("Deceleration indicator", "bool", "false"))
                 .build();
    b->adapt();
    double worst = 1e9;
    for (std::size_t j = 0; j < probes.size(); ++j) {
      run_adaptive(*b, probes[j]);
      double x1d = 0.0;
      for (const auto& p : coupled(*b).parts())
        if (p.one_d()) x1d = p.x1;
      const double gap = slowing_from[j] - x1d;
      std::printf("[measured] t = %.2f s: full 2D slows from x = %.4f m; %s indicator: last 1D "
                  "slot ends at %.4f m (%+.1f cm)\n",
                  probes[j], slowing_from[j], indicator ? "with the" : "without the", x1d,
                  100.0 * gap);
      worst = std::min(worst, gap);
    }
    return worst;
  };
  const double with = closest(true), without = closest(false);
  EXPECT_GE(with, -0.025);
  EXPECT_GE(with - without, 0.02);
}

// Started from the paper's gate part and 1D beyond it, the manager must create the 2D part at
// the wall when the material stops there and grow it upstream ahead of the shock, check after
// check: many moves, each conserving mass to round-off.
TEST(DomainManager, SetupTwoWallPartCreatedAndGrownConservesMass) {
  const auto r = probe_setup_two(setup_two_dynamic("dm_setup2_created", "2D, 1D", "0.2", 1.0));
  EXPECT_GE(r.moves, 10);
  // a move only re-sorts the same mass into other cells and markers: round-off of the sums over
  // ~10^3 cells of ~1e-5 m^2 each
  EXPECT_LT(r.worst_move_defect, 1e-15);
  // The run's ledger also books what the 2D -> 1D interface's two sides count differently
  // (markers that leave against the DAM's flux from the 2D columns' h and u_mean, which the
  // static layout has too: -0.3 % at 10 mm, tests in test_coupled_2d.cpp); it must stay at that
  // discretisation level (measured 0.6 % here, with the interface at 0.16 m).
  EXPECT_LT(std::abs(r.run_defect), 0.02 * r.mass);
  EXPECT_EQ(r.uncovered, 0);
  EXPECT_GT(r.shock_steps, 50);
  // A move keeps each converted column's u_mean and h (eq. 25, the markers), so the record's
  // momentum changes by the rounding of h to whole markers only: measured at most 4.8e-4 of
  // the interval's momentum. (Before, the record measured the new 2D parts before their
  // inflow faces were connected and missed half a column: -0.5 to -0.9 % per 1D-to-2D move in
  // an independent run.) Asserted 2e-3.
  EXPECT_LT(r.worst_momentum_change, 2e-3);
  // Without a 2D part at the wall the first material at rest there is in 1D until the next
  // check creates one: at most one 'Check interval' (5 ms) plus one probe (1 ms) after the
  // resting layer reaches the manager's material depth (a thinner layer, from the first
  // contact on, is not material to it), never later.
  ASSERT_GE(r.first_wet_rest_t, 0.0);
  EXPECT_LE(r.last_shock_in_1d_t, r.first_wet_rest_t + 0.005 + 0.001 + 1e-9);
  EXPECT_EQ(r.wall_part_released, 0);
  EXPECT_LT(r.wall_part_x0, 0.9);  // it did grow upstream with the shock
}

// The same with 'Check interval' = 'Hold time' = 0.2 s (allowed): the manager checks again
// before a wave or the shock can cross the margin (5 cm at |u_mean| + c of the channel, 3-4 m/s
// here: every 12-17 ms), so the wall part is still created and grown ahead of the shock. Before,
// the next check came 0.2 s later and the shock piled up at the 1D-to-2D interface (an
// independent run: u_mean L2 26 % against full 2D at 1.5 s). Asserted as above, with the delay
// bounded by the margin at 1 m/s (well below the flow's speed) instead of the 5 ms interval,
// and checks brought forward by the speed (summary.json checks_brought_forward).
TEST(DomainManager, LongCheckIntervalStillKeepsTheShockInTwoD) {
  Chute dy = dynamic("dm_setup2_long_check", param("Hold time", "double", "0.2") +
                                                 param("Check interval", "double", "0.2"));
  dy.models = "2D, 1D";
  dy.interfaces = "0.2";
  dy.wall = true;
  dy.end_time = 1.0;
  const auto r = probe_setup_two(dy);
  EXPECT_LT(r.worst_move_defect, 1e-15);
  EXPECT_EQ(r.uncovered, 0);
  EXPECT_GT(r.shock_steps, 50);
  ASSERT_GE(r.first_wet_rest_t, 0.0);
  EXPECT_LE(r.last_shock_in_1d_t, r.first_wet_rest_t + 0.05 / 1.0 + 0.001 + 1e-9);
  EXPECT_LT(r.wall_part_x0, 0.9);
  auto b = dy.build();
  run_adaptive(*b, dy.end_time);
  nlohmann::json rep;
  b->report(rep);
  const long forward = rep["coupled"]["domain_manager"]["checks_brought_forward"].get<long>();
  const long checks = rep["coupled"]["domain_manager"]["checks"].get<long>();
  std::printf("[measured] Check interval 0.2 s: %ld checks to %g s, %ld brought forward\n",
              checks, dy.end_time, forward);
  // 1 s at the interval alone: 5 checks; measured 48 (43 brought forward: every 20-50 ms while
  // the channel fills, 12-17 ms once it flows)
  EXPECT_GT(forward, 20);
}

// Five parts, 2D / 1D / 2D / 1D / 2D on Setup II: the inner 2D part at [0.4, 0.6] m becomes
// calm and goes back to 1D as a whole while its 1D-to-2D interface holds pending inflow (the
// gate's fractional markers and the carried mass). With no 2D part downstream to take it, that
// mass goes into the DAM cell just downstream of the old interface: every move conserves mass to
// round-off (found by an independent run: -1.3e-5 m^2 lost in one move before).
TEST(DomainManager, RemovedPartGivesItsPendingInflowToTheDam) {
  const Chute dy = setup_two_dynamic("dm_five", "2D, 1D, 2D, 1D, 2D", "0.2, 0.4, 0.6, 0.8", 1.0);
  auto b = dy.build();
  b->adapt();
  run_adaptive(*b, dy.end_time);
  nlohmann::json rep;
  b->report(rep);
  double worst = 0.0, to_1d = 0.0;
  long moves = 0;
  for (const auto& m : rep["coupled"]["domain_manager"]["log"]) {
    worst = std::max(worst, std::abs(m["mass_defect"].get<double>()));
    to_1d += m["pending_inflow_to_1d"].get<double>();
    EXPECT_EQ(m["pending_inflow_lost"].get<double>(), 0.0) << "move at t = " << m["t"];
    ++moves;
  }
  std::printf("[measured] five parts, Setup II 10 mm to 1 s: %ld moves, pending inflow given to "
              "the DAM %.3e m^2, largest move defect %.2e m^2\n", moves, to_1d, worst);
  EXPECT_GT(to_1d, 0.0);  // the case happened: a part with pending inflow was removed
  // round-off of sums over ~10^3 cells of ~1e-5 m^2 (the pending mass itself is ~1e-5 m^2)
  EXPECT_LT(worst, 1e-15);
}

// A move while the DAM has taken mass through its ghosts ahead of the 2D side's markers (a
// hostile-user run): Setup II at 10 mm, the paper's layout, checks every 1e-4 s, hold time 1e-4
// s, thresholds 0.1 / 0.09. At t = 0.238 s the 1D tip has just passed x_IF = 0.2 m, the 2D -> 1D
// interface carries -1.38e-5 m^2 (the DAM took that much more than the markers that left), and
// the gate part shrinks to 0.11 m. The nearly dry DAM could give back only half of it before the
// rebuild, and the other half was booked as unplaced mass: the fields held 6.9e-6 m^2 more than
// the run's inflow (the ledger, counting the negative unplaced mass, still closed). Now what the
// DAM cannot take before the rebuild goes to the DAM that covers x_IF after it, which holds the
// converted columns (CoupledModel::place_settle_leftovers). Asserted: the case happened (a move
// with the front at the interface), nothing left unplaced (round-off of the hand-over, 1e-15 of
// the 0.022 m^2 in the channel), the ledger closed to round-off.
TEST(DomainManager, MoveRightAfterTheFrontKeepsNoUnplacedMass) {
  Chute dy = dynamic("dm_early_move", manager("0.1", "0.09", "0.02", "0.04", "0.0001", "0.0001"));
  dy.models = "2D, 1D, 2D";
  dy.interfaces = "0.2, 0.7";
  dy.wall = true;
  dy.end_time = 1.0;
  auto b = dy.build();
  b->adapt();
  run_adaptive(*b, dy.end_time);
  nlohmann::json rep;
  b->report(rep);
  const auto& c = rep["coupled"];
  const double unplaced = c["mass_unplaced"].get<double>();
  const long moves = c["domain_manager"]["moves"].get<long>();
  const auto mb = b->mass_balance();
  const double defect = mb.current - mb.initial - mb.inflow + mb.outflow;
  std::printf("[measured] move right after the front, Setup II 10 mm to 1 s: %ld moves, unplaced "
              "%.2e m^2, ledger defect %.2e m^2 of %.4e m^2\n", moves, unplaced, defect, mb.current);
  EXPECT_GE(moves, 1);
  EXPECT_LE(std::abs(unplaced), 1e-15 * mb.current);
  EXPECT_LE(std::abs(defect), 1e-14 * mb.current);
}

// The gate part rebuilt (a second hostile-user run, 2026-12-01), Setup II at 10 mm, checks and
// hold time 5e-4 s (1e-4 s in the second case), margin 0, minimum length 0.04 m:
//  - five parts {1D, 2D, 1D, 2D, 1D} at {0.1, 0.3, 0.5, 0.8} m, thresholds 0.1 / 0.05, to 0.3 s:
//    the gate part turns 2D and grows until, at 0.141 s, the DAM between it and the 2D part at
//    [0.1, 0.3] m vanishes; that part's pending inflow (the DAM's mass not yet in markers) was
//    handed to the merged gate part as owed mass, which a gate part never injects: the ledger
//    lost 7.8e-6 m^2 (relative -8.2e-4 at 0.3 s). Now booked as unplaced (pending_inflow_lost).
//  - the paper's layout with thresholds 100 / 99, no shock indicator, rest speed 0, to 0.8 s: the
//    gate part turns 1D at 0.089 s, and the 2D gate's fractional markers (inflow that had passed
//    the gate, in no field and in no booked inflow) were handed on to the next 2D part's inflow:
//    the fields held h_in u_in t, the booked inflow 3.0e-5 m^2 less (relative 1.7e-3 at 5 mm).
//    Now booked as the run's inflow (CoupledModel::book_gate_inflow).
// Asserted: both cases happen (moves of the gate part) and the ledger closes to round-off
// (1e-13 of the mass: sums of ~10^3 terms).
TEST(DomainManager, RebuiltGatePartKeepsTheLedgerClosed) {
  struct Variant {
    const char* name;
    const char* models;
    const char* interfaces;
    std::string extra;
    double end;
  };
  const std::string common = param("Margin", "double", "0.02") +
                             param("Minimum length", "double", "0.04");
  const Variant variants[] = {
      {"dm_gate_five", "1D, 2D, 1D, 2D, 1D", "0.1, 0.3, 0.5, 0.8",
       common + param("Shallowness threshold", "double", "0.1") +
           param("Lower threshold", "double", "0.05") + param("Hold time", "double", "0.0005") +
           param("Check interval", "double", "0.0005"),
       0.3},
      {"dm_gate_to_1d", "2D, 1D, 2D", "0.2, 0.7",
       common + param("Shallowness threshold", "double", "100") +
           param("Lower threshold", "double", "99") + param("Hold time", "double", "0.0001") +
           param("Check interval", "double", "0.0001") +
           param("Shock indicator", "bool", "false") +
           param("Deceleration indicator", "bool", "false") + param("Rest speed", "double", "0"),
       0.8}};
  for (const auto& v : variants) {
    Chute dy = dynamic(v.name, v.extra);
    dy.models = v.models;
    dy.interfaces = v.interfaces;
    dy.wall = true;
    dy.end_time = v.end;
    auto b = dy.build();
    b->adapt();
    long gate_moves = 0;
    run_adaptive(*b, dy.end_time);
    nlohmann::json rep;
    b->report(rep);
    for (const auto& m : rep["coupled"]["domain_manager"]["log"]) {
      const std::string before = m["before"], after = m["after"];
      if (before.substr(0, 6) != after.substr(0, 6) ||
          before.substr(0, before.find('|')) != after.substr(0, after.find('|')))
        ++gate_moves;
    }
    const auto mb = b->mass_balance();
    const double defect = mb.current - mb.initial - mb.inflow + mb.outflow;
    std::printf("[measured] %s: %ld moves of the gate part, ledger defect %.2e of %.4e m^2, "
                "unplaced %.2e m^2\n",
                v.name, gate_moves, defect, mb.current,
                rep["coupled"]["mass_unplaced"].get<double>());
    EXPECT_GE(gate_moves, 1) << v.name;
    EXPECT_LE(std::abs(defect), 1e-13 * mb.current) << v.name;
  }
}

// Steady supercritical flow (Setup I, open end): once the flow and the layout have settled, the
// layout stays (the hysteresis between the two thresholds, 'Hold time').
TEST(DomainManager, SteadySupercriticalFlowMakesNoMoveOnceSettled) {
  Chute dy = dynamic("dm_settle");
  dy.end_time = 1.4;
  auto b = dy.build();
  const auto* dm = coupled(*b).domain_manager();
  b->adapt();
  run_adaptive(*b, 1.0);
  const long settled = dm->moves();
  const auto layout = coupled(*b).layout();
  run_adaptive(*b, 1.4);
  std::printf("[measured] Setup I dynamic, 10 mm: %ld moves to 1.0 s, %ld in [1.0, 1.4] s; "
              "layout at 1.4 s:", settled, dm->moves() - settled);
  for (std::size_t i = 0; i < coupled(*b).parts().size(); ++i)
    std::printf(" %s [%.3f, %.3f]", coupled(*b).parts()[i].kind.c_str(),
                coupled(*b).parts()[i].x0, coupled(*b).parts()[i].x1);
  std::printf("\n");
  EXPECT_GE(settled, 1);  // it did adapt the paper's layout to the flow
  EXPECT_EQ(dm->moves(), settled);
  EXPECT_EQ(coupled(*b).layout().interfaces, layout.interfaces);
  // and on the way there no column went back and forth (DomainManager::flickers)
  EXPECT_EQ(dm->flickers(), 0);
}

// A move in steady supercritical flow (Setup I, open end): the interfaces of the paper's layout
// shift by 5 cells each; the flow must not notice beyond the layout's own effect.
TEST(DomainManager, MoveInSteadySupercriticalFlowSendsNoReflection) {
  Chute s;
  s.name = "dm_steady";
  s.length = 1.0;
  s.end_time = 1.2;
  auto a = s.build();
  s.name = "dm_steady_b";
  auto b = s.build();
  run(*a, 0.9);
  run(*b, 0.9);
  double jump0 = interface_jump(*a);
  auto rec = move_to(coupled_mut(*b), {{"2D", 0.0, 0.25}, {"1D", 0.25, 0.65}, {"2D", 0.65, 1.0}});
  std::printf("[measured] move: mass %.6e -> %.6e (defect %.2e), momentum %.6e -> %.6e, "
              "remainder %.2e given back %.2e; columns to 2D %d, to 1D %d\n",
              rec.mass_before, rec.mass_after, rec.defect(), rec.momentum_before,
              rec.momentum_after, rec.remainder, rec.remainder_given_back, rec.columns_to_2d,
              rec.columns_to_1d);
  double worst_jump = interface_jump(*b);
  std::printf("[measured] jump static %.3e, right after the move %.3e\n", jump0, worst_jump);
  for (int k = 0; k < 40; ++k) {
    const double t = 0.9 + 0.3 * (k + 1) / 40.0;
    run(*a, t);
    run(*b, t);
    worst_jump = std::max(worst_jump, interface_jump(*b));
    jump0 = std::max(jump0, interface_jump(*a));
    const auto pa = a->profile(), pb = b->profile();
    double du = 0.0;
    for (std::size_t i = 0; i < pa.x.size(); ++i)
      if (pa.h[i] > 2e-3) du = std::max(du, std::abs(pb.u_mean[i] - pa.u_mean[i]) / pa.u_mean[i]);
    if (k % 8 == 0 || k == 39)
      std::printf("[measured] t = %.3f: jump %.3e (static %.3e), max |du|/u moved vs static %.3e\n", t,
                  interface_jump(*b), interface_jump(*a), du);
  }
  // The u_mean jump across an interface is the coupling's own discretisation error (static
  // layout: 2.3-2.8 % at 10 mm); a move must not add to it beyond the first steps: right after
  // it and later it stays below the static layout's largest jump plus 1 % (measured: 2.4 % right
  // after, 2.0-2.4 % later).
  EXPECT_LT(worst_jump, jump0 + 0.01);
}

// A force-free layer (Gravity 0: no pressure, no friction) translates at the gate's 0.37 m/s
// whatever the layout does. An independent run (2026-12-06) let the gate part give back its calm
// layer behind the front slot by slot: the 1D-to-2D interface then followed one or two columns
// behind the front, whose inflow profile (eq. 25) came from the front's own column, and the
// front ran ahead. 'Minimum length' now counts the material a 2D subdomain keeps
// (DomainManager::target). Measured at every step of the tester's scene (10 mm, thresholds 0.1 /
// 0.05, hold 0.05 s, checks every 5 ms) to 0.5 s: before, u_mean up to 37 % from 0.37 m/s and the
// front 2.5 cm (2.5 cells) ahead of 0.37 t; with the minimum length 16 % and 5 mm; since each
// move's converted state is made divergence-free before the next step
// (NdamSolver::remove_divergence) 9.5 % and 9.4 mm (the front is the last column deeper than
// 1 mm: a 10 mm quantum). Asserted: the layout moved (at least 5 moves), the front within one
// cell of 0.37 t, and u_mean of every column deeper than 1 mm within 20 % of 0.37 m/s. What is
// left of the deviation: the first 2D column behind the 1D-to-2D interface right after a move
// (0.33-0.35 m/s), whose inflow face takes the u_mean of the DAM cell next to it (eq. 24), and
// that cell was made from the old part's first column, which the inflow had left 2-8 mm off the
// layer's depth; Gravity 0 never evens either out (no pressure, no friction). The Static layout
// {1D, 2D} keeps 0.370 m/s to 4 digits.
TEST(DomainManager, ForceFreeLayerTranslatesThroughMoves) {
  Chute dy = dynamic("dm_force_free", manager("0.1", "0.05", "0.05", "0.05", "0.05", "0.005"));
  dy.wall = true;
  dy.gravity = 0.0;
  dy.height = 0.2;
  dy.end_time = 0.5;
  auto b = dy.build();
  const auto* dm = coupled(*b).domain_manager();
  double worst = 0.0, worst_t = 0.0, worst_x = 0.0, worst_front = 0.0;
  while (b->time() < dy.end_time - 1e-12) {
    b->step(std::min(b->stable_dt(), dy.end_time - b->time()));
    const auto h = b->check();
    ASSERT_TRUE(h.ok) << h.reason << " at x = " << h.x;
    b->accept();
    b->adapt();
    const auto p = b->profile();
    double front = 0.0;
    for (std::size_t i = 0; i < p.x.size(); ++i) {
      if (!(p.h[i] > 1e-3)) continue;
      front = std::max(front, p.x[i] + 0.5 * dy.cell);
      const double d = std::abs(p.u_mean[i] - 0.37) / 0.37;
      if (d > worst) worst = d, worst_t = b->time(), worst_x = p.x[i];
    }
    worst_front = std::max(worst_front, std::abs(front - 0.37 * b->time()));
  }
  std::printf("[measured] force-free layer through %ld moves, 10 mm to 0.5 s: u_mean at most "
              "%.2f %% from 0.37 m/s (t = %.3f s, x = %.3f m); front at most %.4f m from 0.37 t\n",
              dm->moves(), 100.0 * worst, worst_t, worst_x, worst_front);
  EXPECT_GE(dm->moves(), 5);
  EXPECT_LT(worst, 0.20);
  EXPECT_LT(worst_front, dy.cell);
}

// A Moving lid on the channel's closed left end belongs to x = 0: a 2D part that starts at an
// interface takes the interface's inflow there, and the lid's speed imposed on that side drove
// the inflow (the gate's case, an independent run, 2026-12-06: w = -0.37 .. -2.06 m/s in the gate
// column against -0.008 .. -0.28 without the lid). Asserted on the factory's configuration: the
// part at x = 0 keeps the lid and its speed, a part behind an interface has the no-slip side
// (w = 0 on it, as at the gate), and the right end is untouched.
TEST(DomainManager, LidAtTheClosedEndIsNotAppliedAtAnInterface) {
  Chute c;
  c.name = "dm_lid_left";
  c.wall = true;
  std::string xml = c.xml();
  auto replace = [&xml](const std::string& a, const std::string& b) {
    const auto at = xml.find(a);
    ASSERT_NE(at, std::string::npos) << a;
    xml.replace(at, a.size(), b);
  };
  replace(R"(<Parameter name="Type" type="string" value="Inflow"/>
      <Parameter name="Inflow depth" type="double" value="0.06"/>
      <Parameter name="Inflow velocity" type="double" value="0.37"/>)",
          R"(<Parameter name="Type" type="string" value="Wall"/>)");
  replace(R"(<Parameter name="Left" type="string" value="No-slip"/>)",
          R"(<Parameter name="Left" type="string" value="Moving lid"/>
      <Parameter name="Left lid velocity" type="double" value="-2"/>)");
  const std::string file = ::testing::TempDir() + "test_coupled_2d_dm_lid_left_" +
                           std::to_string(static_cast<long>(::getpid())) + ".xml";
  std::ofstream(file) << xml;
  auto b = scene::build_model(scene::load(file));
  std::remove(file.c_str());
  const auto& f = *coupled(*b).factory();
  const auto at_end = f.ndam_config(0.0, 0.2, {false, true});
  const auto behind = f.ndam_config(0.7, 1.0, {true, false});
  EXPECT_EQ(at_end.walls[0].kind, ndam::WallKind::MovingLid);
  EXPECT_EQ(at_end.walls[0].velocity, -2.0);
  EXPECT_EQ(behind.walls[0].kind, ndam::WallKind::NoSlip);
  EXPECT_EQ(behind.walls[0].velocity, 0.0);
  EXPECT_EQ(behind.walls[1].kind, ndam::WallKind::Coulomb);
}

// A move must not make the run depend on the step that follows it. The converted state of a
// move is divergence-free only approximately, and the next step's projection turned its
// divergence into a pressure of div / dt that the incremental update kept: a step of 1e-5 s
// after each move put 110-150 m^2/s^2 into p (0.1-7 otherwise) and moved the profile at 1 s by
// 14.6 % in u_mean (L2). Now the state is made divergence-free at the move
// (NdamSolver::remove_divergence). Setup II from 2D [0, 0.2] / 1D at 10 mm to 1 s, three
// runs: ordinary steps; a step of 1e-5 s right after each move; a step of 1e-5 s every 20th
// step. Measured (u_mean L2 against the first run at 1 s): 0.9 % after the moves, 1.6 % at the
// other times (the run's own sensitivity to its step sequence, with the shock and the deposit
// in the 10 mm columns). Asserted: after the moves below 4 %, i.e. within about twice that
// sensitivity and far below the 14.6 % before.
TEST(DomainManager, ShortStepAfterAMoveDoesNotChangeTheRun) {
  auto run = [](int mode) {
    Chute dy = setup_two_dynamic("dm_short_after_move_" + std::to_string(mode), "2D, 1D", "0.2",
                                 1.0);
    auto b = dy.build();
    const auto* dm = coupled(*b).domain_manager();
    long seen = 0, n = 0;
    while (b->time() < dy.end_time - 1e-12) {
      double dt = std::min(b->stable_dt(), dy.end_time - b->time());
      if (mode == 1 && dm->moves() != seen) dt = std::min(dt, 1e-5);
      if (mode == 2 && n % 20 == 7) dt = std::min(dt, 1e-5);
      seen = dm->moves();
      ++n;
      b->step(dt);
      const auto h = b->check();
      EXPECT_TRUE(h.ok) << h.reason;
      if (!h.ok) break;
      b->accept();
      b->adapt();
    }
    EXPECT_GE(dm->moves(), 10) << "mode " << mode;  // the layout did move
    return b->profile();
  };
  const auto a = run(0), after_moves = run(1), other_times = run(2);
  ASSERT_EQ(a.x.size(), after_moves.x.size());
  ASSERT_EQ(a.x.size(), other_times.x.size());
  const double d_moves = rel_l2(a.u_mean, after_moves.u_mean, a.h, 1e-3);
  const double d_other = rel_l2(a.u_mean, other_times.u_mean, a.h, 1e-3);
  std::printf("[measured] Setup II dynamic, 10 mm, t = 1 s: u_mean L2 against ordinary steps: a "
              "step of 1e-5 s after each move %.2f %%, every 20th step %.2f %%\n",
              100.0 * d_moves, 100.0 * d_other);
  EXPECT_LT(d_moves, 0.04);
}

// Froude similarity. Setup II scaled by 4 and by 1/4 (lengths x s, times and speeds x sqrt(s),
// nu, m_c, m_y and every dimensional default with them: Chute::froude_scale) is the same run in
// the scaled units: each operation of the models then scales by a power of two, which binary
// floating point does exactly, so nothing but a constant of the code that does not scale with
// the scene can separate the runs. An independent run found the coupled runs apart by 2e-10 from
// 0.23 s and by 4 % in h at 0.5 s (full 2D and the DAM alone exact): the 1D -> 2D inflow's
// thresholds were fixed numbers, 0.1 mm and 0.1 m/s, and the DAM's tip arriving at x = 0.7 m took
// the other branch in the scaled run. They are in units of the grid now (dz / 50 and half the
// gravity-wave speed of one cell, src/ndam/inflow.cpp; the rest speed of a move's profile shape
// likewise, src/coupling/conversion.cpp). Measured at 10 mm to 1.5 s: identical to 0.9 s, then
// at most 3e-15 of the field's largest value (the deposit's solves; not growing).
// Asserted: 1e-12 at every 0.1 s to 1 s, the same steps and moves (a branch taken differently
// shows as 1e-10 or more, as before).
TEST(DomainManager, FroudeScaledSetupIIIsTheScaledRun) {
  for (const std::string layout : {"Static", "Dynamic"}) {
    Chute base = setup_two_dynamic("froude_" + layout, "2D, 1D, 2D", "0.2, 0.7", 1.0);
    base.layout = layout;
    base.decomposition_extra.clear();  // the defaults, written out by the scaled scenes
    std::vector<core::Profile> ref;
    long ref_steps = 0, ref_moves = 0;
    for (const double s : {1.0, 4.0, 0.25}) {
      Chute sc = base;
      sc.name = base.name + "_" + std::to_string(s);
      sc.froude_scale = s;
      const double L = s, T = std::sqrt(s);
      auto b = sc.build();
      for (int k = 1; k <= 10; ++k) {
        run_adaptive(*b, 0.1 * k * T);
        auto p = b->profile();
        if (s == 1.0) {
          ref.push_back(p);
          continue;
        }
        const auto& r = ref[static_cast<std::size_t>(k - 1)];
        ASSERT_EQ(r.x.size(), p.x.size());
        double hmax = 0, umax = 0, dh = 0, du = 0;
        for (std::size_t i = 0; i < r.x.size(); ++i) {
          hmax = std::max(hmax, r.h[i]);
          umax = std::max(umax, std::abs(r.u_mean[i]));
          dh = std::max(dh, std::abs(p.h[i] / L - r.h[i]));
          du = std::max(du, std::abs(p.u_mean[i] / T - r.u_mean[i]));
        }
        EXPECT_LE(dh, 1e-12 * hmax) << layout << " x" << s << " at t = " << 0.1 * k;
        EXPECT_LE(du, 1e-12 * umax) << layout << " x" << s << " at t = " << 0.1 * k;
        if (k == 10)
          std::printf("[measured] %s Setup II x %.2f at 1 s (scaled back): max |dh| %.1e of "
                      "%.3f m, max |du| %.1e of %.3f m/s\n",
                      layout.c_str(), s, dh, hmax, du, umax);
      }
      const long moves = layout == "Dynamic" ? coupled(*b).domain_manager()->moves() : 0;
      if (s == 1.0) {
        ref_steps = b->steps();
        ref_moves = moves;
        continue;
      }
      EXPECT_EQ(b->steps(), ref_steps) << layout << " x" << s;
      EXPECT_EQ(moves, ref_moves) << layout << " x" << s;
    }
    if (layout == "Dynamic") EXPECT_GE(ref_moves, 1);  // the layout did move
  }
}
