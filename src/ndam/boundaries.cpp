// N-DAM boundaries: the rigid walls, the moving lid, the Coulomb sliding law (11)-(13) as a
// Robin ghost value, the tangential ghost rows and columns of the velocity, and the ghosts of
// cell-centred scalars.
//
// Every velocity sample a stencil touches is a `Ref` (stencil.hpp): a * (unknown) + b. Beyond a
// wall the tangential ghost is the mirror of the first inner value,
//   no-slip     u_g = -u_1,          moving lid  u_g = 2 U - u_1,      free slip  u_g = u_1,
//   Coulomb     u_g = a_F u_1 + b_F  from the sliding law (13) linearised in the step,
// and wall-normal faces are fixed (u = 0). The free surface, the silo gate and the open outflow
// give the other known faces (free_surface.cpp, inflow.cpp).
#include "stencil.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace granflow::ndam {

namespace {
// The tangential ghost beyond a wall of kind wl from the inside sample r (see above); a Coulomb
// wall's ghost is affine in r, a r + b (update_friction).
NdamSolver::Ref wall_ghost(const Wall& wl, NdamSolver::Ref r, double a, double b) {
  if (wl.kind == WallKind::Coulomb) {
    r.a *= a;
    r.b = a * r.b + b;
    r.friction = true;
    return r;
  }
  const double s = wl.kind == WallKind::FreeSlip ? 1.0 : -1.0;
  r.a *= s;
  r.b = s * r.b + (wl.kind == WallKind::MovingLid ? 2.0 * wl.velocity : 0.0);
  return r;
}

// The Robin ghost of a Coulomb face, ghost = a u + b, when the friction factor of the step is
// linearised as c_l + d (u - v) (update_friction): with q = dz tan(delta) N / nu_b the stress
// balance nu_b (u - ghost) / dz = tan(delta) N (c_l + d (u - v)) gives
//   a = 1 - q d,  b = -q (c_l - d v).
// a < -1 is a drag stiffer than sticking: clamped to the no-slip ghost (a = -1, b = 0), since
// regularised friction cannot hold more than sticking does. Returns whether it was clamped.
// `decided`, when given, is the clamp decided beforehand: the nonlinear pressure system keeps
// the clamps of its first evaluation (NdamSolver::stuck_frozen_), so that its map P(q) is
// continuous in q; unclamped, a may then lie below -1 (a drag a little stiffer than sticking,
// which only adds to the diagonal of the momentum matrix).
bool coulomb_ghost(double q, double c_l, double d, double v, double& a, double& b,
                   const std::uint8_t* decided = nullptr) {
  a = 1.0 - q * d;
  b = -q * (c_l - d * v);
  const bool stuck = decided ? *decided != 0 : a < -1.0;
  if (!stuck) return false;
  a = -1.0;
  b = 0.0;
  return true;
}
}  // namespace

