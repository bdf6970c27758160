#pragma once
// The domain manager: 1D-2D interfaces that move while the simulation runs
// (Decomposition->Layout = Dynamic; the paper proposes it in section 4.1, strategy (i)).
//
// Every 'Check interval', between two accepted steps, the manager evaluates along the whole
// channel, slot by slot (a slot is one 2D column, or one 1D cell if those are coarser; every
// interface lies on a slot edge, a node of both grids), the depth-averaged state {h, u_mean}:
//
//   eps  = 1/Fr^2 = beta h / u_mean^2,  beta = g cos(zeta) K_act        on both sides, and
//   eps  = max(eps, |w_mean| / |u_mean|)                                in the 2D columns,
//   rest = |u_mean| < 'Rest speed' where there is material:              counts as 2D,
//   shock = u_mean drops across the slot by more than the wave speed sqrt(beta h), to less than
//          half the upstream speed (1D side; a front, with a dry neighbour, is not a shock),
//   slowing = on a slope that accelerates a sliding layer, the 2D flow slows and deepens
//          downstream (2D side: the upstream reach of a shock, 'Deceleration indicator').
//
// The two sides' indicators are comparable because both use 1/Fr^2 of the same depth-averaged
// state; |w|/|u| (the paper's eps of the 2D model) adds what only the 2D side can see (a jet,
// a column collapsing). A deposit is never shrunk: in a column at rest |w|/|u| is 0/0 and 1/Fr^2
// infinite, so rest is 2D.
//
// The target layout: 2D wherever eps >= 'Shallowness threshold', rest, a shock or slowing,
// widened by 'Margin' on both sides (so the shock moving up from a wall stays inside 2D until the next
// check: Margin must exceed the shock speed times the check interval); a 2D column becomes 1D
// only once eps < 'Lower threshold' there has held for 'Hold time' (hysteresis), from the ends
// of its subdomain (a subdomain calm all over goes as a whole); 1D pieces
// shorter than 'Minimum length' between or at the end of 2D ones become 2D, and 2D subdomains are
// never shorter than it. Growing, shrinking, creating and merging subdomains are all the same
// operation: the parts whose slots change model are rebuilt, with their neighbours where they
// merge, by the conservative conversion of conversion.hpp, and CoupledModel::replace_parts
// swaps them in. Every move is booked (time, layout before and after, mass and momentum of the
// converted interval before and after, the marker remainder).
#include "granflow/coupling/conversion.hpp"
#include "granflow/coupling/coupled_model.hpp"
#include "granflow/coupling/factory.hpp"

#include <nlohmann/json_fwd.hpp>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

namespace granflow::io {
class Checkpoint;
}

namespace granflow::coupling {

class DomainManager {
 public:
  /// Throws params::InputError when the grids have no common slot (the 2D column width and
  /// the 1D cell width must be multiples of one another) or 'Minimum length' is below four
  /// slots.
  DomainManager(const Decomposition& d, std::shared_ptr<const SubdomainFactory> factory);

  /// Between accepted steps: at each check time evaluates the indicators and changes the
  /// layout of `model` where they ask for it (collective). Returns whether the layout changed.
  bool adapt(CoupledModel& model);

  /// Per slot: the indicator of the last check (for tests and output).
  struct SlotState {
    double x0 = 0.0, x1 = 0.0;
    double h = 0.0, u_mean = 0.0, eps = 0.0;
    bool two_d = false;   ///< the model of the slot at the check
    bool needs_2d = false;  ///< eps >= upper threshold, rest, shock or slowing
    bool shock = false;
    bool slowing = false;  ///< 2D flow slowing and deepening on a driving slope
  };
  const std::vector<SlotState>& last_check() const { return slots_; }
  double slot_width() const { return slot_; }
  /// The slot of grids with 1D cells of dx_1d and 2D columns of dx_2d: the coarser of the two
  /// (interfaces lie on its nodes, common to both grids).
  static double slot_width(double dx_1d, double dx_2d) { return std::max(dx_1d, dx_2d); }
  long moves() const { return static_cast<long>(log_.size()); }
  long checks() const { return checks_; }
  /// Releases (2D -> 1D) of a column that was released twice before within kFlickerHolds
  /// 'Hold time's: an interface that flickers (book_changes).
  long flickers() const { return flickers_; }
  static constexpr double kFlickerHolds = 20.0;

  void save(io::Checkpoint& c) const;
  void load(const io::Checkpoint& c);
  void report(nlohmann::json& s) const;

 private:
  double wave_beta() const;
  struct Move {
    double t = 0.0;
    std::string before, after;  // layouts, "2D 0 0.2 | 1D 0.2 0.7 | ..."
    ConversionRecord record;
    double seconds = 0.0;
  };
  std::vector<Piece> target(const CoupledModel& model);  // evaluates the slots, the hysteresis

  Decomposition d_;
  std::shared_ptr<const SubdomainFactory> factory_;
  double slot_ = 0.0;
  int nslots_ = 0;
  double next_check_ = 0.0;
  std::vector<double> calm_since_;  // per slot: since when eps < lower (-1: not calm)
  std::vector<SlotState> slots_;
  std::vector<Move> log_;
  long checks_ = 0;
  long checks_by_speed_ = 0;  ///< checks brought before the interval by the signal speed
  // per slot: the times of its last two releases to 1D (-1: none); a third release within
  // kFlickerHolds hold times of the older one is a flicker (counted, and warned of once)
  std::vector<double> released_at_, released_before_;
  long flickers_ = 0;
  double flicker_t_ = -1.0, flicker_x_ = 0.0;
  void book_changes(const std::vector<char>& cur, const std::vector<char>& tgt, double t);
  double seconds_checks_ = 0.0;
};

}  // namespace granflow::coupling
