// N-DAM free surface: marker-and-cell (paper section 2.3; NaSt2D, Griebel et al. 1998, ch. 7).
//
// The material is the set of marker particles (markers.hpp). From their counts every cell is
// Fluid, Surface (material next to an Empty cell, with the mask of its empty sides) or Empty
// (flag rule classify_cell, grid.hpp). At the surface the stress is free:
//   normal stress   p = 2 nu_eff n.D.n in a Surface cell (n.D.n of its empty sides), p = 0 in
//                   Empty cells, plus the hydrostatic offset of the marker depth inside the cell;
//   tangential      zero shear stress at corners touching an Empty cell (momentum.cpp);
//   continuity      div u = 0 in every Surface cell, the empty faces taking the remainder.
// The depth h and the depth-averaged u of eq. (21) of each column come from the markers.
#include "stencil.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace granflow::ndam {

// The empty-side face (c, i, k) of a Surface cell as its opposite face plus the lagged
// difference; a Ref with a = 0 and gid = -1 (and b = 0) when the face is not of that kind.
NdamSolver::Ref NdamSolver::surface_face_ref(Comp c, int i, int k) const {
  const int gi = mac_.slab.i0 + i;
  // the two cells of the face: (gi, k) and (gi + 1, k) for u, (gi, k) and (gi, k + 1) for w
  const int g2 = c == U ? gi + 1 : gi, k2 = c == U ? k : k + 1;
  const bool m1 = mac_.fluid(gi, k), m2 = mac_.fluid(g2, k2);
  if (m1 == m2) return Ref{};
  const int gs = m1 ? gi : g2, ks = m1 ? k : k2;  // the Surface cell
  if (mac_.gflag(gs, ks) != CellFlag::Surface) return Ref{};
  const std::uint8_t mask = mac_.mask(gs, ks);
  std::uint8_t opp;
  int io = i, ko = k;
  if (c == U) {
    opp = m1 ? empty_side::Left : empty_side::Right;
    io = m1 ? i - 1 : i + 1;
  } else {
    opp = m1 ? empty_side::Bottom : empty_side::Top;
    ko = m1 ? k - 1 : k + 1;
  }
  if (mask & opp) return Ref{};
  // The opposite face is one column beyond (i, k) for u: callers evaluate this only for
  // columns whose neighbours are in the halo (fill_velocity_ghosts leaves the outermost ghost
  // columns to the exchange), so reading beyond it is a bug, not a boundary case.
  if (io < -Field::G || io >= mac_.slab.nx_local + Field::G)
    throw std::logic_error("N-DAM: free-surface face (" + std::to_string(gi) + ", " +
                           std::to_string(k) + ") follows a face outside the halo");
  Ref m = ref(c, io, ko);
  const Field& f = c == U ? u_ : w_;
  m.b += f(i, k) - f(io, ko);
  return m;
}

// Dirichlet values of the projection increment: Surface cells go to the normal-stress value
// (surface_pressure), Empty cells stay at p = 0, and with InflowPressure::Dirichlet the material
// cells of the inflow column take eq. (26). The pressure matrix follows the flags.
void NdamSolver::surface_conditions() {
  Field ps(mac_.slab.nx_local, cfg_.grid.nz);
  surface_pressure(ps);
  p_dir_.fill(0.0);
  for (int i = 0; i < mac_.slab.nx_local; ++i)
    for (int k = 0; k < cfg_.grid.nz; ++k) {
      const CellFlag f = mac_.gflag(mac_.slab.i0 + i, k);
      if (f == CellFlag::Surface || f == CellFlag::Empty) p_dir_(i, k) = ps(i, k) - p_(i, k);
      if (cfg_.inflow_pressure == InflowPressure::Dirichlet && mac_.slab.i0 + i == 0 &&
          mac_.fluid(0, k))
        p_dir_(i, k) = inflow_p26(k) - p_(i, k);  // eq. (26) as the Dirichlet value
    }
  mac_.exchange(p_dir_);
  assemble_pressure_if_flags_changed();
}

