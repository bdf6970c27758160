// N-DAM time step on the staggered MAC grid (see ndam_solver.hpp for the equations and the
// file of each step, grid.hpp for the index conventions): construction from a resting state,
// the stable time step, step() as the algorithm box, check() and accept().
#include "stencil.hpp"

#include "granflow/params/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace granflow::ndam {

using detail::Clock;
using detail::seconds_since;

namespace {
// Implicit Newtonian momentum: the momentum matrix depends on dt only, so the dt it was assembled
// with is kept while it stays within [kDtHoldFraction, 1] of the stable dt, and the matrix and
// its preconditioner are reused. A held dt is at least 0.8 of the stable one: at most 1.25
// times the steps, against a reassembly and preconditioner setup in every step.
constexpr double kDtHoldFraction = 0.8;
// A linear solve that stopped short of its tolerance is counted in summary.json; one whose
// relative residual is above this (six orders of magnitude of reduction, e.g. 'Max iterations'
// too small for a stiff system) stops the run instead of producing a wrong state.
constexpr double kLinearSolveStopResidual = 1e-6;
// The surface-wave limit's Courant number sqrt(g cos(zeta) h) dt / dx is at most this, whatever
// CFL is: the limit is the explicit surface's stability, not an accuracy choice. At a wave
// Courant number of 1 (CFL 1) a resting pile woke up with every form of the rotational update
// (a = 1 column, 5 mm: rms speed 31 mm/s against its creep bound 10.9); at 0.5 (the default
// CFL) it rests (docs/validation.md, "What wakes the deposit").
constexpr double kMaxWaveCourant = 0.5;
// The gate's limit (stable_dt) cuts the step to at most this fraction of the others: a series
// whose depth jumps within a shorter time is taken as a jump.
constexpr double kGateJumpFraction = 1e-3;
}  // namespace

NdamSolver::NdamSolver(MPI_Comm comm, const NdamConfig& cfg, const Rheology& rheo,
                       const NdamPhysics& phys)
    : NdamSolver(comm, cfg, rheo, phys, nullptr, NdamStatistics{}) {}

NdamSolver::NdamSolver(MPI_Comm comm, const NdamConfig& cfg, const Rheology& rheo,
                       const NdamPhysics& phys, const NdamState& state,
                       const NdamStatistics& stats)
    : NdamSolver(comm, cfg, rheo, phys, &state, stats) {}

NdamSolver::NdamSolver(MPI_Comm comm, const NdamConfig& cfg, const Rheology& rheo,
                       const NdamPhysics& phys, const NdamState* state,
                       const NdamStatistics& stats)
    : comm_(comm), cfg_(cfg), rheo_(rheo), phys_(phys),
      mac_(comm, cfg.grid, cfg.periodic_x()), stats_(stats) {
  setup();
  if (state) {
    import_state(*state);
    assemble_pressure();
    flags_changed_ = false;
  } else {
    rest_state();
  }
}

