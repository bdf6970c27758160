#pragma once
// N-DAM: the full two-dimensional incompressible viscoplastic model (Domnik et al. 2013,
// section 2) on a closed or x-periodic box [0, Lx] x [0, Lz]:
//
//   div u = 0,                                                              (1)
//   du/dt = div(sigma) + g,  sigma = -p 1 + 2 nu_eff D,  g = (g sin zeta, -g cos zeta),   (2, 3)
//   nu_eff from the Rheology module (eqs. 4-6).
//
// One time step is the projection method of NaSt2D in incremental form (docs/numerics.md):
//   predict_velocity   u* = u^n + dt (-(u.grad)u + g - grad p^n + div(2 nu_eff D(u)))
//                      the viscous stress explicit (u^n) or implicit (u*, nu_eff lagged at t^n);
//   solve_pressure     -L phi = -div(u*) / dt  (L: 5-point Laplacian with Neumann walls);
//   correct_velocity   u^{n+1} = u* - dt grad phi,  p^{n+1} = p^n + phi (- 2 nu_eff div u* when
//                      implicit: the rotational form, see docs/numerics.md).
// The pressure at t = 0 solves eq. (10) with the Neumann condition (14), so a fluid at rest
// starts in hydrostatic balance.
//
// With 'Free surface' (NdamConfig::free_surface) the box is a chute: the material is tracked by
// marker particles (MarkerSet), cells are Fluid/Surface/Empty, momentum is solved on faces
// between material cells, pressure unknowns are the Fluid cells (Surface: normal-stress
// Dirichlet value, Empty: p = 0), the silo gate injects at x = x0 and an open end removes
// markers. Walls of kind Coulomb apply the sliding law (11)-(13) as a Robin ghost value. See
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
#include "granflow/ndam/grid.hpp"
#include "granflow/ndam/markers.hpp"
#include "granflow/ndam/rheology.hpp"
#include "granflow/solvers/linear_system.hpp"
#include "granflow/solvers/nonlinear_system.hpp"

#include <mpi.h>

#include <Teuchos_ParameterList.hpp>

#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace granflow::ndam {

enum class Momentum { Explicit, Implicit };
/// How the pressure enters tau_y and the Coulomb law (13): at t^n (Lagged) or at t^{n+1}
/// (Nonlinear: the nonlinear pressure system solved by NOX in every step).
enum class PressureCoupling { Lagged, Nonlinear };
enum class Side : int { Left = 0, Right = 1, Bottom = 2, Top = 3 };
/// Coulomb: the sliding law (11)-(13) with c_F = tan(delta) (1 - exp(-m_c |u_t|)) (Bottom and
/// Right only; delta = 0 is free slip).
enum class WallKind { NoSlip, FreeSlip, MovingLid, Periodic, Coulomb };
/// Velocity profile over the opening of the silo gate (free-surface chute, left side).
///  Uniform: u = u_in over 0 <= z < h_in (plug flow out of the silo; the documented default).
///  CopyInterior: the shape of the first interior 2D column u(0, z) scaled to the mean u_in
///                (eq. 25, d/dx d/dz u = 0; used by the 2D side of a 1D-to-2D interface).
enum class InflowShape { Uniform, CopyInterior };
/// How the pressure of eq. (26), p = g cos(zeta)(h - z)(1 + K)/2, enters at the inflow side.
///  None:      not at all (a silo gate; the inflow column's pressure is solved like any other).
///  Dirichlet: the paper's literal reading: the material cells of the inflow column are
///             Dirichlet cells of the projection with that p, so continuity is not enforced
///             there (measured: the 2D flow behind a 1D-to-2D interface decelerates).
///  Rheology:  the inflow column stays in the projection (div u = 0, p solved); eq. (26) is the
///             pressure its yield stress tau_y = tau_c + tau_p p sees (the 1D side's pressure
///             at x_IF, where the 2D pressure is still adjusting to the injected state).
enum class InflowPressure { None, Dirichlet, Rheology };

/// Boundary condition of one side of the box. `velocity` is the tangential wall velocity of a
/// moving lid (u on bottom/top, w on left/right).
struct Wall {
  WallKind kind = WallKind::NoSlip;
  double velocity = 0.0;
};

