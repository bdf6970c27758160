// N-DAM free surface, Coulomb sliding and the chute boundaries (issue 4): verification cases of
// DESIGN.md section 7 on small grids (each well under 60 s).
#include "ndam_chute_util.hpp"

#include "granflow/io/fields.hpp"
#include "granflow/markers/markers.hpp"
#include "granflow/scene/scene.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <cmath>

namespace {

using namespace granflow;
using namespace ndam_chute;

void run_to(ndam::NdamSolver& s, double t_end, double dt_max) {
  while (s.time() < t_end - 1e-12) {
    const double dt = std::min({s.stable_dt(), dt_max, t_end - s.time()});
    s.step(dt);
    const auto h = s.check();
    ASSERT_TRUE(h.ok) << h.quantity << " " << h.reason << " at x = " << h.x;
    s.accept();
  }
}

}  // namespace


// A free-surface pool at rest in a closed box (no slope) stays at rest and flat: the surface
// cells take p = 0 and the Fluid cells below the hydrostatic pressure, so the projection finds
// no flow. Tolerances: |u| < 1e-3 m/s after 0.3 s (gravity would give 3 m/s in that time, so
// this is a balance to 3e-4 of the driving force) and the column depths stay equal to the
// marker resolution dz / n (count-based depth: one marker row is dz / 4).
TEST(NdamFreeSurface, PoolAtRestStaysFlat) {
  const FsCase c = closed_pool(20, 10, 0.2, 0.1, 0.055);
  auto s = make_fs(c);
  const auto m0 = s->mass_balance();
  run_to(*s, 0.3, 0.01);
  const auto p = s->profile();
  const double hmax = *std::max_element(p.h.begin(), p.h.end());
  const double hmin = *std::min_element(p.h.begin(), p.h.end());
  EXPECT_LT(ndam_test::max_abs(s->gather_u()), 1e-3);
  EXPECT_LT(ndam_test::max_abs(s->gather_w()), 1e-3);
  EXPECT_LE(hmax - hmin, 0.25 * c.lz / c.nz + 1e-12);
  const auto m1 = s->mass_balance();
  EXPECT_NEAR(m1.current, m0.initial, 1e-14);  // markers are neither created nor lost
  // bottom-cell pressure: hydrostatic g (h - dz/2) with p = 0 at the marker surface h (the
  // Surface cell's Dirichlet value carries the sub-cell position of the surface); 1 %: the
  // pressure of a rest state is exact up to the solver tolerance, the margin covers the
  // lagged normal-stress term of the first steps.
  const auto pp = s->gather_p();
  const double dz = c.lz / c.nz;
  const double p_bottom = pp[static_cast<std::size_t>(10 * c.nz + 0)];
  const double expect = 9.81 * (c.depth - 0.5 * dz);
  EXPECT_NEAR(p_bottom, expect, 0.01 * expect);
}

// The pressure at t = 0 (eq. 10) takes the free surface's Dirichlet values as every step does:
// p = 0 at the markers' surface inside the top cell, not at its centre. A pool whose surface lies
// a quarter cell above the top cell's centre (h = 57.5 mm in 10 mm cells) is hydrostatic,
// p = g (h - z) at every material cell centre, right after construction and after a step of
// 1 ms. Before, the t = 0 pressure (fields.h5 and wall.csv at t = 0, and the first step's lagged
// pressure) was g (h_top - z) with h_top the top cell's centre: here g dz / 4 = 0.0245 m^2/s^2
// low everywhere (a hostile-user run: 10 % at the foot of a 5 mm pool). Tolerance 1e-8 m^2/s^2:
// the projection solves to 1e-10 of ||b||, ||b|| = O(g h) per cell.
TEST(NdamFreeSurface, PoolStartsHydrostaticFromItsSurface) {
  const FsCase c = closed_pool(20, 10, 0.2, 0.1, 0.0575);
  auto s = make_fs(c);
  const double dz = c.lz / c.nz, g = 9.81;
  auto check = [&](const char* when) {
    const auto pp = s->gather_p();
    double worst = 0.0;
    int cells = 0;
    for (int i = 0; i < c.nx; ++i)
      for (int k = 0; k < c.nz; ++k) {
        const double zc = (k + 0.5) * dz;
        if (zc >= c.depth) continue;
        worst = std::max(worst, std::abs(pp[static_cast<std::size_t>(i * c.nz + k)] - g * (c.depth - zc)));
        ++cells;
      }
    EXPECT_EQ(cells, c.nx * 6) << when;  // six rows of cell centres below 57.5 mm
    EXPECT_LT(worst, 1e-8) << when;
    std::printf("[measured] pool %s: max |p - g (h - z)| = %.2e m^2/s^2 over %d cells\n", when,
                worst, cells);
  };
  check("at t = 0");
  s->step(1e-3);
  ASSERT_TRUE(s->check().ok);
  s->accept();
  check("after one step");
}

// A droplet falls (a Surface cell with all four sides empty: no face of it is an unknown of the
// momentum step, so before NdamSolver::fall_droplets nothing accelerated it and a marker thrown
// off a resting pile flew on at constant velocity: in the 2.5 mm column collapse single markers
// rose at 0.28-0.32 m/s from 1.2 s to the end of the run). A pool 2 cm deep in a closed box of
// 5 mm cells and one marker added at rest at the centre of a cell 5 cm above it, the step held
// at 1 ms. Asserted at every step:
//  - while the marker is in its first cell (22 steps), its height is z0 - g t^2 / 2 to 1e-9 m
//    (Heun's rule is exact for a velocity linear in t; measured to the printed 5 digits);
//  - afterwards it keeps falling (lower at every step) until 60 ms.
// Not asserted, and measured: on entering the next cell the droplet's lower face is the empty
// region's extrapolated value (0 here), the surface rules' continuity share averages it with the
// upper face, and the droplet loses half its speed (0.219 -> 0.170 m/s at 23 ms); at 60 ms it
// falls at 0.255 m/s where g t is 0.584 m/s. Before fall_droplets it stayed at z0.
TEST(NdamFreeSurface, DropletFallsFreely) {
  const FsCase c = closed_pool(20, 20, 0.1, 0.1, 0.02);
  auto st = make_fs(c)->export_state();
  const double dx = c.lx / c.nx, dz = c.lz / c.nz, z0 = 14.5 * dz;
  ndam::Marker drop;
  drop.x = 10.5 * dx;
  drop.z = z0;
  drop.id = ndam::kInjectedIdBase + st.inject_next++;
  st.markers.push_back(drop);
  st.surface_applied = false;
  auto s = make_fs(c, MPI_COMM_WORLD, &st);
  const double g = 9.81, dt = 1e-3;
  double z = z0, zprev = z0;
  int in_first_cell = 0;
  for (int n = 1; n <= 60; ++n) {
    s->step(dt);
    ASSERT_TRUE(s->check().ok);
    s->accept();
    zprev = z;
    for (const auto& m : s->markers()->markers())
      if (m.id == drop.id) z = m.z;
    const double t = n * dt;
    if (z >= 14.0 * dz) {
      ++in_first_cell;
      EXPECT_NEAR(z, z0 - 0.5 * g * t * t, 1e-9) << "step " << n;
    } else {
      EXPECT_LT(z, zprev) << "step " << n;
    }
  }
  std::printf("[measured] droplet: free fall to 1e-9 m for %d steps in its first cell; fell %.4f m "
              "in 60 ms (free fall %.4f m), %.3f m/s at the end (g t = %.3f)\n",
              in_first_cell, z0 - z, 0.5 * g * 0.06 * 0.06, (zprev - z) / dt, g * 0.0595);
  EXPECT_GE(in_first_cell, 20);  // the case tested: a fall of most of a cell from rest
}

// The initial layer holds its rectangle's area (MarkerSet::seed_rectangle): depth x length to
// within one marker per partly covered marker row and column, here the top row and the two end
// columns, so 3 markers of A_m = dx dz / 16. Seeding a marker where its centre lay inside
// rounded the depth to whole marker rows: an independent run (2026-12-05, 10 mm cells, rows of
// 2.5 mm) got nothing for a 1 mm layer, 25 % too much for 2 mm and 2.2 % too little for
// 53.7 mm. A layer on the marker lattice (0.03 m from x = 0) seeds the same markers as before.
TEST(NdamFreeSurface, InitialLayerHoldsItsRectanglesArea) {
  const double am = 0.01 * 0.01 / 16.0;
  for (double depth : {0.001, 0.002, 0.0537, 0.03})
    for (const auto& ab : {std::array<double, 2>{0.0, 1e30}, {0.0137, 0.1921}}) {
      FsCase c = closed_pool(20, 15, 0.2, 0.15, depth);
      c.init_x0 = ab[0];
      c.init_x1 = ab[1];
      auto s = make_fs(c);
      const double exact = depth * (std::min(ab[1], 0.2) - ab[0]);
      const double area = s->markers()->mass().area;
      std::printf("[measured] initial layer %.4f m on [%.4f, %.4f): area %.6e against %.6e "
                  "(%.2f markers)\n",
                  depth, ab[0], std::min(ab[1], 0.2), area, exact, (area - exact) / am);
      EXPECT_NEAR(area, exact, 3.0 * am) << depth << " m on [" << ab[0] << ", " << ab[1] << ")";
      if (ab[0] == 0.0 && depth == 0.03) {  // on the lattice: every marker whole (round-off)
        EXPECT_NEAR(area, exact, 1e-12 * exact);
      }
    }
}

// Material that reaches the top of the box stops the run (NdamSolver::check): the free surface
// has met the lid, and a deposit deeper than the box would be capped with its markers packed
// into the top cells (Setup II at 5 mm to 1.5 s in its 0.15 m box completed with a 0.1525 m wall
// column, mass kept, depth wrong). An initial layer that deep is refused before the run
// (cli.layer_at_box_top), so here the box fills during the run: a horizontal box 0.2 m long and
// 0.1 m high (10 mm cells, 4 x 4 markers per cell: one marker row is 2.5 mm of depth) fed by the
// paper's gate (0.06 m at 0.37 m/s, q = 0.0222 m^2/s) against a wall; its mean depth would reach
// the limit Height - dz / 2 = 0.095 m at 0.86 s. Asserted: the run stops before 1.5 s with the
// quantity "material depth", its value above the limit by less than one cell (the growth of a
// step), at a column inside the box, the message naming N-DAM->Height; and a pool 9 cm deep
// (its surface in the top cell's lower half) runs 0.1 s without stopping.
TEST(NdamFreeSurface, MaterialAtTheTopOfTheBoxStopsTheRun) {
  {
    auto s = make_fs(closed_pool(20, 10, 0.2, 0.1, 0.09));
    run_to(*s, 0.1, 0.01);
    EXPECT_GT(s->time(), 0.1 - 1e-12);
  }
  FsCase c = closed_pool(20, 10, 0.2, 0.1, 0.0);
  c.left = "Inflow";
  auto s = make_fs(c);
  core::Health h;
  while (s->time() < 1.5) {
    s->step(std::min(s->stable_dt(), 0.01));
    h = s->check();
    if (!h.ok) break;
    s->accept();
  }
  std::printf("[measured] box 0.2 x 0.1 m filled by the gate: ok %d at t = %.4f s, %s = %.5f m "
              "at x = %.4f m: %s\n",
              h.ok ? 1 : 0, s->time(), h.quantity.c_str(), h.value, h.x, h.reason.c_str());
  ASSERT_FALSE(h.ok);
  EXPECT_EQ(h.quantity, "material depth");
  EXPECT_GT(h.value, 0.095);
  EXPECT_LT(h.value, 0.095 + 0.01);
  EXPECT_GT(h.x, 0.0);
  EXPECT_LT(h.x, 0.2);
  EXPECT_NE(h.reason.find("N-DAM->Height"), std::string::npos);
}

// A Drucker-Prager layer released from rest on a periodic incline with a Coulomb bed (issue 11
// item 1): with sin(phi) > tan(delta) the basal friction yields before the material does, and
// the layer slides as a rigid plug following the law of the model's own regularised friction
// (12), u' = g sin(zeta) - g cos(zeta) tan(delta) (1 - exp(-m_c u)) from u(0) = 0 (plug_law;
// a t plus ln(1 + tan(delta) / (tan(zeta) - tan(delta))) / m_c = 8.1 mm/s for 40/25 deg). The
// issue's layer (3 cm, dz = 2.5 mm, free surface) with dx = 5 mm (the plug is uniform in x: the
// issue's 1.25 mm gives the same u(t) to 1e-4, measured; NdamPlugLong runs it), three angle
// sets: the issue's 40/25/35 and 30/20/30 and one near the plug limit, 40/30/35.5 (sin(phi) =
// 0.5807 against tan(delta) = 0.5774). At every output from 0.05 s to 1 s, at the CFL step
// (CFL 0.5, Max time step 0.01 s) and at half of it:
// - u_mean within the issue's 1 % of the law (measured at most 0.18 %, at 0.05 s near the plug
//   limit; the lagged drag beta(u^n) u^{n+1} this replaces was 47 % slow at 0.05 s, 3.5 % at 1 s);
// - the error does not grow when dt halves (measured: it shrinks by 1.3-1.5x at 0.05 s; a
//   dt-independent remainder of 0.04-0.09 % at 0.05 s is the creep of the regularised
//   rheology inside the layer, see NdamPlugLong for the observed order);
// - the layer is a plug: u_top - u_bottom of a column within 1 % of the base speed at 1 s.
TEST(NdamCoulomb, PlugFromRestFollowsTheRegularisedLaw) {
  expect_plug_from_rest_follows_law("Surface cells");
}