// The layout and its fields, the obstacle cells, the (empty) marker set and the linear systems.
void NdamSolver::setup() {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  const bool per = cfg_.periodic_x();
  mac_.dirichlet_inflow_column = cfg_.inflow_pressure == InflowPressure::Dirichlet;
  mac_.ghost_surface = cfg_.free_surface && cfg_.ghost_surface;
  // Ghost fluid at walls: the zone next to each wall end of this box (a 2D subdomain's ends at
  // interfaces are an open outflow on the right and an inflow on the left, no walls)
  mac_.ghost_zone_all = cfg_.ghost_wall_columns <= 0;
  if (!per && cfg_.ghost_wall_columns > 0) {
    mac_.wall_columns_right = cfg_.outflow_right ? 0 : cfg_.ghost_wall_columns;
    mac_.wall_columns_left = cfg_.wall_left ? cfg_.ghost_wall_columns : 0;
  }
  const int nxl = mac_.slab.nx_local;
  u_ = Field(nxl, nz);
  w_ = Field(nxl, nz);
  p_ = Field(nxl, nz);
  nu_ = Field(nxl, nz, rheo_.nu);
  // Cell flags of the whole box on every rank (small, and the stencils near slab edges need
  // their neighbours' flags): obstacle where a cell centre lies in an obstacle rectangle.
  for (const auto& r : cfg_.obstacles) {
    int covered = 0;
    for (int gi = 0; gi < nx; ++gi)
      for (int k = 0; k < nz; ++k) {
        const double x = (gi + 0.5) * cfg_.grid.dx(), z = (k + 0.5) * cfg_.grid.dz();
        if (x > r[0] && x < r[1] && z > r[2] && z < r[3]) {
          mac_.flags[static_cast<std::size_t>(gi * nz + k)] = CellFlag::Obstacle;
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
      throw params::InputError("parameter 'granflow->N-DAM->Obstacles': obstacles are not "
                               "available with 'Free surface' = true in this version; allowed: "
                               "no obstacles");
    // Markers: the left side injects (MarkerSet reflects there like a wall when nothing is
    // injected), the right side removes at an open outflow; bed and top are walls.
    MarkerConfig mc;
    mc.per_cell_x = mc.per_cell_z = cfg_.markers_per_cell;
    mc.sides[0] = per ? MarkerBoundary::Periodic : MarkerBoundary::Inflow;
    mc.sides[1] = per ? MarkerBoundary::Periodic
                      : (cfg_.outflow_right ? MarkerBoundary::Outflow : MarkerBoundary::Wall);
    markers_ = std::make_unique<MarkerSet>(comm_, cfg_.grid, mac_.slab, mc);
    markers_new_ = std::make_unique<MarkerSet>(*markers_);
  }
  p_dir_ = Field(nxl, nz);
  normD_ = Field(nxl, nz);
  // Pressure: one unknown per cell, numbered gi * nz + k (contiguous per slab). The matrix -L
  // changes only with the cell flags: it is assembled once the flags are known and again
  // whenever they change (free surface); its preconditioner is set up after each assembly.
  pressure_ = std::make_unique<solvers::LinearSystem>(
      comm_, static_cast<long long>(nx) * nz, mac_.p_gid(mac_.slab.i0, 0), nxl * nz,
      cfg_.pressure_solver);
  if (cfg_.momentum == Momentum::Implicit) {
    // u and w of a cell are interleaved (2 (gi nz + k) and +1) so that MueLu can aggregate them
    // as two equations per node; wall-normal faces are identity rows.
    Teuchos::ParameterList mp = cfg_.momentum_solver;
    if (!mp.sublist("MueLu").isParameter("number of equations"))
      mp.sublist("MueLu").set("number of equations", 2);
    momentum_ = std::make_unique<solvers::LinearSystem>(
        comm_, 2LL * nx * nz, 2 * mac_.p_gid(mac_.slab.i0, 0), 2 * nxl * nz, mp);
  }
  const auto nb = static_cast<std::size_t>(nxl + 2 * Field::G);
  bed_a_.assign(nb, 1.0);
  bed_b_.assign(nb, 0.0);
  bed_q_.assign(nb, 0.0);
  bed_stuck_.assign(nb, 0);
  wall_a_.assign(static_cast<std::size_t>(nz), 1.0);
  wall_b_.assign(static_cast<std::size_t>(nz), 0.0);
  wall_q_.assign(static_cast<std::size_t>(nz), 0.0);
  wall_stuck_.assign(static_cast<std::size_t>(nz), 0);
}

// The cells outside the obstacles must form one connected region (parameters.md, Obstacles):
// the pressure of the closed box is fixed up to a constant by one pinned cell, so a region cut
// off from it has a singular pressure system whose level is whatever the Krylov iteration
// leaves (found by an independent run: a full-width slab in the rest-slope box ran to the end
// with pressures of -214 to 10 499 Pa along one row under it). A breadth-first search over the
// non-obstacle cells from the first of them (across the periodic ends when x is periodic),
// the same on every rank (the flags of the whole box are on every rank).
void NdamSolver::check_obstacles_connected() const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  auto open = [&](int gi, int k) { return mac_.gflag(gi, k) != CellFlag::Obstacle; };
  std::vector<char> seen(static_cast<std::size_t>(nx) * static_cast<std::size_t>(nz), 0);
  auto at = [&](int gi, int k) -> char& {
    return seen[static_cast<std::size_t>(gi) * static_cast<std::size_t>(nz) + static_cast<std::size_t>(k)];
  };
  long long open_cells = 0, reached = 0;
  std::vector<std::array<int, 2>> queue;
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k)
      if (open(gi, k)) {
        ++open_cells;
        if (queue.empty()) {
          queue.push_back({gi, k});
          at(gi, k) = 1;
        }
      }
  for (std::size_t q = 0; q < queue.size(); ++q) {
    ++reached;
    const auto [gi, k] = queue[q];
    const int di[4] = {-1, 1, 0, 0}, dk[4] = {0, 0, -1, 1};
    for (int n = 0; n < 4; ++n) {
      int gj = gi + di[n];
      const int kk = k + dk[n];
      if (kk < 0 || kk >= nz) continue;
      if (gj < 0 || gj >= nx) {
        if (!cfg_.periodic_x()) continue;
        gj = (gj + nx) % nx;
      }
      if (!open(gj, kk) || at(gj, kk)) continue;
      at(gj, kk) = 1;
      queue.push_back({gj, kk});
    }
  }
  if (reached == open_cells) return;
  std::string spec;
  for (const auto& r : cfg_.obstacles)
    spec += (spec.empty() ? "" : "; ") + params::str(r[0]) + " " + params::str(r[1]) + " " +
            params::str(r[2]) + " " + params::str(r[3]);
  throw params::InputError(
      "parameter 'granflow->N-DAM->Obstacles' = " + spec + ": the obstacles cut the box into "
      "regions that do not connect (" + std::to_string(open_cells - reached) + " of " +
      std::to_string(open_cells) + " fluid cells are cut off from the cell at x = " +
      params::str(cfg_.x0 + (queue[0][0] + 0.5) * cfg_.grid.dx()) + " m, z = " +
      params::str((queue[0][1] + 0.5) * cfg_.grid.dz()) + " m), so the pressure of a closed "
      "region has no reference; allowed: rectangles that leave one connected fluid region");
}

