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

std::unique_ptr<CoupledModel> build(const Decomposition& layout, const core::Material& m,
                                    const core::Channel& c, const dam::DamConfig& cfg,
                                    const DamInitialiser& init, const TwoD* two_d) {
  const Decomposition d = layout.normalised(c.length);
  const auto phys = dam::DamPhysics::from(m, c, cfg);
  const double dx = c.length / cfg.cells;
  const std::size_t n = d.models.size();
  std::vector<Subdomain> parts(n);
  // Interfaces reach their neighbours through these tables, filled as the parts are built
  // (upstream first); a callback only runs once every part exists.
  auto dams = std::make_shared<std::vector<dam::DamSolver*>>(n, nullptr);
  auto twods = std::make_shared<std::vector<ndam::NdamSolver*>>(n, nullptr);
  auto state_at = [dams, twods](std::size_t j, double x) -> std::array<double, 2> {
    if ((*dams)[j]) return (*dams)[j]->sample(x);
    const auto cs = (*twods)[j]->column_state(x);
    return {cs.h, cs.u_mean};
  };
  for (std::size_t i = 0; i < n; ++i) {
    const auto [x0, x1] = d.extent(i, c.length);
    parts[i].kind = d.models[i];
    parts[i].x0 = x0;
    parts[i].x1 = x1;
    if (d.models[i] == "2D") {
      if (!two_d)
        throw params::InputError(
            "parameter 'granflow->Decomposition->Models' has a 2D subdomain on [" +
            params::str(x0) + ", " + params::str(x1) +
            "] m, but this scene has no 2D model configured; allowed: 1D only");
      auto cfg2 = two_d->cfg;
      const double dx2 = two_d->cfg.grid.lx / two_d->cfg.grid.nx;
      cfg2.x0 = x0;
      cfg2.grid.lx = x1 - x0;
      cfg2.grid.nx = std::max(4, static_cast<int>(std::lround((x1 - x0) / dx2)));
      if (i + 1 < n) {  // open outflow into the next subdomain
        cfg2.outflow_right = true;
        cfg2.outflow_extrapolate = true;  // inside the accelerating flow, not its end
        cfg2.walls[static_cast<int>(ndam::Side::Right)].kind = ndam::WallKind::FreeSlip;
      }
      if (i > 0) cfg2.inflow = nullptr;  // set below from the upstream neighbour
      auto nd = std::make_unique<ndam::NdamSolver>(two_d->comm, cfg2, two_d->rheology,
                                                   two_d->physics);
      if (i > 0) {
        // eq. (24): u_mean and h of the 1D side at x_IF; eq. (25): profile shape of the first
        // interior 2D column; eq. (26): p = g cos(zeta)(h - z)(1 + K)/2 with K = K_act of the 1D
        // side (its delta_1D when DAM->Bed friction angle is set), in the
        // way 'Interface pressure' says.
        const auto pressure = d.interface_pressure == "Dirichlet" ? ndam::InflowPressure::Dirichlet
                              : d.interface_pressure == "None"    ? ndam::InflowPressure::None
                                                                  : ndam::InflowPressure::Rheology;
        // Mass: the 2D side lets in exactly what the DAM upstream lets out in the same step
        // (its ledger term; the DAM has stepped first), not h u_mean of the reconstruction.
        ndam::NdamSolver::InflowMass mass = [dams, i](double t, double dt) -> std::optional<double> {
          const dam::DamSolver* up = (*dams)[i - 1];
          if (!up) return std::nullopt;
          const auto p = up->pending_step();
          if (!p || std::abs(p->t0 - t) > 1e-12 * (1.0 + t) || std::abs(p->dt - dt) > 1e-12 * dt)
            return std::nullopt;
          return p->out;
        };
        nd->set_inflow([state_at, i, x0](double) { return state_at(i - 1, x0); },
                       ndam::InflowShape::CopyInterior, pressure, cfg.material(m).K_active(),
                       mass);
      }
      (*twods)[i] = nd.get();
      ndam::NdamSolver* raw = nd.get();
      parts[i].sample = [raw](double x) {
        const auto cs = raw->column_state(x);
        return std::array<double, 2>{cs.h, cs.u_mean};
      };
      parts[i].last_transfer = [raw] {
        const auto t = raw->last_transfer();
        return std::array<double, 2>{t.in, t.out};
      };
      parts[i].model = std::move(nd);
      continue;
    }
    auto sub_cfg = cfg;
    sub_cfg.cells = std::max(4, static_cast<int>(std::lround((x1 - x0) / dx)));
    dam::DamBoundary left = i == 0 ? dam::DamBoundary::from(c.left) : dam::DamBoundary{};
    dam::DamBoundary right = i + 1 == n ? dam::DamBoundary::from(c.right) : dam::DamBoundary{};
    if (i > 0) {
      // 1D | 1D and 2D -> 1D (eqs. 19-21): the ghosts take the neighbour's depth-averaged
      // state where they lie, inside the neighbour.
      left.type = core::BoundaryType::Inflow;
      left.inflow = [state_at, i](double, double x) { return state_at(i - 1, x); };
    }
    if (i + 1 < n) {
      right.type = core::BoundaryType::Inflow;
      right.inflow = [state_at, i](double, double x) { return state_at(i + 1, x); };
    }
    auto dam = std::make_unique<dam::DamSolver>(x0, x1, sub_cfg, phys, left, right);
    init(*dam);
    (*dams)[i] = dam.get();
    dam::DamSolver* raw = dam.get();
    parts[i].sample = [raw](double x) { return raw->sample(x); };
    parts[i].last_transfer = [raw] { return raw->last_transfer(); };
    parts[i].model = std::move(dam);
  }
  return std::make_unique<CoupledModel>(std::move(parts));
}

}  // namespace granflow::coupling
