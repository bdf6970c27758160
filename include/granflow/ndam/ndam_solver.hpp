#pragma once
// N-DAM: the full two-dimensional incompressible viscoplastic model (Domnik et al. 2013,
// section 2) on a closed or x-periodic box [0, Lx] x [0, Lz]:
//
//   div u = 0,                                                              (1)
//   du/dt = div(sigma) + g,  sigma = -p 1 + 2 nu_eff D,  g = (g sin zeta, -g cos zeta),   (2, 3)
//   nu_eff from the Rheology module (eqs. 4-6).
//
// One time step is the projection method of NaSt2D in incremental form (docs/numerics.md);
// step() reads as this box, each line in its own file of src/ndam/:
//   gate_state         the inflow of the step, h_in and u_in (inflow.cpp, eqs. 24-27)
//   update_viscosity   nu_eff(u^n, p^n) (viscosity.cpp, eqs. 4-6) and the Coulomb ghost
//                      factors of the sliding law (boundaries.cpp, eqs. 11-13; the momentum
//                      step iterates them to the step's mean friction factor)
//   surface_conditions Dirichlet values of the Surface/Empty cells (free_surface.cpp)
//   predict_velocity   u* = u^n + dt (-(u.grad)u + g - grad p^n + div(2 nu_eff D(u)))
//                      the viscous stress explicit (u^n) or implicit (u*, nu_eff lagged at t^n)
//                      (momentum.cpp, eqs. 8-9)
//   solve_pressure     -L phi = -div(u*) / dt  (L: 5-point Laplacian with Neumann walls)
//                      (projection.cpp, eqs. 10, 14)
//   correct_velocity   u^{n+1} = u* - dt grad phi,  p^{n+1} = p^n + phi (- 2 nu_eff div u* when
//                      implicit: the rotational form, see docs/numerics.md) (projection.cpp)
//   or, 'Pressure coupling' = Nonlinear, the three above as the fixed point of the nonlinear
//                      pressure system solved by NOX (pressure_system.cpp, eqs. 10 + 13 + 14)
//   advect_markers     markers move with Heun's method in u^n and u^{n+1}, the gate injects
//                      (free_surface.cpp, inflow.cpp)
//   update_flags       Fluid/Surface/Empty from the markers (free_surface.cpp, mac_layout.cpp)
// The grid and its unknowns are the MacLayout (mac_layout.hpp); output and checkpoints are
// ndam_output.cpp.
// The pressure at t = 0 solves eq. (10) with the Neumann condition (14), so a fluid at rest
// starts in hydrostatic balance.
//
// With 'Free surface' (NdamConfig::free_surface) the box is a chute: the material is tracked by
// marker particles (MarkerSet), cells are Fluid/Surface/Empty, momentum is solved on faces
// between material cells, pressure unknowns are the Fluid cells (Surface: normal-stress
// Dirichlet value, Empty: p = 0; with 'Surface pressure' = Ghost fluid the Surface cells below
// the surface are unknowns too, with p = 0 imposed at the surface by a ghost value and their
// faces to Empty cells momentum unknowns), the silo gate injects at x = x0 and an open end
// removes markers. Walls of kind Coulomb apply the sliding law (11)-(13) as a Robin ghost value. See
// docs/numerics.md, "2D granular chute".
//
// Pressure coupling (the yield stress tau_y = tau_c + tau_p p and the Coulomb law (13) depend on
// p): 'Lagged' evaluates them with p^n (one predictor-projection per step); 'Nonlinear' solves
// the system (10)+(13)+(14) with tau_y and (13) at p^{n+1}: one step is the fixed-point map
// p^{n+1} = P(q) (predictor and projection with nu_eff and the friction evaluated at q), and
// NOX's Newton-Krylov method (Jacobian-free, GMRES) solves R(q) = q - P(q) = 0. See
// docs/numerics.md, "Nonlinear pressure coupling".
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/core/stepper.hpp"
#include "granflow/markers/markers.hpp"
#include "granflow/ndam/config.hpp"
#include "granflow/ndam/grid.hpp"
#include "granflow/ndam/mac_layout.hpp"
#include "granflow/ndam/ndam_state.hpp"
#include "granflow/ndam/rheology.hpp"
#include "granflow/ndam/statistics.hpp"
#include "granflow/solvers/linear_system.hpp"
#include "granflow/solvers/nonlinear_system.hpp"

