// The coupled model with 2D subdomains, built through the XML scene interface (scene::load and
// scene::build_model, as the granflow app does) on coarse chutes (10 mm cells): a zero-length 1D
// part is the full 2D run, mass through the interfaces is conserved, and steady supercritical
// flow crosses the 2D-to-1D and 1D-to-2D interfaces without reflections.
#include "granflow/coupling/coupled_model.hpp"
#include "granflow/dam/dam_solver.hpp"
#include "granflow/ndam/ndam_solver.hpp"
#include "granflow/scene/scene.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "chute_scene.hpp"

using namespace granflow;
using namespace granflow::test;


// A zero-length 1D part: 'Interfaces' {0.4, 0.4} leaves the 1D subdomain out and its two 2D
// neighbours merge (Decomposition::normalised), so the coupled run is the full 2D run.
TEST(Coupled2D, ZeroLength1DPartReproducesTheFull2DRun) {
  Chute full;
  full.name = "zero_full";
  full.model = "N-DAM";
  full.end_time = 0.3;
  Chute zero = full;
  zero.name = "zero_coupled";
  zero.model = "Coupled";
  zero.interfaces = "0.4, 0.4";
  auto a = full.build();
  auto b = zero.build();
  ASSERT_EQ(coupled(*b).parts().size(), 1u);
  EXPECT_EQ(coupled(*b).parts()[0].kind, "2D");
  run(*a, full.end_time);
  run(*b, zero.end_time);
  const auto pa = a->profile(), pb = b->profile();
  ASSERT_EQ(pa.x.size(), pb.x.size());
  double dh = 0, du = 0, hmax = 0;
  for (std::size_t i = 0; i < pa.x.size(); ++i) {
    EXPECT_DOUBLE_EQ(pa.x[i], pb.x[i]);
    dh = std::max(dh, std::abs(pa.h[i] - pb.h[i]));
    du = std::max(du, std::abs(pa.u_mean[i] - pb.u_mean[i]));
    hmax = std::max(hmax, pa.h[i]);
  }
  std::printf("[measured] zero-length 1D vs full 2D, t = 0.3 s: max |dh| %.3e m, max |du| %.3e "
              "m/s; front material up to h = %.4f m; steps %ld / %ld\n",
              dh, du, hmax, a->steps(), b->steps());
  // The same 2D subdomain on [0, L] with the scene's own boundaries: the same operations in the
  // same order, so the profiles agree to round-off (1e-12 allows for nothing else).
  EXPECT_GT(hmax, 0.01);  // material has flowed (not a trivially empty comparison)
  EXPECT_LE(dh, 1e-12);
  EXPECT_LE(du, 1e-12);
  EXPECT_EQ(a->steps(), b->steps());
  const auto ma = a->mass_balance(), mb = b->mass_balance();
  EXPECT_NEAR(ma.current, mb.current, 1e-14);
}

// The same semantics at the ends: a 1D piece of zero length at x = 0 or x = L disappears, and
// equal neighbours of different models keep their interface.
TEST(Coupled2D, ZeroLengthSubdomainsAreLeftOut) {
  coupling::Decomposition d;
  d.models = {"1D", "2D", "1D"};
  d.interfaces = {0.0, 1.0};
  auto n = d.normalised(1.0);
  EXPECT_EQ(n.models, std::vector<std::string>({"2D"}));
  EXPECT_TRUE(n.interfaces.empty());
  d.models = {"2D", "1D", "1D", "2D"};
  d.interfaces = {0.2, 0.5, 0.5};
  n = d.normalised(1.0);
  EXPECT_EQ(n.models, std::vector<std::string>({"2D", "1D", "2D"}));
  EXPECT_EQ(n.interfaces, std::vector<double>({0.2, 0.5}));
  // an interface between two subdomains of the same model that the user asked for stays
  d.models = {"1D", "1D", "2D"};
  d.interfaces = {0.2, 0.7};
  n = d.normalised(1.0);
  EXPECT_EQ(n.models, d.models);
  EXPECT_EQ(n.interfaces, d.interfaces);
}

namespace {
// Setup II coupled at 10 mm (wall at x = 1 m; 2D / 1D / 2D split at `interfaces`) run to t_end.
std::unique_ptr<core::Stepper> run_setup_two(const std::string& name, double t_end,
                                             const std::string& interfaces = "0.2, 0.7") {
  Chute s;
  s.name = name;
  s.wall = true;
  s.interfaces = interfaces;
  s.end_time = t_end;
  auto m = s.build();
  run(*m, t_end);
  return m;
}
// What the 1D -> 2D interface (the second one) has not accounted for: the DAM's outgoing mass
// minus what the 2D side injected minus what its inflow holds [m^2].
double inflow_ledger_gap(const coupling::CoupledModel& c) {
  const auto i1 = c.interface_mass(1);
  return i1[0] - i1[1] - dynamic_cast<const ndam::NdamSolver&>(*c.parts()[2].model).inflow_pending();
}
}  // namespace