// Markers of the step (the tentative set): Heun's method in u^n and u^{n+1}, both with the
// free-surface values of the flags of t^n; then the gate injects, and the new flags follow from
// the new marker counts (update_flags).
void NdamSolver::advect_markers(double dt) {
  *markers_new_ = *markers_;
  markers_new_->advect(dt, u_, w_, u_new_, w_new_);
  inject_markers(dt, *markers_new_);
  // Back-flow through a 1D-to-2D interface: where the 2D side is deeper than the DAM, the DAM's
  // flux at x_IF turns negative (its ghosts read the 2D columns) and the DAM gains mass that its
  // ledger says it took from the 2D side. The inflow carries that as a negative owed mass; here
  // the 2D side gives it up, the whole markers of it nearest to the face (before, nothing was
  // taken and the debt grew: a 2D column collapsing into a DAM made 92 % of its mass, and the
  // ledger, counting the debt as negative pending mass, still closed).
  // The debt is what the two pots hold together: the DAM's averaging terms (inflow_held_) are
  // one-signed while the DAM's end deepens under a back-flow, so they count too.
  if (inflow_mass_ && inflow_owed_new_ + inflow_held_new_ < 0.0) {
    const double a = markers_new_->marker_area();
    const auto want = static_cast<long long>(std::floor(-(inflow_owed_new_ + inflow_held_new_) / a));
    if (want > 0) {
      long long got = markers_new_->take_back(want), all = 0;
      MPI_Allreduce(&got, &all, 1, MPI_LONG_LONG, MPI_SUM, comm_);
      // what was given up settles the owed mass first, the held pool with the rest
      const double given = a * static_cast<double>(all);
      const double to_owed = std::clamp(-inflow_owed_new_, 0.0, given);
      inflow_owed_new_ += to_owed;
      inflow_held_new_ += given - to_owed;
    }
  }
  if (const long long n = fill_marker_voids(*markers_new_, &marker_counts_new_); n > 0) {
    stats_.marker_void_fills += n;
    ++stats_.marker_void_steps;
  }
  marker_mass_new_ = markers_new_->mass();
}

// Voids of the marker sampling (issue 11 item 3). A cell without markers whose Empty region
// reaches neither the atmosphere nor an open side (ndam::enclosed_voids: material, the bed or a
// wall on every path out) is a hole: its Dirichlet p = 0 cuts the pressure of the material
// around it (a deposit's wall-foot pressure read 0), although in an incompressible flow the
// material is there and only its sampling is not. Markers carry a fixed area and are material
// points, so a stretching flow spreads them apart: the top of a slumping column (its top
// layer stretched several times along x), or material injected fast that comes to rest (rows
// spread apart normal to the flow). Each such cell takes one marker from its neighbour with
// the most markers, if that one keeps at least one (below, left, right, above on ties): the
// donor's marker nearest to the void, moved the least distance into it (MarkerSet::relocate).
// Where no neighbour can give (a void ringed by cells of one marker each: the expanding flow
// behind a 1D-to-2D interface that a shock has reached, the static lab chute), the donor is
// the cell of the second ring with the most markers (the four diagonal cells and the four two
// cells away, each reached through a neighbour that held markers and is not an obstacle;
// ndam::void_fill_moves). Mass is exact (the marker keeps its area), the material moves by
// about a cell (at most about two from the second ring), and a larger void fills from its rim
// over the next steps. Not in a periodic box (the flood fill
// does not wrap). Every rank has the counts of the whole box, so every rank finds the same
// moves: the same on any number of ranks and across a restart.
long long NdamSolver::fill_marker_voids(MarkerSet& m, std::vector<double>* counts_out) const {
  if (counts_out) counts_out->clear();
  if (!cfg_.fill_marker_voids || cfg_.periodic_x()) return 0;
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  const auto counts = m.cell_counts();
  auto all = mac_.gather_columns(std::vector<double>(counts.begin(), counts.end()));
  std::vector<CellFlag> flags;
  std::vector<std::uint8_t> mask;
  mac_.classify(all, flags, mask);
  const auto moves = void_fill_moves(all, flags, nx, nz, void_sides());
  m.relocate(moves);
  // nothing moved (nearly every step): the step's flags follow from these counts
  if (moves.empty() && counts_out) *counts_out = std::move(all);
  return static_cast<long long>(moves.size());
}

// Over a 1D-to-2D interface lies the atmosphere above the 1D layer (the 2D side's boundary faces
// there are closed only because no material crosses them), so an Empty region that reaches the
// left side above the 1D layer's depth is open, not a hole: the air between the incoming layer
// and the face of a deposit that a shock has brought to the interface. This cannot tell a
// sampling void in a deposit piled against the interface above the layer from that air (it is
// left unfilled there; the static layout is outside its range once a shock arrives). Under a
// silo gate's lip the side is a wall.
VoidSides NdamSolver::void_sides() const {
  VoidSides s;
  if (cfg_.outflow_right) s.right_from = 0;
  if (cfg_.inflow && inflow_mass_)  // the 1D layer's depth at x_IF (not the step's opening,
    // which the mass sets within 1.5 times it: the same rows during a step and after it)
    s.left_from = first_row_above(cfg_.inflow(t_)[0], cfg_.grid.dz(), cfg_.grid.nz);
  return s;
}

// Flags of the markers m (collective): every rank gathers the marker counts of the whole box and
// applies the flag rule (MacLayout::classify, the rule classify_cell of grid.hpp).
void NdamSolver::update_flags(const MarkerSet& m, std::vector<CellFlag>& flags,
                              std::vector<std::uint8_t>& mask, std::vector<double>& depth,
                              std::pair<double, int>* deepest) const {
  const auto counts = m.cell_counts();
  std::vector<double> local(counts.begin(), counts.end());
  update_flags(mac_.gather_columns(local), m.marker_area(), flags, mask, depth, deepest);
}

