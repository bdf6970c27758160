#pragma once
// Conservative state conversion between the models of the coupled channel, for a change of its
// layout (the domain manager): the parts of an interval [a, b] are rebuilt as a new sequence of
// 1D and 2D parts over the same interval, from the state of the old ones.
//
//  - The depth-averaged state of the old parts as piecewise-constant cells (ChannelField): the
//    DAM's cells (on its staggered grid the two end cells clipped to their halves inside the
//    part, as DamSolver::mass counts them) and the 2D columns (h from the markers, so the mass is
//    the marker area exactly; hu = h u_mean with u_mean of eq. 21).
//  - A new 1D part takes the exact averages of that field over its cells (on the grid phase of
//    the old DAM it overlaps most, so kept cells are copied bit for bit).
//  - A new 2D part copies the columns that were 2D (fields u, w, p and markers unchanged) and
//    fills the others from the field: markers of fixed area fill the column bottom-up with its
//    mass, to within a remainder below one marker that is booked and given back to a
//    neighbouring DAM cell (or carried as inflow of a 1D-to-2D interface); u(z) the profile
//    shape of the nearest copied column scaled to the field's u_mean (eq. 25), w from
//    continuity (27), p from eq. (26).
// Interfaces lie on nodes common to both grids (multiples of the slot width, see DomainManager).
#include "granflow/coupling/factory.hpp"
#include "granflow/coupling/subdomain.hpp"

#include <array>
#include <string>
#include <vector>

namespace granflow::coupling {

/// Piecewise-constant depth-averaged state: cell i is [x[i], x[i+1]] with averages h[i], hu[i].
struct ChannelField {
  std::vector<double> x, h, hu;
  /// Averages of h and hu over [a, b]; an interval that is exactly one cell returns that cell's
  /// values unchanged (a kept cell is copied, not recomputed).
  std::array<double, 2> average(double a, double b) const;
  /// Integrals of h and hu over [a, b] [m^2, m^3/s].
  std::array<double, 2> integral(double a, double b) const;
};

/// The field of the parts [first, first + count) (current, accepted states).
ChannelField channel_field(const std::vector<Subdomain>& parts, std::size_t first,
                           std::size_t count);

/// One part of a planned layout.
struct Piece {
  std::string kind;  ///< "1D" or "2D"
  double x0 = 0.0, x1 = 0.0;
};

/// What a rebuild did, for summary.json.
struct ConversionRecord {
  double mass_before = 0.0, mass_after = 0.0;          ///< over [a, b] [m^2]
  double momentum_before = 0.0, momentum_after = 0.0;  ///< int h u_mean dx [m^3/s]
  double remainder = 0.0;  ///< marker remainders of filled 2D columns [m^2]
  double remainder_given_back = 0.0;  ///< of which given to a DAM cell or carried as inflow
  double remainder_to_inflow = 0.0;   ///< of which carried as inflow (not in mass_after)
  /// of which no part could take (a whole channel made 2D: no DAM, no interface inflow);
  /// booked in the coupled model's ledger (CoupledModel::book_unplaced), not in mass_after
  double remainder_unplaced = 0.0;
  /// Pending inflow of a 1D-to-2D interface that vanished with no 2D part downstream to take
  /// it (booked in the coupled model's ledger, CoupledModel::book_unplaced) [m^2].
  double pending_lost = 0.0;
  /// Pending inflow of a vanished 1D-to-2D interface with no 2D part downstream, put back into
  /// the DAM cell just downstream of it (in mass_after) [m^2].
  double pending_to_1d = 0.0;
  /// Mass not accounted for by the move: mass_after + remainder_to_inflow +
  /// remainder_unplaced - mass_before - pending_to_1d (round-off: every remainder and pending
  /// inflow goes into a part or into the ledger).
  double defect() const {
    return mass_after + remainder_to_inflow + remainder_unplaced - mass_before - pending_to_1d;
  }
  int columns_to_2d = 0, columns_to_1d = 0;  ///< 2D-column-sized slots that changed model
  /// The largest |div u| of the rebuilt 2D parts as converted, which the move removes before
  /// the next step (NdamSolver::remove_divergence) [1/s].
  double divergence_removed = 0.0;
};

/// Rebuilds the parts [first, first + count) of `parts` as `plan` (covering the same interval;
/// the parts before and after it stay and are the new parts' neighbours). Collective (2D parts
/// are built on all ranks).
std::vector<Subdomain> rebuild(const std::vector<Subdomain>& parts, std::size_t first,
                               std::size_t count, const std::vector<Piece>& plan,
                               const SubdomainFactory& factory, ConversionRecord& record);

}  // namespace granflow::coupling