// A layer of `depth` on the periodic incline of 4 x 24 cells of 5 x 2.5 mm, slope / delta / phi
// `an` [deg], m_c = 100 s/m, the given CFL and 'Surface cell mass'.
FsCase thin_plug(double depth, const std::array<double, 3>& an, double cfl, const char* mass) {
  FsCase c;
  c.nx = 4;
  c.lx = 0.02;
  c.nz = 24;
  c.lz = 0.06;
  c.depth = depth;
  c.slope_deg = an[0];
  c.delta_deg = an[1];
  c.phi_deg = an[2];
  c.m_c = 100.0;
  c.cfl = cfl;
  c.surface_mass = mass;
  return c;
}

// u_mean / law - 1 of the box of `c` at each of `times`, printed at 0.05 / 0.5 / 1 s with the
// worst (`what` names the case); empty if the run did not reach every time.
std::vector<double> plug_errors(const FsCase& c, const std::vector<double>& law,
                                const std::vector<double>& times, const std::string& what) {
  auto s = make_fs(c);
  const auto u = mean_u_at(*s, times, 0.01);
  if (u.size() != times.size()) return {};
  std::vector<double> e;
  double worst = 0.0;
  for (std::size_t q = 0; q < times.size(); ++q) {
    e.push_back(u[q] / law[q] - 1.0);
    if (std::abs(e.back()) > std::abs(worst)) worst = e.back();
  }
  std::printf("[measured] %s, CFL %.2f: u_mean/law - 1 at 0.05 / 0.5 / 1 s %+.3f / %+.3f / "
              "%+.3f %%, worst %+.3f %%\n",
              what.c_str(), c.cfl, 100 * e[0], 100 * e[9], 100 * e[19], 100 * worst);
  return e;
}

// A layer thinner than one cell ('Surface cell mass' = Material share, stability suite case 3 in
// docs/validation.md): 1.25 mm of markers (two of the four marker rows) in 2.5 mm cells on the
// periodic incline. Its momentum rows weight mass and forces by the material share 1/2, so it
// slides by the plug law of the regularised friction like the 3 cm layer above: u_mean within
// 1 % of the law at every output from 0.05 s to 1 s, at the CFL step and at half of it, for the
// issue's 40/25/35 deg and for 30/20/30 deg, and the error does not grow when dt halves
// (measured: at most 0.09 %, halving with dt: 0.045 -> 0.021 % at 0.05 s). As a full cell
// (the default, NaSt2D's) the empty half is driven too and the friction of the true depth
// holds only half of it: measured for contrast (printed), u_mean 62 % (40 deg) and 84 %
// (30 deg) ahead of the law at 1 s.
TEST(NdamCoulomb, ThinLayerSlidesByThePlugLawWithTheMaterialShare) {
  std::vector<double> times;
  for (int q = 1; q <= 20; ++q) times.push_back(0.05 * q);
  for (const auto& an : {std::array<double, 3>{40, 25, 35}, std::array<double, 3>{30, 20, 30}}) {
    const auto law = plug_law(an[0], an[1], 100.0, times);
    std::vector<double> err[2];  // Material share at CFL 0.5 and 0.25
    for (const char* mass : {"Material share", "Full cell"}) {
      for (double cfl : {0.5, 0.25}) {
        char what[96];
        std::snprintf(what, sizeof what, "thin layer %g/%g/%g, %s", an[0], an[1], an[2], mass);
        const auto e = plug_errors(thin_plug(0.00125, an, cfl, mass), law, times, what);
        ASSERT_EQ(e.size(), times.size());
        if (std::string(mass) == "Material share")
          for (std::size_t q = 0; q < times.size(); ++q) {
            EXPECT_LT(std::abs(e[q]), 0.01)
                << an[0] << "/" << an[1] << " CFL " << cfl << " t = " << times[q];
            err[cfl < 0.4 ? 1 : 0].push_back(std::abs(e[q]));
          }
      }
    }
    // halving dt: the error at each output does not grow (1e-5: round-off of u / law)
    ASSERT_EQ(err[0].size(), err[1].size());
    for (std::size_t q = 0; q < err[0].size(); ++q)
      EXPECT_LE(err[1][q], err[0][q] + 1e-5) << an[0] << "/" << an[1] << " t = " << times[q];
  }
}

// A plug whose depth ends inside a cell ('Surface cell mass' = Full cell and weight): the
// momentum step drives the full cells, and the bed friction now carries their weight, so the
// plug follows the law of its regularised friction at depths that end inside a cell, provided
// they end on a marker row (a multiple of dz / 4 with 4 x 4 markers per cell). Layers of 0.5,
// 4.5 and 9.5 cells (1.25, 11.25 and 23.75 mm in 2.5 mm cells) on 30/20/30 and 40/25/35 deg: u_mean within
// 1 % of the law at every output from 0.05 s to 1 s, at CFL 0.5 and 0.25, the error not growing
// as dt halves beyond the friction iteration's floor. The paper's Full cell is run for contrast at CFL
// 0.5 and must be off by more than 3 % at 1 s for the 4.5-cell layer (an independent run
// measured +17 % on 30/20 deg at 10 mm; it is (H - h) / h of the driven excess, here 0.5 / 4.5
// of the weight against the net drive), so that the test tells the two apart. Between marker
// rows the law does not hold (an independent run, session 26: 2.7 cells on 30/20 deg at 5 mm
// -4.7 % at 1 s, worst -11.8 %; the partial row's markers cannot be spread evenly over the
// columns, the columns' depths differ by a quarter row, and the surface pressure pulses as those
// markers cross from column to column; docs/validation.md, "The weight of the full cells").
TEST(NdamCoulomb, PlugEndingOnAMarkerRowFollowsTheLawWithTheFullCellsWeight) {
  std::vector<double> times;
  for (int q = 1; q <= 20; ++q) times.push_back(0.05 * q);
  for (const auto& an : {std::array<double, 3>{30, 20, 30}, std::array<double, 3>{40, 25, 35}}) {
    const auto law = plug_law(an[0], an[1], 100.0, times);
    for (double depth : {0.00125, 0.01125, 0.02375}) {
      std::vector<double> err[2];
      for (const char* mass : {"Full cell and weight", "Full cell"})
        for (double cfl : {0.5, 0.25}) {
          const bool weight = std::string(mass) == "Full cell and weight";
          if (!weight && cfl < 0.4) continue;
          char what[96];
          std::snprintf(what, sizeof what, "plug %g/%g/%g, %.2f cells, %s", an[0], an[1], an[2],
                        depth / 0.0025, mass);
          const auto e = plug_errors(thin_plug(depth, an, cfl, mass), law, times, what);
          ASSERT_EQ(e.size(), times.size());
          for (std::size_t q = 0; weight && q < times.size(); ++q) {
            EXPECT_LT(std::abs(e[q]), 0.01) << an[0] << "/" << an[1] << " depth " << depth
                                            << " CFL " << cfl << " t = " << times[q];
            err[cfl < 0.4 ? 1 : 0].push_back(std::abs(e[q]));
          }
          if (!weight && depth == 0.01125) {
            EXPECT_GT(e[19], 0.03);
          }
        }
      // halving dt: the error does not grow beyond the floor the friction iteration leaves
      // (kFrictionTolerance = 1e-4 of the Coulomb bound: 1e-4 tan(delta) / (tan(zeta) -
      // tan(delta)) of the acceleration, 1.7e-4 on 30/20 deg, NdamPlugLong)
      const double ta = std::tan(an[0] * M_PI / 180.0), td = std::tan(an[1] * M_PI / 180.0);
      const double floor = 1e-4 * td / (ta - td);
      ASSERT_EQ(err[0].size(), err[1].size());
      for (std::size_t q = 0; q < err[0].size(); ++q)
        EXPECT_LE(err[1][q], err[0][q] + floor)
            << an[0] << "/" << an[1] << " depth " << depth << " t = " << times[q];
    }
  }
}

// The creep bound of a layer at rest on `an` = slope / delta / phi [deg] with the regularised
// laws (m_c [s/m], m_y = 100 s): the bed's -ln(1 - tan(zeta) / tan(delta)) / m_c plus the
// rheology's shear tan(zeta) / (sin(phi) m_y) over the full cells' height H.
double rest_creep_bound(const std::array<double, 3>& an, double m_c, double H) {
  const double deg = M_PI / 180.0;
  const double tz = std::tan(an[0] * deg), td = std::tan(an[1] * deg);
  return -std::log(1.0 - tz / td) / m_c + H * tz / (std::sin(an[2] * deg) * 100.0);
}

// A layer released at rest on a slope below its bed friction angle stays at rest at depths that
// end inside a cell on a marker row, with the full cells' weight (20 / 22 / 33 deg, m_c = 1e4
// s/m, m_y = 100 s; the periodic box of
// thin_plug, 2.5 mm cells; 1.5, 4.5 and 9.5 cells deep, to 1 s at CFL 0.5). The momentum step
// drives the partly filled top cell as a full cell; the option loads the bed and the yield
// pressure of the column's cells with the full cells' weight (boundaries.cpp, viscosity.cpp).
// With the weight on the bed alone (session 25) the top cell, held by a yield stress of
// sin(phi) g cos(zeta) (h - k dz) against a drive of g sin(zeta) dz, crept over the cell below
// (a gate pulse on 20 deg at 1-1.5 cm/s for seconds, the Setup II corner block at 11.5 mm/s
// against its 11.4 bound). The creep bound of the regularised laws: the bed's
// -ln(1 - tan(zeta) / tan(delta)) / m_c = 0.23 mm/s, plus the rheology's shear
// tan(zeta) / (sin(phi) m_y) = 6.7e-3 1/s over the full cells' height H, at most 0.17 mm/s:
// u_c = 0.23 mm/s + H tan(zeta) / (sin(phi) m_y). Asserted: |u_mean| < u_c at every output from
// 0.05 s to 1 s. The paper's Full cell beside it: the 1.5-cell layer, driven by two cells and held
// by the friction of 1.5, slides off at (tan(zeta) - 0.75 tan(delta)) g cos(zeta) = 0.56 m/s^2
// (asserted: faster than 0.1 m/s at 1 s).
TEST(NdamCoulomb, LayerEndingOnAMarkerRowRestsBelowDeltaWithTheFullCellsWeight) {
  std::vector<double> times;
  for (int q = 1; q <= 20; ++q) times.push_back(0.05 * q);
  const std::array<double, 3> an{20, 22, 33};
  for (double depth : {0.00375, 0.01125, 0.02375}) {
    const double H = std::ceil(depth / 0.0025 - 1e-9) * 0.0025;
    const double u_c = rest_creep_bound(an, 1e4, H);
    for (const char* mass : {"Full cell and weight", "Full cell"}) {
      const bool weight = std::string(mass) == "Full cell and weight";
      if (!weight && depth > 0.004) continue;
      FsCase c = thin_plug(depth, an, 0.5, mass);
      c.m_c = 1e4;
      auto s = make_fs(c);
      const auto u = mean_u_at(*s, times, 0.01);
      ASSERT_EQ(u.size(), times.size());
      double worst = 0.0;
      for (double v : u) worst = std::max(worst, std::abs(v));
      std::printf("[measured] layer at rest 20/22/33, %.1f cells, %s: |u_mean| at 0.05 / 0.5 / 1 s "
                  "%.2e / %.2e / %.2e m/s, worst %.2e, creep bound %.2e m/s\n",
                  depth / 0.0025, mass, std::abs(u[0]), std::abs(u[9]), std::abs(u[19]), worst,
                  u_c);
      if (weight)
        for (std::size_t q = 0; q < times.size(); ++q)
          EXPECT_LT(std::abs(u[q]), u_c) << depth << " m at t = " << times[q];
      else
        EXPECT_GT(u[19], 0.1);
    }
  }
}

