#pragma once
// Free surface of the N-DAM by marker particles (marker-and-cell method; paper section 2.3,
// NaSt2D lineage: Griebel, Dornseifer, Neunhoeffer 1998, ch. 7).
//
// Markers are massless points that carry no state but their position. They
//  - are seeded n_x x n_z per cell on a regular sub-lattice (deterministic positions
//    ((a + 1/2) dx / n_x, (b + 1/2) dz / n_z) inside each cell), so each marker stands for the
//    area A_m = dx dz / (n_x n_z) of material;
//  - are injected at an inflow opening on the left side (x = 0, 0 <= z < h_in) with the
//    inflow face velocities, one strip per sub-lattice row, each strip with a fractional
//    accumulator so that the injected area equals int_0^t int_0^h_in u dz dt to within one
//    marker per row, with no drift; each at a (hashed) random height of its strip, so that
//    the strips form no material lines;
//  - are advected with Heun's method (explicit trapezoidal RK2, second order in time) in the
//    staggered velocity interpolated bilinearly as in NaSt2D (u on the grid shifted by dz/2 in
//    z, w on the grid shifted by dx/2 in x);
//  - are kept inside rigid walls by reflection, removed at an open outflow, wrapped at periodic
//    sides, kept out of obstacle cells;
//  - migrate between the MPI x-slabs of the grid (Slab) after each move.
// From the markers the module derives the cell flags (Fluid, Surface with the bitmask of its
// empty sides, Empty; Obstacle kept), the flow depth h of each column, the depth-averaged
// velocity u_mean of eq. (21), and the marker area for the mass balance.
//
// Conventions are those of grid.hpp: local column i of a rank is global column slab.i0 + i;
// u(i,k) lives on the RIGHT face of cell (i,k) at x = (i0 + i + 1) dx, z = (k + 1/2) dz; w(i,k)
// on its TOP face at x = (i0 + i + 1/2) dx, z = (k + 1) dz. Owned-cell arrays (flags, counts)
// are indexed i * nz + k with i in [0, nx_local), as the N-DAM solver stores its flags.
//
// Collective calls (every rank of the communicator must call them): the constructor,
// set_obstacles, advect, migrate, update_flags, mass, global_count, gather. The others are
// rank-local.
#include "granflow/ndam/grid.hpp"