// Mass through the interfaces of Setup II coupled (2D [0, 0.2] / 1D [0.2, 0.7] / 2D [0.7, 1],
// wall at x = 1 m) to t = 0.75 s, when material has crossed both interfaces and reached the wall.
TEST(Coupled2D, MassThroughInterfacesIsConserved) {
  auto m = run_setup_two("mass", 0.75);
  const auto& c = coupled(*m);
  ASSERT_EQ(c.parts().size(), 3u);
  const auto i0 = c.interface_mass(0), i1 = c.interface_mass(1);
  const auto& down = dynamic_cast<const ndam::NdamSolver&>(*c.parts()[2].model);
  const double pending = down.inflow_pending();
  const auto mb = m->mass_balance();
  double parts_defect = 0.0;
  std::vector<double> defects;
  for (const auto& p : c.parts()) {
    defects.push_back(p.model->mass_balance().defect());
    parts_defect += defects.back();
  }
  const auto& dam = dynamic_cast<const dam::DamSolver&>(*c.parts()[1].model);
  const double half_cell = 0.5 * dam.dx() * dam.sample(0.2)[0];
  std::printf("[measured] DAM grid %s, half cell at 0.2 m: %.3e m^2\n",
              dam.staggered() ? "staggered" : "primary", half_cell);
  std::printf("[measured] Setup II coupled, 10 mm, t = 0.75 s: 2D->1D at 0.2 m out %.6e in %.6e "
              "(rel %.2e); 1D->2D at 0.7 m out %.6e in %.6e pending %.3e (rel out - in - pending "
              "%.2e); subdomain defects %.2e %.2e %.2e; total defect %.3e of %.5f m^2\n",
              i0[0], i0[1], (i0[1] - i0[0]) / i0[0], i1[0], i1[1], pending,
              (i1[0] - i1[1] - pending) / i1[0], defects[0], defects[1], defects[2], mb.defect(),
              mb.current);
  ASSERT_GT(i1[0], 1e-3);  // a real amount (m^2 per unit width) has crossed x = 0.7 m
  // 1D -> 2D: the 2D side lets in exactly the DAM's outgoing ledger term of each step; what is
  // not yet in the box as markers is the gate's fractional accumulators (under one marker per
  // injection row) plus any carried remainder, both reported as inflow_pending. So the identity
  // out = in + pending holds to round-off of the ~10^3 summed steps (1e-12 relative).
  EXPECT_NEAR(i1[1] + pending, i1[0], 1e-12 * i1[0]);
  // ... and what is pending is at most one marker per injection row of the opening (h < 6 cm,
  // 24 rows of 2.5 mm, marker area 6.25e-6 m^2): the 2D side is not starved.
  EXPECT_GE(pending, -1e-15);
  EXPECT_LE(pending, 24 * 6.25e-6);
  // 2D -> 1D: the DAM's first cells evaluate the flux across x = 0.2 m from the 2D columns' h and
  // u_mean (eqs. 19-21), the 2D side counts the markers that left. Left alone, the two counts
  // drifted apart: each primary step books dx (h_g - h_0) / 4 of the overlap (h_g the 2D
  // column's depth in the DAM's ghost, h_0 the DAM's end cell), each staggered step dx h'_0 / 8,
  // and where the two models' depths at x_IF differ by a steady offset these terms do not
  // cancel. The mismatch grew with the steps, to 2.4e-4 m^2 (2.2 % of the transfer) at 0.75 s
  // here, between -0.7 and +2.3 % over N-DAM CFL 0.4-0.5, so the DAM made mass. Now the
  // difference is carried and handed to the DAM's first cells, dt / 0.01 s of it per step
  // (Interface::settle). What is carried is then one staggered step's overlap term at most (on
  // the staggered grid the DAM's ledger has taken in about half a cell, dx h / 2, that the 2D
  // side still holds; here 9.0e-5 m^2) plus the drift rate times 0.01 s (3e-6 m^2). Measured
  // 1.1e-5 m^2 (0.1 %); asserted 1.5 half cells, below the 2.7 half cells of the drift without
  // the hand-over.
  EXPECT_LT(std::abs(i0[0] - i0[1]), 1.5 * half_cell);
  // Total balance: the 2D subdomains' marker ledgers are exact (defect 0), the DAM's too up to
  // positivity fixes at the front, and the coupled ledger counts what the interfaces carry
  // (the 2D -> 1D difference above and the 1D -> 2D pending inflow), so it closes to the
  // subdomains' own defects within round-off (measured -3.5e-18 m^2; asserted 1e-13 m^2,
  // round-off of ~10^3 summed steps of 1e-5 m^2).
  EXPECT_NEAR(defects[0], 0.0, 1e-15);
  EXPECT_NEAR(defects[2], 0.0, 1e-15);
  EXPECT_NEAR(mb.defect(), parts_defect, 1e-13);
}

// Short steps late in a run keep the 1D -> 2D transfer exact. The 2D side takes the DAM's ledger
// term of the same step only if the DAM's pending step is the step asked for; the DAM's step
// length t_new - t0 carries the round-off of t, not of dt, and a relative tolerance of 1e-12 dt
// refused steps below about 1e-4 t (ulp(t) / dt > 1e-12): their inflow fell back to h u_mean dt
// of the DAM's reconstruction, and mass was lost or made (the coupled nu = 0.3 stability case:
// 5.2e-8 m^2 over its 2343 steps of down to 1.5e-5 s). Setup II at 10 mm to 0.6 s (material
// crosses x = 0.7 m from about 0.45 s), then 20 steps of 1e-7 s (ulp(0.6) / 1e-7 = 1.1e-9)
// and 20 of 1e-5 s: out = in + pending at the interface, and the run's ledger closes, to
// round-off (measured 5e-17 / 4e-17 m^2; asserted 1e-15 m^2; without the fix 8.9e-7 m^2, the
// averaging term, O(dx^2 h_x) per step, that the fallback let in or held back).
TEST(Coupled2D, ShortStepsLateInARunKeepTheInterfaceMassExact) {
  auto m = run_setup_two("short_steps", 0.6);
  const auto& c = coupled(*m);
  ASSERT_EQ(c.parts().size(), 3u);
  ASSERT_GT(c.interface_mass(1)[0], 1e-4);  // material has crossed x = 0.7 m
  for (double dt : {1e-7, 1e-5})
    for (int n = 0; n < 20; ++n) {
      m->step(dt);
      ASSERT_TRUE(m->check().ok);
      m->accept();
    }
  const double mismatch = inflow_ledger_gap(c);
  const auto mb = m->mass_balance();
  std::printf("[measured] short steps at t = 0.6 s: 1D->2D out - in - pending %.2e m^2, run defect "
              "%.2e m^2 of %.5f\n", mismatch, mb.defect(), mb.current);
  EXPECT_LT(std::abs(mismatch), 1e-15);
  EXPECT_LT(std::abs(mb.defect()), 1e-15);
}

