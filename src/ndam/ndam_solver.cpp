// N-DAM time step on the staggered MAC grid (see ndam_solver.hpp for the equations and grid.hpp
// for the index conventions). One step:
//
//   predict_velocity   u* = u^n + dt [ -C(u^n) + g - G p^n + V(u) ]       V = div(2 nu_eff D(u))
//                      explicit: V(u^n);  implicit: (I/dt - V) u* = ..., V with nu_eff(t^n)
//   solve_pressure     -L phi = -D u* / dt        (D: divergence, L = D G with wall faces fixed)
//   correct_velocity   u^{n+1} = u* - dt G phi,  p^{n+1} = p^n + phi - chi nu_eff D u*
//                      (chi = 2 implicit: rotational pressure update; chi = 0 explicit)
//
// C is NaSt2D's convective term in conservative form, blended between central differences and
// donor-cell upwinding by gamma. V is the divergence of the discrete stress: normal stresses
// 2 nu_eff du/dx, 2 nu_eff dw/dz at cell centres, shear stress nu_eff (du/dz + dw/dx) at cell
// corners with nu_eff averaged from the four cells around the corner. Written this way V is the
// (negative) adjoint of the discrete strain rate weighted by nu_eff, so I/dt - V is symmetric
// positive definite (CG applies) and, unlike nu_eff Laplace(u), it is the right operator when
// nu_eff varies.
//
// Boundary values enter through `Ref`: every velocity sample the stencils touch is written as
// a * (unknown) + b, where ghost values of no-slip/moving walls are 2 U_wall - u_inside,
// free-slip ghosts are u_inside, wall-normal faces are fixed (a = 0), and periodic columns wrap.
// The explicit operator evaluates the same Refs that the implicit one assembles, so the two
// treatments share one discretisation.
#include "granflow/ndam/ndam_solver.hpp"

#include "granflow/io/fields.hpp"
#include "granflow/params/parameters.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace granflow::ndam {

using Clock = std::chrono::steady_clock;

namespace {
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}
double allreduce_max(double v, MPI_Comm c) {
  double r = v;
  MPI_Allreduce(&v, &r, 1, MPI_DOUBLE, MPI_MAX, c);
  return r;
}
std::string gstr(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}
double allreduce_sum(double v, MPI_Comm c) {
  double r = v;
  MPI_Allreduce(&v, &r, 1, MPI_DOUBLE, MPI_SUM, c);
  return r;
}
}  // namespace

/// A velocity sample as a * x[gid] + b: gid is the global unknown (or -1 when a == 0), loc the
/// position of x in this rank's field (with its ghosts filled, a * field[loc] + b is its value).
struct NdamSolver::Ref {
  long long gid = -1;
  std::size_t loc = 0;
  double a = 0.0, b = 0.0;
};

// ---------------------------------------------------------------------------------------------
// Construction
// ---------------------------------------------------------------------------------------------
NdamSolver::NdamSolver(MPI_Comm comm, const NdamConfig& cfg, const Rheology& rheo,
                       const NdamPhysics& phys)
    : comm_(comm), cfg_(cfg), rheo_(rheo), phys_(phys) {
  int rank = 0, ranks = 1;
  MPI_Comm_rank(comm_, &rank);
  MPI_Comm_size(comm_, &ranks);
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  if (nx < 2 * ranks)
    throw params::InputError("N-DAM: 'Cells x' = " + std::to_string(nx) + " is too few for " +
                             std::to_string(ranks) + " ranks (need >= 2 columns per rank)");
  slab_ = Slab::split(nx, rank, ranks);
  const bool per = cfg_.periodic_x();
  left_ = rank > 0 ? rank - 1 : (per ? ranks - 1 : MPI_PROC_NULL);
  right_ = rank < ranks - 1 ? rank + 1 : (per ? 0 : MPI_PROC_NULL);

  const int nxl = slab_.nx_local;
  u_ = Field(nxl, nz);
  w_ = Field(nxl, nz);
  p_ = Field(nxl, nz);
  nu_ = Field(nxl, nz, rheo_.nu);
  // Cell flags of the whole box on every rank (small, and the stencils near slab edges need
  // their neighbours' flags): obstacle where a cell centre lies in an obstacle rectangle.
  flags_.assign(static_cast<std::size_t>(nx * nz), CellFlag::Fluid);
  for (const auto& r : cfg_.obstacles) {
    int covered = 0;
    for (int gi = 0; gi < nx; ++gi)
      for (int k = 0; k < nz; ++k) {
        const double x = (gi + 0.5) * cfg_.grid.dx(), z = (k + 0.5) * cfg_.grid.dz();
        if (x > r[0] && x < r[1] && z > r[2] && z < r[3]) {
          flags_[static_cast<std::size_t>(gi * nz + k)] = CellFlag::Obstacle;
          ++covered;
        }
      }
    if (covered == 0) {
      std::ostringstream os;
      os << "N-DAM->Obstacles: rectangle '" << r[0] << " " << r[1] << " " << r[2] << " " << r[3]
         << "' contains no cell centre on this grid; allowed: rectangles that cover at least "
            "one cell";
      throw params::InputError(os.str());
    }
    has_obstacles_ = true;
  }
  if (cfg_.free_surface) {
    if (has_obstacles_)
      throw params::InputError("N-DAM->Obstacles: obstacles are not available with 'Free "
                               "surface' = true in this version; allowed: no obstacles");
    // Markers: the left side injects (MarkerSet reflects there like a wall when nothing is
    // injected), the right side removes at an open outflow; bed and top are walls.
    MarkerConfig mc;
    mc.per_cell_x = mc.per_cell_z = cfg_.markers_per_cell;
    mc.sides[0] = per ? MarkerBoundary::Periodic : MarkerBoundary::Inflow;
    mc.sides[1] = per ? MarkerBoundary::Periodic
                      : (cfg_.outflow_right ? MarkerBoundary::Outflow : MarkerBoundary::Wall);
    markers_ = std::make_unique<MarkerSet>(comm_, cfg_.grid, slab_, mc);
    const double xa = cfg_.initial_x0 - cfg_.x0, xb = cfg_.initial_x1 - cfg_.x0,
                 h0 = cfg_.initial_depth;
    if (h0 > 0.0) markers_->seed([&](double x, double z) { return x >= xa && x < xb && z < h0; });
    mass0_ = markers_->mass().area;
    marker_mass_ = markers_->mass();
    update_flags_from_markers();
  }
  p_dir_ = Field(nxl, nz);
  normD_ = Field(nxl, nz);
  fluid_cells_ = 0;
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k)
      if (p_unknown(gi, k)) ++fluid_cells_;
  if (fluid_cells_ == 0 && !cfg_.free_surface)
    throw params::InputError("N-DAM->Obstacles: the obstacles fill the whole box; allowed: "
                             "rectangles that leave fluid cells");

  // Pressure: one unknown per cell, numbered gi * nz + k (contiguous per slab). The matrix -L
  // changes only with the cell flags: it is assembled now and again whenever the flags change
  // (free surface); its preconditioner is set up after each assembly.
  pressure_ = std::make_unique<solvers::LinearSystem>(
      comm_, static_cast<long long>(nx) * nz, p_gid(slab_.i0, 0), nxl * nz, cfg_.pressure_solver);
  assemble_pressure();
  if (cfg_.momentum == Momentum::Implicit) {
    // u and w of a cell are interleaved (2 (gi nz + k) and +1) so that MueLu can aggregate them
    // as two equations per node; wall-normal faces are identity rows.
    Teuchos::ParameterList mp = cfg_.momentum_solver;
    if (!mp.sublist("MueLu").isParameter("number of equations"))
      mp.sublist("MueLu").set("number of equations", 2);
    momentum_ = std::make_unique<solvers::LinearSystem>(
        comm_, 2LL * nx * nz, 2 * p_gid(slab_.i0, 0), 2 * nxl * nz, mp);
  }
  bed_a_.assign(static_cast<std::size_t>(nxl + 2 * Field::G), 1.0);
  wall_a_.assign(static_cast<std::size_t>(nz), 1.0);
  if (cfg_.inflow) inflow_now_ = cfg_.inflow(0.0);
  fill_velocity_ghosts(u_, w_);
  update_viscosity(p_);
  initial_pressure();
  if (cfg_.free_surface) {
    update_viscosity(p_);  // Coulomb factors with the initial pressure
    update_profile_cache();
  }
  u_new_ = u_;
  w_new_ = w_;
  p_new_ = p_;
}

NdamSolver::~NdamSolver() = default;

