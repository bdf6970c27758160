#pragma once
// The coupled model (paper sections 4 and 5): the channel split along x into a sequence of
// subdomains, each run by its own model (DAM "1D" or N-DAM "2D"), advancing with one common dt
// and exchanging boundary data through interface objects at fixed or moving positions.
//
//   dt = min over subdomains of stable_dt() (with sub-cycling: over the 2D ones, the 1D ones
//   taking several steps of their own inside it);  every subdomain steps from the states at t
//   (an interface reads its neighbour's state at t: explicit exchange, except the one contract
//   of interface.hpp), in an order that honours it;  check all;  accept all.
//
// The interfaces and the conditions they set are interface.hpp; the parts are built by the
// SubdomainFactory (factory.hpp). Mass through every interface is tracked from both sides and
// reported in summary.json.
#include "granflow/analysis/profiles.hpp"
#include "granflow/core/channel.hpp"
#include "granflow/core/stepper.hpp"
#include "granflow/coupling/interface.hpp"
#include "granflow/coupling/subdomain.hpp"

#include <Teuchos_ParameterList.hpp>

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace granflow::coupling {

/// "Decomposition" sublist: the sequence of models along the channel and the interfaces. The
/// defaults are the paper's Setup I/II layout 2D [0, 0.2] / 1D [0.2, 0.7] / 2D [0.7, L] and the
/// a priori criteria of analysis::LayoutCriteria; getValidParameters() takes them from here.
struct Decomposition {
  /// "1D" or "2D" per subdomain, upstream first
  std::vector<std::string> models{"2D", "1D", "2D"};
  std::vector<double> interfaces{0.2, 0.7};  ///< interface positions [m], non-decreasing in [0, L]
  std::string layout = "Static";             ///< "Static", "A priori" or "Dynamic"
  /// a priori and dynamic: 2D where eps >= this
  double eps_threshold = analysis::LayoutCriteria{}.threshold;
  double margin = analysis::LayoutCriteria{}.margin;  ///< widening of each 2D region [m]
  double min_length = analysis::LayoutCriteria{}.min_length;  ///< shortest subdomain kept [m]
  // Dynamic layout (the domain manager, domain_manager.hpp)
  std::string initial_layout = "Static";  ///< "Static" or "A priori": where a dynamic run starts
  double eps_lower = 0.05;          ///< a 2D column may become 1D once eps < this ...
  double hold_time = 0.05;          ///< ... for this long [s] (hysteresis)
  double check_interval = 0.005;    ///< time between two evaluations of the layout [s]
  double rest_speed = 0.05;         ///< |u_mean| below this is material at rest: 2D [m/s]
  bool shock_indicator = true;      ///< a shock on the 1D side counts as 2D
  /// a 2D column whose flow slows and deepens downstream on a slope that drives it (the
  /// upstream reach of a shock, which the DAM cannot carry) counts as 2D
  bool deceleration_indicator = true;
  /// The 1D parts take their own stable steps inside the common step of the 2D parts.
  bool subcycling = true;
  /// [s] interfaces into a DAM hand the mass their two sides count differently to the DAM's
  /// first cells at the rate 1 / this (Interface::settle); 0: all of it after every step.
  double interface_mass_relaxation = 0.01;
  /// 1D-to-2D interfaces: how the pressure of eq. (26) enters the 2D inflow column
  /// ("Rheology", "Dirichlet" or "None"; see ndam::InflowPressure).
  std::string interface_pressure = "Rheology";

  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();
  /// `user`: the scene's own Decomposition list (before the defaults), when there is one: a
  /// setting the chosen layout does not use is refused by name.
  static Decomposition from_parameters(const Teuchos::ParameterList& pl,
                                       const core::Channel& channel,
                                       const Teuchos::ParameterList* user = nullptr);
  /// [x0, x1] of subdomain i on a channel of length L.
  std::array<double, 2> extent(std::size_t i, double length) const;
  /// The layout that is built on a channel of length L: subdomains of zero length (equal
  /// neighbouring 'Interfaces', or one at 0 or L) left out, and neighbours of the same model
  /// that then touch merged into one subdomain. {2D, 1D, 2D} with {a, a} is the full 2D model.
  Decomposition normalised(double length) const;
};

class SubdomainFactory;
class DomainManager;

class CoupledModel final : public core::Stepper {
 public:
  /// The parts in order along the channel (touching, upstream first); the interfaces between
  /// them are connected here. `factory` (optional) is what the parts were built with; a
  /// checkpoint with a different layout is rebuilt through it.
  CoupledModel(std::vector<Subdomain> parts, const InterfaceOptions& options,
               std::shared_ptr<const SubdomainFactory> factory = nullptr);
  ~CoupledModel() override;

  std::string model_name() const override { return "Coupled"; }
  double time() const override { return parts_.front().model->time(); }
  long steps() const override { return steps_; }
  double stable_dt() const override;
  void step(double dt) override;
  core::Health check() const override;
  void accept() override;
  bool adapt() override;
  core::Profile profile() const override;
  std::vector<core::LayoutPiece> layout_pieces() const override;
  core::MassBalance mass_balance() const override;
  core::Speed max_speed() const override;
  std::string dt_limit() const override;
  void write_fields(io::FieldWriter& w) const override;
  void save(io::Checkpoint& c) const override;
  void load(const io::Checkpoint& c) override;
  void restart_point() override;
  void report(nlohmann::json& stats) const override;
  /// The channel ends at a wall (the last part's, or the scene's channel when that part is 1D).
  bool end_wall() const override;
  /// The load on the end wall from the last part when it is 2D (the part at the wall, whatever
  /// its extent after a rebuild by the domain manager); empty while that part is 1D.
  std::optional<core::WallLoad> wall_load() const override;

  const std::vector<Subdomain>& parts() const { return parts_; }
  const Interface& interface(std::size_t i) const { return *interfaces_[i]; }
  std::size_t interfaces() const { return interfaces_.size(); }
  /// Cumulative mass that left subdomain i through interface i (upstream side) and that
  /// entered subdomain i + 1 through it (downstream side) [m^2], since that interface was
  /// connected.
  std::array<double, 2> interface_mass(std::size_t i) const { return interfaces_[i]->mass(); }
  /// Replaces the parts [first, first + count) by `with` (inserting, removing or resizing
  /// subdomains is one call) and reconnects all interfaces. The new parts must cover exactly
  /// the replaced interval. The run's mass ledger carries over: the inflow and outflow that
  /// replaced end parts had booked stay booked.
  void replace_parts(std::size_t first, std::size_t count, std::vector<Subdomain> with);
  /// Models and interface positions of the current layout.
  Decomposition layout() const;
  /// The runtime domain manager (Layout = Dynamic): adapt() lets it move the interfaces.
  void set_domain_manager(std::unique_ptr<DomainManager> m);
  /// Sub-cycling of the 1D parts (Decomposition->Sub-cycling): the common dt is the 2D parts'
  /// (at most kMaxSubsteps of a 1D part's stable step), each DAM sub-cycles inside it.
  void set_subcycling(bool on) { subcycling_ = on; }
  /// Decomposition->Interface mass relaxation (Interface::settle).
  void set_interface_mass_relaxation(double seconds) { relaxation_ = seconds; }
  /// Hands every interface's carried mass to its DAM now (before the domain manager rebuilds
  /// parts: reconnected interfaces start from nothing carried). What no DAM cell can take (a
  /// removal from a nearly dry DAM) is kept, with the interface's position, for
  /// place_settle_leftovers().
  void settle_interfaces();
  /// After a rebuild: each leftover of settle_interfaces() goes to the interface now at its
  /// position (carried on, settled by the relaxation as before), else to the DAM that now covers
  /// its position (the converted columns hold the mass its DAM had taken ahead of the 2D
  /// side); what neither can take stays booked in the ledger (mass_unplaced).
  void place_settle_leftovers();
  /// Mass [m^2] that leaves the parts without leaving the channel and that no part can take (a
  /// move's unplaced marker remainder, the pending inflow of a vanished interface): kept in
  /// the run's ledger (mass_balance().current), reported as `mass_unplaced`.
  void book_unplaced(double m) { unplaced_ += m; }
  /// Mass [m^2] that passed the channel's gate but was not yet in the fields when the gate's
  /// part was rebuilt (a 2D gate's fractional markers, handed on by the conversion): booked as
  /// the run's inflow, which counted only what the old part had injected.
  void book_gate_inflow(double m) { retired_inflow_ += m; }
  static constexpr int kMaxSubsteps = 64;
  const DomainManager* domain_manager() const { return manager_.get(); }
  std::shared_ptr<const SubdomainFactory> factory() const { return factory_; }

 private:
  void reconnect();  // interfaces between the current parts, and the step order
  std::string dt_setter(double dt) const;  // what set a step of length dt (after stable_dt())

  std::vector<Subdomain> parts_;
  // per part, its stable step as the common step sees it (1D sub-cycled: kMaxSubsteps times
  // its own), from the last stable_dt(); and per cause, the steps it set in this run (from the
  // start or the restart: a diagnosis, not state)
  mutable std::vector<double> part_dt_;
  std::map<std::string, long> dt_set_by_;
  InterfaceOptions options_;
  std::shared_ptr<const SubdomainFactory> factory_;
  std::vector<std::unique_ptr<Interface>> interfaces_;
  std::vector<std::size_t> step_order_;  // parts in the order their step() runs
  long steps_ = 0;
  double initial_mass_ = 0.0;
  double retired_inflow_ = 0.0, retired_outflow_ = 0.0;  // booked by replaced end parts
  std::unique_ptr<DomainManager> manager_;
  bool subcycling_ = false;
  double relaxation_ = 0.0;
  double last_dt_ = 0.0;     // of the step in progress
  double unplaced_ = 0.0;    // book_unplaced() and what settle_interfaces() could not place
  std::vector<std::array<double, 2>> settle_leftovers_;  // (x, mass) between settle and place
};

}  // namespace granflow::coupling