// A shock that runs upstream through a 1D -> 2D interface keeps the transfer exact. Once the
// shock reflected from the wall reaches the interface, the first 2D column flows back in some
// rows; the inflow's profile shape (eq. 25) copied that and booked the negative rows' share as
// mass let in, while markers enter only through rows of positive flux: mass was made (the static
// lab chute: 9.3e-4 m^2, 1.4 %). The shape now takes the positive part of column 0. Setup II at
// 10 mm with the downstream 2D part only 6 cm long ([0.94, 1] m). In the 0.15 m box of before,
// the capped deposit was pushed through x = 0.94 m into the DAM by 1.2 s (its last cell 0.10 m);
// in the 0.3 m box (a column reaching the top now stops the run) the 6 cm part holds the shock
// and piles up instead (0.26 m at 1.15 s against 0.16 m in full 2D at 1 s: the static layout's
// failure once the shock reaches its interface; at 1.19 s it reaches the top of the box). To
// t = 1.15 s: asserted that the shock is at the interface (the first 2D column deeper than
// four times the 8 mm inflowing layer; measured 0.0425 m), out = in + pending at 0.94 m and the
// run's ledger to round-off, 1e-15 m^2 (measured 8e-18 / 3e-17 m^2 in the 0.15 m box; without
// the fix 6.6e-4 m^2, 2.4 % of the run's mass).
TEST(Coupled2D, ShockThroughAnInflowInterfaceKeepsTheMassExact) {
  auto m = run_setup_two("shock_through_inflow", 0.0, "0.2, 0.94");
  const auto& c = coupled(*m);
  ASSERT_EQ(c.parts().size(), 3u);
  // the step by step: the least the interface ever holds (negative: a debt of the 2D side)
  double least_pending = 0.0;
  while (m->time() < 1.15 - 1e-12) {
    m->step(std::min(m->stable_dt(), 1.15 - m->time()));
    ASSERT_TRUE(m->check().ok);
    m->accept();
    least_pending = std::min(least_pending, c.interface(1).carried());
  }
  const auto i1 = c.interface_mass(1);
  const double mismatch = inflow_ledger_gap(c);
  // the shock is at the interface: the first 2D column, downstream of 0.94 m, holds the
  // deposit's foot (the inflowing layer is about 8 mm deep)
  const auto prof = m->profile();
  double h_first_2d = 0.0;
  for (std::size_t k = prof.x.size(); k-- > 0;)
    if (prof.x[k] > 0.94) h_first_2d = prof.h[k];
  const auto mb = m->mass_balance();
  const double pending = c.interface(1).carried();
  std::printf("[measured] shock at x = 0.94 m (10 mm, 1.15 s): h in the first 2D column %.4f m; "
              "1D->2D out %.4e in %.4e, pending %.3e (least %.3e), out - in - pending %.2e m^2; "
              "run defect %.2e m^2 of %.5f\n",
              h_first_2d, i1[0], i1[1], pending, least_pending, mismatch, mb.defect(), mb.current);
  EXPECT_GT(h_first_2d, 4.0 * 0.008);
  // Where the DAM's flux at the interface turns negative (the deposit pushing back), the 2D side
  // gives up the markers nearest to the face (MarkerSet::take_back), so its debt never exceeds
  // one marker (1e-4 m^2 / 16 = 6.25e-6 m^2). Without that the debt grew to 1.05e-4 m^2 here and
  // the DAM held mass that the 2D side still counted (the DAM's last cell 0.10 m instead of
  // 0.077 m): made mass that a ledger counting the debt as negative pending mass hid.
  EXPECT_GE(least_pending, -6.25e-6 * (1.0 + 1e-9));
  EXPECT_LT(std::abs(mismatch), 1e-15);
  EXPECT_LT(std::abs(mb.defect()), 1e-15);
}