/// Numerical parameters of the N-DAM ("N-DAM" sublist).
struct NdamConfig {
  Grid grid{64, 32, 1.0, 0.15};
  Momentum momentum = Momentum::Implicit;
  double cfl = 0.5;
  double gamma = 0.5;  ///< donor-cell weight of the convective terms (0: central, 1: upwind)
  std::array<Wall, 4> walls{};  ///< by Side
  /// Obstacle rectangles {x0, x1, z0, z1} [m]: cells whose centre lies inside are obstacles
  /// (rigid, no-slip surfaces).
  std::vector<std::array<double, 4>> obstacles;
  Teuchos::ParameterList momentum_solver, pressure_solver;
  PressureCoupling pressure_coupling = PressureCoupling::Lagged;
  Teuchos::ParameterList pressure_newton;  ///< "Pressure Newton": NonlinearSystem's list
  /// 'Pressure Newton failure' = Continue: an unconverged step keeps NOX's best iterate
  /// (counted in summary.json) instead of stopping the run.
  bool newton_failure_continue = false;

  // --- free-surface chute (issue 4) ----------------------------------------------------------
  /// Material tracked by markers: cells with markers are Fluid/Surface, the others Empty (p = 0).
  bool free_surface = false;
  int markers_per_cell = 4;  ///< n_x = n_z of the marker sub-lattice
  /// Initial layer z < initial_depth on initial_x0 <= x < initial_x1 (0: no initial material).
  double initial_depth = 0.0, initial_x0 = 0.0, initial_x1 = 1e300;
  /// Silo gate at x = x0 (left side): {h_in, u_in} at time t; empty function: no inflow.
  std::function<std::array<double, 2>(double t)> inflow;
  InflowShape inflow_shape = InflowShape::Uniform;
  /// How the pressure of eq. (26) enters on the inflow column (see InflowPressure).
  InflowPressure inflow_pressure = InflowPressure::None;
  double inflow_K = 1.0;  ///< earth pressure coefficient K of eq. (26)
  bool outflow_right = false;  ///< open outflow at x = x0 + L (else the Right wall)
  /// Open outflow: u continues beyond the last interior face with the lagged (t^n) gradient of
  /// the last two interior faces instead of zero gradient (the 2D side of a 2D-to-1D interface
  /// inside an accelerating flow; the channel's own open end keeps zero gradient).
  bool outflow_extrapolate = false;
  double m_c = 100.0;  ///< [s/m] regularisation of the Coulomb friction factor (12)
  double x0 = 0.0;     ///< grid origin along the slope [m] (2D subdomains of the coupled model)

  bool periodic_x() const { return walls[0].kind == WallKind::Periodic; }
  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();
  /// Reads a validated "N-DAM" list. `user` is the list as written (or null); the box length
  /// is the Channel's; `ranks` is checked against the columns (each rank needs >= 2 columns).
  static NdamConfig from_parameters(const Teuchos::ParameterList& validated,
                                    const Teuchos::ParameterList* user,
                                    const core::Channel& channel, int ranks);
};

/// Physical constants the N-DAM uses (passed, never global).
struct NdamPhysics {
  double gx = 0.0;    ///< g sin(zeta)
  double gz = -9.81;  ///< -g cos(zeta)
  double density = 1440.0;
  double tan_delta = 0.0;  ///< tan of the bed friction angle (Coulomb walls)
  static NdamPhysics from(const core::Material& m, const core::Channel& c);
};

class NdamSolver final : public core::Stepper {
 public:
  /// Builds the grid slab of this rank on `comm` (collective) with the fluid at rest and the
  /// pressure of eq. (10) (hydrostatic).
  NdamSolver(MPI_Comm comm, const NdamConfig& cfg, const Rheology& rheo, const NdamPhysics& phys);
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
  void write_fields(io::FieldWriter& w) const override;
  void save(io::Checkpoint& c) const override;
  void load(const io::Checkpoint& c) override;
  void report(nlohmann::json& stats) const override;

