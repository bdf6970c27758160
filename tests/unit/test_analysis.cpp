// Run comparison, a priori layout and the momentum budget (granflow-study) on synthetic
// profiles and layers with known answers, and the budget of a DAM solution.
#include "granflow/analysis/budget.hpp"
#include "granflow/analysis/profiles.hpp"

#include "../dam/dam_test_util.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

using namespace granflow::analysis;

namespace {
ProfileAt uniform_profile(int n, double L, double h, double u) {
  ProfileAt p;
  for (int i = 0; i < n; ++i) {
    p.x.push_back((i + 0.5) * L / n);
    p.h.push_back(h);
    p.u.push_back(u);
    p.eps.push_back(0.0);
    p.model.push_back("1D");
  }
  return p;
}
}  // namespace

TEST(Compare, RelativeErrorsOfAKnownPerturbation) {
  auto ref = uniform_profile(100, 1.0, 0.02, 2.0);
  auto test = ref;
  for (auto& h : test.h) h *= 1.01;  // +1 % everywhere
  test.u[50] = 2.2;                   // +10 % at one point
  const auto e = compare(ref, test, 1e-3, 1e-3);
  // Exact values up to round-off of the arithmetic on O(1) numbers.
  EXPECT_NEAR(e.h.max_rel, 0.01, 1e-12);
  EXPECT_NEAR(e.h.l2_rel, 0.01, 1e-12);
  EXPECT_NEAR(e.u.max_rel, 0.1, 1e-12);
  EXPECT_NEAR(e.u.l2_rel, std::sqrt(0.2 * 0.2 / (100 * 4.0)), 1e-12);
  EXPECT_EQ(e.h.points, 100);
}

TEST(Compare, DryReferencePointsAreNotCompared) {
  auto ref = uniform_profile(10, 1.0, 0.02, 1.0);
  for (int i = 5; i < 10; ++i) ref.h[static_cast<std::size_t>(i)] = 0.0;
  auto test = ref;
  test.h[7] = 0.05;  // material where the reference is dry: outside the flowing part
  const auto e = compare(ref, test, 1e-3, 1e-3);
  EXPECT_EQ(e.h.points, 5);
  EXPECT_EQ(e.h.max_rel, 0.0);
}

TEST(Compare, AveragedVelocityOfALinearProfileIsItsMidpointValue) {
  // u = 3 x on [0, 1]: 1/l int_0^l 3x dx = 1.5 l; the midpoint rule is exact for linear data.
  auto p = uniform_profile(200, 1.0, 0.01, 0.0);
  for (std::size_t i = 0; i < p.x.size(); ++i) p.u[i] = 3.0 * p.x[i];
  EXPECT_NEAR(average_velocity(p, 0.2), 0.3, 1e-12);
}

namespace {
// read_profiles of a profiles.csv text written to a file under the temporary directory (not the
// source tree), removed again
std::map<double, ProfileAt> read_text(const std::string& name, const std::string& text,
                                      std::string* note = nullptr) {
  const auto path = std::filesystem::temp_directory_path() /
                    ("granflow_" + name + "_" + std::to_string(::getpid()) + ".csv");
  std::ofstream(path, std::ios::binary) << text;
  struct Remove {
    std::filesystem::path p;
    ~Remove() { std::filesystem::remove(p); }
  } remove{path};
  return read_profiles(path.string(), note);
}
}  // namespace