// Steady supercritical flow through both interfaces: Setup I's chute shortened to L = 1 m (open
// end), 2D [0, 0.2] / 1D [0.2, 0.7] / 2D [0.7, 1], against the full 2D run, at t = 1 s when the
// front has left the channel (at about 0.55 s) and the flow from the gate is steady. A reflection
// at either interface would show as a disturbance upstream of it (the 2D part [0, 0.2] m) or as
// a jump of h or u_mean across it.
TEST(Coupled2D, SteadySupercriticalFlowCrossesInterfacesWithoutReflections) {
  Chute full;
  full.name = "steady_full";
  full.model = "N-DAM";
  full.end_time = 1.0;
  // 5 mm cells (10 mm until 2026-12-06): since the bed does not carry the free surface's
  // viscous traction the 2D chute follows its plug law, and at 10 mm, where the layer is under
  // one cell deep beyond 0.3 m, the scheme's first-order excess over that law put the 2D parts
  // 2.8 % (u_mean, the 1D part) and 1.7 % (downstream) away from the DAM's flow; at 5 mm 0.8 %
  // and 0.8 %
  full.cell = 0.005;
  Chute cpl = full;
  cpl.name = "steady_coupled";
  cpl.model = "Coupled";
  auto a = full.build();
  auto b = cpl.build();
  // the full run's profile 0.1 s before the end: how steady the reference is
  run(*a, 0.9);
  const auto p09 = a->profile();
  run(*a, full.end_time);
  run(*b, cpl.end_time);
  const auto pa = a->profile(), pb = b->profile();
  ASSERT_EQ(pa.x.size(), pb.x.size());
  const double h_min = 1e-3;
  const double unsteady = rel_l2(pa.u_mean, p09.u_mean, pa.h, h_min);
  // error of the coupled run: the upstream 2D part, the 1D part, the downstream 2D part
  auto part = [&](double x0, double x1, const std::vector<double>& ra,
                  const std::vector<double>& rb) {
    std::vector<double> va, vb, ha;
    for (std::size_t i = 0; i < pa.x.size(); ++i)
      if (pa.x[i] >= x0 && pa.x[i] < x1) {
        va.push_back(ra[i]);
        vb.push_back(rb[i]);
        ha.push_back(pa.h[i]);
      }
    return rel_l2(va, vb, ha, h_min);
  };
  const double up_h = part(0.0, 0.2, pa.h, pb.h), up_u = part(0.0, 0.2, pa.u_mean, pb.u_mean);
  const double mid_h = part(0.2, 0.7, pa.h, pb.h), mid_u = part(0.2, 0.7, pa.u_mean, pb.u_mean);
  const double dn_h = part(0.7, 1.0, pa.h, pb.h), dn_u = part(0.7, 1.0, pa.u_mean, pb.u_mean);
  const double all_h = rel_l2(pa.h, pb.h, pa.h, h_min);
  const double all_u = rel_l2(pa.u_mean, pb.u_mean, pa.h, h_min);
  // jumps across the interfaces: the change of u_mean and h between the two cells either side
  // of x_IF in the coupled run, against the same change in the full 2D run
  auto jump = [&](double x, const std::vector<double>& ra, const std::vector<double>& rb) {
    std::size_t k = 0;
    while (k + 1 < pb.x.size() && pb.x[k + 1] < x) ++k;
    const double dc = rb[k + 1] - rb[k], df = ra[k + 1] - ra[k];
    return std::abs(dc - df) / std::abs(ra[k]);
  };
  const double j1u = jump(0.2, pa.u_mean, pb.u_mean), j1h = jump(0.2, pa.h, pb.h);
  const double j2u = jump(0.7, pa.u_mean, pb.u_mean), j2h = jump(0.7, pa.h, pb.h);
  // mean depth of each part (the mass per length: robust to the marker depth's quantisation,
  // the layer is under one 10 mm cell deep beyond x = 0.3 m)
  auto mean_h = [&](double x0, double x1, const core::Profile& p) {
    double s = 0;
    int n = 0;
    for (std::size_t i = 0; i < p.x.size(); ++i)
      if (p.x[i] >= x0 && p.x[i] < x1) {
        s += p.h[i];
        ++n;
      }
    return s / n;
  };
  double mh[3];
  const double xs[4] = {0.0, 0.2, 0.7, 1.0};
  for (int q = 0; q < 3; ++q)
    mh[q] = std::abs(mean_h(xs[q], xs[q + 1], pb) / mean_h(xs[q], xs[q + 1], pa) - 1.0);
  std::printf("[measured] steady flow, L = 1 m, 5 mm, t = 1 s: full 2D change 0.9 -> 1 s %.2e; "
              "coupled vs full L2 h / u_mean: [0, 0.2] %.2e / %.2e, [0.2, 0.7] %.2e / %.2e, "
              "[0.7, 1] %.2e / %.2e, all %.2e / %.2e; mean h of the parts %.2e %.2e %.2e; "
              "excess jump at 0.2 m h %.2e u %.2e, at 0.7 m h %.2e u %.2e\n",
              unsteady, up_h, up_u, mid_h, mid_u, dn_h, dn_u, all_h, all_u, mh[0], mh[1], mh[2],
              j1h, j1u, j2h, j2u);
  // The reference is steady: u_mean changed by 0.15 % (L2) from t = 0.9 to 1 s. Asserted 1 %.
  EXPECT_LT(unsteady, 1e-2);
  // Upstream of the 2D-to-1D interface: a reflection would disturb [0, 0.2] m. Measured 0.27 %
  // (L2); asserted 1.5 %. (With a zero-gradient outflow on the 2D side instead of the lagged
  // gradient its last columns were up to 4 % slow and this was 1.3 %.)
  EXPECT_LT(up_u, 1.5e-2);
  // The 1D part: the DAM's own physics against the 2D model's (Savage-Hutter with K_act
  // against Drucker-Prager with Coulomb sliding), not an interface effect. Measured 1.2 %;
  // asserted 3 %.
  EXPECT_LT(mid_u, 3e-2);
  // Downstream of the 1D-to-2D interface: measured 0.77 % (10 mm; 0.77 % at 5 mm since
  // 2026-12-06, up 0.78 % in the 1D part); asserted 1.5 % (before the fix of the
  // gate's partly open top row this part was 3 to 10 % slow, docs/validation.md).
  EXPECT_LT(dn_u, 1.5e-2);
  // No jump of u_mean across either interface beyond the full 2D run's own change between the
  // same two cells: measured 0.08 % at 0.2 m and 0.02 % at 0.7 m when written; at 2c15936
  // 0.10 % and 0.47 %; since the DAM takes minmod at steep fronts (issue 12's coupled 1D-tip
  // fix) 0.003 % and 1.02 % (with Minmod throughout the DAM 0.04 % / 0.17 %). The jump at 0.7 m
  // is the history of the markers in a layer under one cell deep (mean h 6.5 mm at 10 mm
  // cells; the front crossed it at 0.45 s): the DAM's steady state is the same (no cell takes
  // the minmod fallback after 0.9 s). Asserted 1 % at 0.2 m, 1.5 % at 0.7 m.
  EXPECT_LT(j1u, 1e-2);
  EXPECT_LT(j2u, 1.5e-2);
  // Mass per length of each part (steady: q / u_mean, so it follows u_mean): measured 0 % /
  // 1.9 % / 0.3 % without sub-cycling; asserted 2 % in the gate part and 4 % in the 1D part. The pointwise h
  // differences (L2 about 10 % beyond 0.2 m) are the marker depth's quantisation in a layer
  // under one cell deep, in both runs, and are not asserted.
  EXPECT_LT(mh[0], 2e-2);
  EXPECT_LT(mh[1], 4e-2);
  // (With the DAM sub-cycled inside the 2D step, Decomposition->Sub-cycling, 2.7 % in the
  // downstream part: the DAM at its own CFL step is less diffusive than at the 2D parts' step,
  // and the thin layer it passes on is the marker depth's quantum deep; asserted 3.5 % there.)
  EXPECT_LT(mh[2], 3.5e-2);
}