// t = 0: the material at rest (the initial layer of the free-surface box, or the whole closed
// box) with the pressure of eq. (10), i.e. in hydrostatic balance.
void NdamSolver::rest_state() {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  if (cfg_.free_surface) {
    const double xa = cfg_.initial_x0 - cfg_.x0, xb = cfg_.initial_x1 - cfg_.x0,
                 h0 = cfg_.initial_depth;
    // The layer is the channel's: a 2D part of a coupled layout that it does not reach starts
    // empty (the layout's validation refuses a layer that reaches into a 1D part). Before, such
    // a part refused the layer as holding no marker, so no layout with two 2D parts took one
    // (an independent run, session 44).
    const double lx = nx * cfg_.grid.dx();
    const double reach = std::min(xb, lx) - std::max(xa, 0.0);
    if (h0 > 0.0 && reach > 0.0) markers_->seed_rectangle(xa, xb, h0);
    mass0_ = markers_->mass().area;
    // A layer too thin (or too short) for one marker would start an empty box without a word
    // (an independent run: 'Initial depth' 1e-9 m, exit 0, mass 0): refused where the layer lies
    // in this box, or reaches into it by more than half a marker's spacing (less is a part's
    // end meeting the layer's by round-off, e.g. a part rebuilt on a restart: no marker's
    // centre lies there).
    const double spacing = cfg_.grid.dx() / cfg_.markers_per_cell;
    const bool whole_layer = xa >= -1e-9 * lx && xb <= lx * (1.0 + 1e-9);
    if (h0 > 0.0 && mass0_ == 0.0 && (whole_layer || reach > 0.5 * spacing))
      throw params::InputError(
          "parameter 'granflow->N-DAM->Initial depth' = " + params::str(h0) +
          ": the layer on [" + params::str(cfg_.initial_x0) + ", " +
          params::str(cfg_.initial_x1) + ") m holds no marker (markers carry dx dz / " +
          std::to_string(cfg_.markers_per_cell * cfg_.markers_per_cell) +
          " each); allowed: 0 (no layer), or a layer of at least one marker's area, e.g. a "
          "depth >= dz / 'Markers per cell' = " +
          params::str(cfg_.grid.dz() / cfg_.markers_per_cell) + " m");
    marker_mass_ = markers_->mass();
    update_flags(*markers_, mac_.flags, mac_.empty_mask, mac_.depth);
    mac_.classify_surface_pressure();
  }
  fluid_cells_ = 0;
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < nz; ++k)
      if (mac_.p_unknown(gi, k)) ++fluid_cells_;
  if (fluid_cells_ == 0 && !cfg_.free_surface)
    throw params::InputError("N-DAM->Obstacles: the obstacles fill the whole box; allowed: "
                             "rectangles that leave fluid cells");
  if (!cfg_.obstacles.empty()) check_obstacles_connected();
  assemble_pressure();
  if (cfg_.inflow) inflow_now_ = cfg_.inflow(0.0);
  fill_velocity_ghosts(u_, w_);
  update_viscosity(p_);
  if (cfg_.free_surface) {
    // The free surface's Dirichlet values in eq. (10) as in every step (surface_conditions):
    // p = 0 at the markers' surface inside a Surface cell, not at its centre. Without them the
    // pressure written at t = 0 (fields.h5, wall.csv) and the first step's lagged pressure were
    // g cos(zeta) dz / 2 low under a surface (an independent run: a pool of 5 mm cells 10 %
    // low at its foot at t = 0, hydrostatic from the first step on).
    update_profile_cache();
    surface_conditions();
  }
  initial_pressure();
  // Coulomb factors with the initial pressure (the column profiles above take no pressure)
  if (cfg_.free_surface) update_viscosity(p_);
  u_new_ = u_;
  w_new_ = w_;
  p_new_ = p_;
  // the first step from rest: the friction factor of a base that gravity alone accelerates
  // grows by m_c |g| dt at most (stable_dt)
  if (cfg_.momentum == Momentum::Implicit && coulomb_walls())
    friction_dt_ = 1.0 / (cfg_.m_c * std::hypot(phys_.gx, phys_.gz));
  u_star_ = u_;  // the wall load of the initial state (no step yet)
  w_star_ = w_;
}

NdamSolver::~NdamSolver() = default;

bool NdamSolver::coulomb_walls() const {
  return cfg_.walls[1].kind == WallKind::Coulomb || cfg_.walls[2].kind == WallKind::Coulomb;
}