void NdamSolver::assemble_pressure() {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz, nxl = slab_.nx_local;
  const bool per = cfg_.periodic_x();
  // A closed region of Fluid cells without Dirichlet neighbours (no free surface) has the
  // singular pure-Neumann Laplacian: pin phi = 0 in its first cell. With a free surface the
  // Surface and Empty cells are Dirichlet cells and no pin is needed.
  pin_ = -1;
  bool dirichlet = false;
  for (int gi = 0; gi < nx && !dirichlet; ++gi)
    for (int k = 0; k < nz; ++k) {
      const CellFlag f = flags_[static_cast<std::size_t>(gi * nz + k)];
      if (f == CellFlag::Surface || f == CellFlag::Empty) {
        dirichlet = true;
        break;
      }
    }
  if (!dirichlet)
    for (int gi = 0; gi < nx && pin_ < 0; ++gi)
      for (int k = 0; k < nz; ++k)
        if (p_unknown(gi, k)) {
          pin_ = p_gid(gi, k);
          break;
        }
  fluid_cells_ = 0;
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k)
      if (p_unknown(gi, k)) ++fluid_cells_;
  const double cx = 1.0 / (cfg_.grid.dx() * cfg_.grid.dx());
  const double cz = 1.0 / (cfg_.grid.dz() * cfg_.grid.dz());
  pressure_->begin();
  for (int i = 0; i < nxl; ++i) {
    const int gi = slab_.i0 + i;
    for (int k = 0; k < nz; ++k) {
      const long long row = p_gid(gi, k);
      // The pinned cell and every cell that is not a pressure unknown (obstacle: phi = 0;
      // Surface: phi from the normal-stress condition; Empty: p = 0) is an identity row whose
      // right-hand side is its value. An unknown next to such a Dirichlet cell moves the
      // coupling to its right-hand side (solve_pressure), which keeps -L symmetric positive
      // definite. Faces to walls, obstacles and the open outflow carry no phi flux (Neumann,
      // eq. 14 for the projection increment).
      if (row == pin_ || !p_unknown(gi, k)) {
        pressure_->add(row, row, row == pin_ ? cx + cz : 1.0);
        continue;
      }
      auto couple = [&](int gn, int kn, double c) {
        const CellFlag f = gflag(gn, kn);
        if (f == CellFlag::Obstacle) return;
        pressure_->add(row, row, c);
        if (!p_unknown(gn, kn)) return;  // Dirichlet neighbour: right-hand side
        const long long col = p_gid(per ? (gn % nx + nx) % nx : gn, kn);
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

// ---------------------------------------------------------------------------------------------
// Boundary conditions as Refs, ghost exchange
// ---------------------------------------------------------------------------------------------
CellFlag NdamSolver::gflag(int gi, int k) const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  if (k < 0 || k >= nz) return CellFlag::Obstacle;
  if (cfg_.periodic_x()) gi = (gi % nx + nx) % nx;
  else if (gi < 0 || gi >= nx) return CellFlag::Obstacle;
  return flags_[static_cast<std::size_t>(gi * nz + k)];
}

// Material cells (Fluid or Surface) carry momentum; only Fluid cells carry pressure unknowns.
bool NdamSolver::fluid(int gi, int k) const {
  const CellFlag f = gflag(gi, k);
  return f == CellFlag::Fluid || f == CellFlag::Surface;
}

bool NdamSolver::p_unknown(int gi, int k) const {
  // With the pressure of eq. (26) imposed at a 1D-to-2D interface, the material cells of the
  // inflow column are Dirichlet cells too.
  if (cfg_.inflow_pressure == InflowPressure::Dirichlet && gi == 0 && !cfg_.periodic_x() &&
      fluid(gi, k))
    return false;
  return gflag(gi, k) == CellFlag::Fluid;
}

// A face is an unknown when the cells on both sides are fluid; the faces at x = 0 and x = L
// (non-periodic) and all faces touching an obstacle cell are fixed.
bool NdamSolver::u_unknown(int i, int k) const {
  const int gi = slab_.i0 + i;
  if (!cfg_.periodic_x() && (gi < 0 || gi >= cfg_.grid.nx - 1)) return false;
  return fluid(gi, k) && fluid(gi + 1, k);
}

bool NdamSolver::w_unknown(int i, int k) const {
  const int gi = slab_.i0 + i;
  if (k < 0 || k >= cfg_.grid.nz - 1) return false;
  if (!cfg_.periodic_x() && (gi < 0 || gi >= cfg_.grid.nx)) return false;
  return fluid(gi, k) && fluid(gi, k + 1);
}

NdamSolver::Ref NdamSolver::u_ref(int i, int k) const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  if (k < 0 || k >= nz) {
    // tangential ghost below the bottom / above the top wall
    const Wall& wl = cfg_.walls[k < 0 ? 2 : 3];
    Ref r = u_ref(i, k < 0 ? 0 : nz - 1);
    if (wl.kind == WallKind::Coulomb) {
      // Coulomb sliding (11)-(13) as a Robin ghost u(i,-1) = a u(i,0), a from update_viscosity
      const double a = bed_a_[static_cast<std::size_t>(i + Field::G)];
      r.a *= a;
      r.b *= a;
      return r;
    }
    const double s = wl.kind == WallKind::FreeSlip ? 1.0 : -1.0;
    r.a *= s;
    r.b = s * r.b + (wl.kind == WallKind::MovingLid ? 2.0 * wl.velocity : 0.0);
    return r;
  }
  Ref r;
  r.loc = u_.index(i, k);
  if (!u_unknown(i, k)) {
    // A face inside an obstacle (no fluid on either side) next to a fluid face above or below
    // is the tangential ghost of the obstacle's no-slip surface: minus that fluid face.
    // Every other fixed face is wall- or obstacle-normal: u = 0.
    const int gi = slab_.i0 + i;
    if (has_obstacles_ && !fluid(gi, k) && !fluid(gi + 1, k)) {
      for (int kn : {k + 1, k - 1})
        if (u_unknown(i, kn)) {
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
          // Zero gradient. Fix (issue 5): when the last column holds a Surface cell whose left
          // neighbour is empty (the tail of a layer leaving through the open end), that cell's
          // left face follows this one (surface_face_ref) and this one followed it back: an
          // endless recursion (stack overflow once the front had left a chute). Such a face
          // keeps its value, like the other known faces of an empty region.
          if (!fluid(nx - 2, k) && fluid(nx - 1, k)) {
            r.a = 1.0;
            return r;
          }
          Ref m = u_ref(nx - 2 - slab_.i0, k);
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
  const int gi = ((slab_.i0 + i) % nx + nx) % nx;
  r.gid = 2 * p_gid(gi, k);
  r.a = 1.0;
  return r;
}

NdamSolver::Ref NdamSolver::w_ref(int i, int k) const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  Ref r;
  r.loc = w_.index(i, k);
  if (k <= -1 || k >= nz - 1) return r;  // bottom and top walls: w = 0
  const int gi = slab_.i0 + i;
  if (!cfg_.periodic_x() && (gi < 0 || gi >= nx)) {
    // tangential ghost left of x = 0 / right of x = L: mirror of the first inner column
    const Wall& wl = cfg_.walls[gi < 0 ? 0 : 1];
    Ref m = w_ref(gi < 0 ? i + 1 : i - 1, k);
    if (wl.kind == WallKind::Coulomb && gi >= nx) {
      // Coulomb sliding at the end wall: Robin ghost w(nx, k) = a w(nx-1, k)
      const double a = wall_a_[static_cast<std::size_t>(k)];
      m.a *= a;
      m.b *= a;
      return m;
    }
    const double s = wl.kind == WallKind::FreeSlip ? 1.0 : -1.0;
    m.a *= s;
    m.b = s * m.b + (wl.kind == WallKind::MovingLid ? 2.0 * wl.velocity : 0.0);
    return m;
  }
  if (!w_unknown(i, k)) {
    // inside an obstacle next to a fluid face left or right: no-slip tangential ghost
    if (has_obstacles_ && !fluid(gi, k) && !fluid(gi, k + 1)) {
      for (int in : {i + 1, i - 1})
        if (w_unknown(in, k)) {
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
  r.gid = 2 * p_gid((gi % nx + nx) % nx, k) + 1;
  r.a = 1.0;
  return r;
}

// The empty-side face (c, i, k) of a Surface cell as its opposite face plus the lagged
// difference; a Ref with a = 0 and gid = -1 (and b = 0) when the face is not of that kind.
NdamSolver::Ref NdamSolver::surface_face_ref(Comp c, int i, int k) const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  const int gi = slab_.i0 + i;
  // the two cells of the face: (gi, k) and (gi + 1, k) for u, (gi, k) and (gi, k + 1) for w
  const int g2 = c == U ? gi + 1 : gi, k2 = c == U ? k : k + 1;
  const bool m1 = fluid(gi, k), m2 = fluid(g2, k2);
  if (m1 == m2) return Ref{};
  const int gs = m1 ? gi : g2, ks = m1 ? k : k2;  // the Surface cell
  if (gflag(gs, ks) != CellFlag::Surface) return Ref{};
  const int gw = cfg_.periodic_x() ? (gs % nx + nx) % nx : gs;
  const std::uint8_t mask = empty_mask_[static_cast<std::size_t>(gw * nz + ks)];
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
  Ref m = ref(c, io, ko);
  const Field& f = c == U ? u_ : w_;
  m.b += f(i, k) - f(io, ko);
  return m;
}

NdamSolver::Ref NdamSolver::ref(Comp c, int i, int k) const {
  return c == U ? u_ref(i, k) : w_ref(i, k);
}

// Ghost columns from the neighbour slabs (periodic wrap included); G columns of nz + 2 values
// are contiguous in a Field.
void NdamSolver::exchange(Field& f) const {
  const int G = Field::G, nxl = slab_.nx_local;
  const int n = G * (cfg_.grid.nz + 2);
  // send my first G columns to the left, receive my right ghosts from the right
  MPI_Sendrecv(f.column(0), n, MPI_DOUBLE, left_, 11, f.column(nxl), n, MPI_DOUBLE, right_, 11,
               comm_, MPI_STATUS_IGNORE);
  // send my last G columns to the right, receive my left ghosts from the left
  MPI_Sendrecv(f.column(nxl - G), n, MPI_DOUBLE, right_, 12, f.column(-G), n, MPI_DOUBLE, left_,
               12, comm_, MPI_STATUS_IGNORE);
}

void NdamSolver::fill_velocity_ghosts(Field& u, Field& w) const {
  exchange(u);
  exchange(w);
  boundary_faces(u, w);
  if (cfg_.free_surface) {
    // The free-surface faces of the owned columns and of one ghost column on each side are set
    // redundantly on both ranks from the same data (each such face depends only on its own
    // surface cell), then the exchange makes the ghosts the owners' values.
    apply_free_surface(u, w);
    exchange(u);
    exchange(w);
    boundary_faces(u, w);
  }
  const int G = Field::G, nxl = slab_.nx_local, nz = cfg_.grid.nz;
  auto eval = [](const Ref& r, const Field& f) {
    return r.a == 0.0 ? r.b : r.a * f.data()[r.loc] + r.b;
  };
  // u: tangential ghost rows below and above
  for (int i = -G; i < nxl + G; ++i) {
    u(i, -1) = eval(u_ref(i, -1), u);
    u(i, nz) = eval(u_ref(i, nz), u);
  }
}

void NdamSolver::boundary_faces(Field& u, Field& w) const {
  const int G = Field::G, nxl = slab_.nx_local, nz = cfg_.grid.nz;
  auto eval = [](const Ref& r, const Field& f) {
    return r.a == 0.0 ? r.b : r.a * f.data()[r.loc] + r.b;
  };
  // wall-normal faces and the columns beyond the walls; the silo gate (free surface) gives
  // u = u_in(z) below h_in and 0 above; an open outflow copies the last interior face.
  if (!cfg_.periodic_x()) {
    if (slab_.i0 == 0)
      for (int k = -1; k <= nz; ++k) {
        const double v = cfg_.free_surface && k >= 0 && k < nz ? inflow_face(k) : 0.0;
        u(-1, k) = u(-2, k) = v;
      }
    if (slab_.i0 + nxl == cfg_.grid.nx)
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
    if (slab_.i0 == 0)
      for (int k = 0; k < nz - 1; ++k) w(-2, k) = w(-1, k) = eval(w_ref(-1, k), w);
    if (slab_.i0 + nxl == cfg_.grid.nx)
      for (int k = 0; k < nz - 1; ++k) w(nxl + 1, k) = w(nxl, k) = eval(w_ref(nxl, k), w);
  }
  // Obstacles: the fixed faces (normal: 0; inside next to fluid: no-slip mirror) in the columns
  // the convective stencils of the owned faces reach.
  if (has_obstacles_)
    for (int i = -1; i <= nxl; ++i) {
      const int gi = slab_.i0 + i;
      if (!cfg_.periodic_x() && (gi < 0 || gi >= cfg_.grid.nx)) continue;
      for (int k = 0; k < nz; ++k) {
        if (!u_unknown(i, k) && (cfg_.periodic_x() || gi < cfg_.grid.nx - 1))
          u(i, k) = eval(u_ref(i, k), u);
        if (k < nz - 1 && !w_unknown(i, k)) w(i, k) = eval(w_ref(i, k), w);
      }
    }
}

// Cell-centred scalars (p, phi, nu_eff): zero normal gradient at walls.
void NdamSolver::fill_scalar_ghosts(Field& s) const {
  exchange(s);
  const int G = Field::G, nxl = slab_.nx_local, nz = cfg_.grid.nz;
  if (!cfg_.periodic_x()) {
    if (slab_.i0 == 0)
      for (int k = 0; k < nz; ++k) s(-1, k) = s(-2, k) = s(0, k);
    if (slab_.i0 + nxl == cfg_.grid.nx)
      for (int k = 0; k < nz; ++k) s(nxl, k) = s(nxl + 1, k) = s(nxl - 1, k);
  }
  for (int i = -G; i < nxl + G; ++i) {
    s(i, -1) = s(i, 0);
    s(i, nz) = s(i, nz - 1);
  }
}

// ---------------------------------------------------------------------------------------------
// Free surface (marker-and-cell, NaSt2D ch. 7)
// ---------------------------------------------------------------------------------------------
// Inflow velocity of row k of the gate opening 0 <= z < h_in: the material velocity of the row
// (u_in(z) on its open part), like every face of a partly filled Surface cell inside the box; the
// mass that enters is the markers' (accept(): each row's open part times its face value, so the
// total is h_in u_mean). Uniform: u_in(z) = u_in. CopyInterior (eq. 25): the shape of the first
// interior column u(0,k), scaled so that its mean over the opening [0, h_in] is u_in.
// Fix (issue 5): the face value used to be flux-equivalent, u_in times the open part of the
// face. A row only partly below h_in is the top material row, and the interior faces of such a
// row carry the full material velocity, so the gate slowed the top row down; with CopyInterior
// the slowed row came back through the copied shape at every step and was slowed again, which
// turned the profile over (measured in Setup I coupled at 5 mm: u = 2.78 / 1.76 m/s in the two
// rows of the first 2D column behind x = 0.7 m against a plug of 2.56 / 2.58 m/s in full 2D, and
// the downstream 2D part 3 % slow). Openings on cell boundaries (the shipped silo gates) are
// unchanged.
double NdamSolver::inflow_face(int k) const {
  const double h = inflow_now_[0], um = inflow_now_[1], dz = cfg_.grid.dz();
  if (!(h > 0.0)) return 0.0;
  const double open = std::clamp((h - k * dz) / dz, 0.0, 1.0);
  if (open <= 0.0) return 0.0;
  if (cfg_.inflow_shape == InflowShape::Uniform || slab_.i0 != 0) return um;
  // shape from column 0 (this rank owns it): mean of the shape over the opening
  double q = 0.0;
  for (int kk = 0; kk < cfg_.grid.nz; ++kk) {
    const double o = std::clamp((h - kk * dz) / dz, 0.0, 1.0);
    if (o <= 0.0) break;
    q += o * dz * u_(0, kk);
  }
  const double mean = q / h;
  if (!(std::abs(mean) > 1e-12)) return um;  // no shape yet (empty column): uniform
  return um * u_(0, k) / mean;
}

// Lagged gradient continued through an open outflow (NdamConfig::outflow_extrapolate): the
// difference of the last two interior faces of row k in the current state u_, where both are
// material faces; 0 otherwise (zero gradient) and on ranks that do not own the end.
double NdamSolver::outflow_slope(int k) const {
  const int nx = cfg_.grid.nx, i = nx - 2 - slab_.i0;
  if (!cfg_.outflow_extrapolate || slab_.i0 + slab_.nx_local != nx || i - 1 < -Field::G) return 0.0;
  if (!u_unknown(i, k) || !u_unknown(i - 1, k)) return 0.0;
  return u_(i, k) - u_(i - 1, k);
}

// eq. (26): p = g cos(zeta) (h - z) (1 + K) / 2 with h the inflow depth, at the row's centre
double NdamSolver::inflow_p26(int k) const {
  const double z = (k + 0.5) * cfg_.grid.dz();
  return std::abs(phys_.gz) * std::max(0.0, inflow_now_[0] - z) * (1.0 + cfg_.inflow_K) / 2.0;
}

void NdamSolver::set_inflow(std::function<std::array<double, 2>(double t)> provider,
                            InflowShape shape, InflowPressure pressure, double K,
                            InflowMass mass) {
  if (!cfg_.free_surface || cfg_.periodic_x())
    throw params::InputError("N-DAM: an inflow needs 'Free surface' = true and a non-periodic box");
  cfg_.inflow = std::move(provider);
  cfg_.inflow_shape = shape;
  cfg_.inflow_pressure = pressure;
  cfg_.inflow_K = K;
  inflow_mass_ = std::move(mass);
  inflow_owed_ = inflow_owed_new_ = 0.0;
  inflow_now_ = cfg_.inflow ? cfg_.inflow(t_) : std::array<double, 2>{0.0, 0.0};
  flags_changed_ = true;  // the Dirichlet cells of eq. (26) may have changed
  fill_velocity_ghosts(u_, w_);
}

// Flags from the marker counts of all cells (gathered on every rank, so that every rank holds
// the flags of the whole box as the stencils near the slab edges need): a cell with markers is
// material, Surface if one of its four neighbours inside the box is Empty (with the mask of its
// empty sides), else Fluid; outside the box counts as not empty (walls, gate, outflow, top).
void NdamSolver::update_flags_from_markers() {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  const auto counts = markers_->cell_counts();
  std::vector<double> local(counts.begin(), counts.end());
  const auto all = gather_columns(local);
  const auto old = flags_;
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k) {
      auto& f = flags_[static_cast<std::size_t>(gi * nz + k)];
      if (f == CellFlag::Obstacle) continue;
      f = all[static_cast<std::size_t>(gi * nz + k)] > 0.0 ? CellFlag::Fluid : CellFlag::Empty;
    }
  empty_mask_.assign(flags_.size(), 0);
  const bool per = cfg_.periodic_x();
  auto empty = [&](int gi, int k) {
    if (k < 0 || k >= nz) return false;
    if (per) gi = (gi % nx + nx) % nx;
    else if (gi < 0 || gi >= nx) return false;
    return flags_[static_cast<std::size_t>(gi * nz + k)] == CellFlag::Empty;
  };
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k) {
      const auto q = static_cast<std::size_t>(gi * nz + k);
      if (flags_[q] != CellFlag::Fluid) continue;
      std::uint8_t m = 0;
      if (empty(gi - 1, k)) m |= empty_side::Left;
      if (empty(gi + 1, k)) m |= empty_side::Right;
      if (empty(gi, k - 1)) m |= empty_side::Bottom;
      if (empty(gi, k + 1)) m |= empty_side::Top;
      empty_mask_[q] = m;
    }
  for (std::size_t q = 0; q < flags_.size(); ++q)
    if (empty_mask_[q]) flags_[q] = CellFlag::Surface;
  if (flags_ != old) flags_changed_ = true;
}

// Normal-stress condition of the free surface (NaSt2D): p = 2 nu_eff n.D.n in a Surface cell,
// n.D.n the normal strain rate of its empty sides (du/dx for left/right, dw/dz for
// bottom/top), averaged over them when there are several (the mixed normals of corner cells are
// not resolved). Empty cells: p = 0. Evaluated with u^n and nu_eff(t^n) (lagged).
void NdamSolver::surface_pressure(Field& target) const {
  const int nz = cfg_.grid.nz;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  for (int i = 0; i < slab_.nx_local; ++i)
    for (int k = 0; k < nz; ++k) {
      const int gi = slab_.i0 + i;
      const CellFlag f = gflag(gi, k);
      if (f == CellFlag::Empty) target(i, k) = 0.0;
      if (f != CellFlag::Surface) continue;
      const std::uint8_t m = empty_mask_[static_cast<std::size_t>(gi * nz + k)];
      const double dudx = (u_(i, k) - u_(i - 1, k)) / dx, dwdz = (w_(i, k) - w_(i, k - 1)) / dz;
      double sum = 0.0;
      int n = 0;
      if (m & (empty_side::Left | empty_side::Right)) {
        sum += dudx * (((m & empty_side::Left) ? 1 : 0) + ((m & empty_side::Right) ? 1 : 0));
        n += ((m & empty_side::Left) ? 1 : 0) + ((m & empty_side::Right) ? 1 : 0);
      }
      if (m & (empty_side::Bottom | empty_side::Top)) {
        sum += dwdz * (((m & empty_side::Bottom) ? 1 : 0) + ((m & empty_side::Top) ? 1 : 0));
        n += ((m & empty_side::Bottom) ? 1 : 0) + ((m & empty_side::Top) ? 1 : 0);
      }
      // nu_eff at the surface itself, where p = 0: tau_y = tau_c (Drucker-Prager: 0, so
      // nu_eff = nu). The cell's own nu_eff (with its centre pressure) would feed the lagged
      // yield stress back into the Dirichlet value: measured unstable on the periodic incline
      // (tau_y m_y D_nn is O(tau_y) noise in a plug where ||D|| -> 0).
      // With the implicit momentum step the term is left out (p = 0 at the surface): lagged,
      // it acts on the face below as an explicit viscous term of weight 2 nu dt / dz^2 and was
      // measured unstable at nu dt / dz^2 > 0.5 (Newtonian layer, nu = 0.03, dz = 5 mm); the
      // explicit scheme's viscous time-step limit covers it.
      const double nus = rheo_.nu_eff(normD_(i, k), 0.0);
      const bool viscous_normal = cfg_.momentum == Momentum::Explicit;
      target(i, k) = n > 0 && viscous_normal ? 2.0 * nus * sum / n : 0.0;
      // A cell whose top is empty holds the free surface at the column's marker depth z_s,
      // not at its centre: p = 0 belongs at z_s, so the cell centre gets the hydrostatic
      // increment g cos(zeta) (z_s - z_c) (z_s clamped into the cell). Without it the pressure
      // below a surface would be off by up to g cos(zeta) dz / 2 (5 % of the basal pressure of
      // a 10-cell layer, and the Coulomb friction with it).
      if ((m & empty_side::Top) && !col_h_.empty()) {
        const double zs = std::clamp(col_h_[static_cast<std::size_t>(gi)], k * dz, (k + 1) * dz);
        target(i, k) += std::abs(phys_.gz) * (zs - (k + 0.5) * dz);
      }
    }
}

// Velocity conditions of the free surface on the columns [-1, nx_local] of (u, w):
//  1. Surface cells: each face towards an Empty cell first takes the value of its opposite face
//     when that one is not empty (NaSt2D's rule for cells with two adjacent empty sides), then
//     the remaining divergence is removed in equal shares by the empty faces, so that
//     div u = 0 in every Surface cell (continuity, NaSt2D's rule for one empty side).
//  2. Faces between two non-material cells (the Empty region next to the surface) are
//     extrapolated: u upward with zero normal gradient (the tangential-stress-free condition
//     du/dz = 0 of a shallow surface), at the bed ahead of a front from the face behind it;
//     w from a neighbouring column that touches material (ahead of/behind a front), else upward.
//  So marker advection and the stencils of material faces see a smooth velocity.
void NdamSolver::apply_free_surface(Field& u, Field& w) const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz, nxl = slab_.nx_local;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  const bool per = cfg_.periodic_x();
  auto inside = [&](int gi) { return per || (gi >= 0 && gi < nx); };
  for (int i = -1; i <= nxl; ++i) {
    const int gi = slab_.i0 + i;
    if (!inside(gi)) continue;
    const int gw = per ? (gi % nx + nx) % nx : gi;
    for (int k = 0; k < nz; ++k) {
      if (gflag(gi, k) != CellFlag::Surface) continue;
      const std::uint8_t m = empty_mask_[static_cast<std::size_t>(gw * nz + k)];
      double* face[4] = {&u(i - 1, k), &u(i, k), &w(i, k - 1), &w(i, k)};  // L R B T
      const std::uint8_t bit[4] = {empty_side::Left, empty_side::Right, empty_side::Bottom,
                                   empty_side::Top};
      const double sgn[4] = {-1.0, 1.0, -1.0, 1.0}, hh[4] = {dx, dx, dz, dz};
      for (int q = 0; q < 4; ++q) {
        const int o = q ^ 1;  // opposite face
        if ((m & bit[q]) && !(m & bit[o])) *face[q] = *face[o];
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
  // 2. extrapolation into the Empty region
  for (int i = -1; i <= nxl; ++i) {
    const int gi = slab_.i0 + i;
    if (!per && (gi < 0 || gi >= nx - 1)) continue;  // u: the boundary faces are set elsewhere
    for (int k = 0; k < nz; ++k) {
      if (fluid(gi, k) || fluid(gi + 1, k)) continue;
      if (k > 0) u(i, k) = u(i, k - 1);
      else u(i, k) = (fluid(gi - 1, k) || fluid(gi, k)) ? u(i - 1, k) : 0.0;
    }
  }
  for (int i = -1; i <= nxl; ++i) {
    const int gi = slab_.i0 + i;
    if (!inside(gi)) continue;
    for (int k = 0; k < nz - 1; ++k) {
      if (fluid(gi, k) || fluid(gi, k + 1)) continue;
      if (fluid(gi - 1, k) || fluid(gi - 1, k + 1)) w(i, k) = w(i - 1, k);
      else if (fluid(gi + 1, k) || fluid(gi + 1, k + 1)) w(i, k) = w(i + 1, k);
      else w(i, k) = k > 0 ? w(i, k - 1) : 0.0;
    }
  }
}

void NdamSolver::update_profile_cache() {
  if (!markers_) return;
  const auto cp = markers_->profile(u_, w_);
  std::vector<double> local;
  for (std::size_t c = 0; c < cp.h.size(); ++c) {
    local.push_back(cp.h[c]);
    local.push_back(cp.u_mean[c]);
    local.push_back(cp.w_mean[c]);
  }
  const auto all = gather_columns(local);
  const int nx = cfg_.grid.nx;
  col_h_.assign(static_cast<std::size_t>(nx), 0.0);
  col_u_ = col_h_;
  col_w_ = col_h_;
  for (int gi = 0; gi < nx; ++gi) {
    col_h_[static_cast<std::size_t>(gi)] = all[static_cast<std::size_t>(3 * gi)];
    col_u_[static_cast<std::size_t>(gi)] = all[static_cast<std::size_t>(3 * gi + 1)];
    col_w_[static_cast<std::size_t>(gi)] = all[static_cast<std::size_t>(3 * gi + 2)];
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

// ---------------------------------------------------------------------------------------------
// Rheology: nu_eff at cell centres from ||D|| and p (lagged: state at t^n)
// ---------------------------------------------------------------------------------------------
void NdamSolver::update_viscosity(const Field& p_yield) {
  if (rheo_.newtonian()) {
    nu_.fill(rheo_.nu);
    update_friction(p_yield);
    return;
  }
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  const int nz = cfg_.grid.nz;
  // shear rate du/dz + dw/dx at the top-right corner of cell (i, k)
  auto shear = [&](int i, int k) {
    return (u_(i, k + 1) - u_(i, k)) / dz + (w_(i + 1, k) - w_(i, k)) / dx;
  };
  for (int i = 0; i < slab_.nx_local; ++i)
    for (int k = 0; k < nz; ++k) {
      if (!fluid(slab_.i0 + i, k)) continue;
      const double d11 = (u_(i, k) - u_(i - 1, k)) / dx;
      const double d22 = (w_(i, k) - w_(i, k - 1)) / dz;
      const double d12 =
          0.125 * (shear(i, k) + shear(i - 1, k) + shear(i, k - 1) + shear(i - 1, k - 1));
      const double normD = std::sqrt(2.0 * (d11 * d11 + d22 * d22 + 2.0 * d12 * d12));
      // the inflow column of a 1D-to-2D interface (InflowPressure::Rheology): tau_y from the
      // pressure of eq. (26), the 1D side's pressure at x_IF
      const bool p26 = cfg_.inflow_pressure == InflowPressure::Rheology && slab_.i0 + i == 0 &&
                       !cfg_.periodic_x();
      nu_(i, k) = rheo_.nu_eff(normD, p26 ? inflow_p26(k) : p_yield(i, k));
      if (cfg_.free_surface) normD_(i, k) = normD;
    }
  fill_scalar_ghosts(nu_);
  if (has_obstacles_ || cfg_.free_surface) {
    // Obstacle cells enter the corner averages of nu_eff on their surfaces: give them the mean
    // of their fluid neighbours (a mirror, as at the box walls).
    for (int i = 0; i < slab_.nx_local; ++i)
      for (int k = 0; k < nz; ++k) {
        const int gi = slab_.i0 + i;
        if (fluid(gi, k)) continue;
        double sum = 0.0;
        int n = 0;
        const int di[4] = {1, -1, 0, 0}, dk[4] = {0, 0, 1, -1};
        for (int q = 0; q < 4; ++q)
          if (fluid(gi + di[q], k + dk[q])) {
            sum += nu_(i + di[q], k + dk[q]);
            ++n;
          }
        nu_(i, k) = n > 0 ? sum / n : rheo_.nu;
      }
    fill_scalar_ghosts(nu_);
  }
  update_friction(p_yield);
}

// Coulomb sliding law (11)-(13) on the bed (and the end wall) as a Robin ghost value. At the
// bed the tangential stress of the material balances the friction,
//   nu_eff du/dz = c_F sgn(u_b) N,  N = p + 2 nu_eff du/dx (compressive normal stress, 13),
//   c_F = tan(delta) (1 - exp(-m_c |u_b|))                              (12),
// which is written as nu_b (u(i,0) - u(i,-1)) / dz = beta N u(i,0) with the friction per unit
// velocity beta = c_F / |u_b| (-> tan(delta) m_c as u_b -> 0), i.e. the ghost
//   u(i,-1) = a u(i,0),  a = 1 - dz beta N / nu_b.
// beta, N and nu_b are lagged (t^n), the velocity is the unknown of the (implicit) momentum
// step: a positive drag that stays stable for any dt (Picard linearisation of the friction).
// a is clamped at -1 (no slip): regularised friction cannot hold more than sticking does.
// delta = 0 gives a = 1: free slip. p at the bed: the mean of the material cells above the face
// extrapolated hydrostatically by dz/2 (p_b = p_0 + g cos(zeta) dz / 2).
void NdamSolver::update_friction(const Field& p_yield) {
  const int G = Field::G, nxl = slab_.nx_local, nz = cfg_.grid.nz;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  auto beta = [&](double ub) {
    const double x = cfg_.m_c * std::abs(ub);
    return phys_.tan_delta * (x < 1e-8 ? cfg_.m_c * (1.0 - 0.5 * x) : -std::expm1(-x) / std::abs(ub));
  };
  bed_a_.assign(static_cast<std::size_t>(nxl + 2 * G), 1.0);
  if (cfg_.walls[2].kind == WallKind::Coulomb)
    for (int i = -G; i < nxl + G; ++i) {
      const int gi = slab_.i0 + i;
      const int ir = std::min(i + 1, nxl + G - 1), il = std::max(i - 1, -G);
      double pb = 0.0;
      int n = 0;
      for (int c : {i, ir})
        if (fluid(gi + (c - i), 0)) {
          pb += p_yield(c, 0);
          ++n;
        }
      if (n == 0) continue;
      pb = pb / n + 0.5 * dz * std::abs(phys_.gz);
      const double nub = 0.5 * (nu_(i, 0) + nu_(ir, 0));
      const double dudx = (u_(ir, 0) - u_(il, 0)) / ((ir - il) * dx);
      const double N = std::max(0.0, pb + 2.0 * nub * dudx);
      const double a = 1.0 - dz * beta(u_(i, 0)) * N / nub;
      bed_a_[static_cast<std::size_t>(i + G)] = std::max(-1.0, a);
    }
  wall_a_.assign(static_cast<std::size_t>(nz), 1.0);
  if (cfg_.walls[1].kind == WallKind::Coulomb && slab_.i0 + nxl == cfg_.grid.nx)
    for (int k = 0; k < nz - 1; ++k) {
      const int i = nxl - 1, gi = slab_.i0 + i;
      double pw = 0.0;
      int n = 0;
      for (int kk : {k, k + 1})
        if (fluid(gi, kk)) {
          pw += p_yield(i, kk);
          ++n;
        }
      if (n == 0) continue;
      // the end wall holds the downslope gravity: p grows by g sin(zeta) dx / 2 to the wall
      pw = pw / n + 0.5 * dx * std::max(0.0, phys_.gx);
      const double nuw = 0.5 * (nu_(i, k) + nu_(i, k + 1));
      const double dwdz = (w_(i, k + 1) - w_(i, std::max(k - 1, -1))) / ((k + 1 - std::max(k - 1, -1)) * dz);
      const double N = std::max(0.0, pw + 2.0 * nuw * dwdz);
      const double a = 1.0 - dx * beta(w_(i, k)) * N / nuw;
      wall_a_[static_cast<std::size_t>(k)] = std::max(-1.0, a);
    }
}

double NdamSolver::nu_corner(int i, int k) const {
  if (cfg_.free_surface) {
    // A corner that touches an Empty cell lies on the free surface: its shear stress is zero
    // (the tangential-stress condition). Averaging nu_eff there instead would couple the
    // material to the extrapolated (lagged) velocities of the empty region with the full,
    // possibly huge, viscoplastic nu_eff: a spurious lid that holds back the layer.
    const int gi = slab_.i0 + i;
    for (int di = 0; di <= 1; ++di)
      for (int dk = 0; dk <= 1; ++dk)
        if (gflag(gi + di, k + dk) == CellFlag::Empty) return 0.0;
  }
  return 0.25 * (nu_(i, k) + nu_(i + 1, k) + nu_(i, k + 1) + nu_(i + 1, k + 1));
}

// V = div(2 nu_eff D) at the u face (i, k): d/dx of the normal stress in the cells left and
// right of the face, d/dz of the shear stress at the corners above and below.
template <class Emit>
void NdamSolver::viscous_u(int i, int k, Emit&& e) const {
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  for (int c : {i + 1, i}) {
    const double s = (c == i + 1 ? 1.0 : -1.0) / dx;
    const double f = 2.0 * nu_(c, k) / dx;  // tau_xx = 2 nu (u(c) - u(c-1)) / dx
    e(U, c, k, s * f);
    e(U, c - 1, k, -s * f);
  }
  for (int kc : {k, k - 1}) {
    const double s = (kc == k ? 1.0 : -1.0) / dz;
    const double n = nu_corner(i, kc);  // tau_xz = nu (du/dz + dw/dx) at corner (i, kc)
    e(U, i, kc + 1, s * n / dz);
    e(U, i, kc, -s * n / dz);
    e(W, i + 1, kc, s * n / dx);
    e(W, i, kc, -s * n / dx);
  }
}

// V at the w face (i, k): d/dx of the shear stress at the corners left and right, d/dz of the
// normal stress in the cells below and above.
template <class Emit>
void NdamSolver::viscous_w(int i, int k, Emit&& e) const {
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  for (int ic : {i, i - 1}) {
    const double s = (ic == i ? 1.0 : -1.0) / dx;
    const double n = nu_corner(ic, k);
    e(U, ic, k + 1, s * n / dz);
    e(U, ic, k, -s * n / dz);
    e(W, ic + 1, k, s * n / dx);
    e(W, ic, k, -s * n / dx);
  }
  for (int c : {k + 1, k}) {
    const double s = (c == k + 1 ? 1.0 : -1.0) / dz;
    const double f = 2.0 * nu_(i, c) / dz;  // tau_zz = 2 nu (w(c) - w(c-1)) / dz
    e(W, i, c, s * f);
    e(W, i, c - 1, -s * f);
  }
}

// Convective terms of NaSt2D (Griebel et al.): d(u^2)/dx + d(uw)/dz at u faces and
// d(uw)/dx + d(w^2)/dz at w faces, central part plus gamma times the donor-cell correction.
double NdamSolver::conv_u(int i, int k) const {
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz(), g = cfg_.gamma;
  const Field& u = u_;
  const Field& w = w_;
  const double ur = 0.5 * (u(i, k) + u(i + 1, k)), ul = 0.5 * (u(i - 1, k) + u(i, k));
  const double du2 = (ur * ur - ul * ul) / dx +
                     g / dx *
                         (std::abs(ur) * 0.5 * (u(i, k) - u(i + 1, k)) -
                          std::abs(ul) * 0.5 * (u(i - 1, k) - u(i, k)));
  const double wt = 0.5 * (w(i, k) + w(i + 1, k)), wb = 0.5 * (w(i, k - 1) + w(i + 1, k - 1));
  const double duw = (wt * 0.5 * (u(i, k) + u(i, k + 1)) - wb * 0.5 * (u(i, k - 1) + u(i, k))) /
                         dz +
                     g / dz *
                         (std::abs(wt) * 0.5 * (u(i, k) - u(i, k + 1)) -
                          std::abs(wb) * 0.5 * (u(i, k - 1) - u(i, k)));
  return du2 + duw;
}

double NdamSolver::conv_w(int i, int k) const {
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz(), g = cfg_.gamma;
  const Field& u = u_;
  const Field& w = w_;
  const double ur = 0.5 * (u(i, k) + u(i, k + 1)), ul = 0.5 * (u(i - 1, k) + u(i - 1, k + 1));
  const double duw = (ur * 0.5 * (w(i, k) + w(i + 1, k)) - ul * 0.5 * (w(i - 1, k) + w(i, k))) /
                         dx +
                     g / dx *
                         (std::abs(ur) * 0.5 * (w(i, k) - w(i + 1, k)) -
                          std::abs(ul) * 0.5 * (w(i - 1, k) - w(i, k)));
  const double wt = 0.5 * (w(i, k) + w(i, k + 1)), wb = 0.5 * (w(i, k - 1) + w(i, k));
  const double dw2 = (wt * wt - wb * wb) / dz +
                     g / dz *
                         (std::abs(wt) * 0.5 * (w(i, k) - w(i, k + 1)) -
                          std::abs(wb) * 0.5 * (w(i, k - 1) - w(i, k)));
  return duw + dw2;
}

// ---------------------------------------------------------------------------------------------
// Time step
// ---------------------------------------------------------------------------------------------
double NdamSolver::stable_dt() const {
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  const int nz = cfg_.grid.nz;
  double umax = 0.0, wmax = 0.0;
  for (int i = 0; i < slab_.nx_local; ++i)
    for (int k = 0; k < nz; ++k) {
      umax = std::max(umax, std::abs(u_(i, k)));
      wmax = std::max(wmax, std::abs(w_(i, k)));
    }
  umax = allreduce_max(umax, comm_);
  wmax = allreduce_max(wmax, comm_);
  double dt = std::numeric_limits<double>::infinity();
  if (cfg_.free_surface && cfg_.inflow) umax = std::max(umax, std::abs(inflow_now_[1]));
  if (umax > 0.0) dt = std::min(dt, dx / umax);
  if (wmax > 0.0) dt = std::min(dt, dz / wmax);
  if (cfg_.momentum == Momentum::Explicit) {
    // Forward Euler on div(2 nu D): the largest eigenvalue is below
    // nu (8/dx^2 + 8/dz^2) (normal stress 2 nu, shear stress nu, 3-point stencils), so
    // dt <= 1 / (4 nu (1/dx^2 + 1/dz^2)) keeps it stable with the safety factor below.
    const double numax = max_nu_eff();
    if (numax > 0.0) dt = std::min(dt, 1.0 / (4.0 * numax * (1.0 / (dx * dx) + 1.0 / (dz * dz))));
    // Coulomb friction, explicit: the bed face loses nu_b (1 - a) / dz^2 of its velocity per
    // second (a: the Robin ghost factor), so forward Euler needs dt <= 1 / that rate.
    double rate = 0.0;
    for (int i = 0; i < slab_.nx_local && cfg_.walls[2].kind == WallKind::Coulomb; ++i) {
      const double a = bed_a_[static_cast<std::size_t>(i + Field::G)];
      rate = std::max(rate, 0.5 * (nu_(i, 0) + nu_(i + 1, 0)) * (1.0 - a) / (dz * dz));
    }
    rate = allreduce_max(rate, comm_);
    if (rate > 0.0) dt = std::min(dt, 1.0 / rate);
  }
  dt *= cfg_.cfl;
  // Implicit and Newtonian: the momentum matrix depends on dt only, so a dt that stays within
  // [0.8, 1] of the limit is held; the matrix and its preconditioner are then reused.
  if (cfg_.momentum == Momentum::Implicit && rheo_.newtonian() && momentum_dt_ > 0.0 &&
      momentum_dt_ <= dt && momentum_dt_ >= 0.8 * dt)
    dt = momentum_dt_;
  return dt;
}

double NdamSolver::max_nu_eff() const {
  double m = 0.0;
  for (int i = 0; i < slab_.nx_local; ++i)
    for (int k = 0; k < cfg_.grid.nz; ++k) m = std::max(m, nu_(i, k));
  return allreduce_max(m, comm_);
}

// u* on every unknown face; wall-normal faces keep their boundary value 0.
void NdamSolver::predict_velocity(double dt, Field& us, Field& ws) {
  const int nxl = slab_.nx_local, nz = cfg_.grid.nz;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  us = u_;
  ws = w_;
  // Explicit forces: convection, gravity, the pressure gradient of t^n.
  auto force_u = [&](int i, int k) {
    return -conv_u(i, k) + phys_.gx - (p_(i + 1, k) - p_(i, k)) / dx;
  };
  auto force_w = [&](int i, int k) {
    return -conv_w(i, k) + phys_.gz - (p_(i, k + 1) - p_(i, k)) / dz;
  };
  if (cfg_.momentum == Momentum::Explicit) {
    double vis = 0.0;
    auto eval = [&](Comp c, int i, int k, double coeff) {
      const Ref r = ref(c, i, k);
      const Field& f = c == U ? u_ : w_;
      vis += coeff * (r.a == 0.0 ? r.b : r.a * f.data()[r.loc] + r.b);
    };
    for (int i = 0; i < nxl; ++i) {
      for (int k = 0; k < nz; ++k)
        if (u_unknown(i, k)) {
          vis = 0.0;
          viscous_u(i, k, eval);
          us(i, k) = u_(i, k) + dt * (force_u(i, k) + vis);
        }
      for (int k = 0; k < nz - 1; ++k) {
        if (!w_unknown(i, k)) continue;
        vis = 0.0;
        viscous_w(i, k, eval);
        ws(i, k) = w_(i, k) + dt * (force_w(i, k) + vis);
      }
    }
    fill_velocity_ghosts(us, ws);
    return;
  }

  // Implicit: (I/dt - V) u* = u^n/dt + forces. The matrix depends on nu_eff and dt only; with
  // a constant viscosity and an unchanged dt the assembled matrix and its preconditioner are
  // reused. The boundary constants of V go to the right-hand side in every step.
  const bool rebuild = !rheo_.newtonian() || dt != momentum_dt_ || cfg_.free_surface ||
                       cfg_.walls[1].kind == WallKind::Coulomb ||
                       cfg_.walls[2].kind == WallKind::Coulomb;
  const long long first = 2 * p_gid(slab_.i0, 0);
  std::vector<double> rhs(static_cast<std::size_t>(2 * nxl * nz)), x(rhs.size());
  if (rebuild) momentum_->begin();
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k)
      for (Comp c : {U, W}) {
        const long long row = 2 * p_gid(slab_.i0 + i, k) + c;
        const auto lr = static_cast<std::size_t>(row - first);
        const bool unknown = c == U ? u_unknown(i, k) : w_unknown(i, k);
        if (!unknown) {  // wall-normal face: identity row, value 0
          if (rebuild) momentum_->add(row, row, 1.0);
          rhs[lr] = 0.0;
          x[lr] = 0.0;
          continue;
        }
        double b = c == U ? u_(i, k) / dt + force_u(i, k) : w_(i, k) / dt + force_w(i, k);
        if (rebuild) momentum_->add(row, row, 1.0 / dt);
        auto emit = [&](Comp cc, int ii, int kk, double coeff) {
          const Ref r = ref(cc, ii, kk);
          if (r.gid < 0) {  // a known value (boundary or free-surface face)
            const Field& f = cc == U ? u_ : w_;
            b += coeff * (r.a == 0.0 ? r.b : r.a * f.data()[r.loc] + r.b);
            return;
          }
          b += coeff * r.b;
          if (r.a != 0.0 && rebuild) momentum_->add(row, r.gid, -coeff * r.a);
        };
        if (c == U) viscous_u(i, k, emit);
        else viscous_w(i, k, emit);
        rhs[lr] = b;
        x[lr] = c == U ? u_(i, k) : w_(i, k);  // initial guess: u^n
      }
  if (rebuild) {
    momentum_->end();
    momentum_dt_ = dt;
  }
  mom_stats_ = momentum_->solve(rhs, x);
  ++m_solves_;
  m_iters_ += mom_stats_.iterations;
  worst_m_res_ = std::max(worst_m_res_, mom_stats_.residual);
  if (!mom_stats_.converged) ++failed_solves_;
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) {
      const auto lr = static_cast<std::size_t>(2 * p_gid(slab_.i0 + i, k) - first);
      if (u_unknown(i, k)) us(i, k) = x[lr];
      if (w_unknown(i, k)) ws(i, k) = x[lr + 1];
    }
  fill_velocity_ghosts(us, ws);
}

double NdamSolver::divergence(const Field& u, const Field& w, int i, int k) const {
  return (u(i, k) - u(i - 1, k)) / cfg_.grid.dx() + (w(i, k) - w(i, k - 1)) / cfg_.grid.dz();
}

// -L phi = -div(u*)/dt on the pressure unknowns (Fluid cells). Dirichlet cells (Surface:
// the increment to the normal-stress value, Empty: 0, obstacles: 0) are identity rows with
// their value p_dir_, and their coupling to an unknown goes to its right-hand side. Without a
// Dirichlet cell (closed box) the right-hand side is made compatible (zero sum; it is zero up
// to round-off anyway since the wall fluxes vanish) and one cell is pinned.
void NdamSolver::solve_pressure(double dt, const Field& us, const Field& ws, Field& phi) {
  const int nxl = slab_.nx_local, nz = cfg_.grid.nz, nx = cfg_.grid.nx;
  const bool per = cfg_.periodic_x();
  const double cx = 1.0 / (cfg_.grid.dx() * cfg_.grid.dx());
  const double cz = 1.0 / (cfg_.grid.dz() * cfg_.grid.dz());
  std::vector<double> rhs(static_cast<std::size_t>(nxl * nz)), x(rhs.size(), 0.0);
  double sum = 0.0;
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) {
      const int gi = slab_.i0 + i;
      const auto q = static_cast<std::size_t>(i * nz + k);
      if (!p_unknown(gi, k)) {
        rhs[q] = x[q] = p_dir_(i, k);
        continue;
      }
      double r = -divergence(us, ws, i, k) / dt;
      sum += r;
      auto dir = [&](int ii, int kn, double c) {
        const int gn = slab_.i0 + ii;
        if (!per && (gn < 0 || gn >= nx)) return;
        if (kn < 0 || kn >= nz) return;
        const CellFlag f = gflag(gn, kn);
        if (f == CellFlag::Obstacle || f == CellFlag::Fluid) return;
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
    const double mean = allreduce_sum(sum, comm_) / static_cast<double>(fluid_cells_);
    const long long first = p_gid(slab_.i0, 0);
    for (int i = 0; i < nxl; ++i)
      for (int k = 0; k < nz; ++k) {
        const auto q = static_cast<std::size_t>(i * nz + k);
        const long long row = first + static_cast<long long>(q);
        if (row == pin_ || !p_unknown(slab_.i0 + i, k)) rhs[q] = 0.0;  // pinned or obstacle
        else rhs[q] -= mean;
      }
  }
  p_stats_ = pressure_->solve(rhs, x);
  ++p_solves_;
  p_iters_ += p_stats_.iterations;
  worst_p_res_ = std::max(worst_p_res_, p_stats_.residual);
  if (!p_stats_.converged) ++failed_solves_;
  phi = Field(nxl, nz);
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) phi(i, k) = x[static_cast<std::size_t>(i * nz + k)];
  fill_scalar_ghosts(phi);
}

void NdamSolver::correct_velocity(double dt, const Field& phi, Field& us, Field& ws) const {
  const int nxl = slab_.nx_local, nz = cfg_.grid.nz;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  for (int i = 0; i < nxl; ++i) {
    for (int k = 0; k < nz; ++k) {
      if (u_unknown(i, k)) us(i, k) -= dt * (phi(i + 1, k) - phi(i, k)) / dx;
      if (w_unknown(i, k)) ws(i, k) -= dt * (phi(i, k + 1) - phi(i, k)) / dz;
    }
  }
  fill_velocity_ghosts(us, ws);
}

// The pressure of a closed box is fixed up to a constant. The constant is chosen so that p,
// extrapolated linearly to the top wall z = Lz, averages to zero there: the top of the box plays
// the role of the free surface, and the tau_p p yield stress sees a pressure that grows with
// depth from 0.
void NdamSolver::normalise_pressure(Field& p) const {
  // Columns whose two top cells are fluid; if an obstacle covers the top of every column, the
  // mean over the fluid cells is set to zero instead.
  const int nxl = slab_.nx_local, nz = cfg_.grid.nz;
  double sums[4] = {0.0, 0.0, 0.0, 0.0};  // top sum, top columns, fluid sum, fluid cells
  for (int i = 0; i < nxl; ++i) {
    const int gi = slab_.i0 + i;
    if (nz > 1 && fluid(gi, nz - 1) && fluid(gi, nz - 2)) {
      sums[0] += 1.5 * p(i, nz - 1) - 0.5 * p(i, nz - 2);
      sums[1] += 1.0;
    }
    for (int k = 0; k < nz; ++k)
      if (fluid(gi, k)) {
        sums[2] += p(i, k);
        sums[3] += 1.0;
      }
  }
  double all[4];
  MPI_Allreduce(sums, all, 4, MPI_DOUBLE, MPI_SUM, comm_);
  const double c = all[1] > 0.0 ? all[0] / all[1] : all[2] / all[3];
  for (auto& v : p.data()) v -= c;
}

// Eq. (10) at t = 0: -L p = -div F with F = -C(u) + V(u) + g on the unknown faces and the
// Neumann condition (14) n.grad p = n.F, i.e. F = 0 on the fixed wall-normal faces. This is the
// projection of the force field, computed with dt = 1 through the same routines.
void NdamSolver::initial_pressure() {
  const int nxl = slab_.nx_local, nz = cfg_.grid.nz;
  Field fu = u_, fw = w_;
  double vis = 0.0;
  auto eval = [&](Comp c, int i, int k, double coeff) {
    const Ref r = ref(c, i, k);
    const Field& f = c == U ? u_ : w_;
    vis += coeff * (r.a == 0.0 ? r.b : r.a * f.data()[r.loc] + r.b);
  };
  fu.fill(0.0);
  fw.fill(0.0);
  for (int i = 0; i < nxl; ++i) {
    for (int k = 0; k < nz; ++k)
      if (u_unknown(i, k)) {
        vis = 0.0;
        viscous_u(i, k, eval);
        fu(i, k) = -conv_u(i, k) + phys_.gx + vis;
      }
    for (int k = 0; k < nz - 1; ++k) {
      if (!w_unknown(i, k)) continue;
      vis = 0.0;
      viscous_w(i, k, eval);
      fw(i, k) = -conv_w(i, k) + phys_.gz + vis;
    }
  }
  exchange(fu);
  exchange(fw);
  Field phi;
  solve_pressure(1.0, fu, fw, phi);
  // solve_pressure returns phi with -L phi = -div F, i.e. grad phi is the gradient part of F.
  p_ = phi;
  if (!cfg_.free_surface) normalise_pressure(p_);
  fill_scalar_ghosts(p_);
}

void NdamSolver::step(double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw std::invalid_argument("NdamSolver::step: dt must be positive and finite");
  const auto t0 = Clock::now();
  if (cfg_.free_surface) {
    // the gate state of this step (lagged at t^n), the boundary faces with it
    inflow_now_ = cfg_.inflow ? cfg_.inflow(t_) : std::array<double, 2>{0.0, 0.0};
    inflow_owed_new_ = inflow_owed_;
    if (inflow_mass_) {
      if (const auto m = inflow_mass_(t_, dt)) {
        // Exact transfer: the step lets in what the upstream side let out (plus what earlier
        // steps could not take). The velocity is capped at 1.5 |u_mean| + 0.1 m/s of the
        // provider (the CFL condition of this step was set with that u_mean), and a depth below
        // 0.1 mm takes nothing: the rest waits for the next steps.
        const double target = *m + inflow_owed_, h = inflow_now_[0];
        const double ucap = 1.5 * std::abs(inflow_now_[1]) + 0.1;
        double u = 0.0;
        if (h > 1e-4 && target > 0.0) u = std::min(target / (dt * h), ucap);
        inflow_now_[1] = u;
        inflow_owed_new_ = target - u * dt * h;
      }
    }
    fill_velocity_ghosts(u_, w_);
  }
  update_viscosity(p_);  // nu_eff(u^n, p^n), Coulomb ghost factors
  // The rotational pressure update is a splitting correction (it vanishes at a steady state),
  // not part of eq. (10): it keeps nu_eff(u^n, p^n) in the nonlinear coupling too, where the
  // trial pressure would otherwise enter through 2 nu_eff(q) div u*, a term that is large
  // wherever the material is stopped (nu_eff ~ tau_p m_y q) and that made Newton stall.
  nu_rot_ = nu_;
  if (cfg_.free_surface) {
    // Dirichlet values of the projection increment: Surface cells go to the normal-stress
    // value (surface_pressure), Empty cells stay at p = 0.
    Field ps(slab_.nx_local, cfg_.grid.nz);
    surface_pressure(ps);
    p_dir_.fill(0.0);
    for (int i = 0; i < slab_.nx_local; ++i)
      for (int k = 0; k < cfg_.grid.nz; ++k) {
        const CellFlag f = gflag(slab_.i0 + i, k);
        if (f == CellFlag::Surface || f == CellFlag::Empty) p_dir_(i, k) = ps(i, k) - p_(i, k);
        if (cfg_.inflow_pressure == InflowPressure::Dirichlet && slab_.i0 + i == 0 &&
            fluid(0, k))
          p_dir_(i, k) = inflow_p26(k) - p_(i, k);  // eq. (26) as the Dirichlet value
      }
    exchange(p_dir_);
    if (flags_changed_) {
      assemble_pressure();
      flags_changed_ = false;
    }
  }
  sec_other_ = seconds_since(t0);
  sec_mom_ = sec_p_ = 0.0;
  newton_failed_ = false;
  if (cfg_.pressure_coupling == PressureCoupling::Nonlinear && pressure_dependent())
    solve_pressure_system(dt);  // tau_y and (13) at p^{n+1}
  else
    project(dt);  // tau_y and (13) at p^n (nu_eff and the friction factors from above)
  const auto t3 = Clock::now();
  // divergence of the tentative state, for check() and the statistics
  double dmax = 0.0;
  for (int i = 0; i < slab_.nx_local; ++i)
    for (int k = 0; k < cfg_.grid.nz; ++k)
      if (fluid(slab_.i0 + i, k))
        dmax = std::max(dmax, std::abs(divergence(u_new_, w_new_, i, k)));
  max_div_new_ = allreduce_max(dmax, comm_);
  t_new_ = t_ + dt;
  dt_min_ = steps_ == 0 ? dt : std::min(dt_min_, dt);
  dt_max_ = std::max(dt_max_, dt);
  sec_other_ += seconds_since(t3);
}

// One predictor-projection from the state at t^n with the current nu_eff and friction factors:
// u*, phi, u^{n+1} = u* - dt G phi and p^{n+1} into u_new_, w_new_, p_new_. In the 'Nonlinear'
// coupling this is the map P(q) whose fixed point is the new pressure.
void NdamSolver::project(double dt) {
  const auto t1 = Clock::now();
  mom_stats_ = solvers::SolveStats{};
  predict_velocity(dt, u_new_, w_new_);
  sec_mom_ += seconds_since(t1);
  const auto t2 = Clock::now();
  Field phi;
  solve_pressure(dt, u_new_, w_new_, phi);
  u_star_ = u_new_;
  w_star_ = w_new_;
  correct_velocity(dt, phi, u_new_, w_new_);
  p_new_ = p_;
  // Rotational pressure update (Timmermans et al. 1996; Guermond, Minev & Shen 2006) for the
  // implicit treatment: p^{n+1} = p^n + phi - 2 nu_eff div u*. In the stress form
  // div(2 nu D u) = 2 nu grad(div u) - nu curl curl u (constant nu), so 2 nu div u* is the part
  // of the implicit viscous term that the projection removes from u*; putting it back into the
  // pressure removes the splitting error that otherwise makes the pressure lag by
  // O(nu dt / dx^2) steps when nu_eff is large (a Stokes-limit Uzawa iteration with step
  // 2 nu_eff). It vanishes at a steady state and for the explicit scheme (the paper's) it is
  // not used.
  const double rot = cfg_.momentum == Momentum::Implicit ? 2.0 : 0.0;
  for (int i = 0; i < slab_.nx_local; ++i)
    for (int k = 0; k < cfg_.grid.nz; ++k) {
      if (p_unknown(slab_.i0 + i, k))
        p_new_(i, k) += phi(i, k) - rot * nu_rot_(i, k) * divergence(u_star_, w_star_, i, k);
      else  // Dirichlet cells: phi is the increment to their value (surface normal stress,
            // eq. 26 at an interface, 0 when Empty); obstacles: phi = 0
        p_new_(i, k) += phi(i, k);
    }
  if (!cfg_.free_surface) normalise_pressure(p_new_);
  fill_scalar_ghosts(p_new_);
  sec_p_ += seconds_since(t2);
}

// P(q): nu_eff(u^n, q) and the friction factors at the trial pressure q (this rank's cells,
// i * nz + k), then one predictor-projection into u_new_, w_new_, p_new_.
void NdamSolver::project_at(const std::vector<double>& q, double dt) {
  const int nxl = slab_.nx_local, nz = cfg_.grid.nz;
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) p_trial_(i, k) = q[static_cast<std::size_t>(i * nz + k)];
  fill_scalar_ghosts(p_trial_);
  update_viscosity(p_trial_);
  project(dt);
  q_evaluated_ = q;
}

bool NdamSolver::pressure_dependent() const {
  return (!rheo_.newtonian() && rheo_.tau_p != 0.0) || cfg_.walls[1].kind == WallKind::Coulomb ||
         cfg_.walls[2].kind == WallKind::Coulomb;
}

// The nonlinear pressure system (10)+(13)+(14) of the paper: tau_y = tau_c + tau_p p and the
// Coulomb law (13) at the new pressure. With P(q) one predictor-projection whose nu_eff(u^n, q)
// and friction factors use the trial pressure q, the new pressure is the fixed point q = P(q),
// i.e. the root of
//     R(q) = (q - P(q)) / (p_ref sqrt(N)),   p_ref = g cos(zeta) Lz,  N = cells of the box,
// so that ||R||_2 is the RMS pressure mismatch relative to the hydrostatic pressure at the
// bottom of the box. For the paper's explicit momentum step this is exactly
// -L (q - p^n) = -D u*(q) / dt with u*(q) = u^n + dt F(u^n, q), eq. (10) with F from (8) at q.
// NOX solves R = 0 by Newton's method from q0 = p^n (the lagged answer is its first
// residual); J v by finite differences of R (Jacobian-free: P contains the linear solves),
// GMRES without a preconditioner since J = I - dP/dq is the identity plus the yield-stress
// coupling. The state of the step is P at the converged q (so u^{n+1} and p^{n+1} belong to
// one projection); a Newton solve that fails marks the step for check().
void NdamSolver::solve_pressure_system(double dt) {
  const auto t0 = Clock::now();
  const int nxl = slab_.nx_local, nz = cfg_.grid.nz;
  const std::size_t n = static_cast<std::size_t>(nxl) * static_cast<std::size_t>(nz);
  newton_dt_ = dt;
  newton_scale_ = 1.0 / (std::abs(phys_.gz) * cfg_.grid.lz *
                         std::sqrt(static_cast<double>(cfg_.grid.nx) * nz));
  if (!newton_) {
    p_trial_ = Field(nxl, nz);
    auto residual = [this, nxl, nz](const std::vector<double>& q, std::vector<double>& F) {
      project_at(q, newton_dt_);
      F.resize(q.size());
      for (int i = 0; i < nxl; ++i)
        for (int k = 0; k < nz; ++k) {
          const auto r = static_cast<std::size_t>(i * nz + k);
          F[r] = (q[r] - p_new_(i, k)) * newton_scale_;
        }
      ++newton_evals_;
    };
    newton_ = std::make_unique<solvers::NonlinearSystem>(
        comm_, static_cast<long long>(cfg_.grid.nx) * nz, p_gid(slab_.i0, 0), nxl * nz,
        cfg_.pressure_newton, residual, solvers::NonlinearSystem::Matrix{});
  }
  std::vector<double> q(n);
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) q[static_cast<std::size_t>(i * nz + k)] = p_(i, k);
  const double inner = sec_mom_ + sec_p_;
  newton_stats_ = newton_->solve(q);
  // the state of the step: P at the returned iterate (re-evaluated unless it was the last one)
  if (q != q_evaluated_) project_at(q, dt);
  ++newton_solves_;
  newton_iters_ += newton_stats_.newton_iterations;
  newton_krylov_ += newton_stats_.krylov_iterations;
  newton_max_iters_ = std::max(newton_max_iters_, newton_stats_.newton_iterations);
  newton_worst_residual_ = std::max(newton_worst_residual_, newton_stats_.final_residual);
  newton_failed_ = !newton_stats_.converged;
  if (newton_failed_) {
    // where the returned iterate is furthest from its own projection (for the diagnosis)
    struct {
      double v;
      int cell;
    } loc{-1.0, 0}, glob{-1.0, 0};
    for (int i = 0; i < nxl; ++i)
      for (int k = 0; k < nz; ++k) {
        const double r = std::abs(q[static_cast<std::size_t>(i * nz + k)] - p_new_(i, k));
        if (r > loc.v) loc = {r, (slab_.i0 + i) * nz + k};
      }
    MPI_Allreduce(&loc, &glob, 1, MPI_DOUBLE_INT, MPI_MAXLOC, comm_);
    newton_fail_cell_ = {(glob.cell / nz + 0.5) * cfg_.grid.dx() + cfg_.x0,
                         (glob.cell % nz + 0.5) * cfg_.grid.dz(), glob.v};
  }
  if (newton_failed_ && cfg_.newton_failure_continue) {
    // 'Pressure Newton failure' = Continue: the step keeps the best iterate NOX returned (the
    // line search only accepts decreasing ||R||); counted and reported, never silent.
    newton_failed_ = false;
    ++newton_continued_;
    newton_continued_worst_ = std::max(newton_continued_worst_, newton_stats_.final_residual);
    if (newton_continued_ == 1 && slab_.rank == 0)
      std::fprintf(stderr,
                   "\ngranflow: warning: the N-DAM pressure Newton solve did not converge in the "
                   "step from t = %g s (%s); continuing with its best iterate ('Pressure Newton "
                   "failure' = Continue); such steps are counted in summary.json "
                   "(ndam.newton.unconverged_steps_continued)\n",
                   t_, newton_stats_.reason.c_str());
  }
  // Newton's own work (NOX, GMRES vectors) counts as pressure time; the momentum predictors
  // inside the residual evaluations stay in the momentum phase.
  const double total = seconds_since(t0);
  newton_seconds_ += total;
  sec_p_ += std::max(0.0, total - (sec_mom_ + sec_p_ - inner));
}

double NdamSolver::last_seconds(const std::string& phase) const {
  if (phase == "momentum") return sec_mom_;
  if (phase == "pressure") return sec_p_;
  if (phase == "markers") return sec_mark_;
  return sec_other_;
}

core::Health NdamSolver::check() const {
  core::Health h;
  const int nz = cfg_.grid.nz;
  const double dx = cfg_.grid.dx();
  // Local first, then agree on all ranks (the driver's decision must be collective).
  int bad = 0;
  for (int i = 0; i < slab_.nx_local && !bad; ++i)
    for (int k = 0; k < nz && !bad; ++k) {
      const double vals[3] = {u_new_(i, k), w_new_(i, k), p_new_(i, k)};
      const char* names[3] = {"u", "w", "p"};
      for (int q = 0; q < 3; ++q)
        if (!std::isfinite(vals[q]) || (q < 2 && std::abs(vals[q]) > 1e4)) {
          bad = 1;
          h.ok = false;
          h.quantity = names[q];
          h.value = vals[q];
          h.x = (slab_.i0 + i + 0.5) * dx;
          h.reason = std::isfinite(vals[q]) ? "velocity above 1e4 m/s" : "not finite";
        }
    }
  int any = 0;
  MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, comm_);
  if (any && h.ok) {
    h.ok = false;
    h.quantity = "u";
    h.reason = "not finite or above 1e4 m/s on another rank";
  }
  // The nonlinear pressure system: a Newton solve that did not converge stops the run (the
  // NOX stats are reduced over all ranks, so the decision is collective).
  if (h.ok && newton_failed_) {
    h.ok = false;
    h.quantity = "pressure Newton (NOX)";
    h.value = newton_stats_.final_residual;
    h.x = newton_fail_cell_[0];
    std::ostringstream hist;
    for (double r : newton_stats_.residual_history) hist << (hist.tellp() > 0 ? " " : "") << r;
    h.reason = "the nonlinear pressure system did not converge: " + newton_stats_.reason +
               " (||R|| per Newton iteration: " + hist.str() + "; " +
               std::to_string(newton_stats_.krylov_iterations) +
               " GMRES iterations; largest mismatch |q - P(q)| = " + gstr(newton_fail_cell_[2]) +
               " m^2/s^2 in the cell at x = " + gstr(newton_fail_cell_[0]) +
               " m, z = " + gstr(newton_fail_cell_[1]) + " m; see N-DAM->Pressure Newton: Absolute tolerance, Relative "
               "tolerance, Max Newton iterations, or 'Pressure coupling' = Lagged)";
  }
  // A linear solve that stopped short of its tolerance is counted in summary.json; one that is
  // far from it (relative residual above 1e-6, e.g. 'Max iterations' too small for a stiff
  // system) stops the run with a diagnosis instead of producing a wrong state. The stats are
  // the same on all ranks (Belos reductions), so the decision is collective.
  if (h.ok) {
    for (const auto* st : {&mom_stats_, &p_stats_}) {
      const bool used = st == &p_stats_ || cfg_.momentum == Momentum::Implicit;
      if (used && !st->converged && !(st->residual <= 1e-6)) {
        h.ok = false;
        h.quantity = st == &p_stats_ ? "pressure solve" : "momentum solve";
        h.value = st->residual;
        h.reason = "Belos did not converge (relative residual " +
                   std::to_string(st->residual) + " after " + std::to_string(st->iterations) +
                   " iterations; see the solver sublist's Tolerance, Max iterations, "
                   "Preconditioner)";
      }
    }
  }
  return h;
}

void NdamSolver::accept() {
  total_mom_ += sec_mom_;
  total_p_ += sec_p_;
  total_other_ += sec_other_;
  std::swap(u_, u_new_);
  std::swap(w_, w_new_);
  std::swap(p_, p_new_);
  if (cfg_.free_surface) {
    // Markers move with Heun's method in the old (u_new_ after the swap) and new velocity, both
    // with the free-surface values of the flags of t^n; then injection at the gate, new flags,
    // and the free-surface conditions of the new flags on the accepted state.
    const auto tm = Clock::now();
    const double dt = t_new_ - t_;
    markers_->advect(dt, u_new_, w_new_, u_, w_);
    if (cfg_.inflow && slab_.i0 == 0 && inflow_now_[0] > 0.0) {
      std::vector<double> uf(static_cast<std::size_t>(cfg_.grid.nz), 0.0);
      const double dz = cfg_.grid.dz();
      for (int k = 0; k < cfg_.grid.nz; ++k) {
        const double open = std::clamp((inflow_now_[0] - k * dz) / dz, 0.0, 1.0);
        if (open > 0.0) uf[static_cast<std::size_t>(k)] = u_(-1, k);  // material velocity of the open part
      }
      markers_->inject(dt, inflow_now_[0], uf);
    }
    inflow_owed_ = inflow_owed_new_;
    const MarkerMass mm = markers_->mass();
    transfer_.in = mm.injected_area - marker_mass_.injected_area;
    transfer_.out = mm.removed_area - marker_mass_.removed_area;
    marker_mass_ = mm;
    update_flags_from_markers();
    for (int i = 0; i < slab_.nx_local; ++i)
      for (int k = 0; k < cfg_.grid.nz; ++k)
        if (gflag(slab_.i0 + i, k) == CellFlag::Empty) p_(i, k) = 0.0;
    fill_scalar_ghosts(p_);
    t_ = t_new_;
    if (cfg_.inflow) inflow_now_ = cfg_.inflow(t_);
    fill_velocity_ghosts(u_, w_);
    update_profile_cache();
    sec_mark_ = seconds_since(tm);
    total_mark_ += sec_mark_;
  }
  u_new_ = u_;
  w_new_ = w_;
  p_new_ = p_;
  t_ = t_new_;
  ++steps_;
  max_div_ = std::max(max_div_, max_div_new_);
}

double NdamSolver::max_divergence() const {
  double dmax = 0.0;
  for (int i = 0; i < slab_.nx_local; ++i)
    for (int k = 0; k < cfg_.grid.nz; ++k)
      if (fluid(slab_.i0 + i, k)) dmax = std::max(dmax, std::abs(divergence(u_, w_, i, k)));
  return allreduce_max(dmax, comm_);
}

// ---------------------------------------------------------------------------------------------
// Gather / scatter (output, checkpoints, tests)
// ---------------------------------------------------------------------------------------------
std::vector<double> NdamSolver::gather_columns(const std::vector<double>& local) const {
  const int n = static_cast<int>(local.size());
  std::vector<int> counts(static_cast<std::size_t>(slab_.ranks)), displs(counts.size());
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_);
  int total = 0;
  for (std::size_t r = 0; r < counts.size(); ++r) {
    displs[r] = total;
    total += counts[r];
  }
  std::vector<double> all(static_cast<std::size_t>(total));
  MPI_Allgatherv(local.data(), n, MPI_DOUBLE, all.data(), counts.data(), displs.data(),
                 MPI_DOUBLE, comm_);
  return all;
}