  // Inspection (tests, benchmark, the coupling of the next issue).
  const Grid& grid() const { return cfg_.grid; }
  const Slab& slab() const { return slab_; }
  const NdamConfig& config() const { return cfg_; }
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
  long long newton_solves() const { return newton_solves_; }
  /// Cell flag of global cell (gi, k).
  CellFlag flag(int gi, int k) const {
    return flags_[static_cast<std::size_t>(gi * cfg_.grid.nz + k)];
  }
  /// Largest nu_eff of the current state [m^2/s].
  double max_nu_eff() const;
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
  /// the cap on the velocity, see docs/numerics.md) is carried to the next steps.
  using InflowMass = std::function<std::optional<double>(double t, double dt)>;
  void set_inflow(std::function<std::array<double, 2>(double t)> provider, InflowShape shape,
                  InflowPressure pressure = InflowPressure::None, double K = 1.0,
                  InflowMass mass = nullptr);
  /// Inflow area not yet in the box as markers (collective): the carried mass of `mass` above
  /// plus the fractional marker accumulators of the gate. Injected area + this = the total of
  /// the `mass` provider (to round-off) when one is set.
  double inflow_pending() const;
  struct Transfer {
    double in = 0.0, out = 0.0;  ///< marker area [m^2] that entered at x0 / left at x1
  };
  /// Mass (area per unit width) through the two ends during the last accepted step.
  Transfer last_transfer() const { return transfer_; }
  const MarkerSet* markers() const { return markers_.get(); }
  /// Seconds spent in the last step's phases: "momentum", "pressure", "other".
  double last_seconds(const std::string& phase) const;

 private:
  struct Ref;  // a velocity sample as a linear function of the unknowns (see ndam_solver.cpp)
  enum Comp { U = 0, W = 1 };
  Ref u_ref(int i, int k) const;
  Ref w_ref(int i, int k) const;
  Ref ref(Comp c, int i, int k) const;
  Ref surface_face_ref(Comp c, int i, int k) const;
  long long p_gid(int gi, int k) const { return static_cast<long long>(gi) * cfg_.grid.nz + k; }
  bool fluid(int gi, int k) const;  // material cell (Fluid or Surface); false outside
  bool p_unknown(int gi, int k) const;  // pressure unknown: Fluid (Surface/Empty: Dirichlet)
  CellFlag gflag(int gi, int k) const;  // flag of global cell; Obstacle outside the box
  void assemble_pressure();
  void update_flags_from_markers();
  void surface_pressure(Field& target) const;
  void apply_free_surface(Field& u, Field& w) const;
  void boundary_faces(Field& u, Field& w) const;
  double inflow_face(int k) const;  // u(-1, k) of the gate (material velocity of the open rows)
  double inflow_p26(int k) const;   // eq. (26) at the centre of row k of the inflow column
  double outflow_slope(int k) const;  // lagged u difference of the last two faces (extrapolate)
  void update_profile_cache();
  bool u_unknown(int i, int k) const;  // u(i,k) an unknown: fluid on both sides, not a wall
  bool w_unknown(int i, int k) const;
  double nu_corner(int i, int k) const;
  template <class Emit> void viscous_u(int i, int k, Emit&& e) const;
  template <class Emit> void viscous_w(int i, int k, Emit&& e) const;
  double conv_u(int i, int k) const;
  double conv_w(int i, int k) const;

  void exchange(Field& f) const;
  void fill_velocity_ghosts(Field& u, Field& w) const;
  void fill_scalar_ghosts(Field& s) const;
  void update_viscosity(const Field& p_yield);
  void update_friction(const Field& p_yield);
  void project(double dt);  // predictor, projection, pressure update into *_new_ (timed)
  void project_at(const std::vector<double>& q, double dt);  // P(q): tau_y, (13) at q
  void solve_pressure_system(double dt);  // 'Nonlinear': NOX on R(q) = q - P(q)
  bool pressure_dependent() const;  // tau_p != 0 or a Coulomb side: the system is nonlinear
  void predict_velocity(double dt, Field& us, Field& ws);
  void solve_pressure(double dt, const Field& us, const Field& ws, Field& phi);
  void correct_velocity(double dt, const Field& phi, Field& us, Field& ws) const;
  void normalise_pressure(Field& p) const;
  void initial_pressure();
  double divergence(const Field& u, const Field& w, int i, int k) const;
  std::vector<double> gather_cells(const Field& f, bool z_major) const;
  std::vector<double> gather_columns(const std::vector<double>& local) const;
  void scatter_cells(const std::vector<double>& global, Field& f) const;

