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

// Mass through the interfaces of Setup II coupled (2D [0, 0.2] / 1D [0.2, 0.7] / 2D [0.7, 1],
// wall at x = 1 m) to t = 0.75 s, when material has crossed both interfaces and reached the wall.
TEST(Coupled2D, MassThroughInterfacesIsConserved) {
  Chute s;
  s.name = "mass";
  s.wall = true;
  s.end_time = 0.75;
  auto m = s.build();
  run(*m, s.end_time);
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
  // u_mean (eqs. 19-21), the 2D side counts the markers that left. On the staggered grid the
  // DAM's end cell is centred at x_IF and its ledger has already taken in about half a cell,
  // dx h / 2, that the 2D side still holds (given back on the next, primary step; seen in a
  // staggered state: in - out = 8.47e-5 m^2 against dx h / 2 = 8.9e-5 m^2). Measured here
  // (primary grid at t = 0.75 s): -0.065 % of the transfer with CG for the momentum solve,
  // -0.53 % (5.8e-5 m^2) with GMRES, and -0.36 % (-3.9e-5 m^2, staggered grid, where the
  // half-cell argument would predict the opposite sign) with GMRES + Gauss-Seidel: all solve to
  // 1e-10, but the marker paths, and with them the cells the markers cross, differ within that
  // tolerance, so this non-exact interface's mismatch moves by that much, in either direction.
  // Bound: the two estimates differ by less than the mass of one DAM cell at the interface,
  // dx h = 2 x 8.3e-5 m^2 here (1.5 % of the transfer): the DAM's end cell reaches dx/2 into
  // the 2D side and its ghost samples the 2D column dx/2 upstream of x_IF.
  EXPECT_NEAR(i0[1], i0[0], 2.0 * half_cell);
  // Total balance: the 2D subdomains' marker ledgers are exact (defect 0), the DAM's is exact
  // up to its positivity fixes at the front, so the coupled defect is the 2D->1D mismatch plus
  // the 1D->2D pending mass plus the subdomains' own defects, to round-off.
  EXPECT_NEAR(defects[0], 0.0, 1e-15);
  EXPECT_NEAR(defects[2], 0.0, 1e-15);
  EXPECT_NEAR(mb.defect(), (i0[1] - i0[0]) + (i1[1] - i1[0]) + parts_defect, 1e-12);
  // The whole balance therefore closes to within those bounds: one DAM cell at 0.2 m, the
  // pending markers at 0.7 m and the DAM's own positivity defect (measured -4.8e-5 m^2 of
  // 0.0165 m^2, 0.3 %).
  EXPECT_LT(std::abs(mb.defect()), 2.0 * half_cell + 24 * 6.25e-6 + std::abs(defects[1]));
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
  std::printf("[measured] steady flow, L = 1 m, 10 mm, t = 1 s: full 2D change 0.9 -> 1 s %.2e; "
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
  // Downstream of the 1D-to-2D interface: measured 0.77 %; asserted 1.5 % (before the fix of the
  // gate's partly open top row this part was 3 to 10 % slow, docs/validation.md).
  EXPECT_LT(dn_u, 1.5e-2);
  // No jump of u_mean across either interface beyond the full 2D run's own change between the
  // same two cells: measured 0.08 % at 0.2 m and 0.02 % at 0.7 m; asserted 1 %.
  EXPECT_LT(j1u, 1e-2);
  EXPECT_LT(j2u, 1e-2);
  // Mass per length of each part (steady: q / u_mean, so it follows u_mean): measured 0 % /
  // 1.9 % / 0.3 %; asserted 2 % in the 2D parts and 4 % in the 1D part. The pointwise h
  // differences (L2 about 10 % beyond 0.2 m) are the marker depth's quantisation in a layer
  // under one cell deep, in both runs, and are not asserted.
  EXPECT_LT(mh[0], 2e-2);
  EXPECT_LT(mh[1], 4e-2);
  EXPECT_LT(mh[2], 2e-2);
}