void NdamSolver::update_flags(const std::vector<double>& all, double marker_area,
                              std::vector<CellFlag>& flags, std::vector<std::uint8_t>& mask,
                              std::vector<double>& depth, std::pair<double, int>* deepest) const {
  mac_.classify(all, flags, mask);
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  const double per_marker = marker_area / cfg_.grid.dx();
  depth.assign(static_cast<std::size_t>(nx), 0.0);
  if (deepest) *deepest = {0.0, -1};
  for (int gi = 0; gi < nx; ++gi) {
    double n = 0.0;
    for (int k = 0; k < nz; ++k) n += all[static_cast<std::size_t>(gi * nz + k)];
    depth[static_cast<std::size_t>(gi)] = n * per_marker;
    if (deepest && n * per_marker > deepest->first) *deepest = {n * per_marker, gi};
  }
}

// Normal-stress condition of the free surface (NaSt2D): p = 2 nu_eff n.D.n in a Surface cell,
// n.D.n the normal strain rate of its empty sides (du/dx for left/right, dw/dz for
// bottom/top), averaged over them when there are several (the mixed normals of corner cells are
// not resolved). Evaluated with u^n and nu_eff(t^n) (lagged); 0 for any other cell.
double NdamSolver::surface_viscous_stress(int i, int k) const {
  const int gi = mac_.slab.i0 + i;
  if (mac_.gflag(gi, k) != CellFlag::Surface) return 0.0;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  const std::uint8_t m = mac_.mask(gi, k);
  const double dudx = (u_(i, k) - u_(i - 1, k)) / dx, dwdz = (w_(i, k) - w_(i, k - 1)) / dz;
  const int nlr = ((m & empty_side::Left) ? 1 : 0) + ((m & empty_side::Right) ? 1 : 0);
  const int nbt = ((m & empty_side::Bottom) ? 1 : 0) + ((m & empty_side::Top) ? 1 : 0);
  if (nlr + nbt == 0) return 0.0;
  // nu_eff at the surface itself, where p = 0: tau_y = tau_c (Drucker-Prager: 0, so
  // nu_eff = nu). The cell's own nu_eff (with its centre pressure) would feed the lagged
  // yield stress back into the Dirichlet value: measured unstable on the periodic incline
  // (tau_y m_y D_nn is O(tau_y) noise in a plug where ||D|| -> 0).
  const double nus = rheo_.nu_eff(normD_(i, k), 0.0);
  return 2.0 * nus * (dudx * nlr + dwdz * nbt) / (nlr + nbt);
}

// The Dirichlet values of the Surface and Empty cells: the normal-stress condition above
// (explicit momentum step only) plus the hydrostatic offset of the marker depth; Empty: 0.
// With the implicit momentum step the viscous part is left out (p = 0 at the surface): lagged,
// it acts on the face below as an explicit viscous term of weight 2 nu dt / dz^2 and was
// measured unstable at nu dt / dz^2 > 0.5 (Newtonian layer, nu = 0.03, dz = 5 mm); the
// explicit scheme's viscous time-step limit covers it. The bed's normal stress takes the
// missing part back (surface_traction_at_bed).
void NdamSolver::surface_pressure(Field& target) const {
  const int nz = cfg_.grid.nz;
  const double dz = cfg_.grid.dz();
  const bool viscous_normal = cfg_.momentum == Momentum::Explicit;
  for (int i = 0; i < mac_.slab.nx_local; ++i)
    for (int k = 0; k < nz; ++k) {
      const int gi = mac_.slab.i0 + i;
      const CellFlag f = mac_.gflag(gi, k);
      if (f == CellFlag::Empty) target(i, k) = 0.0;
      if (f != CellFlag::Surface) continue;
      target(i, k) = viscous_normal ? surface_viscous_stress(i, k) : 0.0;
      // A cell whose top is empty holds the free surface at the column's marker depth z_s,
      // not at its centre: p = 0 belongs at z_s, so the cell centre gets the hydrostatic
      // increment g cos(zeta) (z_s - z_c) (z_s clamped into the cell). Without it the pressure
      // below a surface would be off by up to g cos(zeta) dz / 2 (5 % of the basal pressure of
      // a 10-cell layer, and the Coulomb friction with it).
      const double zs = surface_height(gi, k);
      if (zs >= 0.0) target(i, k) += std::abs(phys_.gz) * (zs - (k + 0.5) * dz);
    }
}