NdamSolver::Ref NdamSolver::u_ref(int i, int k) const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  if (k < 0 || k >= nz) {
    // tangential ghost below the bottom / above the top wall
    // (Coulomb: the bed only, the Robin ghost u(i,-1) = a u(i,0) + b of update_friction)
    const auto f = static_cast<std::size_t>(i + Field::G);
    return wall_ghost(cfg_.walls[k < 0 ? 2 : 3], u_ref(i, k < 0 ? 0 : nz - 1), bed_a_[f],
                      bed_b_[f]);
  }
  Ref r;
  r.loc = u_.index(i, k);
  if (!mac_.u_unknown(i, k)) {
    // A face inside an obstacle (no fluid on either side) next to a fluid face above or below
    // is the tangential ghost of the obstacle's no-slip surface: minus that fluid face.
    // Every other fixed face is wall- or obstacle-normal: u = 0.
    const int gi = mac_.slab.i0 + i;
    if (has_obstacles_ && !mac_.fluid(gi, k) && !mac_.fluid(gi + 1, k)) {
      for (int kn : {k + 1, k - 1})
        if (mac_.u_unknown(i, kn)) {
          Ref m = u_ref(i, kn);
          m.a = -m.a;
          m.b = -m.b;
          return m;
        }
    }
    if (cfg_.free_surface) {
      if (!cfg_.periodic_x() && gi <= -1) {  // silo gate at x = x0: inflow below h_in, wall above
        r.b = inflow_face(k);
        return r;
      }
      if (!cfg_.periodic_x() && gi >= nx - 1) {
        if (cfg_.outflow_right) {
          // Zero gradient. When the last column holds a Surface cell whose left neighbour is
          // empty (the tail of a layer leaving through the open end), that cell's left face
          // follows this one (surface_face_ref), so this one must not follow it back (an endless
          // recursion): it keeps its value, like the other known faces of an empty region.
          if (!mac_.fluid(nx - 2, k) && mac_.fluid(nx - 1, k)) {
            r.a = 1.0;
            return r;
          }
          Ref m = u_ref(nx - 2 - mac_.slab.i0, k);
          m.b += outflow_slope(k);
          return m;
        }
        return r;  // rigid wall: u = 0
      }
      // A face next to an Empty cell: its value is set by the free-surface conditions
      // (apply_free_surface). When it is the empty side of a Surface cell whose opposite side
      // is not empty, it follows that opposite face with their lagged difference,
      // u_f = u_o + (u_f^n - u_o^n): the normal stress of the Surface cell is then the lagged
      // (continuity) value, and the implicit stencil holds no lagged copy of a neighbouring
      // unknown (that explicit coupling with weight nu dt / dx^2 was measured unstable for
      // nu dt / dx^2 > 1). Other faces of the empty region are known constants: a = 1,
      // gid = -1 reads the field itself.
      if (const Ref m = surface_face_ref(U, i, k); m.a != 0.0 || m.gid >= 0) return m;
      r.a = 1.0;
      return r;
    }
    return r;
  }
  const int gi = ((mac_.slab.i0 + i) % nx + nx) % nx;
  r.gid = 2 * mac_.p_gid(gi, k);
  r.a = 1.0;
  return r;
}

NdamSolver::Ref NdamSolver::w_ref(int i, int k) const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  Ref r;
  r.loc = w_.index(i, k);
  if (k <= -1 || k >= nz - 1) return r;  // bottom and top walls: w = 0
  const int gi = mac_.slab.i0 + i;
  if (!cfg_.periodic_x() && (gi < 0 || gi >= nx)) {
    // tangential ghost left of x = 0 / right of x = L: mirror of the first inner column
    // (Coulomb: the end wall only, the Robin ghost w(nx, k) = a w(nx-1, k) + b of
    // update_friction)
    const auto f = static_cast<std::size_t>(k);
    return wall_ghost(cfg_.walls[gi < 0 ? 0 : 1], w_ref(gi < 0 ? i + 1 : i - 1, k),
                      gi >= nx ? wall_a_[f] : 1.0, gi >= nx ? wall_b_[f] : 0.0);
  }
  if (!mac_.w_unknown(i, k)) {
    // inside an obstacle next to a fluid face left or right: no-slip tangential ghost
    if (has_obstacles_ && !mac_.fluid(gi, k) && !mac_.fluid(gi, k + 1)) {
      for (int in : {i + 1, i - 1})
        if (mac_.w_unknown(in, k)) {
          Ref m = w_ref(in, k);
          m.a = -m.a;
          m.b = -m.b;
          return m;
        }
    }
    if (cfg_.free_surface) {  // next to an Empty cell (see u_ref)
      if (const Ref m = surface_face_ref(W, i, k); m.a != 0.0 || m.gid >= 0) return m;
      r.a = 1.0;
    }
    return r;  // obstacle-normal face: w = 0
  }
  r.gid = 2 * mac_.p_gid((gi % nx + nx) % nx, k) + 1;
  r.a = 1.0;
  return r;
}

NdamSolver::Ref NdamSolver::ref(Comp c, int i, int k) const {
  return c == U ? u_ref(i, k) : w_ref(i, k);
}