// The growth of the friction factor in the tentative step: max over the Coulomb faces of
// (|c(u^{n+1})| - |c(u^n)|)^+ with c of (12), as dt_step / growth, the time over which it
// would grow by 1 at that rate (<= 0: it did not grow). Faces clamped to sticking do not count.
double NdamSolver::friction_growth_dt() const {
  const int G = Field::G, nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
  const double m = cfg_.m_c;
  auto c = [m](double u) { return -std::expm1(-m * std::abs(u)); };
  double growth = 0.0;
  if (cfg_.walls[2].kind == WallKind::Coulomb)
    for (int i = 0; i < nxl; ++i) {
      const auto f = static_cast<std::size_t>(i + G);
      if (bed_q_[f] > 0.0 && !bed_stuck_[f] && mac_.u_unknown(i, 0))
        growth = std::max(growth, c(u_new_(i, 0)) - c(u_(i, 0)));
    }
  if (cfg_.walls[1].kind == WallKind::Coulomb && mac_.slab.i0 + nxl == cfg_.grid.nx)
    for (int k = 0; k < nz - 1; ++k) {
      const auto f = static_cast<std::size_t>(k);
      if (wall_q_[f] > 0.0 && !wall_stuck_[f] && mac_.w_unknown(nxl - 1, k))
        growth = std::max(growth, c(w_new_(nxl - 1, k)) - c(w_(nxl - 1, k)));
    }
  growth = detail::allreduce_max(growth, comm_);
  return growth > 0.0 ? (t_new_ - t_) / growth : -1.0;
}

double NdamSolver::stable_dt() const {
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  const int nz = cfg_.grid.nz;
  double umax = 0.0, wmax = 0.0;
  for (int i = 0; i < mac_.slab.nx_local; ++i)
    for (int k = 0; k < nz; ++k) {
      umax = std::max(umax, std::abs(u_(i, k)));
      wmax = std::max(wmax, std::abs(w_(i, k)));
    }
  umax = detail::allreduce_max(umax, comm_);
  wmax = detail::allreduce_max(wmax, comm_);
  double dt = std::numeric_limits<double>::infinity();
  dt_cause_ = "no flow";
  // which candidate is the smallest (for the coupled model's tally of what sets the step)
  auto cand = [&](double v, const char* why) {
    if (v < dt) {
      dt = v;
      dt_cause_ = why;
    }
  };
  const bool inflow_fastest = cfg_.free_surface && cfg_.inflow && std::abs(inflow_now_[1]) > umax;
  if (inflow_fastest) umax = std::abs(inflow_now_[1]);
  if (umax > 0.0) cand(dx / umax, inflow_fastest ? "inflow velocity, dx / |u_in|" : "advection, dx / |u|");
  if (wmax > 0.0) cand(dz / wmax, "advection, dz / |w|");
  if (cfg_.momentum == Momentum::Explicit) {
    // Forward Euler on div(2 nu D): the largest eigenvalue is below
    // nu (8/dx^2 + 8/dz^2) (normal stress 2 nu, shear stress nu, 3-point stencils), so
    // dt <= 1 / (4 nu (1/dx^2 + 1/dz^2)) keeps it stable with the safety factor below.
    const double numax = max_nu_eff();
    if (numax > 0.0)
      cand(1.0 / (4.0 * numax * (1.0 / (dx * dx) + 1.0 / (dz * dz))), "explicit viscous limit");
    // Coulomb friction, explicit: the bed face loses nu_b (1 - a) / dz^2 of its velocity per
    // second (a: the Robin ghost factor), so forward Euler needs dt <= 1 / that rate.
    double rate = 0.0;
    for (int i = 0; i < mac_.slab.nx_local && cfg_.walls[2].kind == WallKind::Coulomb; ++i) {
      const double a = bed_a_[static_cast<std::size_t>(i + Field::G)];
      rate = std::max(rate, 0.5 * (nu_(i, 0) + nu_(i + 1, 0)) * (1.0 - a) / (dz * dz));
    }
    rate = detail::allreduce_max(rate, comm_);
    if (rate > 0.0) cand(1.0 / rate, "explicit Coulomb friction limit");
  }
  // The start-up of the Coulomb friction (implicit momentum): while a base accelerates from rest
  // its friction factor c of (12) grows from 0 to 1 within |u| ~ 5 / m_c, i.e. over a few
  // milliseconds, and the friction impulse of that transient (the plug's offset
  // ln(1 + c_F / a) / m_c over a t, docs/numerics.md) is only as good as the steps that resolve
  // it. The step is limited so that c grows by at most CFL per step, at the rate of the last
  // step (friction_dt_: the time over which it would grow by 1). A base that slows down or keeps
  // its speed sets no limit: a steady slide (c = 1) and a deposit at rest keep the advective
  // step, and a base coming to rest at a shock is not held back.
  if (cfg_.momentum == Momentum::Implicit && friction_dt_ > 0.0)
    cand(friction_dt_, "Coulomb friction start-up");
  // Surface gravity waves (free surface): the surface height enters the step explicitly (the
  // markers of t^n set the Surface cells' pressure g cos(zeta) (h - z) and move afterwards), so
  // the long waves of a column of depth h, speed |u_mean| +- sqrt(g cos(zeta) h) as in the DAM's
  // step, must be resolved like advection: the limit takes sqrt(g cos(zeta) h), the advective
  // limit beside it |u|, so that (|u| + sqrt(g cos(zeta) h)) dt / dx <= 2 CFL. In a flow the
  // faces' |u| is the larger speed; in a
  // deposit at rest |u| -> 0 lets the advective step grow until the explicit surface pumps the
  // pile: a column collapse at 2.5 mm crept at an rms speed of 8-27 mm/s (its regularisation's
  // creep bound 11 mm/s) with steps of 3-4 ms, at 2.7-3.1 mm/s with 2 ms, and the same at 5 mm
  // with 2.4 ms (docs/validation.md, "Coulomb friction in time and deposits at rest").
  if (const double c = surface_wave().speed; c > 0.0)
    cand(dx / c * std::min(1.0, kMaxWaveCourant / cfg_.cfl),
         "surface gravity waves, dx / sqrt(g cos(zeta) h)");
  dt *= cfg_.cfl;
  // The gate of an inflow series: the opening h_in is taken at t^n for the whole step
  // (gate_state), so a gate closing within one step turned several rows from inflow faces into
  // the wall at once under a column still moving, and the projection answered with a suction
  // that threw the gate's cells (m_y = 1000 s, CFL 0.5: four rows in one step, 5.4 m/s, a pulse
  // on 20 deg that ran to the wall; docs/validation.md, "The gate pulse's run-out"). The edge
  // of the opening is resolved like a wave: |h_in(t^n + dt) - h_in(t^n)| <= CFL dz. It binds
  // only while the series opens or closes the gate (a 10 ms closure of 6 cm at 5 mm: 24 steps
  // at CFL 0.5); a steady gate and an interface's inflow (no series) set no limit. A series
  // row that moves the gate faster than kGateJumpFraction of the other limits allow is taken
  // as the jump it describes (the step is not cut below that fraction).
  if (cfg_.free_surface && cfg_.inflow && cfg_.inflow_volume) {
    const double h0 = cfg_.inflow(t_)[0], moves = cfg_.cfl * dz;
    double probe = std::isfinite(dt) ? dt : 1.0;  // at rest: the gate may still open
    const double shortest = kGateJumpFraction * probe;
    bool bound = false;
    while (probe > shortest && std::abs(cfg_.inflow(t_ + probe)[0] - h0) > moves) {
      probe = std::max(shortest, 0.75 * probe);
      bound = true;
    }
    if (bound && probe < dt) {
      dt = probe;
      dt_cause_ = "inflow series, the gate's opening: CFL dz / |dh_in/dt|";
    }
  }
  // The free surface's viscous limit (implicit momentum): the viscous stress is implicit, but
  // the velocity conditions of the Surface cells' faces towards Empty cells are set from the
  // last iterate, an explicit part of the viscous operator; at large nu dt / h^2 it amplified
  // (nu = 0.3 m^2/s, 5 mm: notches and pillars of single surface cells behind the gate, 20-40
  // m/s, at nu dt / h^2 = 36-48; held at 30). Not scaled by the CFL number: it is the scheme's
  // limit, not the flow's. With the default viscosity (0.003) K h^2 / nu = 0.17 s at 5 mm.
  if (const double v = viscous_surface_dt(); std::isfinite(v))
    cand(v, "free-surface viscous limit, K min(dx, dz)^2 / nu");
  // Implicit and Newtonian: the dt of the assembled momentum matrix is held (kDtHoldFraction).
  if (cfg_.momentum == Momentum::Implicit && rheo_.newtonian() && momentum_dt_ > 0.0 &&
      momentum_dt_ <= dt && momentum_dt_ >= kDtHoldFraction * dt) {
    dt = momentum_dt_;
    dt_cause_ = "held momentum matrix dt";
  }
  return dt;
}