#include <mpi.h>

#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace granflow::ndam {

class NdamSolver final : public core::Stepper {
 public:
  /// Builds the grid slab of this rank on `comm` (collective) with the fluid at rest and the
  /// pressure of eq. (10) (hydrostatic).
  NdamSolver(MPI_Comm comm, const NdamConfig& cfg, const Rheology& rheo, const NdamPhysics& phys);
  /// Builds the box from a given state (collective): a restart, or a subdomain rebuilt for a new
  /// extent; `state` must have the grid of `cfg` (InputError otherwise). The initial layer of
  /// `cfg` is not seeded. `stats` continues the run's counters.
  NdamSolver(MPI_Comm comm, const NdamConfig& cfg, const Rheology& rheo, const NdamPhysics& phys,
             const NdamState& state, const NdamStatistics& stats = {});
  ~NdamSolver() override;

  // Stepper
  std::string model_name() const override { return "N-DAM"; }
  double time() const override { return t_; }
  long steps() const override { return steps_; }
  double stable_dt() const override;
  void step(double dt) override;
  core::Health check() const override;
  void accept() override;
  core::Profile profile() const override;
  core::MassBalance mass_balance() const override;
  core::Speed max_speed() const override;
  std::string dt_limit() const override;
  /// What set the last stable_dt() (a short phrase: "advection, dx / |u|", "Coulomb friction
  /// start-up", ...), for the coupled model's tally of what sets the common step.
  const char* dt_cause() const { return dt_cause_; }
  void write_fields(io::FieldWriter& w) const override;
  void save(io::Checkpoint& c) const override;
  void load(const io::Checkpoint& c) override;
  void restart_point() override;
  /// Several ranks with 'Load balance' = Material: every kBalanceInterval steps, the x-slabs
  /// are split anew by the work of the columns when a rank holds more than 10 % above the mean
  /// (the box is rebuilt from its state; load_balance.cpp). Returns whether it did.
  bool adapt() override;
  void report(nlohmann::json& stats) const override;
  /// A free-surface chute that ends at a rigid wall (not periodic, no open outflow).
  bool end_wall() const override;
  /// The load on that wall from the wall column (cell nx - 1): the pressure extrapolated from
  /// the cell centres to the wall by the downslope gravity over dx/2 (as the Coulomb law of the
  /// end wall takes it, boundaries.cpp), integrated over the column's material cells; the
  /// normal viscous stress 2 nu_eff u*_x of those cells (u*: the velocity of the last step's
  /// viscous solve); the shear stress the wall's ghost velocities apply (the Coulomb law (13)
  /// on a Coulomb wall) at its w faces; the bottom cell's pressure. See docs/numerics.md,
  /// "Wall load". Collective.
  std::optional<core::WallLoad> wall_load() const override;