// The ghost values of (u, w): neighbour slabs, walls, and (surface_rules) the free-surface
// conditions of the current flags on the faces next to Empty cells. Those rules are not
// idempotent (a Surface cell with two opposite empty sides keeps the difference of its last
// values), so a state that already holds them (a checkpoint, NdamState::surface_applied) is
// filled without them: it then has the ghosts the straight run had.
void NdamSolver::fill_velocity_ghosts(Field& u, Field& w, bool surface_rules) const {
  mac_.exchange(u);
  mac_.exchange(w);
  boundary_faces(u, w);
  if (cfg_.free_surface && surface_rules) {
    // The free-surface faces of the owned columns and of one ghost column on each side are set
    // redundantly on both ranks from the same data (each such face depends only on its own
    // surface cell), then the exchange makes the ghosts the owners' values.
    apply_free_surface(u, w);
    mac_.exchange(u);
    mac_.exchange(w);
    boundary_faces(u, w);
  }
  const int G = Field::G, nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
  // u: tangential ghost rows below and above, evaluated on the owned columns and on those
  // beyond the end walls of the box. The ghost columns of a neighbour slab (or of the periodic
  // wrap) take the owner's rows from the exchange below, like every other ghost value: the
  // row's Ref can reach one face beyond its column (surface_face_ref: the opposite face of a
  // Surface cell's empty side), which for the outermost ghost column lies outside the halo
  // (the heap-buffer-overflow read of issue 13 item 8). On one rank without periodic sides
  // the exchange is a no-op.
  for (int i = -G; i < nxl + G; ++i) {
    const int gi = mac_.slab.i0 + i;
    const bool beyond_wall = !cfg_.periodic_x() && (gi < 0 || gi >= cfg_.grid.nx);
    if ((i < 0 || i >= nxl) && !beyond_wall) continue;
    u(i, -1) = detail::value(u_ref(i, -1), u);
    u(i, nz) = detail::value(u_ref(i, nz), u);
  }
  mac_.exchange(u);
}

void NdamSolver::boundary_faces(Field& u, Field& w) const {
  const int G = Field::G, nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
  // wall-normal faces and the columns beyond the walls; the silo gate (free surface) gives
  // u = u_in(z) below h_in and 0 above; an open outflow copies the last interior face.
  if (!cfg_.periodic_x()) {
    if (mac_.slab.i0 == 0)
      for (int k = -1; k <= nz; ++k) {
        const double v = cfg_.free_surface && k >= 0 && k < nz ? inflow_face(k) : 0.0;
        u(-1, k) = u(-2, k) = v;
      }
    if (mac_.slab.i0 + nxl == cfg_.grid.nx)
      for (int k = -1; k <= nz; ++k) {
        const double v =
            cfg_.free_surface && cfg_.outflow_right ? u(nxl - 2, k) + outflow_slope(k) : 0.0;
        u(nxl - 1, k) = u(nxl, k) = u(nxl + 1, k) = v;
      }
  }
  // w: walls top and bottom, tangential ghosts left and right
  for (int i = -G; i < nxl + G; ++i) {
    w(i, -1) = 0.0;
    w(i, nz - 1) = 0.0;
    w(i, nz) = 0.0;
  }
  if (!cfg_.periodic_x()) {
    if (mac_.slab.i0 == 0)
      for (int k = 0; k < nz - 1; ++k) w(-2, k) = w(-1, k) = detail::value(w_ref(-1, k), w);
    if (mac_.slab.i0 + nxl == cfg_.grid.nx)
      for (int k = 0; k < nz - 1; ++k) w(nxl + 1, k) = w(nxl, k) = detail::value(w_ref(nxl, k), w);
  }
  // Obstacles: the fixed faces (normal: 0; inside next to fluid: no-slip mirror) in the columns
  // the convective stencils of the owned faces reach.
  if (has_obstacles_)
    for (int i = -1; i <= nxl; ++i) {
      const int gi = mac_.slab.i0 + i;
      if (!cfg_.periodic_x() && (gi < 0 || gi >= cfg_.grid.nx)) continue;
      for (int k = 0; k < nz; ++k) {
        if (!mac_.u_unknown(i, k) && (cfg_.periodic_x() || gi < cfg_.grid.nx - 1))
          u(i, k) = detail::value(u_ref(i, k), u);
        if (k < nz - 1 && !mac_.w_unknown(i, k)) w(i, k) = detail::value(w_ref(i, k), w);
      }
    }
}