TEST(Profiles, AnOutputWrittenInPartIsLeftOutWithANote) {
  // A run still writing its last output, or stopped inside it: granflow-study compare took
  // the rows it found and filled the missing columns with the last one (h L2 0.631 against the
  // true 0.070; an independent run). Outputs of four columns on [0, 1] m:
  const std::string head = "t,x,h,u_mean,eps,model\n";
  auto output = [](const std::string& t) {
    std::string o;
    for (const char* x : {"0.125", "0.375", "0.625", "0.875"})
      o += t + "," + x + ",0.1,1,0.1,1D\n";
    return o;
  };
  std::string note;
  // whole: both outputs, no note
  auto whole = read_text("whole", head + output("0") + output("0.5"), &note);
  EXPECT_EQ(whole.size(), 2u);
  EXPECT_TRUE(note.empty()) << note;
  // the second output ends at x = 0.375 m where the first reached 0.875 m: left out
  auto part = read_text("part", head + output("0") + "0.5,0.125,0.2,2,0.1,1D\n"
                                                      "0.5,0.375,0.2,2,0.1,1D\n", &note);
  ASSERT_EQ(part.size(), 1u);
  EXPECT_EQ(part.begin()->first, 0.0);
  EXPECT_NE(note.find("t = 0.5 s"), std::string::npos) << note;
  // a row of the last output cut inside its eps field (no newline): that output is left out
  auto cut = read_text("cut", head + output("0") + "0.5,0.125,0.2,2,0.1,1D\n0.5,0.375,0.2,2,0.0",
                       &note);
  ASSERT_EQ(cut.size(), 1u);
  EXPECT_FALSE(note.empty());
  // the first row of a next output cut: the output before it is whole and stays (a review:
  // it was dropped)
  auto next = read_text("next", head + output("0") + output("0.5") + "1,0.125,0.1", &note);
  EXPECT_EQ(next.size(), 2u);
  EXPECT_TRUE(note.empty()) << note;
  // the only output cut: nothing complete is left
  auto only = read_text("only", head + "0,0.125,0.1,1,0.1,1D\n0,0.375,0.1", &note);
  EXPECT_TRUE(only.empty());
  EXPECT_FALSE(note.empty());
  // a dynamic layout whose last part changes grid between outputs: the first output ends in
  // 0.05 m cells at 0.975 m, the second in 0.25 m cells at 0.875 m; both reach x = 1 m and stay
  // (a review: the second was dropped, its last centre lying before the first's)
  auto regrid = read_text("regrid", head +
      "0,0.125,0.1,1,0.1,1D\n0,0.375,0.1,1,0.1,1D\n0,0.625,0.1,1,0.1,1D\n"
      "0,0.775,0.1,1,0.1,2D\n0,0.825,0.1,1,0.1,2D\n0,0.875,0.1,1,0.1,2D\n"
      "0,0.925,0.1,1,0.1,2D\n0,0.975,0.1,1,0.1,2D\n" + output("0.5"), &note);
  EXPECT_EQ(regrid.size(), 2u);
  EXPECT_TRUE(note.empty()) << note;
  // CRLF line ends (a copy through another system) read as LF
  std::string crlf = head + output("0");
  for (std::size_t q = 0; (q = crlf.find('\n', q)) != std::string::npos; q += 2) crlf.insert(q, "\r");
  EXPECT_EQ(read_text("crlf", crlf).size(), 1u);
  // a model that is neither 1D nor 2D, or a number with trailing text, is no row
  EXPECT_THROW(read_text("model", head + "0,0.125,0.1,1,0.1,2X\n"), std::runtime_error);
  EXPECT_THROW(read_text("number", head + "0,0.125,0.1x,1,0.1,1D\n"), std::runtime_error);
}

TEST(Layout, TwoDeepRegionsWidenedByTheMarginWithOneDBetween) {
  // eps >= 0.1 on x < 0.05 (inlet) and x > 0.9 (wall): expect 2D [0, 0.05 + m],
  // 1D in between, 2D [0.9 - m, 1].
  auto p = uniform_profile(100, 1.0, 0.02, 1.0);
  for (std::size_t i = 0; i < p.x.size(); ++i)
    p.eps[i] = (p.x[i] < 0.05 || p.x[i] > 0.9) ? 1.0 : 0.01;
  const std::map<double, ProfileAt> run{{0.5, p}};
  const auto lay = propose_layout(run, 1.0, 0.1, 0.05, 0.02, 1e-3);
  ASSERT_EQ(lay.size(), 3u);
  EXPECT_EQ(lay[0].model, "2D");
  EXPECT_EQ(lay[1].model, "1D");
  EXPECT_EQ(lay[2].model, "2D");
  // Cell faces lie on multiples of 0.01; round-off only.
  EXPECT_NEAR(lay[0].x1, 0.10, 1e-12);
  EXPECT_NEAR(lay[2].x0, 0.85, 1e-12);
  EXPECT_NEAR(lay[2].x1, 1.0, 1e-12);
}