// The normal traction that the implicit scheme's surface condition puts on the top of local
// column i, as the vertical balance of the layer carries it to the bed. A free surface carries
// none: -sigma_zz = p - 2 nu w_z = 0 there, so p_s = 2 nu_s w_z (NaSt2D's condition above,
// which the explicit scheme imposes). The implicit scheme imposes p_s = 0 instead, and the
// layer's pressure then holds -2 nu_s w_z more than the free surface gives, down to the bed,
// where N = p_b + 2 nu_eff u_x (13) loads the Coulomb friction with it. In an extending chute
// flow (w_z = -u_x < 0) that is a load pressing the layer onto the bed: Setup I at 2.5 mm,
// 2 nu u_x = 22 % of the weight, the friction with it, and the flow's gain of u^2 / 2 along
// the chute 4 % below the plug law, 6 % at 1.25 mm, where nu -> 0 gave 3 % above it (the
// scheme's own error, first order in dx; docs/validation.md, "The surface's normal stress and
// the bed"). The bed takes it back here; the projection keeps p_s = 0 (stable). The traction
// is that of the explicit scheme's Dirichlet value, with the surface's nu_s, not the cell's own
// nu_eff: the latter adds the top cell's plastic stress, sin(phi) times a pressure of at most
// g cos(zeta) dz / 2, which the continuum's surface does not have (measured: 1.4 points
// further from the plug law at 2.5 mm). Returns the traction for a column whose contiguous
// material stack from the bed ends in a Surface cell with an empty top; 0 otherwise, without a
// free surface, or with the explicit scheme.
double NdamSolver::surface_traction_at_bed(int i) const {
  if (!cfg_.free_surface || cfg_.momentum == Momentum::Explicit) return 0.0;
  const int gi = mac_.slab.i0 + i, k = bed_stack_top(gi);
  if (k < 0) return 0.0;
  if (mac_.gflag(gi, k) != CellFlag::Surface || !(mac_.mask(gi, k) & empty_side::Top)) return 0.0;
  // Signed, and at most the column's weight either way. Where nu_s is large the lagged
  // traction is the difference of two large stresses in N (at nu = 0.3 m^2/s 2 nu |u_x| is 30
  // times the weight of the gate's layer), and taking it whole fed the friction's noise back
  // into the flow (ndam_nu_0.3 diverged at 32 m/s near the gate): hence the cap; the chute's
  // 22 % is far inside it. Signed, because the top cells' w_z is noisy from column to column
  // (the free-surface rule, the marker depth): limited to its extending part here, column by
  // column, the noise was rectified into a mean unloading of the bed, and a layer creeping at
  // its friction limit (21/22 deg, periodic) ran away with the viscosity (0.52 m/s at 1 s with
  // nu = 0.03 against the law's 0.030; docs/validation.md). The sign is taken after the filter
  // (bed_surface_traction), where the noise has averaged out.
  const double weight = std::abs(phys_.gz) * column_depth(gi);
  return std::clamp(-surface_viscous_stress(i, k), -weight, weight);
}

// What the bed face right of global column gi carries of the columns' surface tractions t
// (surface_traction_at_bed of every column, gathered): a layer of depth h passes a traction
// that varies along x to its bed filtered, the Fourier mode of wavenumber k by 1 / cosh(k h)
// (Laplace's equation in a strip, Dirichlet on top, Neumann on the bed), i.e. convolved with
// sech(pi x / (2 h)) / (2 h). So only its slow part reaches the bed: where the top cells'
// traction varies over a cell or two (a shock or an impact at a wall, where 2 nu |u_x| reaches
// three times the weight of a 0.1 m deposit at 10 mm) the deposit's bed hardly feels it, while
// along a chute the traction varies over many depths and arrives whole. The discrete form: the
// kernel at the centres of the material columns within 4 h (sech(2 pi) = 0.004), normalised
// over them, with h the depth at the face (the mean of its two columns' marker depths).
// The filtered traction unloads the bed (the surface extends) by at most the face's weight.
// It loads it (the surface compresses) only where the layer is quiet: the derivation is the
// quasi-steady vertical balance of a shallow layer, and where the surface compresses hard (the
// shock, the impact at a wall) the vertical accelerations carry the surface's value instead;
// taking it there (a load added to the bed, up to three times the deposit's weight in a cell
// or two of the shock) moved the wall-impact cell of ndam_cfl_1 from 4.4 to 6.8 m/s and let
// the 85 deg run-up reach the top of its 0.3 m box (5.3 m/s with a load of at most a tenth of
// the weight). Taking the unloading part alone rectifies the top cells' noise along a quiet
// layer, though: a layer of 2 whole cells creeping at its friction limit (21/22 deg, nu = 0.03)
// ran to +10 % of its law with Full cell and weight. So the bed takes the compressive part,
// down to minus its weight, where no column within the filter's reach carries a traction above
// a quarter of the face's weight (docs/validation.md, "The surface's normal stress and the
// bed").
double NdamSolver::bed_surface_traction(int gi, const std::vector<double>& t) const {
  const int nx = cfg_.grid.nx;
  const bool per = cfg_.periodic_x();
  auto wrap = [&](int g) { return per ? (g % nx + nx) % nx : g; };
  auto inside = [&](int g) { return per || (g >= 0 && g < nx); };
  double h = 0.0;
  int nh = 0;
  for (int g : {gi, gi + 1})
    if (inside(g) && mac_.fluid(g, 0)) {
      h += col_h_[static_cast<std::size_t>(wrap(g))];
      ++nh;
    }
  if (nh == 0) return 0.0;
  const double dx = cfg_.grid.dx();
  h = std::max(h / nh, 0.5 * dx);
  const int reach = static_cast<int>(std::ceil(4.0 * h / dx)) + 1;
  // no traction within reach (most faces of a deposit, whose surface does not extend): 0,
  // without the kernel's cosh per column over 4 h; the largest one decides the gate below
  double tmax = 0.0;
  for (int g = gi + 1 - reach; g <= gi + reach; ++g)
    if (inside(g)) tmax = std::max(tmax, std::abs(t[static_cast<std::size_t>(wrap(g))]));
  if (tmax == 0.0) return 0.0;
  double sum = 0.0, wsum = 0.0;
  for (int g = gi + 1 - reach; g <= gi + reach; ++g) {
    if (!inside(g) || !mac_.fluid(g, 0)) continue;
    const double d = (g + 0.5 - (gi + 1)) * dx;  // column centre from the face
    const double w = 1.0 / std::cosh(0.5 * M_PI * d / h);
    sum += w * t[static_cast<std::size_t>(wrap(g))];
    wsum += w;
  }
  if (wsum <= 0.0) return 0.0;
  double weight = 0.0;
  for (int g : {gi, gi + 1})
    if (inside(g) && mac_.fluid(g, 0)) weight += std::abs(phys_.gz) * column_depth(g) / nh;
  // compression loads the bed only where no column within reach carries more than a quarter
  // of the face's weight (see above: a shock or an impact keeps the clamp at 0)
  const double lo = tmax <= 0.25 * weight ? -weight : 0.0;
  return std::clamp(sum / wsum, lo, weight);
}