// Owned cells of f on every rank: x-major (gi * nz + k) or z-major (k * nx + gi, FieldWriter).
std::vector<double> NdamSolver::gather_cells(const Field& f, bool z_major) const {
  const int nz = cfg_.grid.nz, nx = cfg_.grid.nx;
  std::vector<double> local;
  local.reserve(static_cast<std::size_t>(slab_.nx_local * nz));
  for (int i = 0; i < slab_.nx_local; ++i)
    for (int k = 0; k < nz; ++k) local.push_back(f(i, k));
  auto all = gather_columns(local);
  if (!z_major) return all;
  std::vector<double> zm(all.size());
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k)
      zm[static_cast<std::size_t>(k * nx + gi)] = all[static_cast<std::size_t>(gi * nz + k)];
  return zm;
}

void NdamSolver::scatter_cells(const std::vector<double>& global, Field& f) const {
  const int nz = cfg_.grid.nz;
  for (int i = 0; i < slab_.nx_local; ++i)
    for (int k = 0; k < nz; ++k)
      f(i, k) = global[static_cast<std::size_t>((slab_.i0 + i) * nz + k)];
}

std::vector<double> NdamSolver::gather_u() const { return gather_cells(u_, false); }
std::vector<double> NdamSolver::gather_w() const { return gather_cells(w_, false); }
std::vector<double> NdamSolver::gather_p() const { return gather_cells(p_, false); }
std::vector<double> NdamSolver::gather_nu() const { return gather_cells(nu_, false); }