// Between marker rows (4 x 4 markers per cell: depths that are not a multiple of dz / 4) a
// uniform layer cannot give every column the same marker count: the partial row's markers
// (13 of 16 over the box's four columns at 2.7 cells) leave one column a marker deeper, and
// as the layer slides that marker crosses from column to column; with the count depth the
// surface pressure jumped at each crossing (an independent run, session 26). The option's
// column depth shares each marker between its two nearest columns and spreads the depth over
// about two cells (update_profile_cache), so the pressure follows the crossing continuously
// and the pattern of the partial row does not force the layer. 2.5 mm cells, CFL 0.5:
// - plugs of 2.7, 4.3 and 6.6 cells on 30/20/30 and 40/25/35 deg: worst |u_mean / law - 1| over
//   0.05-1 s measured 0.09 / 0.09 / 0.09 % and 0.05 / 0.04 / 0.05 % (sharing only, session 26:
//   0.93 / 2.30 / 1.08 % and 1.26 / 1.80 / 0.21 %; the count depth 21.1 / 1.76 / 1.20 % and
//   9.12 / 1.10 / 0.73 %); asserted within the issue's 1 % at every output;
// - a layer at rest on 20/22/33 deg (m_c = 1e4 s/m) of 2.7 and 4.3 cells to 4 s: |u_mean| at
//   most 0.256 / 0.278 mm/s against the creep bound u_c = 0.281 / 0.315 mm/s of the test above
//   (with the count depth 1.84 / 4.74 mm/s, 6.5 and 15 times it, bursts from about 1.9 s);
//   asserted below u_c at every output.
TEST(NdamCoulomb, LayerBetweenMarkerRowsFollowsTheLawWithTheFullCellsWeight) {
  std::vector<double> times;
  for (int q = 1; q <= 20; ++q) times.push_back(0.05 * q);
  for (const auto& an : {std::array<double, 3>{30, 20, 30}, std::array<double, 3>{40, 25, 35}}) {
    const auto law = plug_law(an[0], an[1], 100.0, times);
    for (double cells : {2.7, 4.3, 6.6}) {
      char what[96];
      std::snprintf(what, sizeof what, "plug between rows %g/%g/%g, %.2f cells", an[0], an[1],
                    an[2], cells);
      const auto e = plug_errors(thin_plug(cells * 0.0025, an, 0.5, "Full cell and weight"), law,
                                 times, what);
      ASSERT_EQ(e.size(), times.size());
      for (std::size_t q = 0; q < times.size(); ++q)
        EXPECT_LT(std::abs(e[q]), 0.01) << what << " t = " << times[q];
    }
  }
  const std::array<double, 3> an{20, 22, 33};
  std::vector<double> t4;
  for (int q = 1; q <= 40; ++q) t4.push_back(0.1 * q);
  for (double cells : {2.7, 4.3}) {
    const double H = std::ceil(cells - 1e-9) * 0.0025;
    const double u_c = rest_creep_bound(an, 1e4, H);
    FsCase c = thin_plug(cells * 0.0025, an, 0.5, "Full cell and weight");
    c.m_c = 1e4;
    auto s = make_fs(c);
    const auto u = mean_u_at(*s, t4, 0.01);
    ASSERT_EQ(u.size(), t4.size());
    double worst = 0.0;
    for (std::size_t q = 0; q < t4.size(); ++q) {
      worst = std::max(worst, std::abs(u[q]));
      EXPECT_LT(std::abs(u[q]), u_c) << cells << " cells at t = " << t4[q];
    }
    std::printf("[measured] layer at rest between rows 20/22/33, %.1f cells: worst |u_mean| to 4 s "
                "%.3e m/s, creep bound %.3e\n", cells, worst, u_c);
  }
}

// The plug law at the depths a user takes, with either consistent surface cell mass
// (scripts/plug_law.py; docs/validation.md, "The plug law at any depth" and "The bed's normal
// stress from the step's own balance"): 5 mm cells, a periodic box of 40 columns (a partial
// marker row leaves a pattern of columns one marker deeper that a box of four cannot hold), 6
// cells high, m_c = 100 s/m, CFL 0.5. Before the column depth was spread over two cells
// (free_surface.cpp), a partial row's pattern forced the near-rigid layer at the grid scale:
// Full cell and weight lagged 9.1 / 10.6 % at 2.3 / 2.8 cells, the Material share 3.5 / 4.3 %
// and ran 13.8 % ahead at 0.46 cells (30/22/33 deg, m_y = 100 s). Before the bed's normal
// stress came from the step's own vertical balance (record_bed_stress), a layer of one full
// cell under a partly filled one (1.4 cells) lagged 0.8-1.0 %, and with the stiffer
// regularisation m_y = 1e4 s the plugs of 2.3-2.8 cells lagged 9-11 % at the CFL step (the
// rotational pressure update's bias in a nu_eff that grows with depth). Measured now at most
// 0.41 % (m_y = 100 s) and 0.455 % (m_y = 1e4 s) at the depths below. Asserted at every output
// from 0.05 to 1 s, on 30/22/33 and 40/25/35 deg, both forms: within the issue's 1 % at 0.46,
// 1.4, 2.3 and 2.8 cells with m_y = 100 s and at 1.4 and 2.8 cells with m_y = 1e4 s. (A layer
// of one partly filled row with m_y = 1e4 s, 0.46-0.9 cells, whose bottom cell is no pressure
// unknown, is within 1.5 % at 5 mm and 3 % at 2.5 mm: not asserted at 1 %.)
TEST(NdamCoulomb, PlugBetweenMarkerRowsFollowsTheLawWithEitherConsistentForm) {
  std::vector<double> times;
  for (int q = 1; q <= 20; ++q) times.push_back(0.05 * q);
  struct Depth {
    double cells, m_y;
  };
  for (const auto& an : {std::array<double, 3>{30, 22, 33}, std::array<double, 3>{40, 25, 35}}) {
    const auto law = plug_law(an[0], an[1], 100.0, times);
    for (const char* mass : {"Material share", "Full cell and weight"})
      for (const Depth& d : {Depth{0.46, 100.0}, Depth{1.4, 100.0}, Depth{2.3, 100.0},
                             Depth{2.8, 100.0}, Depth{1.4, 1e4}, Depth{2.8, 1e4}}) {
        FsCase c;
        c.nx = 40;
        c.lx = 0.2;
        c.nz = 6;
        c.lz = 0.03;
        c.depth = d.cells * 0.005;
        c.slope_deg = an[0];
        c.delta_deg = an[1];
        c.phi_deg = an[2];
        c.m_c = 100.0;
        c.m_y = d.m_y;
        c.cfl = 0.5;
        c.surface_mass = mass;
        char what[112];
        std::snprintf(what, sizeof what, "plug %g/%g/%g, %.2f cells of 5 mm, m_y %g s, %s", an[0],
                      an[1], an[2], d.cells, d.m_y, mass);
        const auto e = plug_errors(c, law, times, what);
        ASSERT_EQ(e.size(), times.size());
        for (std::size_t q = 0; q < times.size(); ++q)
          EXPECT_LT(std::abs(e[q]), 0.01) << what << " t = " << times[q];
      }
  }
}

// A viscous layer at its friction limit creeps at the regularised law's speed, whatever its
// viscosity (an independent run, 2026-12-06). On 21/22/33 deg the bed holds the layer only
// while it slides at u_eq = -ln(1 - tan(zeta) / tan(delta)) / m_c = 0.0300 m/s (m_c = 100 s/m),
// which the law (12) from rest reaches with a time constant of about 50 ms (plug_law). The bed
// takes back the surface's viscous traction, which the implicit scheme's p = 0 leaves in the
// layer's pressure (free_surface.cpp, surface_traction_at_bed); in a uniform layer it is 0 on
// average, but the top cells' w_z is noisy from column to column, and limited to its extending
// part column by column the noise unloaded the bed: with nu = 0.03 m^2/s the layer ran away
// (profiles' u_mean at 1 s 0.051 m/s in whole cells, 0.52 in Material share; 0.030 / 0.025
// before the traction existed). The box: periodic, 0.2 m of 40 x 10 cells of 5 mm, CFL 0.5,
// nu = 0.03 and 0.003. Near the limit the creep speed magnifies an error in the bed's load N:
// du_eq / (dN / N) = tan(zeta) / (tan(delta) - tan(zeta)) / m_c = 0.18 m/s, so 1 % of N is 6 %
// of u_eq. Asserted at every output (0.1 s apart):
// - 2.25 cells (on a marker row), Material share and Full cell and weight, to 3 s: u_mean
//   within 2 % of the law (N within 0.3 %); measured at most 0.4 % (at 0.1 s), every case; the
//   same for 4 whole cells on 25/26/33 deg (measured 0.5 %);
// - 2 whole cells with Full cell and weight, to 3 s: within 3 % (N within 0.5 %: the surface
//   lies on a cell boundary, where a marker crossing into the empty row above changes the
//   column's top cell); measured -1.8 % / -1.1 % (nu = 0.03 / 0.003). It was +10 % at 3 s
//   while the bed took only the unloading part of the filtered traction, which rectified slow
//   waves along such a layer: the compressive part now loads the bed where the layer is quiet
//   (bed_surface_traction). Not
//   asserted because it fails: 2 whole cells with Material share at nu = 0.03 (3 times the
//   law by 3 s, 0.089 m/s; 0.091 before): its top cells' traction reaches the column's weight, above the
//   gate (docs/validation.md, session 29; open);
// - 2 whole cells, the paper's Full cell, to 1 s: within 25 % (N within 4 %); measured -5.9 % /
//   +8.3 % (nu = 0.03 / 0.003; +18 % / +4.9 % before the compressive part). With Full cell a
//   marker that crosses into the empty row above makes a cell driven by gravity over its whole
//   volume (the option's known excess, 'Surface cell mass'), and the layer speeds up over
//   seconds with either viscosity and in the build before the traction too (u_mean at 3 s 0.10
//   / 0.041 m/s here, nu = 0.03 / 0.003; 0.054 before the traction existed).
// (The Full cell layer of 2.25 cells is no case: driven by 3 cells and held by 2.25 it slides
// off at 0.74 m/s^2, as the tests above state.)
TEST(NdamCoulomb, ViscousLayerAtItsFrictionLimitCreepsAtTheLawsSpeed) {
  const double deg = M_PI / 180.0;
  struct Layer {
    std::array<double, 3> an;
    double depth;
    const char* mass;
    double end, tol;
  };
  const std::array<double, 3> a21{21, 22, 33}, a25{25, 26, 33};
  for (const Layer& l : {Layer{a21, 0.01, "Full cell", 1.0, 0.25},
                         Layer{a21, 0.01125, "Material share", 3.0, 0.02},
                         Layer{a21, 0.01125, "Full cell and weight", 3.0, 0.02},
                         Layer{a21, 0.01, "Full cell and weight", 3.0, 0.03},
                         Layer{a25, 0.02, "Material share", 3.0, 0.02},
                         Layer{a25, 0.02, "Full cell and weight", 3.0, 0.02}})
    for (double nu : {0.03, 0.003}) {
      const auto& an = l.an;
      const double u_eq = -std::log(1.0 - std::tan(an[0] * deg) / std::tan(an[1] * deg)) / 100.0;
      std::vector<double> times;
      for (int q = 1; q <= static_cast<int>(std::lround(l.end / 0.1)); ++q) times.push_back(0.1 * q);
      const auto law = plug_law(an[0], an[1], 100.0, times);
      FsCase c;
      c.nx = 40;
      c.lx = 0.2;
      c.nz = 10;
      c.lz = 0.05;
      c.depth = l.depth;
      c.slope_deg = an[0];
      c.delta_deg = an[1];
      c.phi_deg = an[2];
      c.nu = nu;
      c.surface_mass = l.mass;
      auto s = make_fs(c);
      const auto u = mean_u_at(*s, times, 0.01);
      ASSERT_EQ(u.size(), times.size());
      double worst = 0.0;
      for (std::size_t q = 0; q < times.size(); ++q) {
        const double e = u[q] / law[q] - 1.0;
        if (std::abs(e) > std::abs(worst)) worst = e;
        EXPECT_LT(std::abs(e), l.tol) << an[0] << "/" << an[1] << ", " << l.mass << ", nu = "
                                     << nu << ", t = " << times[q] << ": u_mean " << u[q]
                                     << " against the law's " << law[q];
      }
      std::printf("[measured] layer at its limit %g/%g/%g, %.2f cells (%s), nu = %g: u_mean at "
                  "0.1 / 1 / %g s %.4f / %.4f / %.4f m/s (law %.4f / %.4f / %.4f, u_eq %.4f), "
                  "worst %+.1f %%\n",
                  an[0], an[1], an[2], l.depth / 0.005, l.mass, nu, l.end, u[0], u[9], u.back(),
                  law[0], law[9], law.back(), u_eq, 100 * worst);
    }
}

