// DAM verification (DESIGN.md section 7, issue 2 point 6): closed-form solutions, conservation,
// positivity, observed order of convergence and stopping of the NOC scheme in
// src/dam/dam_solver.cpp, driven through its C++ API (dt = min(stable_dt, t_end - t); step;
// check; accept). Every tolerance states where its number comes from; the measured values are
// printed as "[measured]" lines and collected in docs/validation.md ("1D depth-averaged model").
#include "dam_test_util.hpp"

#include "granflow/dam/initial_condition.hpp"

#include <cstdio>

using namespace granflow::dam;
using namespace granflow::dam::testing;

namespace {


// =============================================================================================
// 1. Uniform layer on a periodic incline: h stays h0, u(t) = u0 + s t
// =============================================================================================
// With uniform data all slopes and flux differences vanish identically, so one step is
// hu <- hu + dt (g sin(zeta) - g cos(zeta) tan(delta)) h: a few roundings per step. Over n ~ 700
// steps the accumulated relative error is <= n * 4 eps ~ 6e-13 in the worst case (it measured
// 1.2e-15, the roundings do not accumulate coherently); h is never touched apart from the
// Gauss-weight rounding of set_state (measured 1.4e-16 = 1 ulp).
TEST(DamVerification, UniformLayerAcceleratesAtS) {
  for (TimeStepping ts : kBothTimeSteppings)
  for (Scheme scheme : {Scheme::Minmod, Scheme::BeamWarming}) {
    const auto phys = incline(35.0, 20.0, 30.0, EarthPressure::SavageHutter);
    const double s = net_acceleration(phys), h0 = 0.1, u0 = 0.5;  // u0 > 0: friction sign fixed
    ASSERT_GT(s, 0.0);
    DamSolver dam(0.0, 1.0, config(100, scheme, EarthPressure::SavageHutter, 0.45, ts), phys,
                  boundary(BoundaryType::Periodic), boundary(BoundaryType::Periodic));
    dam.set_state([=](double) { return h0; }, [=](double) { return u0; });
    double worst_h = 0.0, worst_u = 0.0;
    advance(dam, 1.0, [&](const DamSolver& d) {
      const double u_ex = u0 + s * d.time();
      for (std::size_t k = 0; k < d.h().size(); ++k) {
        worst_h = std::max(worst_h, std::abs(d.h()[k] - h0) / h0);
        worst_u = std::max(worst_u, std::abs(d.hu()[k] / d.h()[k] - u_ex) / u_ex);
      }
    });
    std::printf("[measured] uniform layer (%s, %s, N=100, %ld steps to t=1 s): max rel err h "
                "%.2e, u %.2e\n",
                name(ts), name(scheme), dam.steps(), worst_h, worst_u);
    EXPECT_LT(worst_h, 1e-14);  // 1 ulp measured; 1e-14 = ~70 ulp
    EXPECT_LT(worst_u, 1e-12);  // worst-case bound n * 4 eps ~ 6e-13 (see above)
  }
}

// =============================================================================================
// 2. Dam break on an incline against the Ritter solution in the accelerating frame
// =============================================================================================
// Constant K (Active), slope steeper than delta (s > 0), released from rest: all material moves
// downslope, friction has a fixed sign and x' = x - s t^2/2, u' = u - s t turn the problem into
// the frictionless Ritter dam break:
//   h = (2 c0 - x'/t)^2 / (9 beta), u = 2/3 (c0 + x'/t) + s t   for -c0 t < x' < 2 c0 t.
struct RitterResult {
  double l1 = 0.0, l1_rel = 0.0;
};

RitterResult ritter_run(int cells, TimeStepping ts) {
  const auto phys = incline(35.0, 25.0, 35.0, EarthPressure::Active);
  const double s = net_acceleration(phys), beta = phys.g_cos * phys.K_act;
  const double h0 = 0.1, xd = 1.0, a = 0.0, b = 2.4, t_end = 0.5;
  const double c0 = std::sqrt(beta * h0);
  // The left end lets the undisturbed reservoir (h0, u = s t) in; it is undisturbed there while
  // the rarefaction tail xd - c0 t + s t^2/2 stays > 0 (0.72 m at t_end). The front reaches
  // xd + 2 c0 t + s t^2/2 = 1.99 m < b.
  DamSolver dam(a, b, config(cells, Scheme::Minmod, EarthPressure::Active, 0.45, ts), phys,
                inflow([=](double t) { return std::array<double, 2>{h0, s * t}; }),
                boundary(BoundaryType::Outflow));
  dam.set_state([=](double x) { return x < xd ? h0 : 0.0; }, [](double) { return 0.0; });
  advance(dam, t_end);
  auto exact = [=](double x) {
    const double xp = x - xd - 0.5 * s * t_end * t_end;
    if (xp <= -c0 * t_end) return h0;
    if (xp >= 2.0 * c0 * t_end) return 0.0;
    const double w = 2.0 * c0 - xp / t_end;
    return w * w / (9.0 * beta);
  };
  const auto hex = cell_averages(exact, a, b, cells);
  std::vector<double> h, hu;
  dam.primary(h, hu);
  RitterResult r;
  double m = 0.0;
  for (std::size_t k = 0; k < h.size(); ++k) {
    r.l1 += std::abs(h[k] - hex[k]) * dam.dx();
    m += hex[k] * dam.dx();
  }
  r.l1_rel = r.l1 / m;
  return r;
}

TEST(DamVerification, RitterDamBreakOnIncline) {
  for (TimeStepping ts : kBothTimeSteppings) {
  const auto r1 = ritter_run(240, ts), r2 = ritter_run(480, ts);
  const double order = std::log2(r1.l1 / r2.l1);
  std::printf("[measured] Ritter dam break (%s, Minmod, t=0.5 s): L1(h) N=240 %.3e m^2 (rel "
              "%.2e), N=480 %.3e m^2 (rel %.2e), observed order %.2f\n",
              name(ts), r1.l1, r1.l1_rel, r2.l1, r2.l1_rel, order);
  // Error level: measured rel. L1 3.7e-3 (N=240) and 1.75e-3 (N=480), O(dx): the smeared and
  // lagging dry front (cells below the dry depth 1e-6 m do not move), the kinks at the
  // rarefaction tail and the front, and the O(dx) imprint of the initial jump. Bounds ~1.4x.
  // The dam sits on a cell face at both resolutions: the error depends on where the jump falls
  // in a cell (with the jump mid-cell, N=400 on [0, 3 m], L1 was 35 % larger than with N=300),
  // which would otherwise scramble the observed order. Semi-discrete: 5.6e-3 and 2.9e-3,
  // order 0.96 (its fan dissipation a dx smears the front more than the staggered averaging
  // at the stable step); bounds ~1.4x.
  const bool stag = ts == TimeStepping::Staggered;
  EXPECT_LT(r1.l1_rel, stag ? 5e-3 : 8e-3);
  EXPECT_LT(r2.l1_rel, stag ? 2.5e-3 : 4e-3);
  // Convergence: first order expected at the front/kinks (measured 1.08; 0.97-1.08 for N = 180,
  // 360, 720 on the same channel).
  EXPECT_GT(order, 0.8);
  }
}

// =============================================================================================
// 3. Shock reflected from a wall against the Rankine-Hugoniot conditions
// =============================================================================================
// Horizontal frictionless channel, K = 1 (beta = g): the state (h0, u0 > 0) runs into the right
// wall; behind the reflected shock u = 0 and h1 solves
//   mass     S (h1 - h0) = -h0 u0,
//   momentum S (0 - h0 u0) = beta h1^2/2 - h0 u0^2 - beta h0^2/2,
// i.e. h0 u0^2 h1 = beta/2 (h1 - h0)^2 (h1 + h0), S = -h0 u0 / (h1 - h0).
double rh_depth(double h0, double u0, double beta) {
  double h1 = 1.5 * h0 + u0 * std::sqrt(h0 / beta);  // start above h0: the compressive root
  for (int it = 0; it < 60; ++it) {
    const double F = 0.5 * beta * (h1 - h0) * (h1 - h0) * (h1 + h0) - h0 * u0 * u0 * h1;
    const double dF =
        beta * (h1 - h0) * (h1 + h0) + 0.5 * beta * (h1 - h0) * (h1 - h0) - h0 * u0 * u0;
    h1 -= F / dF;
  }
  return h1;
}

TEST(DamVerification, WallShockRankineHugoniot) {
  for (TimeStepping ts : kBothTimeSteppings) {
  const auto phys = incline(0.0, 0.0, 30.0, EarthPressure::Isotropic);
  const double beta = phys.g_cos, h0 = 0.1, u0 = 1.0, L = 2.0;
  const double h1 = rh_depth(h0, u0, beta), S = -h0 * u0 / (h1 - h0);
  const int N = 400;
  DamSolver dam(0.0, L, config(N, Scheme::Minmod, EarthPressure::Isotropic, 0.45, ts), phys,
                inflow(h0, u0), boundary(BoundaryType::Wall));
  dam.set_state([=](double) { return h0; }, [=](double) { return u0; });
  struct Snapshot {
    double xs, h, u;
  };
  // Shock position: where the primary-grid depth crosses (h0 + h1)/2 (linear interpolation);
  // plateau: mean h and u over the middle half between shock and wall.
  auto snapshot = [&]() {
    std::vector<double> h, hu;
    dam.primary(h, hu);
    const double mid = 0.5 * (h0 + h1);
    Snapshot r{L, 0.0, 0.0};
    for (int j = N - 1; j > 0; --j) {
      const auto k = static_cast<std::size_t>(j);
      if (h[k - 1] < mid && h[k] >= mid) {
        r.xs = dam.dx() * (j - 0.5 + (mid - h[k - 1]) / (h[k] - h[k - 1]));
        break;
      }
    }
    int n = 0;
    for (int j = 0; j < N; ++j) {
      const auto k = static_cast<std::size_t>(j);
      const double x = (j + 0.5) * dam.dx();
      if (x > r.xs + 0.25 * (L - r.xs) && x < L - 0.25 * (L - r.xs)) {
        r.h += h[k];
        r.u += hu[k] / h[k];
        ++n;
      }
    }
    r.h /= n;
    r.u /= n;
    return r;
  };
  advance(dam, 0.6);
  const Snapshot a = snapshot();
  advance(dam, 1.4);
  const Snapshot b = snapshot();
  const double S_num = (b.xs - a.xs) / 0.8;
  std::printf("[measured] wall shock (%s, Minmod, N=400): h1 exact %.6f m, plateau %.6f / %.6f "
              "(rel %.1e / %.1e), u plateau %.1e / %.1e m/s; S exact %.5f m/s, measured %.5f "
              "(rel %.1e)\n",
              name(ts), h1, a.h, b.h, a.h / h1 - 1, b.h / h1 - 1, a.u, b.u, S, S_num,
              S_num / S - 1);
  // The plateau is a constant state, which the conservative scheme reproduces exactly once the
  // start-up transient at the wall has decayed (measured rel. 1.6e-5 and 4.7e-7, u ~ 4e-6 m/s
  // staggered; 3.1e-6 and 1.6e-7, u ~ 8e-7 m/s semi-discrete).
  // 1e-4 leaves room for that transient without admitting any O(dx) error (dx/L = 2.5e-3).
  EXPECT_NEAR(a.h / h1, 1.0, 1e-4);
  EXPECT_NEAR(b.h / h1, 1.0, 1e-4);
  EXPECT_LT(std::abs(a.u), 1e-4);
  EXPECT_LT(std::abs(b.u), 1e-4);
  // Shock speed from positions 0.68 m apart; the interpolated mid-depth point of a smeared but
  // steadily travelling profile is known to ~0.1 dx = 5e-4 m -> 1.5e-3 relative
  // (measured 2.4e-4 / 2.2e-4); bound 2e-3.
  EXPECT_NEAR(S_num / S, 1.0, 2e-3);
  }
}

// =============================================================================================
// 4. Steady supercritical profile: h u = q, u^2/2 + beta q/u = E0 + s x
// =============================================================================================
struct SteadyResult {
  double q_err = 0.0, u_err = 0.0, e_spread = 0.0, fr_min = 1e300;
};

SteadyResult steady_run(int N, Scheme scheme) {
  const auto phys = incline(35.0, 25.0, 35.0, EarthPressure::Active);
  const double s = net_acceleration(phys), beta = phys.g_cos * phys.K_act;
  const double hin = 0.05, uin = 2.0, q = hin * uin, L = 2.0;
  const double E0 = 0.5 * uin * uin + beta * q / uin;
  DamSolver dam(0.0, L, config(N, scheme, EarthPressure::Active), phys, inflow(hin, uin),
                boundary(BoundaryType::Outflow));
  dam.set_state([=](double) { return hin; }, [=](double) { return uin; });
  advance(dam, 4.0);  // transit time L / u < 0.9 s: > 4 transits
  if (dam.staggered()) advance(dam, dam.time() + 0.5 * dam.stable_dt());
  // u(x) from the algebraic relation by Newton on the supercritical branch (u^3 > beta q, where
  // F' = u - beta q / u^2 > 0), started from the frictionless-pressure-free guess.
  auto u_exact = [&](double x) {
    double u = std::sqrt(uin * uin + 2.0 * s * x);
    for (int it = 0; it < 50; ++it) {
      const double F = 0.5 * u * u + beta * q / u - E0 - s * x;
      u -= F / (u - beta * q / (u * u));
    }
    return u;
  };
  SteadyResult r;
  double Emin = 1e300, Emax = -1e300;
  for (int j = 0; j < N; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const double x = (j + 0.5) * dam.dx(), u = dam.hu()[k] / dam.h()[k], ue = u_exact(x);
    r.q_err = std::max(r.q_err, std::abs(dam.hu()[k] - q) / q);
    r.u_err = std::max(r.u_err, std::abs(u - ue) / ue);
    const double E = 0.5 * u * u + beta * q / u - s * x;
    Emin = std::min(Emin, E);
    Emax = std::max(Emax, E);
    r.fr_min = std::min(r.fr_min, u / std::sqrt(beta * dam.h()[k]));
  }
  r.e_spread = (Emax - Emin) / E0;
  std::printf("[measured] steady supercritical (%s, N=%d): max rel |hu-q| %.2e, max rel |u-u_ex| "
              "%.2e, spread of (E - s x)/E0 %.2e, min Fr %.2f\n",
              name(scheme), N, r.q_err, r.u_err, r.e_spread, r.fr_min);
  return r;
}

TEST(DamVerification, SteadySupercriticalProfile) {
  // Beam-Warming, the paper's variant for this regime: the interior is steady to 1e-10 and
  // carries a constant q; what is left is made at the inflow end, which imposes the flux of
  // (h_in, u_in) at x = 0 exactly and reconstructs the first cell against the reflected ghost
  // 2 w_in - w_0 (src/dam/dam_solver.cpp, fill_ghosts). Measured: q 2.3e-4 / 1.7e-4, u 4.3e-4 /
  // 2.2e-4, E spread 1.6e-3 / 4.0e-4 (N = 100 / 200), largest in the first cell. (Before the
  // inflow fix, with the ghost state w_in half a cell upstream of x = 0 and half a staggered
  // cell of it booked per step: q 3.2e-3 / 1.5e-3, u 1.9e-3 / 8.4e-4, E 6.4e-4 / 4.9e-4.)
  // Bounds: measured x 1.5; the order of u (first, measured ratio 1.96) and of E (measured
  // ratio 4.1) asserted with margin; q converges more slowly (ratio 1.4) and is only bounded.
  const auto b1 = steady_run(100, Scheme::BeamWarming), b2 = steady_run(200, Scheme::BeamWarming);
  EXPECT_GT(b1.fr_min, 2.0);  // supercritical everywhere (Fr ~ 3.8)
  EXPECT_LT(b2.q_err, 2.5e-4);
  EXPECT_LT(b2.u_err, 3.3e-4);
  EXPECT_LT(b2.e_spread, 6e-4);
  EXPECT_GT(b1.u_err / b2.u_err, 1.6);
  EXPECT_GT(b1.e_spread / b2.e_spread, 2.0);
  // Minmod does not settle: limiter switching on the nearly constant hu keeps a noise of ~2 %
  // in hu (rel.) travelling downstream, independent of N (1.7-2.7 %) and of the CFL number
  // (0.25-0.45) -- the spurious oscillations the paper (section 3.2) gives as its reason for
  // the limiter-free variant in smooth supercritical regions. Bounds: measured x 1.5.
  const auto m1 = steady_run(100, Scheme::Minmod), m2 = steady_run(200, Scheme::Minmod);
  EXPECT_LT(m1.q_err, 4e-2);
  EXPECT_LT(m2.q_err, 4e-2);
  EXPECT_LT(m1.u_err, 8e-3);  // measured 4.9e-3
  EXPECT_LT(m2.u_err, 5e-3);  // measured 2.9e-3
}

// =============================================================================================
// 5. Mass conservation: closed channel; ledger with inflow and outflow
// =============================================================================================
// Each step is conservative in exact arithmetic (the corrector telescopes; walls have zero flux
// exactly). Rounding: each of the N new cell values carries ~2 eps relative error, and mass() is
// an N-term sum, so a step changes the computed mass by ~sqrt(N) eps ~ 5e-15 relative (random
// walk, N = 400) and n ~ 6000 steps by ~sqrt(n) * that ~ 4e-13 at worst; it measured 4e-15
// (the per-step errors partly cancel). Bound 1e-13: a single non-conservative flux at the
// walls (an O(dt dx) term) would exceed it by orders of magnitude.
TEST(DamVerification, MassConservedInClosedChannel) {
  for (TimeStepping ts : kBothTimeSteppings) {
  const auto phys = incline(35.0, 25.0, 35.0, EarthPressure::SavageHutter);
  DamSolver dam(0.0, 1.0, config(400, Scheme::Minmod, EarthPressure::SavageHutter, 0.45, ts),
                phys,
                boundary(BoundaryType::Wall), boundary(BoundaryType::Wall));
  // A block sliding into the lower wall: front, impact, reflected shock, deposit.
  dam.set_state([](double x) { return (x > 0.1 && x < 0.4) ? 0.1 : 0.0; },
                [](double x) { return (x > 0.1 && x < 0.4) ? 1.0 : 0.0; });
  const double m0 = dam.mass();
  double worst = 0.0;
  advance(dam, 3.0,
          [&](const DamSolver& d) { worst = std::max(worst, std::abs(d.mass() - m0) / m0); });
  const auto mb = dam.mass_balance();
  std::printf("[measured] closed channel (%s, Minmod, Savage-Hutter K, N=400, %ld steps): max "
              "rel mass change %.1e, ledger defect %.1e, positivity fixes %ld\n",
              name(ts), dam.steps(), worst, mb.defect() / m0, dam.positivity_fixes());
  EXPECT_LT(worst, 1e-13);
  EXPECT_LT(std::abs(mb.defect()) / m0, 1e-13);
  EXPECT_EQ(mb.inflow, 0.0);  // wall fluxes vanish identically (mirrored ghosts)
  EXPECT_EQ(mb.outflow, 0.0);
  }
}

// Inflow (time-dependent) into a dry channel, outflow at the other end: current - initial -
// inflow + outflow must vanish; the same rounding argument relative to the mass throughput
// (~10000 steps) gives ~1e-13 at worst; measured 4-8e-15 for both schemes and time steppings
// (Beam-Warming including ~1000 positivity fixes, which redistribute mass exactly). The inflow
// booked is what enters through the face, dt h u at t + dt/2 (staggered) or the mean of the
// stage times (semi-discrete): against the exact integral 2 (0.15 + 0.004 (1 - cos 15)) m^2 an
// O(dt^2) quadrature error, dt^2 t |f''| / 12 ~ 3e-9 relative at dt ~ 3e-4 s; bound 1e-7.
TEST(DamVerification, MassLedgerClosesWithInflowOutflow) {
  for (TimeStepping ts : kBothTimeSteppings)
  for (Scheme scheme : {Scheme::Minmod, Scheme::BeamWarming}) {
    const auto phys = incline(35.0, 25.0, 35.0, EarthPressure::SavageHutter);
    DamSolver dam(0.0, 1.0, config(400, scheme, EarthPressure::SavageHutter, 0.45, ts), phys,
                  inflow([](double t) {
                    return std::array<double, 2>{0.05 + 0.02 * std::sin(5.0 * t), 2.0};
                  }),
                  boundary(BoundaryType::Outflow));
    dam.set_state([](double) { return 0.0; }, [](double) { return 0.0; });
    double worst = 0.0;
    advance(dam, 3.0, [&](const DamSolver& d) {
      const auto mb = d.mass_balance();
      worst = std::max(worst, std::abs(mb.defect()) / std::max(mb.inflow, 1e-300));
    });
    const auto mb = dam.mass_balance();
    const double in_exact = 2.0 * (0.15 + 0.004 * (1.0 - std::cos(15.0)));
    std::printf("[measured] mass ledger (%s, %s, inflow/outflow, N=400, %ld steps): in %.4f "
                "(rel. to the integral %.1e) out %.4f held %.4f m^2, max |defect|/in %.1e, "
                "positivity fixes %ld\n",
                name(ts), name(scheme), dam.steps(), mb.inflow, mb.inflow / in_exact - 1.0,
                mb.outflow, mb.current, worst, dam.positivity_fixes());
    EXPECT_GT(mb.outflow, 0.5 * mb.inflow);  // the case really exercises both ends
    EXPECT_LT(worst, 1e-13);
    EXPECT_NEAR(mb.inflow / in_exact, 1.0, 1e-7);
  }
}

// =============================================================================================
// 6. Positivity at wet/dry fronts
// =============================================================================================
// Dam break onto a dry bed (wall behind the reservoir) and a block spreading on a slope, both
// with Savage-Hutter K. min h >= 0 after every step is exact (no tolerance): the scheme must
// never leave a negative depth. For Minmod the NT update itself stayed positive (0 fixes
// measured, and now also for Beam-Warming, see below).
// The spreading front must also stay below the physical bound u0 + 2 sqrt(beta(K(0)) h0) + s t
// of a block released with uniform u0 (K(0): the earth pressure coefficient at u_x = 0 inside
// the block; the front itself is spreading, i.e. active, which is smaller). Before the fix of
// the K switch at wet/dry fronts (src/dam/dam_solver.cpp, wet_ux) dry cells counted as u = 0,
// the spreading front was taken as passive and the tip ran at 4.97 m/s > bound 3.79 m/s (dam
// break: 5.11 > 4.27 m/s); after the fix 2.90 and 3.34 m/s. Beam-Warming, the paper's variant
// for smooth supercritical flow, took its unlimited upwind slope also where the depth falls
// steeply to a front (up to 10 times the cell's depth) and in the dry cells ahead of it: its
// fronts needed 692-1960 positivity fixes here and left thin cells running at 28 m/s (spreading
// block, staggered) and 76 / 14.5 m/s (semi-discrete), and the coupled Setup II's 1D tip ran at
// 9-15 m/s (docs/validation.md, "Stability suite"). Now it takes the minmod slope where
// |h'| > h or the cell is dry (dam_solver.cpp, bw_ok): 0 fixes in all eight runs (asserted), the
// staggered fronts 3.75 / 3.36 m/s, below their bounds (asserted, as for Minmod); the
// semi-discrete Beam-Warming fronts 4.71 / 4.16 m/s, 10 % above them (not asserted: its face
// reconstruction of a front cell still has the unlimited slope where |h'| <= h).
TEST(DamVerification, PositivityAtFronts) {
  for (TimeStepping ts : kBothTimeSteppings)
  for (Scheme scheme : {Scheme::Minmod, Scheme::BeamWarming}) {
    for (int which = 0; which < 2; ++which) {
      const auto phys = incline(30.0, 20.0, 30.0, EarthPressure::SavageHutter);
      const double s = net_acceleration(phys), h0 = which == 0 ? 0.2 : 0.1, u0 = 0.5;
      DamSolver dam(0.0, 2.0, config(400, scheme, EarthPressure::SavageHutter, 0.45, ts), phys,
                    boundary(which == 0 ? BoundaryType::Wall : BoundaryType::Outflow),
                    boundary(BoundaryType::Outflow));
      if (which == 0)
        dam.set_state([=](double x) { return x < 0.5 ? h0 : 0.0; }, [](double) { return 0.0; });
      else
        dam.set_state([=](double x) { return (x > 0.3 && x < 0.6) ? h0 : 0.0; },
                      [=](double) { return u0; });
      double hmin = 1e300, umax = 0.0;
      const double t_end = 0.5;
      advance(dam, t_end, [&](const DamSolver& d) {
        hmin = std::min(hmin, min_of(d.h()));
        for (std::size_t k = 0; k < d.h().size(); ++k)
          if (d.h()[k] > 1e-6) umax = std::max(umax, d.hu()[k] / d.h()[k]);
      });
      const double bound =
          (which == 0 ? 0.0 : u0) + 2.0 * std::sqrt(phys.g_cos * phys.K(0.0) * h0) + s * t_end;
      std::printf("[measured] positivity (%s, %s, %s, N=400, %ld steps): min h %.1e, positivity "
                  "fixes %ld, max front speed %.2f m/s (bound %.2f)\n",
                  name(ts), name(scheme), which == 0 ? "dam break on dry bed" : "spreading block",
                  dam.steps(), hmin, dam.positivity_fixes(), umax, bound);
      EXPECT_GE(hmin, 0.0);
      EXPECT_EQ(dam.positivity_fixes(), 0);
      if (scheme == Scheme::Minmod || ts == TimeStepping::Staggered) {
        EXPECT_LT(umax, bound);
      }
    }
  }
}

// =============================================================================================
// 6b. A vacuum that opens at a wall: the Riemann invariants bound the near-dry cells
// =============================================================================================
// A layer h0 = 5 cm leaves a wall at u0 = 10 m/s on a flat frictionless bed (K = 1), faster than
// 2 c0 = 1.40 m/s: a vacuum opens at the wall, bounded by a rarefaction with u - 2c = u0 - 2 c0
// (the exact velocity stays in [u0 - 2 c0, u0] = [8.60, 10] m/s, the vacuum's edge at
// (u0 - 2 c0) t). The wall's mirror is the state (h0, -u0), so the invariant region of the data
// is u + 2c <= u0 + 2 c0 = 11.40 m/s, u - 2c >= -u0 - 2 c0: no cell, however thin, may move
// faster than 11.40 m/s. In the staggered scheme the cells of 1e-6 - 1e-3 m that the smeared
// vacuum leaves at the wall took q / h from two small differences and ran at 20-82 m/s (an
// independent run, 2026-12-05); each new cell thinner than a tenth of the cells it reads now
// takes a velocity inside their invariants (DamSolver::step_once).
// Asserted, at every step:
// - the semi-discrete scheme keeps every cell inside the invariant bound (measured 10.5-11.1
//   m/s at 400 and 800 cells);
// - the staggered scheme leaves it only in a start-up of a fixed number of steps, whose length
//   in time halves with dx (measured: until 7.7 / 3.8 ms at 400 / 800 cells; its deeper cells
//   reach 15.3 m/s there at both resolutions, the self-similar first steps of the reconstructed
//   jump between the layer and its mirror): bounds 10 / 5 ms;
// - no cell thinner than h0/10 runs faster than 1.1 times the fastest deeper cell (measured
//   16.28 against 15.32 m/s; without the bound 198.5 m/s in this test's staggered steps, 82 m/s
//   in the independent run's). The bound limits a thin cell by the cells it reads, not by the
//   data's invariant region, which the staggered start-up leaves (above).
TEST(DamVerification, VacuumAtAWallKeepsTheRiemannInvariants) {
  const auto phys = incline(0.0, 0.0, 30.0, EarthPressure::Isotropic);
  const double h0 = 0.05, u0 = 10.0, c0 = std::sqrt(kG * h0), bound = u0 + 2.0 * c0;
  for (TimeStepping ts : kBothTimeSteppings)
  for (int N : {400, 800}) {
    DamSolver dam(0.0, 2.0, config(N, Scheme::Minmod, EarthPressure::Isotropic, 0.45, ts), phys,
                  boundary(BoundaryType::Wall), boundary(BoundaryType::Outflow));
    dam.set_state([=](double x) { return x < 0.5 ? h0 : 0.0; }, [=](double) { return u0; });
    double thin = 0.0, wet = 0.0;  // fastest cell below / above a tenth of h0, over all steps
    double last_above = 0.0;
    advance(dam, 0.05, [&](const DamSolver& d) {
      for (std::size_t k = 0; k < d.h().size(); ++k)
        if (d.h()[k] > 1e-6 && std::abs(d.hu()[k] / d.h()[k]) > bound) last_above = d.time();
      for (std::size_t k = 0; k < d.h().size(); ++k) {
        if (d.h()[k] <= 1e-6) continue;
        const double u = std::abs(d.hu()[k] / d.h()[k]);
        (d.h()[k] < 0.1 * h0 ? thin : wet) = std::max(d.h()[k] < 0.1 * h0 ? thin : wet, u);
      }
    });
    std::printf("[measured] vacuum at a wall (%s, N=%d, %ld steps): fastest cell thinner than "
                "h0/10 %.2f m/s, deeper %.2f m/s; invariant bound %.2f m/s; %ld bounded; last above "
                "the bound at %.4f s\n",
                name(ts), N, dam.steps(), thin, wet, bound, dam.thin_velocity_bounds(), last_above);
    if (ts == TimeStepping::SemiDiscrete) {
      EXPECT_LE(std::max(thin, wet), bound) << "N = " << N;
    } else {
      EXPECT_LE(last_above, N == 400 ? 0.010 : 0.005) << "N = " << N;
      EXPECT_GT(dam.thin_velocity_bounds(), 0);
    }
    EXPECT_LE(thin, 1.1 * wet) << name(ts) << ", N = " << N;
  }
}

// =============================================================================================
// 7. Observed order of convergence on smooth periodic data
// =============================================================================================
// h = h0 (1 + a sin(2 pi x / L)), u = u0 on a periodic incline (s > 0, u > 0 throughout so the
// friction sign is fixed), K = 1. Characteristics u +- sqrt(beta h) steepen the profile into
// shocks only after ~1 s; we stop at t = 0.3 s. Error: L1 of cell averages against a run with
// N = 6400 averaged onto the coarse cells, all runs ending on the primary grid after an even
// number of equal steps with dt / dx fixed (Courant number ~0.23).
std::vector<double> sine_run(int N, Scheme scheme, double t_end, double dt_per_dx,
                             TimeStepping ts) {
  const auto phys = incline(30.0, 20.0, 30.0, EarthPressure::Isotropic);
  const double h0 = 0.1, a = 0.2, u0 = 1.0, L = 1.0;
  DamSolver dam(0.0, L, config(N, scheme, EarthPressure::Isotropic, 0.45, ts), phys,
                boundary(BoundaryType::Periodic), boundary(BoundaryType::Periodic));
  dam.set_state(
      [=](double x) { return h0 * (1.0 + a * std::sin(2.0 * granflow::core::kPi * x / L)); },
      [=](double) { return u0; });
  advance_even(dam, t_end, dt_per_dx * dam.dx());
  return dam.h();
}

TEST(DamVerification, ObservedOrderSmoothPeriodic) {
  const double t_end = 0.3, dt_per_dx = 0.1;  // max |u| + c ~ 2.3 m/s -> Courant ~ 0.23
  for (TimeStepping ts : kBothTimeSteppings)
  for (Scheme scheme : {Scheme::Minmod, Scheme::BeamWarming}) {
    // the semi-discrete runs (two stages per step) stop at N = 400 with a reference at 3200
    const bool stag = ts == TimeStepping::Staggered;
    const int Nref = stag ? 6400 : 3200;
    const std::vector<int> Ns = stag ? std::vector<int>{50, 100, 200, 400, 800}
                                     : std::vector<int>{50, 100, 200, 400};
    const auto href = sine_run(Nref, scheme, t_end, dt_per_dx, ts);
    std::vector<double> err;
    for (int N : Ns) {
      const auto h = sine_run(N, scheme, t_end, dt_per_dx, ts);
      const int r = Nref / N;
      double e = 0.0;
      for (int j = 0; j < N; ++j) {
        double avg = 0.0;
        for (int k = 0; k < r; ++k) avg += href[static_cast<std::size_t>(j * r + k)];
        e += std::abs(h[static_cast<std::size_t>(j)] - avg / r) / N;  // L1 over L = 1 m
      }
      err.push_back(e);
    }
    std::printf("[measured] observed order (%s, %s, smooth periodic, t=0.3 s): L1(h) [m]",
                name(ts), name(scheme));
    for (std::size_t i = 0; i < Ns.size(); ++i) std::printf(" N=%d %.3e", Ns[i], err[i]);
    std::printf("; orders");
    for (std::size_t i = 1; i < Ns.size(); ++i) std::printf(" %.2f", std::log2(err[i - 1] / err[i]));
    std::printf("\n");
    // Measured orders: Minmod 1.61 1.80 1.93 2.00 (the limiter clips the extrema, which costs
    // accuracy on coarse grids: the usual approach to 2 from below); Beam-Warming 1.97 1.99
    // 2.00 2.02. The reference error (N = 6400) is < 2 % of the N = 800 error for either.
    // Semi-discrete (reference 3200): Minmod 1.27 1.71 1.91, Beam-Warming 2.01 2.01 2.01.
    // Asserted bounds sit ~0.2-0.4 below the measured orders on the finer pairs (from N = 200).
    const double lo = scheme == Scheme::Minmod ? 1.5 : 1.8;
    for (std::size_t i = 2; i < Ns.size(); ++i)
      EXPECT_GT(std::log2(err[i - 1] / err[i]), lo) << name(scheme) << " N=" << Ns[i];
    // Error level at N = 400 (measured Minmod 5.2e-6, Beam-Warming 1.27e-6 staggered; 5.7e-6
    // and 1.44e-6 semi-discrete), bounds ~1.5x.
    EXPECT_LT(err[3], scheme == Scheme::Minmod ? 8.5e-6 : 2.1e-6);
  }
}

// =============================================================================================
// 8. Material on a slope gentler than delta decelerates, stops and stays
// =============================================================================================
// zeta = 20 deg < delta = 30 deg: s = g cos(zeta)(tan zeta - tan delta) < 0 while u > 0, and
// at rest |g sin zeta| < g cos zeta tan delta, so the bounded friction impulse holds the
// material. A uniform layer stops at t_stop = u0 / |s| exactly; after that hu must be exactly
// 0 (the friction impulse clips |hu| to 0, no residue) and h bitwise unchanged.
TEST(DamVerification, UniformLayerStopsAndStays) {
  for (TimeStepping ts : kBothTimeSteppings) {
  const auto phys = incline(20.0, 30.0, 35.0, EarthPressure::SavageHutter);
  const double s = net_acceleration(phys), u0 = 1.0, h0 = 0.1;
  ASSERT_LT(s, 0.0);
  const double t_stop = u0 / -s;
  DamSolver dam(0.0, 1.0, config(100, Scheme::Minmod, EarthPressure::SavageHutter, 0.45, ts), phys,
                boundary(BoundaryType::Periodic), boundary(BoundaryType::Periodic));
  dam.set_state([=](double) { return h0; }, [=](double) { return u0; });
  double worst = 0.0;
  advance(dam, 0.99 * t_stop, [&](const DamSolver& d) {
    for (std::size_t k = 0; k < d.h().size(); ++k)
      worst = std::max(worst, std::abs(d.hu()[k] / d.h()[k] - (u0 + s * d.time())));
  });
  EXPECT_LT(worst, 1e-13);  // deceleration at s, as in case 1 (measured 7.8e-16 m/s)
  EXPECT_GT(min_of(dam.hu()), 0.0);  // still moving just before t_stop
  advance(dam, 1.01 * t_stop);
  const auto h_a = dam.h();
  long moving = 0;
  advance(dam, 3.0 * t_stop, [&](const DamSolver& d) {
    for (double v : d.hu()) moving += v != 0.0;
  });
  for (double v : dam.hu()) EXPECT_EQ(v, 0.0);
  EXPECT_EQ(moving, 0);
  if (dam.staggered()) advance(dam, dam.time() + 0.5 * dam.stable_dt());
  for (std::size_t k = 0; k < h_a.size(); ++k) EXPECT_EQ(dam.h()[k], h_a[k]);
  std::printf("[measured] uniform layer stops (%s, zeta 20, delta 30 deg): t_stop %.4f s, |u - "
              "(u0 + s t)| before %.1e m/s, hu after: exactly 0 in every step, h bitwise "
              "unchanged\n",
              name(ts), t_stop, worst);
  }
}

// A block (h0 = 0.1 m, u0 = 1 m/s) on zeta = 10 deg < delta = 30 deg, constant K (Active):
// the block spreads (pressure) while it decelerates. All motion ended at 2.8 t_stop (measured,
// N = 400), the last material to stop being the front relaxing to the critical slope
// K h_x = tan(zeta) - tan(delta). We require hu == 0 exactly at every step from 6 t_stop to
// 40 t_stop (margin 2x on the stop time) and the mass conserved to round-off.
// h is NOT unchanged at rest: the staggered averaging of the minmod reconstruction diffuses the
// deposit's crest and margins even with u == 0 (the two half-steps are exact averages of a
// reconstruction that the limiter has flattened at extrema and kinks). Measured: the crest
// changes by up to 6.1e-3 m (h max 0.065 m) over 34 t_stop (8.8 s) at N = 400, at a rate that
// does not fall with dx (4.7e-4 m/s at N = 200, 4.6e-4 m/s at N = 400 over the first ~10 s).
// Reported as a limitation of the scheme; the bound below (measured x 1.5) guards against it
// getting worse.
TEST(DamVerification, BlockStopsAndStays) {
  for (TimeStepping ts : kBothTimeSteppings) {
  const auto phys = incline(10.0, 30.0, 35.0, EarthPressure::Active);
  const double s = net_acceleration(phys), u0 = 1.0, h0 = 0.1;
  const double t_stop = u0 / -s;
  DamSolver dam(0.0, 4.0, config(400, Scheme::Minmod, EarthPressure::Active, 0.45, ts), phys,
                boundary(BoundaryType::Outflow), boundary(BoundaryType::Outflow));
  dam.set_state([=](double x) { return (x > 0.3 && x < 0.6) ? h0 : 0.0; },
                [=](double x) { return (x > 0.3 && x < 0.6) ? u0 : 0.0; });
  double t_last = 0.0;
  advance(dam, 6.0 * t_stop, [&](const DamSolver& d) {
    for (double v : d.hu())
      if (v != 0.0) t_last = d.time();
  });
  if (dam.staggered()) advance(dam, dam.time() + 0.5 * dam.stable_dt());
  auto centre = [&]() {
    double m = 0.0, mx = 0.0;
    const auto x = dam.centres();
    for (std::size_t k = 0; k < x.size(); ++k) {
      m += dam.h()[k];
      mx += dam.h()[k] * x[k];
    }
    return mx / m;
  };
  const auto h_a = dam.h();
  const double xc_a = centre(), m_a = dam.mass(), t_a = dam.time();
  long moving = 0;
  advance(dam, 40.0 * t_stop, [&](const DamSolver& d) {
    for (double v : d.hu()) moving += v != 0.0;
  });
  if (dam.staggered()) advance(dam, dam.time() + 0.5 * dam.stable_dt());
  double dh = 0.0, hmax = 0.0;
  for (std::size_t k = 0; k < h_a.size(); ++k) {
    dh = std::max(dh, std::abs(dam.h()[k] - h_a[k]));
    hmax = std::max(hmax, h_a[k]);
  }
  std::printf("[measured] block stops (%s, Active K, zeta 10, delta 30 deg, N=400): t_stop %.3f s, "
              "last motion %.3f s (%.2f t_stop), moving cell-steps after 6 t_stop: %ld, mass "
              "centre shift %.1e m, rel. mass change %.1e, at-rest change of h over %.1f s: %.2e m "
              "(h max %.3f m)\n",
              name(ts), t_stop, t_last, t_last / t_stop, moving, centre() - xc_a, dam.mass() / m_a - 1.0,
              dam.time() - t_a, dh, hmax);
  EXPECT_LT(t_last, 6.0 * t_stop);
  EXPECT_EQ(moving, 0);
  for (double v : dam.hu()) EXPECT_EQ(v, 0.0);
  EXPECT_NEAR(dam.mass() / m_a, 1.0, 1e-13);  // closed to round-off as in case 5
  // The at-rest smoothing also shifts the mass centre of the asymmetric deposit (measured
  // -1.1e-3 m = 0.11 dx over 8.8 s) while u == 0; bound 2e-3 m (x 1.9).
  EXPECT_LT(std::abs(centre() - xc_a), 2e-3);
  EXPECT_LT(dh, 9e-3);  // measured 6.1e-3 m
  }
}

// Savage-Hutter K (active where the flow spreads, passive where it contracts): a block
// (h0 = 0.1 m, u0 = 1 m/s) on zeta = 20 deg < delta = 30 deg, phi = 35 deg. Before the fix it
// never stopped: a period-3 pattern of moving and resting cells formed in the deposit, cell K
// alternated between K_act and K_pas, and the jump of beta_j h_j^2 / 2 between the cells' own
// fluxes was a force ~4x the friction (u ~ 0.1-0.17 m/s at 10-40 t_stop, N = 400). Now K is
// held fixed inside each cell an update integrates over, and material at rest may take any K
// in [K_act, K_pas] (src/dam/dam_solver.cpp, step()). Measured: all motion ends at 2.84 / 2.77
// / 2.85 t_stop (N = 200 / 400 / 800), and the deposit is then at rest in every step. Asserted:
// the last motion before 6 t_stop (margin 2x), hu == 0 exactly in every step from 6 t_stop to
// 40 t_stop (the bounded friction leaves no residue), the mass to round-off (as in case 5), the
// stop time within 10 % between N = 200 and 400 (measured 2.5 %; semi-discrete 2.77 / 2.81
// t_stop, 1.5 %), and the deposit statically
// admissible: between every two wet cells (h > 1 mm) some K in [K_act, K_pas] satisfies
// |tan(zeta) - K h_x| <= tan(delta) (measured: with a margin of 0.13 / 0.095 in tan units,
// N = 200 / 400).
struct ShBlock {
  double t_stop = 0.0, t_last = 0.0;
  long moving_late = 0;
  double mass_change = 0.0, worst_excess = -1e300, dh_rest = 0.0;  // excess: max over pairs
  int pairs = 0;
};

ShBlock sh_block(int cells, TimeStepping ts) {
  const auto phys = incline(20.0, 30.0, 35.0, EarthPressure::SavageHutter);
  const double s = net_acceleration(phys), u0 = 1.0, h0 = 0.1;
  ShBlock r;
  r.t_stop = u0 / -s;
  DamSolver dam(0.0, 4.0, config(cells, Scheme::Minmod, EarthPressure::SavageHutter, 0.45, ts),
                phys,
                boundary(BoundaryType::Outflow), boundary(BoundaryType::Outflow));
  dam.set_state([=](double x) { return (x > 0.3 && x < 0.6) ? h0 : 0.0; },
                [=](double x) { return (x > 0.3 && x < 0.6) ? u0 : 0.0; });
  const double m0 = dam.mass();
  advance(dam, 6.0 * r.t_stop, [&](const DamSolver& d) {
    for (double v : d.hu())
      if (v != 0.0) r.t_last = d.time();
  });
  if (dam.staggered()) advance(dam, dam.time() + 0.5 * dam.stable_dt());
  const auto h_a = dam.h();
  advance(dam, 40.0 * r.t_stop, [&](const DamSolver& d) {
    for (double v : d.hu()) r.moving_late += v != 0.0;
  });
  if (dam.staggered()) advance(dam, dam.time() + 0.5 * dam.stable_dt());
  r.mass_change = dam.mass() / m0 - 1.0;
  for (std::size_t k = 0; k < h_a.size(); ++k)
    r.dh_rest = std::max(r.dh_rest, std::abs(dam.h()[k] - h_a[k]));
  const double tz = phys.g_sin / phys.g_cos;
  for (std::size_t k = 0; k + 1 < dam.h().size(); ++k) {
    const double a = dam.h()[k], b = dam.h()[k + 1];
    if (a < 1e-3 || b < 1e-3) continue;
    const double hx = (b - a) / dam.dx();
    const double v1 = tz - phys.K_act * hx, v2 = tz - phys.K_pas * hx;
    const double vmin = v1 * v2 <= 0.0 ? 0.0 : std::min(std::abs(v1), std::abs(v2));
    r.worst_excess = std::max(r.worst_excess, vmin - phys.tan_delta);
    ++r.pairs;
  }
  std::printf("[measured] Savage-Hutter block stops (%s, zeta 20, delta 30, phi 35 deg, N=%d): t_stop "
              "%.3f s, last motion %.3f s (%.2f t_stop), moving cell-steps 6-40 t_stop: %ld, rel. "
              "mass change %.1e, rest criterion on %d wet pairs: max(min_K |tan zeta - K h_x| - "
              "tan delta) %.2e, at-rest "
              "change of h %.2e m\n",
              name(ts), cells, r.t_stop, r.t_last, r.t_last / r.t_stop, r.moving_late, r.mass_change,
              r.pairs, r.worst_excess, r.dh_rest);
  return r;
}

TEST(DamVerification, SavageHutterBlockStops) {
  for (TimeStepping ts : kBothTimeSteppings) {
  const auto a = sh_block(200, ts), b = sh_block(400, ts);
  for (const auto& r : {a, b}) {
    EXPECT_LT(r.t_last, 6.0 * r.t_stop);
    EXPECT_EQ(r.moving_late, 0);
    EXPECT_NEAR(r.mass_change, 0.0, 1e-13);
    EXPECT_GT(r.pairs, 50);
    EXPECT_LE(r.worst_excess, 0.0);
  }
  EXPECT_NEAR(a.t_last / b.t_last, 1.0, 0.1);
  }
}

}  // namespace