// The pressure of cell (i, k) that the Coulomb law of the bed takes for its normal stress
// (13). A Surface cell whose top side is not empty but one of its sides is (the toe of a pile,
// the front of a layer, the face of a column) carries the Dirichlet value of that side, p = 0
// (NaSt2D's free-surface condition at its centre), although its column's material lies on it:
// its bed face then had N = g cos(zeta) dz / 2 whatever the weight above (a sixth of it under
// 3 cm at 10 mm cells), and a toe cell slid off at 0.1 m/s while the pile stood (the tester's
// 10 mm columns; docs/validation.md, "Loaded surface cells"). Such a cell takes the hydrostatic
// pressure of its column's material above its centre, g cos(zeta) (h - z_c) with h the
// column's marker depth, where that is larger, so the bed carries the column's weight. The
// projection's Dirichlet value and the cell's strength are unchanged: the strength from this
// pressure too (tau_y of eqs. 4-6) was measured and not kept (the full weight overstates the
// mean stress of a cell at a free face, about half of it, and held the 10 mm Setup II deposit
// so steep that it reached the top of its box). Cells with an empty top keep theirs: their p
// already holds the hydrostatic increment from the surface inside them.
double NdamSolver::loaded_pressure(int i, int k, double p) const {
  const int gi = mac_.slab.i0 + i;
  if (col_h_.empty() || k + 1 >= cfg_.grid.nz || mac_.gflag(gi, k) != CellFlag::Surface ||
      !mac_.fluid(gi, k + 1))
    return p;
  const double zc = (k + 0.5) * cfg_.grid.dz();
  return std::max(p, std::abs(phys_.gz) * (column_depth(gi) - zc));
}

double NdamSolver::column_depth(int gi) const {
  const int nx = cfg_.grid.nx;
  const int gw = cfg_.periodic_x() ? (gi % nx + nx) % nx : gi;
  return (col_hs_.empty() ? col_h_ : col_hs_)[static_cast<std::size_t>(gw)];
}

int NdamSolver::bed_stack_top(int gi) const {
  if (!mac_.fluid(gi, 0)) return -1;
  int k = 0;
  while (k + 1 < cfg_.grid.nz && mac_.fluid(gi, k + 1)) ++k;
  return k;
}

double NdamSolver::full_cell_excess(int gi, int* top) const {
  if (top) *top = -1;
  if (!cfg_.full_cell_weight || cfg_.surface_mass_share || col_h_.empty() || !mac_.fluid(gi, 0))
    return 0.0;
  const int k = bed_stack_top(gi);
  if (top) *top = k;
  return std::max(0.0, (k + 1) * cfg_.grid.dz() - column_depth(gi));
}

