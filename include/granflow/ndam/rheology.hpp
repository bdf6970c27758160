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
