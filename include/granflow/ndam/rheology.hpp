#pragma once
// Viscoplastic rheology of the N-DAM (paper eqs. 3-6), as its own module:
//
//   sigma = -p 1 + 2 nu_eff D,      ||D|| = sqrt(2 tr D^2),
//   nu_eff = nu + tau_y / ||D|| (1 - exp(-m_y ||D||))        (Papanastasiou regularisation, 5)
//   tau_y  = tau_c + tau_p max(p, 0)                          (6; tau_p = sin(phi): Drucker-Prager)
//
// Newtonian: tau_c = tau_p = 0. Bingham: constant tau_y = tau_c, tau_p = 0. Drucker-Prager:
// tau_p = sin(phi) from the Material's internal friction angle, tau_c the cohesion (0 for dry
// grains). All stresses are normalised by the bulk density rho [m^2/s^2]. As ||D|| -> 0 the
// regularised nu_eff tends to nu + tau_y m_y, its largest value (used for the explicit time-step
// limit).
#include "granflow/core/material.hpp"

#include <Teuchos_ParameterList.hpp>

#include <algorithm>
#include <cmath>
#include <string>

namespace granflow::ndam {

enum class RheologyModel { Newtonian, Bingham, DruckerPrager };

/// Below m s = kRegularisationSeries, regularised_inverse() uses the series m (1 - m s / 2): it
/// avoids 0 / 0 at s = 0, and the next term, m (m s)^2 / 6, is below round-off there.
inline constexpr double kRegularisationSeries = 1e-8;
/// (1 - exp(-m s)) / s for s >= 0 (-> m as s -> 0): the regularisation of the yield stress
/// (eq. 5, m = m_y, s = ||D||) and of the Coulomb friction factor (eq. 12, m = m_c, s = |u_b|).
inline double regularised_inverse(double m, double s) {
  const double x = m * s;
  return x < kRegularisationSeries ? m * (1.0 - 0.5 * x) : -std::expm1(-x) / s;
}

/// The Coulomb factor of a time step (eq. 12 in time; docs/numerics.md, "Coulomb friction in
/// time"): with c(u) = sgn(u) (1 - exp(-m |u|)), the factor of tan(delta) in (12), the friction
/// of a step in which the base velocity goes from u0 to u1 is the mean of c over the velocities
/// passed,
///   c_mean(u0, u1) = (C(u1) - C(u0)) / (u1 - u0),   C(u) = |u| - (1 - exp(-m |u|)) / m  (C' = c),
/// i.e. the friction work of the step is exactly tan(delta) N (C(u1) - C(u0)) (a discrete
/// gradient). |c_mean| <= 1: the stress never exceeds the Coulomb bound tan(delta) N, and
/// c_mean(u, u) = c(u) (the exact stress of a steady slide). `dc` is d c_mean / d u1 (>= 0, c is
/// increasing), the slope of its linearisation in u1 (Newton's method on the step).
struct CoulombMean {
  double c = 0.0, dc = 0.0;
};
namespace detail {
/// (1 - (1 + x) e^-x) / x^2 and (x - 1 + e^-x) / x^2 for x >= 0, both -> 1/2 as x -> 0; below
/// x = 1e-2 their Taylor series to x^3 (the next terms, x^4 / 144 and x^4 / 720, are below
/// 1e-10, while the closed forms lose about 1e-16 / x^2 to cancellation).
inline double coulomb_psi1(double x) {
  return x < 1e-2 ? 0.5 - x / 3.0 + x * x / 8.0 - x * x * x / 30.0
                  : (-std::expm1(-x) - x * std::exp(-x)) / (x * x);
}
inline double coulomb_psi2(double x) {
  return x < 1e-2 ? 0.5 - x / 6.0 + x * x / 24.0 - x * x * x / 120.0
                  : (x + std::expm1(-x)) / (x * x);
}
}  // namespace detail
inline CoulombMean coulomb_mean(double m, double u0, double u1) {
  CoulombMean r;
  if (u0 * u1 >= 0.0) {
    // one sign: with a = s u0, b = s u1 >= 0 and lo = min(a, b), x = m |b - a|,
    //   c_mean = s (1 - e^{-m lo} (1 - e^-x) / x)   (no cancellation as u1 -> u0),
    //   dc = m e^{-m lo} psi1(x) (b >= a)  or  m e^{-m lo} psi2(x) (b < a)
    const double s = u0 + u1 >= 0.0 ? 1.0 : -1.0;
    const double a = s * u0, b = s * u1, lo = std::min(a, b), x = m * std::abs(b - a);
    const double e = std::exp(-m * lo);
    r.c = s * (1.0 - e * regularised_inverse(1.0, x));
    r.dc = m * e * (b >= a ? detail::coulomb_psi1(x) : detail::coulomb_psi2(x));
    return r;
  }
  // opposite signs: |u1 - u0| = |u0| + |u1| > 0; C(u) = m u^2 psi2(m |u|) (even, no cancellation)
  auto C = [m](double u) { return m * u * u * detail::coulomb_psi2(m * std::abs(u)); };
  const double du = u1 - u0;
  r.c = (C(u1) - C(u0)) / du;
  const double c1 = (u1 > 0.0 ? 1.0 : -1.0) * -std::expm1(-m * std::abs(u1));
  r.dc = std::max(0.0, (c1 - r.c) / du);
  return r;
}

/// The default is the paper's: Drucker-Prager for dry grains (no cohesion) of the default
/// Material; getValidParameters() takes its defaults from a default-constructed one. A Newtonian
/// or Bingham rheology says so (model, and tau_p = 0).
struct Rheology {
  RheologyModel model = RheologyModel::DruckerPrager;
  double nu = 0.003;    ///< [m^2/s] constant kinematic viscosity
  double tau_c = 0.0;   ///< [m^2/s^2] yield stress (Bingham) or cohesion (Drucker-Prager)
  /// [-] pressure coefficient of the yield stress: sin(phi) (Drucker-Prager), 0 otherwise
  double tau_p = std::sin(core::deg2rad(core::Material{}.internal_friction_deg));
  double m_y = 100.0;   ///< [s] regularisation exponent

  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();
  /// Reads a validated "Rheology" list; `user` is the list as written (parameters the chosen
  /// model does not use are an InputError); tau_p = sin(phi) comes from `material`.
  static Rheology from_parameters(const Teuchos::ParameterList& validated,
                                  const Teuchos::ParameterList* user,
                                  const core::Material& material);

  bool newtonian() const { return model == RheologyModel::Newtonian; }
  /// Yield stress tau_y at pressure p (only the compressive part of p counts).
  double yield_stress(double p) const {
    return tau_c + tau_p * (p > 0.0 ? p : 0.0);
  }
  /// nu_eff at strain-rate norm ||D|| and pressure p (eq. 5).
  double nu_eff(double normD, double p) const {
    const double ty = yield_stress(p);
    if (ty == 0.0) return nu;
    return nu + ty * regularised_inverse(m_y, normD);
  }
  std::string name() const;
};

}  // namespace granflow::ndam
