// N-DAM pressure projection (paper eqs. 10 and 14, NaSt2D's incremental form):
//
//   -L phi = -D u* / dt           on the pressure unknowns (Fluid cells), L = D G with the wall
//                                 faces fixed: n.grad phi = 0 at walls (the Neumann condition
//                                 (14) for the increment); Surface/Empty cells are Dirichlet
//                                 cells with the free-surface value (free_surface.cpp)
//   u^{n+1} = u* - dt G phi
//   p^{n+1} = p^n + phi - chi nu_eff D u*   (chi = 2 implicit: the rotational pressure update;
//                                            chi = 0 for the paper's explicit scheme)
// The pressure at t = 0 solves eq. (10) itself, -L p = -div F with the Neumann condition (14)
// n.grad p = n.F, so that a fluid at rest starts in hydrostatic balance.
#include "stencil.hpp"

#include <algorithm>
#include <cmath>

namespace granflow::ndam {

using detail::Clock;

void NdamSolver::assemble_pressure_if_flags_changed() {
  if (!flags_changed_) return;
  assemble_pressure();
  flags_changed_ = false;
}

void NdamSolver::assemble_pressure() {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz, nxl = mac_.slab.nx_local;
  const bool per = cfg_.periodic_x();
  // A closed region of Fluid cells without Dirichlet neighbours (no free surface) has the
  // singular pure-Neumann Laplacian: pin phi = 0 in its first cell. With a free surface the
  // Surface and Empty cells are Dirichlet cells and no pin is needed.
  pin_ = -1;
  bool dirichlet = false;
  for (int gi = 0; gi < nx && !dirichlet; ++gi)
    for (int k = 0; k < nz; ++k) {
      const CellFlag f = mac_.flags[static_cast<std::size_t>(gi * nz + k)];
      if (f == CellFlag::Surface || f == CellFlag::Empty) {
        dirichlet = true;
        break;
      }
    }
  if (!dirichlet)
    for (int gi = 0; gi < nx && pin_ < 0; ++gi)
      for (int k = 0; k < nz; ++k)
        if (mac_.p_unknown(gi, k)) {
          pin_ = mac_.p_gid(gi, k);
          break;
        }
  fluid_cells_ = 0;
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < mac_.top(gi); ++k)  // (above: Empty cells)
      if (mac_.p_unknown(gi, k)) ++fluid_cells_;
  const double cx = 1.0 / (cfg_.grid.dx() * cfg_.grid.dx());
  const double cz = 1.0 / (cfg_.grid.dz() * cfg_.grid.dz());
  // The preconditioner switch ('Stiff threshold' of the pressure solver): the farthest a
  // pressure unknown lies from a Dirichlet cell, in cells (dirichlet_distance). Without a
  // Dirichlet cell (a closed box, the pinned cell) the distance is unbounded.
  // With symmetric Gauss-Seidel below the threshold: SSOR with omega = 2 / (1 + 4.5 / d),
  // about the best omega measured on Setup II (CG iterations per solve 28 -> 22 at 5 mm,
  // 53 -> 35 at 2.6 mm, 105 -> 55 at 1.3 mm against omega = 1; fixed omega 1.5 or 1.8 each
  // lost 10-25 % at one of them).
  const double d = dirichlet ? dirichlet_distance() : kUnbounded;
  pressure_->set_stiffness(d);
  if (d < kUnbounded) stats_.pressure_max_distance = std::max(stats_.pressure_max_distance, d);
  pressure_->set_relaxation_damping(d < kUnbounded ? 2.0 / (1.0 + 4.5 / std::max(d, 1.0)) : 0.0);
  pressure_->begin();
  for (int i = 0; i < nxl; ++i) {
    const int gi = mac_.slab.i0 + i;
    for (int k = 0; k < mac_.top(gi); ++k) {  // (above: Empty cells, rows without entries)
      const long long row = mac_.p_gid(gi, k);
      // The pinned cell and every cell that is not a pressure unknown (obstacle: phi = 0;
      // Surface: phi from the normal-stress condition; Empty: p = 0) is an identity row whose
      // right-hand side is its value. An unknown next to such a Dirichlet cell moves the
      // coupling to its right-hand side (solve_pressure), which keeps -L symmetric positive
      // definite. Faces to walls, obstacles and the open outflow carry no phi flux (Neumann,
      // eq. 14 for the projection increment). A row without entries is an identity row.
      if (row == pin_ || !mac_.p_unknown(gi, k)) {
        if (row == pin_) pressure_->add(row, row, cx + cz);
        continue;
      }
      auto couple = [&](int gn, int kn, double c) {
        const CellFlag f = mac_.gflag(gn, kn);
        if (f == CellFlag::Obstacle) return;
        // Ghost-fluid surface: phi = 0 at the surface, theta of the way to the Empty centre,
        // so the ghost value is -phi (1 - theta) / theta and the flux c (ghost - phi) is
        // -c phi / theta: the coefficient c / theta on the diagonal, nothing on the right.
        if (mac_.ghost_surface && f == CellFlag::Empty) {
          pressure_->add(row, row, c / mac_.surface_theta(gi, k, gn, kn));
          return;
        }
        pressure_->add(row, row, c);
        if (!mac_.p_unknown(gn, kn)) return;  // Dirichlet neighbour: right-hand side
        const long long col = mac_.p_gid(per ? (gn % nx + nx) % nx : gn, kn);
        if (col != pin_) pressure_->add(row, col, -c);
      };
      if (gi + 1 < nx || per) couple(gi + 1, k, cx);
      if (gi - 1 >= 0 || per) couple(gi - 1, k, cx);
      if (k + 1 < nz) couple(gi, k + 1, cz);
      if (k - 1 >= 0) couple(gi, k - 1, cz);
    }
  }
  pressure_->end();
}

