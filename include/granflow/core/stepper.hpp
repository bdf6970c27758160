#pragma once
// One time-stepping interface for every model (DAM, N-DAM, coupled), so that the run driver and
// the domain manager treat them alike:  dt = stable_dt(); step(dt); check(); accept().
// step() computes a tentative state; only accept() makes it current, so a step whose state fails
// check() leaves the last good state (and its output and checkpoint) untouched.
#include <nlohmann/json_fwd.hpp>

#include <optional>
#include <string>
#include <vector>

namespace granflow::io {
class FieldWriter;
class Checkpoint;
}  // namespace granflow::io

namespace granflow::core {

/// check() of every model stops a run whose tentative state moves faster than this [m/s]. The
/// paper's chutes flow at 0.4-3 m/s and free fall down any laboratory chute stays below
/// 100 m/s, so |u| > 1e4 m/s is a diverging state; it is caught while its numbers are still
/// finite, so the diagnosis can name the cell.
inline constexpr double kMaxVelocity = 1.0e4;
/// The reason check() gives for a velocity above kMaxVelocity (summary.json, stderr).
inline constexpr const char* kMaxVelocityReason = "velocity above 1e4 m/s";
/// profiles.csv caps the shallowness parameter eps at this: material at rest has eps -> infinity
/// (u_mean -> 0). Any cap far above the a priori layout's threshold (0.1) gives the same layout;
/// a finite one keeps the CSV and its plots readable.
inline constexpr double kEpsCap = 1.0e6;

/// Depth-averaged profile along the channel (the output contract's profiles.csv rows).
struct Profile {
  std::vector<double> x, h, u_mean, eps;
  std::vector<std::string> model;  ///< "1D" or "2D" per point
  void append(double xi, double hi, double ui, double epsi, const std::string& m) {
    x.push_back(xi);
    h.push_back(hi);
    u_mean.push_back(ui);
    eps.push_back(epsi);
    model.push_back(m);
  }
};

/// Mass (per unit channel width, m^2) and what crossed the boundaries.
struct MassBalance {
  double initial = 0.0;   ///< mass at t0
  double current = 0.0;   ///< mass now
  double inflow = 0.0;    ///< cumulative mass that entered through boundaries
  double outflow = 0.0;   ///< cumulative mass that left through boundaries
  /// admitted through the left end's gate and not yet part of the state: the 2D gate lets its
  /// discharge in as whole markers, and each open marker row carries its fraction of a marker
  /// (under one marker per row; a series gate that closes leaves up to half a marker of either
  /// sign) to the next steps. The gate's h_in u_in t = inflow + this.
  double pending_inflow = 0.0;
  double defect() const { return current - initial - inflow + outflow; }
};

/// The fastest material velocity of a state: how fast, where, which component. The run driver
/// keeps the largest one over the accepted steps (summary.json "max_speed"), so a stability
/// check compares every step with its bound, not only the output times.
struct Speed {
  double value = 0.0;    ///< |velocity| [m/s]
  double x = 0.0;        ///< where along the channel [m]
  double z = 0.0;        ///< height above the bed [m] (2D; 0 for a depth average)
  std::string quantity;  ///< "|u|" (a 2D cell's centred velocity), "u_mean" (a 1D cell)
};

/// The load of the material on the rigid end wall at x = L, per unit channel width: what an
/// engineer takes from the model for a defence structure (wall.csv, summary.json). Forces on the
/// wall (the reaction on the material has the opposite sign).
struct WallLoad {
  double force = 0.0;   ///< pressure force rho int_0^h p dz at the wall [N/m]
  double normal = 0.0;  ///< force of the full normal stress rho int_0^h (p - 2 nu_eff u_x) dz [N/m]
  double shear = 0.0;   ///< tangential force rho int_0^h tau_xz dz, + up the wall (+z) [N/m]
  double p_foot = 0.0;  ///< pressure of the bottom cell of the wall column, rho p [Pa]
  double depth = 0.0;   ///< material depth of the wall column [m]
  /// The material has reached the wall as a layer the model resolves (a 2D model: at least one
  /// cell height in the wall column), not as a few stray markers ahead of the front: the start
  /// of the impact.
  bool contact = false;
};

/// Result of checking a tentative state: where, when and which quantity went wrong.
struct Health {
  bool ok = true;
  std::string quantity;  ///< e.g. "h", "hu", "u"
  double x = 0.0;        ///< where [m]
  /// where, when no single x says it (a linear solve of a whole 2D part): replaces "at x = "
  std::string where;
  double value = 0.0;    ///< offending value
  std::string reason;    ///< e.g. "not finite", "negative depth"
  /// A limit of the scene reached (the material at the top of the 2D box), not a divergence:
  /// the run stops the same way (exit 3, last good state kept) with status "stopped".
  bool limit = false;
};

/// One piece of a model's layout along the channel: which model runs [x0, x1].
struct LayoutPiece {
  std::string model;  ///< "1D" or "2D"
  double x0 = 0.0, x1 = 0.0;
};

class Stepper {
 public:
  virtual ~Stepper() = default;
  virtual std::string model_name() const = 0;
  virtual double time() const = 0;
  virtual long steps() const = 0;
  /// Largest time step the model accepts in its current state (CFL and other limits).
  virtual double stable_dt() const = 0;
  /// Which condition sets stable_dt() now and where: the quantity, its value and its place
  /// (e.g. "viscous: nu_eff = 1 m^2/s at x = 0.2 m, z = 0.01 m"), for the diagnosis of a run
  /// whose stable step falls below 'Min time step'; collective like stable_dt(). Empty when the
  /// model does not say.
  virtual std::string dt_limit() const { return {}; }
  /// Compute the state at time() + dt into a tentative buffer.
  virtual void step(double dt) = 0;
  /// Diagnose the tentative state (finite, positive depth, ...).
  virtual Health check() const = 0;
  /// Make the tentative state current.
  virtual void accept() = 0;
  /// Between accepted steps (and once before the first): a model may change its own structure,
  /// e.g. the coupled model's domain manager moves its interfaces. Returns whether it did.
  virtual bool adapt() { return false; }

  virtual Profile profile() const = 0;
  /// The models along the channel now (one piece for a single model; the coupled model's
  /// subdomains), for summary.json's interface positions over time.
  virtual std::vector<LayoutPiece> layout_pieces() const;
  virtual MassBalance mass_balance() const = 0;
  /// The fastest velocity of the material in the current state (cell-centred in the material
  /// cells in 2D, depth-averaged in the wet cells in 1D); collective in 2D.
  virtual Speed max_speed() const = 0;
  /// Field snapshot (HDF5 + XDMF).
  virtual void write_fields(io::FieldWriter& w) const = 0;
  virtual void save(io::Checkpoint& c) const = 0;
  /// Called after a checkpoint of the current state was written: the run may be restarted from
  /// here, so state that the checkpoint cannot hold and that the next steps would read (lagged
  /// preconditioners) is dropped, and the straight run and a restarted one continue alike.
  virtual void restart_point() {}
  virtual void load(const io::Checkpoint& c) = 0;
  /// Whether the model ends at a rigid wall at x = L whose load it reports (wall.csv).
  virtual bool end_wall() const { return false; }
  /// The load on that wall in the current (accepted) state; empty when the model has no end
  /// wall, or when the part at the wall cannot resolve it (a 1D subdomain of a coupled model).
  /// Collective under MPI (every rank gets the value).
  virtual std::optional<WallLoad> wall_load() const { return std::nullopt; }
  /// Solver statistics for summary.json.
  virtual void report(nlohmann::json& stats) const = 0;
};

}  // namespace granflow::core
