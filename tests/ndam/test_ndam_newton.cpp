// The nonlinear pressure system of the N-DAM ('Pressure coupling' = Nonlinear, issue 4 item 4):
// tau_y = tau_p p and the Coulomb law (13) at p^{n+1}, solved by NOX in every step.
#include "ndam_chute_util.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace {

using namespace granflow;

// A Drucker-Prager lid-driven box under gravity (closed, no free surface): the pressure grows
// with depth, so tau_y = sin(phi) p varies in space, and the start-up of the flow changes p in
// time, so the lagged and the nonlinear coupling differ by the change of p over one step.
ndam_test::Case dp_box(const std::string& coupling) {
  ndam_test::Case c;
  c.nx = c.nz = 12;
  c.lx = c.lz = 0.1;
  c.rheology = "Drucker-Prager";
  c.nu = 0.003;
  c.m_y = 100.0;
  c.gravity = 9.81;
  c.lid = 0.5;
  c.coupling = coupling;
  return c;
}

}  // namespace

// The gate-fed chute with Drucker-Prager material and Coulomb bed and wall, run with the lagged
// and with the nonlinear coupling (dt = 1 ms, to 0.06 s): every Newton solve converges within
// 3 iterations (measured 1-3), the two couplings differ (the nonlinear one is not silently the
// lagged step: measured max |du| 1.0e-3 m/s, max |dp| 1.1e-3 m^2/s^2) and agree to within what
// lagging p by one step can make, bounded by 5e-3 m/s (1.4 % of the 0.37 m/s inflow; the
// lagged error is O(dt dp/dt); measured values 1.0e-3 (dt = 1 ms) and 2.4e-3 (2 ms), i.e.
// first order up to the marker noise).
TEST(NdamPressureNewton, NonlinearAndLaggedCouplingAgreeToOneStepLag) {
  const double dt = 1e-3, t_end = 0.06;
  auto lag = ndam_chute::make_fs(ndam_chute::gate_chute("Lagged"));
  auto nl = ndam_chute::make_fs(ndam_chute::gate_chute("Nonlinear"));
  int max_newton = 0;
  for (int n = 0; n * dt < t_end - 1e-12; ++n) {
    lag->step(dt);
    ASSERT_TRUE(lag->check().ok);
    lag->accept();
    nl->step(dt);
    const auto h = nl->check();
    ASSERT_TRUE(h.ok) << h.quantity << ": " << h.reason;
    ASSERT_TRUE(nl->last_newton_solve().converged);
    max_newton = std::max(max_newton, nl->last_newton_solve().newton_iterations);
    nl->accept();
  }
  const double du = ndam_test::max_abs_diff(lag->gather_u(), nl->gather_u());
  const double dp = ndam_test::max_abs_diff(lag->gather_p(), nl->gather_p());
  std::printf("lagged vs nonlinear: max |du| %.3e m/s, max |dp| %.3e m^2/s^2, Newton its <= %d\n",
              du, dp, max_newton);
  EXPECT_EQ(nl->newton_solves(), 60);
  EXPECT_LE(max_newton, 3);
  EXPECT_GT(du, 1e-6);
  EXPECT_LT(du, 5e-3);
}

// With the nonlinear coupling the Drucker-Prager layer on the periodic Coulomb incline (50/22/33
// deg, 5 cm, 1 cm cells) still slides as a rigid plug from rest along the law of the
// regularised friction (plug_law), within the same 1 % at every output to 0.3 s as the lagged
// test (in a plug p is hydrostatic, so both couplings must agree), and every Newton solve
// converges (check() would stop the step otherwise).
TEST(NdamPressureNewton, PlugSlidesWithNonlinearCoupling) {
  ndam_chute::FsCase c;
  c.coupling = "Nonlinear";
  auto s = ndam_chute::make_fs(c);
  const std::vector<double> times{0.05, 0.1, 0.15, 0.2, 0.25, 0.3};
  const auto law = ndam_chute::plug_law(c.slope_deg, c.delta_deg, c.m_c, times);
  const auto u = ndam_chute::mean_u_at(*s, times, 0.01);
  ASSERT_EQ(u.size(), times.size());
  for (std::size_t q = 0; q < times.size(); ++q) {
    std::printf("nonlinear plug t = %.2f s: u_mean %.5f m/s, law %.5f (%+.3f %%)\n", times[q],
                u[q], law[q], 100 * (u[q] / law[q] - 1));
    EXPECT_NEAR(u[q], law[q], 0.01 * law[q]) << "t = " << times[q];
  }
  EXPECT_GT(s->newton_solves(), 0);
}

// A Newton solve that cannot reach its tolerance stops the step with a diagnosis naming the
// nonlinear pressure system, never silently: one Newton iteration allowed, tolerance 1e-15.
// With 'Pressure Newton failure' = Continue the step goes on and is counted in the report.
TEST(NdamPressureNewton, NewtonFailureStopsTheStep) {
  auto c = dp_box("Nonlinear");
  c.newton_max = 1;
  c.newton_abs_tol = 1e-15;
  auto s = ndam_test::make(c);
  s->step(2e-3);
  const auto h = s->check();
  EXPECT_FALSE(h.ok);
  EXPECT_EQ(h.quantity, "pressure Newton (NOX)");
  EXPECT_NE(h.reason.find("did not converge"), std::string::npos) << h.reason;
  EXPECT_FALSE(s->last_newton_solve().converged);
  // 'Pressure Newton failure' = Continue keeps the best iterate and counts the step instead
  c.newton_continue = true;
  auto k = ndam_test::make(c);
  k->step(2e-3);
  EXPECT_TRUE(k->check().ok);
  EXPECT_FALSE(k->last_newton_solve().converged);
  nlohmann::json st;
  k->report(st);
  EXPECT_EQ(st["ndam"]["newton"]["unconverged_steps_continued"].get<long long>(), 1);
  EXPECT_GT(st["ndam"]["newton"]["worst_residual_continued"].get<double>(), 1e-15);
}

// A Newtonian box without Coulomb sides does not depend on p: the nonlinear coupling is the
// lagged step itself (no Newton solve, identical state).
TEST(NdamPressureNewton, LinearSystemNeedsNoNewton) {
  auto c = dp_box("Nonlinear");
  c.rheology = "Newtonian";
  auto nl = ndam_test::make(c);
  c.coupling = "Lagged";
  auto lag = ndam_test::make(c);
  for (int n = 0; n < 5; ++n) {
    nl->step(2e-3);
    nl->accept();
    lag->step(2e-3);
    lag->accept();
  }
  EXPECT_EQ(nl->newton_solves(), 0);
  EXPECT_EQ(ndam_test::max_abs_diff(nl->gather_p(), lag->gather_p()), 0.0);
}