// The largest graph distance, in cells (steps between face neighbours through pressure
// unknowns), from a pressure unknown to the nearest cell whose value is given (a Surface or
// Empty cell that is no unknown, the material of a Dirichlet inflow column); kUnbounded if an
// unknown has none. It measures how hard the pressure system is for a one-level
// preconditioner: the smallest eigenvalue of -L on a layer of d cells under a Dirichlet
// surface is about (pi / 2 d)^2 / dz^2, so the condition number grows as d^2 and the
// iterations of CG with symmetric Gauss-Seidel grow with d (Setup II to 0.75 s: at most d = 23
// and 53 iterations per solve at 2.6 mm, d = 47 and 105 at 1.3 mm). A breadth-first search from
// all those cells at once; the flags are the same on every rank, and so is the distance.
double NdamSolver::dirichlet_distance() const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  const bool per = cfg_.periodic_x();
  const std::size_t n = static_cast<std::size_t>(nx) * static_cast<std::size_t>(nz);
  // Only material cells can be unknowns: the Empty air above the layer, most of the box, is
  // skipped by its flag. The search starts from the unknowns next to a given cell (distance 1).
  std::vector<int>& dist = dirichlet_dist_;
  std::vector<int>& queue = dirichlet_queue_;
  dist.assign(n, -1);  // -1: not an unknown or not reached; 0: an unknown not reached yet
  queue.clear();
  long long unknowns = 0;
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < mac_.top(gi); ++k) {
      const CellFlag f = mac_.flags[static_cast<std::size_t>(gi * nz + k)];
      if ((f == CellFlag::Fluid || f == CellFlag::Surface) && mac_.p_unknown(gi, k)) {
        dist[static_cast<std::size_t>(gi * nz + k)] = 0;
        ++unknowns;
      }
    }
  auto given = [&](int gn, int kn) {  // a neighbour whose pressure is given
    return mac_.gflag(gn, kn) != CellFlag::Obstacle && !mac_.p_unknown(gn, kn);
  };
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < mac_.top(gi); ++k) {
      const std::size_t c = static_cast<std::size_t>(gi * nz + k);
      if (dist[c] != 0) continue;
      if (given(gi + 1, k) || given(gi - 1, k) || given(gi, k + 1) || given(gi, k - 1)) {
        dist[c] = 1;
        queue.push_back(static_cast<int>(c));
      }
    }
  int far = 0;
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int c = queue[head], gi = c / nz, k = c % nz;
    const int d = dist[static_cast<std::size_t>(c)];
    far = std::max(far, d);
    const int nbr[4][2] = {{gi + 1, k}, {gi - 1, k}, {gi, k + 1}, {gi, k - 1}};
    for (const auto& g : nbr) {
      int gn = g[0];
      const int kn = g[1];
      if (kn < 0 || kn >= nz) continue;
      if (per) gn = (gn % nx + nx) % nx;
      else if (gn < 0 || gn >= nx) continue;
      const std::size_t q = static_cast<std::size_t>(gn * nz + kn);
      if (dist[q] != 0) continue;  // not an unknown, or reached
      dist[q] = d + 1;
      queue.push_back(static_cast<int>(q));
    }
  }
  return static_cast<long long>(queue.size()) < unknowns ? kUnbounded : static_cast<double>(far);
}