TEST(Layout, ShortOneDGapsAreAbsorbedAndDryCellsIgnored) {
  auto p = uniform_profile(100, 1.0, 0.02, 1.0);
  for (std::size_t i = 0; i < p.x.size(); ++i) {
    p.eps[i] = (p.x[i] < 0.3 || (p.x[i] > 0.32 && p.x[i] < 0.5)) ? 1.0 : 0.0;
    if (p.x[i] > 0.8) { p.h[i] = 0.0; p.eps[i] = 1e6; }  // dry: must not count
  }
  const auto lay = propose_layout({{0.1, p}}, 1.0, 0.1, 0.0, 0.05, 1e-3);
  ASSERT_EQ(lay.size(), 2u);
  EXPECT_EQ(lay[0].model, "2D");
  EXPECT_NEAR(lay[0].x1, 0.5, 1e-12);
  EXPECT_EQ(lay[1].model, "1D");
}

TEST(Layout, NoMarginAndNoMinimumLengthGiveNoRoundOffSubdomains) {
  // Margin 0 and 'Minimum length' 0 (allowed): the flagged cells' faces x_i +- dx/2 of
  // neighbours differ in the last bits, and each such pair made a 1D subdomain of 6e-18 m (and
  // one of 8.7e-19 m at x = 0), whose stable step of 3e-18 s stopped the run at t = 0 (an
  // independent run). Cells of 10 mm flagged on [0, 0.06) and [0.93, 1]: exactly three parts,
  // their ends on the cell faces to round-off.
  auto p = uniform_profile(100, 1.0, 0.02, 1.0);
  for (std::size_t i = 0; i < p.x.size(); ++i)
    p.eps[i] = (p.x[i] < 0.06 || p.x[i] > 0.93) ? 1.0 : 0.01;
  const auto lay = propose_layout({{0.5, p}}, 1.0, 0.1, 0.0, 0.0, 1e-3);
  ASSERT_EQ(lay.size(), 3u);
  EXPECT_EQ(lay[0].model, "2D");
  EXPECT_EQ(lay[0].x0, 0.0);
  EXPECT_NEAR(lay[0].x1, 0.06, 1e-12);
  EXPECT_EQ(lay[1].model, "1D");
  EXPECT_NEAR(lay[2].x0, 0.93, 1e-12);
  EXPECT_EQ(lay[2].x1, 1.0);
  for (const auto& s : lay) EXPECT_GT(s.x1 - s.x0, 0.005) << s.model << " [" << s.x0 << ", " << s.x1 << "]";
  // a margin that is no multiple of half a cell: cells flagged on [0, 0.06) and [0.09, 0.5)
  // widened by 0.0149999 m leave a gap of 2e-7 m between them (a review): no 1D part there
  for (std::size_t i = 0; i < p.x.size(); ++i)
    p.eps[i] = (p.x[i] < 0.06 || (p.x[i] > 0.09 && p.x[i] < 0.5)) ? 1.0 : 0.01;
  const auto lay2 = propose_layout({{0.5, p}}, 1.0, 0.1, 0.0149999, 0.0, 1e-3);
  ASSERT_EQ(lay2.size(), 2u);
  EXPECT_EQ(lay2[0].model, "2D");
  EXPECT_NEAR(lay2[0].x1, 0.5149999, 1e-12);
  EXPECT_EQ(lay2[1].model, "1D");
}

// --- the depth-averaged momentum budget (granflow-study budget) on analytic layers -----------

namespace {
// A layer of depth h(x) on nx columns of dx, nz cells of dz: cell-centred fields from u(x, z)
// and the hydrostatic pressure p = g cos(zeta) (h - z), constant nu, flags from h.
Snapshot2D layer(double t, int nx, int nz, double dx, double dz, const BudgetPhysics& ph,
                 double (*h)(double), double (*u)(double x, double z, double h, double t),
                 double nu) {
  Snapshot2D s;
  s.t = t;
  s.nx = nx;
  s.nz = nz;
  s.dx = dx;
  s.dz = dz;
  const double gc = ph.g * std::cos(ph.zeta);
  for (int k = 0; k < nz; ++k)
    for (int i = 0; i < nx; ++i) {
      const double x = (i + 0.5) * dx, z = (k + 0.5) * dz, hi = h(x);
      const bool m = k * dz < hi;
      s.u.push_back(m ? u(x, z, hi, t) : 0.0);
      s.p.push_back(m ? gc * std::max(0.0, hi - z) : 0.0);
      s.nu.push_back(nu);
      s.flag.push_back(m ? 1.0 : 3.0);
    }
  for (int i = 0; i < nx; ++i) s.h.push_back(h((i + 0.5) * dx));
  return s;
}
BudgetPhysics slope(double zeta_deg, double delta_deg) {
  BudgetPhysics ph;
  ph.zeta = zeta_deg * M_PI / 180.0;
  ph.tan_delta = std::tan(delta_deg * M_PI / 180.0);
  return ph;
}
double flat(double) { return 0.02; }
double plug(double, double, double, double) { return 2.0; }
}  // namespace