// The 1D -> 2D inflow does not depend on the time step. The DAM's outgoing ledger term of a step
// is dt times its end flux plus an averaging term of the staggered scheme that does not shrink
// with dt and alternates in sign from step to step. The 2D side's inflow velocity carried the
// whole term through the DAM's depth, so in steps shorter than the stable one it swung by up to
// +-20 % around the DAM's u_mean and the first 2D columns ran slower and deeper (Setup I coupled,
// 5 mm, steps of 2e-4 s: u_mean 2.39-2.40 against 2.51-2.53 m/s at the stable step, L2 against
// full 2D 1.7 % against 1.0 %; docs/validation.md, "The 1D-to-2D inflow and the time step"). The
// opening now takes the DAM's u_mean (eq. 24) with the mass in its depth, and the averaging
// terms wait in a pool that enters at the rate the flow crosses a 2D cell. Steady Setup I
// (L = 1 m, 10 mm, open end), the paper's layout, run with the stable step and with a third of
// it: the downstream 2D part [0.7, 1] m at t = 1 s against full 2D at the stable step (at 5 mm
// full 2D moves by 0.06-0.7 % in u_mean L2 when its step is held at 4e-4 s), and the two coupled
// runs against each other. Before the change: 0.29 / 1.33 % against full 2D, 1.49 % apart, first
// columns 2.645 / 2.581 m/s (the first and the last comparison below failed); after: 0.45 / 0.49 %,
// 0.17 % apart, 2.640 / 2.643 m/s (full 2D 2.642).
TEST(Coupled2D, InflowThroughA1DTo2DInterfaceDoesNotDependOnTheStep) {
  Chute full;
  full.name = "dtin_full";
  full.model = "N-DAM";
  full.end_time = 1.0;
  Chute cpl = full;
  cpl.model = "Coupled";
  cpl.name = "dtin_coupled";
  auto f = full.build();
  run(*f, 1.0);
  auto run_cut = [](core::Stepper& s, double t_end, double cut) {
    while (s.time() < t_end - 1e-12) {
      s.step(std::min(s.stable_dt() / cut, t_end - s.time()));
      ASSERT_TRUE(s.check().ok);
      s.accept();
    }
  };
  auto a = cpl.build();
  cpl.name = "dtin_coupled_third";
  auto b = cpl.build();
  run_cut(*a, 1.0, 1.0);
  run_cut(*b, 1.0, 3.0);
  const auto pf = f->profile(), pa = a->profile(), pb = b->profile();
  ASSERT_EQ(pf.x.size(), pa.x.size());
  ASSERT_EQ(pf.x.size(), pb.x.size());
  std::vector<double> uf, ua, ub, hf;
  double first_a = 0.0, first_b = 0.0;  // mean u_mean of the first three 2D columns
  for (std::size_t i = 0; i < pf.x.size(); ++i)
    if (pf.x[i] > 0.7) {
      uf.push_back(pf.u_mean[i]);
      ua.push_back(pa.u_mean[i]);
      ub.push_back(pb.u_mean[i]);
      hf.push_back(pf.h[i]);
      if (uf.size() <= 3) {
        first_a += pa.u_mean[i] / 3.0;
        first_b += pb.u_mean[i] / 3.0;
      }
    }
  const double ea = rel_l2(uf, ua, hf, 1e-3), eb = rel_l2(uf, ub, hf, 1e-3);
  const double eab = rel_l2(ua, ub, hf, 1e-3);
  std::printf("[measured] 1D->2D inflow, 10 mm, t = 1 s, [0.7, 1] m: u_mean L2 against full 2D "
              "%.2e (stable step, %ld steps) / %.2e (a third, %ld steps), between them %.2e; first "
              "three 2D columns u_mean %.4f / %.4f m/s\n",
              ea, a->steps(), eb, b->steps(), eab, first_a, first_b);
  ASSERT_GT(b->steps(), 2 * a->steps());
  // Cutting the step may not move the coupled run away from full 2D: the shorter step's error
  // at most that of the stable step plus 0.5 % (the full 2D run's own dt sensitivity at 5 mm
  // reaches 0.7 %; measured +0.04 %, +1.0 % before the change).
  EXPECT_LT(eb, ea + 5e-3);
  // The two coupled runs differ by under 1.5 % (the coupling's own error against full 2D at the
  // stable step is 0.3-0.5 % here and 1-1.5 % at 5 mm; measured 0.17 %, 1.49 % before), and the
  // first columns' speed by under 1.5 % (measured 0.1 %, 2.4 % before).
  EXPECT_LT(eab, 1.5e-2);
  EXPECT_LT(std::abs(first_b / first_a - 1.0), 1.5e-2);
}

namespace {
/// The 2D subdomains of a model: the model itself (N-DAM) or the 2D parts of a coupled one.
std::vector<const ndam::NdamSolver*> two_d_parts(const core::Stepper& s) {
  std::vector<const ndam::NdamSolver*> out;
  if (const auto* n = dynamic_cast<const ndam::NdamSolver*>(&s)) out.push_back(n);
  if (const auto* c = dynamic_cast<const coupling::CoupledModel*>(&s))
    for (const auto& p : c->parts())
      if (const auto* n = dynamic_cast<const ndam::NdamSolver*>(p.model.get())) out.push_back(n);
  return out;
}
/// Hole cells (enclosed voids, ndam::enclosed_voids) of every 2D subdomain of the model.
std::size_t hole_cells(const core::Stepper& s) {
  std::size_t n = 0;
  for (const auto* nd : two_d_parts(s)) {
    const auto& g = nd->grid();
    std::vector<ndam::CellFlag> f(static_cast<std::size_t>(g.nx * g.nz));
    for (int gi = 0; gi < g.nx; ++gi)
      for (int k = 0; k < g.nz; ++k) f[static_cast<std::size_t>(gi * g.nz + k)] = nd->flag(gi, k);
    n += ndam::enclosed_voids(f, g.nx, g.nz, nd->void_sides()).size();
  }
  return n;
}
/// Bottom pressure [Pa] of the wall column (the last 2D subdomain's last column).
// The pressure at the foot of the wall: the mean over the wall column's cells in the bottom
// 1 cm (one cell's value swings by 10-20 % from step to step in the resting deposit, in both
// runs; the 1 cm mean is the figure an engineer reads off a pressure cell).
double wall_bottom_pressure(const core::Stepper& s, double band = 0.01) {
  const auto* nd = two_d_parts(s).back();
  const auto& g = nd->grid();
  const auto p = nd->gather_p();
  const int n = std::max(1, static_cast<int>(std::lround(band / g.dz())));
  double sum = 0.0;
  for (int k = 0; k < n; ++k) sum += p[static_cast<std::size_t>((g.nx - 1) * g.nz + k)];
  return sum / n * 1440.0;
}
}  // namespace

