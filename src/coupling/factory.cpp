// The subdomain factory (factory.hpp): the channel-wide configurations cut to one subdomain.
#include "granflow/coupling/factory.hpp"

#include "granflow/params/parameters.hpp"

#include <algorithm>
#include <cmath>

namespace granflow::coupling {

namespace {
// The smallest subdomain either model is built with [cells]: a DAM needs two ghost cells on each
// side of a NOC stencil, an N-DAM box two columns per MPI rank and the outflow extrapolation two
// interior faces.
}  // namespace

SubdomainFactory::SubdomainFactory(const core::Material& m, const core::Channel& c,
                                   const dam::DamConfig& cfg, DamInitialiser init,
                                   const TwoD* two_d, const std::string& interface_pressure)
    : material_(m), channel_(c), dam_cfg_(cfg), dam_phys_(dam::DamPhysics::from(m, c, cfg)),
      init_(std::move(init)) {
  if (two_d) two_d_ = *two_d;
  iface_.pressure = interface_pressure == "Dirichlet" ? ndam::InflowPressure::Dirichlet
                    : interface_pressure == "None"    ? ndam::InflowPressure::None
                                                      : ndam::InflowPressure::Rheology;
  // K of eq. (26): K_act of the 1D side (its delta_1D when DAM->Bed friction angle is set)
  iface_.K = cfg.material(m).K_active();
}

double SubdomainFactory::dx_2d() const {
  return two_d_ ? two_d_->cfg.grid.lx / two_d_->cfg.grid.nx : 0.0;
}

int SubdomainFactory::dam_cells(double x0, double x1) const {
  return std::max(kMinimumCells, static_cast<int>(std::lround((x1 - x0) / dx_1d())));
}

dam::DamBoundary SubdomainFactory::dam_boundary(int side, Neighbours n) const {
  // The channel's own ends; a side towards a neighbour is set by the interface (connect()).
  if (side == 0) return n.upstream ? dam::DamBoundary{} : dam::DamBoundary::from(channel_.left);
  return n.downstream ? dam::DamBoundary{} : dam::DamBoundary::from(channel_.right);
}

ndam::NdamConfig SubdomainFactory::ndam_config(double x0, double x1, Neighbours n) const {
  if (!two_d_)
    throw params::InputError(
        "parameter 'granflow->Decomposition->Models' has a 2D subdomain on [" + params::str(x0) +
        ", " + params::str(x1) +
        "] m, but this scene has no 2D model configured; allowed: 1D only");
  auto cfg2 = two_d_->cfg;
  cfg2.x0 = x0;
  cfg2.grid.lx = x1 - x0;
  cfg2.grid.nx = std::max(kMinimumCells, static_cast<int>(std::lround((x1 - x0) / dx_2d())));
  if (n.downstream) {  // open outflow into the next subdomain
    cfg2.outflow_right = true;
    cfg2.outflow_extrapolate = true;  // inside the accelerating flow, not its end
    cfg2.walls[static_cast<int>(ndam::Side::Right)].kind = ndam::WallKind::FreeSlip;
  }
  if (n.upstream) {  // the interface sets it (connect())
    cfg2.inflow = nullptr;
    cfg2.inflow_volume = nullptr;
    cfg2.wall_left = false;
    // a Moving lid of the channel's closed left end belongs to x = 0, not to an interface,
    // whose inflow it would drive (w = the lid's speed across the opening): the interface
    // side takes the gate's tangential condition, w = 0 on the side
    auto& left = cfg2.walls[static_cast<int>(ndam::Side::Left)];
    if (left.kind == ndam::WallKind::MovingLid) {
      left.kind = ndam::WallKind::NoSlip;
      left.velocity = 0.0;
    }
  }
  return cfg2;
}

Subdomain SubdomainFactory::initial(const std::string& kind, double x0, double x1,
                                    Neighbours n) const {
  Subdomain s;
  s.kind = kind;
  s.x0 = x0;
  s.x1 = x1;
  if (kind == "2D") {
    const auto cfg2 = ndam_config(x0, x1, n);  // InputError without a 2D model
    auto nd = std::make_unique<ndam::NdamSolver>(two_d_->comm, cfg2, two_d_->rheology,
                                                 two_d_->physics);
    s.ndam = nd.get();
    s.model = std::move(nd);
    return s;
  }
  auto sub_cfg = dam_cfg_;
  sub_cfg.cells = dam_cells(x0, x1);
  auto d = std::make_unique<dam::DamSolver>(x0, x1, sub_cfg, dam_phys_, dam_boundary(0, n),
                                            dam_boundary(1, n));
  init_(*d);
  s.dam = d.get();
  s.model = std::move(d);
  return s;
}

Subdomain SubdomainFactory::dam(double x0, double x1, std::vector<double> h,
                                std::vector<double> hu, double t, long steps, Neighbours n,
                                bool staggered) const {
  Subdomain s;
  s.kind = "1D";
  s.x0 = x0;
  s.x1 = x1;
  auto sub_cfg = dam_cfg_;
  sub_cfg.cells = static_cast<int>(h.size()) - (staggered ? 1 : 0);
  auto d = std::make_unique<dam::DamSolver>(x0, x1, sub_cfg, dam_phys_, dam_boundary(0, n),
                                            dam_boundary(1, n));
  d->set_cells(std::move(h), std::move(hu), t, steps, staggered);
  s.dam = d.get();
  s.model = std::move(d);
  return s;
}

Subdomain SubdomainFactory::ndam(double x0, double x1, const ndam::NdamState& st,
                                 const ndam::NdamStatistics& stats, Neighbours n) const {
  Subdomain s;
  s.kind = "2D";
  s.x0 = x0;
  s.x1 = x1;
  auto cfg2 = ndam_config(x0, x1, n);
  auto nd = std::make_unique<ndam::NdamSolver>(two_d_->comm, cfg2, two_d_->rheology,
                                               two_d_->physics, st, stats);
  s.ndam = nd.get();
  s.model = std::move(nd);
  return s;
}

}  // namespace granflow::coupling