  // Inspection (tests, benchmark, the coupling).
  const Grid& grid() const { return cfg_.grid; }
  const Slab& slab() const { return mac_.slab; }
  const NdamConfig& config() const { return cfg_; }
  /// The run's counters and timers, with the preconditioner work of this box's linear systems
  /// folded in (what a box rebuilt for a new extent continues from).
  NdamStatistics statistics() const;
  /// The state the next step reads (collective).
  NdamState export_state() const;
  /// Makes u, w divergence-free in the pressure unknowns' cells by one projection that leaves p
  /// as it is (collective): for a state assembled from converted columns (coupling::rebuild),
  /// whose divergence the next step's projection would otherwise turn into a pressure of
  /// div / dt and keep in p (the incremental update). Returns the largest |div u| before [1/s].
  double remove_divergence();
  /// Global fields gathered on every rank, index gi * nz + k: u on the right face of cell
  /// (gi, k), w on its top face, p and nu_eff at its centre.
  std::vector<double> gather_u() const;
  std::vector<double> gather_w() const;
  std::vector<double> gather_p() const;
  std::vector<double> gather_nu() const;
  /// max |div u| over the cells of the current state [1/s].
  double max_divergence() const;
  /// Statistics of the last step's linear solves (momentum is empty when explicit).
  const solvers::SolveStats& last_momentum_solve() const { return mom_stats_; }
  const solvers::SolveStats& last_pressure_solve() const { return p_stats_; }
  /// The last step's Newton solve of the nonlinear pressure system ('Pressure coupling' =
  /// Nonlinear and a pressure-dependent system; otherwise default-constructed).
  const solvers::NonlinearStats& last_newton_solve() const { return newton_stats_; }
  /// Newton solves so far (steps that solved the nonlinear pressure system).
  long long newton_solves() const { return stats_.newton_solves; }
  /// Cell flag of global cell (gi, k).
  CellFlag flag(int gi, int k) const {
    return mac_.flags[static_cast<std::size_t>(gi * cfg_.grid.nz + k)];
  }
  /// The open sides of the box for ndam::enclosed_voids (the holes of the material): an
  /// outflow's every row, and the rows above the 1D layer at a 1D-to-2D interface, where the
  /// atmosphere lies over the 1D layer; a wall, the gate and the rows of an opening are closed.
  VoidSides void_sides() const;
  /// Largest nu_eff of the current state [m^2/s].
  double max_nu_eff() const;
  /// The normal stress N = p_b + 2 nu_eff du/dx (eq. 13, divided by the density [m^2/s^2]) that
  /// the Coulomb law of the bed used in the last friction update, at the bed faces
  /// u(i, 0), i = 0 .. nx_local - 1, of this rank's slab (0 where no material is above the face
  /// or the bed is not Coulomb).
  std::vector<double> bed_normal_stress() const;
  /// The fastest long surface wave of the current state: sqrt(g cos(zeta) h) [m/s] of the
  /// deepest column (free surface only; 0 without material), that column's global index and h.
  struct SurfaceWave {
    double speed = 0.0;
    std::size_t column = 0;
    double h = 0.0;
  };
  SurfaceWave surface_wave() const;
  // --- free-surface chute and coupling API ---------------------------------------------------
  struct ColumnState {
    double h = 0.0, u_mean = 0.0;
  };
  /// {h, u_mean} (eq. 21, from the markers) of the column containing the slope coordinate x
  /// (x clamped into the box; the grid origin is config().x0). Rank-local, no communication:
  /// the column states are gathered on every rank at each accept().
  ColumnState column_state(double x) const;
  /// Replaces the inflow of the left side after construction: {h, u_mean} at time t, the
  /// profile shape, and how the pressure of eq. (26) with coefficient K enters (InflowPressure).
  /// `mass` (optional): the area [m^2 per unit width] the inflow must let in during the step
  /// [t, t + dt], when known (a 1D-to-2D interface: exactly what the DAM upstream lets out in
  /// the same step). The step's inflow velocity is then that mass / (dt h) instead of the
  /// provider's u_mean; what cannot enter in a step (a negative or dry-side transfer, or beyond
  /// the cap on the velocity, see docs/numerics.md) is carried to the next steps. `held`: the
  /// part of `mass` that does not set this step's velocity but waits for the next step (the
  /// DAM's dt-independent averaging term, DamSolver::PendingStep::out_flux).
  struct InflowStepMass {
    double mass = 0.0, held = 0.0;
  };
  using InflowMass = std::function<std::optional<InflowStepMass>(double t, double dt)>;
  void set_inflow(std::function<std::array<double, 2>(double t)> provider, InflowShape shape,
                  InflowPressure pressure = InflowPressure::None, double K = 1.0,
                  InflowMass mass = nullptr);
  /// Inflow area not yet in the box as markers (collective): the carried mass of `mass` above
  /// (what a step could not take, and the DAM ledger's averaging terms still held back) plus
  /// the fractional marker accumulators of the gate. Injected area + this = the total of
  /// the `mass` provider (to round-off) when one is set.
  double inflow_pending() const;
  /// The inflow faces u(x0, z) of the current state, row k = 0 .. nz - 1 (0 above the
  /// opening): the gate's or the 1D-to-2D interface's velocity of each row, the eq. (25) shape
  /// where it is copied (collective; every rank gets the values of the owner of column 0).
  std::vector<double> inflow_faces() const;
  struct Transfer {
    double in = 0.0, out = 0.0;  ///< marker area [m^2] that entered at x0 / left at x1
  };
  /// Mass (area per unit width) through the two ends during the last accepted step.
  Transfer last_transfer() const { return transfer_; }
  const MarkerSet* markers() const { return markers_.get(); }
  /// Seconds spent in the last step's phases: "momentum", "pressure", "markers", "other".
  double last_seconds(const std::string& phase) const;

