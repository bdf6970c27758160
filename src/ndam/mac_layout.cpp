// The MAC layout of an N-DAM box (mac_layout.hpp): the x-slab of each rank, the cell flags of
// the whole box, the free-surface flag rule applied to marker counts, the halo exchange of ghost
// columns and the gather/scatter of owned cells.
#include "granflow/ndam/mac_layout.hpp"

#include "granflow/params/parameters.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace granflow::ndam {

MacLayout::MacLayout(MPI_Comm c, const Grid& g, bool periodic_x, const std::vector<int>& starts)
    : comm(c), grid(g), periodic(periodic_x) {
  int rank = 0, ranks = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &ranks);
  if (grid.nx < 2 * ranks)
    throw params::InputError("N-DAM: 'Cells x' = " + std::to_string(grid.nx) +
                             " is too few for " + std::to_string(ranks) +
                             " ranks (need >= 2 columns per rank)");
  if (starts.empty()) {
    slab = Slab::split(grid.nx, rank, ranks);
  } else {
    bool ok = static_cast<int>(starts.size()) == ranks + 1 && starts.front() == 0 &&
              starts.back() == grid.nx;
    for (int r = 0; ok && r < ranks; ++r)
      ok = starts[static_cast<std::size_t>(r) + 1] - starts[static_cast<std::size_t>(r)] >=
           kMinColumns;
    if (!ok)  // the callers derive the starts (load_balance.cpp, a checkpoint of this box)
      throw std::logic_error("N-DAM: slab starts do not split " + std::to_string(grid.nx) +
                             " columns over " + std::to_string(ranks) + " ranks");
    slab = Slab::from_starts(starts, rank);
  }
  left = rank > 0 ? rank - 1 : (periodic ? ranks - 1 : MPI_PROC_NULL);
  right = rank < ranks - 1 ? rank + 1 : (periodic ? 0 : MPI_PROC_NULL);
  flags.assign(static_cast<std::size_t>(grid.nx * grid.nz), CellFlag::Fluid);
  empty_mask.assign(flags.size(), 0);
}

// Every rank holds the counts of the whole box, so every rank derives the same flags; a cell
// outside the box counts as not empty (walls, gate, outflow, top), across a periodic side as the
// wrapped cell.
void MacLayout::classify(const std::vector<double>& counts, std::vector<CellFlag>& flags_out,
                         std::vector<std::uint8_t>& mask_out) const {
  const int nx = grid.nx, nz = grid.nz;
  auto empty = [&](int gi, int k) {
    if (k < 0 || k >= nz) return false;
    if (periodic) gi = (gi % nx + nx) % nx;
    else if (gi < 0 || gi >= nx) return false;
    const auto q = static_cast<std::size_t>(gi * nz + k);
    return flags[q] != CellFlag::Obstacle && !(counts[q] > 0.0);
  };
  std::vector<CellFlag> out(flags.size());
  std::vector<std::uint8_t> mask(flags.size(), 0);
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k) {
      const auto q = static_cast<std::size_t>(gi * nz + k);
      if (flags[q] == CellFlag::Obstacle) {
        out[q] = CellFlag::Obstacle;
        continue;
      }
      if (!(counts[q] > 0.0)) {  // classify_cell's Empty, without looking at the neighbours
        out[q] = CellFlag::Empty;
        continue;
      }
      out[q] = classify_cell(counts[q] > 0.0, empty(gi - 1, k), empty(gi + 1, k),
                             empty(gi, k - 1), empty(gi, k + 1), mask[q]);
    }
  flags_out = std::move(out);
  mask_out = std::move(mask);
}

void MacLayout::refresh_tops() {
  const int nx = grid.nx, nz = grid.nz;
  tops.assign(static_cast<std::size_t>(nx), 0);
  for (int gi = 0; gi < nx; ++gi)
    tops[static_cast<std::size_t>(gi)] = column_top(&flags[static_cast<std::size_t>(gi * nz)], nz);
}