// ---------------------------------------------------------------------------------------------
// Output contract
// ---------------------------------------------------------------------------------------------
core::Profile NdamSolver::profile() const {
  if (cfg_.free_surface) {
    // h and u_mean of eq. (21) from the markers (MarkerSet::profile: count-based depth), eps =
    // |w_mean| / |u_mean| (section 4.1); gathered at every accept().
    core::Profile p;
    for (int gi = 0; gi < cfg_.grid.nx; ++gi) {
      const auto q = static_cast<std::size_t>(gi);
      const double um = col_u_[q], wm = col_w_[q];
      const double eps = um != 0.0 ? std::min(1e6, std::abs(wm) / std::abs(um)) : 0.0;
      p.append(cfg_.x0 + (gi + 0.5) * cfg_.grid.dx(), col_h_[q], um, eps, "2D");
    }
    return p;
  }
  // Depth averages of the cell-centred velocities over the fluid cells of each column; h is
  // the fluid height of the column (Lz in a box without obstacles); eps = |w_mean| / |u_mean|
  // (paper section 4.1).
  const int nz = cfg_.grid.nz;
  std::vector<double> local;
  for (int i = 0; i < slab_.nx_local; ++i) {
    double um = 0.0, wm = 0.0;
    int n = 0;
    for (int k = 0; k < nz; ++k) {
      if (!fluid(slab_.i0 + i, k)) continue;
      um += 0.5 * (u_(i, k) + u_(i - 1, k));
      wm += 0.5 * (w_(i, k) + w_(i, k - 1));
      ++n;
    }
    local.push_back(n > 0 ? um / n : 0.0);
    local.push_back(n > 0 ? wm / n : 0.0);
    local.push_back(n * cfg_.grid.dz());
  }
  const auto all = gather_columns(local);
  core::Profile p;
  for (int gi = 0; gi < cfg_.grid.nx; ++gi) {
    const double um = all[static_cast<std::size_t>(3 * gi)];
    const double wm = all[static_cast<std::size_t>(3 * gi + 1)];
    const double eps = um != 0.0 ? std::min(1e6, std::abs(wm) / std::abs(um)) : 0.0;
    p.append((gi + 0.5) * cfg_.grid.dx(), all[static_cast<std::size_t>(3 * gi + 2)], um, eps,
             "2D");
  }
  return p;
}