// Cell-centred scalars (p, phi, nu_eff): zero normal gradient at walls.
void NdamSolver::fill_scalar_ghosts(Field& s) const {
  mac_.exchange(s);
  const int G = Field::G, nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
  if (!cfg_.periodic_x()) {
    if (mac_.slab.i0 == 0)
      for (int k = 0; k < nz; ++k) s(-1, k) = s(-2, k) = s(0, k);
    if (mac_.slab.i0 + nxl == cfg_.grid.nx)
      for (int k = 0; k < nz; ++k) s(nxl, k) = s(nxl + 1, k) = s(nxl - 1, k);
  }
  for (int i = -G; i < nxl + G; ++i) {
    s(i, -1) = s(i, 0);
    s(i, nz) = s(i, nz - 1);
  }
}

// Coulomb sliding law (11)-(13) on the bed (and the end wall) as a Robin ghost value. At the
// bed the tangential stress of the material balances the friction,
//   nu_eff du/dz = tan(delta) c N,  N = p + 2 nu_eff du/dx (compressive normal stress, 13),
//   c = sgn(u_b) (1 - exp(-m_c |u_b|))                                   (12),
// written with the first inner face as u_b: nu_b (u(i,0) - u(i,-1)) / dz = tan(delta) N c.
// N and nu_b are lagged (t^n). In time, c is the mean of (12) over the base velocities of the
// step, c_mean(u^n, u^{n+1}) (rheology.hpp: the step's friction work is exact, |c| <= 1 so the
// stress never exceeds the Coulomb bound tan(delta) N, and c = c(u) at a steady slide; see
// docs/numerics.md, "Coulomb friction in time"). It is nonlinear in the unknown u^{n+1}, so it
// is linearised about a velocity v, c ~ c_l + d (u - v), which makes the ghost affine,
//   u(i,-1) = a u(i,0) + b  (coulomb_ghost),  q = dz tan(delta) N / nu_b,
// and the momentum step is repeated with v = its last solution until the law holds
// (relinearise_friction, Newton's method). Here, at the start of the step, the factors are the
// tangent of (12) at u^n: c_l = c(u^n), d = c'(u^n), v = u^n (linearised backward Euler: the
// exact stress c(u^n) at u = u^n and a positive drag, stable for any dt). The lagged form
// beta(u^n) u^{n+1} with beta = c(u^n) / |u^n| that this replaces exceeded the Coulomb bound
// by u^{n+1} / u^n while the base accelerates (issue 11). delta = 0 gives a = 1, b = 0: free
// slip. N at the bed: the mean over the material cells either side of the face, extrapolated
// hydrostatically by dz/2 (p_b = p_0 + g cos(zeta) dz / 2). In the implicit scheme, where both
// cells are pressure unknowns, the cell's -sigma_zz of the vertical balance that the last step
// solved (record_bed_stress: the step's pressure p^n + phi and its predictor's viscous normal
// stress) stands for p_0 + 2 nu_eff u_x, plus q - p^n where the nonlinear coupling evaluates
// the law at a trial pressure q (0 in a lagged step); elsewhere (a bottom cell that is not a
// pressure unknown, the first step, the explicit scheme) p_0 and u^n as written.
void NdamSolver::update_friction(const Field& p_yield) {
  const int G = Field::G, nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz(), m = cfg_.m_c;
  // the tangent of (12) at u^n: c_l = c(u^n), d = c'(u^n) = m exp(-m |u^n|)
  // (decided: the clamp of the nonlinear pressure system's first evaluation, stuck_frozen_)
  auto tangent = [&](double q, double un, double& a, double& b, const std::uint8_t* decided) {
    const double e = std::exp(-m * std::abs(un));
    return coulomb_ghost(q, (un >= 0.0 ? 1.0 : -1.0) * (1.0 - e), m * e, un, a, b, decided);
  };
  // A later evaluation of the nonlinear pressure system whose first evaluation took Newton
  // starts from the first evaluation's solution v instead (Newton's linearisation
  // c_mean(u^n, v) + dc (u - v), as relinearise_friction does): v is within the change of the
  // trial pressure from p^n of this evaluation's solution, so one solve meets
  // kFrictionTolerance where the tangent at u^n took two (docs/validation.md, "nonlinear
  // pressure": the momentum solves per step). Not the last evaluation's: a start that
  // depends on the order of the evaluations makes P(q) depend on it too, below the friction
  // tolerance, and Newton-Krylov's finite differences of P then failed their line search.
  const bool warm = friction_warm_start();
  auto linearise = [&](double q, double un, double v, double& a, double& b,
                       const std::uint8_t* decided) {
    if (!warm) return tangent(q, un, a, b, decided);
    const CoulombMean cm = coulomb_mean(m, un, v);
    return coulomb_ghost(q, cm.c, cm.dc, v, a, b, decided);
  };
  const auto nb = static_cast<std::size_t>(nxl + 2 * G);
  bed_a_.assign(nb, 1.0);
  bed_b_.assign(nb, 0.0);
  bed_q_.assign(nb, 0.0);
  bed_n_.assign(nb, 0.0);
  bed_stuck_.assign(nb, 0);
  // every column's surface traction (surface_traction_at_bed), for the filter through the depth
  std::vector<double> surf_t;
  if (cfg_.walls[2].kind == WallKind::Coulomb && cfg_.free_surface &&
      cfg_.momentum != Momentum::Explicit && !col_h_.empty()) {
    std::vector<double> local(static_cast<std::size_t>(nxl));
    for (int i = 0; i < nxl; ++i) local[static_cast<std::size_t>(i)] = surface_traction_at_bed(i);
    surf_t = mac_.gather_columns(local);
  }
  const bool balance = cfg_.momentum == Momentum::Implicit && bed_stress_.nx_local() == nxl;
  if (cfg_.walls[2].kind == WallKind::Coulomb)
    for (int i = -G; i < nxl + G; ++i) {
      const int gi = mac_.slab.i0 + i;
      // faces of a neighbour slab (or of the periodic wrap) take the owner's value below
      const bool inside = cfg_.periodic_x() || (gi >= 0 && gi < cfg_.grid.nx);
      if (inside && (i < 0 || i >= nxl)) continue;
      const int ir = std::min(i + 1, nxl + G - 1), il = std::max(i - 1, -G);
      const bool from_balance = balance && mac_.p_unknown(gi, 0) &&
                                mac_.p_unknown(gi + (ir - i), 0) &&
                                std::isfinite(bed_stress_(i, 0)) && std::isfinite(bed_stress_(ir, 0));
      double pb = 0.0;
      int n = 0;
      for (int c : {i, ir})
        if (mac_.fluid(gi + (c - i), 0)) {
          pb += loaded_pressure(
              c, 0, from_balance ? bed_stress_(c, 0) + (p_yield(c, 0) - p_(c, 0)) : p_yield(c, 0));
          ++n;
        }
      if (n == 0) continue;
      pb = pb / n + 0.5 * dz * std::abs(phys_.gz);
      // 'Full cell and weight': the momentum step drives every material cell as full, so the
      // bed carries the full cells' weight, g cos(zeta) (H - h) more than the markers' depth h
      // gives, H the top of the column's highest material cell; then a plug's friction per
      // unit driven mass is tan(delta) g cos(zeta) c(u) at depths on a marker row (the full cell
      // slid 17 % ahead of its law at 4.5 cells on 30/20 deg: an independent run). The same
      // weight raises the yield pressure of the column's cells (viscosity.cpp).
      if (cfg_.full_cell_weight) {
        double extra = 0.0;
        int ne = 0;
        for (int c : {i, ir}) {
          const int gc = gi + (c - i);
          if (!mac_.fluid(gc, 0)) continue;
          extra += full_cell_excess(gc);
          ++ne;
        }
        pb += std::abs(phys_.gz) * extra / ne;
      }
      // The implicit scheme's surface p = 0 leaves the viscous normal stress of the surface out
      // of p (free_surface.cpp): the bed does not carry that traction (surface_traction_at_bed).
      if (!surf_t.empty()) pb -= bed_surface_traction(gi, surf_t);
      const double nub = 0.5 * (nu_(i, 0) + nu_(ir, 0));
      const double dudx = (u_(ir, 0) - u_(il, 0)) / ((ir - il) * dx);
      const double N = std::max(0.0, pb + (from_balance ? 0.0 : 2.0 * nub * dudx));
      const auto f = static_cast<std::size_t>(i + G);
      bed_n_[f] = N;
      bed_q_[f] = dz * phys_.tan_delta * N / nub;
      // (a face beyond the box, i < 0 or i >= nxl on the end ranks, takes no part in Newton:
      // relinearise_friction checks the owned faces; it keeps the tangent at u^n)
      const bool owned = i >= 0 && i < nxl;
      bed_stuck_[f] = owned ? linearise(bed_q_[f], u_(i, 0),
                                        warm ? bed_v_first_[static_cast<std::size_t>(i)] : 0.0,
                                        bed_a_[f], bed_b_[f],
                                        stuck_frozen_ ? &bed_stuck_first_[f] : nullptr)
                            : tangent(bed_q_[f], u_(i, 0), bed_a_[f], bed_b_[f],
                                      stuck_frozen_ ? &bed_stuck_first_[f] : nullptr);
    }
  exchange_bed_factors();
  wall_a_.assign(static_cast<std::size_t>(nz), 1.0);
  wall_b_.assign(static_cast<std::size_t>(nz), 0.0);
  wall_q_.assign(static_cast<std::size_t>(nz), 0.0);
  wall_stuck_.assign(static_cast<std::size_t>(nz), 0);
  if (cfg_.walls[1].kind == WallKind::Coulomb && mac_.slab.i0 + nxl == cfg_.grid.nx)
    for (int k = 0; k < nz - 1; ++k) {
      const int i = nxl - 1, gi = mac_.slab.i0 + i;
      double pw = 0.0;
      int n = 0;
      for (int kk : {k, k + 1})
        if (mac_.fluid(gi, kk)) {
          pw += p_yield(i, kk);
          ++n;
        }
      if (n == 0) continue;
      // the end wall holds the downslope gravity: p grows by g sin(zeta) dx / 2 to the wall
      pw = pw / n + 0.5 * dx * std::max(0.0, phys_.gx);
      const double nuw = 0.5 * (nu_(i, k) + nu_(i, k + 1));
      const double dwdz = (w_(i, k + 1) - w_(i, std::max(k - 1, -1))) / ((k + 1 - std::max(k - 1, -1)) * dz);
      const double N = std::max(0.0, pw + 2.0 * nuw * dwdz);
      const auto f = static_cast<std::size_t>(k);
      wall_q_[f] = dx * phys_.tan_delta * N / nuw;
      wall_stuck_[f] = linearise(wall_q_[f], w_(i, k), warm ? wall_v_first_[f] : 0.0,
                                 wall_a_[f], wall_b_[f],
                                 stuck_frozen_ ? &wall_stuck_first_[f] : nullptr);
    }
}