// The same on the issue's own grid (8 x 24 cells of 1.25 x 2.5 mm), 40/25/35 deg, at CFL 0.5,
// 0.25, 0.125 (label `long`, about 25 s): u_mean within 1 % of the plug law at every output
// from 0.05 s to 1 s at each dt, and the error against the law shrinks at every output each
// time dt halves, by at least a factor 0.8 (observed order p = log2(|e_dt| / |e_dt/2|) >= 0.32),
// down to the floor the friction iteration leaves: it holds the friction to kFrictionTolerance
// = 1e-4 of the Coulomb bound, and the acceleration is the difference of the driving force and
// that friction, so its relative accuracy is 1e-4 tan(delta) / (tan(zeta) - tan(delta)) =
// 1.25e-4 here; below that an error need not shrink with dt. The law is exact, so the error
// against it is the measure; the order of the differences between successive dt (a Richardson
// estimate, for when no exact solution is known) is printed too but not asserted. Measured:
// with the t = 0 pressure of the surface's Dirichlet values (2026-12-05) the errors are 2.7e-5
// / 3.9e-5 / 0.2e-5 at 0.05 s (below the floor at every dt; before, with the pressure half a
// cell low at t = 0, a start-up offset of 1.1e-4 / 0.75e-4 / -0.29e-4 m/s carried along, 7e-4
// relative at 0.05 s, which shrank as dt halved).
TEST(NdamPlugLong, IssueGridConvergesAsDtHalves) {
  std::vector<double> times;
  for (int q = 1; q <= 20; ++q) times.push_back(0.05 * q);
  const auto law = plug_law(40, 25, 100.0, times);
  std::vector<std::vector<double>> u;
  for (double cfl : {0.5, 0.25, 0.125}) {
    FsCase c = plug_3cm(40, 25, 35, 8, 0.01);
    c.cfl = cfl;
    auto s = make_fs(c);
    u.push_back(mean_u_at(*s, times, 0.01));
    ASSERT_EQ(u.back().size(), times.size());
    for (std::size_t q = 0; q < times.size(); ++q)
      EXPECT_LT(std::abs(u.back()[q] / law[q] - 1.0), 0.01) << "CFL " << cfl << " t = " << times[q];
  }
  for (std::size_t q = 0; q < times.size(); ++q) {
    double e[3];
    for (int j = 0; j < 3; ++j) e[j] = std::abs(u[static_cast<std::size_t>(j)][q] / law[q] - 1.0);
    const double pd = std::log2(std::abs(u[0][q] - u[1][q]) / std::abs(u[1][q] - u[2][q]));
    std::printf("plug (issue grid) t = %.2f s: error %+.4f / %+.4f / %+.4f %%, observed order "
                "against the law %.2f / %.2f (of the differences %.2f)\n",
                times[q], 100 * (u[0][q] / law[q] - 1), 100 * (u[1][q] / law[q] - 1),
                100 * (u[2][q] / law[q] - 1), std::log2(e[0] / e[1]), std::log2(e[1] / e[2]), pd);
    const double kPi = std::acos(-1.0);
    const double floor = 1e-4 * std::tan(25 * kPi / 180) /
                         (std::tan(40 * kPi / 180) - std::tan(25 * kPi / 180));  // 1.25e-4
    EXPECT_LT(e[1], std::max(0.8 * e[0], floor)) << "t = " << times[q];
    EXPECT_LT(e[2], std::max(0.8 * e[1], floor)) << "t = " << times[q];
  }
}

// The Newtonian limit with Coulomb slip (DESIGN.md section 7): the layer accelerates uniformly
// at g cos(zeta)(tan zeta - tan delta) while the basal friction c_F p = tan(delta) g cos(zeta) h
// sets the shear, so u - u_b = g cos(zeta) tan(delta) (h z - z^2/2) / nu once the start-up has
// decayed (time scale 4 h^2 / (pi^2 nu) = 0.03 s here; compared at t = 0.5 s). The bed speed u_b
// is not a grid value, so the profile is compared relative to the lowest face:
// u(z_k) - u(z_0) against f(z_k) - f(z_0), within 2 % of the amplitude f(h) - f(z_0).
TEST(NdamCoulomb, NewtonianSlipReachesShearProfile) {
  FsCase c;
  c.rheology = "Newtonian";
  c.nu = 0.03;
  auto s = make_fs(c);
  run_to(*s, 0.5, 0.002);
  const double zeta = core::deg2rad(50.0), delta = core::deg2rad(22.0), h = c.depth;
  const double G = 9.81 * std::cos(zeta) * std::tan(delta);
  auto f = [&](double z) { return G * (h * z - 0.5 * z * z) / c.nu; };
  const double dz = c.lz / c.nz;
  const int layers = static_cast<int>(std::lround(h / dz));
  const auto u = s->gather_u();
  const double amp = f(h) - f(0.5 * dz);
  double err = 0.0;
  for (int k = 1; k < layers; ++k) {
    const double zk = (k + 0.5) * dz;
    const double num = u[static_cast<std::size_t>(5 * c.nz + k)] - u[static_cast<std::size_t>(5 * c.nz)];
    err = std::max(err, std::abs(num - (f(zk) - f(0.5 * dz))));
  }
  std::printf("Newtonian slip: amplitude %.5f m/s, max error %.2e (%.2f %%)\n", amp, err,
              100 * err / amp);
  EXPECT_LT(err, 0.02 * amp);
}

// A Drucker-Prager block on a slope gentler than delta (zeta = 15 < delta = 22 deg) must stay.
// With the smoothed friction factor it can only creep at the speed where c_F balances gravity,
// tan(delta)(1 - exp(-m_c u)) = tan(zeta): u_creep = -ln(1 - tan zeta / tan delta) / m_c
// (1.09 cm/s for m_c = 100 s/m), plus the regularised internal creep. Checked: the sliding speed
// after 0.3 s stays below 1.2 u_creep (20 %: the lagged friction and the internal creep of the
// Papanastasiou regularisation add a little), and it is a small fraction of what the slope
// would give without friction (g sin(zeta) t = 0.76 m/s).
TEST(NdamCoulomb, BlockBelowFrictionAngleStays) {
  FsCase c;
  c.slope_deg = 15.0;
  auto s = make_fs(c);
  run_to(*s, 0.3, 0.002);
  const double creep =
      -std::log(1.0 - std::tan(core::deg2rad(15.0)) / std::tan(core::deg2rad(22.0))) / c.m_c;
  const double um = layer_mean_u(*s);
  std::printf("block: u_mean = %.5f m/s, creep bound %.5f m/s\n", um, creep);
  EXPECT_LT(um, 1.2 * creep);
  EXPECT_GT(um, 0.0);
}

// The coupling API on a short chute (gate inflow, wall): the area that entered through the gate
// (summed last_transfer().in) equals h_in u_in t to within one marker per injection row (the
// accumulators carry the rest), nothing leaves through a wall, column_state reads the profile,
// and the pressure of eq. (26) imposed on the inflow column is what the column holds.
TEST(NdamChute, GateInflowTransferAndInterfaceApi) {
  const FsCase c = gate_chute();
  auto s = make_fs(c);
  double in = 0.0, out = 0.0;
  while (s->time() < 0.1 - 1e-12) {
    const double dt = std::min({s->stable_dt(), 0.002, 0.1 - s->time()});
    s->step(dt);
    ASSERT_TRUE(s->check().ok);
    s->accept();
    in += s->last_transfer().in;
    out += s->last_transfer().out;
  }
  const auto* mk = s->markers();
  const double rows = std::ceil(c.h_in / mk->spacing_z() - 1e-9);
  EXPECT_NEAR(in, c.h_in * c.u_in * 0.1, rows * mk->marker_area());
  EXPECT_EQ(out, 0.0);
  EXPECT_DOUBLE_EQ(s->mass_balance().current, in);
  const auto p = s->profile();
  const auto cs = s->column_state(p.x[3]);
  EXPECT_DOUBLE_EQ(cs.h, p.h[3]);
  EXPECT_DOUBLE_EQ(cs.u_mean, p.u_mean[3]);
  EXPECT_GT(cs.h, 0.0);
  // 1D-to-2D interface mode: {h, u} from a provider, eq. (26) pressure on the inflow column
  const double K = 1.5;
  s->set_inflow([](double) { return std::array<double, 2>{0.04, 0.5}; },
                ndam::InflowShape::CopyInterior, ndam::InflowPressure::Dirichlet, K);
  for (int n = 0; n < 5; ++n) {
    s->step(std::min(s->stable_dt(), 0.002));
    ASSERT_TRUE(s->check().ok);
    s->accept();
  }
  const auto pp = s->gather_p();
  const double dz = c.lz / c.nz, gcos = 9.81 * std::cos(core::deg2rad(c.slope_deg));
  for (int k = 0; k < 3; ++k) {
    if (s->flag(0, k) != ndam::CellFlag::Empty) {
      EXPECT_NEAR(pp[static_cast<std::size_t>(k)], gcos * (0.04 - (k + 0.5) * dz) * (1 + K) / 2, 1e-9)
          << "k = " << k;
    }
  }
}

// Steps s to t_end at its stable step capped at cap (every step checked) and adds what its left
// end injected to `in`.
static void run_gate_capped(ndam::NdamSolver& s, double t_end, double cap, double& in) {
  while (s.time() < t_end - 1e-12) {
    const double dt = std::min({s.stable_dt(), cap, t_end - s.time()});
    s.step(dt);
    ASSERT_TRUE(s.check().ok) << "t = " << s.time();
    s.accept();
    in += s.last_transfer().in;
  }
}

// A hydrograph through the 2D gate: an inflow series that opens to 4 cm, shuts inside 0.1 ms
// at 0.05 s, then a triangular pulse (the depth rising to 3 cm and falling to 0 over 40 ms).
// What enters must be its volume, int h u dt, whatever the steps. Before, the markers took the
// left-point flux h(t^n) u dt per step and a row's remainder (up to one marker per row) stayed
// behind when the opening fell below the row: an independent run lost 0.9 % of such a
// hydrograph at 10 mm (1.3 % of the triangle) and gained 0.2 % at 5 mm. Now the step's exact
// volume is admitted, closing rows hand on their remainders, and a shut gate turns what the
// rows still hold into markers. Step caps 2e-3 s and 1.3e-3 s (the stable step is about 4e-3 s
// here) put the step ends at different places around the series' rows. Asserted at 0.15 s,
// after both pulses: the injected area within half a marker of the volume (the rounding of
// the rows' remainders when the gate shuts), the box holding what was injected.
TEST(NdamChute, GateSeriesAdmitsItsVolumeWhateverTheSteps) {
  const std::string f = ::testing::TempDir() + "gate_pulse_series.csv";
  std::ofstream(f) << "t,h,u\n0,0.04,0.37\n0.05,0.04,0.37\n0.0501,0,0.37\n0.08,0,0.5\n"
                      "0.1,0.03,0.5\n0.12,0,0.5\n";
  FsCase c = gate_chute();
  c.series_file = f;
  const auto series = core::InflowSeries::from_csv(f, "Inflow series file");
  const double t_end = 0.15, exact = series.discharge(0.0, t_end);
  for (double cap : {2e-3, 1.3e-3}) {
    auto s = make_fs(c);
    double in = 0.0;
    ASSERT_NO_FATAL_FAILURE(run_gate_capped(*s, t_end, cap, in));
    const double a = s->markers()->marker_area();
    std::printf("[measured] gate series, cap %.1e s: injected %.6e m^2, volume %.6e m^2, "
                "difference %.3f markers\n", cap, in, exact, (in - exact) / a);
    EXPECT_LE(std::abs(in - exact), 0.5 * a + 1e-12 * exact) << "cap " << cap;
    EXPECT_NEAR(s->mass_balance().current, in, 1e-12 * exact);
  }
}