// The deposit of Setup II at the wall, coupled (2D [0, 0.2] / 1D [0.2, 0.7] / 2D [0.7, 1]) against
// full 2D, 10 mm cells, Height 0.3 m, to t = 1 s (issue 11 item 3). The front reaches the wall
// at about 0.6 s; the deposit then grows to 0.16 m at the wall, inside the downstream 2D
// subdomain, whose material has entered through the 1D-to-2D interface at 2.6 m/s. Before the
// fix of the marker injection (markers at the strip centres of the interface's inflow, which the
// deposit's deceleration spread into lines with empty cells between them; see
// MarkersInflow.DeceleratedLayerLeavesNoEmptyCellInside) this run measured 111 hole cell-steps
// in the deposit (0 in full 2D), u_mean L2 up to 19 %, a wall column of 0.214 m against 0.154 m
// at 1 s, and 0.05 s means of the wall-bottom pressure up to 36 % off; each assertion below
// failed.
//
// Run at the issue's resolution, 5 mm, to its 1.5 s (about 30 s for the two runs): at 10 mm the
// 1D part's front differs from the 2D one by more (u_mean L2 up to 5.7 % at 10 mm after the DAM's
// deposit fixes of issue 12, 2.1 % at 5 mm), which is the DAM's resolution, not the coupling.
TEST(Coupled2D, SetupIIDepositAtTheWallMatchesFull2D) {
  Chute full;
  full.name = "deposit_full";
  full.model = "N-DAM";
  full.wall = true;
  full.cell = 0.005;
  full.height = 0.3;  // the wall column of the coupled run used to climb past 0.15 m
  full.end_time = 1.5;
  // Momentum solves to 1e-12 instead of the default 1e-10 in both runs. The resting deposit
  // amplifies solver-tolerance differences (docs/validation.md, "Momentum solve on deposits"):
  // with fresh momentum preconditioners at 1e-10 (Gauss-Seidel or MueLu) full 2D and coupled
  // alike open a void in the deposit between 1.45 and 1.5 s (1-2 hole cell-steps each, u_mean
  // L2 0.05 at 1.5 s), with the lagged Gauss-Seidel preconditioner of before and with MueLu at
  // 1e-12 neither does (u_mean L2 at most 0.020 and 0.022). The void is in both runs alike: it
  // is the solve, not the coupling that this test is about.
  full.ndam_extra = R"x(
    <ParameterList name="Momentum solver">
      <Parameter name="Tolerance" type="double" value="1e-12"/>
    </ParameterList>)x";
  Chute cpl = full;
  cpl.name = "deposit_coupled";
  cpl.model = "Coupled";
  auto a = full.build();
  auto b = cpl.build();
  // Steps to t_end, counting the hole cells of every accepted step and integrating the
  // wall-bottom pressure over time.
  struct Log {
    std::size_t holes = 0, voids = 0, open_steps = 0, longest = 0, at_outputs = 0;
    double p_int = 0.0, p2_int = 0.0, p3_int = 0.0, n_int = 0.0, t_int = 0.0;
  } la, lb;
  auto advance = [](core::Stepper& s, double t_end, Log& log) {
    while (s.time() < t_end - 1e-12) {
      const double dt = std::min(s.stable_dt(), t_end - s.time());
      s.step(dt);
      const auto h = s.check();
      ASSERT_TRUE(h.ok) << h.reason << " at x = " << h.x;
      s.accept();
      const std::size_t holes = hole_cells(s);
      log.holes += holes;
      // a void that opens (none in the step before), and how many steps the longest one lasted
      if (holes > 0 && log.open_steps == 0) ++log.voids;
      log.open_steps = holes > 0 ? log.open_steps + 1 : 0;
      log.longest = std::max(log.longest, log.open_steps);
      log.p_int += wall_bottom_pressure(s) * dt;
      log.p2_int += wall_bottom_pressure(s, 0.02) * dt;
      log.p3_int += wall_bottom_pressure(s, 0.03) * dt;
      const auto w = s.wall_load();
      ASSERT_TRUE(w.has_value());
      log.n_int += w->normal * dt;
      log.t_int += dt;
    }
  };
  // The deposit profile: the columns beyond x = 0.85 m (the shock stays downstream of 0.9 m),
  // h averaged over three neighbouring columns (the count depth of a single column scatters by
  // one or two marker rows of 2.5 mm: column by column, two full 2D runs that differ only in
  // where the markers are injected differ by 5-7 % (L2) from 0.75 s on, 1.5-4 % with the
  // three-column mean; measured with strip-centre and random-height injection).
  auto deposit = [](const core::Profile& p, std::vector<double>& h) {
    h.clear();
    const std::size_t n = p.x.size();
    for (std::size_t i = 0; i < n; ++i)
      if (p.x[i] > 0.85) {
        const std::size_t l = i - 1, r = std::min(i + 1, n - 1);
        h.push_back((p.h[l] + p.h[i] + p.h[r]) / static_cast<double>(r - l + 1));
      }
  };
  double worst_u = 0, worst_dep = 0, worst_wall = 0, worst_p = 0, worst_p1 = 0, worst_n = 0;
  for (int q = 1; q <= 30; ++q) {
    const double t = 0.05 * q;
    for (Log* l : {&la, &lb}) l->p_int = l->p2_int = l->p3_int = l->n_int = l->t_int = 0.0;
    advance(*a, t, la);
    advance(*b, t, lb);
    la.at_outputs += hole_cells(*a);
    lb.at_outputs += hole_cells(*b);
    const auto A = a->profile(), B = b->profile();
    ASSERT_EQ(A.x.size(), B.x.size());
    std::vector<double> da, db;
    deposit(A, da);
    deposit(B, db);
    const double u_l2 = rel_l2(A.u_mean, B.u_mean, A.h, 1e-3);
    const double dep_l2 = rel_l2(da, db, da, 1e-3);
    const double wall = A.h.back() > 0 ? B.h.back() / A.h.back() - 1.0 : 0.0;
    const double pa = la.p_int / la.t_int, pb = lb.p_int / lb.t_int;
    const double pr = pa > 0 ? pb / pa - 1.0 : 0.0;
    const double p2a = la.p2_int / la.t_int, p2b = lb.p2_int / lb.t_int;
    const double p3a = la.p3_int / la.t_int, p3b = lb.p3_int / lb.t_int;
    const double na = la.n_int / la.t_int, nb = lb.n_int / lb.t_int;
    const double nr = na > 0 ? nb / na - 1.0 : 0.0;
    std::printf("[measured] Setup II deposit, 5 mm, t = %.2f s: hole cell-steps full %zu coupled "
                "%zu; coupled vs full u_mean L2 %.4f, deposit (x > 0.85 m, 3-column mean) h L2 %.4f, wall "
                "column %.4f / %.4f m, wall-bottom p (mean over the last 0.05 s) %.0f / %.0f "
                "Pa, bottom 2 cm %.0f / %.0f, 3 cm %.0f / %.0f, wall normal force %.1f / %.1f N/m\n",
                t, la.holes, lb.holes, u_l2, dep_l2, B.h.back(), A.h.back(), pb, pa, p2b, p2a, p3b, p3a, nb, na);
    if (t < 0.65 - 1e-9) continue;  // before and at the impact (the front reaches the wall
                                     // about 0.01 s earlier in the coupled run)
    worst_u = std::max(worst_u, u_l2);
    // The deposit from 0.75 s, when it spans six columns and more (at 0.65-0.7 s it is a wall
    // column still rising by 0.8 m/s, and the 0.01 s earlier impact of the coupled run alone
    // makes 13 % there).
    if (t > 0.75 - 1e-9) {
      worst_dep = std::max(worst_dep, dep_l2);
      worst_wall = std::max(worst_wall, std::abs(wall));
    }
    // the wall pressure after the impact peak (at 5 mm the peak falls in the window ending at
    // 0.65 s: 4.5 against 5.1 kPa, the coupled front arriving a few ms earlier)
    if (t > 0.7 - 1e-9) {
      worst_p = std::max(worst_p, std::abs(p3a > 0 ? p3b / p3a - 1.0 : 0.0));
      worst_p1 = std::max(worst_p1, std::abs(pr));
      worst_n = std::max(worst_n, std::abs(nr));
    }
  }
  std::printf("[measured] Setup II deposit from 0.7 s, coupled vs full: wall-bottom p (bottom 3 cm) "
              "%.4f, (bottom 1 cm) %.4f; wall normal force %.4f\n", worst_p, worst_p1, worst_n);
  // No hole in the full 2D run at any step (measured: none); no hole in the coupled run at any
  // output (the issue's criterion), and between outputs at most one void of a single cell that
  // opens in the deposit and closes within a few steps, the kind the comment above describes for
  // both runs at other solver settings. Measured: none before issue 12's coupled 1D-tip fix of
  // the DAM; 2 cell-steps of one void at 1.30-1.35 s after it; with the exact 2D -> 1D
  // interface mass (Interface::settle) one cell for 5 steps, 1.3572-1.3608 s (3.6 ms of the
  // run's ~2800 steps); with the 1D -> 2D inflow at the DAM's velocity (kInflowDeepen) none.
  // Asserted: one void, closed within 10 steps (a void that stayed, the fault of issue 11
  // item 3, was 63 hole cells over 31 outputs).
  std::printf("[measured] hole cell-steps full %zu coupled %zu; voids full %zu coupled %zu, "
              "longest %zu / %zu steps; holes at outputs full %zu coupled %zu\n",
              la.holes, lb.holes, la.voids, lb.voids, la.longest, lb.longest, la.at_outputs,
              lb.at_outputs);
  EXPECT_EQ(la.holes, 0u);
  EXPECT_EQ(lb.at_outputs, 0u);
  EXPECT_LE(lb.voids, 1u);
  EXPECT_LE(lb.longest, 10u);
  // From 0.65 s (after the impact peak) to 1 s at every output:
  // u_mean within the issue's 3 % (L2; measured at most 2.2 % at 5 mm with the 1e-12 momentum
  // solves, 2.0-2.1 % before at 1e-10; the DAM's own 2 % faster flow over [0.2, 0.7] m is in it,
  // docs/validation.md; with the Material share, the default since session 45, 1.2-2.7 %);
  EXPECT_LT(worst_u, 0.03);
  // from 0.75 s the deposit profile within the issue's 5 % (L2 of the three-column mean over
  // x > 0.85 m; measured at most 3.8 % at 5 mm, against the 1.5-4 % two full 2D runs differ by;
  // with the Material share 1.7-4.8 %);
  EXPECT_LT(worst_dep, 0.05);
  // and the depth at the wall within 10 % (one column, not averaged: measured at most 3.5 % with
  // the Full cell; 5.5 % at 1.5 s with the short-step inflow velocity of 2026-12-01, 0.2 % since
  // the inflow takes the DAM's u_mean (2026-12-02); with the Material share, the default since
  // session 45, 6.4-8.4 %: its full 2D wall column stands a run-up above its neighbours that the
  // coupled run's does not, while the three-column mean above agrees within 4.8 %; the
  // single-column scatter above is 5-7 %);
  EXPECT_LT(worst_wall, 0.10);
  // the wall-bottom pressure, averaged over each output interval (the single-step value of one
  // cell swings by 10-20 % in both runs), within the issue's 10 % from 0.7 s at every output,
  // as the mean over the bottom 3 cm of the wall column (6 cells; measured at most 4.1 %). Why
  // not the bottom 1 cm (2 cells): between 0.95 and 1.1 s the pressure of the nearly rigid pile
  // oscillates from cell to cell up the corner (odd-even, +-50 % between neighbours at 1.05 s:
  // 1071 / 2624 / 899 Pa in cells 1-3), and 10-20 ms dips of 20-30 % of the bottom cells come
  // and go in either run at times that move with dt: full 2D alone moved by 17 % (bottom cell,
  // 0.05 s mean at 1.05 s) when dt halved, coupled vs full was 9-10 % at CFL 0.5 and 27 % at
  // CFL 0.25 in app runs of this scene; here 18.5 % at 1.05 s. Over the bottom 2 cm the two
  // runs differ by at most 7.4 %, over 3 cm by 4.1 %, and the wall's normal force by 2.9 %:
  // the pressure moves between the bottom cells, not off the wall. Outside 0.95-1.1 s the
  // bottom 1 cm agrees to 3 %.
  EXPECT_LT(worst_p, 0.10);
  // the load on the wall (normal force, wall.csv), the integral over the column, within the
  // issue's 10 % at every output from 0.7 s (measured at most 2.9 %).
  EXPECT_LT(worst_n, 0.10);
}