// The bottom cells' normal stress of the vertical balance that this step solves, for the next
// step's Coulomb friction (update_friction). The step applies the pressure P = p^n + phi (the
// predictor's p^n, the projection's increment) and the viscous stress of the predictor's u*;
// summed over the cells of a row, the shear terms of the w rows cancel, so in a quasi-steady
// layer the rows carry its weight down to the bottom cells as -sigma_zz = P - 2 nu_eff w*_z, and
// over a periodic bed these sum to the weight (less the half cell below the centres; inertia,
// convection and, with the Material share, the share's weights of a partly filled cell enter
// the rows too).
// eq. (13) taken from the stored p^{n+1} = P - chi nu_eff div u* (the rotational update,
// projection.cpp) and u^{n+1} does not: the rotational term is the viscous splitting error for a
// uniform nu_eff only, and where nu_eff varies (a plug, nu_eff ~ tau_y m_y growing with depth)
// the bed's normal stress summed over the columns departed from the weight by -2 to +13 %, with
// the step and with m_y. A plug of 2.3-2.8 cells then lagged its law by 9-11 % (m_y = 1e4 s) at
// the CFL step and converged to it only as dt -> 0; one of 1.4-1.8 cells (one full cell under a
// partly filled one) by 1-2 % at any step; the material share's 2.3 cells at m_y = 1e4 s ran
// 3-5 % ahead at small steps (docs/validation.md, "The bed's normal stress from the step's own
// balance"). NaN where the bottom cell is not a pressure unknown (its p is a Dirichlet value
// and no w row carries it): update_friction then takes eq. (13) from p.
void NdamSolver::record_bed_stress(const Field& phi) {
  const int nxl = mac_.slab.nx_local;
  const double dz = cfg_.grid.dz();
  // no Coulomb bed, or the explicit scheme: nothing to record (nor to checkpoint)
  if (cfg_.momentum != Momentum::Implicit || cfg_.walls[2].kind != WallKind::Coulomb) {
    bed_stress_new_ = Field();
    return;
  }
  if (bed_stress_new_.nx_local() != nxl || bed_stress_new_.nz() != cfg_.grid.nz)
    bed_stress_new_ = Field(nxl, cfg_.grid.nz);
  bed_stress_new_.fill(std::numeric_limits<double>::quiet_NaN());
  for (int i = 0; i < nxl; ++i)
    if (mac_.p_unknown(mac_.slab.i0 + i, 0))
      bed_stress_new_(i, 0) = p_(i, 0) + phi(i, 0) -
                              2.0 * nu_normal(i, 0) * (w_star_(i, 0) - w_star_(i, -1)) / dz;
  fill_scalar_ghosts(bed_stress_new_);
}