  /// Internal to the step files: a velocity sample as a linear function of the unknowns
  /// (defined in src/ndam/stencil.hpp), and the velocity components.
  struct Ref;
  enum Comp { U = 0, W = 1 };

 private:
  NdamSolver(MPI_Comm comm, const NdamConfig& cfg, const Rheology& rheo, const NdamPhysics& phys,
             const NdamState* state, const NdamStatistics& stats);
  void setup();                              // layout, fields, markers, linear systems
  void rest_state();                         // the initial layer at rest, eq. (10) pressure
  void check_obstacles_connected() const;    // one connected fluid region (input check)
  void import_state(const NdamState& s);     // the given state (restart, rebuilt box)
  // --- load_balance.cpp: x-slabs by the work of the columns ----------------------------------
  std::vector<double> column_work() const;                 // every rank, from the flags
  std::vector<int> balanced_starts(const std::vector<double>& work) const;
  void rebuild_slabs(const std::vector<int>& starts);      // the same state on other slabs
  void relayout(const std::vector<int>& starts);           // empty box on the slabs `starts`
  // --- boundaries.cpp: walls, moving lid, Coulomb slip ghosts, friction factors, ghosts -----
  Ref u_ref(int i, int k) const;
  Ref w_ref(int i, int k) const;
  Ref ref(Comp c, int i, int k) const;
  void fill_velocity_ghosts(Field& u, Field& w, bool surface_rules = true) const;
  void boundary_faces(Field& u, Field& w) const;
  void fill_scalar_ghosts(Field& s) const;
  void update_friction(const Field& p_yield);  // Coulomb ghosts: tangent of (12) at u^n
  void record_bed_stress(const Field& phi);  // the bed cells' -sigma_zz of the step's balance
  double relinearise_friction(const Field& us, const Field& ws,  // Newton on the friction
                              const std::function<bool(double, double, double)>& iterate,
                              bool& relinearised);
  void exchange_bed_factors();
  // --- inflow.cpp: the silo gate and the 1D-to-2D interface (eqs. 24-27) -------------------
  void gate_state(double dt);
  double inflow_face(int k) const;  // u(-1, k) of the gate (material velocity of the open rows)
  double inflow_p26(int k) const;   // eq. (26) at the centre of row k of the inflow column
  double outflow_slope(int k) const;  // lagged u difference of the last two faces (extrapolate)
  void inject_markers(double dt, MarkerSet& markers) const;
  // --- free_surface.cpp: markers, flags, surface pressure and velocity conditions ----------
  Ref surface_face_ref(Comp c, int i, int k) const;
  void surface_conditions();
  void surface_pressure(Field& target) const;
  /// 2 nu_s n.D.n of Surface cell (i, k) (NaSt2D's normal-stress condition, lagged); 0 otherwise.
  double surface_viscous_stress(int i, int k) const;
  /// The normal traction that p = 0 at the surface (implicit scheme) puts on local column i's
  /// top and so on its bed: minus the top Surface cell's surface_viscous_stress, signed
  /// (positive where the surface extends), limited to the column's weight either way; 0
  /// without such a surface.
  double surface_traction_at_bed(int i) const;
  /// The surface tractions t (one per global column) as the bed face right of global column gi
  /// carries them: filtered through the layer's depth (1 / cosh(k h)), then only the unloading
  /// part, at most the face's weight.
  double bed_surface_traction(int gi, const std::vector<double>& t) const;
  /// The free surface's viscous step limit K min(dx, dz)^2 / nu ('Viscous surface number');
  /// infinite where it does not apply (explicit momentum, no free surface, K = 0 or nu = 0).
  double viscous_surface_dt() const;
  /// The free surface inside global cell (gi, k) (wrapped when periodic): the column's marker
  /// depth clamped into [k dz, (k + 1) dz] for a Surface cell whose top side is empty; -1 for
  /// every other cell (or before the column depths exist).
  double surface_height(int gi, int k) const;
  /// The pressure that sets the bed's normal stress under cell (i, k): p, or for a Surface cell
  /// under material (its top side not empty, the cell above a material cell) the hydrostatic
  /// pressure of the column's material above its centre, if that is larger.
  double loaded_pressure(int i, int k, double p) const;
  /// The marker depth of global column gi (wrapped when periodic) that the free surface's
  /// pressure, the loaded bed and the full cells' weight take: col_h_, or col_hs_ with
  /// 'Full cell and weight'; col_h_ must exist.
  double column_depth(int gi) const;
  /// 'Surface cell mass' = Full cell and weight: the height of global column gi's full cells
  /// above its marker depth, H - h with H the top of the material cells that stand on the bed
  /// without a gap; `top` (if given) gets the highest such cell (-1: the bottom cell is not
  /// material). 0 for the other options, a column without material on the bed, or before the
  /// column depths exist.
  double full_cell_excess(int gi, int* top = nullptr) const;
  /// The highest cell of global column gi's material stack standing on the bed without a gap;
  /// -1 when the bottom cell is not material.
  int bed_stack_top(int gi) const;
  void apply_free_surface(Field& u, Field& w) const;
  void advect_markers(double dt);
  /// Flags of markers m and every column's material depth [m] (marker count times marker
  /// area over dx); `deepest` (if given) gets the deepest column's depth and its global column.
  void update_flags(const MarkerSet& m, std::vector<CellFlag>& flags,
                    std::vector<std::uint8_t>& mask, std::vector<double>& depth,
                    std::pair<double, int>* deepest = nullptr) const;
  /// The same from the gathered marker counts of the whole box (gi * nz + k) and the area of
  /// one marker.
  void update_flags(const std::vector<double>& counts, double marker_area,
                    std::vector<CellFlag>& flags, std::vector<std::uint8_t>& mask,
                    std::vector<double>& depth, std::pair<double, int>* deepest) const;
  /// Moves a marker into every enclosed void cell of m that has a neighbour (or, failing that,
  /// a cell of the second ring) with two or more (collective); returns the markers moved.
  /// When it moved none, `counts` (if given) gets the gathered marker counts of m it computed
  /// (the flags of m follow from them), else is cleared.
  long long fill_marker_voids(MarkerSet& m, std::vector<double>* counts = nullptr) const;
  /// The difference of p (ghosts filled) across face (c, i, k), the second cell's value minus
  /// the first's (divided by the spacing: the gradient); on a ghost face of the ghost-fluid
  /// surface the Empty cell's value is the ghost -p (1 - theta) / theta of p = 0 at the
  /// surface, theta of the spacing from the unknown's centre.
  double pressure_difference(const Field& p, Comp c, int i, int k) const;
  /// The column profiles of the current markers (col_h_, col_u_, col_w_; collective); with
  /// `flag_depths` the depths come from mac_.depth, the flag update's count of these markers.
  void update_profile_cache(bool flag_depths = false);
  // --- viscosity.cpp (eqs. 4-6) ---------------------------------------------------------------
  void update_viscosity(const Field& p_yield);
  // --- momentum.cpp: the predictor (eqs. 8-9) ---------------------------------------------------
  double nu_corner(int i, int k) const;
  double nu_normal(int i, int k) const;
  template <class Emit> void viscous_u(int i, int k, Emit&& e) const;
  template <class Emit> void viscous_w(int i, int k, Emit&& e) const;
  bool surface_upwind(int i1, int k1, int i2, int k2) const;
  /// Does a cell of global columns [g0, g1] and rows [k0, k1] have a flag with is(flag)?
  /// (gflag answers outside the box too: Obstacle, or the periodic image.)
  template <class Is> bool any_flag(int g0, int g1, int k0, int k1, Is&& is) const {
    for (int gi = g0; gi <= g1; ++gi)
      for (int k = k0; k <= k1; ++k)
        if (is(mac_.gflag(gi, k))) return true;
    return false;
  }
  double filling_divergence(int i, int k) const;
  double conv_u(int i, int k) const;
  double conv_w(int i, int k) const;
  void explicit_force(bool with_pressure, Field& fu, Field& fw) const;
  void predict_velocity(double dt, Field& us, Field& ws);
  void fall_droplets(double dt, Field& us, Field& ws) const;  // Surface cells empty all round
  // --- projection.cpp: the pressure projection (eqs. 10, 14) ----------------------------------
  void assemble_pressure();
  void assemble_pressure_if_flags_changed();  // the matrix of the current flags
  /// The farthest a pressure unknown lies from a Dirichlet cell, in cells (projection.cpp):
  /// the stiffness of the pressure preconditioner switch; kUnbounded without one.
  double dirichlet_distance() const;
  static constexpr double kUnbounded = 1e300;
  void project(double dt);  // predictor, projection, pressure update into *_new_ (timed)
  void solve_pressure(double dt, const Field& us, const Field& ws, Field& phi);
  void correct_velocity(double dt, const Field& phi, Field& us, Field& ws) const;
  double normalise_pressure(Field& p) const;  // returns the constant it took off
  void initial_pressure();
  double divergence(const Field& u, const Field& w, int i, int k) const;
  bool rotational_cell(int i, int k) const;  // the rotational pressure update acts here
  double rotational_weight(int i, int k, double dt) const;  // its chi (projection.cpp)
  double max_abs_divergence(const Field& u, const Field& w) const;  // collective
  // --- pressure_system.cpp: the nonlinear pressure system (NOX) --------------------------------
  void project_at(const std::vector<double>& q, double dt);  // P(q): tau_y, (13) at q
  void solve_pressure_system(double dt);  // 'Nonlinear': the root of R(q) = q - P(q)
  // ends what project_at keeps from a solve's first evaluation (its clamps, the held momentum
  // preconditioner): before a solve and after it, so that no step inherits them
  void release_first_evaluation();
  // 'Pressure iteration' = Anderson fixed point: q <- P(q) with Anderson mixing
  solvers::NonlinearStats anderson_fixed_point(std::vector<double>& q, double dt);
  bool pressure_dependent() const;  // tau_p != 0 or a Coulomb side: the system is nonlinear
  bool coulomb_walls() const;       // a Coulomb bed or end wall

