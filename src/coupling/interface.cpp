// Interfaces of the coupled model (interface.hpp): the conditions each side of an interface
// reads, and the mass that crosses it.
#include "granflow/coupling/interface.hpp"

#include "granflow/dam/dam_solver.hpp"
#include "granflow/ndam/ndam_solver.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace granflow::coupling {

std::array<double, 2> Subdomain::sample(double x) const {
  if (dam) return dam->sample(x);
  const auto cs = ndam->column_state(x);
  return {cs.h, cs.u_mean};
}

std::array<double, 2> Subdomain::last_transfer() const {
  if (dam) return dam->last_transfer();
  const auto t = ndam->last_transfer();
  return {t.in, t.out};
}

Interface::Interface(Subdomain& upstream, Subdomain& downstream, const InterfaceOptions& options)
    : up_(&upstream), down_(&downstream), opt_(options) {
  if (up_->one_d() && down_->one_d()) type_ = Type::OneDOneD;
  else if (!up_->one_d() && down_->one_d()) type_ = Type::TwoDToOneD;
  else if (up_->one_d() && !down_->one_d()) type_ = Type::OneDToTwoD;
  else
    throw std::invalid_argument("coupling: two touching 2D subdomains are one subdomain");
}

std::string Interface::name() const {
  switch (type_) {
    case Type::OneDOneD: return "1D | 1D";
    case Type::TwoDToOneD: return "2D -> 1D";
    case Type::OneDToTwoD: return "1D -> 2D";
  }
  return "";
}

void Interface::connect() {
  const Interface* self = this;
  // The downstream DAM's left ghosts take the upstream state where they lie, inside the
  // upstream subdomain: the DAM's reconstruction (1D | 1D) or the 2D columns (eqs. 19-21).
  if (down_->one_d()) {
    dam::DamBoundary b;
    b.type = core::BoundaryType::Inflow;
    b.inflow = [self](double, double x) { return self->up_->sample(x); };
    down_->dam->set_boundary(0, std::move(b));
  }
  // The upstream DAM's right ghosts read the downstream side (1D | 1D, and the 2D columns
  // behind a 1D -> 2D interface).
  if (up_->one_d()) {
    dam::DamBoundary b;
    b.type = core::BoundaryType::Inflow;
    b.inflow = [self](double, double x) { return self->down_->sample(x); };
    up_->dam->set_boundary(1, std::move(b));
  }
  if (type_ == Type::OneDToTwoD) {
    // eq. (24): u_mean and h of the 1D side at x_IF; eq. (25): profile shape of the first
    // interior 2D column; eq. (26) with K as the options say. Mass: the 2D side lets in exactly
    // what the DAM upstream lets out in the same step (its ledger term), not h u_mean of the
    // reconstruction.
    const double x = this->x();
    down_->ndam->set_inflow([self, x](double) { return self->up_->sample(x); },
                            ndam::InflowShape::CopyInterior, opt_.pressure, opt_.K,
                            [self](double t, double dt) {
                              std::optional<ndam::NdamSolver::InflowStepMass> s;
                              if (const auto m = self->pending_mass(t, dt))
                                s = ndam::NdamSolver::InflowStepMass{(*m)[0], (*m)[1]};
                              return s;
                            });
  }
}

std::optional<std::array<double, 2>> Interface::pending_mass(double t, double dt) const {
  if (!up_->dam) return std::nullopt;
  const auto p = up_->dam->pending_step();
  // The DAM's step is [t0, t0 + dt] with its end time t0 + dt rounded to a double, so its
  // length t_new - t0 is dt only to the round-off of t, not of dt: a relative tolerance of
  // 1e-12 dt refused steps of 1.5e-5 s at t = 0.5 s (ulp(t) / dt = 7e-12), whose inflow then
  // let in h u_mean dt of the DAM's reconstruction instead of its ledger term (coupled
  // nu = 0.3: 5.2e-8 m^2 lost over the run).
  if (!p || std::abs(p->t0 - t) > 1e-12 * (1.0 + t) || std::abs(p->dt - dt) > 1e-12 * (1.0 + t))
    return std::nullopt;
  return std::array<double, 2>{p->out, p->out - p->out_flux};
}

double Interface::carried() const {
  if (down_->one_d()) return mass_[0] - mass_[1];
  return up_->one_d() ? down_->ndam->inflow_pending() : 0.0;
}

void Interface::settle(double dt, double relaxation) {
  if (!down_->one_d()) return;
  const double w = relaxation > 0.0 ? std::min(1.0, dt / relaxation) : 1.0;
  const double c = w * carried();
  if (c == 0.0) return;
  // a dry first DAM cell takes the velocity the upstream side has at x
  mass_[1] += down_->dam->take_interface_mass(c, up_->sample(x())[1]);
}

void Interface::book() {
  mass_[0] += up_->last_transfer()[1];
  mass_[1] += down_->last_transfer()[0];
}

}  // namespace granflow::coupling