std::vector<double> NdamSolver::bed_normal_stress() const {
  const int G = Field::G, nxl = mac_.slab.nx_local;
  std::vector<double> n(static_cast<std::size_t>(nxl), 0.0);
  if (bed_n_.size() == static_cast<std::size_t>(nxl + 2 * G))
    for (int i = 0; i < nxl; ++i) n[static_cast<std::size_t>(i)] = bed_n_[static_cast<std::size_t>(i + G)];
  return n;
}

bool NdamSolver::friction_warm_start() const {
  return stuck_frozen_ && friction_newton_first_ &&
         bed_v_first_.size() == static_cast<std::size_t>(mac_.slab.nx_local) &&
         wall_v_first_.size() == static_cast<std::size_t>(cfg_.grid.nz);
}

// Newton's method on the friction of the step (update_friction): after a momentum solve us, ws
// with the current factors, the residual of the law at each Coulomb face,
//   r = |c_used - c_mean(u^n, u)|,  c_used = (u - ghost) / q = c_l + d (u - v)
// (the factor the solve applied, against the step's mean factor at its solution u; in units of
// the Coulomb bound tan(delta) N), and how far c_used went beyond the bound, |c_used| - 1. The
// factors are relinearised about the solution, c_l = c_mean(u^n, u), d = d c_mean / du, v = u,
// for another solve when `iterate(r, overshoot)` says so (max over the faces of all ranks).
// Returns max r (collective). Faces clamped to sticking are left out (the law is replaced by
// no-slip there), and so are the fixed faces beyond the box.
double NdamSolver::relinearise_friction(const Field& us, const Field& ws,
                                        const std::function<bool(double, double, double)>& iterate,
                                        bool& relinearised) {
  const int G = Field::G, nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
  const double m = cfg_.m_c;
  struct Face {
    std::size_t f;
    bool bed;
    double q, u0, u1;
  };
  std::vector<Face> faces;
  double r = 0.0, r_acc = 0.0, over = -1.0;
  auto check = [&](bool bed, std::size_t f, double q, double ghost_a, double ghost_b, double u0,
                   double u1) {
    const double used = (u1 - (ghost_a * u1 + ghost_b)) / q;
    const double res = std::abs(used - coulomb_mean(m, u0, u1).c);
    r = std::max(r, res);
    // a base speeding up in its direction of motion (not reversing, not slowing down)
    if (u0 * u1 > 0.0 && std::abs(u1) > std::abs(u0)) r_acc = std::max(r_acc, res);
    over = std::max(over, std::abs(used) - 1.0);
    faces.push_back({f, bed, q, u0, u1});
  };
  if (cfg_.walls[2].kind == WallKind::Coulomb)
    for (int i = 0; i < nxl; ++i) {
      const auto f = static_cast<std::size_t>(i + G);
      if (bed_q_[f] > 0.0 && !bed_stuck_[f] && mac_.u_unknown(i, 0))
        check(true, f, bed_q_[f], bed_a_[f], bed_b_[f], u_(i, 0), us(i, 0));
    }
  if (cfg_.walls[1].kind == WallKind::Coulomb && mac_.slab.i0 + nxl == cfg_.grid.nx)
    for (int k = 0; k < nz - 1; ++k) {
      const auto f = static_cast<std::size_t>(k);
      if (wall_q_[f] > 0.0 && !wall_stuck_[f] && mac_.w_unknown(nxl - 1, k))
        check(false, f, wall_q_[f], wall_a_[f], wall_b_[f], w_(nxl - 1, k), ws(nxl - 1, k));
    }
  r = detail::allreduce_max(r, comm_);
  r_acc = detail::allreduce_max(r_acc, comm_);
  over = detail::allreduce_max(over, comm_);
  relinearised = iterate(r, r_acc, over);
  if (!relinearised) return r;
  // a face left unclamped by the first evaluation of the nonlinear pressure system stays so
  static constexpr std::uint8_t kUnclamped = 0;
  const std::uint8_t* decided = stuck_frozen_ ? &kUnclamped : nullptr;
  for (const Face& fc : faces) {
    const CoulombMean cm = coulomb_mean(m, fc.u0, fc.u1);
    if (fc.bed)
      bed_stuck_[fc.f] = coulomb_ghost(fc.q, cm.c, cm.dc, fc.u1, bed_a_[fc.f], bed_b_[fc.f], decided);
    else
      wall_stuck_[fc.f] = coulomb_ghost(fc.q, cm.c, cm.dc, fc.u1, wall_a_[fc.f], wall_b_[fc.f], decided);
  }
  exchange_bed_factors();
  return r;
}