  MPI_Comm comm_;
  NdamConfig cfg_;
  Rheology rheo_;
  NdamPhysics phys_;
  MacLayout mac_;  // grid, slab, flags, unknowns, halo exchange
  std::vector<int> slab_starts_;  // first column of each rank (empty: the equal split)

  // state at t^n (ghosts filled) and the tentative state of step()
  Field u_, w_, p_, nu_;
  Field nu_rot_;                 // nu_eff(u^n, p^n) of the rotational pressure update
  Field u_new_, w_new_, p_new_;
  Field u_star_, w_star_;        // u* of the last step (rotational pressure update, wall load)
  Field normD_;                  // ||D|| of the cells (free surface: surface stress)
  Field p_dir_;                  // Dirichlet phi of non-unknown cells in solve_pressure
  double t_ = 0.0, t_new_ = 0.0;
  long steps_ = 0;

  // free surface: the markers at t^n, the tentative markers and flags of step()
  std::unique_ptr<MarkerSet> markers_, markers_new_;
  std::vector<CellFlag> flags_new_;
  std::vector<std::uint8_t> mask_new_;
  std::vector<double> depth_new_;  // column depths of the tentative markers
  std::pair<double, int> deepest_new_{0.0, -1};  // deepest column of the tentative markers
  MarkerMass marker_mass_, marker_mass_new_;  // of the current / tentative markers
  double mass0_ = 0.0;
  std::vector<double> col_h_, col_u_, col_w_;  // column states of the whole box (every rank)
  // 'Full cell and weight': the columns' depths with every marker shared between the two
  // columns nearest to it (cloud in cell), the depth the surface pressure and the weight take
  // (column_depth); empty otherwise (column_depth then takes col_h_)
  std::vector<double> col_hs_;
  Transfer transfer_;
  bool flags_changed_ = true;
  bool has_obstacles_ = false;