double NdamSolver::viscous_surface_dt() const {
  if (cfg_.momentum != Momentum::Implicit || !cfg_.free_surface ||
      !(cfg_.viscous_surface_number > 0.0) || !(rheo_.nu > 0.0))
    return std::numeric_limits<double>::infinity();
  const double h = std::min(cfg_.grid.dx(), cfg_.grid.dz());
  return cfg_.viscous_surface_number * h * h / rheo_.nu;
}

// The condition behind stable_dt() and its place, for the diagnosis of a collapsed step: the
// candidates of stable_dt (advective u and w, the surface waves of the deepest column, the free
// surface's viscous limit, and for the explicit scheme the viscous and the Coulomb-friction
// limits), each at the face, cell or
// column of its largest value over the ranks.
std::string NdamSolver::dt_limit() const {
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  const int nz = cfg_.grid.nz;
  struct Where {
    double v = 0.0, x = 0.0, z = 0.0;
  };
  Where u, w, nu, fr;
  for (int i = 0; i < mac_.slab.nx_local; ++i) {
    const int gi = mac_.slab.i0 + i;
    for (int k = 0; k < nz; ++k) {
      if (std::abs(u_(i, k)) > u.v) u = {std::abs(u_(i, k)), (gi + 1) * dx, (k + 0.5) * dz};
      if (std::abs(w_(i, k)) > w.v) w = {std::abs(w_(i, k)), (gi + 0.5) * dx, (k + 1) * dz};
      if (nu_(i, k) > nu.v) nu = {nu_(i, k), (gi + 0.5) * dx, (k + 0.5) * dz};
    }
    if (cfg_.momentum == Momentum::Explicit && cfg_.walls[2].kind == WallKind::Coulomb) {
      const double a = bed_a_[static_cast<std::size_t>(i + Field::G)];
      const double r = 0.5 * (nu_(i, 0) + nu_(i + 1, 0)) * (1.0 - a) / (dz * dz);
      if (r > fr.v) fr = {r, (gi + 0.5) * dx, 0.0};
    }
  }
  auto global = [&](Where q) {  // the largest over the ranks, its place from the rank holding it
    struct {
      double v;
      int rank;
    } mine{q.v, mac_.slab.rank}, top{};
    MPI_Allreduce(&mine, &top, 1, MPI_DOUBLE_INT, MPI_MAXLOC, comm_);
    double b[3] = {q.v, q.x, q.z};
    MPI_Bcast(b, 3, MPI_DOUBLE, top.rank, comm_);
    return Where{b[0], cfg_.x0 + b[1], b[2]};
  };
  u = global(u), w = global(w), nu = global(nu), fr = global(fr);
  const SurfaceWave sw = surface_wave();  // the same on every rank (col_h_: all columns)
  const Where gw{sw.speed, cfg_.x0 + (static_cast<double>(sw.column) + 0.5) * dx, sw.h};
  const double inf = std::numeric_limits<double>::infinity();
  const bool expl = cfg_.momentum == Momentum::Explicit;
  const double dt_u = u.v > 0.0 ? dx / u.v : inf, dt_w = w.v > 0.0 ? dz / w.v : inf;
  const double dt_nu = expl && nu.v > 0.0 ? 1.0 / (4.0 * nu.v * (1.0 / (dx * dx) + 1.0 / (dz * dz)))
                                          : inf;
  const double dt_fr = expl && fr.v > 0.0 ? 1.0 / fr.v : inf;
  const double dt_gw = gw.v > 0.0 ? dx / gw.v : inf;
  const double dt_start = cfg_.momentum == Momentum::Implicit && friction_dt_ > 0.0 ? friction_dt_ : inf;
  // (the free surface's viscous limit is not scaled by the CFL number: compared as CFL-scaled)
  const double dt_vs = viscous_surface_dt() / cfg_.cfl;
  std::ostringstream os;
  const double m = std::min({dt_u, dt_w, dt_nu, dt_fr, dt_gw, dt_start, dt_vs});
  if (!std::isfinite(m)) return "no velocity and no viscous limit (the material at rest)";
  if (m == dt_vs)
    os << "the free surface's viscous limit K min(dx, dz)^2 / nu: K = "
       << cfg_.viscous_surface_number << ", nu = " << rheo_.nu << " m^2/s";
  else if (m == dt_start)
    os << "the Coulomb friction start-up (the friction factor of a base starting to slide grows "
          "by at most CFL per step): it would grow by 1 in " << dt_start << " s";
  else if (m == dt_gw)
    os << "the surface-wave limit CFL dx / sqrt(g cos(zeta) h): sqrt(g cos(zeta) h) = " << gw.v
       << " m/s in the column at x = " << gw.x << " m, h = " << gw.z << " m";
  else if (m == dt_nu)
    os << "the explicit viscous limit CFL / (4 nu_eff (1/dx^2 + 1/dz^2)): nu_eff = " << nu.v
       << " m^2/s at x = " << nu.x << " m, z = " << nu.z << " m";
  else if (m == dt_fr)
    os << "the explicit Coulomb friction limit: bed damping rate " << fr.v << " 1/s at x = "
       << fr.x << " m";
  else if (m == dt_u)
    os << "the advective CFL limit: |u| = " << u.v << " m/s at the face x = " << u.x
       << " m, z = " << u.z << " m";
  else
    os << "the advective CFL limit: |w| = " << w.v << " m/s at the face x = " << w.x
       << " m, z = " << w.z << " m";
  return os.str();
}