// A uniform plug at 2 m/s on a slope at the bed friction angle, hydrostatic: gravity and the
// Coulomb friction balance (tan(delta) N with N = g cos(zeta) h: the cell-centre pressure taken
// to the bed, and m_c u = 200 makes the regularisation 1 - exp(-200) = 1), every other term is
// zero, alpha = 1: the budget closes to round-off.
TEST(Budget, UniformPlugAtTheFrictionAngleIsInBalance) {
  const auto ph = slope(30.0, 30.0);
  const auto a = layer(0.0, 20, 8, 0.01, 0.0025, ph, flat, plug, 0.01);
  const auto b = layer(0.1, 20, 8, 0.01, 0.0025, ph, flat, plug, 0.01);
  const auto cb = momentum_budget({column_integrals(a, ph), column_integrals(b, ph)}, {0.0, 0.1},
                                  0.0, 0.01, ph);
  for (std::size_t i = 0; i < cb.x.size(); ++i) {
    EXPECT_NEAR(cb.alpha[i], 1.0, 1e-14);
    EXPECT_NEAR(cb.u_mean[i], 2.0, 1e-14);
    EXPECT_NEAR(cb.gravity[i], 9.81 * 0.5 * 0.02, 1e-15);
    EXPECT_NEAR(cb.friction[i], -cb.gravity[i], 1e-14);        // applied Coulomb stress
    EXPECT_NEAR(cb.friction_bound[i], -cb.gravity[i], 1e-14);  // tan(delta) p_b
    EXPECT_NEAR(cb.residual[i], 0.0, 1e-14);
    EXPECT_NEAR(cb.flux[i] + cb.pressure[i] + cb.viscous[i] + cb.dQdt[i], 0.0, 1e-14);
  }
}

// Sheared, thinning and accelerating: u = U(t) 2 z / h (mean U, alpha = 4/3 of the linear
// profile), h = 0.02 - 0.01 x, U = 1 + 3 t. The budget's terms against their analytic values:
// d(hU)/dt = 3 h, the flux d(alpha h U^2)/dx = (4/3) U^2 h_x, the pressure -g cos(zeta) h h_x. Tolerances: the column integrals
// weigh the cell containing the surface by its filled fraction but take its centre value (as
// the profile's u_mean, eq. 21), an error first order in dz/h (h = 20-40 cells here: alpha to
// 1.1 %, and its column-to-column variation in the x-derivative of the flux to 2.9 %); the
// pressure is linear in z and its integral second order (measured 0.5 %), d(hu)/dt exact but
// for the same partial cell (0.06 %).
TEST(Budget, ShearedThinningLayerTermsMatchTheAnalyticOnes) {
  const auto ph = slope(40.0, 25.0);
  auto h = [](double x) { return 0.02 - 0.01 * x; };
  auto u = [](double, double z, double hh, double t) { return (1.0 + 3.0 * t) * 2.0 * z / hh; };
  const int nx = 50, nz = 40;
  const double dx = 0.02, dz = 0.0005;
  std::vector<ColumnIntegrals> cols;
  std::vector<double> ts;
  for (double t : {0.0, 0.05, 0.1}) {
    cols.push_back(column_integrals(layer(t, nx, nz, dx, dz, ph, h, u, 0.001), ph));
    ts.push_back(t);
  }
  const auto cb = momentum_budget(cols, ts, 0.0, dx, ph);
  const double gc = 9.81 * std::cos(ph.zeta), hx = -0.01;
  const double U = 1.0 + 3.0 * 0.05;  // the time mean of U over [0, 0.1]
  double worst_alpha = 0, worst_q = 0, worst_f = 0, worst_p = 0;
  for (std::size_t i = 1; i + 1 < cb.x.size(); ++i) {
    const double hi = h(cb.x[i]);
    worst_alpha = std::max(worst_alpha, std::abs(cb.alpha[i] - 4.0 / 3.0));
    worst_q = std::max(worst_q, std::abs(cb.dQdt[i] - 3.0 * hi) / (3.0 * hi));
    // mean of U^2 over t in [0, 0.1] by the trapezoid rule of three snapshots
    const double U2 = 0.25 * 1.0 + 0.5 * U * U + 0.25 * 1.3 * 1.3;
    worst_f = std::max(worst_f, std::abs(cb.flux[i] - 4.0 / 3.0 * U2 * hx) / std::abs(4.0 / 3.0 * U2 * hx));
    worst_p = std::max(worst_p, std::abs(cb.pressure[i] + gc * hi * hx) / std::abs(gc * hi * hx));
  }
  std::printf("[measured] budget of the sheared layer: |alpha - 4/3| %.2e, d(hu)/dt %.2e, flux "
              "%.2e, pressure %.2e (relative)\n", worst_alpha, worst_q, worst_f, worst_p);
  EXPECT_LT(worst_alpha, 0.02);
  EXPECT_LT(worst_q, 2e-3);
  EXPECT_LT(worst_f, 0.05);
  EXPECT_LT(worst_p, 0.01);
}