void MacLayout::classify_surface_pressure() {
  refresh_tops();
  inside.assign(flags.size(), 0);
  if (!ghost_surface || depth.empty()) return;
  const int nx = grid.nx, nz = grid.nz;
  const double dz = grid.dz();
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k) {
      const auto q = static_cast<std::size_t>(gi * nz + k);
      if (flags[q] != CellFlag::Surface || !in_ghost_zone(gi)) continue;
      // A Surface cell with material above it is inside; one under an Empty cell holds the
      // surface, at the column's depth, and is inside when its centre lies at least
      // kThetaMin dz below it.
      const bool top_empty = (empty_mask[q] & empty_side::Top) != 0;
      inside[q] =
          !top_empty || depth[static_cast<std::size_t>(gi)] - (k + 0.5) * dz >= kThetaMin * dz;
    }
}

double MacLayout::surface_theta(int gm, int km, int ge, int ke) const {
  const int nx = grid.nx;
  auto h = [&](int gi) {
    const int gw = periodic ? (gi % nx + nx) % nx : gi;
    return depth[static_cast<std::size_t>(gw)];
  };
  const double dz = grid.dz(), zc = (km + 0.5) * dz;
  double theta = 0.5;
  if (ge == gm) {
    if (ke > km) theta = (h(gm) - zc) / dz;
  } else {
    // the level set phi = z - depth(x) at the two centres; the surface where it changes sign
    const double fm = zc - h(gm), fe = zc - h(ge);
    if (fm < 0.0 && fe > 0.0) theta = fm / (fm - fe);
  }
  return std::clamp(theta, kThetaMin, 1.0);
}

// Ghost columns from the neighbour slabs (periodic wrap included); G columns of nz + 2 values
// are contiguous in a Field.
void MacLayout::exchange(Field& f) const {
  const int G = Field::G, nxl = slab.nx_local;
  const int n = G * (grid.nz + 2);
  // send my first G columns to the left, receive my right ghosts from the right
  MPI_Sendrecv(f.column(0), n, MPI_DOUBLE, left, 11, f.column(nxl), n, MPI_DOUBLE, right, 11,
               comm, MPI_STATUS_IGNORE);
  // send my last G columns to the right, receive my left ghosts from the left
  MPI_Sendrecv(f.column(nxl - G), n, MPI_DOUBLE, right, 12, f.column(-G), n, MPI_DOUBLE, left,
               12, comm, MPI_STATUS_IGNORE);
}

std::vector<double> MacLayout::gather_columns(const std::vector<double>& local) const {
  const int n = static_cast<int>(local.size());
  std::vector<int> counts(static_cast<std::size_t>(slab.ranks)), displs(counts.size());
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  int total = 0;
  for (std::size_t r = 0; r < counts.size(); ++r) {
    displs[r] = total;
    total += counts[r];
  }
  std::vector<double> all(static_cast<std::size_t>(total));
  MPI_Allgatherv(local.data(), n, MPI_DOUBLE, all.data(), counts.data(), displs.data(),
                 MPI_DOUBLE, comm);
  return all;
}

std::vector<double> MacLayout::gather_cells(const Field& f, bool z_major) const {
  const int nz = grid.nz, nx = grid.nx;
  std::vector<double> local;
  local.reserve(static_cast<std::size_t>(slab.nx_local * nz));
  for (int i = 0; i < slab.nx_local; ++i)
    for (int k = 0; k < nz; ++k) local.push_back(f(i, k));
  auto all = gather_columns(local);
  if (!z_major) return all;
  std::vector<double> zm(all.size());
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k)
      zm[static_cast<std::size_t>(k * nx + gi)] = all[static_cast<std::size_t>(gi * nz + k)];
  return zm;
}

void MacLayout::scatter_cells(const std::vector<double>& global, Field& f) const {
  const int nz = grid.nz;
  for (int i = 0; i < slab.nx_local; ++i)
    for (int k = 0; k < nz; ++k)
      f(i, k) = global[static_cast<std::size_t>((slab.i0 + i) * nz + k)];
}

}  // namespace granflow::ndam
