#pragma once
// DAM: the one-dimensional depth-averaged granular flow model (Domnik et al. 2013, section 3;
// Savage-Hutter on a plane):
//
//   h_t + (h u)_x = 0,                                                      (15)
//   (h u)_t + (h u^2 + beta h^2 / 2)_x = s h,                               (16)
//   s = g cos(zeta) (tan(zeta) - sgn(u) tan(delta)),   beta = g K cos(zeta),
//   K_act/pas = 2 sec^2(phi) (1 -/+ sqrt(1 - cos^2(phi) sec^2(delta))) - 1  (active if u_x > 0).
//
// Numerics: the second-order non-oscillatory central (NOC, Nessyahu-Tadmor) scheme on a
// time-staggered grid. Step n -> n+1 moves the cell centres by dx/2: the primary grid ("A") has
// N cells with centres x0 + (j + 1/2) dx; the staggered grid ("B") has N + 1 cells centred on
// x0 + j dx whose two end cells straddle the channel ends and count half in the mass. Slopes are
// either minmod-limited (TVD) or, in the paper's limiter-free variant, Beam-Warming (one-sided
// upwind differences). Bed friction is applied so that it opposes the motion and never reverses
// it: material decelerates, stops and stays where |driving force| <= friction for some earth
// pressure between K_act and K_pas. A prescribed inflow is a cell face of both grids and lets in
// exactly the flux of its state. See docs/numerics.md for the derivation of each block.
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/core/stepper.hpp"