core::MassBalance NdamSolver::mass_balance() const {
  // Incompressible and closed (or periodic): the mass per unit width is the fluid area, which
  // cannot change; the discrete divergence (reported separately) measures how well the velocity
  // field respects it.
  core::MassBalance m;
  if (cfg_.free_surface) {
    // the marker area (m^2 per unit width): initial, now, injected at the gate, removed at the
    // outflow; the defect is the marker count's, i.e. exactly 0 unless markers are lost.
    m.initial = mass0_;
    m.current = marker_mass_.area;
    m.inflow = marker_mass_.injected_area;
    m.outflow = marker_mass_.removed_area;
    return m;
  }
  m.initial = m.current = static_cast<double>(fluid_cells_) * cfg_.grid.dx() * cfg_.grid.dz();
  return m;
}

void NdamSolver::write_fields(io::FieldWriter& wr) const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  std::vector<double> xn(static_cast<std::size_t>(nx + 1)), zn(static_cast<std::size_t>(nz + 1));
  for (int i = 0; i <= nx; ++i) xn[static_cast<std::size_t>(i)] = cfg_.x0 + i * cfg_.grid.dx();
  for (int k = 0; k <= nz; ++k) zn[static_cast<std::size_t>(k)] = k * cfg_.grid.dz();
  Field uc(slab_.nx_local, nz), wc(slab_.nx_local, nz), dv(slab_.nx_local, nz),
      fl(slab_.nx_local, nz), pk(slab_.nx_local, nz);
  for (int i = 0; i < slab_.nx_local; ++i)
    for (int k = 0; k < nz; ++k) {
      const bool f = fluid(slab_.i0 + i, k);
      uc(i, k) = f ? 0.5 * (u_(i, k) + u_(i - 1, k)) : 0.0;
      wc(i, k) = f ? 0.5 * (w_(i, k) + w_(i, k - 1)) : 0.0;
      dv(i, k) = f ? divergence(u_, w_, i, k) : 0.0;
      fl(i, k) = static_cast<double>(flag(slab_.i0 + i, k));
      pk(i, k) = p_(i, k) * phys_.density;
    }
  auto& m = wr.add_mesh("ndam", std::move(xn), std::move(zn));
  m.cell_fields.emplace_back("u", gather_cells(uc, true));
  m.cell_fields.emplace_back("w", gather_cells(wc, true));
  m.cell_fields.emplace_back("p", gather_cells(p_, true));
  m.cell_fields.emplace_back("p_Pa", gather_cells(pk, true));
  m.cell_fields.emplace_back("nu_eff", gather_cells(nu_, true));
  m.cell_fields.emplace_back("div_u", gather_cells(dv, true));
  m.cell_fields.emplace_back("flag", gather_cells(fl, true));
}