NdamSolver::SurfaceWave NdamSolver::surface_wave() const {
  SurfaceWave sw;
  if (!cfg_.free_surface) return sw;
  for (std::size_t q = 0; q < col_h_.size(); ++q)  // the deepest column is the fastest
    if (col_h_[q] > sw.h) sw = {std::sqrt(std::abs(phys_.gz) * col_h_[q]), q, col_h_[q]};
  return sw;
}

double NdamSolver::max_nu_eff() const {
  double m = 0.0;
  for (int i = 0; i < mac_.slab.nx_local; ++i)
    for (int k = 0; k < cfg_.grid.nz; ++k) m = std::max(m, nu_(i, k));
  return detail::allreduce_max(m, comm_);
}

// One time step from t^n to t^n + dt into the tentative state (u_new_, w_new_, p_new_, the
// tentative markers and flags); accept() makes it current. The lines of the algorithm:
void NdamSolver::step(double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw std::invalid_argument("NdamSolver::step: dt must be positive and finite");
  const auto t0 = Clock::now();
  // 1. the gate state of this step (lagged at t^n) and the boundary faces with it
  if (cfg_.free_surface) gate_state(dt);
  // 2. nu_eff(u^n, p^n) (eqs. 4-6) and the Coulomb ghost factors (13)
  update_viscosity(p_);
  // The rotational pressure update is a splitting correction (it vanishes at a steady state),
  // not part of eq. (10): it keeps nu_eff(u^n, p^n) in the nonlinear coupling too, where the
  // trial pressure would otherwise enter through 2 nu_eff(q) div u*, a term that is large
  // wherever the material is stopped (nu_eff ~ tau_p m_y q) and that made Newton stall; and
  // (pressure_system.cpp) the divergence of the lagged step's predictor, for the same reason.
  nu_rot_ = nu_;
  // 3. free-surface conditions: the Dirichlet values of the Surface and Empty cells
  if (cfg_.free_surface) surface_conditions();
  stats_.step_other = detail::seconds_since(t0);
  stats_.step_momentum = stats_.step_pressure = stats_.step_markers = 0.0;
  newton_failed_ = false;
  // 4.-6. predictor (8), projection (10), correction; tau_y and (13) at p^n (Lagged) or at the
  // new pressure (Nonlinear: the fixed point solved by NOX)
  if (cfg_.pressure_coupling == PressureCoupling::Nonlinear && pressure_dependent())
    solve_pressure_system(dt);
  else
    project(dt);
  const auto t3 = Clock::now();
  max_div_new_ = max_abs_divergence(u_new_, w_new_);  // for check() and the statistics
  t_new_ = t_ + dt;
  stats_.record_dt(dt);
  stats_.step_other += detail::seconds_since(t3);
  if (cfg_.free_surface) {
    // 7. markers move in u^n and u^{n+1}; the gate injects. They advance by the step of the
    // clock, t^{n+1} - t^n (in floating point not always dt), so that positions and time agree.
    const auto tm = Clock::now();
    advect_markers(t_new_ - t_);
    // 8. Fluid/Surface/Empty from the new markers (from the counts the void filling took,
    // when it moved no marker)
    if (!marker_counts_new_.empty())
      update_flags(marker_counts_new_, markers_new_->marker_area(), flags_new_, mask_new_,
                   depth_new_, &deepest_new_);
    else
      update_flags(*markers_new_, flags_new_, mask_new_, depth_new_, &deepest_new_);
    stats_.step_markers = detail::seconds_since(tm);
  }
}