// One predictor-projection from the state at t^n with the current nu_eff and friction factors:
// u*, phi, u^{n+1} = u* - dt G phi and p^{n+1} into u_new_, w_new_, p_new_. In the 'Nonlinear'
// coupling this is the map P(q) whose fixed point is the new pressure.
void NdamSolver::project(double dt) {
  const auto t1 = Clock::now();
  mom_stats_ = solvers::SolveStats{};
  predict_velocity(dt, u_new_, w_new_);
  stats_.step_momentum += detail::seconds_since(t1);
  const auto t2 = Clock::now();
  Field phi;
  solve_pressure(dt, u_new_, w_new_, phi);
  u_star_ = u_new_;
  w_star_ = w_new_;
  correct_velocity(dt, phi, u_new_, w_new_);
  record_bed_stress(phi);
  p_new_ = p_;
  // Rotational pressure update (Timmermans et al. 1996; Guermond, Minev & Shen 2006) for the
  // implicit treatment: p^{n+1} = p^n + phi - 2 nu_eff div u*. In the stress form
  // div(2 nu D u) = 2 nu grad(div u) - nu curl curl u (constant nu), so 2 nu div u* is the part
  // of the implicit viscous term that the projection removes from u*; putting it back into the
  // pressure removes the splitting error that otherwise makes the pressure lag by
  // O(nu dt / dx^2) steps when nu_eff is large (a Stokes-limit Uzawa iteration with step
  // 2 nu_eff). It vanishes at a steady state and for the explicit scheme (the paper's) it is
  // not used.
  for (int i = 0; i < mac_.slab.nx_local; ++i)
    for (int k = 0; k < cfg_.grid.nz; ++k) {
      if (mac_.p_unknown(mac_.slab.i0 + i, k))
        p_new_(i, k) += phi(i, k) - rotational_weight(i, k, dt) * nu_rot_(i, k) *
                                        divergence(u_star_, w_star_, i, k);
      else  // Dirichlet cells: phi is the increment to their value (surface normal stress,
            // eq. 26 at an interface, 0 when Empty); obstacles: phi = 0
        p_new_(i, k) += phi(i, k);
    }
  if (!cfg_.free_surface) {
    // a closed box: the pressure's level is free; the bed's stress takes the same level
    const double c = normalise_pressure(p_new_);
    for (auto& v : bed_stress_new_.data()) v -= c;  // (NaN stays NaN)
  }
  fill_scalar_ghosts(p_new_);
  stats_.step_pressure += detail::seconds_since(t2);
}