// A gate that closes on its moving column (the stability suite's gate pulse: 6 cm at 0.37 m/s
// for 0.2 s, shut within 10 ms, onto 20 deg with delta = 22 deg, 5 mm cells, Full cell and
// weight, m_c = 1e4 s/m, and a stiff yield regularisation m_y = 1000 s). The gate state is
// lagged at t^n, and at the default step four rows closed within one step of 3.4 ms: the
// projection answered with a suction of -75 m^2/s^2 in the gate's column and threw its cells
// (5.42 m/s at 0.207 s; the pulse then ran 1 m to the wall instead of resting at 0.4 m;
// docs/validation.md, "The gate pulse's run-out"). Now the step resolves the gate's edge like a
// wave, |h_in(t^n + dt) - h_in(t^n)| <= CFL dz. Asserted to 0.3 s (steps cut at outputs every
// 0.1 s, as the driver does), at CFL 0.5 and 0.25:
//  - the law itself, at every step: the opening moves by at most CFL dz (+1e-12 m: round-off
//    of the series' interpolation);
//  - no cell faster than the gate column can make it: u_in + 2 sqrt(g cos(zeta) h_in) = 1.86
//    m/s, the frictionless dam-break front (Ritter) of the 6 cm column moving at u_in; the
//    slope adds nothing, its pull g sin(zeta) being below the bed's friction g cos(zeta)
//    tan(delta). Measured 0.83-0.85 m/s; 1.21 m/s with this test's steps before the limit
//    (the scene's own step sequence threw a cell at 5.42 m/s);
//  - the front (the last column deeper than 1 mm) at 0.3 s the same at both steps within two
//    cells (the step sequence's spread of the run-out at 3 s is 3 cells, 0.398-0.423 m, over
//    CFL 0.125-0.5 and output intervals 0.05-0.25 s; measured here: the same cell).
// The box is 0.4 m long (the front is at about 0.18 m at 0.3 s, so the end wall plays no part).
TEST(NdamChute, ClosingGateIsResolvedInTimeAndThrowsNoCells) {
  const std::string f = ::testing::TempDir() + "gate_closing_series.csv";
  std::ofstream(f) << "t,h,u\n0,0.06,0.37\n0.2,0.06,0.37\n0.21,0,0\n";
  const auto series = core::InflowSeries::from_csv(f, "Inflow series file");
  FsCase c = gate_chute();
  c.series_file = f;
  c.nx = 80;
  c.lx = 0.4;
  c.nz = 30;
  c.lz = 0.15;
  c.slope_deg = 20.0;
  c.m_c = 1e4;
  c.m_y = 1000.0;
  c.surface_mass = "Full cell and weight";
  const double t_end = 0.3, interval = 0.1, dz = c.lz / c.nz, g = 9.81;
  const double zeta = core::deg2rad(c.slope_deg);
  ASSERT_LT(std::tan(zeta), std::tan(core::deg2rad(c.delta_deg)));  // the bound's premise
  const double bound = 0.37 + 2.0 * std::sqrt(g * std::cos(zeta) * 0.06);
  std::vector<double> fronts;
  for (double cfl : {0.5, 0.25}) {
    c.cfl = cfl;
    auto s = make_fs(c);
    double fastest = 0.0, worst_move = 0.0;
    int steps = 0;
    while (s->time() < t_end - 1e-12) {
      const double next = interval * (std::floor(s->time() / interval + 1e-9) + 1.0);
      const double dt = std::min(s->stable_dt(), next - s->time());
      worst_move = std::max(worst_move, std::abs(series.depth(s->time() + dt) -
                                                 series.depth(s->time())) / (cfl * dz));
      s->step(dt);
      ASSERT_TRUE(s->check().ok) << "t = " << s->time();
      s->accept();
      ++steps;
      fastest = std::max(fastest, s->max_speed().value);
    }
    const auto p = s->profile();
    double front = 0.0;
    for (std::size_t q = 0; q < p.x.size(); ++q)
      if (p.h[q] > 1e-3) front = std::max(front, p.x[q]);
    fronts.push_back(front);
    std::printf("[measured] closing gate, CFL %.2f: %d steps, largest gate move %.3f CFL dz, "
                "fastest cell %.3f m/s (bound %.2f), front %.4f m at %.1f s\n",
                cfl, steps, worst_move, fastest, bound, front, t_end);
    EXPECT_LE(worst_move, 1.0 + 1e-12 / (cfl * dz)) << "CFL " << cfl;
    EXPECT_LT(fastest, bound) << "CFL " << cfl;
  }
  EXPECT_NEAR(fronts[0], fronts[1], 2.0 * c.lx / c.nx + 1e-9);
}

// A gate still open when the run ends: what it admitted, int h u dt = h_in u_in t, is the
// injected markers plus what the rows hold as fractions of a marker (under one marker per open
// marker row). summary.json reports that part as ndam.inflow_pending_area; the mass balance counts
// markers only (an independent run found 9.6 markers, 0.44 %, unreported at 10 mm). Asserted
// at two step caps: injected + pending = h_in u_in t to round-off (1e-12 relative), the
// pending part below one marker per open marker row (the gate injects row by row of markers).
TEST(NdamChute, OpenGateReportsWhatIsNotYetMarkers) {
  FsCase c = gate_chute();
  const double t_end = 0.1;
  for (double cap : {2e-3, 1.3e-3}) {
    auto s = make_fs(c);
    double in = 0.0;
    ASSERT_NO_FATAL_FAILURE(run_gate_capped(*s, t_end, cap, in));
    const double a = s->markers()->marker_area(), exact = c.h_in * c.u_in * t_end;
    const double pending = s->inflow_pending();
    // the gate injects by marker rows (strips of the marker spacing), each holding a fraction
    const int open_rows = static_cast<int>(std::ceil(c.h_in / s->markers()->spacing_z() - 1e-9));
    std::printf("[measured] open gate, cap %.1e s: injected %.6e, pending %.3e m^2 (%.2f markers), "
                "int h u dt %.6e m^2\n", cap, in, pending, pending / a, exact);
    EXPECT_NEAR(in + pending, exact, 1e-12 * exact) << "cap " << cap;
    EXPECT_GE(pending, 0.0);
    EXPECT_LT(pending, open_rows * a) << "cap " << cap;
  }
}

// The 1D-to-2D interface copies the shape of the first interior column (eq. 25), scaled to the
// 1D side's u_mean (eq. 24). The copy must let in exactly h u_mean whatever the shape, and a
// disturbed first column must not make an inflow face many times u_mean: a column whose top
// rows have turned back while its bottom row still runs has a small positive mean, and the
// unbounded copy scaled that row by u_mean / mean (+195 m/s faces from a 1.27 m/s inflow in
// the coupled Setup II cascade of docs/validation.md). Checked on the gate chute at 0.1 s
// (10 mm cells, an opening of 4 rows):
//  - the undisturbed column's shape (its largest face at most 2 times its mean, asserted) is
//    copied as it is: every face u_mean u(0, k) / mean to round-off (1e-12 relative);
//  - the disturbed column (bottom row 1 m/s, the three rows above -0.5 m/s: an unbounded copy
//    gives 4 u_mean in the bottom row) gives faces in [0, 2 u_mean] (the bound kShapeMax = 2,
//    above a plug's 1, Bagnold's 5/3 and a Newtonian half-parabola's 3/2);
//  - in both the opening's flux sum_k open_k dz u_k is h u_mean to 1e-12 relative (the mass
//    that the DAM let out enters, exactly as before the bound).
TEST(NdamChute, InterfaceInflowShapeIsCopiedBoundedAndExact) {
  const FsCase c = gate_chute();
  auto s = make_fs(c);
  run_to(*s, 0.1, 0.002);
  const double h = 0.04, um = 1.27, dz = c.lz / c.nz;
  auto faces_of = [&](const ndam::NdamState& st) {
    auto b = make_fs(c, MPI_COMM_WORLD, &st);
    b->set_inflow([&](double) { return std::array<double, 2>{h, um}; },
                  ndam::InflowShape::CopyInterior, ndam::InflowPressure::Dirichlet, 1.0);
    return b->inflow_faces();
  };
  auto flux = [&](const std::vector<double>& f) {
    double q = 0.0;
    for (int k = 0; k < c.nz; ++k)
      q += std::clamp((h - k * dz) / dz, 0.0, 1.0) * dz * f[static_cast<std::size_t>(k)];
    return q;
  };
  ndam::NdamState st = s->export_state();
  const int rows = 4;  // h / dz
  double mean = 0.0, top = 0.0;
  for (int k = 0; k < rows; ++k) {
    const double u0 = st.u[static_cast<std::size_t>(k)];  // right face of cell (0, k)
    ASSERT_GT(u0, 0.0) << "k = " << k;
    mean += u0 / rows;
    top = std::max(top, u0);
  }
  ASSERT_LE(top, 2.0 * mean);  // an ordinary chute profile: the copy is not bounded
  const auto f = faces_of(st);
  for (int k = 0; k < rows; ++k)
    EXPECT_NEAR(f[static_cast<std::size_t>(k)], um * st.u[static_cast<std::size_t>(k)] / mean,
                1e-12 * um)
        << "k = " << k;
  EXPECT_NEAR(flux(f), h * um, 1e-12 * h * um);

  st.u[0] = 1.0;
  for (int k = 1; k < rows; ++k) st.u[static_cast<std::size_t>(k)] = -0.5;
  const auto g = faces_of(st);
  std::printf("disturbed first column: inflow faces %.3f %.3f %.3f %.3f m/s (u_mean %.2f)\n",
              g[0], g[1], g[2], g[3], um);
  for (int k = 0; k < rows; ++k) {
    EXPECT_GE(g[static_cast<std::size_t>(k)], 0.0) << "k = " << k;
    EXPECT_LE(g[static_cast<std::size_t>(k)], 2.0 * um * (1.0 + 1e-12)) << "k = " << k;
  }
  for (int k = rows; k < c.nz; ++k) EXPECT_EQ(g[static_cast<std::size_t>(k)], 0.0) << "k = " << k;
  EXPECT_NEAR(flux(g), h * um, 1e-12 * h * um);
}

// A 2D subdomain that does not start at x = 0 (issue 11 item 3 asked whether the end-wall
// Coulomb friction and its pressure act there): the grid origin x0 only places the box along the
// channel (profile, fields and column_state coordinates); the dynamics, including the Coulomb
// bed and end-wall ghost factors, are those of the same box at x0 = 0. A 0.3 m box fed at
// 2.6 m/s through the gate (as the downstream subdomain of coupled Setup II is) until the
// deposit at the wall is 0.15 m deep, at x0 = 0 and x0 = 0.7 m: the same operations in the same
// order, so the fields agree to the last bit (tolerance 0), and the profile is shifted by x0.
TEST(NdamChute, SubdomainOriginDoesNotChangeTheWallDeposit) {
  FsCase c = gate_chute();
  c.nz = 20;
  c.lz = 0.2;
  c.h_in = 0.01;
  c.u_in = 2.6;
  FsCase d = c;
  d.x0 = 0.7;
  auto a = make_fs(c), b = make_fs(d);
  while (a->time() < 0.3 - 1e-12) {
    const double dt = std::min(a->stable_dt(), 0.3 - a->time());
    ASSERT_EQ(dt, std::min(b->stable_dt(), 0.3 - b->time()));
    for (auto* s : {a.get(), b.get()}) {
      s->step(dt);
      ASSERT_TRUE(s->check().ok);
      s->accept();
    }
  }
  const auto pa = a->profile(), pb = b->profile();
  std::printf("origin: wall column h = %.4f m, wall-bottom p = %.1f Pa\n", pa.h.back(),
              a->gather_p()[static_cast<std::size_t>((c.nx - 1) * c.nz)] * 1440.0);
  EXPECT_GT(pa.h.back(), 0.05);  // a deposit has formed against the wall
  EXPECT_EQ(a->gather_u(), b->gather_u());
  EXPECT_EQ(a->gather_w(), b->gather_w());
  EXPECT_EQ(a->gather_p(), b->gather_p());
  for (int gi = 0; gi < c.nx; ++gi)
    for (int k = 0; k < c.nz; ++k) ASSERT_EQ(a->flag(gi, k), b->flag(gi, k));
  for (std::size_t q = 0; q < pa.x.size(); ++q) {
    EXPECT_DOUBLE_EQ(pb.x[q], pa.x[q] + 0.7);
    EXPECT_EQ(pb.h[q], pa.h[q]);
  }
  EXPECT_EQ(b->column_state(0.7 + pa.x.back()).h, pa.h.back());
}

