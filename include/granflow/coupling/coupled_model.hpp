#pragma once
// The coupled model (paper sections 4 and 5): the channel split along x into a sequence of
// subdomains, each run by its own model (DAM "1D" or N-DAM "2D"), advancing with one common dt
// and exchanging boundary data through interface objects at fixed or moving positions.
//
//   dt = min over subdomains of stable_dt();  every subdomain steps from the states at t
//   (an interface reads its neighbour's state at t: explicit exchange);  check all;  accept all.
//
// Interfaces here:
//   1D | 1D  each side's ghost cells sample the neighbour's reconstruction at the ghost centres
//            (overlapping exchange; transparent for sub- and supercritical flow);
//   2D -> 1D eqs. (19)-(21): the 1D inflow ghosts take h and the depth-averaged u of the 2D side
//            at their centres (needs the 2D chute model: issue 4);
//   1D -> 2D eqs. (24)-(27) (needs the 2D chute model: issue 4).
// Mass through every interface is tracked from both sides and reported in summary.json.
#include "granflow/core/channel.hpp"
#include "granflow/core/stepper.hpp"

#include <Teuchos_ParameterList.hpp>

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace granflow::coupling {

/// "Decomposition" sublist: the sequence of models along the channel and the interfaces.
struct Decomposition {
  std::vector<std::string> models;  ///< "1D" or "2D" per subdomain, upstream first
  std::vector<double> interfaces;   ///< interface positions [m], non-decreasing in [0, L]
  std::string layout = "Static";    ///< "Static" or "A priori"
  double eps_threshold = 0.1;       ///< a priori: 2D where eps = 1/Fr^2 >= this
  double margin = 0.05;             ///< a priori: widening of each 2D region [m]
  double min_length = 0.05;         ///< a priori: shortest subdomain kept [m]
  /// 1D-to-2D interfaces: how the pressure of eq. (26) enters the 2D inflow column
  /// ("Rheology", "Dirichlet" or "None"; see ndam::InflowPressure).
  std::string interface_pressure = "Rheology";

  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();
  static Decomposition from_parameters(const Teuchos::ParameterList& pl,
                                       const core::Channel& channel);
  /// [x0, x1] of subdomain i on a channel of length L.
  std::array<double, 2> extent(std::size_t i, double length) const;
  /// The layout that is built on a channel of length L: subdomains of zero length (equal
  /// neighbouring 'Interfaces', or one at 0 or L) left out, and neighbours of the same model
  /// that then touch merged into one subdomain. {2D, 1D, 2D} with {a, a} is the full 2D model.
  Decomposition normalised(double length) const;
};

/// One subdomain: its model and how the coupling reads and feeds it.
struct Subdomain {
  std::string kind;  ///< "1D" or "2D"
  double x0 = 0.0, x1 = 0.0;
  std::unique_ptr<core::Stepper> model;
  /// Depth-averaged state {h, u_mean} of the current state at x in [x0, x1].
  std::function<std::array<double, 2>(double)> sample;
  /// Mass [m^2] that entered at x0 and left at x1 in the last accepted step.
  std::function<std::array<double, 2>()> last_transfer;
};

class CoupledModel final : public core::Stepper {
 public:
  explicit CoupledModel(std::vector<Subdomain> parts);

  std::string model_name() const override { return "Coupled"; }
  double time() const override { return parts_.front().model->time(); }
  long steps() const override { return steps_; }
  double stable_dt() const override;
  void step(double dt) override;
  core::Health check() const override;
  void accept() override;
  core::Profile profile() const override;
  core::MassBalance mass_balance() const override;
  void write_fields(io::FieldWriter& w) const override;
  void save(io::Checkpoint& c) const override;
  void load(const io::Checkpoint& c) override;
  void report(nlohmann::json& stats) const override;

  const std::vector<Subdomain>& parts() const { return parts_; }
  /// Cumulative mass that left subdomain i through interface i (upstream side) and that
  /// entered subdomain i + 1 through it (downstream side) [m^2].
  std::array<double, 2> interface_mass(std::size_t i) const { return iface_mass_[i]; }

 private:
  std::vector<Subdomain> parts_;
  std::vector<std::array<double, 2>> iface_mass_;
  long steps_ = 0;
};

}  // namespace granflow::coupling