// The rotational update corrects the splitting error of the implicit viscous term where the
// discrete operator has its interior form: in the Fluid cells. A Surface cell that is a
// pressure unknown of the ghost-fluid surface has a stress-free side (its ghost face's stencil
// is one-sided), where 2 nu_eff div u* is not that error: in a resting pile (nu_eff 20-50
// m^2/s) it swung the pressure of the cells on the pile's face between +50 and -380 m^2/s^2
// from step to step and threw their ghost faces off at 6 m/s (Setup II at 5 mm,
// docs/validation.md, "Ghost-fluid free surface"). Every Fluid cell keeps
// it, with a weight that rolls off where the step is stiff (rotational_weight).
bool NdamSolver::rotational_cell(int i, int k) const {
  const int gi = mac_.slab.i0 + i;
  return mac_.gflag(gi, k) == CellFlag::Fluid && mac_.p_unknown(gi, k);
}

// chi in p^{n+1} = p^n + phi - chi nu_eff div u*: 2 in the rotational cells (the stress form's
// factor, above), 0 elsewhere and for the explicit scheme. The update is a Uzawa step of size
// chi nu_eff on the pressure, exact in the Stokes limit of a constant nu_eff but not next to the
// free surface nor where nu_eff jumps between neighbours, and there the full step, repeated
// from step to step, amplifies once the step is stiff, s = nu_eff dt / h^2 >> 1
// (h = min(dx, dz)). So chi rolls off with r = s / c (c = kRotationalStiffness = 2); where
// s < c it stays near 2 (at s = 0.23, the thin front of Setup II at 1.25 mm, 1.97):
//  - next to the free surface, NaSt2D's (Dirichlet Surface cells) and the ghost fluid's alike:
//    chi = 2 / (1 + r^2), so chi s -> 2 c^2 / s vanishes where s >> c (the standard
//    incremental update). Until 2026-12-05 NaSt2D's surface took chi = 1 + 1 / (1 + r^2), a
//    Uzawa step of nu_eff where the full step overshoots; that threw the viscous gate flows'
//    surface cells off (nu = 0.3 / 1 m^2/s, s up to 46: 61 / 276 m/s in the stability suite,
//    the 10 kPa Bingham material 7.1 m/s) where this form keeps them at 0.63-0.76 m/s
//    (docs/validation.md, "Stability suite"). chi -> 1 had been chosen on 2026-12-04 for a
//    column collapse (a = 1, phi = 35, delta = 30 deg) that crept at 10-16 mm/s at 2.5 mm
//    with chi -> 0; re-measured with the loaded surface cells and the marker-void fill since,
//    it rests with chi -> 0 at 4.6 mm/s (2.5 mm) and 4.5 mm/s (5 mm) against its creep bound
//    of 10.9 mm/s. (A full chi = 2 there, before 2026-12-04: in a resting pile, nu_eff 20-100
//    m^2/s and s ~ 1e3, a flag change at the toe started a pressure oscillation that woke the
//    whole deposit for 0.1 s, the same column at 5 mm: rms speed 3.8 -> 21 mm/s from 0.64 to
//    0.70 s, the top sinking by a cell.) The ghost-fluid surface's own measurement follows
//    the next bullet.
//  - in the interior chi = 1 + 1 / (1 + r^2) with r scaled by the contrast of nu_eff over the
//    cell and its four neighbours, 1 - nu_min / nu_max, so that chi = 2 stays where nu_eff is
//    uniform (a Newtonian fluid: a nu = 1e3 m^2/s cavity settles in 40 steps with chi = 2,
//    slower with chi = 1; numerics.md). In the interior (2026-12-05): a pile of phi = 40, delta = 20 deg (a = 1, 5 mm) at rest
//    from 0.40 s creeps along a one-cell shear band from its top at the symmetry wall to the
//    toe, where nu_eff is orders of magnitude below the plug's on either side; with chi = 2
//    the band's cells started a row-by-row pressure oscillation at 0.546 s (u 7 mm/s -> 20-60
//    mm/s in 3 steps, no flag change) and the pile woke five times to 0.67 s (rms 28.5 mm/s
//    against its creep bound of 10.8 mm/s); rolled off it rests at 4-6.5 mm/s (across the
//    band nu_min / nu_max is far below 1, so the contrast leaves r nearly as it is).
//    The ghost-fluid surface's measurement of the surface form: Setup II with nu = 1 m^2/s at 5 mm
//    (s up to 140), the fastest cell to 0.3 s with outputs every 0.02 / 0.025 / 0.05 s:
//    46 / 7.2 / 15 m/s at the gate's top with chi = 2 there (a fixed chi of 1 or 0.5 there:
//    6-20 m/s), 0.38-0.49 m/s with this roll-off, c = 1 and 2 alike (the app and test
//    NdamGhostSurface.ViscousGateFlowStaysSlow); a linear cap chi = 2 min(1, c / s) left
//    0.4-5.2 m/s for c = 0.25-4 (docs/validation.md, "Ghost-fluid free surface").
double NdamSolver::rotational_weight(int i, int k, double dt) const {
  if (cfg_.momentum != Momentum::Implicit || !rotational_cell(i, k)) return 0.0;
  constexpr double kRot = 2.0, kRotationalStiffness = 2.0;
  const double h = std::min(cfg_.grid.dx(), cfg_.grid.dz());
  double r = nu_rot_(i, k) * dt / (h * h) / kRotationalStiffness;
  const int gi = mac_.slab.i0 + i;
  const bool near_surface =
      any_flag(gi - 1, gi + 1, k - 1, k + 1,
               [](CellFlag f) { return f == CellFlag::Surface || f == CellFlag::Empty; });
  if (near_surface) return kRot / (1.0 + r * r);
  // the interior: the full step is exact where nu_eff is uniform
  double lo = nu_rot_(i, k), hi = lo;
  for (const double n : {nu_rot_(i - 1, k), nu_rot_(i + 1, k), nu_rot_(i, k - 1), nu_rot_(i, k + 1)}) {
    lo = std::min(lo, n);
    hi = std::max(hi, n);
  }
  r *= hi > 0.0 ? 1.0 - lo / hi : 0.0;
  return 1.0 + 1.0 / (1.0 + r * r);
}