// wall.csv and summary.json's wall_load come from the part at the end wall when a model there
// resolves the wall's pressure (2D): the shipped coupled Setup II has one. With a 1D part there
// and a static layout nothing can, and the run wrote an empty wall.csv and a summary of zeros
// beside a 0.1 m deposit (an independent tester); now it writes none (end_wall() is false).
TEST(Coupled2D, AWallSeriesOnlyWhereAModelResolvesTheWall) {
  const std::string in = std::string(GRANFLOW_INPUTS) + "/setup2_coupled.xml";
  std::ifstream f(in);
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const std::string shipped = "value=\"{2D, 1D, 2D}\"";
  const auto at = text.find(shipped);
  ASSERT_NE(at, std::string::npos);
  EXPECT_TRUE(scene::build_model(scene::load(in))->end_wall());
  text.replace(at, shipped.size(), "value=\"{2D, 1D, 1D}\"");
  const std::string one_d_at_wall = testing::TempDir() + "coupled_1d_at_wall.xml";
  std::ofstream(one_d_at_wall) << text;
  const auto m = scene::build_model(scene::load(one_d_at_wall));
  EXPECT_FALSE(m->end_wall());
  EXPECT_FALSE(m->wall_load().has_value());
}

// An initial layer in one 2D part of a layout with two (a block released at the wall behind the
// paper's Setup II layout, no gate): the channel's layer belongs to the part it lies in, and the
// other 2D part starts empty. Each part built the channel's layer for itself, so the gate part,
// which the layer does not reach, refused it as "holding no marker" and no layout with two 2D
// parts took an initial layer (an independent run, session 44: exit 2 with a message naming a
// depth 16 times the minimum it quoted). Asserted: the scene builds, the layer's mass
// (0.02 m x 0.2 m = 0.004 m^2, a whole number of markers: 640 of 1e-4 / 16 m^2 at 10 mm) is
// all in the wall part and none in the gate part, and after 0.3 s of sliding into the wall
// (25 deg over delta = 22) the mass is conserved to round-off and none of it has left the wall
// part (the layer only moves downslope).
TEST(Coupled2D, InitialLayerInOneOfTwoTwoDParts) {
  Chute c;
  c.name = "layer_in_wall_part";
  c.wall = true;
  c.gate = false;
  c.slope = 25.0;
  c.end_time = 0.3;
  c.ndam_extra = R"x(
    <Parameter name="Initial depth" type="double" value="0.02"/>
    <Parameter name="Initial x0" type="double" value="0.8"/>
    <Parameter name="Initial x1" type="double" value="1.0"/>)x";
  auto b = c.build();
  const auto& cm = coupled(*b);
  ASSERT_EQ(cm.parts().size(), 3u);
  const auto start = b->mass_balance();
  EXPECT_NEAR(start.current, 0.004, 1e-15);
  EXPECT_EQ(cm.parts()[0].model->mass_balance().current, 0.0);
  EXPECT_EQ(cm.parts()[1].model->mass_balance().current, 0.0);
  EXPECT_NEAR(cm.parts()[2].model->mass_balance().current, 0.004, 1e-15);
  run(*b, c.end_time);
  const auto end = b->mass_balance();
  std::printf("[measured] layer in the wall part, 10 mm, %.1f s: mass %.6e m^2, defect %.2e; "
              "gate part %.2e, 1D part %.2e m^2\n", c.end_time, end.current, end.defect(),
              cm.parts()[0].model->mass_balance().current,
              cm.parts()[1].model->mass_balance().current);
  EXPECT_LT(std::abs(end.defect()), 1e-15);  // round-off of sums of 640 marker areas
  EXPECT_EQ(cm.parts()[0].model->mass_balance().current, 0.0);
  EXPECT_EQ(cm.parts()[1].model->mass_balance().current, 0.0);
}

