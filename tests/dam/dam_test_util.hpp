#pragma once
// Helpers shared by the DAM verification tests: build a DamSolver from angles, advance it with
// the Stepper protocol (dt = min(stable_dt, t_end - t); step; check; accept), and compare cell
// averages.
#include "granflow/core/material.hpp"
#include "granflow/dam/dam_solver.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <vector>

namespace granflow::dam::testing {

using core::BoundaryType;
constexpr double kG = 9.81;

/// Physics of an incline with slope zeta, bed friction delta and internal friction phi [deg].
inline DamPhysics incline(double zeta_deg, double delta_deg, double phi_deg, EarthPressure ep) {
  core::Material m;
  m.gravity = kG;
  m.internal_friction_deg = phi_deg;
  m.bed_friction_deg = delta_deg;
  DamPhysics p;
  p.g_sin = kG * std::sin(core::deg2rad(zeta_deg));
  p.g_cos = kG * std::cos(core::deg2rad(zeta_deg));
  p.tan_delta = m.tan_delta();
  p.K_act = m.K_active();
  p.K_pas = m.K_passive();
  p.model = ep;
  p.k_smoothing = 0.1;
  return p;
}

/// Net driving acceleration s = g cos(zeta) (tan(zeta) - tan(delta)) for downslope motion.
inline double net_acceleration(const DamPhysics& p) { return p.g_sin - p.g_cos * p.tan_delta; }

inline DamConfig config(int cells, Scheme scheme, EarthPressure ep, double cfl = 0.45,
                        TimeStepping ts = TimeStepping::Staggered) {
  DamConfig c;
  c.cells = cells;
  c.scheme = scheme;
  c.cfl = cfl;
  c.earth_pressure = ep;
  c.time_stepping = ts;
  return c;
}
inline const char* name(Scheme s) { return s == Scheme::Minmod ? "Minmod" : "Beam-Warming"; }
inline const char* name(TimeStepping t) {
  return t == TimeStepping::Staggered ? "Staggered" : "Semi-discrete";
}
constexpr TimeStepping kBothTimeSteppings[] = {TimeStepping::Staggered,
                                               TimeStepping::SemiDiscrete};

inline DamBoundary boundary(BoundaryType t) {
  DamBoundary b;
  b.type = t;
  return b;
}
/// A prescribed inflow in time only (the ghost position x is ignored).
inline DamBoundary inflow(std::function<std::array<double, 2>(double)> f) {
  DamBoundary b;
  b.type = BoundaryType::Inflow;
  b.prescribed = true;
  b.inflow = [f = std::move(f)](double t, double) { return f(t); };
  return b;
}
inline DamBoundary inflow(double h, double u) {
  return inflow([h, u](double) { return std::array<double, 2>{h, u}; });
}

/// Advance to t_end with dt = min(stable_dt(), t_end - t); `after` runs after every accepted
/// step. Fails the test (fatally) if a tentative state does not pass check().
inline void advance(DamSolver& s, double t_end,
                    const std::function<void(const DamSolver&)>& after = {}) {
  while (t_end - s.time() > 1e-13 * std::max(1.0, std::abs(t_end))) {
    const double dt = std::min(s.stable_dt(), t_end - s.time());
    ASSERT_GT(dt, 0.0);
    s.step(dt);
    const auto hl = s.check();
    ASSERT_TRUE(hl.ok) << "t = " << s.time() << ": " << hl.quantity << " = " << hl.value
                       << " at x = " << hl.x << " (" << hl.reason << ")";
    s.accept();
    if (after) after(s);
  }
}

/// Advance to t_end in an even number of equal steps (so the state ends on the primary grid
/// without the reconstruction in primary()), each at most `dt_cap`; asserts that every step
/// respects the scheme's stability limit CFL < 1/2.
inline void advance_even(DamSolver& s, double t_end, double dt_cap, double cfl_used = 0.45) {
  const double span = t_end - s.time();
  const long n = 2 * static_cast<long>(std::ceil(span / (2.0 * dt_cap)));
  const double dt = span / static_cast<double>(n);
  for (long k = 0; k < n; ++k) {
    // stable_dt() = cfl dx / a_max, so the Courant number of this dt is dt cfl / stable_dt.
    ASSERT_LT(dt * cfl_used / s.stable_dt(), 0.5) << "step " << k;
    s.step(dt);
    const auto hl = s.check();
    ASSERT_TRUE(hl.ok) << hl.quantity << " = " << hl.value << " at x = " << hl.x << " ("
                       << hl.reason << ")";
    s.accept();
  }
  ASSERT_FALSE(s.staggered());
}

/// Exact cell averages of f over N equal cells of [a, b] (Gauss-Legendre, 4 points on each of
/// `sub` sub-intervals; f may have a few kinks, whose cells then carry an O(dx^2/sub^2) error).
inline std::vector<double> cell_averages(const std::function<double(double)>& f, double a,
                                         double b, int n, int sub = 16) {
  static const double gx[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                               0.8611363115940526};
  static const double gw[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                               0.3478548451374538};
  const double dx = (b - a) / n, ds = dx / sub;
  std::vector<double> out(static_cast<std::size_t>(n), 0.0);
  for (int j = 0; j < n; ++j) {
    double s = 0.0;
    for (int k = 0; k < sub; ++k) {
      const double xc = a + j * dx + (k + 0.5) * ds;
      for (int q = 0; q < 4; ++q) s += 0.5 * gw[q] * f(xc + 0.5 * ds * gx[q]);
    }
    out[static_cast<std::size_t>(j)] = s / sub;
  }
  return out;
}

inline double min_of(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

/// Advance to t_end with dt = min(stable_dt(), dt_cap, t_end - t) (a `Time->Max time step`).
inline void advance_capped(DamSolver& s, double t_end, double dt_cap,
                           const std::function<void(const DamSolver&)>& after = {}) {
  while (t_end - s.time() > 1e-13 * std::max(1.0, std::abs(t_end))) {
    const double dt = std::min({s.stable_dt(), dt_cap, t_end - s.time()});
    ASSERT_GT(dt, 0.0);
    s.step(dt);
    const auto hl = s.check();
    ASSERT_TRUE(hl.ok) << "t = " << s.time() << ": " << hl.quantity << " = " << hl.value
                       << " at x = " << hl.x << " (" << hl.reason << ")";
    s.accept();
    if (after) after(s);
  }
}

/// The paper's Setup II material and slope in the DAM: zeta = 50, delta = 22, phi = 33 deg,
/// Savage-Hutter K.
inline DamPhysics setup2_physics() { return incline(50.0, 22.0, 33.0, EarthPressure::SavageHutter); }

}  // namespace granflow::dam::testing