void NdamSolver::save(io::Checkpoint& c) const {
  c.set("ndam/t", t_);
  c.set("ndam/steps", static_cast<double>(steps_));
  c.set("ndam/nx", static_cast<double>(cfg_.grid.nx));
  c.set("ndam/nz", static_cast<double>(cfg_.grid.nz));
  c.set("ndam/u", gather_u());
  c.set("ndam/w", gather_w());
  c.set("ndam/p", gather_p());
  if (markers_) {
    // Free surface: all markers (gathered, sorted by id; an id is stored as two doubles, its
    // high and low 31 bits, since injected ids start at 2^62, beyond a double's 53 bits), the
    // injection accumulators of the gate (rank 0 owns column 0), the global counters, the
    // initial marker area.
    const auto all = markers_->gather();
    std::vector<double> xs, zs, ids;
    for (const auto& m : all) {
      xs.push_back(m.x);
      zs.push_back(m.z);
      ids.push_back(static_cast<double>(m.id >> 31));
      ids.push_back(static_cast<double>(m.id & ((1LL << 31) - 1)));
    }
    c.set("ndam/markers_x", xs);
    c.set("ndam/markers_z", zs);
    c.set("ndam/markers_id", ids);
    std::vector<double> acc = markers_->inflow_accumulators();
    int n = static_cast<int>(acc.size());
    MPI_Bcast(&n, 1, MPI_INT, 0, comm_);
    acc.resize(static_cast<std::size_t>(n));
    MPI_Bcast(acc.data(), n, MPI_DOUBLE, 0, comm_);
    c.set("ndam/markers_accumulators", acc);
    const MarkerState st = markers_->save();
    long long loc[2] = {st.inject_next, st.seed_base}, mx[2] = {0, 0};
    MPI_Allreduce(loc, mx, 2, MPI_LONG_LONG, MPI_MAX, comm_);
    c.set("ndam/markers_inject_next", static_cast<double>(mx[0]));
    c.set("ndam/markers_seed_base", static_cast<double>(mx[1]));
    c.set("ndam/markers_injected", static_cast<double>(marker_mass_.injected));
    c.set("ndam/markers_removed", static_cast<double>(marker_mass_.removed));
    c.set("ndam/mass0", mass0_);
    c.set("ndam/inflow_owed", inflow_owed_);
  }
}

