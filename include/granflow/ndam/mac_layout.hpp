#pragma once
// The MAC layout of one N-DAM box: everything a change of the box's extent rebuilds.
//
//  - the grid (grid.hpp) and this rank's x-slab of it, with the neighbour ranks;
//  - the cell flags of the whole box on every rank (the stencils near a slab edge need the
//    neighbours' flags) and the empty-side masks of the Surface cells;
//  - the classification of the unknowns: a cell is a pressure unknown when it is Fluid (with the
//    ghost-fluid surface also a Surface cell whose centre lies below the surface), a face is a
//    velocity unknown when both its cells hold material (Fluid or Surface), or, with the
//    ghost-fluid surface, one is such a Surface cell and the other Empty, and it is not a
//    wall-normal face;
//  - the halo exchange of a Field's ghost columns and the gather/scatter of owned cells.
//
// Numbering: pressure unknown of cell (gi, k) is gi * nz + k (contiguous per slab); the momentum
// system interleaves u and w of a cell as 2 (gi nz + k) and 2 (gi nz + k) + 1.
#include "granflow/ndam/grid.hpp"

#include <mpi.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace granflow::ndam {

class MacLayout {
 public:
  MacLayout() = default;
  /// This rank's slab of `grid` on `comm` (collective only in the sense that every rank builds
  /// its own); every cell Fluid. Throws params::InputError when a rank would get fewer than two
  /// columns. `starts` (optional, ranks + 1 entries): the first column of each rank instead of
  /// the equal split (Slab::from_starts; each rank at least kMinColumns columns).
  MacLayout(MPI_Comm comm, const Grid& grid, bool periodic_x, const std::vector<int>& starts = {});
  /// Columns a rank needs at least in a weighted split: the halo is G = 2 columns deep and
  /// comes from the neighbour's owned columns.
  static constexpr int kMinColumns = 4;

  MPI_Comm comm = MPI_COMM_NULL;
  Grid grid;
  Slab slab;
  int left = MPI_PROC_NULL, right = MPI_PROC_NULL;  ///< neighbour ranks (MPI_PROC_NULL at walls)
  bool periodic = false;                            ///< x-periodic box
  /// The material cells of column 0 are Dirichlet cells of the projection (the pressure of
  /// eq. 26 imposed at a 1D-to-2D interface, InflowPressure::Dirichlet).
  bool dirichlet_inflow_column = false;
  std::vector<CellFlag> flags;            ///< all cells of the box, gi * nz + k
  std::vector<std::uint8_t> empty_mask;   ///< empty_side bits of the Surface cells, gi * nz + k
  /// Marker depth of every column of the box [m] (marker count times marker area over dx),
  /// from the markers of the flags (free surface; empty before the first markers).
  std::vector<double> depth;
  /// 'Surface pressure' = Ghost fluid (NdamConfig::ghost_surface). The Surface cells of
  /// `inside` (material above them, or their centre at least kThetaMin dz below the column's
  /// marker depth) are pressure unknowns like the Fluid cells; p = 0 is imposed where the free
  /// surface crosses the line from such a cell to each Empty neighbour (surface_theta gives
  /// where: a ghost value), and those faces are momentum unknowns (ghost faces). The other
  /// Surface cells, thin ones whose centre lies above (or just below) the surface, stay
  /// Dirichlet cells with the hydrostatic value of their centre; their faces to material cells
  /// are momentum unknowns as in NaSt2D.
  bool ghost_surface = false;
  std::vector<std::uint8_t> inside;  ///< Surface cells that are pressure unknowns, gi * nz + k
  /// 'Surface pressure' = Ghost fluid at walls: the ghost-fluid treatment (pressure unknowns
  /// in Surface cells, ghost faces, the upwind convection and the thin-cell rule next to Empty
  /// cells) only in the columns gi < wall_columns_left and gi >= nx - wall_columns_right, the
  /// columns next to a wall end of the channel; NaSt2D's Surface cells elsewhere. Both 0 with
  /// 'Ghost fluid' means everywhere (ghost_zone_all).
  bool ghost_zone_all = true;
  int wall_columns_left = 0, wall_columns_right = 0;
  bool in_ghost_zone(int gi) const {
    return ghost_zone_all || (wall_columns_left > 0 && gi < wall_columns_left) ||
           (wall_columns_right > 0 && gi >= grid.nx - wall_columns_right);
  }
  /// The smallest distance, in cells, from a pressure unknown's centre to the free surface: a
  /// Surface cell whose centre lies less deep stays a Dirichlet cell (its neighbour below then
  /// sees p = 0 at the surface, as a ghost would place it), and ghost distances are clamped to
  /// [kThetaMin, 1] (the ghost's coefficient c / theta at most 10 times a neighbour's).
  static constexpr double kThetaMin = 0.1;

