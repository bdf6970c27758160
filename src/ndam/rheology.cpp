// Rheology parameters: which of nu, tau_c, tau_p (= sin phi), m_y each model reads, and the
// checks that keep a scene from silently ignoring a value.
#include "granflow/ndam/rheology.hpp"

#include "granflow/params/parameters.hpp"

#include <algorithm>
#include <map>
#include <vector>

namespace granflow::ndam {

namespace {
const std::map<std::string, std::vector<std::string>>& used_by_model() {
  static const std::map<std::string, std::vector<std::string>> m{
      {"Newtonian", {"Viscosity"}},
      {"Bingham", {"Viscosity", "Yield stress", "Regularisation"}},
      {"Drucker-Prager", {"Viscosity", "Yield stress", "Regularisation"}}};
  return m;
}
}  // namespace

Teuchos::RCP<const Teuchos::ParameterList> Rheology::getValidParameters() {
  static Teuchos::RCP<const Teuchos::ParameterList> valid = [] {
    using namespace params;
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("Rheology"));
    const Rheology d;
    add_enum(*pl, "Model", d.name(),
             "Newtonian: nu_eff = nu; Bingham: constant yield stress tau_y = 'Yield stress'; "
             "Drucker-Prager: tau_y = 'Yield stress' + sin(phi) p with phi the Material's "
             "internal friction angle (the paper's pressure-dependent yield stress, eq. 6)",
             {"Newtonian", "Bingham", "Drucker-Prager"});
    add_double(*pl, "Viscosity", d.nu,
               "nu [m^2/s]: constant kinematic viscosity (paper: 0.003 m^2/s)", 0.0, 1.0e6);
    add_double(*pl, "Yield stress", d.tau_c,
               "tau_c [m^2/s^2 = Pa / rho]: yield stress normalised by the bulk density "
               "(Bingham), or cohesion added to sin(phi) p (Drucker-Prager; 0 for dry grains)",
               0.0, 1.0e9);
    add_double(*pl, "Regularisation", d.m_y,
               "m_y [s]: exponent of the Papanastasiou regularisation (eq. 5); nu_eff is bounded "
               "by nu + tau_y m_y. Larger values are closer to the ideal yield stress and stiffer. "
               "The paper leaves it open; 100 s keeps nu_eff below ~1e3 m^2/s for the paper's "
               "pressures",
               1.0e-6, 1.0e9);
    return pl;
  }();
  return valid;
}

Rheology Rheology::from_parameters(const Teuchos::ParameterList& pl,
                                   const Teuchos::ParameterList* user,
                                   const core::Material& material) {
  Rheology r;
  const auto m = pl.get<std::string>("Model");
  r.model = m == "Newtonian" ? RheologyModel::Newtonian
            : m == "Bingham" ? RheologyModel::Bingham
                             : RheologyModel::DruckerPrager;
  r.nu = pl.get<double>("Viscosity");
  r.m_y = pl.get<double>("Regularisation");
  params::fail_unused(pl, user, used_by_model().at(m), "Model",
                      "the rheology Model '" + m + "'");
  // Each model sets both yield-stress coefficients (the struct's defaults are Drucker-Prager's).
  r.tau_c = r.model != RheologyModel::Newtonian ? pl.get<double>("Yield stress") : 0.0;
  r.tau_p = r.model == RheologyModel::DruckerPrager
                ? std::sin(core::deg2rad(material.internal_friction_deg))
                : 0.0;
  if (r.model == RheologyModel::Bingham && r.tau_c == 0.0 && r.nu == 0.0)
    params::fail(pl, "Viscosity", "0",
                 "a Bingham material with zero yield stress and zero viscosity has no stress; "
                 "allowed: Viscosity > 0 or Yield stress > 0");
  if (r.model == RheologyModel::Newtonian && r.nu == 0.0)
    params::fail(pl, "Viscosity", "0",
                 "the Newtonian model needs a viscosity (the inviscid limit is not supported); "
                 "allowed: > 0");
  return r;
}

std::string Rheology::name() const {
  switch (model) {
    case RheologyModel::Newtonian: return "Newtonian";
    case RheologyModel::Bingham: return "Bingham";
    case RheologyModel::DruckerPrager: return "Drucker-Prager";
  }
  return "?";
}

}  // namespace granflow::ndam
