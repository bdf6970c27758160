// DAM verification (DESIGN.md section 7, issue 2 point 6): analytic solutions, conservation,
// positivity and observed order of convergence of the NOC scheme in src/dam/dam_solver.cpp.
#include "dam_test_util.hpp"

#include <cstdio>

using namespace granflow::dam;
using namespace granflow::dam::testing;

namespace {

// =============================================================================================
// 1. Uniform layer on a periodic incline
// =============================================================================================
TEST(DamVerification, UniformLayerAcceleratesAtS) {
  for (Scheme scheme : {Scheme::Minmod, Scheme::BeamWarming}) {
    const auto phys = incline(35.0, 20.0, 30.0, EarthPressure::SavageHutter);
    const double s = net_acceleration(phys), h0 = 0.1, u0 = 0.5;
    DamSolver dam(0.0, 1.0, config(100, scheme, EarthPressure::SavageHutter), phys,
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
    std::printf("[measured] uniform layer (%s): steps %ld, max rel err h %.3e, u %.3e\n",
                scheme == Scheme::Minmod ? "Minmod" : "Beam-Warming", dam.steps(), worst_h,
                worst_u);
    EXPECT_LT(worst_h, 1e-14);
    EXPECT_LT(worst_u, 1e-12);
  }
}

// =============================================================================================
// 2. Dam break on an incline against the Ritter solution in the accelerating frame
// =============================================================================================
struct RitterResult {
  double l1 = 0.0, l1_rel = 0.0;
  long fixes = 0;
};

RitterResult ritter_run(int cells, Scheme scheme) {
  const auto phys = incline(35.0, 25.0, 35.0, EarthPressure::Active);
  const double s = net_acceleration(phys), beta = phys.g_cos * phys.K_act;
  const double h0 = 0.1, xd = 1.0, a = 0.0, b = 3.0, t_end = 0.5;
  const double c0 = std::sqrt(beta * h0);
  // Left end: the undisturbed reservoir (h0, u = s t) enters; it stays undisturbed there while
  // the rarefaction tail xd - c0 t + s t^2/2 > 0.
  DamSolver dam(a, b, config(cells, scheme, EarthPressure::Active), phys,
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
  for (int j = 0; j < cells; ++j) {
    r.l1 += std::abs(h[static_cast<std::size_t>(j)] - hex[static_cast<std::size_t>(j)]) * dam.dx();
    m += hex[static_cast<std::size_t>(j)] * dam.dx();
  }
  r.l1_rel = r.l1 / m;
  r.fixes = dam.positivity_fixes();
  return r;
}

TEST(DamVerification, RitterDamBreakOnIncline) {
  for (Scheme scheme : {Scheme::Minmod}) {
    const auto r1 = ritter_run(150, scheme), r2 = ritter_run(300, scheme),
               r3 = ritter_run(600, scheme);
    std::printf("[measured] Ritter: L1(h) N=150 %.4e (rel %.3e), N=300 %.4e (rel %.3e), N=600 "
                "%.4e (rel %.3e), orders %.2f %.2f\n",
                r1.l1, r1.l1_rel, r2.l1, r2.l1_rel, r3.l1, r3.l1_rel, std::log2(r1.l1 / r2.l1),
                std::log2(r2.l1 / r3.l1));
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
  double h1 = h0 + u0 * std::sqrt(h0 / beta) + 0.5 * h0;  // above h0: the compressive root
  for (int it = 0; it < 50; ++it) {
    const double F = 0.5 * beta * (h1 - h0) * (h1 - h0) * (h1 + h0) - h0 * u0 * u0 * h1;
    const double dF = beta * (h1 - h0) * (h1 + h0) + 0.5 * beta * (h1 - h0) * (h1 - h0) -
                      h0 * u0 * u0;
    h1 -= F / dF;
  }
  return h1;
}

TEST(DamVerification, WallShockRankineHugoniot) {
  const auto phys = incline(0.0, 0.0, 30.0, EarthPressure::Isotropic);
  const double beta = phys.g_cos, h0 = 0.1, u0 = 1.0, L = 2.0;
  const double h1 = rh_depth(h0, u0, beta), S = -h0 * u0 / (h1 - h0);
  const int N = 400;
  DamSolver dam(0.0, L, config(N, Scheme::Minmod, EarthPressure::Isotropic), phys, inflow(h0, u0),
                boundary(BoundaryType::Wall));
  dam.set_state([=](double) { return h0; }, [=](double) { return u0; });
  // Shock position: where the primary-grid depth crosses (h0 + h1)/2 (linear interpolation).
  auto shock_at = [&](double& plateau_h, double& plateau_u) {
    std::vector<double> h, hu;
    dam.primary(h, hu);
    const double mid = 0.5 * (h0 + h1);
    double xs = L;
    for (int j = N - 1; j > 0; --j) {
      const auto k = static_cast<std::size_t>(j);
      if (h[k - 1] < mid && h[k] >= mid) {
        xs = dam.dx() * (j - 0.5 + (mid - h[k - 1]) / (h[k] - h[k - 1]));
        break;
      }
    }
    // plateau: the middle half between shock and wall
    double sh = 0.0, su = 0.0;
    int n = 0;
    for (int j = 0; j < N; ++j) {
      const double x = (j + 0.5) * dam.dx();
      if (x > xs + 0.25 * (L - xs) && x < L - 0.25 * (L - xs)) {
        sh += h[static_cast<std::size_t>(j)];
        su += hu[static_cast<std::size_t>(j)] / h[static_cast<std::size_t>(j)];
        ++n;
      }
    }
    plateau_h = sh / n;
    plateau_u = su / n;
    return xs;
  };
  double ph1, pu1, ph2, pu2;
  advance(dam, 0.6);
  const double x1 = shock_at(ph1, pu1);
  advance(dam, 1.4);
  const double x2 = shock_at(ph2, pu2);
  const double S_num = (x2 - x1) / 0.8;
  std::printf("[measured] RH: h1 exact %.6f, plateau %.6f (rel %.2e) / %.6f (rel %.2e), u %.2e "
              "%.2e; S exact %.6f, measured %.6f (rel %.2e), x1 %.4f x2 %.4f\n",
              h1, ph1, ph1 / h1 - 1, ph2, ph2 / h1 - 1, pu1, pu2, S, S_num, S_num / S - 1, x1, x2);
}

// =============================================================================================
// 4. Steady supercritical profile: h u = q, u^2/2 + beta q/u = E0 + s x
// =============================================================================================
TEST(DamVerification, SteadySupercriticalProfile) {
  for (Scheme scheme : {Scheme::Minmod, Scheme::BeamWarming}) {
    for (int N : {100, 200}) {
      const auto phys = incline(35.0, 25.0, 35.0, EarthPressure::Active);
      const double s = net_acceleration(phys), beta = phys.g_cos * phys.K_act;
      const double hin = 0.05, uin = 2.0, q = hin * uin, L = 2.0;
      const double E0 = 0.5 * uin * uin + beta * q / uin;
      DamSolver dam(0.0, L, config(N, scheme, EarthPressure::Active), phys, inflow(hin, uin),
                    boundary(BoundaryType::Outflow));
      dam.set_state([=](double) { return hin; }, [=](double) { return uin; });
      advance(dam, 4.0);
      if (dam.staggered()) advance(dam, dam.time() + 0.5 * dam.stable_dt());
      // u(x) from the algebraic relation by Newton (supercritical branch: u^3 > beta q)
      auto u_exact = [&](double x) {
        double u = std::sqrt(uin * uin + 2.0 * s * x);
        for (int it = 0; it < 50; ++it) {
          const double F = 0.5 * u * u + beta * q / u - E0 - s * x;
          u -= F / (u - beta * q / (u * u));
        }
        return u;
      };
      double eq = 0.0, eu = 0.0, Emin = 1e300, Emax = -1e300, fr = 1e300;
      for (int j = 0; j < N; ++j) {
        const auto k = static_cast<std::size_t>(j);
        const double x = (j + 0.5) * dam.dx(), u = dam.hu()[k] / dam.h()[k];
        eq = std::max(eq, std::abs(dam.hu()[k] - q) / q);
        eu = std::max(eu, std::abs(u - u_exact(x)) / u_exact(x));
        const double E = 0.5 * u * u + beta * q / u - s * x;
        Emin = std::min(Emin, E);
        Emax = std::max(Emax, E);
        fr = std::min(fr, u / std::sqrt(beta * dam.h()[k]));
      }
      std::printf("[measured] steady (%s, N=%d): max rel |hu-q| %.3e, max rel |u-u_ex| %.3e, "
                  "spread of E - s x %.3e (rel %.3e), min Fr %.2f\n",
                  scheme == Scheme::Minmod ? "Minmod" : "BW", N, eq, eu, Emax - Emin,
                  (Emax - Emin) / E0, fr);
    }
  }
}

// =============================================================================================
// 5. Mass conservation: closed channel; ledger with inflow and outflow
// =============================================================================================
TEST(DamVerification, MassConservedInClosedChannel) {
  const auto phys = incline(35.0, 25.0, 35.0, EarthPressure::SavageHutter);
  DamSolver dam(0.0, 1.0, config(400, Scheme::Minmod, EarthPressure::SavageHutter), phys,
                boundary(BoundaryType::Wall), boundary(BoundaryType::Wall));
  dam.set_state([](double x) { return (x > 0.1 && x < 0.4) ? 0.1 : 0.0; },
                [](double) { return 1.0; });
  const double m0 = dam.mass();
  double worst = 0.0;
  advance(dam, 3.0, [&](const DamSolver& d) {
    worst = std::max(worst, std::abs(d.mass() - m0) / m0);
  });
  const auto mb = dam.mass_balance();
  std::printf("[measured] closed channel: steps %ld, max rel mass change %.3e, defect %.3e, "
              "in %.3e out %.3e, fixes %ld\n",
              dam.steps(), worst, mb.defect() / m0, mb.inflow, mb.outflow,
              dam.positivity_fixes());
}

TEST(DamVerification, MassLedgerClosesWithInflowOutflow) {
  for (Scheme scheme : {Scheme::Minmod, Scheme::BeamWarming}) {
    const auto phys = incline(35.0, 25.0, 35.0, EarthPressure::SavageHutter);
    DamSolver dam(0.0, 1.0, config(400, scheme, EarthPressure::SavageHutter), phys,
                  inflow([](double t) { return std::array<double, 2>{0.05 + 0.02 * std::sin(5 * t), 2.0}; }),
                  boundary(BoundaryType::Outflow));
    dam.set_state([](double) { return 0.0; }, [](double) { return 0.0; });
    double worst = 0.0;
    advance(dam, 3.0, [&](const DamSolver& d) {
      const auto mb = d.mass_balance();
      worst = std::max(worst, std::abs(mb.defect()) / std::max(mb.inflow, 1e-300));
    });
    const auto mb = dam.mass_balance();
    std::printf("[measured] ledger (%s): steps %ld, in %.5f out %.5f now %.5f, max |defect|/in "
                "%.3e, fixes %ld\n",
                scheme == Scheme::Minmod ? "Minmod" : "BW", dam.steps(), mb.inflow, mb.outflow,
                mb.current, worst, dam.positivity_fixes());
  }
}

// =============================================================================================
// 6. Positivity at wet/dry fronts
// =============================================================================================
TEST(DamVerification, PositivityAtFronts) {
  for (Scheme scheme : {Scheme::Minmod, Scheme::BeamWarming}) {
    for (int which = 0; which < 2; ++which) {
      const auto phys = incline(30.0, 20.0, 30.0, EarthPressure::SavageHutter);
      DamSolver dam(0.0, 2.0, config(400, scheme, EarthPressure::SavageHutter), phys,
                    boundary(which == 0 ? BoundaryType::Wall : BoundaryType::Outflow),
                    boundary(BoundaryType::Outflow));
      if (which == 0)
        dam.set_state([](double x) { return x < 0.5 ? 0.2 : 0.0; }, [](double) { return 0.0; });
      else
        dam.set_state([](double x) { return (x > 0.3 && x < 0.6) ? 0.1 : 0.0; },
                      [](double) { return 0.5; });
      double hmin = 1e300;
      advance(dam, 0.5, [&](const DamSolver& d) { hmin = std::min(hmin, min_of(d.h())); });
      std::printf("[measured] positivity (%s, %s): steps %ld, min h %.3e, fixes %ld\n",
                  scheme == Scheme::Minmod ? "Minmod" : "BW", which == 0 ? "dam break" : "block",
                  dam.steps(), hmin, dam.positivity_fixes());
    }
  }
}

// =============================================================================================
// 7. Observed order of convergence on smooth periodic data
// =============================================================================================
std::vector<double> sine_run(int N, Scheme scheme, double t_end, double dt_per_dx) {
  const auto phys = incline(30.0, 20.0, 30.0, EarthPressure::Isotropic);
  const double h0 = 0.1, a = 0.2, u0 = 1.0, L = 1.0;
  DamSolver dam(0.0, L, config(N, scheme, EarthPressure::Isotropic), phys,
                boundary(BoundaryType::Periodic), boundary(BoundaryType::Periodic));
  dam.set_state([=](double x) { return h0 * (1.0 + a * std::sin(2.0 * granflow::core::kPi * x / L)); },
                [=](double) { return u0; });
  advance_even(dam, t_end, dt_per_dx * dam.dx());
  std::vector<double> h = dam.h();
  return h;
}

TEST(DamVerification, ObservedOrderSmoothPeriodic) {
  const double t_end = 0.3, dt_per_dx = 0.1;  // max speed ~ 1 + 0.3*t*? + 1.1 -> CFL ~ 0.25
  for (Scheme scheme : {Scheme::Minmod, Scheme::BeamWarming}) {
    const int Nref = 6400;
    const auto href = sine_run(Nref, scheme, t_end, dt_per_dx);
    double prev = 0.0;
    for (int N : {50, 100, 200, 400, 800}) {
      const auto h = sine_run(N, scheme, t_end, dt_per_dx);
      const int r = Nref / N;
      double e = 0.0;
      for (int j = 0; j < N; ++j) {
        double avg = 0.0;
        for (int k = 0; k < r; ++k) avg += href[static_cast<std::size_t>(j * r + k)];
        e += std::abs(h[static_cast<std::size_t>(j)] - avg / r) / N;
      }
      std::printf("[measured] order (%s): N=%d L1 %.4e order %.3f\n",
                  scheme == Scheme::Minmod ? "Minmod" : "BW", N, e,
                  prev > 0 ? std::log2(prev / e) : 0.0);
      prev = e;
    }
  }
}

// =============================================================================================
// 8. Material on a slope gentler than delta decelerates, stops and stays
// =============================================================================================
TEST(DamVerification, StopsAndStaysBelowFrictionAngle) {
  const auto phys = incline(20.0, 30.0, 35.0, EarthPressure::SavageHutter);
  const double s = net_acceleration(phys), u0 = 1.0, h0 = 0.1;
  const double t_stop = u0 / -s;
  {
    DamSolver dam(0.0, 1.0, config(100, Scheme::Minmod, EarthPressure::SavageHutter), phys,
                  boundary(BoundaryType::Periodic), boundary(BoundaryType::Periodic));
    dam.set_state([=](double) { return h0; }, [=](double) { return u0; });
    double worst = 0.0;
    advance(dam, 0.9 * t_stop, [&](const DamSolver& d) {
      for (std::size_t k = 0; k < d.h().size(); ++k)
        worst = std::max(worst, std::abs(d.hu()[k] / d.h()[k] - (u0 + s * d.time())));
    });
    advance(dam, 1.01 * t_stop);
    std::vector<double> h1 = dam.h(), hu1 = dam.hu();
    std::printf("[measured] stop (uniform): t_stop %.4f, max |u - u_ex| before %.3e, max hu after %.3e\n",
                t_stop, worst, *std::max_element(hu1.begin(), hu1.end()));
  }
  {
    DamSolver dam(0.0, 2.0, config(400, Scheme::Minmod, EarthPressure::SavageHutter), phys,
                  boundary(BoundaryType::Outflow), boundary(BoundaryType::Outflow));
    dam.set_state([=](double x) { return (x > 0.3 && x < 0.6) ? h0 : 0.0; },
                  [=](double x) { return (x > 0.3 && x < 0.6) ? u0 : 0.0; });
    double t_last_motion = 0.0;
    advance(dam, 10.0 * t_stop, [&](const DamSolver& d) {
      for (double v : d.hu())
        if (v != 0.0) t_last_motion = d.time();
    });
    std::vector<double> ha, hua, hb, hub;
    dam.primary(ha, hua);
    const double m_a = dam.mass();
    advance(dam, 20.0 * t_stop);
    dam.primary(hb, hub);
    double dh = 0.0, hmax = 0.0, xf = 0.0;
    for (std::size_t k = 0; k < ha.size(); ++k) {
      dh = std::max(dh, std::abs(ha[k] - hb[k]));
      hmax = std::max(hmax, ha[k]);
      if (ha[k] > 1e-6) xf = (k + 0.5) * dam.dx();
    }
    std::printf("[measured] stop (block): t_stop %.4f, last motion %.4f, max|dh| %.3e (hmax %.3e), front %.3f, mass %.6e -> %.6e, fixes %ld\n",
                t_stop, t_last_motion, dh, hmax, xf, m_a, dam.mass(), dam.positivity_fixes());
  }
}

}  // namespace