  long long p_gid(int gi, int k) const { return static_cast<long long>(gi) * grid.nz + k; }
  /// Flag of global cell (gi, k); Obstacle outside the box (walls), wrapped when periodic.
  CellFlag gflag(int gi, int k) const {
    const int nx = grid.nx, nz = grid.nz;
    if (k < 0 || k >= nz) return CellFlag::Obstacle;
    if (periodic) gi = (gi % nx + nx) % nx;
    else if (gi < 0 || gi >= nx) return CellFlag::Obstacle;
    return flags[static_cast<std::size_t>(gi * nz + k)];
  }
  /// Material cell (Fluid or Surface): carries momentum. False outside the box.
  bool fluid(int gi, int k) const {
    const CellFlag f = gflag(gi, k);
    return f == CellFlag::Fluid || f == CellFlag::Surface;
  }
  /// Pressure unknown: a Fluid cell, and with the ghost-fluid surface a Surface cell of
  /// `inside`; the others are Dirichlet cells (Surface: the free-surface value, Empty: 0,
  /// obstacles), and so are the material cells of the inflow column of
  /// InflowPressure::Dirichlet.
  bool p_unknown(int gi, int k) const {
    if (dirichlet_inflow_column && gi == 0 && !periodic && fluid(gi, k)) return false;
    const CellFlag f = gflag(gi, k);
    return f == CellFlag::Fluid ||
           (f == CellFlag::Surface && ghost_surface && !inside.empty() && inside[cell(gi, k)]);
  }
  /// The face between neighbour cells a and b is a ghost face of the ghost-fluid surface: one
  /// is a pressure unknown, the other Empty.
  bool ghost_face(int ga, int ka, int gb, int kb) const {
    if (!ghost_surface) return false;
    const CellFlag fa = gflag(ga, ka), fb = gflag(gb, kb);
    return (fb == CellFlag::Empty && fa == CellFlag::Surface && p_unknown(ga, ka)) ||
           (fa == CellFlag::Empty && fb == CellFlag::Surface && p_unknown(gb, kb));
  }
  /// u(i, k) (local column i) is an unknown: material on both sides, or a ghost face; the faces
  /// at x = 0 and x = L (non-periodic) and all faces touching an obstacle cell are fixed.
  bool u_unknown(int i, int k) const {
    const int gi = slab.i0 + i;
    if (!periodic && (gi < 0 || gi >= grid.nx - 1)) return false;
    return (fluid(gi, k) && fluid(gi + 1, k)) || ghost_face(gi, k, gi + 1, k);
  }
  bool w_unknown(int i, int k) const {
    const int gi = slab.i0 + i;
    if (k < 0 || k >= grid.nz - 1) return false;
    if (!periodic && (gi < 0 || gi >= grid.nx)) return false;
    return (fluid(gi, k) && fluid(gi, k + 1)) || ghost_face(gi, k, gi, k + 1);
  }
  /// Ghost fluid: where the free surface crosses the line from the centre of pressure unknown
  /// (gm, km) to the centre of its Empty neighbour (ge, ke), as a fraction theta of that
  /// distance, in [kThetaMin, 1]. The surface is z = depth(x), the column depths linear
  /// between the columns' centres: above the cell theta = (depth - z_c) / dz; to the side,
  /// where depth(x) falls to z_c between the two centres, else 1/2; below, 1/2.
  double surface_theta(int gm, int km, int ge, int ke) const;
  /// `inside` from the flags, masks and column depths (ghost-fluid surface only), and the
  /// columns' tops (refresh_tops): called after every update of the flags.
  void classify_surface_pressure();

  /// The extent of the material in each column: tops[gi] = 1 + the highest k whose cell is not
  /// Empty (0: the whole column Empty), from the flags (refresh_tops). Every cell above lies in
  /// the Empty region, where no face or cell is an unknown, so the step's loops over a column
  /// stop there instead of testing the flags of the whole box (at 1.3 mm 17 cells of the box
  /// for each material cell).
  std::vector<int> tops;
  void refresh_tops();
  /// tops of global column gi: 0 outside a non-periodic box, wrapped when periodic, nz before
  /// the first refresh_tops (every cell counted).
  int top(int gi) const {
    if (periodic) gi = (gi % grid.nx + grid.nx) % grid.nx;
    else if (gi < 0 || gi >= grid.nx) return 0;
    return tops.empty() ? grid.nz : tops[static_cast<std::size_t>(gi)];
  }
  /// The first row k of local column i from which on the cell (gi, k), its neighbours left,
  /// right, below and above, and so every face of the cell, are Empty: no unknown, no material
  /// neighbour (at most nz).
  int empty_from(int i) const {
    const int gi = slab.i0 + i;
    const int k = std::max({top(gi - 1), top(gi) + 1, top(gi + 1)});
    return k < grid.nz ? k : grid.nz;
  }
  /// Mask of the Empty neighbours of global Surface cell (gi, k) (wrapped when periodic).
  std::uint8_t mask(int gi, int k) const { return empty_mask[cell(gi, k)]; }
  /// Index gi * nz + k of a cell inside the box (wrapped when periodic).
  std::size_t cell(int gi, int k) const {
    const int gw = periodic ? (gi % grid.nx + grid.nx) % grid.nx : gi;
    return static_cast<std::size_t>(gw * grid.nz + k);
  }

  /// Free-surface flags of the whole box from the marker count of every cell (gi * nz + k, all
  /// ranks' columns) by the rule classify_cell (grid.hpp); obstacle cells stay. Writes into
  /// `flags_out` and `mask_out` (which may be this layout's own).
  void classify(const std::vector<double>& counts, std::vector<CellFlag>& flags_out,
                std::vector<std::uint8_t>& mask_out) const;

  /// Fills the G ghost columns of f from the neighbour slabs (periodic wrap included).
  void exchange(Field& f) const;
  /// The ranks' `local` vectors concatenated in rank order, on every rank (collective).
  std::vector<double> gather_columns(const std::vector<double>& local) const;
  /// Owned cells of f on every rank: x-major (gi * nz + k) or z-major (k * nx + gi).
  std::vector<double> gather_cells(const Field& f, bool z_major) const;
  /// The owned cells of f from a global x-major array.
  void scatter_cells(const std::vector<double>& global, Field& f) const;
};

}  // namespace granflow::ndam