#include <mpi.h>

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace granflow::ndam {

/// What a side of the box does to markers. Index the array in MarkerConfig by side:
/// 0 left (x = 0), 1 right (x = Lx), 2 bottom (z = 0), 3 top (z = Lz).
enum class MarkerBoundary {
  Wall,      ///< rigid: a marker that crosses is reflected back inside
  Inflow,    ///< left side only: markers are injected by inject(); a crossing one is reflected
  Outflow,   ///< open: a marker that crosses is removed (and counted in `removed`)
  Periodic   ///< left and right together: x wraps
};

/// Flow depth of a column from its markers (see depth()).
enum class DepthMethod {
  Count,  ///< h = A_m N_col / dx: the marker area of the column per unit width (default)
  Top     ///< h = z of the n_x-th highest marker of the column + dz / (2 n_z)
};

struct MarkerConfig {
  int per_cell_x = 4;  ///< markers per cell along x (n_x)
  int per_cell_z = 4;  ///< markers per cell along z (n_z)
  std::array<MarkerBoundary, 4> sides{MarkerBoundary::Wall, MarkerBoundary::Wall,
                                      MarkerBoundary::Wall, MarkerBoundary::Wall};
  DepthMethod depth = DepthMethod::Count;
};

struct Marker {
  double x = 0.0, z = 0.0;  ///< position [m], 0 <= x < Lx, 0 <= z < Lz
  long long id = 0;         ///< unique over all ranks (seeding: from the cell; injection: a counter)
};

/// Ids of markers that a box did not seed itself (injected at the gate, or filled into a column
/// by the domain manager's conversion) are kInjectedIdBase + the box's counter
/// (MarkerState::inject_next, a count from 0, well below 2^53 so that a checkpoint's double
/// holds it exactly).
inline constexpr long long kInjectedIdBase = 1LL << 62;

/// Global marker bookkeeping (areas in m^2 of the x-z plane, i.e. m^3 per metre of width).
struct MarkerMass {
  long long count = 0;     ///< markers now
  long long injected = 0;  ///< injected since construction
  long long removed = 0;   ///< removed at outflows or by remove_if since construction
  double area = 0.0, injected_area = 0.0, removed_area = 0.0;  ///< the counts times A_m
  double pending_area = 0.0;  ///< the inflow rows' fractions of a marker (accumulators) times A_m
};

/// Everything a checkpoint needs to restore this rank's marker set bit for bit.
struct MarkerState {
  std::vector<Marker> markers;
  std::vector<double> inflow_accumulators;
  long long seed_base = 0, inject_next = 0, injected = 0, removed = 0, migrated = 0;
};

/// Per owned column: depth, depth-averaged u (eq. 21) and w (for eps = |w_mean| / |u_mean|).
struct ColumnProfile {
  std::vector<double> x, h, u_mean, w_mean;
};

class MarkerSet {
 public:
  /// `grid` and `slab` as the N-DAM solver uses them on `comm` (slab.rank/ranks must match).
  MarkerSet(MPI_Comm comm, const Grid& grid, const Slab& slab, const MarkerConfig& cfg);

  // --- geometry -----------------------------------------------------------------------------
  double spacing_x() const { return dx_ / cfg_.per_cell_x; }
  double spacing_z() const { return dz_ / cfg_.per_cell_z; }
  double marker_area() const { return spacing_x() * spacing_z(); }
  const MarkerConfig& config() const { return cfg_; }

  // --- seeding and removal (rank-local; call on every rank with the same arguments) ----------
  /// Adds the sub-lattice markers of the owned cells whose position satisfies inside(x, z)
  /// (cells flagged Obstacle by set_obstacles are skipped). Returns the markers added here.
  long long seed(const std::function<bool(double x, double z)>& inside);
  /// seed() of the layer z < h(x).
  long long seed_depth(const std::function<double(double x)>& h);
  /// The rectangle [xa, xb) x [0, h) (box coordinates) with its area to within one marker per
  /// partly covered marker row and column: each marker stands for its sub-cell of the lattice,
  /// fully covered ones are seeded, and of those that the rectangle covers by a fraction c (the
  /// top row, the two end columns) every marker whose index j along that row or column has
  /// floor((j + 1) c + 1/2) > floor(j c + 1/2), so that a row of n such markers holds n c of
  /// them to within one, the same on any number of ranks. seed()'s rule (a marker inside when its centre is)
  /// rounds the depth to whole marker rows: 1 mm in rows of 2.5 mm seeded nothing.
  long long seed_rectangle(double xa, double xb, double h);
  /// Removes this rank's markers with pred(x, z) (counted in `removed`). Returns the number.
  long long remove_if(const std::function<bool(double x, double z)>& pred);
  /// Takes back up to n markers through the inflow side: those of this rank nearest to x = 0 in
  /// the first column (material that flows back out through an inflow face). They leave the
  /// injected count, the inflow's net transfer, not the removed one (the outflow's). Returns how
  /// many this rank took (0 on ranks that do not own the first column).
  long long take_back(long long n);
  /// Removes all markers and resets the counters and inflow accumulators.
  void clear();

  // --- inflow ---------------------------------------------------------------------------------
  /// Injects the markers that entered through the inflow opening 0 <= z < h_in of the left
  /// side during dt. Row r of the marker sub-lattice covers the strip [r s_z, min((r+1) s_z,
  /// h_in)] of height s_r; its inflow q_r (m^2/s) adds q_r dt / A_m to the row's accumulator,
  /// and every whole unit becomes a marker at x = the distance travelled at the strip's mean
  /// velocity q_r / s_r since it crossed x = 0 during the step and at a uniformly distributed
  /// height z of the strip (from a hash of the marker's id, so reproducible on any number of
  /// ranks and across restarts; strip centres would make every strip a material line that a
  /// decelerating flow spreads into empty cells, see inject_rows). So the
  /// injected area is int q dt to within one marker per row, without drift, for any dt
  /// sequence. Strips with q_r <= 0 inject nothing. Only the rank owning column 0 acts (the
  /// others return at once); the left side must be MarkerBoundary::Inflow. Call after advect().
  ///
  /// This overload: q_r = int_strip u_in(z) dz (3-point Gauss per strip, exact for profiles of
  /// degree <= 5), so the total is int_0^h_in u_in dz = h_in u_mean.
  ///
  /// volume >= 0: the step's inflow volume is prescribed (an inflow series: the integral of
  /// h u over the step); the strips' fluxes are scaled to it. Strips that closed hand their
  /// remainders to the highest open row, and a closed opening (h_in <= 0) turns the rows'
  /// remainders into markers (their rounded sum), so that a hydrograph's volume enters to
  /// within half a marker.
  void inject(double dt, double h_in, const std::function<double(double z)>& u_in,
              double volume = -1.0);
  /// This overload: q_r = u_face[k] s_r with k the cell row of the strip; u_face[k] is the mean
  /// inflow velocity over the OPENING part of the face of row k (for a face only partly below
  /// h_in this differs from a face value u(-1,k) that carries the flux u(-1,k) dz: pass
  /// u(-1,k) dz / (opening part of the face) there).
  void inject(double dt, double h_in, const std::vector<double>& u_face, double volume = -1.0);
  /// The fractional accumulators of the injection rows (for checkpoints and tests).
  const std::vector<double>& inflow_accumulators() const { return acc_; }
  /// The gate's pending markers (the rows' fractions) on this rank: the sum of the accumulators
  /// on the rank that injects (column 0), 0 on the others, whose copies from a state import
  /// (restart, rebuild, move) never change; sum over the ranks for the whole.
  double inflow_pending_markers() const;
  void set_inflow_accumulators(const std::vector<double>& a) { acc_ = a; }

  // --- advection ------------------------------------------------------------------------------
  /// Moves every marker over [t, t + dt] with Heun's method
  ///   x* = x + dt v^n(x),   x^{n+1} = x + dt/2 (v^n(x) + v^{n+1}(x*)),
  /// v^n from (u0, w0), v^{n+1} from (u1, w1) (pass the same fields twice for a frozen velocity).
  /// The fields need their ghost columns and ghost rows filled (neighbour ranks, periodic wrap,
  /// and the wall conditions, as the solver does before its own stencils). x* and x^{n+1} are
  /// reflected at walls; a marker whose new position lies in an obstacle cell moves only
  /// along x, or only along z, or stays where it was (first of these that is free). Then
  /// outflow removal, periodic wrap and migrate(). Requires |v| dt < dx (CFL <= 1): a stage
  /// that leaves the ghost columns throws std::runtime_error.
  void advect(double dt, const Field& u0, const Field& w0, const Field& u1, const Field& w1);
  void advect(double dt, const Field& u, const Field& w) { advect(dt, u, w, u, w); }
  /// Velocity (u, w) interpolated at (x, z) as advect() does (x within one column of the slab).
  std::array<double, 2> velocity(const Field& u, const Field& w, double x, double z) const;
  /// Hands markers outside this rank's slab to the neighbour ranks until each rank holds
  /// exactly the markers of its columns (pack, MPI_Sendrecv, unpack; repeated while any moves).
  void migrate();
  /// Fills sampling voids (collective; every rank passes the same list): for each move
  /// {donor gi, donor k, target gi, target k} the donor cell's marker nearest to the target
  /// cell's centre (ties: the smaller id) is put into the target cell, at the point of the cell
  /// nearest to where it was, a quarter of the marker spacing inside; the rank that holds the
  /// donor's column moves it, then migrate(). The area moves, none is made or lost.
  void relocate(const std::vector<std::array<int, 4>>& moves);

  // --- obstacles and flags --------------------------------------------------------------------
  /// Records the Obstacle cells of `flags` (owned cells, i * nz + k) with the neighbours' ghost
  /// columns. Obstacles are static until the next call.
  void set_obstacles(const std::vector<CellFlag>& flags);
  /// Markers per owned cell (i * nz + k).
  std::vector<int> cell_counts() const;
  /// Sets the flags of the owned cells (size nx_local * nz): cells flagged Obstacle (in `flags`
  /// or by set_obstacles) stay Obstacle; the others by the free-surface rule classify_cell
  /// (grid.hpp), with the neighbours' emptiness across the slab edges from the neighbour ranks. If `empty_sides` is given it receives per cell the mask of
  /// empty_side bits of its Empty neighbours (0 unless Surface).
  void update_flags(std::vector<CellFlag>& flags, std::vector<std::uint8_t>* empty_sides = nullptr) const;

  // --- depth, profiles, mass ------------------------------------------------------------------
  /// Flow depth of each owned column (config().depth):
  ///  Count: h = A_m N / dx with N the markers of the column (area-equivalent depth; sum h dx
  ///         is the marker area, one stray marker changes h by only s_z / n_x);
  ///  Top:   h = z_(n_x) + s_z / 2 with z_(n_x) the n_x-th highest marker (the top of the
  ///         highest complete marker row; up to n_x - 1 stray markers above are ignored);
  ///         Count is used when the column holds fewer than n_x markers.
  std::vector<double> depth() const;
  /// Depth and the depth averages (eq. 21) u_mean = 1/h int_0^h u dz, likewise w_mean, of each
  /// owned column at its centre x. u and w at the cell centre are the means of the two faces;
  /// the integral takes full cells below h and the fraction (h - k dz) / dz of the cell
  /// containing h. Columns with h = 0 report 0. `h`, if given, is depth() of these markers
  /// (the owned columns), already known to the caller: it is not counted again.
  ColumnProfile profile(const Field& u, const Field& w,
                        const std::vector<double>* h = nullptr) const;
  /// Global counts and areas (collective).
  MarkerMass mass() const;
  long long global_count() const;

  // --- access ---------------------------------------------------------------------------------
  const std::vector<Marker>& markers() const { return m_; }
  /// Adds markers as given (ids must be unique); they are migrated by the next migrate().
  void add(const std::vector<Marker>& ms) { m_.insert(m_.end(), ms.begin(), ms.end()); }
  /// Markers this rank has sent to its neighbours since construction (statistics).
  long long migrated() const { return migrated_; }
  /// All markers of all ranks, sorted by id, on every rank (collective; tests and output).
  std::vector<Marker> gather() const;
  /// This rank's state for a checkpoint, and its restoration (same grid, slab and config).
  MarkerState save() const;
  void load(const MarkerState& s);

 private:
  int global_column(double x) const;  // floor(x / dx) clamped to [0, nx)
  int cell_row(double z) const;       // floor(z / dz) clamped to [0, nz)
  bool obstacle_at(double x, double z) const;  // x within G columns of the slab
  void wall(double& x, double& z) const;       // reflect at wall/inflow sides
  void inject_rows(double dt, double h_in,
                   const std::function<double(double zb, double zt)>& strip_flux, double volume);
  // Sends the n values `first` (of this rank's first columns) to the left neighbour and `last`
  // to the right one; receives the left neighbour's last columns into ghost_left and the right
  // one's first columns into ghost_right; where there is no neighbour, fills with `fill`.
  void halo(const std::vector<int>& first, const std::vector<int>& last,
            std::vector<int>& ghost_left, std::vector<int>& ghost_right, int fill) const;

  MPI_Comm comm_;
  Grid grid_;
  Slab slab_;
  MarkerConfig cfg_;
  double dx_, dz_;
  int left_ = MPI_PROC_NULL, right_ = MPI_PROC_NULL;  // neighbour ranks
  std::vector<Marker> m_;
  std::vector<char> obst_;  // (nx_local + 2G) * nz, column i + G
  bool has_obstacles_ = false;  // an obstacle cell in obst_ (set_obstacles)
  std::vector<double> acc_;  // injection row accumulators
  /// seed() and seed_rectangle(): the lattice positions that `keep` accepts (lattice column
  /// and row over the whole box, the position's centre)
  long long seed_lattice(
      const std::function<bool(long long jx, long long jz, double x, double z)>& keep);
  long long seed_base_ = 0, inject_next_ = 0;
  long long injected_ = 0, removed_ = 0, migrated_ = 0;  // this rank's counters
};

/// The sides of a box through which an Empty region reaches the atmosphere: rows k >= left_from
/// of the left side, k >= right_from of the right side (0: every row, an outflow; kClosed: no
/// row, a wall or a gate). A 2D part fed by a 1D part opens its left side above the 1D layer.
struct VoidSides {
  static constexpr int kClosed = 1 << 30;
  int left_from = kClosed;
  int right_from = kClosed;
};

/// Holes in the material (issue 11): the Empty cells of `flags` (the whole box, gi * nz + k)
/// that enclosed voids are made of, i.e. whose 4-connected region of Empty cells reaches neither
/// the top row of the box (the atmosphere above the flow) nor an open part of a side (`sides`).
/// Such a cell has material or a wall on every path out; in an incompressible free-surface flow
/// it is a marker-sampling artefact, and its p = 0 Dirichlet value cuts the pressure of the
/// material around it. The air under a free jet's overhang reaches the atmosphere around the
/// jet and is not a hole. Returns {gi, k} of each hole cell.
std::vector<std::array<int, 2>> enclosed_voids(const std::vector<CellFlag>& flags, int nx, int nz,
                                               VoidSides sides);
/// The moves that fill the enclosed voids (enclosed_voids with `sides`) of a sampling with
/// `counts` markers per cell (whole box, gi * nz + k; `flags` its cell flags): each void cell,
/// in the order enclosed_voids lists them, takes one marker from the 4-neighbour with the most
/// markers that keeps at least one (ties: below, left, right, above), else from the cell of the
/// second ring with the most, reached through a 4-neighbour that holds markers and is not an
/// Obstacle (ties: the diagonals, lower before upper, left before right, then below, left,
/// right and above two cells away), so a void ringed by single markers takes from beyond them
/// and a larger void fills from its rim; counts are updated move by move. A void with no such
/// donor is left. Returns {donor gi, donor k, target gi, target k} (MarkerSet::relocate).
/// The depth of a layer entering through a side as a first open row: the rows k >= the result
/// have their bottom k dz at or above `depth` (to 1e-9 of a row), at most nz.
int first_row_above(double depth, double dz, int nz);
std::vector<std::array<int, 4>> void_fill_moves(std::vector<double> counts,
                                                const std::vector<CellFlag>& flags, int nx,
                                                int nz, VoidSides sides);
/// The same with each side either open on every row (an outflow) or closed.
inline std::vector<std::array<int, 2>> enclosed_voids(const std::vector<CellFlag>& flags, int nx,
                                                      int nz, bool open_left = false,
                                                      bool open_right = false) {
  return enclosed_voids(flags, nx, nz,
                        VoidSides{open_left ? 0 : VoidSides::kClosed,
                                  open_right ? 0 : VoidSides::kClosed});
}

}  // namespace granflow::ndam