double NdamSolver::divergence(const Field& u, const Field& w, int i, int k) const {
  return (u(i, k) - u(i - 1, k)) / cfg_.grid.dx() + (w(i, k) - w(i, k - 1)) / cfg_.grid.dz();
}

// max |div u| over the material cells of (u, w), on all ranks.
double NdamSolver::max_abs_divergence(const Field& u, const Field& w) const {
  double dmax = 0.0;
  for (int i = 0; i < mac_.slab.nx_local; ++i)
    for (int k = 0; k < mac_.top(mac_.slab.i0 + i); ++k)
      if (mac_.fluid(mac_.slab.i0 + i, k)) dmax = std::max(dmax, std::abs(divergence(u, w, i, k)));
  return detail::allreduce_max(dmax, comm_);
}

// -L phi = -div(u*)/dt on the pressure unknowns (Fluid cells). Dirichlet cells (Surface:
// the increment to the normal-stress value, Empty: 0, obstacles: 0) are identity rows with
// their value p_dir_, and their coupling to an unknown goes to its right-hand side. Without a
// Dirichlet cell (closed box) the right-hand side is made compatible (zero sum; it is zero up
// to round-off anyway since the wall fluxes vanish) and one cell is pinned.
void NdamSolver::solve_pressure(double dt, const Field& us, const Field& ws, Field& phi) {
  const int nxl = mac_.slab.nx_local, nz = cfg_.grid.nz, nx = cfg_.grid.nx;
  const bool per = cfg_.periodic_x();
  const double cx = 1.0 / (cfg_.grid.dx() * cfg_.grid.dx());
  const double cz = 1.0 / (cfg_.grid.dz() * cfg_.grid.dz());
  std::vector<double> rhs(static_cast<std::size_t>(nxl * nz)), x(rhs.size(), 0.0);
  double sum = 0.0;
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) {
      const int gi = mac_.slab.i0 + i;
      const auto q = static_cast<std::size_t>(i * nz + k);
      if (k >= mac_.top(gi) || !mac_.p_unknown(gi, k)) {  // (above the top: Empty)
        rhs[q] = x[q] = p_dir_(i, k);
        continue;
      }
      double r = -divergence(us, ws, i, k) / dt;
      sum += r;
      auto dir = [&](int ii, int kn, double c) {
        const int gn = mac_.slab.i0 + ii;
        if (!per && (gn < 0 || gn >= nx)) return;
        if (kn < 0 || kn >= nz) return;
        const CellFlag f = mac_.gflag(gn, kn);
        if (f == CellFlag::Obstacle || f == CellFlag::Fluid) return;
        // ghost fluid: a Surface cell that is an unknown, and the ghost (phi = 0 at the surface)
        if (mac_.ghost_surface && (f == CellFlag::Empty || mac_.p_unknown(gn, kn))) return;
        r += c * p_dir_(ii, kn);
      };
      if (cfg_.free_surface) {
        dir(i + 1, k, cx);
        dir(i - 1, k, cx);
        dir(i, k + 1, cz);
        dir(i, k - 1, cz);
      }
      rhs[q] = r;
    }
  if (pin_ >= 0) {
    const double mean = detail::allreduce_sum(sum, comm_) / static_cast<double>(fluid_cells_);
    const long long first = mac_.p_gid(mac_.slab.i0, 0);
    for (int i = 0; i < nxl; ++i)
      for (int k = 0; k < nz; ++k) {
        const auto q = static_cast<std::size_t>(i * nz + k);
        const long long row = first + static_cast<long long>(q);
        if (row == pin_ || !mac_.p_unknown(mac_.slab.i0 + i, k)) rhs[q] = 0.0;  // pinned or obstacle
        else rhs[q] -= mean;
      }
  }
  p_stats_ = pressure_->solve(rhs, x);
  ++stats_.pressure_solves;
  stats_.pressure_iterations += p_stats_.iterations;
  if (p_stats_.stiff) ++stats_.pressure_stiff_solves;
  stats_.pressure_max_iterations = std::max(stats_.pressure_max_iterations, p_stats_.iterations);
  stats_.worst_pressure_residual = std::max(stats_.worst_pressure_residual, p_stats_.residual);
  if (!p_stats_.converged) ++stats_.unconverged_solves;
  phi = Field(nxl, nz);
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) phi(i, k) = x[static_cast<std::size_t>(i * nz + k)];
  fill_scalar_ghosts(phi);
}