// The steady chute below the silo gate (Setup I's material and slope, a 1 m chute with an open
// end): the layer thins as it accelerates and slides as a plug (shape factor 1.00-1.01,
// docs/validation.md "Momentum budget"), so along it
//   u du/dx = g sin(zeta) - g cos(zeta) tan(delta) (1 - exp(-m_c u)) - K g cos(zeta) dh/dx,
// i.e. u^2 / 2 gains a = g (sin(zeta) - cos(zeta) tan(delta)) = 4.967 m/s^2 per metre (the
// exponential is below 1e-60 at u > 1.5 m/s; the earth-pressure term, K = 0.3 for Drucker-Prager
// in extension, adds 0.3 %). The Newtonian viscosity does not enter: its normal stress 2 nu u_x
// integrates to nothing across a free surface. The test fits u_mean^2 / 2 over x in [0.3, 0.9] m,
// time-averaged over 11 outputs in [0.6, 0.8] s, with nu = 0.003 m^2/s (the paper's) and
// 1e-4 m^2/s, at 5 and 2.5 mm. Measured (2026-12-06): a +4.6 % / +4.1 % of the law at 5 / 2.5 mm
// with nu = 0.003, +5.6 % / +4.4 % with 1e-4: the viscosity moves a by 1.0 % / 0.3 %. Before the
// bed took back the surface's traction (surface_traction_at_bed), the implicit scheme's p = 0 at
// the surface loaded the bed with 2 nu u_x more than the weight (22 % of it), and the viscosity
// moved a by 9.1 % / 8.4 % (-4.0 % / -4.4 % of the law with nu = 0.003, +5.1 % / +4.0 % with
// 1e-4). Tolerances: the viscosity's effect at most 2 % (1.0 % measured, the defect 8-9 %); a
// within 6 % of the law (4-6 % measured: the scheme's own error of the thin layer, 2-4 cells
// deep here, which Setup I shows shrinking to +2.2 % at 1.25 mm; docs/validation.md).
TEST(NdamChute, ThinningChuteFlowGainsSpeedByThePlugLaw) {
  auto run = [](int nx, int nz, double nu) {
    FsCase c = gate_chute();  // Setup I's gate (h_in = 6 cm) on a 1 m chute with an open end
    c.nx = nx;
    c.nz = nz;
    c.lx = 1.0;
    c.lz = 0.08;
    c.nu = nu;
    c.walls[1] = "Free-slip";
    c.right = "Outflow";
    c.h_in = 0.06;
    auto s = make_fs(c);
    std::vector<double> times;
    for (int q = 0; q <= 10; ++q) times.push_back(0.6 + 0.02 * q);
    std::vector<double> u_sum(static_cast<std::size_t>(nx), 0.0), x;
    for (double T : times) {
      run_to(*s, T, 1.0);
      if (::testing::Test::HasFatalFailure()) return 0.0;
      const auto p = s->profile();
      x = p.x;
      for (std::size_t q = 0; q < p.x.size(); ++q) u_sum[q] += p.u_mean[q] / times.size();
    }
    // least-squares slope of u^2 / 2 against x on [0.3, 0.9] m
    double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
    int n = 0;
    for (std::size_t q = 0; q < x.size(); ++q) {
      if (x[q] < 0.3 || x[q] > 0.9) continue;
      const double y = 0.5 * u_sum[q] * u_sum[q];
      sx += x[q];
      sy += y;
      sxx += x[q] * x[q];
      sxy += x[q] * y;
      ++n;
    }
    return (n * sxy - sx * sy) / (n * sxx - sx * sx);
  };
  const double z = core::deg2rad(50.0), d = core::deg2rad(22.0);
  const double a_plug = 9.81 * (std::sin(z) - std::cos(z) * std::tan(d));
  for (int nx : {200, 400}) {
    const double a = run(nx, nx / 12.5, 0.003), a_low = run(nx, nx / 12.5, 1e-4);
    ASSERT_FALSE(HasFatalFailure());
    const double e = a / a_plug - 1.0, dnu = (a - a_low) / a_plug;
    std::printf("thinning chute, dx = %.1f mm: a = %.3f m/s^2 (%+.2f %% of %.3f), with nu = 1e-4: "
                "%.3f (the viscosity's effect %+.2f %%)\n",
                1000.0 / nx, a, 100.0 * e, a_plug, a_low, 100.0 * dnu);
    EXPECT_LE(std::abs(dnu), 0.02) << "dx = " << 1000.0 / nx << " mm";
    EXPECT_LE(std::abs(e), 0.06) << "dx = " << 1000.0 / nx << " mm";
  }
}

// The Coulomb friction's Newton re-solves inside a step keep the step's first momentum
// preconditioner (predict_velocity, LinearSystem::hold_preconditioner): every step's first
// solve builds a fresh one, a re-solve builds one only when the held one stops being effective
// or fails (a retry). Without the hold every solve builds one, i.e. setups = solves. A plug
// released from rest (the issue's 3 cm layer on 40/25/35 deg at the CFL step) re-solves in its
// start-up, where the tangent at u^n misses the step's mean factor of an accelerating base
// (measured: 11 re-solves in 70 steps to 0.3 s, 70 setups, no retry).
// (This test used the gate chute until a base sliding at the bound stopped counting its
// round-off, |c_used| - 1 = 1e-15 .. 1e-12, as an overshoot: its many re-solves were those.)
TEST(NdamChute, FrictionResolvesKeepTheStepsPreconditioner) {
  auto s = make_fs(plug_3cm(40.0, 25.0, 35.0));
  int steps = 0;
  while (s->time() < 0.3 - 1e-12) {
    s->step(std::min({s->stable_dt(), 0.01, 0.3 - s->time()}));
    ASSERT_TRUE(s->check().ok);
    s->accept();
    ++steps;
  }
  const auto st = s->statistics();
  const long long first = st.momentum_solves - st.friction_solves;  // one per step
  // (the retries are counted over both systems: a bound for the momentum system's)
  const long long setups = st.retired_momentum_setups,
                  retries = st.retired_preconditioner_retries;
  std::printf("[measured] %d steps: %lld momentum solves, %lld friction re-solves, %lld "
              "setups, %lld retries\n",
              steps, st.momentum_solves, st.friction_solves, st.retired_momentum_setups,
              st.retired_preconditioner_retries);
  EXPECT_EQ(first, steps);
  // the test means something: re-solves in a tenth of the steps at least, so that building a
  // preconditioner for each would exceed the bound below
  EXPECT_GE(st.friction_solves, steps / 10);
  // each step's first solve builds a fresh one (this system has no step of trivial rows only)
  EXPECT_GE(setups, first);
  EXPECT_LE(setups, first + retries);  // the re-solves keep it
}

// A checkpoint of a free-surface chute restores markers, gate accumulators and counters: the
// restarted run continues like the straight run, its markers exactly (same mass, same flags);
// the fields agree to the linear-solver tolerance only (1e-10 relative: the restarted solver's
// lagged preconditioner was built at another step, so its Krylov iterates differ; measured
// 6e-12 m/s), asserted 1e-9.
TEST(NdamChute, CheckpointRestartReproducesStraightRun) {
  FsCase c = gate_chute();  // shortened to 0.2 m
  c.nx = 20;
  c.lx = 0.2;
  auto a = make_fs(c), b = make_fs(c);
  for (int n = 0; n < 20; ++n) {
    a->step(0.002);
    a->accept();
  }
  io::Checkpoint cp;
  a->save(cp);
  b->load(cp);
  for (int n = 0; n < 20; ++n) {
    a->step(0.002);
    a->accept();
    b->step(0.002);
    b->accept();
  }
  EXPECT_LT(ndam_test::max_abs_diff(a->gather_u(), b->gather_u()), 1e-9);
  EXPECT_LT(ndam_test::max_abs_diff(a->gather_p(), b->gather_p()), 1e-9);
  EXPECT_EQ(a->mass_balance().current, b->mass_balance().current);
  EXPECT_EQ(a->mass_balance().inflow, b->mass_balance().inflow);
  EXPECT_GT(a->mass_balance().current, 0.0);
}

namespace {
// The shipped column collapse (inputs/ndam_column_collapse.xml, 0.5 x 0.25 m) with nx x nz
// cells (10 mm: 50 x 25) and the given m_c; per output every 0.05 s to 1.5 s: the front (the last
// column with h > 1 mm, its right edge), the top of the pile (the depth of the column at the
// symmetry wall) and the rms speed of the material cells (Fluid and Surface; cell-centre u, w
// from the face means).
struct CollapseLog {
  std::vector<double> t, front, top, rms;
};
// The rms speed of the material cells (Fluid and Surface) of an nx x nz box, from the
// cell-centre u, w (the means of each cell's two faces; the faces beyond the box are 0).
double material_rms_speed(const ndam::NdamSolver& s, int nx, int nz) {
  const auto u = s.gather_u(), w = s.gather_w();
  const auto at = [nz](int i, int kk) { return static_cast<std::size_t>(i * nz + kk); };
  double sum = 0.0;
  int cells = 0;
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k) {
      const auto f = s.flag(gi, k);
      if (f != ndam::CellFlag::Fluid && f != ndam::CellFlag::Surface) continue;
      const double uc = 0.5 * (u[at(gi, k)] + (gi > 0 ? u[at(gi - 1, k)] : 0.0));
      const double wc = 0.5 * (w[at(gi, k)] + (k > 0 ? w[at(gi, k - 1)] : 0.0));
      sum += uc * uc + wc * wc;
      ++cells;
    }
  return std::sqrt(sum / std::max(cells, 1));
}
// Another column than the shipped one: its angles, its depth (the width stays 0.1 m) and the
// box's height (0: the scene's); cfl > 0: that CFL with donor-cell convection.
struct Column {
  double phi = 0.0, delta = 0.0, depth = 0.0, height = 0.0, cfl = 0.0;
};
CollapseLog column_collapse(double m_c, int nx = 50, int nz = 25, Column col = {}) {
  auto sc = scene::load(std::string(GRANFLOW_INPUTS) + "/ndam_column_collapse.xml");
  auto& n = sc.params->sublist("N-DAM");
  n.set("Cells x", nx);
  n.set("Cells z", nz);
  n.set("Friction regularisation", m_c);
  if (col.depth > 0.0) {
    sc.params->sublist("Material").set("Internal friction angle", col.phi);
    sc.params->sublist("Material").set("Bed friction angle", col.delta);
    n.set("Initial depth", col.depth);
    n.set("Height", col.height);
  }
  if (col.cfl > 0.0) {
    n.set("CFL", col.cfl);
    n.set("Donor-cell weight", 1.0);
  }
  auto model = scene::build_model(sc);
  auto* s = dynamic_cast<ndam::NdamSolver*>(model.get());
  CollapseLog log;
  if (!s) {
    ADD_FAILURE() << "not an N-DAM model";
    return log;
  }
  const double dx = 0.5 / nx;
  for (int q = 1; q <= 30; ++q) {
    const double t = 0.05 * q;
    if (mean_u_at(*s, {t}, 0.01).empty()) return log;
    const auto p = s->profile();
    double front = 0.0;
    for (std::size_t c = 0; c < p.x.size(); ++c)
      if (p.h[c] > 1e-3) front = p.x[c] + 0.5 * dx;
    log.top.push_back(p.h[0]);
    log.t.push_back(t);
    log.front.push_back(front);
    log.rms.push_back(material_rms_speed(*s, nx, nz));
  }
  return log;
}
}  // namespace

// A deposit at rest stays at rest to within the creep of the regularisations (issue 11 item 2):
// the column collapse of inputs/ndam_column_collapse.xml (a = 2, horizontal Coulomb bed, phi =
// 30, delta = 28 deg) at 10 mm stops spreading by 0.5 s (measured: the front at 0.34 m from
// 0.45 s on). At rest the regularised laws still creep: the base slides at
// u_b = ln(1 / (1 - r_b)) / m_c where its friction is the fraction r_b of tan(delta) N (12), and
// the material shears at ||D|| = ln(1 / (1 - r)) / m_y where its stress is the fraction r of the
// yield stress (5). With both fractions below 1 - 1/e the deposit (height H = 0.12 m) creeps
// below the bound u_c = 1 / m_c + H / m_y = 1.1 cm/s. Asserted at every output from 0.6 s to
// 1.5 s: the rms speed of the material below u_c (measured 3.5-6.2 mm/s; 3.8-7.4 before the
// surface-wave step limit), the front within one
// cell of where it stopped; and the creep is the regularisation's: with m_c = 1000 s/m the mean
// rms speed over those outputs is at most 0.7 of that at m_c = 100 s/m (measured 0.36; the rest
// is the internal creep and the noise of the surface cells, whose single-cell speeds reach
// 1-5 cm/s at flag changes, docs/validation.md). About 2.5 s for the two runs.
TEST(NdamDeposit, ColumnCollapseComesToRestWithinTheCreepBound) {
  const double u_c = 1.0 / 100.0 + 0.12 / 100.0;
  const auto a = column_collapse(100.0);
  ASSERT_EQ(a.t.size(), 30u);
  double front_stop = -1.0, mean_a = 0.0;
  int n = 0;
  for (std::size_t q = 0; q < a.t.size(); ++q) {
    std::printf("column collapse t = %.2f s: front %.3f m, rms speed %.4f m/s\n", a.t[q],
                a.front[q], a.rms[q]);
    if (a.t[q] < 0.6 - 1e-9) continue;
    if (front_stop < 0.0) front_stop = a.front[q];
    EXPECT_LT(a.rms[q], u_c) << "t = " << a.t[q];
    EXPECT_NEAR(a.front[q], front_stop, 0.01 + 1e-9) << "t = " << a.t[q];
    mean_a += a.rms[q];
    ++n;
  }
  // runout (r_inf - r0) / r0 of the a = 2 column: within the planar laws' 1.2 a = 2.4 and
  // 1.9 a^(2/3) = 3.0 to 25 % (the 10 mm grid; 2.5 mm: 2.3, docs/validation.md)
  EXPECT_GT((front_stop - 0.1) / 0.1, 0.75 * 2.4);
  EXPECT_LT((front_stop - 0.1) / 0.1, 1.25 * 3.0);
  const auto b = column_collapse(1000.0);
  ASSERT_EQ(b.t.size(), 30u);
  double mean_b = 0.0;
  for (std::size_t q = 0; q < b.t.size(); ++q)
    if (b.t[q] > 0.6 - 1e-9) mean_b += b.rms[q];
  std::printf("column collapse: mean rms speed from 0.6 s %.4f (m_c = 100) / %.4f m/s (m_c = 1000)\n",
              mean_a / n, mean_b / n);
  EXPECT_LT(mean_b, 0.7 * mean_a);
}