double NdamSolver::last_seconds(const std::string& phase) const {
  if (phase == "momentum") return stats_.step_momentum;
  if (phase == "pressure") return stats_.step_pressure;
  if (phase == "markers") return stats_.step_markers;
  return stats_.step_other;
}

core::Health NdamSolver::check() const {
  core::Health h;
  const int nz = cfg_.grid.nz;
  const double dx = cfg_.grid.dx();
  // Local first, then agree on all ranks (the driver's decision must be collective).
  int bad = 0;
  for (int i = 0; i < mac_.slab.nx_local && !bad; ++i)
    for (int k = 0; k < nz && !bad; ++k) {
      const double vals[3] = {u_new_(i, k), w_new_(i, k), p_new_(i, k)};
      const char* names[3] = {"u", "w", "p"};
      for (int q = 0; q < 3; ++q)
        if (!std::isfinite(vals[q]) || (q < 2 && std::abs(vals[q]) > core::kMaxVelocity)) {
          bad = 1;
          h.ok = false;
          h.quantity = names[q];
          h.value = vals[q];
          h.x = cfg_.x0 + (mac_.slab.i0 + i + 0.5) * dx;  // channel coordinates
          h.reason = std::isfinite(vals[q]) ? core::kMaxVelocityReason : "not finite";
        }
    }
  int any = 0;
  MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, comm_);
  if (any && h.ok) {
    h.ok = false;
    h.quantity = "u";
    h.reason = std::string("not finite or ") + core::kMaxVelocityReason + " on another rank";
  }
  // A column whose material reaches the top row of the box: the free surface has met the lid,
  // so the flow is no longer the free-surface flow of the model (a deposit deeper than the
  // box is capped and its markers packed into the top cells: Setup II at 5 mm to 1.5 s in the
  // 0.15 m box held a wall column of 0.1525 m, mass kept, depth wrong). The depth is the
  // markers' (count times area over dx, every marker of the column), the same on all ranks
  // (gathered counts): half a cell below the top of the box is the limit, where the column's
  // surface enters the top row's upper half.
  const double limit = cfg_.grid.material_limit();
  if (h.ok && cfg_.free_surface && deepest_new_.second >= 0 && deepest_new_.first > limit) {
    h.ok = false;
    h.limit = true;
    h.quantity = "material depth";
    h.value = deepest_new_.first;
    h.x = cfg_.x0 + (deepest_new_.second + 0.5) * dx;
    h.reason = "the material of the column reaches the top of the 2D box (depth " +
               detail::gstr(deepest_new_.first) + " m against N-DAM->Height = " +
               detail::gstr(cfg_.grid.lz) + " m; allowed: at most Height - dz / 2 = " +
               detail::gstr(limit) +
               " m): raise N-DAM->Height (and Cells z with it)";
  }
  // The nonlinear pressure system: a Newton solve that did not converge stops the run (the
  // NOX stats are reduced over all ranks, so the decision is collective).
  if (h.ok && newton_failed_) {
    h.ok = false;
    const bool aa = cfg_.pressure_iteration == PressureIteration::Anderson;
    h.quantity = aa ? "pressure fixed point (Anderson)" : "pressure Newton (NOX)";
    h.value = newton_stats_.final_residual;
    h.x = newton_fail_cell_[0];
    std::ostringstream hist;
    for (double r : newton_stats_.residual_history) hist << (hist.tellp() > 0 ? " " : "") << r;
    h.reason = "the nonlinear pressure system did not converge: " + newton_stats_.reason +
               " (||R|| per " + (aa ? "Anderson" : "Newton") + " iteration: " + hist.str() + "; " +
               (aa ? std::string() : std::to_string(newton_stats_.krylov_iterations) + " GMRES iterations; ") +
               "largest mismatch |q - P(q)| = " + detail::gstr(newton_fail_cell_[2]) +
               " m^2/s^2 in the cell at x = " + detail::gstr(newton_fail_cell_[0]) +
               " m, z = " + detail::gstr(newton_fail_cell_[1]) + " m; see N-DAM->Pressure Newton: Absolute tolerance, Relative "
               "tolerance, Max Newton iterations, or 'Pressure coupling' = Lagged)";
  }
  // A linear solve far from its tolerance (kLinearSolveStopResidual) stops the run with a
  // diagnosis. The stats are the same on all ranks (Belos reductions), so the decision is
  // collective.
  if (h.ok) {
    for (const auto* st : {&mom_stats_, &p_stats_}) {
      const bool used = st == &p_stats_ || cfg_.momentum == Momentum::Implicit;
      if (used && !st->converged && !(st->residual <= kLinearSolveStopResidual)) {
        h.ok = false;
        h.quantity = st == &p_stats_ ? "pressure solve" : "momentum solve";
        h.value = st->residual;
        // a Krylov solve has a residual of the whole part, not of one place (it said "at x =
        // 0 m"; an independent run)
        h.where = "over the 2D part [" + detail::gstr(cfg_.x0) + ", " +
                  detail::gstr(cfg_.x0 + cfg_.grid.lx) + "] m";
        h.reason = "Belos did not converge (relative residual " +
                   std::to_string(st->residual) + " after " + std::to_string(st->iterations) +
                   " iterations; see the solver sublist's Tolerance, Max iterations, "
                   "Preconditioner)";
      }
    }
  }
  return h;
}