  // boundaries: the Coulomb ghosts u(i,-1) = a u(i,0) + b (local columns + G) and
  // w(nx, k) = a w(nx-1, k) + b; q = dz tan(delta) N / nu_b of each face (dx ... at the wall;
  // 0: no friction there) and whether its ghost is clamped to sticking (update_friction)
  std::vector<double> bed_a_, bed_b_, wall_a_, wall_b_, bed_q_, wall_q_, bed_n_;
  std::vector<std::uint8_t> bed_stuck_, wall_stuck_;
  // The nonlinear pressure system keeps the no-slip clamps of its first evaluation (q = p^n,
  // the lagged step) in its later ones: a clamp decided anew at each trial pressure q makes
  // P(q) jump where a face's drag crosses the no-slip one (the ghost's b drops to 0), and the
  // fixed point then cycles (Setup II at 5 mm stopped at 0.624 s, the wall-bottom cell's
  // mismatch changing sign with the wall face's clamp). stuck_frozen_ is true inside a solve
  // once its first evaluation is done; *_stuck_first_ are that evaluation's clamps.
  bool stuck_frozen_ = false;
  std::vector<std::uint8_t> bed_stuck_first_, wall_stuck_first_;
  // The same system's later evaluations start the step's friction Newton where the first
  // evaluation left it (update_friction): the factors linearised about its solution at each
  // Coulomb face (*_v_first_: u(i, 0) of the owned columns, w(nx - 1, k) at the end wall), and
  // Newton taken iff the first evaluation took it (friction_newton_first_), so that P(q) does
  // not switch between the tangent and Newton from one trial pressure to the next.
  bool friction_newton_first_ = false;
  std::vector<double> bed_v_first_, wall_v_first_;
  // -sigma_zz of each bottom cell in the vertical balance that the last accepted step solved,
  // P - 2 nu_eff w*_z (record_bed_stress), the bed's normal stress (13) for the next step's
  // friction; NaN where the cell was not a pressure unknown (the state at t^n; *_new_: the
  // tentative step's)
  Field bed_stress_, bed_stress_new_;
  bool friction_warm_start() const;  // inside a solve, after a first evaluation that took Newton
  // dt over which the friction factor of the last step grew by 1 (stable_dt; <= 0: no limit)
  double friction_dt_ = -1.0;
  mutable const char* dt_cause_ = "";  // set by stable_dt() (a string literal)
  double friction_growth_dt() const;  // that of the tentative step (collective)