namespace {
// A layer 0.02 m deep at rest on 25 deg (delta 22, phi 33 deg), a free-slip wall at x = 0 and an
// open end at x = 2 m: full 2D ("N-DAM") or 2D [0, 1] / 1D [1, 2] m ("Coupled", the DAM part
// starting from the same layer), cells of `cell` m in x and z, a box 0.05 m high.
Chute plug_scene(const std::string& model, double cell, const std::string& name) {
  Chute c;
  c.name = name;
  c.model = model;
  c.models = "2D, 1D";
  c.interfaces = "1.0";
  c.length = 2.0;
  c.slope = 25.0;
  c.cell = cell;
  c.height = 0.05;
  c.gate = false;
  c.left_side = "Free-slip";
  c.end_time = 0.5;
  c.ndam_extra = R"x(
    <Parameter name="Initial depth" type="double" value="0.02"/>)x";
  if (model == "Coupled") {
    c.ndam_extra += R"x(
    <Parameter name="Initial x0" type="double" value="0.0"/>
    <Parameter name="Initial x1" type="double" value="1.0"/>)x";
    c.top_extra = R"x(
  <ParameterList name="Initial condition">
    <Parameter name="Type" type="string" value="Dam break"/>
    <Parameter name="Left depth" type="double" value="0.0"/>
    <Parameter name="Right depth" type="double" value="0.02"/>
    <Parameter name="Position" type="double" value="1.0"/>
  </ParameterList>)x";
  }
  return c;
}
}  // namespace

// A 2D -> 1D interface must not hold back the 2D part upstream of it. A uniform layer released
// from rest slides as a plug in either model; the 2D side's open outflow continued the lagged
// velocity difference of its last two faces, and the projection, which takes that face as given,
// slowed the interior faces where the outflow was slower, which made the difference more
// negative: a feedback that ran into its 5 % bound within 0.2 s. The Drucker-Prager plug then
// carried the braking to the whole 2D part (bed pressure up to 2.2 times hydrostatic) and it ran
// at 0.75 / 0.64 of a t at t = 1 s at 5 / 2.5 mm against 1.02 in full 2D (an independent run,
// 2026-12-06); only an accelerating difference is continued now (NdamSolver::outflow_slope).
// Asserted at every output (0.05 s) to 0.5 s, at 5 and 2.5 mm: u_mean of every column of
// [0.5, 0.9] m within 8 % of the full 2D run at the same resolution and step sequence (outputs
// every 0.05 s). Measured: 4.4 / 3.7 % (before: 16.1 / 22.4 % at 0.5 s, growing in time and
// with refinement). The bound: the full 2D run's own dependence on its step sequence here is
// about as large (this non-periodic layer at 5 mm: 0.93-0.96 a t at 0.5 s with outputs every
// 0.05 s, 0.99-1.01 a t with outputs every 0.1 s; issue 11's plug from rest), so the coupled
// run, whose sub-cycled steps differ, is held to 8 %.
TEST(Coupled2D, TwoDToOneDInterfaceDoesNotBrakeAPlug) {
  for (const double cell : {0.005, 0.0025}) {
    const std::string tag = cell > 0.004 ? "5mm" : "2p5mm";
    auto full = plug_scene("N-DAM", cell, "plug_full_" + tag).build();
    auto cpl = plug_scene("Coupled", cell, "plug_cpl_" + tag).build();
    double worst = 0.0, worst_t = 0.0;
    for (int n = 1; n <= 10; ++n) {
      const double t_out = 0.05 * n;
      run(*full, t_out);
      run(*cpl, t_out);
      const auto pf = full->profile(), pc = cpl->profile();
      int columns = 0;
      for (std::size_t i = 0; i < pf.x.size(); ++i) {
        if (pf.x[i] < 0.5 || pf.x[i] > 0.9) continue;
        std::size_t j = 0;  // the same column of the coupled run's profile
        while (j + 1 < pc.x.size() && std::abs(pc.x[j] - pf.x[i]) > 1e-9) ++j;
        ASSERT_NEAR(pc.x[j], pf.x[i], 1e-9);
        ASSERT_GT(pf.u_mean[i], 0.0);
        const double d = std::abs(pc.u_mean[j] / pf.u_mean[i] - 1.0);
        if (d > worst) worst = d, worst_t = t_out;
        ++columns;
      }
      ASSERT_GT(columns, 10);
    }
    std::printf("[measured] plug through a 2D -> 1D interface, %s: u_mean on [0.5, 0.9] m at most "
                "%.2f %% from full 2D (t = %.2f s)\n", tag.c_str(), 100.0 * worst, worst_t);
    EXPECT_LT(worst, 0.08) << tag;
  }
}
