#pragma once
// The staggered marker-and-cell (MAC) grid of the N-DAM on the box [0, Lx] x [0, Lz], x along
// the slope, z normal to it (paper section 2.3, NaSt2D lineage):
//
//        w(i,k)                 p(i,k), nu_eff(i,k), flag(i,k)  at the cell centre
//     +----^----+               u(i,k)  on the RIGHT face of cell (i,k)  x = (i+1) dx
//     |         |               w(i,k)  on the TOP face of cell (i,k)    z = (k+1) dz
//     |  p(i,k) > u(i,k)        u(-1,k) is the left wall face x = 0, w(i,-1) the bottom wall
//     |         |               face z = 0.
//     +---------+
//
// MPI: the columns are split into x-slabs, one per rank. A rank owns the columns
// [i0, i0 + nx_local) and stores G ghost columns on each side (filled from the neighbour ranks,
// periodically wrapped, or from the boundary conditions) and one ghost row below and above.
// Every face is owned by exactly one rank: the one that owns the cell to its left (u) or the
// cell below it (w).
#include <cstddef>
#include <cstdint>
#include <vector>

namespace granflow::ndam {

/// Cell flags (NaSt2D): Obstacle (rigid), Fluid (material, all four neighbours hold material or
/// are walls), Surface (material next to at least one Empty cell), Empty (no material).
enum class CellFlag : int { Obstacle = 0, Fluid = 1, Surface = 2, Empty = 3 };

/// Bits of the empty-side mask of a Surface cell (NaSt2D's surface cell types).
namespace empty_side {
constexpr std::uint8_t Left = 1, Right = 2, Bottom = 4, Top = 8;
}

/// The free-surface flag rule, in one place (MarkerSet::update_flags and the N-DAM's layout both
/// use it): a cell without markers is Empty; a cell with markers is Surface when one of its four
/// neighbours is Empty, with the mask of those sides, else Fluid. The caller says which
/// neighbours are empty; outside the box (walls, gate, outflow, top) counts as not empty, a
/// periodic side as the wrapped cell. Obstacle cells are left to the caller.
inline CellFlag classify_cell(bool has_markers, bool empty_left, bool empty_right,
                              bool empty_bottom, bool empty_top, std::uint8_t& mask) {
  mask = 0;
  if (!has_markers) return CellFlag::Empty;
  if (empty_left) mask |= empty_side::Left;
  if (empty_right) mask |= empty_side::Right;
  if (empty_bottom) mask |= empty_side::Bottom;
  if (empty_top) mask |= empty_side::Top;
  return mask ? CellFlag::Surface : CellFlag::Fluid;
}

/// One above the highest cell of a column that is not Empty (0: the whole column Empty), for
/// the column's nz flags `col` (bottom first): every cell from there up is Empty.
inline int column_top(const CellFlag* col, int nz) {
  int k = nz;
  while (k > 0 && col[k - 1] == CellFlag::Empty) --k;
  return k;
}

struct Grid {
  int nx = 32, nz = 32;          ///< global cells
  double lx = 1.0, lz = 1.0;     ///< box [m]
  double dx() const { return lx / nx; }
  double dz() const { return lz / nz; }
  /// The deepest a column's material may be, with its surface in the lower half of the top
  /// row: Height - dz / 2. Deeper stops a free-surface run (NdamSolver::check); an initial
  /// layer or a gate opening that deep is refused before it (NdamConfig::from_parameters).
  double material_limit() const { return lz - 0.5 * dz(); }
};

/// This rank's part of the grid.
struct Slab {
  int rank = 0, ranks = 1;
  int i0 = 0;        ///< first owned global column
  int nx_local = 0;  ///< owned columns
  /// Balanced contiguous split of nx columns over `ranks` ranks.
  static Slab split(int nx, int rank, int ranks) {
    Slab s;
    s.rank = rank;
    s.ranks = ranks;
    const int base = nx / ranks, extra = nx % ranks;
    s.nx_local = base + (rank < extra ? 1 : 0);
    s.i0 = rank * base + (rank < extra ? rank : extra);
    return s;
  }
  /// The slab of `rank` for the first columns `starts` of the ranks (ranks + 1 entries,
  /// starts[0] = 0, starts[ranks] = nx, increasing): a split weighted by the work of the
  /// columns (load_balance.cpp).
  static Slab from_starts(const std::vector<int>& starts, int rank) {
    Slab s;
    s.rank = rank;
    s.ranks = static_cast<int>(starts.size()) - 1;
    s.i0 = starts[static_cast<std::size_t>(rank)];
    s.nx_local = starts[static_cast<std::size_t>(rank) + 1] - s.i0;
    return s;
  }
};

/// A cell-indexed array of one rank with G ghost columns and one ghost row on each side;
/// (i, k) with i in [-G, nx_local + G), k in [-1, nz].
class Field {
 public:
  static constexpr int G = 2;
  Field() = default;
  Field(int nx_local, int nz, double v = 0.0)
      : nxl_(nx_local), nz_(nz),
        a_(static_cast<std::size_t>((nx_local + 2 * G) * (nz + 2)), v) {}
  std::size_t index(int i, int k) const {
    return static_cast<std::size_t>((i + G) * (nz_ + 2) + (k + 1));
  }
  double& operator()(int i, int k) { return a_[index(i, k)]; }
  double operator()(int i, int k) const { return a_[index(i, k)]; }
  double* column(int i) { return &a_[index(i, -1)]; }  ///< nz + 2 values of column i
  const double* column(int i) const { return &a_[index(i, -1)]; }
  int nx_local() const { return nxl_; }
  int nz() const { return nz_; }
  std::vector<double>& data() { return a_; }
  const std::vector<double>& data() const { return a_; }
  void fill(double v) { a_.assign(a_.size(), v); }

 private:
  int nxl_ = 0, nz_ = 0;
  std::vector<double> a_;
};

}  // namespace granflow::ndam