double NdamSolver::inflow_pending() const {
  if (!markers_) return 0.0;
  double acc = 0.0;
  if (slab_.i0 == 0)
    for (double a : markers_->inflow_accumulators()) acc += a;
  double all = 0.0;
  MPI_Allreduce(&acc, &all, 1, MPI_DOUBLE, MPI_SUM, comm_);
  return inflow_owed_ + all * markers_->marker_area();
}

void NdamSolver::load(const io::Checkpoint& c) {
  if (static_cast<int>(c.scalar("ndam/nx")) != cfg_.grid.nx ||
      static_cast<int>(c.scalar("ndam/nz")) != cfg_.grid.nz) {
    std::ostringstream os;
    os << "checkpoint grid (" << c.scalar("ndam/nx") << " x " << c.scalar("ndam/nz")
       << " cells) does not match the scene (" << cfg_.grid.nx << " x " << cfg_.grid.nz << ")";
    throw params::InputError(os.str());
  }
  t_ = c.scalar("ndam/t");
  steps_ = static_cast<long>(c.scalar("ndam/steps"));
  scatter_cells(c.array("ndam/u"), u_);
  scatter_cells(c.array("ndam/w"), w_);
  scatter_cells(c.array("ndam/p"), p_);
  if (markers_) {
    // This rank takes the markers of its columns; the gate's accumulators and the global
    // counters go to rank 0 (MarkerSet::mass() sums the ranks' counters).
    MarkerState st;
    const auto& xs = c.array("ndam/markers_x");
    const auto& zs = c.array("ndam/markers_z");
    const auto& ids = c.array("ndam/markers_id");
    const double dx = cfg_.grid.dx();
    for (std::size_t q = 0; q < xs.size(); ++q) {
      const int gi = std::clamp(static_cast<int>(std::floor(xs[q] / dx)), 0, cfg_.grid.nx - 1);
      if (gi >= slab_.i0 && gi < slab_.i0 + slab_.nx_local)
        st.markers.push_back(Marker{xs[q], zs[q],
                                    (static_cast<long long>(ids[2 * q]) << 31) +
                                        static_cast<long long>(ids[2 * q + 1])});
    }
    st.inflow_accumulators = c.array("ndam/markers_accumulators");
    st.inject_next = static_cast<long long>(c.scalar("ndam/markers_inject_next"));
    st.seed_base = static_cast<long long>(c.scalar("ndam/markers_seed_base"));
    st.injected = slab_.rank == 0 ? static_cast<long long>(c.scalar("ndam/markers_injected")) : 0;
    st.removed = slab_.rank == 0 ? static_cast<long long>(c.scalar("ndam/markers_removed")) : 0;
    markers_->load(st);
    mass0_ = c.scalar("ndam/mass0");
    if (c.scalars().count("ndam/inflow_owed")) inflow_owed_ = c.scalar("ndam/inflow_owed");
    inflow_owed_new_ = inflow_owed_;
    marker_mass_ = markers_->mass();
    update_flags_from_markers();
    if (cfg_.inflow) inflow_now_ = cfg_.inflow(t_);
  }
  fill_velocity_ghosts(u_, w_);
  fill_scalar_ghosts(p_);
  update_viscosity(p_);
  if (markers_) update_profile_cache();
  u_new_ = u_;
  w_new_ = w_;
  p_new_ = p_;
}