void NdamSolver::correct_velocity(double dt, const Field& phi, Field& us, Field& ws) const {
  const int nxl = mac_.slab.nx_local;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  for (int i = 0; i < nxl; ++i) {
    for (int k = 0; k < mac_.empty_from(i); ++k) {  // (above: no unknown face)
      if (mac_.u_unknown(i, k)) us(i, k) -= dt * pressure_difference(phi, U, i, k) / dx;
      if (mac_.w_unknown(i, k)) ws(i, k) -= dt * pressure_difference(phi, W, i, k) / dz;
    }
  }
  fill_velocity_ghosts(us, ws);
}

double NdamSolver::pressure_difference(const Field& p, Comp c, int i, int k) const {
  const int gi = mac_.slab.i0 + i;
  const int g2 = c == U ? gi + 1 : gi, k2 = c == U ? k : k + 1;
  const int i2 = c == U ? i + 1 : i;
  if (mac_.ghost_face(gi, k, g2, k2)) {
    // p = 0 at the surface, theta of the spacing from the unknown's centre
    // (MacLayout::surface_theta): the difference to the ghost value -p (1 - theta) / theta
    if (mac_.gflag(g2, k2) == CellFlag::Empty) return -p(i, k) / mac_.surface_theta(gi, k, g2, k2);
    return p(i2, k2) / mac_.surface_theta(g2, k2, gi, k);
  }
  return p(i2, k2) - p(i, k);
}

