#include "granflow/coupling/build.hpp"

#include "granflow/analysis/profiles.hpp"
#include "granflow/params/parameters.hpp"

#include <cmath>
#include <map>

namespace granflow::coupling {

Decomposition a_priori_layout(Decomposition d, const core::Material& m, const core::Channel& c,
                              const dam::DamConfig& cfg, const DamInitialiser& init,
                              double end_time, double interval) {
  const auto phys = dam::DamPhysics::from(m, c, cfg);
  dam::DamSolver dam(0.0, c.length, cfg, phys, dam::DamBoundary::from(c.left),
                     dam::DamBoundary::from(c.right));
  init(dam);
  std::map<double, analysis::ProfileAt> run;
  auto record = [&] {
    const auto p = dam.profile();
    run[dam.time()] = analysis::ProfileAt{p.x, p.h, p.u_mean, p.eps, p.model};
  };
  record();
  double next = interval;
  while (dam.time() < end_time - 1e-12) {
    const double dt = std::min({dam.stable_dt(), end_time - dam.time(), next - dam.time()});
    dam.step(dt);
    const auto h = dam.check();
    if (!h.ok)
      throw std::runtime_error("a priori DAM run failed: " + h.reason + " at x = " +
                               params::str(h.x) + " m");
    dam.accept();
    if (dam.time() >= next - 1e-12) {
      record();
      next += interval;
    }
  }
  const auto lay = analysis::propose_layout(run, c.length, d.eps_threshold, d.margin, d.min_length,
                                            analysis::layout_wet_depth(cfg.dry_depth));
  d.models.clear();
  d.interfaces.clear();
  for (std::size_t i = 0; i < lay.size(); ++i) {
    d.models.push_back(lay[i].model);
    if (i > 0) d.interfaces.push_back(lay[i].x0);
  }
  return d;
}

std::unique_ptr<CoupledModel> build(const Decomposition& layout, const core::Material& m,
                                    const core::Channel& c, const dam::DamConfig& cfg,
                                    const DamInitialiser& init, const TwoD* two_d) {
  const Decomposition d = layout.normalised(c.length);
  auto factory = std::make_shared<const SubdomainFactory>(m, c, cfg, init, two_d,
                                                          d.interface_pressure);
  const std::size_t n = d.models.size();
  std::vector<Subdomain> parts;
  for (std::size_t i = 0; i < n; ++i) {
    const auto [x0, x1] = d.extent(i, c.length);
    parts.push_back(factory->initial(d.models[i], x0, x1, Neighbours{i > 0, i + 1 < n}));
  }
  auto model =
      std::make_unique<CoupledModel>(std::move(parts), factory->interface_options(), factory);
  model->set_subcycling(d.subcycling);
  model->set_interface_mass_relaxation(d.interface_mass_relaxation);
  return model;
}

}  // namespace granflow::coupling