// The tentative state becomes the state at t^{n+1}: fields, markers and flags, then the
// free-surface conditions of the new flags on it (Empty cells p = 0, ghost faces, profiles).
void NdamSolver::accept() {
  if (cfg_.momentum == Momentum::Implicit && coulomb_walls()) friction_dt_ = friction_growth_dt();
  std::swap(u_, u_new_);
  std::swap(w_, w_new_);
  std::swap(p_, p_new_);
  std::swap(bed_stress_, bed_stress_new_);
  if (cfg_.free_surface) {
    const auto tm = Clock::now();
    std::swap(markers_, markers_new_);
    inflow_owed_ = inflow_owed_new_;
    inflow_held_ = inflow_held_new_;
    transfer_.in = marker_mass_new_.injected_area - marker_mass_.injected_area;
    transfer_.out = marker_mass_new_.removed_area - marker_mass_.removed_area;
    marker_mass_ = marker_mass_new_;
    // (the ghost-fluid surface's coefficients follow the column depths: every step)
    if (flags_new_ != mac_.flags || mac_.ghost_surface) flags_changed_ = true;
    std::swap(mac_.flags, flags_new_);
    std::swap(mac_.empty_mask, mask_new_);
    std::swap(mac_.depth, depth_new_);
    mac_.classify_surface_pressure();
    for (int i = 0; i < mac_.slab.nx_local; ++i) {
      const int top = mac_.top(mac_.slab.i0 + i);  // (above: all Empty)
      for (int k = 0; k < cfg_.grid.nz; ++k)
        if (k >= top || mac_.gflag(mac_.slab.i0 + i, k) == CellFlag::Empty) p_(i, k) = 0.0;
    }
    fill_scalar_ghosts(p_);
    t_ = t_new_;
    if (cfg_.inflow) inflow_now_ = cfg_.inflow(t_);
    fill_velocity_ghosts(u_, w_);
    update_profile_cache(true);  // the depths of the flag update of these markers
    stats_.step_markers += detail::seconds_since(tm);
  }
  stats_.accept_times();
  u_new_ = u_;
  w_new_ = w_;
  p_new_ = p_;
  t_ = t_new_;
  ++steps_;
  stats_.max_divergence = std::max(stats_.max_divergence, max_div_new_);
}

double NdamSolver::max_divergence() const { return max_abs_divergence(u_, w_); }

}  // namespace granflow::ndam