// The pressure of a closed box is fixed up to a constant. The constant is chosen so that p,
// extrapolated linearly to the top wall z = Lz, averages to zero there: the top of the box plays
// the role of the free surface, and the tau_p p yield stress sees a pressure that grows with
// depth from 0.
double NdamSolver::normalise_pressure(Field& p) const {
  // Columns whose two top cells are fluid; if an obstacle covers the top of every column, the
  // mean over the fluid cells is set to zero instead.
  const int nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
  double sums[4] = {0.0, 0.0, 0.0, 0.0};  // top sum, top columns, fluid sum, fluid cells
  for (int i = 0; i < nxl; ++i) {
    const int gi = mac_.slab.i0 + i;
    if (nz > 1 && mac_.fluid(gi, nz - 1) && mac_.fluid(gi, nz - 2)) {
      sums[0] += 1.5 * p(i, nz - 1) - 0.5 * p(i, nz - 2);
      sums[1] += 1.0;
    }
    for (int k = 0; k < nz; ++k)
      if (mac_.fluid(gi, k)) {
        sums[2] += p(i, k);
        sums[3] += 1.0;
      }
  }
  double all[4];
  MPI_Allreduce(sums, all, 4, MPI_DOUBLE, MPI_SUM, comm_);
  const double c = all[1] > 0.0 ? all[0] / all[1] : all[2] / all[3];
  for (auto& v : p.data()) v -= c;
  return c;
}

// A state assembled from converted columns (the domain manager's moves) is divergence-free only
// approximately: the filled columns take w from continuity (eq. 27) against faces averaged
// between their neighbours, the interfaces' faces are reconnected, and the markers' new flags
// decide which cells are unknowns. The next step's projection would remove that divergence
// with phi = L^-1 div / dt and keep phi in p^{n+1} (the incremental update), so the pressure,
// and with it the velocities of the steps after, depended on the step that followed the move:
// in Setup II from 2D [0, 0.2] / 1D at 10 mm, a step of 1e-5 s after each move put 110-150
// m^2/s^2 into p (0.1-7 otherwise), and at 1 s u_mean was 14.6 % (L2) from the run with
// ordinary steps (such steps at other times: 1.0-1.6 %). Here the state is projected once with
// the increment 0 in the Dirichlet cells and p untouched: 0.9 %
// (DomainManager.ShortStepAfterAMoveDoesNotChangeTheRun).
double NdamSolver::remove_divergence() {
  const double before = max_abs_divergence(u_, w_);
  assemble_pressure_if_flags_changed();
  Field dir(mac_.slab.nx_local, cfg_.grid.nz);  // (zero: no increment in the Dirichlet cells)
  std::swap(p_dir_, dir);
  Field phi;
  solve_pressure(1.0, u_, w_, phi);
  std::swap(p_dir_, dir);
  correct_velocity(1.0, phi, u_, w_);
  if (markers_) update_profile_cache();
  u_new_ = u_star_ = u_;
  w_new_ = w_star_ = w_;
  return before;
}

// Eq. (10) at t = 0: -L p = -div F with F = -C(u) + V(u) + g on the unknown faces and the
// Neumann condition (14) n.grad p = n.F, i.e. F = 0 on the fixed wall-normal faces. This is the
// projection of the force field, computed with dt = 1 through the same routines.
void NdamSolver::initial_pressure() {
  Field fu = u_, fw = w_;
  explicit_force(false, fu, fw);
  mac_.exchange(fu);
  mac_.exchange(fw);
  Field phi;
  solve_pressure(1.0, fu, fw, phi);
  // solve_pressure returns phi with -L phi = -div F, i.e. grad phi is the gradient part of F.
  p_ = phi;
  if (!cfg_.free_surface) normalise_pressure(p_);
  fill_scalar_ghosts(p_);
}

}  // namespace granflow::ndam