void NdamSolver::report(nlohmann::json& s) const {
  auto avg = [](long long its, long long n) { return n > 0 ? double(its) / double(n) : 0.0; };
  s["ndam"] = {
      {"cells_x", cfg_.grid.nx},
      {"cells_z", cfg_.grid.nz},
      {"dx", cfg_.grid.dx()},
      {"dz", cfg_.grid.dz()},
      {"ranks", slab_.ranks},
      {"momentum", cfg_.momentum == Momentum::Explicit ? "Explicit" : "Implicit"},
      {"rheology", rheo_.name()},
      {"steps", steps_},
      {"dt_min", dt_min_},
      {"dt_max", dt_max_},
      {"max_divergence", max_div_},
      {"max_nu_eff", max_nu_eff()},
      {"pressure_solves", p_solves_},
      {"pressure_krylov_iterations", p_iters_},
      {"pressure_krylov_iterations_per_solve", avg(p_iters_, p_solves_)},
      {"pressure_worst_relative_residual", worst_p_res_},
      {"momentum_solves", m_solves_},
      {"momentum_krylov_iterations", m_iters_},
      {"momentum_krylov_iterations_per_solve", avg(m_iters_, m_solves_)},
      {"momentum_worst_relative_residual", worst_m_res_},
      {"unconverged_solves", failed_solves_},
      {"pressure_preconditioner_setups", pressure_->preconditioner_setups()},
      {"pressure_preconditioner_setup_seconds", pressure_->preconditioner_setup_seconds()},
      {"pressure_pattern_builds", pressure_->pattern_builds()},
      {"momentum_pattern_builds", momentum_ ? momentum_->pattern_builds() : 0LL},
      {"momentum_preconditioner_setups", momentum_ ? momentum_->preconditioner_setups() : 0LL},
      {"momentum_preconditioner_setup_seconds",
       momentum_ ? momentum_->preconditioner_setup_seconds() : 0.0},
      {"free_surface", cfg_.free_surface}};
  if (cfg_.free_surface) {
    s["ndam"]["markers"] = marker_mass_.count;
    s["ndam"]["marker_area"] = marker_mass_.area;
    s["ndam"]["seconds_markers_last_step"] = sec_mark_;
    if (inflow_mass_) s["ndam"]["inflow_pending_area"] = inflow_pending();
  }
  // The nonlinear pressure system (Pressure coupling = Nonlinear): Newton and Krylov (GMRES)
  // iterations per step, residual evaluations (each one predictor-projection).
  s["ndam"]["pressure_coupling"] =
      cfg_.pressure_coupling == PressureCoupling::Nonlinear ? "Nonlinear" : "Lagged";
  if (newton_solves_ > 0)
    s["ndam"]["newton"] = {{"solves", newton_solves_},
                           {"newton_iterations", newton_iters_},
                           {"newton_iterations_per_step", avg(newton_iters_, newton_solves_)},
                           {"newton_iterations_max", newton_max_iters_},
                           {"krylov_iterations", newton_krylov_},
                           {"krylov_iterations_per_step", avg(newton_krylov_, newton_solves_)},
                           {"residual_evaluations", newton_evals_},
                           {"residual_evaluations_per_step", avg(newton_evals_, newton_solves_)},
                           {"worst_final_residual", newton_worst_residual_},
                           {"unconverged_steps_continued", newton_continued_},
                           {"worst_residual_continued", newton_continued_worst_},
                           {"seconds", newton_seconds_}};
  // Wall time per phase over the accepted steps (this rank): momentum predictor, pressure
  // solve, markers (advection, injection, flags), and the rest of the step (viscosity,
  // correction, ghost exchange).
  s["ndam"]["seconds"] = {{"momentum", total_mom_},
                          {"pressure", total_p_},
                          {"markers", total_mark_},
                          {"other", total_other_}};
}

}  // namespace granflow::ndam