double NdamSolver::surface_height(int gi, int k) const {
  if (col_h_.empty() || mac_.gflag(gi, k) != CellFlag::Surface ||
      !(mac_.mask(gi, k) & empty_side::Top))
    return -1.0;
  const double dz = cfg_.grid.dz();
  return std::clamp(column_depth(gi), k * dz, (k + 1) * dz);
}

// Velocity conditions of the free surface on the columns [-1, nx_local] of (u, w):
//  1. Surface cells: each face towards an Empty cell first takes the value of its opposite face
//     when that one is not empty (NaSt2D's rule for cells with two adjacent empty sides), then
//     the remaining divergence is removed in equal shares by the empty faces, so that
//     div u = 0 in every Surface cell (continuity, NaSt2D's rule for one empty side).
//     With the ghost-fluid surface ('Surface pressure' = Ghost fluid) a Surface cell that is a
//     pressure unknown keeps its faces (momentum unknowns, projected), and a thin one, whose
//     centre lies above (or just below) the free surface, is not a continuity cell either:
//     its empty faces take the opposite face, with both sides empty the faces below it. The
//     continuity rule sends all that such a cell takes in out through its empty faces,
//     unbraked, since its pressure is the surface's: where a layer meets the end wall, the
//     wall column's thin top cell passed on 5 m/s (Setup II at 5 mm, docs/validation.md,
//     "Ghost-fluid free surface"). Its markers move with the flow, and the mass they carry
//     fills the cell until it is a pressure unknown.
//  2. Faces between two non-material cells (the Empty region next to the surface) are
//     extrapolated: u upward with zero normal gradient (the tangential-stress-free condition
//     du/dz = 0 of a shallow surface), at the bed ahead of a front from the face behind it;
//     w from a neighbouring column that touches material (ahead of/behind a front), else upward.
//  So marker advection and the stencils of material faces see a smooth velocity.
void NdamSolver::apply_free_surface(Field& u, Field& w) const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz, nxl = mac_.slab.nx_local;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  const bool per = cfg_.periodic_x();
  auto inside = [&](int gi) { return per || (gi >= 0 && gi < nx); };
  // The highest material cell of each column [-2, nxl + 1] (-1: none, and beyond a wall).
  // Above it every rule below is the upward copy, done without looking at flags, as one fill
  // of the column's tail: most of the box is empty, and this function runs several times per
  // step (10 % of a run before the flags were skipped, 6 % at 1.3 mm before the fill).
  std::vector<int> top_of(static_cast<std::size_t>(nxl + 4), -1);
  for (int i = -2; i <= nxl + 1; ++i) {
    const int gi = mac_.slab.i0 + i;
    if (!inside(gi)) continue;
    int k = mac_.top(gi) - 1;  // (above it every cell is Empty)
    while (k >= 0 && !mac_.fluid(gi, k)) --k;
    top_of[static_cast<std::size_t>(i + 2)] = k;
  }
  auto top = [&](int i) { return top_of[static_cast<std::size_t>(i + 2)]; };
  for (int i = -1; i <= nxl; ++i) {
    const int gi = mac_.slab.i0 + i;
    if (!inside(gi)) continue;
    for (int k = 0; k <= top(i); ++k) {  // a Surface cell is a material cell
      // (a pressure unknown of the ghost-fluid surface: its faces are momentum unknowns)
      if (mac_.gflag(gi, k) != CellFlag::Surface || mac_.p_unknown(gi, k)) continue;
      const std::uint8_t m = mac_.mask(gi, k);
      double* face[4] = {&u(i - 1, k), &u(i, k), &w(i, k - 1), &w(i, k)};  // L R B T
      const std::uint8_t bit[4] = {empty_side::Left, empty_side::Right, empty_side::Bottom,
                                   empty_side::Top};
      const double sgn[4] = {-1.0, 1.0, -1.0, 1.0}, hh[4] = {dx, dx, dz, dz};
      for (int q = 0; q < 4; ++q) {
        const int o = q ^ 1;  // opposite face
        if ((m & bit[q]) && !(m & bit[o])) *face[q] = *face[o];
      }
      if (mac_.ghost_surface && mac_.in_ghost_zone(gi)) {  // a thin cell: no continuity (see above)
        if ((m & empty_side::Left) && (m & empty_side::Right) && k > 0) {
          *face[0] = u(i - 1, k - 1);  // both sides empty: the faces below
          *face[1] = u(i, k - 1);
        }
        continue;
      }
      double div = 0.0;
      int ne = 0;
      for (int q = 0; q < 4; ++q) {
        div += sgn[q] * *face[q] / hh[q];
        if (m & bit[q]) ++ne;
      }
      for (int q = 0; q < 4; ++q)
        if (m & bit[q]) *face[q] -= sgn[q] * div * hh[q] / ne;
    }
  }
  // 2. extrapolation into the Empty region (above the columns' material: the upward copy)
  for (int i = -1; i <= nxl; ++i) {
    const int gi = mac_.slab.i0 + i;
    if (!per && (gi < 0 || gi >= nx - 1)) continue;  // u: the boundary faces are set elsewhere
    const int kt = std::max(top(i), top(i + 1)) + 1;  // from here up: no material either side
    const int k0 = std::min(std::max(kt + 1, 1), nz);  // the upward copy from k0 on
    for (int k = 0; k < k0; ++k) {
      if (mac_.fluid(gi, k) || mac_.fluid(gi + 1, k)) continue;
      if (k > 0) u(i, k) = u(i, k - 1);
      else u(i, k) = (mac_.fluid(gi - 1, k) || mac_.fluid(gi, k)) ? u(i - 1, k) : 0.0;
    }
    if (k0 < nz) std::fill(&u(i, k0), &u(i, k0) + (nz - k0), u(i, k0 - 1));
  }
  for (int i = -1; i <= nxl; ++i) {
    const int gi = mac_.slab.i0 + i;
    if (!inside(gi)) continue;
    const int kt = std::max({top(i - 1), top(i), top(i + 1)});  // above: no material around
    const int k0 = std::min(std::max(kt + 1, 1), nz - 1);  // the upward copy from k0 on
    for (int k = 0; k < k0; ++k) {
      if (mac_.fluid(gi, k) || mac_.fluid(gi, k + 1)) continue;
      if (mac_.fluid(gi - 1, k) || mac_.fluid(gi - 1, k + 1)) w(i, k) = w(i - 1, k);
      else if (mac_.fluid(gi + 1, k) || mac_.fluid(gi + 1, k + 1)) w(i, k) = w(i + 1, k);
      else w(i, k) = k > 0 ? w(i, k - 1) : 0.0;
    }
    if (k0 < nz - 1) std::fill(&w(i, k0), &w(i, k0) + (nz - 1 - k0), w(i, k0 - 1));
  }
}