  // the gate / 1D-to-2D inflow
  std::array<double, 2> inflow_now_{0.0, 0.0};  // {h_in, u_in} of the current step
  InflowMass inflow_mass_;                        // exact mass of a step (1D-to-2D), optional
  double inflow_owed_ = 0.0, inflow_owed_new_ = 0.0;  // carried inflow mass [m^2]
  // held pool (gate_state): the DAM ledger's averaging terms and a move's carried mass not yet
  // let in, released at the rate the flow crosses one 2D cell so that they do not beat the
  // inflow step by step [m^2]
  double inflow_held_ = 0.0, inflow_held_new_ = 0.0;

  // projection
  long long pin_ = 0;        // pressure cell pinned to phi = 0 (the first fluid cell)
  long long fluid_cells_ = 0;
  mutable std::vector<int> dirichlet_dist_, dirichlet_queue_;  // dirichlet_distance's work space
  std::vector<double> marker_counts_new_;  // gathered counts of the tentative markers, if known
  std::unique_ptr<solvers::LinearSystem> pressure_, momentum_;
  double momentum_dt_ = -1.0;  // dt of the assembled momentum matrix (reused when unchanged)
  // the momentum solve's right-hand side and solution, kept between steps (each step sets
  // every entry; a fresh 2 nx nz vector per step was zeroed for nothing)
  std::vector<double> mom_rhs_, mom_x_;
  std::vector<int> mom_kend_;  // per local column: the first row of its Empty region
  // the momentum rows that sample a Coulomb ghost (the friction's re-solves add only these)
  struct FaceRow {
    int i, k;
    Comp c;
  };
  std::vector<FaceRow> friction_rows_;
  solvers::SolveStats mom_stats_, p_stats_;
  double max_div_new_ = 0.0;   // max |div u| of the tentative state

  // Nonlinear pressure coupling: the NOX solver (built at the first step that needs it), the
  // time step of the current solve, the trial pressure and the last evaluated q.
  std::unique_ptr<solvers::NonlinearSystem> newton_;
  double newton_dt_ = 0.0, newton_scale_ = 1.0;
  Field p_trial_;
  std::vector<double> q_evaluated_;
  // div u* of the solve's first evaluation (q = p^n): the rotational correction's predictor
  std::vector<double> div_lagged_;
  solvers::NonlinearStats newton_stats_;
  bool newton_failed_ = false;
  std::array<double, 3> newton_fail_cell_{0.0, 0.0, 0.0};  // x, z, |q - P(q)| of a failure

  NdamStatistics stats_;  // counters and timers of the run
};

}  // namespace granflow::ndam
