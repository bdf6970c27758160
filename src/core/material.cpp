#include "granflow/core/material.hpp"

#include "granflow/params/parameters.hpp"

#include <cmath>
#include <sstream>

namespace granflow::core {

Teuchos::RCP<const Teuchos::ParameterList> Material::getValidParameters() {
  static Teuchos::RCP<const Teuchos::ParameterList> valid = [] {
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("Material"));
    using namespace params;
    const Material d;
    add_double(*pl, "Internal friction angle", d.internal_friction_deg,
               "phi [deg]: internal friction angle of the grains; sets the earth pressure "
               "coefficient K (DAM) and the Drucker-Prager yield stress tau_p = sin(phi) (N-DAM)",
               0.0, 89.0);
    add_double(*pl, "Bed friction angle", d.bed_friction_deg,
               "delta [deg]: Coulomb friction angle between material and bed; 0 gives free slip. "
               "Must not exceed the internal friction angle (K is undefined for delta > phi)",
               0.0, 89.0);
    add_double(*pl, "Density", d.density,
               "rho [kg/m^3]: bulk density, used only to report pressures in Pa. Default from the "
               "paper's p_H = 1.0 kPa at h = 0.11 m on a 50 deg slope",
               1.0, 1.0e5);
    add_double(*pl, "Gravity", d.gravity, "g [m/s^2]: gravitational acceleration", 0.0, 1.0e3);
    return pl;
  }();
  return valid;
}

Material Material::from_parameters(const Teuchos::ParameterList& pl) {
  Material m;
  m.internal_friction_deg = pl.get<double>("Internal friction angle");
  m.bed_friction_deg = pl.get<double>("Bed friction angle");
  m.density = pl.get<double>("Density");
  m.gravity = pl.get<double>("Gravity");
  if (m.bed_friction_deg > m.internal_friction_deg) {
    std::ostringstream v;
    v << m.bed_friction_deg;
    std::ostringstream why;
    why << "must not exceed 'Internal friction angle' = " << m.internal_friction_deg
        << " deg: the earth pressure coefficient K needs delta <= phi (allowed: [0, phi])";
    params::fail(pl, "Bed friction angle", v.str(), why.str());
  }
  return m;
}

double Material::tan_delta() const { return std::tan(deg2rad(bed_friction_deg)); }

namespace {
double sh_root(const Material& m) {
  const double cphi = std::cos(deg2rad(m.internal_friction_deg));
  const double cdel = std::cos(deg2rad(m.bed_friction_deg));
  const double arg = 1.0 - cphi * cphi / (cdel * cdel);
  return std::sqrt(std::max(0.0, arg));  // arg >= 0 is guaranteed by delta <= phi
}
double sec2(double deg) {
  const double c = std::cos(deg2rad(deg));
  return 1.0 / (c * c);
}
}  // namespace

double Material::K_active() const {
  return 2.0 * sec2(internal_friction_deg) * (1.0 - sh_root(*this)) - 1.0;
}
double Material::K_passive() const {
  return 2.0 * sec2(internal_friction_deg) * (1.0 + sh_root(*this)) - 1.0;
}

}  // namespace granflow::core