// =============================================================================================
// The initial state: exact cell averages of piecewise-constant data
// =============================================================================================
// A Block's ends and a Dam break's position are the jumps of the initial data; set_state
// integrates each cell piece by piece between them, so the mass and momentum of the initial
// state are depth x length and depth x velocity x length to round-off wherever the jumps lie
// (an independent run, 2026-12-05: a Block [0.2, 0.203] m in 10 mm cells held 42 % too little
// mass, [0.2, 0.257] m 2.2 % too much, as 4 Gauss points per cell straddled the jump).
// Tolerance 1e-14 relative: the sum of 100 cell values of about 1e-3 m (a few ulps each).
TEST(DamInitialCondition, PiecewiseConstantDataHaveExactMass) {
  granflow::core::Channel ch;
  ch.length = 1.0;
  const auto phys = incline(30.0, 20.0, 30.0, EarthPressure::SavageHutter);
  DamSolver dam(0.0, 1.0, config(100, Scheme::Minmod, EarthPressure::SavageHutter), phys,
                boundary(BoundaryType::Wall), boundary(BoundaryType::Wall));
  auto momentum = [&]() {
    double m = 0.0;
    for (double v : dam.hu()) m += v;
    return m * 0.01;
  };
  for (const auto& ab : {std::array<double, 2>{0.2, 0.203}, {0.2, 0.253}, {0.2, 0.257},
                         {0.2051, 0.3049}, {0.2, 0.3}, {0.0, 1.0}}) {
    InitialCondition ic;
    ic.type = InitialCondition::Type::Block;
    ic.depth = 0.05;
    ic.velocity = 0.8;
    ic.start = ab[0];
    ic.end = ab[1];
    ic.apply(ch, dam);
    const double exact = 0.05 * (ab[1] - ab[0]);
    EXPECT_NEAR(dam.mass(), exact, 1e-14 * exact) << "block [" << ab[0] << ", " << ab[1] << "]";
    EXPECT_NEAR(momentum(), 0.8 * exact, 1e-14 * exact) << "block [" << ab[0] << ", " << ab[1] << "]";
  }
  for (double x0 : {0.4137, 0.5, 0.00049}) {
    InitialCondition ic;
    ic.type = InitialCondition::Type::DamBreak;
    ic.left_depth = 0.1;
    ic.right_depth = 0.02;
    ic.position = x0;
    ic.apply(ch, dam);
    const double exact = 0.1 * x0 + 0.02 * (1.0 - x0);
    EXPECT_NEAR(dam.mass(), exact, 1e-14 * exact) << "dam break at " << x0;
  }
}
