#pragma once
// Material and channel data shared by the 1D (DAM) and 2D (N-DAM) models.
//
// Symbols as in Domnik et al. (2013): slope angle zeta, internal friction angle phi, bed friction
// angle delta. Stresses are normalised by the bulk density rho; rho is only used to report
// pressures in Pa.
#include <Teuchos_ParameterList.hpp>

namespace granflow::core {

constexpr double kPi = 3.14159265358979323846;
inline double deg2rad(double d) { return d * kPi / 180.0; }

/// Granular material: friction angles, density, gravity.
struct Material {
  double gravity = 9.81;             ///< g [m/s^2]
  double density = 1440.0;           ///< rho [kg/m^3]
  double internal_friction_deg = 33; ///< phi [deg]
  double bed_friction_deg = 22;      ///< delta [deg]

  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();
  /// Reads a validated "Material" list; throws InputError if delta > phi (K undefined).
  static Material from_parameters(const Teuchos::ParameterList& pl);

  double tan_delta() const;
  /// Earth pressure coefficients of Savage-Hutter theory,
  /// K_act/pas = 2 sec^2 phi (1 -/+ sqrt(1 - cos^2 phi sec^2 delta)) - 1 (needs delta <= phi).
  double K_active() const;
  double K_passive() const;
};

}  // namespace granflow::core