namespace {
// The deposit of a column collapse at rest from 0.6 s on (it stops spreading by 0.5 s), within
// the regularisations' creep bound u_c (above): the rms speed of the material below u_c at every
// output, and the front and the top of the pile (at the symmetry wall) moving at most as far as
// u_c carries them in the time since 0.6 s, plus one cell (the marker depth is read per cell
// row and the front per column).
void expect_collapse_rests(const CollapseLog& a, double u_c, double dx, double dz) {
  ASSERT_EQ(a.t.size(), 30u);
  std::size_t q0 = 0;
  while (q0 < a.t.size() && a.t[q0] < 0.6 - 1e-9) ++q0;
  ASSERT_LT(q0, a.t.size());
  for (std::size_t q = 0; q < a.t.size(); ++q) {
    std::printf("column collapse (dx = %.4f m) t = %.2f s: front %.4f m, top %.4f m, rms speed "
                "%.4f m/s\n", dx, a.t[q], a.front[q], a.top[q], a.rms[q]);
    if (q < q0) continue;
    const double creep = u_c * (a.t[q] - a.t[q0]);
    EXPECT_LT(a.rms[q], u_c) << "t = " << a.t[q];
    EXPECT_LE(a.front[q] - a.front[q0], creep + dx + 1e-9) << "t = " << a.t[q];
    EXPECT_LE(std::abs(a.top[q] - a.top[q0]), creep + dz + 1e-9) << "t = " << a.t[q];
  }
}
}  // namespace

// The same deposit at 5 mm (100 x 50 cells, about 15 s). Before the surface-wave step limit
// (NdamSolver::stable_dt) its rms speed was 5.0-8.7 mm/s with steps of up to 5 ms set by the
// creep itself, and at the issue's 2.5 mm it exceeded the bound at 9 of 19 outputs (up to
// 27 mm/s): the explicit surface (the Surface cells' pressure from the markers of t^n) pumps a
// resting pile once dt exceeds about dx / sqrt(g h). Measured now: 2.9-3.2 mm/s at 5 mm,
// 2.7-3.2 mm/s at 2.5 mm (NdamDepositLong below), against u_c = 11.2 mm/s.
TEST(NdamDeposit, ColumnCollapseRestsWithinTheCreepBoundAt5mm) {
  expect_collapse_rests(column_collapse(100.0, 100, 50), 1.0 / 100.0 + 0.12 / 100.0, 0.005, 0.005);
}

// The Setup II corner at the wall (issue 11 item 2): the scene of setup2_ndam.xml (50 deg,
// Coulomb bed and end wall, delta = 22, phi = 33 deg) with the gate closed (Left boundary Wall)
// and a block of 0.15 x 0.1 m released at rest against the wall. It slumps into the corner
// (peak rms speed about 0.11 m/s at 0.25 s) and rests from about 0.55 s, held by the wall
// and its internal friction (on 50 deg nothing rests on the bed alone). Asserted at 10 and
// 5 mm: the pile is at rest by 0.9 s (its rms speed below the creep bound u_c = 1/m_c + H/m_y,
// H: the deepest column at 0.6 s), and at every output from then to 1.5 s the rms speed stays
// below u_c and the pile's upstream edge (the first column with h > 1 mm) and its depth at the
// wall move no further than u_c carries them plus one cell. Measured with the Material share
// (the default since session 45): at rest from 0.65 s at 5 mm (1.3-4.0 mm/s after) and from
// 0.8 s at 10 mm (0.6-2.4 mm/s after; 14.1 / 10.8 mm/s at 0.6 / 0.75 s, still slumping, where
// the Full cell's pile, driven ahead by its top cells, had come to rest by 0.6 s: 0.5-9.1 mm/s
// at 10 mm, 2.0-5.7 mm/s at 5 mm), against u_c = 11.2 mm/s.
TEST(NdamDeposit, SetupIICornerBlockRestsWithinTheCreepBound) {
  for (const auto& [nx, nz] : {std::pair{100, 15}, std::pair{200, 30}}) {
    SCOPED_TRACE("cells " + std::to_string(nx) + " x " + std::to_string(nz));
    auto sc = scene::load(std::string(GRANFLOW_INPUTS) + "/setup2_ndam.xml");
    // the same changes in the validated list and in the list as written (the input checks
    // read the latter: inflow data on a Wall would be refused)
    auto user = Teuchos::rcp(new Teuchos::ParameterList(*sc.user));
    for (Teuchos::ParameterList* l : {sc.params.get(), user.get()}) {
      auto& left = l->sublist("Channel").sublist("Left boundary");
      left.remove("Inflow depth", false);
      left.remove("Inflow velocity", false);
      left.set("Type", std::string("Wall"));
      auto& n = l->sublist("N-DAM");
      n.set("Cells x", nx);
      n.set("Cells z", nz);
      n.set("Initial depth", 0.1);
      n.set("Initial x0", 0.85);
      n.set("Initial x1", 1.0);
    }
    sc.user = user;
    auto model = scene::build_model(sc);
    auto* s = dynamic_cast<ndam::NdamSolver*>(model.get());
    ASSERT_NE(s, nullptr);
    const double dx = 1.0 / nx, dz = 0.15 / nz;
    double u_c = 0.0, back0 = 0.0, wall0 = 0.0, worst = 0.0, t_rest = -1.0;
    for (int q = 1; q <= 30; ++q) {
      const double t = 0.05 * q;
      ASSERT_FALSE(mean_u_at(*s, {t}, 0.01).empty());
      const auto p = s->profile();
      double back = -1.0, hmax = 0.0;
      for (std::size_t c = 0; c < p.x.size(); ++c) {
        if (p.h[c] > 1e-3 && back < 0.0) back = p.x[c];
        hmax = std::max(hmax, p.h[c]);
      }
      const double wall = p.h.back();
      const double rms = material_rms_speed(*s, nx, nz);
      std::printf("corner block %d x %d, t = %.2f s: rms speed %.4f m/s, upstream edge %.4f m, "
                  "wall depth %.4f m\n", nx, nz, t, rms, back, wall);
      if (t < 0.6 - 1e-9) continue;
      if (u_c == 0.0) u_c = 1.0 / 100.0 + hmax / 100.0;  // m_c = 100 s/m, m_y = 100 s (the scene's)
      if (t_rest < 0.0 && rms < u_c) {  // the first output at rest
        t_rest = t;
        back0 = back;
        wall0 = wall;
      }
      if (t_rest < 0.0) continue;
      const double creep = u_c * (t - t_rest);
      worst = std::max(worst, rms);
      EXPECT_LT(rms, u_c) << "t = " << t;
      EXPECT_LE(std::abs(back - back0), creep + dx + 1e-9) << "t = " << t;
      EXPECT_LE(std::abs(wall - wall0), creep + dz + 1e-9) << "t = " << t;
    }
    EXPECT_GT(t_rest, 0.0);
    EXPECT_LE(t_rest, 0.9 + 1e-9);
    std::printf("corner block %d x %d: at rest from %.2f s, rms speed since at most %.4f m/s, "
                "u_c %.4f m/s\n", nx, nz, t_rest, worst, u_c);
  }
}

namespace {
// The tester's a = 1 column (0.1 x 0.1 m, 5 mm, 100 x 30 cells in a 0.15 m box, m_c = 100 s/m)
// of friction angles phi / delta, at the scene's CFL 0.5 and at CFL 1 (donor-cell convection):
// at rest from 0.6 s within the creep bound u_c = 1/m_c + H/m_y (H its top at 0.6 s).
void expect_square_column_rests(double phi, double delta) {
  for (const double cfl : {0.0, 1.0}) {
    SCOPED_TRACE(cfl > 0.0 ? "CFL 1" : "the scene's CFL 0.5");
    const auto a = column_collapse(100.0, 100, 30, Column{phi, delta, 0.1, 0.15, cfl});
    ASSERT_EQ(a.t.size(), 30u);
    expect_collapse_rests(a, 1.0 / 100.0 + a.top[11] / 100.0, 0.005, 0.005);  // top at 0.6 s
  }
}
}  // namespace

// The independent tester's column (issue 11 item 2): a = 1 (0.1 x 0.1 m), phi = 35, delta = 30
// deg, 5 mm (100 x 30 cells in a 0.15 m box). It stops spreading by 0.45 s; at 0.65-0.70 s,
// with the rotational pressure update at its full weight chi = 2 next to the surface, a flag
// change at the toe started a pressure oscillation that woke the whole pile (rms speed 3.8 ->
// 21 mm/s within eight steps, the top sinking by a cell): in the resting pile s = nu_eff dt /
// h^2 is 1e3-1e4, and a Uzawa step of 2 nu_eff does not damp the surface's modes. With chi
// rolled off to 1 there (projection.cpp, rotational_weight) measured 3.3-4.4 mm/s at every
// output from 0.6 s against u_c = 1/m_c + H/m_y = 10.9 mm/s (H = 0.09 m). The same at CFL 1
// (the tester's second run, donor-cell convection): with the surface-wave limit at a wave
// Courant number of CFL = 1 the pile woke at 0.70-0.75 s (12.7 / 30.7 mm/s) with every form of
// chi; the limit's Courant number is now at most 0.5 whatever CFL is (NdamSolver::stable_dt),
// and the pile rests at 3.3-4.1 mm/s. About 10 s.
TEST(NdamDeposit, SquareColumnRestsThroughTheFlagChangesAtItsToe) {
  expect_square_column_rests(35.0, 30.0);
}

// A steeper-friction column (issue 11 item 2; the independent tester's a = 1, phi = 40,
// delta = 20 deg, 5 mm, 100 x 30 cells): it stops spreading by 0.40 s and then creeps along a
// one-cell shear band from its top at the symmetry wall to the toe, across which nu_eff jumps by
// orders of magnitude. With the interior's rotational update at its full weight chi = 2 (the
// exact Uzawa step only for a constant nu_eff) the band's cells started a row-by-row pressure
// oscillation, rms speed 7 -> 19 mm/s in three steps without a flag change, and the pile woke
// five times to 0.67 s (28.5 mm/s in the tester's run), the top sinking by a cell. Rolled off
// to chi = 1 where the step is stiff (projection.cpp, rotational_weight) it rests. Asserted:
// rms speed below u_c = 1/m_c + H/m_y at every output from 0.6 s, the front and the top within
// the creep plus a cell, at the scene's CFL 0.5 and at CFL 1. About 10 s.
TEST(NdamDeposit, SteepFrictionPileRestsThroughItsShearBand) {
  expect_square_column_rests(40.0, 20.0);
}

namespace {
// The shipped column collapse at 2.5 mm (200 x 100) to t_end with the outputs of the scene
// (0.05 s), marker voids filled or not: the enclosed void cells (ndam::enclosed_voids of the
// flags) summed over every accepted step, the markers the fill moved, the marker area against
// the start.
struct VoidCount {
  long long hole_cell_steps = 0, filled = 0;
  double area_defect = 1.0;
};
VoidCount collapse_voids(bool fill, double t_end) {
  auto sc = scene::load(std::string(GRANFLOW_INPUTS) + "/ndam_column_collapse.xml");
  sc.params->sublist("N-DAM").set("Fill marker voids", fill);
  auto model = scene::build_model(sc);
  auto* s = dynamic_cast<ndam::NdamSolver*>(model.get());
  VoidCount v;
  if (!s) {
    ADD_FAILURE() << "not an N-DAM model";
    return v;
  }
  const int nx = s->grid().nx, nz = s->grid().nz;
  const double a0 = s->mass_balance().current;
  std::vector<ndam::CellFlag> flags(static_cast<std::size_t>(nx * nz));
  for (int q = 1; 0.05 * q < t_end + 1e-9; ++q) {
    const double T = 0.05 * q;
    while (s->time() < T - 1e-12) {
      const double to_target = T - s->time();
      double dt = s->stable_dt();
      if (to_target <= dt) dt = to_target;
      else if (to_target < 1.5 * dt) dt = 0.5 * to_target;
      s->step(dt);
      const auto h = s->check();
      if (!h.ok) {
        ADD_FAILURE() << h.reason;
        return v;
      }
      s->accept();
      for (int gi = 0; gi < nx; ++gi)
        for (int k = 0; k < nz; ++k) flags[static_cast<std::size_t>(gi * nz + k)] = s->flag(gi, k);
      v.hole_cell_steps += static_cast<long long>(ndam::enclosed_voids(flags, nx, nz).size());
    }
  }
  nlohmann::json j;
  s->report(j);
  v.filled = j["ndam"]["marker_void_fills"]["markers"].get<long long>();
  v.area_defect = std::abs(s->mass_balance().current - a0) / a0;
  return v;
}
}  // namespace