  MPI_Comm comm_;
  NdamConfig cfg_;
  Rheology rheo_;
  NdamPhysics phys_;
  Slab slab_;
  int left_ = 0, right_ = 0;  // neighbour ranks (MPI_PROC_NULL at walls)

  Field u_, w_, p_, nu_;        // current state (ghosts filled)
  Field nu_rot_;                 // nu_eff(u^n, p^n) of the rotational pressure update
  Field u_new_, w_new_, p_new_;  // tentative state of step()
  Field u_star_, w_star_;        // u* of the last step (rotational pressure update)
  std::vector<CellFlag> flags_;  // all cells of the box (every rank), gi * nz + k
  std::vector<std::uint8_t> empty_mask_;  // empty_side bits of Surface cells (global)
  std::unique_ptr<MarkerSet> markers_;
  Field normD_;                  // ||D|| of the cells (free surface: surface stress)
  Field p_dir_;                  // Dirichlet phi of non-unknown cells in solve_pressure
  std::vector<double> bed_a_;    // Coulomb ghost factor of u(i,-1), local columns + G
  std::vector<double> wall_a_;   // Coulomb ghost factor of w(nx, k) at the right wall
  std::array<double, 2> inflow_now_{0.0, 0.0};  // {h_in, u_in} of the current step
  InflowMass inflow_mass_;                        // exact mass of a step (1D-to-2D), optional
  double inflow_owed_ = 0.0, inflow_owed_new_ = 0.0;  // carried inflow mass [m^2]
  std::vector<double> col_h_, col_u_, col_w_;  // column states of the whole box (every rank)
  Transfer transfer_;
  double mass0_ = 0.0;
  MarkerMass marker_mass_;  // of the current state (collective mass() cached at accept)
  double sec_mark_ = 0.0;
  bool flags_changed_ = true;
  bool has_obstacles_ = false;
  long long pin_ = 0;        // pressure cell pinned to phi = 0 (the first fluid cell)
  long long fluid_cells_ = 0;
  double t_ = 0.0, t_new_ = 0.0;
  long steps_ = 0;

  std::unique_ptr<solvers::LinearSystem> pressure_, momentum_;
  // Nonlinear pressure coupling: the NOX solver (built at the first step that needs it), the
  // time step of the current solve, the trial pressure and the last evaluated q.
  std::unique_ptr<solvers::NonlinearSystem> newton_;
  double newton_dt_ = 0.0, newton_scale_ = 1.0;
  Field p_trial_;
  std::vector<double> q_evaluated_;
  solvers::NonlinearStats newton_stats_;
  bool newton_failed_ = false;
  long long newton_solves_ = 0, newton_iters_ = 0, newton_krylov_ = 0, newton_evals_ = 0;
  int newton_max_iters_ = 0;
  std::array<double, 3> newton_fail_cell_{0.0, 0.0, 0.0};  // x, z, |q - P(q)| of a failure
  long long newton_continued_ = 0;  // unconverged steps kept ('Pressure Newton failure')
  double newton_continued_worst_ = 0.0;
  double newton_worst_residual_ = 0.0, newton_seconds_ = 0.0;
  double momentum_dt_ = -1.0;  // dt of the assembled momentum matrix (reused when unchanged)
  solvers::SolveStats mom_stats_, p_stats_;
  double sec_mom_ = 0, sec_p_ = 0, sec_other_ = 0;
  // cumulative phase seconds of the accepted steps (summary.json)
  double total_mom_ = 0, total_p_ = 0, total_other_ = 0, total_mark_ = 0;

  // statistics for summary.json
  double dt_min_ = 0.0, dt_max_ = 0.0, max_div_ = 0.0, max_div_new_ = 0.0;
  long long p_iters_ = 0, m_iters_ = 0, p_solves_ = 0, m_solves_ = 0, failed_solves_ = 0;
  double worst_p_res_ = 0.0, worst_m_res_ = 0.0;
};

}  // namespace granflow::ndam
