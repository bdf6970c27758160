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
  const auto lay = analysis::propose_layout(run, c.length, d.eps_threshold, d.margin,
                                            d.min_length, 10 * cfg.dry_depth);
  d.models.clear();
  d.interfaces.clear();
  for (std::size_t i = 0; i < lay.size(); ++i) {
    d.models.push_back(lay[i].model);
    if (i > 0) d.interfaces.push_back(lay[i].x0);
  }
  return d;
}

std::unique_ptr<CoupledModel> build(const Decomposition& d, const core::Material& m,
                                    const core::Channel& c, const dam::DamConfig& cfg,
                                    const DamInitialiser& init) {
  const auto phys = dam::DamPhysics::from(m, c, cfg);
  const double dx = c.length / cfg.cells;
  const std::size_t n = d.models.size();
  std::vector<Subdomain> parts(n);
  // Boundaries reach their neighbour through this table, filled once all parts exist.
  auto table = std::make_shared<std::vector<dam::DamSolver*>>(n, nullptr);
  for (std::size_t i = 0; i < n; ++i) {
    const auto [x0, x1] = d.extent(i, c.length);
    if (d.models[i] == "2D")
      throw params::InputError(
          "parameter 'granflow->Decomposition->Models' has a 2D subdomain on [" +
          params::str(x0) + ", " + params::str(x1) +
          "] m: 2D subdomains need the 2D chute model with a free surface, which is not "
          "available yet; allowed now: 1D only");
    auto sub_cfg = cfg;
    sub_cfg.cells = std::max(4, static_cast<int>(std::lround((x1 - x0) / dx)));
    dam::DamBoundary left = i == 0 ? dam::DamBoundary::from(c.left) : dam::DamBoundary{};
    dam::DamBoundary right = i + 1 == n ? dam::DamBoundary::from(c.right) : dam::DamBoundary{};
    if (i > 0) {
      // 1D | 1D: the ghosts sample the upstream neighbour's reconstruction where they lie.
      left.type = core::BoundaryType::Inflow;
      left.inflow = [table, i](double, double x) { return (*table)[i - 1]->sample(x); };
    }
    if (i + 1 < n) {
      right.type = core::BoundaryType::Inflow;
      right.inflow = [table, i](double, double x) { return (*table)[i + 1]->sample(x); };
    }
    auto dam = std::make_unique<dam::DamSolver>(x0, x1, sub_cfg, phys, left, right);
    init(*dam);
    (*table)[i] = dam.get();
    dam::DamSolver* raw = dam.get();
    parts[i].kind = "1D";
    parts[i].x0 = x0;
    parts[i].x1 = x1;
    parts[i].sample = [raw](double x) { return raw->sample(x); };
    parts[i].last_transfer = [raw] { return raw->last_transfer(); };
    parts[i].model = std::move(dam);
  }
  return std::make_unique<CoupledModel>(std::move(parts));
}

}  // namespace granflow::coupling