// The Coulomb factors of the faces in the ghost columns that belong to a neighbour slab (or to
// the other end of a periodic box): the owner's values, so that every rank uses one factor per
// face whatever the slab layout (and a restart, which stores the owners' values, sees the same).
void NdamSolver::exchange_bed_factors() {
  if (cfg_.walls[2].kind != WallKind::Coulomb) return;
  const int G = Field::G, nxl = mac_.slab.nx_local;
  for (std::vector<double>* v : {&bed_a_, &bed_b_}) {
    auto* a = v->data();
    // my first G faces to the left neighbour, its last G into my right ghosts; and mirrored
    std::vector<double> recv_r(static_cast<std::size_t>(G), 1.0), recv_l(recv_r);
    MPI_Sendrecv(a + G, G, MPI_DOUBLE, mac_.left, 21, recv_r.data(), G, MPI_DOUBLE, mac_.right,
                 21, comm_, MPI_STATUS_IGNORE);
    MPI_Sendrecv(a + nxl, G, MPI_DOUBLE, mac_.right, 22, recv_l.data(), G, MPI_DOUBLE,
                 mac_.left, 22, comm_, MPI_STATUS_IGNORE);
    if (mac_.right != MPI_PROC_NULL)
      for (int q = 0; q < G; ++q) a[nxl + G + q] = recv_r[static_cast<std::size_t>(q)];
    if (mac_.left != MPI_PROC_NULL)
      for (int q = 0; q < G; ++q) a[q] = recv_l[static_cast<std::size_t>(q)];
  }
}

}  // namespace granflow::ndam