#include <Teuchos_ParameterList.hpp>

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace granflow::dam {

enum class Scheme { Minmod, BeamWarming };
/// Time stepping: the paper's staggered NOC scheme (Nessyahu-Tadmor), or the semi-discrete
/// central scheme of Kurganov & Tadmor (2000) with Heun's method on the primary grid only.
enum class TimeStepping { Staggered, SemiDiscrete };
enum class EarthPressure { SavageHutter, Active, Passive, Isotropic };
/// The names of the "DAM" list's 'Scheme' and 'Earth pressure' values.
inline const char* to_string(Scheme s) { return s == Scheme::Minmod ? "Minmod" : "Beam-Warming"; }
inline const char* to_string(EarthPressure e) {
  switch (e) {
    case EarthPressure::SavageHutter: return "Savage-Hutter";
    case EarthPressure::Active: return "Active";
    case EarthPressure::Passive: return "Passive";
    case EarthPressure::Isotropic: return "Isotropic";
  }
  return "?";
}

/// Numerical parameters of the DAM ("DAM" sublist).
struct DamConfig {
  int cells = 400;
  Scheme scheme = Scheme::Minmod;
  TimeStepping time_stepping = TimeStepping::Staggered;
  /// Courant number of the step. Stable to 0.5, but above about 0.4 the staggered scheme's
  /// front locks onto the half-cell shift of the grid (docs/validation.md, "DAM fronts and the
  /// Courant number"): the front then depends on the step sequence, i.e. on the output times.
  double cfl = 0.4;
  EarthPressure earth_pressure = EarthPressure::SavageHutter;
  double k_smoothing = 0.1;  ///< [1/s] width of the tanh switch of K at u_x = 0
  double dry_depth = 1e-6;   ///< [m] below this depth a cell is dry: u = 0
  /// delta_1D [deg]: bed friction angle of the DAM when it differs from the Material's (the
  /// paper's Fig. 12 study); negative: the Material's 'Bed friction angle'.
  double bed_friction_deg = -1.0;

  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();
  static DamConfig from_parameters(const Teuchos::ParameterList& pl);
  /// The material the DAM sees: `m` with the bed friction angle of this config if it is set.
  /// Throws InputError (naming 'DAM->Bed friction angle') if that exceeds phi.
  core::Material material(const core::Material& m) const;
};

/// The physical coefficients the DAM needs, from Material and Channel.
struct DamPhysics {
  double g_sin = 0.0;      ///< g sin(zeta)
  double g_cos = 9.81;     ///< g cos(zeta)
  double tan_delta = 0.0;  ///< tan(delta)
  double K_act = 1.0, K_pas = 1.0;
  EarthPressure model = EarthPressure::SavageHutter;
  double k_smoothing = 0.1;

  static DamPhysics from(const core::Material& m, const core::Channel& c, const DamConfig& cfg);
  /// Earth pressure coefficient for a velocity gradient u_x: active for u_x > 0, passive for
  /// u_x < 0, switched smoothly, K = (K_a + K_p)/2 - (K_p - K_a)/2 tanh(u_x / k_smoothing).
  double K(double u_x) const;
  /// The range of K that material at rest can take: [K_act, K_pas] (the Rankine limits) for
  /// Savage-Hutter, the one value otherwise.
  std::array<double, 2> K_bounds() const;
};

/// A DAM boundary: its type and, for Inflow, the state (h, u) it imposes at time t on a ghost
/// cell centred at x (outside the channel). A prescribed inflow ignores x; at a 2D-to-1D
/// interface the coupled model samples the depth-averaged 2D state at the ghost centres, which
/// lie inside the neighbouring 2D subdomain (eqs. 19-21), so the time-staggered 1D grid reads
/// the 2D field where its ghost cells really are.
///
/// A prescribed inflow (`prescribed`, set by `from` for the channel's gate) imposes the flux of
/// its state at the end: all that enters in a step is the flux of (h_in, u_in)(t + dt/2) times
/// dt, whatever dt. An interface (`prescribed` false, the default, as the coupled model builds
/// it) overlaps: its ghosts are the neighbour's state where they lie.
struct DamBoundary {
  core::BoundaryType type = core::BoundaryType::Outflow;
  std::function<std::array<double, 2>(double t, double x)> inflow;  ///< (t, x) -> {h, u}
  bool prescribed = false;  ///< Inflow only: a prescribed inflow (true) or an interface (false)
  /// A prescribed inflow series (not constant): the volume per unit width that enters in
  /// [t0, t1], the exact integral of h u; empty otherwise.
  std::function<double(double t0, double t1)> volume;
  /// The same series' rows strictly inside (t0, t1) (the state is linear in t between them)
  std::function<std::vector<double>(double t0, double t1)> rows;
  static DamBoundary from(const core::BoundarySpec& spec);
};

class DamSolver final : public core::Stepper {
 public:
  DamSolver(double x_left, double x_right, const DamConfig& cfg, const DamPhysics& phys,
            DamBoundary left, DamBoundary right);

  /// Set the state on the primary grid from point values h(x), u(x), averaged over each cell
  /// with 4-point Gauss quadrature on each piece of the cell between the `breaks` (the jumps of
  /// piecewise data: a block's ends, a dam's position), so that such data get exact cell
  /// averages; time and step counters restart at t0.
  void set_state(const std::function<double(double)>& h, const std::function<double(double)>& u,
                 double t0 = 0.0, const std::vector<double>& breaks = {});

  // Stepper
  std::string model_name() const override { return "DAM"; }
  /// A step longer than stable_dt() (the coupled model's common step, set by its 2D parts) is
  /// taken as several steps of the scheme of at most the stable length each (sub-cycling);
  /// pending_step() and last_transfer() then hold their sum.
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
  void write_fields(io::FieldWriter& w) const override;
  void save(io::Checkpoint& c) const override;
  void load(const io::Checkpoint& c) override;
  void report(nlohmann::json& stats) const override;

  // Inspection (tests, coupling).
  double dx() const { return dx_; }
  int cells() const { return n_; }
  bool staggered() const { return staggered_; }
  /// Cell centres, depth and discharge of the current grid (primary or staggered).
  std::vector<double> centres() const;
  const std::vector<double>& h() const { return h_; }
  const std::vector<double>& hu() const { return hu_; }
  /// Cell averages on the primary grid: the current state if it is primary, otherwise the exact
  /// averages of the staggered piecewise-linear reconstruction over the primary cells
  /// (conservative; no time advance).
  void primary(std::vector<double>& h, std::vector<double>& hu) const;
  /// Mass on the current grid (end cells of the staggered grid count half).
  double mass() const;
  long positivity_fixes() const { return positivity_fixes_; }
  /// Near-dry cells whose velocity the Riemann-invariant bound changed (step_once)
  long thin_velocity_bounds() const { return thin_bounds_; }
  /// Depth and velocity at x from the piecewise-linear (minmod) reconstruction of the current
  /// grid, x in [x_left, x_right]; at a 1D-to-2D interface this is the state the 2D inflow takes
  /// (eq. 24) whichever of the two staggered grids is current.
  std::array<double, 2> sample(double x) const;
  /// Mass [m^2] that entered through the left end and left through the right end in the last
  /// accepted step (exact ledger terms): what a neighbouring subdomain must give or receive.
  std::array<double, 2> last_transfer() const { return last_transfer_; }
  /// The step that step() computed and accept() has not taken yet: it starts at t0, lasts dt,
  /// and moves `in` into the left end and `out` out of the right end (the exact ledger terms
  /// that accept() will book). Empty when no step is pending. A 2D subdomain downstream of a
  /// 1D-to-2D interface injects exactly `out` in the same step (the coupled model steps the
  /// subdomains upstream first). `out_flux`: the part of `out` that is dt times the flux
  /// through the right end; the rest, out - out_flux, is the staggered scheme's averaging term
  /// at that end (O(dx^2 h_x), independent of dt), which dominates a step much shorter than the
  /// stable one and can then make `out` negative while material flows out (docs/validation.md,
  /// "Runtime domain manager").
  struct PendingStep {
    double t0 = 0.0, dt = 0.0, in = 0.0, out = 0.0, out_flux = 0.0;
  };
  std::optional<PendingStep> pending_step() const {
    if (!(t_new_ > t_)) return std::nullopt;
    return PendingStep{t_, t_new_ - t_, in_new_, out_new_, out_flux_new_};
  }
  /// Puts mass m [m^2] (m < 0: takes it) into the cells at the left end between two steps: the
  /// coupled model hands over what the neighbour upstream let out through that end and this
  /// DAM's own flux there did not take in (CoupledModel::accept). Velocities are kept (hu scales
  /// with h); a dry first cell takes u_dry. A removal takes at most half of any cell's depth,
  /// going on downstream. Booked as inflow through the left end, so the DAM's ledger stays
  /// closed. Returns the mass placed (m, unless the channel holds too little to take -m).
  double take_interface_mass(double m, double u_dry);
  double x_left() const { return x0_; }
  double x_right() const { return x1_; }

  // Rebuilding (the coupled model's interfaces and the domain manager).
  /// Replaces the boundary of one end (0 left, 1 right) after construction: the coupled model
  /// reconnects its interfaces after a change of its parts.
  void set_boundary(int side, DamBoundary b);
  /// The state from cell averages h, hu at time t after `steps` steps: on the primary grid
  /// (cells() values) or on the staggered grid (cells() + 1 values, the end cells the averages
  /// over their halves inside [x_left, x_right]). The ledger restarts from this mass (a
  /// subdomain rebuilt from the cells of its predecessor or from 2D columns; the coupled model
  /// keeps the run's ledger).
  void set_cells(std::vector<double> h, std::vector<double> hu, double t, long steps,
                 bool staggered = false);

 private:
  static constexpr int G = 2;  // ghost cells per side
  struct Work;                 // padded arrays of one step
  void fill_ghosts(std::vector<double>& h, std::vector<double>& hu, int n, bool on_b,
                   double t) const;
  /// The state {h, u} on the end face of a prescribed inflow (side 0 left, 1 right) at time t,
  /// given the state of the end cell inside the channel: the user's (h_in, u_in) while it is
  /// compatible with the characteristic that leaves the channel there, otherwise the state that
  /// keeps the prescribed discharge (see the definition).
  double series_discharge(const DamBoundary& b, int side, double dt) const;
  std::array<double, 2> series_momentum(const DamBoundary& b, int side, double dt, double x,
                                        double h_end, double hu_end) const;
  std::array<double, 2> gate_state(const DamBoundary& b, int side, double t, double x,
                                   double h_end, double hu_end) const;
  bool wall_centred(int j, int n, bool on_b) const;
  /// +1 / -1 if cell j of a primary grid of n cells touches a right / left Wall, else 0.
  int wall_side(int j, int n) const;
  static bool comes_to_rest(double q1, double q2, double fric, int wall);
  double velocity(double h, double hu) const {
    return h > cfg_.dry_depth ? hu / h : 0.0;
  }
  void fix_positivity(std::vector<double>& h, std::vector<double>& hu, bool on_b);
  void step_semidiscrete(double dt);
  void step_once(double dt);  // one step of the scheme from the current state
  /// One forward-Euler stage w + dt L(w) of the semi-discrete scheme from the primary-grid
  /// state (h, hu) at time t, with the bounded friction; `in`/`out`: mass through the ends.
  void euler_stage(const std::vector<double>& h0, const std::vector<double>& hu0, double t,
                   double dt, std::vector<double>& h1, std::vector<double>& hu1, double& in,
                   double& out);

  DamConfig cfg_;
  DamPhysics phys_;
  DamBoundary left_, right_;
  double x0_, x1_, dx_;
  int n_;  // primary cells N

  // current state (size N on the primary grid, N + 1 on the staggered grid)
  double t_ = 0.0;
  long steps_ = 0;
  bool staggered_ = false;
  std::vector<double> h_, hu_;
  // tentative state of step()
  double t_new_ = 0.0;
  bool staggered_new_ = false;  // the grid of the tentative state
  std::vector<double> h_new_, hu_new_;
  double in_new_ = 0.0, out_new_ = 0.0, out_flux_new_ = 0.0;
  long fixes_new_ = 0, bounds_new_ = 0;

  // ledger
  double mass0_ = 0.0, mass_in_ = 0.0, mass_out_ = 0.0;
  long positivity_fixes_ = 0, thin_bounds_ = 0;
  std::array<double, 2> last_transfer_{0.0, 0.0};
  double dt_min_ = 0.0, dt_max_ = 0.0;
};

}  // namespace granflow::dam
