#pragma once
// An interface of the coupled model at x between an upstream and a downstream subdomain, and
// the conditions it sets on both sides (paper section 4; flow from left to right):
//
//   1D | 1D  each side's ghost cells sample the neighbour's reconstruction at the ghost
//            centres (an overlapping exchange, transparent for sub- and supercritical flow);
//   2D -> 1D eqs. (19)-(21): the 1D ghosts take h and the depth-averaged u of the 2D column
//            where they lie; the 2D side is an open outflow continuing the lagged gradient
//            (built so by the factory);
//   1D -> 2D eqs. (24)-(27): the 2D inflow takes h of the 1D reconstruction at x and exactly
//            the mass the DAM lets out in the same step (eq. 24), the profile shape of the
//            first interior 2D column (25), p of eq. (26) with K = K_act as the options say,
//            w from continuity (27); the 1D ghosts beyond x read the 2D columns.
//
// Step-ordering contract: every side reads its neighbour's ACCEPTED state at t, except the 2D
// side of a 1D -> 2D interface, which reads the upstream DAM's tentative transfer over the
// step [t, t + dt] (DamSolver::pending_step). So the upstream side of such an interface steps
// first (upstream_steps_first()); the coupled model orders its parts by this. A 1D side that
// takes several steps inside one 2D step reports the sum of their transfers over [t, t + dt].
//
// The callbacks a side is given capture this Interface (the coupled model owns it at a stable
// address) and reach the parts through it, so that reconnecting after a change of the parts
// is creating new Interface objects and calling connect() on them.
#include "granflow/coupling/subdomain.hpp"
#include "granflow/ndam/config.hpp"

#include <array>
#include <optional>
#include <string>

namespace granflow::coupling {

/// How the 2D side of a 1D -> 2D interface takes the pressure of eq. (26).
struct InterfaceOptions {
  ndam::InflowPressure pressure = ndam::InflowPressure::Rheology;
  double K = 1.0;  ///< earth pressure coefficient of eq. (26) (K_act of the 1D side)
};

class Interface {
 public:
  enum class Type { OneDOneD, TwoDToOneD, OneDToTwoD };
  /// Throws std::invalid_argument for 2D | 2D (touching 2D subdomains are one subdomain).
  Interface(Subdomain& upstream, Subdomain& downstream, const InterfaceOptions& options);
  Interface(const Interface&) = delete;
  Interface& operator=(const Interface&) = delete;

  Type type() const { return type_; }
  double x() const { return up_->x1; }
  const Subdomain& upstream() const { return *up_; }
  const Subdomain& downstream() const { return *down_; }
  /// Sets the conditions of both sides that read this interface (collective when a side is 2D).
  void connect();
  /// The downstream side reads the upstream side's tentative state of the step.
  bool upstream_steps_first() const { return type_ == Type::OneDToTwoD; }
  /// The mass the upstream DAM lets out through x in the step [t, t + dt], once it has computed
  /// that step (1D -> 2D; nullopt when no such step is pending): {out, out - out_flux}, the
  /// exact ledger term and its dt-independent averaging part (DamSolver::PendingStep).
  std::optional<std::array<double, 2>> pending_mass(double t, double dt) const;
  /// After an accepted step: books what crossed x on each side.
  void book();
  /// Into a DAM (2D -> 1D, 1D | 1D): the DAM's own scheme evaluates the flux through x from
  /// its ghosts, which is not what the upstream side let out (the 2D side counts the markers
  /// that left; the staggered scheme's overlap adds averaging terms). The difference is carried
  /// (carried()) and handed to the DAM's cells at x after every accepted step of length dt, the
  /// fraction min(1, dt / relaxation) of it (relaxation 0: all of it), so that no mass is made
  /// or lost at the interface: the alternating averaging terms and the markers' one-at-a-time
  /// outflow average out in the carried mass instead of shaking the DAM's first cell. No-op for
  /// 1D -> 2D (the 2D side already takes the DAM's exact ledger term).
  void settle(double dt, double relaxation);
  /// Mass that left the upstream side and has not yet entered the downstream one [m^2]: into
  /// a DAM the difference of the two sides' counts; for 1D -> 2D what the 2D inflow holds
  /// (NdamSolver::inflow_pending(): its gate's fractional markers and carried mass).
  double carried() const;
  /// Cumulative mass out of the upstream side through x and into the downstream side [m^2]
  /// since this interface was connected.
  std::array<double, 2> mass() const { return mass_; }
  void restore(const std::array<double, 2>& mass) { mass_ = mass; }  ///< from a checkpoint
  std::string name() const;  ///< "2D -> 1D" etc.

 private:
  Subdomain* up_;
  Subdomain* down_;
  InterfaceOptions opt_;
  Type type_;
  std::array<double, 2> mass_{0.0, 0.0};
};

}  // namespace granflow::coupling