// Voids of the marker sampling (issue 11 item 3; docs/numerics.md): the shipped column collapse
// at its 2.5 mm stretches the top of the slumping column along x several times, and without
// the fill cells there lose their last marker while material lies above them: Empty cells
// enclosed by material, 2 of 31 outputs of the long hole check (0.35-0.40 s; 1-3 cells). With
// the fill no step has one, every marker keeps its area (the mass is exact), and the markers
// moved are few (about 20 in 0.45 s). About 25 s.
TEST(NdamDeposit, ColumnCollapseHasNoVoidsWithTheFill) {
  const VoidCount off = collapse_voids(false, 0.45), on = collapse_voids(true, 0.45);
  std::printf("column collapse to 0.45 s: enclosed void cell-steps %lld without the fill, %lld "
              "with it (%lld markers moved); area defect %.1e / %.1e\n",
              off.hole_cell_steps, on.hole_cell_steps, on.filled, off.area_defect,
              on.area_defect);
  EXPECT_GT(off.hole_cell_steps, 0);  // the scene makes voids: the test can see them
  EXPECT_EQ(off.filled, 0);
  EXPECT_EQ(on.hole_cell_steps, 0);
  EXPECT_GT(on.filled, 0);
  EXPECT_LT(on.area_defect, 1e-12);  // markers keep their area: round-off of the sum
}

// The issue's grid, 2.5 mm (200 x 100 cells, the shipped scene; label `long`, about 90 s).
TEST(NdamDepositLong, ColumnCollapseRestsWithinTheCreepBoundAt2p5mm) {
  expect_collapse_rests(column_collapse(100.0, 200, 100), 1.0 / 100.0 + 0.12 / 100.0, 0.0025,
                        0.0025);
}

namespace {
// A block 3 cm deep and 0.1 m wide on a horizontal Coulomb bed (phi = 40, delta = 35 deg; the
// column-collapse scene) in cells of dx: its solver (null if the scene built another model) and
// its box's column count.
struct Block {
  std::unique_ptr<core::Stepper> model;
  ndam::NdamSolver* solver = nullptr;
  int nx = 0;
};
Block block_on_a_horizontal_bed(double dx) {
  auto sc = scene::load(std::string(GRANFLOW_INPUTS) + "/ndam_column_collapse.xml");
  sc.params->sublist("Material").set("Internal friction angle", 40.0);
  sc.params->sublist("Material").set("Bed friction angle", 35.0);
  auto& n = sc.params->sublist("N-DAM");
  Block b;
  b.nx = static_cast<int>(std::lround(sc.params->sublist("Channel").get<double>("Length") / dx));
  n.set("Cells x", b.nx);
  n.set("Cells z", static_cast<int>(std::lround(0.1 / dx)));
  n.set("Height", 0.1);
  n.set("Initial depth", 0.03);
  n.set("Initial x1", 0.1);
  b.model = scene::build_model(sc);
  b.solver = dynamic_cast<ndam::NdamSolver*>(b.model.get());
  return b;
}
}  // namespace

// The bed's normal stress under a pile's toe (issue 11 item 2; docs/validation.md "Loaded
// surface cells"). The Coulomb law (11)-(13) takes N = p_b + 2 nu_eff du/dx at each bed face;
// a column that rests on its face carries its weight there, N = g cos(zeta) h. The cells of a
// pile's face are Surface cells with an empty side, and NaSt2D's surface condition gives them
// p = 0 (the Dirichlet value of that side) although the column's material lies on them: the
// toe's bed face had N = g cos(zeta) dz / 2 whatever the depth, so a toe cell slid off at
// 0.1 m/s while the tester's 10 mm piles stood. Such a cell now takes the hydrostatic pressure
// of its column's material above its centre for its bed load (NdamSolver::loaded_pressure). Asserted on a block (3 cm deep,
// 0.1 m wide, on a horizontal Coulomb bed, phi = 40, delta = 35 deg; the column-collapse scene)
// at 10 and 5 mm after its first steps (t = 0.01 s, before its face has slumped): the toe's
// bed face (the last one under material, whose right side is empty, so its column leans on no
// neighbour there) carries g h of the toe column within 5 % (the cell's centre pressure is
// extrapolated by dz / 2 to the bed, exact for a hydrostatic column). Measured 1.004 at both;
// 0.171 / 0.087 before (= dz / (2 h)). Printed, not asserted: the faces within about 1.5 h of
// the toe carry 1.1-1.8 g h at this time (the face starting to slump: its lateral stress and
// the vertical momentum of the slump), the interior 0.87-1.04 g h (0.97-1.01 before session 43's
// N from the step's balance; summed over the bed once the slump is over, the next test). About
// 1 s.
TEST(NdamDeposit, ToeOfABlockCarriesItsWeightOnTheBed) {
  for (const int cells_per_10cm : {10, 20}) {
    const double dx = 0.1 / cells_per_10cm;
    SCOPED_TRACE("dx = " + std::to_string(dx));
    const auto block = block_on_a_horizontal_bed(dx);
    auto* s = block.solver;
    ASSERT_NE(s, nullptr);
    const int nx = block.nx;
    ASSERT_FALSE(mean_u_at(*s, {0.01}, 0.01).empty());
    const auto N = s->bed_normal_stress();
    const auto prof = s->profile();
    ASSERT_EQ(N.size(), prof.h.size());  // one rank: the slab is the box
    const double g = 9.81;               // horizontal bed: g cos(zeta) = g
    int toe = -1;
    for (int i = 0; i < nx; ++i)
      if (prof.h[static_cast<std::size_t>(i)] > 0.5 * dx) toe = i;
    ASSERT_GT(toe, 2);
    ASSERT_EQ(prof.h[static_cast<std::size_t>(toe + 1)], 0.0);  // the toe's right side is empty
    for (int i = 0; i <= toe; ++i) {
      // face i lies between the columns i and i + 1; its pressure is their material mean
      const double h0 = prof.h[static_cast<std::size_t>(i)];
      const double h1 = prof.h[static_cast<std::size_t>(i + 1)];
      const double h = h1 > 0.5 * dx ? 0.5 * (h0 + h1) : h0;
      std::printf("block (dx = %.3f m), t = 0.01 s: bed face %d, columns %.4f / %.4f m: "
                  "N / (g h) = %.3f\n", dx, i, h0, h1, N[static_cast<std::size_t>(i)] / (g * h));
    }
    const double h_toe = prof.h[static_cast<std::size_t>(toe)];
    EXPECT_NEAR(N[static_cast<std::size_t>(toe)] / (g * h_toe), 1.0, 0.05);
  }
}

// The bed carries a settled pile's weight (the vertical balance of a pile that has stopped
// slumping; docs/validation.md, "The bed's normal stress from the step's own balance"): the block
// of the test above, left to slump, must put its weight W = g cos(zeta) sum(h) dx (h the markers'
// depth) on the bed through the Coulomb law's N summed over the bed faces, probed every 10 ms
// from 0.2 to 0.5 s (the slump is over by about 0.15 s; its toe film still creeps at a few cm/s
// at 10 mm, whose vertical momentum is nil). Measured with this build, 10 / 5 mm: sum N dx / W
// 1.0275 / 1.0109 on average, at most 6.95 / 2.53 % off at a probe; with eq. (13) taken from the
// stored p^{n+1} and u^{n+1} (the form before session 43): 1.0657 / 1.0245, at most 14.3 / 5.4 %
// off, so a pile's friction was up to 14 % high. Tolerances: the mean's excess is first order in
// the cell (it fell from 2.75 to 1.09 % as dx halved: the full cells' weight of the pile's
// partly filled top cells, the paper's Full cell), so 3.5 % at 10 mm and half that at 5 mm; a
// probe scatters with the marker noise of the pile's surface cells, 8 % / 4 %. The old form
// fails each of the four. About 2 s.
TEST(NdamDeposit, RestingBlockPutsItsWeightOnTheBed) {
  for (const int cells_per_10cm : {10, 20}) {
    const double dx = 0.1 / cells_per_10cm;
    SCOPED_TRACE("dx = " + std::to_string(dx));
    const auto block = block_on_a_horizontal_bed(dx);
    auto* s = block.solver;
    ASSERT_NE(s, nullptr);
    const double g = 9.81;  // horizontal bed: g cos(zeta) = g
    double mean = 0.0, worst = 0.0;
    int probes = 0;
    for (int j = 0; j <= 30; ++j) {
      const double t = 0.2 + 0.01 * j;
      ASSERT_FALSE(mean_u_at(*s, {t}, 0.01).empty());
      const auto N = s->bed_normal_stress();
      const auto prof = s->profile();
      ASSERT_EQ(N.size(), prof.h.size());  // one rank: the slab is the box
      double sum_n = 0.0, weight = 0.0;
      for (std::size_t i = 0; i < N.size(); ++i) {
        sum_n += N[i] * dx;
        weight += g * prof.h[i] * dx;
      }
      mean += sum_n / weight;
      ++probes;
      worst = std::max(worst, std::abs(sum_n / weight - 1.0));
      EXPECT_NEAR(sum_n / weight, 1.0, 0.08 * dx / 0.01) << "t = " << t;
    }
    mean /= probes;
    std::printf("resting block (dx = %.3f m), 0.2-0.5 s: sum N dx / W %.4f on average, at most "
                "%.4f off\n", dx, mean, worst);
    EXPECT_NEAR(mean, 1.0, 0.035 * dx / 0.01);
  }
}

// The pressure preconditioner follows d, the largest distance in cells from a pressure unknown
// to the free surface (projection.cpp, dirichlet_distance; 'Stiff threshold' 64 by default):
// - a layer at rest of 12 full cells (3 cm in 2.5 mm cells, periodic) has its Surface cells in
//   the top row and 11 rows of unknowns below: d = 11 exactly, and its solves take SSOR;
// - the gate chute with threshold 0 takes MueLu in every solve, with the default SSOR in
//   every one, and the two runs agree to what the solver tolerance allows: the markers to the
//   last bit (h identical) and u_mean within 1e-8 m/s (1e-10 relative tolerance of both
//   systems, about 1 m/s; measured 4e-13 m/s).
TEST(NdamChute, PressurePreconditionerFollowsTheDistanceToTheSurface) {
  {
    FsCase c;
    c.nx = 4, c.lx = 0.02, c.nz = 24, c.lz = 0.06, c.depth = 0.03;
    c.slope_deg = 20.0, c.delta_deg = 30.0;  // below the friction angle: it stays at rest
    auto s = make_fs(c);
    for (int n = 0; n < 5; ++n) {
      s->step(s->stable_dt());
      ASSERT_TRUE(s->check().ok);
      s->accept();
    }
    const auto st = s->statistics();
    EXPECT_EQ(st.pressure_max_distance, 11.0);
    EXPECT_EQ(st.pressure_stiff_solves, 0);
  }
  FsCase c = gate_chute();
  std::vector<core::Profile> prof[2];
  ndam::NdamStatistics st[2];
  for (int run = 0; run < 2; ++run) {
    c.pressure_threshold = run == 0 ? -1.0 : 0.0;  // the default 64, then always MueLu
    auto s = make_fs(c);
    while (s->time() < 0.2 - 1e-12) {
      s->step(std::min(s->stable_dt(), 0.2 - s->time()));
      ASSERT_TRUE(s->check().ok);
      s->accept();
      prof[run].push_back(s->profile());
    }
    st[run] = s->statistics();
  }
  std::printf("[measured] gate chute: d up to %g cells; SSOR %lld solves (%lld MueLu), MueLu "
              "%lld of %lld solves; iterations per solve %.1f against %.1f\n",
              st[0].pressure_max_distance, st[0].pressure_solves, st[0].pressure_stiff_solves,
              st[1].pressure_stiff_solves, st[1].pressure_solves,
              static_cast<double>(st[0].pressure_iterations) / st[0].pressure_solves,
              static_cast<double>(st[1].pressure_iterations) / st[1].pressure_solves);
  EXPECT_GT(st[0].pressure_max_distance, 0.0);
  EXPECT_LT(st[0].pressure_max_distance, 10.0);  // the layer is thinner than the 10-cell box
  EXPECT_EQ(st[0].pressure_stiff_solves, 0);
  EXPECT_EQ(st[1].pressure_stiff_solves, st[1].pressure_solves);
  ASSERT_EQ(prof[0].size(), prof[1].size());
  double du = 0.0;
  for (std::size_t n = 0; n < prof[0].size(); ++n)
    for (std::size_t q = 0; q < prof[0][n].h.size(); ++q) {
      ASSERT_EQ(prof[0][n].h[q], prof[1][n].h[q]) << "step " << n << ", column " << q;
      du = std::max(du, std::abs(prof[0][n].u_mean[q] - prof[1][n].u_mean[q]));
    }
  std::printf("[measured] largest u_mean difference %.2e m/s\n", du);
  EXPECT_LE(du, 1e-8);
}