// The budget on a real solution: the DAM's steady Setup I chute (gate h_in = 0.06 m,
// u_in = 0.37 m/s, zeta = 50, delta = 22, phi = 33 deg, 300 cells of 5 mm, Minmod, Savage-Hutter
// K) sampled every 0.02 s over [1.0, 1.5] s, when the flow over [0.3, 1.2] m is steady. With the
// DAM's own closure (alpha = 1, K g cos h^2/2, tan(delta) g cos h) the budget of its conservative
// scheme must close: the residual over the stretch is below 1 % of the flux term, the velocity
// gain of the flow there (measured 0.04 %; what remains is the centred evaluation of a solution
// of a limited, staggered scheme, and the 0.02 s sampling of the time means). This is the check
// that the tool's terms, signs and closure are the DAM's equations (16): on the 2D runs the same
// tool reports the residual of the N-DAM (docs/validation.md).

TEST(Budget, SteadyDamChuteClosesWithTheDamClosure) {
  using namespace granflow::dam;
  using namespace granflow::dam::testing;
  const auto phys = incline(50.0, 22.0, 33.0, EarthPressure::SavageHutter);
  DamSolver s(0.0, 1.5, config(300, Scheme::Minmod, EarthPressure::SavageHutter), phys,
              inflow(0.06, 0.37), boundary(BoundaryType::Outflow));
  std::vector<std::vector<double>> hs, us;
  std::vector<double> ts;
  for (int q = 0; q <= 25; ++q) {
    const double t = 1.0 + 0.02 * q;
    advance(s, t);
    const auto p = s.profile();
    hs.push_back(p.h);
    us.push_back(p.u_mean);
    ts.push_back(t);
  }
  BudgetPhysics ph = slope(50.0, 22.0);
  const auto cb = dam_budget(hs, us, ts, 0.0, 1.5 / 300, ph,
                             [&](double ux) { return phys.K(ux); });
  const auto st = stretch(cb, 0.3, 1.2);
  std::printf("[measured] DAM Setup I budget over [0.3, 1.2] m: flux %.5f, gravity %.5f, "
              "pressure %.5f, friction %.5f, d(hu)/dt %.2e, residual %.2e m^3/s^2 (%.2f %% of "
              "the flux)\n", st.flux, st.gravity, st.pressure, st.friction, st.dQdt, st.residual,
              100.0 * st.residual / st.flux);
  EXPECT_GT(st.flux, 0.03);  // it accelerates by about 1.7 m/s over the stretch
  EXPECT_LT(std::abs(st.dQdt), 0.01 * st.flux);  // steady
  EXPECT_LT(std::abs(st.residual), 0.01 * st.flux);
}