void NdamSolver::update_profile_cache(bool flag_depths) {
  if (!markers_) return;
  // mac_.depth (every column) is n a / dx with n the column's marker count: MarkerSet::depth's
  // Count method to the last bit, so accept() does not count the markers a third time
  std::vector<double> h;
  const bool reuse = flag_depths && markers_->config().depth == DepthMethod::Count &&
                     mac_.depth.size() == static_cast<std::size_t>(cfg_.grid.nx);
  if (reuse)
    h.assign(mac_.depth.begin() + mac_.slab.i0,
             mac_.depth.begin() + mac_.slab.i0 + mac_.slab.nx_local);
  const auto cp = markers_->profile(u_, w_, reuse ? &h : nullptr);
  std::vector<double> local;
  for (std::size_t c = 0; c < cp.h.size(); ++c) {
    local.push_back(cp.h[c]);
    local.push_back(cp.u_mean[c]);
    local.push_back(cp.w_mean[c]);
  }
  const auto all = mac_.gather_columns(local);
  const int nx = cfg_.grid.nx;
  col_h_.assign(static_cast<std::size_t>(nx), 0.0);
  col_u_ = col_h_;
  col_w_ = col_h_;
  for (int gi = 0; gi < nx; ++gi) {
    col_h_[static_cast<std::size_t>(gi)] = all[static_cast<std::size_t>(3 * gi)];
    col_u_[static_cast<std::size_t>(gi)] = all[static_cast<std::size_t>(3 * gi + 1)];
    col_w_[static_cast<std::size_t>(gi)] = all[static_cast<std::size_t>(3 * gi + 2)];
  }
  col_hs_.clear();
  if (cfg_.full_cell_weight || cfg_.surface_mass_share) {
    // 'Full cell and weight' drives whole cells and loads them with the full cells' weight
    // over the markers' depth, so the depth's quantum matters: a layer whose depth ends between
    // two marker rows cannot give every column the same count (13 markers of a partial row
    // over four columns of four), and as the markers travel, a column's count depth jumps by a
    // marker (a quarter row) each time one crosses a column side; the surface pressure then
    // pulsed, a plug on the periodic incline ran 12 % slow and a layer at rest woke to 18
    // times its creep bound (an independent run; docs/validation.md, "The weight of the full
    // cells"). Here each marker is shared between the two columns nearest to it, linearly in
    // its distance from their centres (cloud in cell), so a marker moves its weight across a
    // side continuously; a share that would fall on a column without markers (beyond a front,
    // at the box ends) stays with the marker's own column, so a front keeps its depth.
    const double dx = cfg_.grid.dx(), a = markers_->marker_area();
    // The shares are summed in fixed point, as integer multiples of 2^-32 of a marker: exact,
    // so a column's depth does not depend on the order of the markers in a rank's list. In
    // floating point it did: a restart on two ranks holds the same markers in another order,
    // and the depth's round-off moved the pressure by 1e-12 (cli.restart_exact_2d_np2).
    constexpr long long kWhole = 1LL << 32;  // one marker, in units
    constexpr double kShareUnit = static_cast<double>(kWhole);
    std::vector<long long> hs(static_cast<std::size_t>(nx), 0);
    // one marker row of a column (n markers of area a over dx): the depth quantum between
    // neighbours of a level layer is one marker, a few at most; a larger step is the shape of
    // the surface (a pile's toe, a front), which the sharing would smooth and so move
    const double row = cfg_.grid.dz() / cfg_.markers_per_cell;
    auto has = [&](int own, int gi) {
      if (gi < 0 || gi >= nx) return false;
      const double h = col_h_[static_cast<std::size_t>(gi)];
      return h > 0.0 && std::abs(h - col_h_[static_cast<std::size_t>(own)]) <= row * (1.0 + 1e-9);
    };
    for (const auto& m : markers_->markers()) {
      const int own = std::clamp(static_cast<int>(std::floor(m.x / dx)), 0, nx - 1);
      const double s = m.x / dx - (own + 0.5);  // in [-1/2, 1/2): the offset from the centre
      int other = s >= 0.0 ? own + 1 : own - 1;
      if (cfg_.periodic_x()) other = (other % nx + nx) % nx;
      const long long w = std::llround(std::abs(s) * kShareUnit);  // in [0, kWhole / 2]
      if (has(own, other)) {
        hs[static_cast<std::size_t>(own)] += kWhole - w;
        hs[static_cast<std::size_t>(other)] += w;
      } else {
        hs[static_cast<std::size_t>(own)] += kWhole;
      }
    }
    std::vector<long long> units(static_cast<std::size_t>(nx), 0);
    MPI_Allreduce(hs.data(), units.data(), nx, MPI_LONG_LONG, MPI_SUM, comm_);
    col_hs_.assign(static_cast<std::size_t>(nx), 0.0);
    for (int gi = 0; gi < nx; ++gi)
      col_hs_[static_cast<std::size_t>(gi)] =
          static_cast<double>(units[static_cast<std::size_t>(gi)]) / kShareUnit * (a / dx);
    // Both consistent forms ('Material share' too: its share f and surface pressure take this
    // depth) then spread the depth over about two cells. A layer whose depth ends between two
    // marker rows cannot give its columns the same count: the partial row's markers leave a
    // pattern of columns one marker deeper (6.5 mm in 5 mm cells with 4 x 4 markers: columns of
    // 6.25 and 6.5625 mm), which the sharing above moves smoothly but does not remove. Its
    // surface pressure differs by g cos(zeta) dz / 16 from column to column, and in a layer
    // near rigid, where nu_eff at the bed approaches tau_y m_y, that grid-scale forcing became
    // viscous normal stresses of the order of the weight that did not average out: a plug of
    // 2.3-2.8 cells lagged its law by 3-11 % (m_y = 100 s), 46-60 % (m_y = 1e4 s), and the
    // Material share 14 % ahead at 0.46 cells (scripts/plug_law.py; docs/validation.md, "The
    // plug law at any depth"). Eight passes of the conservative exchange h_i -> h_i / 2 +
    // (h_{i-1} + h_{i+1}) / 4 between neighbours within a marker row of each other (a Gaussian
    // of two cells; a step larger than a row, a front, a pile's toe, a wall's run-up, is not
    // crossed) bring every depth from 0.46 to 4.3 cells within 1.3 % of the law at m_y = 100 s
    // on three angle sets at 5 and 2.5 mm (6 and 12 passes: the same to 0.5 %). The total
    // depth, and the markers' mass, are unchanged; every rank does the same sums.
    constexpr int kDepthSmoothingPasses = 8;
    std::vector<double> next(static_cast<std::size_t>(nx));
    for (int pass = 0; pass < kDepthSmoothingPasses; ++pass) {
      std::fill(next.begin(), next.end(), 0.0);
      for (int gi = 0; gi < nx; ++gi) {
        const double h = col_hs_[static_cast<std::size_t>(gi)];
        double keep = h;
        for (int o : {gi - 1, gi + 1}) {
          const int ow = cfg_.periodic_x() ? (o % nx + nx) % nx : o;
          if (!has(gi, ow)) continue;
          next[static_cast<std::size_t>(ow)] += 0.25 * h;
          keep -= 0.25 * h;
        }
        next[static_cast<std::size_t>(gi)] += keep;
      }
      col_hs_.swap(next);
    }
  }
}

NdamSolver::ColumnState NdamSolver::column_state(double x) const {
  ColumnState c;
  if (col_h_.empty()) return c;
  const int gi = std::clamp(static_cast<int>(std::floor((x - cfg_.x0) / cfg_.grid.dx())), 0,
                            cfg_.grid.nx - 1);
  c.h = col_h_[static_cast<std::size_t>(gi)];
  c.u_mean = col_u_[static_cast<std::size_t>(gi)];
  return c;
}

}  // namespace granflow::ndam
