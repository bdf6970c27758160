// DAM time step: the Nessyahu-Tadmor non-oscillatory central scheme on a time-staggered grid
// for the Savage-Hutter equations (15)-(16). One step reads, for conserved w = (h, hu) and flux
// f(w) = (hu, hu^2/h + beta h^2/2):
//
//   predictor  w_j^{n+1/2} = w_j - (dt / 2dx) f'_j + (dt/2) S(w_j)
//   corrector  w_{j+1/2}^{n+1} = (w_j + w_{j+1})/2 + (w'_j - w'_{j+1})/8
//                              - (dt/dx) [f(w_{j+1}^{n+1/2}) - f(w_j^{n+1/2})] + dt S_{j+1/2}
//
// where w'_j, f'_j are undivided slopes (minmod-limited, or Beam-Warming upwind differences) and
// S = (0, h g sin(zeta) - sgn(u) h g cos(zeta) tan(delta)). The friction part of S is applied as
// a bounded impulse: it reduces |hu| by at most |hu|, so it opposes motion and never reverses it;
// a cell whose momentum the friction can absorb with an earth pressure between K_act and K_pas
// comes to rest (step(), "Coming to rest"). K is held fixed inside each cell an update
// integrates over. A prescribed inflow imposes its flux through the channel end.
#include "granflow/dam/dam_solver.hpp"

#include "granflow/io/fields.hpp"
#include "granflow/params/parameters.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace granflow::dam {

using core::BoundaryType;

// ---------------------------------------------------------------------------------------------
// Parameters
// ---------------------------------------------------------------------------------------------
Teuchos::RCP<const Teuchos::ParameterList> DamConfig::getValidParameters() {
  static Teuchos::RCP<const Teuchos::ParameterList> valid = [] {
    using namespace params;
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("DAM"));
    const DamConfig d;
    add_int(*pl, "Cells", d.cells, "N: number of cells of the primary grid on the channel", 4,
            100000000);
    add_enum(*pl, "Scheme", to_string(d.scheme),
             "NOC slope reconstruction: Minmod (TVD, for shocks, fronts and deposits) or "
             "Beam-Warming (the paper's limiter-free variant for smooth supercritical flow; "
             "oscillates at shocks and kinks such as the head of a rarefaction, and its "
             "semi-discrete form runs a thin sheet ahead of a front on a dry bed)",
             {"Minmod", "Beam-Warming"});
    add_enum(*pl, "Time stepping", "Staggered",
             "Staggered: the paper's NOC scheme (Nessyahu-Tadmor) on two time-staggered grids; "
             "its numerical diffusion grows like dx^2/dt, so results change when dt is held far "
             "below the stable step (Time->Max time step, a coupled 2D neighbour). "
             "Semi-discrete: the central scheme of Kurganov & Tadmor (2000) on the primary grid "
             "with Heun's method, whose results converge as dt -> 0",
             {"Staggered", "Semi-discrete"});
    add_double(*pl, "CFL", d.cfl,
               "Courant number dt max(|u| + sqrt(beta h)) / dx; both time steppings are "
               "stable up to 0.5, but above about 0.4 a front on a dry bed moves with the "
               "step sequence (the output times), not only with dt",
               1e-3, 0.5);
    add_enum(*pl, "Earth pressure", to_string(d.earth_pressure),
             "K: Savage-Hutter (active where u_x > 0, passive where u_x < 0, smoothed switch), "
             "Active, Passive (K fixed at one value), or Isotropic (K = 1, shallow water)",
             {"Savage-Hutter", "Active", "Passive", "Isotropic"});
    add_double(*pl, "Earth pressure smoothing", d.k_smoothing,
               "[1/s] width of the tanh switch between K_act and K_pas around u_x = 0 "
               "(Savage-Hutter only)",
               1e-8, 1e6);
    add_double(*pl, "Dry depth", d.dry_depth,
               "[m] cells shallower than this are dry: their velocity is zero, and "
               "profiles.csv reports them empty (h = 0; fields.h5 keeps the model's h). Below "
               "a tenth of the inflow's and of the initial layer's depth",
               0.0, 1.0);
    add_double(*pl, "Bed friction angle", d.bed_friction_deg,
               "delta_1D [deg]: bed friction angle of the DAM (source term and K) when it should "
               "differ from Material->Bed friction angle, e.g. the 1D subdomains of a coupled "
               "run against delta_2D in the 2D ones (the paper's Fig. 12); -1: the Material's. "
               "Allowed: -1 or [0, Material->Internal friction angle]",
               -1.0, 89.0);
    return pl;
  }();
  return valid;
}

DamConfig DamConfig::from_parameters(const Teuchos::ParameterList& pl) {
  DamConfig c;
  c.cells = pl.get<int>("Cells");
  c.scheme = pl.get<std::string>("Scheme") == "Minmod" ? Scheme::Minmod : Scheme::BeamWarming;
  c.time_stepping = pl.get<std::string>("Time stepping") == "Staggered"
                        ? TimeStepping::Staggered
                        : TimeStepping::SemiDiscrete;
  c.cfl = pl.get<double>("CFL");
  const auto ep = pl.get<std::string>("Earth pressure");
  c.earth_pressure = ep == "Savage-Hutter" ? EarthPressure::SavageHutter
                     : ep == "Active"      ? EarthPressure::Active
                     : ep == "Passive"     ? EarthPressure::Passive
                                           : EarthPressure::Isotropic;
  c.k_smoothing = pl.get<double>("Earth pressure smoothing");
  c.dry_depth = pl.get<double>("Dry depth");
  c.bed_friction_deg = pl.get<double>("Bed friction angle");
  if (c.bed_friction_deg < 0.0 && c.bed_friction_deg != -1.0)
    params::fail(pl, "Bed friction angle", params::str(c.bed_friction_deg),
                 "negative values other than -1 (the Material's angle) mean nothing; allowed: -1 "
                 "or [0, Material->Internal friction angle]");
  return c;
}

core::Material DamConfig::material(const core::Material& m) const {
  core::Material d = m;
  if (bed_friction_deg < 0.0) return d;
  if (bed_friction_deg > m.internal_friction_deg)
    throw params::InputError(
        "parameter 'granflow->DAM->Bed friction angle' = " + params::str(bed_friction_deg) +
        ": must not exceed Material->Internal friction angle = " +
        params::str(m.internal_friction_deg) +
        " deg: the earth pressure coefficient K needs delta <= phi; allowed: -1 or [0, phi]");
  d.bed_friction_deg = bed_friction_deg;
  return d;
}

DamPhysics DamPhysics::from(const core::Material& material, const core::Channel& c,
                            const DamConfig& cfg) {
  const core::Material m = cfg.material(material);  // delta_1D when the DAM list sets one
  DamPhysics p;
  p.g_sin = c.g_sin(m.gravity);
  p.g_cos = c.g_cos(m.gravity);
  p.tan_delta = m.tan_delta();
  p.K_act = m.K_active();
  p.K_pas = m.K_passive();
  p.model = cfg.earth_pressure;
  p.k_smoothing = cfg.k_smoothing;
  return p;
}

double DamPhysics::K(double u_x) const {
  switch (model) {
    case EarthPressure::Active: return K_act;
    case EarthPressure::Passive: return K_pas;
    case EarthPressure::Isotropic: return 1.0;
    case EarthPressure::SavageHutter: break;
  }
  return 0.5 * (K_act + K_pas) - 0.5 * (K_pas - K_act) * std::tanh(u_x / k_smoothing);
}

std::array<double, 2> DamPhysics::K_bounds() const {
  switch (model) {
    case EarthPressure::Active: return {K_act, K_act};
    case EarthPressure::Passive: return {K_pas, K_pas};
    case EarthPressure::Isotropic: return {1.0, 1.0};
    case EarthPressure::SavageHutter: break;
  }
  return {std::min(K_act, K_pas), std::max(K_act, K_pas)};
}

DamBoundary DamBoundary::from(const core::BoundarySpec& spec) {
  DamBoundary b;
  b.type = spec.type;
  b.prescribed = spec.type == BoundaryType::Inflow;
  if (spec.type == BoundaryType::Inflow) {
    const core::InflowSeries s = spec.inflow;
    b.inflow = [s](double t, double) {
      return std::array<double, 2>{s.depth(t), s.velocity(t)};
    };
    if (!s.is_constant()) {
      b.volume = [s](double t0, double t1) { return s.discharge(t0, t1); };
      b.rows = [s](double t0, double t1) { return s.rows_between(t0, t1); };
    }
  }
  return b;
}

// ---------------------------------------------------------------------------------------------
// Construction and state
// ---------------------------------------------------------------------------------------------
DamSolver::DamSolver(double x_left, double x_right, const DamConfig& cfg, const DamPhysics& phys,
                     DamBoundary left, DamBoundary right)
    : cfg_(cfg), phys_(phys), left_(std::move(left)), right_(std::move(right)), x0_(x_left),
      x1_(x_right), dx_((x_right - x_left) / cfg.cells), n_(cfg.cells) {
  if (!(x_right > x_left)) throw std::invalid_argument("DamSolver: empty interval");
  h_.assign(static_cast<std::size_t>(n_), 0.0);
  hu_.assign(static_cast<std::size_t>(n_), 0.0);
}

void DamSolver::set_state(const std::function<double(double)>& h,
                          const std::function<double(double)>& u, double t0,
                          const std::vector<double>& breaks) {
  // 4-point Gauss-Legendre on each piece of a cell between the breaks: exact cell averages for
  // data that are polynomials of degree <= 7 between the breaks. Across a jump that is not a
  // break the average is only second-order accurate: a DAM block [0.2, 0.203] m in 10 mm cells
  // got 42 % too little mass when its ends were not breaks (an independent run).
  static const double gx[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                               0.8611363115940526};
  static const double gw[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                               0.3478548451374538};
  staggered_ = false;
  h_.assign(static_cast<std::size_t>(n_), 0.0);
  hu_.assign(static_cast<std::size_t>(n_), 0.0);
  for (int j = 0; j < n_; ++j) {
    const double xc = x0_ + (j + 0.5) * dx_;
    const double xl = x0_ + j * dx_, xr = x0_ + (j + 1) * dx_;
    std::vector<double> ends{xl};
    for (double b : breaks)
      if (b > xl + 1e-12 * dx_ && b < xr - 1e-12 * dx_) ends.push_back(b);
    ends.push_back(xr);
    std::sort(ends.begin(), ends.end());
    double hs = 0.0, hus = 0.0;
    // a piece of half-length hl about pc, its share of the cell hl / dx per unit weight
    auto piece = [&](double pc, double hl, double share) {
      for (int q = 0; q < 4; ++q) {
        const double x = pc + hl * gx[q];
        const double hq = std::max(0.0, h(x));
        hs += share * gw[q] * hq;
        hus += share * gw[q] * hq * u(x);
      }
    };
    if (ends.size() == 2) {
      piece(xc, 0.5 * dx_, 0.5);  // the whole cell (as before the breaks: bit for bit)
    } else {
      for (std::size_t e = 0; e + 1 < ends.size(); ++e) {
        const double hl = 0.5 * (ends[e + 1] - ends[e]);
        piece(0.5 * (ends[e] + ends[e + 1]), hl, hl / dx_);
      }
    }
    h_[static_cast<std::size_t>(j)] = hs;
    hu_[static_cast<std::size_t>(j)] = hs > cfg_.dry_depth ? hus : 0.0;
  }
  t_ = t0;
  steps_ = 0;
  mass0_ = mass();
  mass_in_ = mass_out_ = 0.0;
  positivity_fixes_ = 0;
}

std::vector<double> DamSolver::centres() const {
  const int n = static_cast<int>(h_.size());
  std::vector<double> x(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j)
    x[static_cast<std::size_t>(j)] = x0_ + (staggered_ ? j : j + 0.5) * dx_;
  return x;
}

double DamSolver::mass() const {
  double m = 0.0;
  for (double v : h_) m += v;
  if (staggered_) m -= 0.5 * (h_.front() + h_.back());
  return m * dx_;
}

// The rest test of a cell (see step(), "Coming to rest"): q1, q2 are its momentum after the
// step without friction for the two limits of K, fric the friction impulse bound. Free cell:
// at rest if some q in [q1, q2] has |q| <= fric. A cell against a rigid wall (wall = +1 on the
// right, -1 on the left) also has the wall's reaction, which can push it back by any amount but
// never pull it: at rest if some q in [q1, q2] lies in [-fric, inf) (right wall) or
// (-inf, fric] (left). Without it the cell next to the wall of a deposit, whose mirrored ghost
// gives it only half the pressure gradient that holds the deposit, kept u ~ 1e-3 - 4e-3 m/s
// indefinitely (Setup II after the gate closed).
bool DamSolver::comes_to_rest(double q1, double q2, double fric, int wall) {
  const double lo = std::min(q1, q2), hi = std::max(q1, q2);
  if (wall > 0) return hi >= -fric;
  if (wall < 0) return lo <= fric;
  return lo <= fric && hi >= -fric;
}

int DamSolver::wall_side(int j, int n) const {
  if (j == n - 1 && right_.type == BoundaryType::Wall) return 1;
  if (j == 0 && left_.type == BoundaryType::Wall) return -1;
  return 0;
}

bool DamSolver::wall_centred(int j, int n, bool on_b) const {
  if (!on_b) return false;
  return (j == 0 && left_.type == BoundaryType::Wall) ||
         (j == n - 1 && right_.type == BoundaryType::Wall);
}

// The state on the face of a prescribed inflow (the gate). The characteristics of (15)-(16) at
// the end are u + c and u - c, c = sqrt(beta h) (source terms aside, with the Riemann invariants
// R+/- = u +/- 2c); counted in the direction v = sigma u into the channel (sigma = +1 at the left
// end, -1 at the right), the gate state can prescribe as many quantities as characteristics
// enter: both at a supercritical inflow (v > c), one at a subcritical one (|v| < c), where the
// other, R = v - 2c, arrives from the interior and the gate state must carry it. Imposing both
// h_in and u_in at a subcritical gate is over-determined: when the wave reflected by the wall
// of the horizontal chute backed up to the gate (interior deeper and slower than the gate
// state), the fixed end flux kept feeding h_in u_in with the momentum flux of the shallow gate
// state, the interior pressure drove the end cell backwards against a face that lets nothing
// out, and the gate cell reached h = 3.1 m, u = -323 m/s (docs/validation.md, "Stability suite").
//
// Rule. R_0 = v_0 - 2 c_0 of the end cell (the interior side; 0 if dry), R_in = v_in - 2 c_in of
// the user's state, c_c = cbrt(q_in a^2) the critical speed of the discharge q_in = h_in v_in:
//  - a subcritical gate state (0 < v_in < c_in) prescribes the *discharge* q_in only, which is
//    what a gate fed by a silo delivers and what the user's mass flux is; the depth comes from
//    the outgoing invariant,
//      q_in / h_b - 2 sqrt(beta h_b) = R_0,   u_b = q_in / h_b,
//    whose subcritical root exists while R_0 <= -c_c (the left side falls monotonically in h_b
//    down to the critical depth): deeper than h_in where the channel backs up to the gate
//    (R_0 < R_in), shallower where it draws the inflow on. Where it draws harder than any
//    subcritical state of q_in can follow (R_0 > -c_c, a dry or accelerating channel) the gate
//    is a hydraulic control: the critical state h_c = (q_in / a)^(2/3), u_c = c_c. The branches
//    agree at R_0 = -c_c (continuous, with a kink). Before (2026-12-02) the user's (h_in, u_in)
//    held whenever R_0 >= R_in: a deep slow gate over a dry bed (0.2 m at 0.01 m/s) then fed
//    the earth pressure of its whole opening with the mass flux of q_in, and the first cells
//    ran at 50-270 m/s (DamInflow.DeepSlowGateOverADryBedIsAHydraulicControl); the paper's gate
//    (u_in / c_in = 0.44 with K(0) = 1.84) is a control too, 0.0333 m at 0.66 m/s in its first
//    cell against 0.0375 m at 0.59 m/s.
//  - a supercritical gate state (v_in >= c_in): both characteristics enter and the user's state
//    holds unless the channel is backed up to it (R_0 < R_in) and the root above is subcritical
//    (a gate drowned by a bore whose R_0 really reaches the gate).
// The gate never lets material out: where the interior flows towards it (v_0 < 0, the
// reflected wave arriving), R_0 < R_in and the gate state is the one of the same outgoing
// invariant that still carries q_in in, deeper and slower (v_b in (0, v_in]); for a closed gate
// (q_in = 0) it is u_b = 0, c_b = c_0 - v_0 / 2: the reflection at a wall. beta: g cos(zeta)
// K(0), the mean of the Rankine limits (the face's K is not known before the step).
// An inflow series' mean discharge over the step [t, t + dt] (into the channel: + at the left
// end, - at the right), the exact volume of the series over the step divided by dt.
double DamSolver::series_discharge(const DamBoundary& b, int side, double dt) const {
  return (side == 0 ? 1.0 : -1.0) * b.volume(t_, t_ + dt) / dt;
}

// An inflow series' mean momentum fluxes over the step [t, t + dt]: {advective h u^2, h^2 / 2}
// of the gate state, averaged over the step by Simpson's rule on each piece between the series'
// rows (the interior's end state held at h_end, hu_end). Where the gate state is the series'
// own (a supercritical gate), h u^2 is cubic and h^2 quadratic on each piece, so the mean is
// exact: the momentum that enters no longer depends on where the steps fall. Sampled at
// t + dt/2 alone, a 20 ms pulse brought in 6.08e-4 m^3/s of momentum with steps of 10 ms and
// 3.64e-4 with 0.1 ms (+67 %; the mass exact in both), and a 2 ms pulse between two samples
// entered with none (an independent run).
std::array<double, 2> DamSolver::series_momentum(const DamBoundary& b, int side, double dt,
                                                 double x, double h_end, double hu_end) const {
  auto flux = [&](double t) {
    const auto s = gate_state(b, side, t, x, h_end, hu_end);
    return std::array<double, 2>{s[0] * s[1] * s[1], 0.5 * s[0] * s[0]};
  };
  std::array<double, 2> sum{0.0, 0.0};
  const double t1 = t_ + dt;
  double a = t_;
  auto piece = [&](double e) {
    const auto fa = flux(a), fm = flux(0.5 * (a + e)), fe = flux(e);
    for (int q = 0; q < 2; ++q) sum[q] += (e - a) / 6.0 * (fa[q] + 4.0 * fm[q] + fe[q]);
    a = e;
  };
  if (b.rows)
    for (double r : b.rows(t_, t1)) piece(r);
  piece(t1);
  return {sum[0] / dt, sum[1] / dt};
}

std::array<double, 2> DamSolver::gate_state(const DamBoundary& b, int side, double t, double x,
                                            double h_end, double hu_end) const {
  const auto s = b.inflow(t, x);
  const double sigma = side == 0 ? 1.0 : -1.0;
  const double h_in = std::max(0.0, s[0]), v_in = sigma * s[1];
  if (v_in < 0.0) return s;  // a "gate" that draws material out: prescribed as given
  const double a = std::sqrt(phys_.g_cos * phys_.K(0.0));  // c = a sqrt(h)
  const double q = h_in > cfg_.dry_depth ? h_in * v_in : 0.0;
  const double R_in = v_in - 2.0 * a * std::sqrt(h_in);
  const bool wet = h_end > cfg_.dry_depth;
  const double R_0 = wet ? sigma * hu_end / h_end - 2.0 * a * std::sqrt(h_end) : 0.0;
  // A subcritical gate state (0 < v_in < c_in) prescribes the discharge only. The depth comes
  // from the interior's R_0 (the root below, deeper or shallower than h_in) as long as a
  // subcritical state carrying q_in has that invariant: R_0 <= R_c = -c_c, c_c = cbrt(q a^2)
  // the critical speed of q_in. Where the interior draws harder (a dry channel, or one
  // accelerating away), the gate is a hydraulic control: the critical state of q_in.
  const bool subcritical = q > 0.0 && v_in < a * std::sqrt(h_in);
  const double c_c = std::cbrt(q * a * a), h_c = (c_c / a) * (c_c / a);
  if (subcritical) {
    if (!wet || R_0 > -c_c) return {h_c, sigma * c_c};
  } else if (!(R_0 < R_in)) {
    return s;
  }
  // q / h - 2 a sqrt(h) = R_0 in s = sqrt(h): g(s) = 2 a s^3 + R_0 s^2 - q = 0. g is convex and
  // increasing right of its root, and s_0 = max(-R_0 / 2a, 0) + cbrt(q / 2a) has g(s_0) >= 0,
  // so Newton from s_0 descends monotonically onto the root.
  double r = std::max(-R_0 / (2.0 * a), 0.0) + std::cbrt(q / (2.0 * a));
  for (int it = 0; it < 100; ++it) {
    const double g = (2.0 * a * r + R_0) * r * r - q, dg = (6.0 * a * r + 2.0 * R_0) * r;
    if (!(dg > 0.0)) break;
    const double next = r - g / dg;
    if (!(next < r)) break;  // converged (monotone descent stalls at round-off)
    r = next;
  }
  const double h_b = r * r, v_b = h_b > 0.0 ? q / h_b : 0.0;
  if (!(v_b < a * r)) {  // supercritical: both characteristics enter
    if (subcritical) return {h_c, sigma * c_c};  // (R_0 = R_c to round-off: the control)
    return s;
  }
  return {h_b, sigma * v_b};
}

// Ghost cells: index j of the grid is stored at j + G; j = -2, -1 and n, n+1 are ghosts.
// Primary grid: the channel ends are cell faces. Staggered grid: the ends are cell centres of the
// first and last cell, so mirrors are taken about those centres.
void DamSolver::fill_ghosts(std::vector<double>& h, std::vector<double>& hu, int n, bool on_b,
                            double t) const {
  auto at = [&](int j) { return static_cast<std::size_t>(j + G); };
  auto set = [&](int dst, double hv, double huv) {
    h[at(dst)] = hv;
    hu[at(dst)] = huv;
  };
  const int off = on_b ? 1 : 0;  // mirror about a centre skips the centre cell
  // Inflow ghosts. An interface's ghosts take the neighbour's state where they lie. A
  // prescribed state (h_in, u_in) holds at the end x0 itself, a cell face of the primary grid,
  // so there the ghosts are the reflection 2 w_in - w_end that puts w_in on the face: the end
  // cell's slope then sees the profile's real gradient (a ghost equal to w_in, i.e. w_in half
  // a cell upstream of x0, halved the slope of an accelerating inflow and made an O(dx) error
  // of 1.2e-3 in the Bernoulli constant of the steady supercritical test at N = 200, 3.6e-4
  // with the reflection). Where that would leave a ghost shallower than h_in / 2 (material
  // piled up at the end, or a dry inflow) the ghosts are w_in. The ghosts only shape slopes and
  // the predictor: what enters is the end flux of step().
  auto set_inflow = [&](int dst, int end, std::array<double, 2> s, const DamBoundary& b,
                        int side, double x) {
    const bool prescribed = b.prescribed;
    if (prescribed) s = gate_state(b, side, t, x, h[at(end)], hu[at(end)]);
    const double hr = 2.0 * s[0] - h[at(end)], hur = 2.0 * s[0] * s[1] - hu[at(end)];
    if (prescribed && !on_b && hr >= 0.5 * s[0] && s[0] > cfg_.dry_depth)
      set(dst, hr, hur);
    else
      set(dst, s[0], s[0] * s[1]);
  };
  switch (left_.type) {
    case BoundaryType::Inflow:
      for (int g = -2; g <= -1; ++g) {
        const double x = x0_ + (g + (on_b ? 0.0 : 0.5)) * dx_;
        set_inflow(g, 0, left_.inflow(t, x), left_, 0, x);
      }
      break;
    case BoundaryType::Outflow:
      for (int g = -2; g <= -1; ++g) set(g, h[at(0)], hu[at(0)]);
      break;
    case BoundaryType::Wall:
      for (int g = 1; g <= 2; ++g) set(-g, h[at(g - 1 + off)], -hu[at(g - 1 + off)]);
      break;
    case BoundaryType::Periodic:
      // staggered: cell n-1 is the same physical cell as cell 0
      for (int g = 1; g <= 2; ++g) set(-g, h[at(n - g - off)], hu[at(n - g - off)]);
      break;
  }
  switch (right_.type) {
    case BoundaryType::Inflow:
      for (int g = 0; g <= 1; ++g) {
        const double x = x0_ + (n + g + (on_b ? 0.0 : 0.5)) * dx_;
        set_inflow(n + g, n - 1, right_.inflow(t, x), right_, 1, x);
      }
      break;
    case BoundaryType::Outflow:
      for (int g = 0; g <= 1; ++g) set(n + g, h[at(n - 1)], hu[at(n - 1)]);
      break;
    case BoundaryType::Wall:
      for (int g = 0; g <= 1; ++g) set(n + g, h[at(n - 1 - g - off)], -hu[at(n - 1 - g - off)]);
      break;
    case BoundaryType::Periodic:
      for (int g = 0; g <= 1; ++g) set(n + g, h[at(g + off)], hu[at(g + off)]);
      break;
  }
}

// ---------------------------------------------------------------------------------------------
// Time step
// ---------------------------------------------------------------------------------------------
namespace {
// Below this fraction of the deepest cell it reads, a new cell's velocity is bounded by the
// Riemann invariants of those cells (step_once, the corrector).
constexpr double kThinFraction = 0.1;
inline double minmod(double a, double b) {
  if (a * b <= 0.0) return 0.0;
  return std::abs(a) < std::abs(b) ? a : b;
}

// Velocity gradient u_x at a cell for the active/passive switch of K, from the wet cells among
// the cell (u0) and its neighbours (um at distance gm cells upstream, up at gp downstream).
// Fix (verification, tests/dam): a dry cell carries u = 0 by convention, so the plain central
// difference saw u_x < 0 at every spreading wet/dry front and chose the passive K there
// (K_pas/K_act ~ 3 for phi = 35, delta = 30 deg): the extra "pressure" at the front shot a
// sliding block's tip to 6.5 m/s where the Ritter bound u0 + 2 c0 is 2.9 m/s. Dry neighbours
// are now skipped (one-sided difference; u_x = 0 if no wet neighbour).
inline double wet_ux(double um, bool wet_m, int gm, double u0, double up, bool wet_p, int gp,
                     double dx) {
  const double a = wet_m ? um : u0, b = wet_p ? up : u0;
  const int span = (wet_m ? gm : 0) + (wet_p ? gp : 0);
  return span > 0 ? (b - a) / (span * dx) : 0.0;
}
}  // namespace

double DamSolver::stable_dt() const {
  // dt = CFL dx / max(|u| + sqrt(beta h)), with beta from the cell's own K (see K()).
  const int n = static_cast<int>(h_.size());
  std::vector<double> h(static_cast<std::size_t>(n + 2 * G)), hu(h.size());
  std::copy(h_.begin(), h_.end(), h.begin() + G);
  std::copy(hu_.begin(), hu_.end(), hu.begin() + G);
  fill_ghosts(h, hu, n, staggered_, t_);
  double amax = 0.0;
  for (int i = 1; i < n + 2 * G - 1; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double u = velocity(h[k], hu[k]);
    const double ux = wet_ux(velocity(h[k - 1], hu[k - 1]), h[k - 1] > cfg_.dry_depth, 1, u,
                             velocity(h[k + 1], hu[k + 1]), h[k + 1] > cfg_.dry_depth, 1, dx_);
    const double beta = phys_.g_cos * phys_.K(ux);
    amax = std::max(amax, std::abs(u) + std::sqrt(std::max(0.0, beta * h[k])));
  }
  if (amax <= 0.0) return std::numeric_limits<double>::infinity();
  return cfg_.cfl * dx_ / amax;
}

// One step of length dt, sub-cycled when dt exceeds the stable step: the scheme's steps of equal
// length up to the stable one, each from the state the previous one left (the boundary values of
// every sub-step are read at its own time; a coupled neighbour answers with its state at t), and
// the sums of their boundary transfers.
void DamSolver::step(double dt) {
  if (!(dt > stable_dt() * (1.0 + 1e-12))) {
    step_once(dt);
    return;
  }
  const auto h0 = h_, hu0 = hu_;
  const double t0 = t_;
  const bool s0 = staggered_;
  double in = 0.0, out = 0.0, out_flux = 0.0, remaining = dt;
  long fixes = 0, bounds = 0;
  while (remaining > 0.0) {
    const double stable = stable_dt();
    const double n = std::ceil(remaining / stable * (1.0 - 1e-12));
    const double h = n <= 1.0 ? remaining : remaining / n;
    step_once(h);
    in += in_new_;
    out += out_new_;
    out_flux += out_flux_new_;
    fixes += fixes_new_;
    bounds += bounds_new_;
    h_.swap(h_new_);
    hu_.swap(hu_new_);
    staggered_ = staggered_new_;
    t_ = t_new_;
    remaining = n <= 1.0 ? 0.0 : t0 + dt - t_;
    if (!std::isfinite(h_.empty() ? 0.0 : h_[0])) break;  // check() diagnoses the state
  }
  // the sub-stepped state is the tentative one; the current state is that of t0 again
  h_new_.swap(h_);
  hu_new_.swap(hu_);
  staggered_new_ = staggered_;
  h_ = h0;
  hu_ = hu0;
  staggered_ = s0;
  t_ = t0;
  t_new_ = t0 + dt;
  in_new_ = in;
  out_new_ = out;
  out_flux_new_ = out_flux;
  fixes_new_ = fixes;
  bounds_new_ = bounds;
}

void DamSolver::step_once(double dt) {
  staggered_new_ = cfg_.time_stepping == TimeStepping::Staggered ? !staggered_ : staggered_;
  bounds_new_ = 0;
  if (cfg_.time_stepping == TimeStepping::SemiDiscrete) {
    step_semidiscrete(dt);
    return;
  }
  const bool on_b = staggered_;
  const int n = static_cast<int>(h_.size());  // cells of the current grid
  const int P = n + 2 * G;                    // padded size
  const double lam = dt / dx_;
  auto at = [](int j) { return static_cast<std::size_t>(j + G); };

  // --- 1. state with ghost cells at time t -------------------------------------------------
  std::vector<double> h(static_cast<std::size_t>(P)), hu(h.size());
  std::copy(h_.begin(), h_.end(), h.begin() + G);
  std::copy(hu_.begin(), hu_.end(), hu.begin() + G);
  fill_ghosts(h, hu, n, on_b, t_);

  // --- 2. earth pressure coefficient per cell from the velocity gradient (lagged in the step)
  std::vector<double> u(h.size()), ux(h.size()), beta(h.size());
  for (int j = -2; j < n + 2; ++j) u[at(j)] = velocity(h[at(j)], hu[at(j)]);
  for (int j = -2; j < n + 2; ++j) {
    const int jm = std::max(j - 1, -2), jp = std::min(j + 1, n + 1);
    ux[at(j)] = wet_ux(u[at(jm)], h[at(jm)] > cfg_.dry_depth, j - jm, u[at(j)], u[at(jp)],
                       h[at(jp)] > cfg_.dry_depth, jp - j, dx_);
    beta[at(j)] = phys_.g_cos * phys_.K(ux[at(j)]);
  }
  // Momentum flux hu^2/h + beta h^2/2 of a state with a given beta.
  auto mflux = [&](double hv, double huv, double b) {
    const double uv = velocity(hv, huv);
    return huv * uv + 0.5 * b * hv * hv;
  };
  auto flux = [&](int j, double hv, double huv, double& f0, double& f1) {
    f0 = huv;
    f1 = mflux(hv, huv, beta[at(j)]);
  };
  // K is held fixed inside each cell that an update integrates over: the predictor of old cell
  // j differences the flux of its neighbours with its own beta_j, and the corrector of a new
  // cell between old cells L and R takes both fluxes with the beta of the new cell, from the
  // velocity difference across it, (u_R - u_L)/dx, where it agrees in sign with the old cells'
  // mean central difference (minmod of the two; else K(0)): a grid-scale wiggle of u, of
  // Beam-Warming or of a creeping deposit, flips the sign of single differences but is no
  // strain rate, and must not switch K between its Rankine limits (a dry side: the wet
  // cell's beta). The
  // pressure force on a cell is then beta (h^2/2)_x with the cell's K, and a jump of K between
  // neighbouring cells is no force. (Before, each old cell's flux carried its own beta_j: in a
  // deposit where moving and resting cells alternate, neighbours switched between K_act and
  // K_pas, and (beta_p - beta_a) h^2 / (2 dx) was a force ~4x the friction that kept the
  // pattern creeping at ~0.1 m/s; docs/numerics.md, "Earth pressure on the grid".)
  auto beta_face = [&](std::size_t L, std::size_t R) {
    const bool wl = h[L] > cfg_.dry_depth, wr = h[R] > cfg_.dry_depth;
    if (wl && wr)
      return phys_.g_cos * phys_.K(minmod((u[R] - u[L]) / dx_, 0.5 * (ux[L] + ux[R])));
    return wl ? beta[L] : beta[R];
  };

  // --- 3. slopes of w and f on cells -1 .. n ------------------------------------------------
  std::vector<double> f0(h.size()), f1(h.size());
  for (int j = -2; j < n + 2; ++j) flux(j, h[at(j)], hu[at(j)], f0[at(j)], f1[at(j)]);
  std::vector<double> sh(h.size(), 0.0), shu(h.size(), 0.0), sf0(h.size(), 0.0),
      sf1(h.size(), 0.0);
  // Beam-Warming's unlimited upwind difference is taken only where it keeps the depth
  // reconstruction as positive as minmod does, |h'_j| <= h_j (the reconstruction then stays
  // >= h_j / 2 across the cell); elsewhere, and in dry cells, every component of the cell takes
  // the minmod slope (bw_ok). Smooth flow (|h'| << h) keeps the paper's scheme. Before, where
  // the depth fell steeply to a front, the upwind difference was up to 10 times the cell's own
  // depth (h = 4e-5 m, h' = -4.2e-4 m), the half-cell averages of the corrector were negative
  // or tiny, and the ratio hu / h of the cells they formed ahead of and at the tip was set by
  // flux differences, not by a velocity: the coupled Setup II's DAM, fed a thick slow front by
  // its 2D part, ran its tip at 9-15 m/s where the bound is 4.48 m/s (the DAM alone, whose
  // front from the gate is thin and fast, at 3.6 m/s; docs/validation.md, "Stability suite").
  // A dry cell ahead of a front took 0 - h_tip as its slope, and the predictor moved mass
  // into it.
  auto bw_ok = [&](int j) {
    const auto k = at(j);
    if (h[k] <= cfg_.dry_depth) return false;
    const double d = u[k] >= 0.0 ? h[k] - h[k - 1] : h[k + 1] - h[k];
    return std::abs(d) <= h[k];
  };
  auto limit = [&](double dm, double dp, int j) {
    if (wall_centred(j, n, on_b)) return 0.5 * (dm + dp);  // symmetric about the wall
    // Beam-Warming: the one-sided difference upwind of the cell's velocity. A cell at rest
    // (u = 0 exactly: held by friction, or dry) has no upwind side; it takes the minmod slope,
    // which is odd under a wall's mirror (h even, hu odd) as the end terms need. With
    // "u >= 0" a deposit at rest against a wall and its mirrored ghost (u = -0) both took the
    // backward difference, and dx (s_c + s_d) / 16 left through the wall every step (Setup II
    // in the DAM at 10 mm: 7.8 % of the inflow by t = 1 s).
    if (cfg_.scheme == Scheme::Minmod || !bw_ok(j) || u[at(j)] == 0.0) return minmod(dm, dp);
    return u[at(j)] > 0.0 ? dm : dp;
  };
  auto slope = [&](const std::vector<double>& v, int j) {
    return limit(v[at(j)] - v[at(j - 1)], v[at(j + 1)] - v[at(j)], j);
  };
  for (int j = -1; j <= n; ++j) {
    const auto k = at(j);
    sh[k] = slope(h, j);
    shu[k] = slope(hu, j);
    // A wet cell next to a dry one (a front): the momentum slope follows the depth slope,
    // hu' = u h', i.e. the velocity is constant across the front cell. Limited separately,
    // h' and hu' of the front cell differ (the minmod of hu picks the jump to the dry cell
    // where that of h does not), and the average of the two reconstructions over the new
    // front cell then carried a velocity of its own: the tip of a dam break on a dry bed ran
    // at 3.6-4.5 m/s where the Ritter front speed is 2.1 m/s + s t (bound with K(0): 4.27).
    if (h[k] > cfg_.dry_depth && (h[k - 1] <= cfg_.dry_depth || h[k + 1] <= cfg_.dry_depth))
      shu[k] = u[k] * sh[k];
    sf0[k] = slope(f0, j);
    // neighbours' momentum fluxes with this cell's beta (K fixed inside the cell, see above)
    sf1[k] = limit(f1[k] - mflux(h[k - 1], hu[k - 1], beta[k]),
                   mflux(h[k + 1], hu[k + 1], beta[k]) - f1[k], j);
  }

  // --- 4. predictor to t + dt/2 on the interior cells; ghosts from the boundary conditions --
  std::vector<double> hm(h.size()), hum(h.size());
  for (int j = 0; j < n; ++j) {
    const auto k = at(j);
    hm[k] = std::max(0.0, h[k] - 0.5 * lam * sf0[k]);
    double q = hu[k] - 0.5 * lam * sf1[k] + 0.5 * dt * phys_.g_sin * h[k];
    const double fric = 0.5 * dt * phys_.g_cos * phys_.tan_delta * h[k];
    q = std::copysign(std::max(std::abs(q) - fric, 0.0), q);  // friction never reverses u
    hum[k] = (wall_centred(j, n, on_b) || hm[k] <= cfg_.dry_depth) ? 0.0 : q;
  }
  fill_ghosts(hm, hum, n, on_b, t_ + 0.5 * dt);
  std::vector<double> g0(h.size());  // mass fluxes at t + dt/2 (momentum: with the new cell's K)
  for (int j = -1; j <= n; ++j) g0[at(j)] = hum[at(j)];
  auto g1 = [&](std::size_t k, double b) { return mflux(hm[k], hum[k], b); };

  // --- 5. fluxes through the channel ends at prescribed inflows ------------------------------
  // A prescribed inflow end is a cell face of both grids: the end cell of the staggered grid is
  // the half cell between the end and the first primary centre, its value the average over
  // that half cell (so the mass of a staggered state, end cells weighted 1/2, is the mass in the
  // channel), and all that enters through the end in a step is dt F, F the flux of the inflow
  // state at t + dt/2 (midpoint rule in time): h_in u_in dt whatever dt. Before, the full
  // staggered end cell straddled the end with its outer half in the ghost, reset to the inflow
  // state every step, and dx (h_in - h_0)/4 of it was booked as inflow per step whatever dt
  // (3.2e-4 m^2 in 100 steps of 1e-7 s where h_in u_in t is 2.2e-7 m^2; docs/validation.md).
  // beta: the K of the new end cell (bc below).
  // An interface to a neighbouring subdomain keeps the overlapping form: its ghosts are the
  // neighbour's state where they lie, the staggered end cell straddles the interface, and on
  // matching grids the split channel tends to the single one as dt -> 0 (the transfers of the
  // two sides agree to 5e-4 at CFL 0.45, 7e-7 at a hundredth of it; docs/validation.md).
  const bool half_left = left_.type == BoundaryType::Inflow && left_.prescribed;
  const bool half_right = right_.type == BoundaryType::Inflow && right_.prescribed;
  // The state on the face is the gate state (gate_state) of the predicted end cell.
  auto end_flux = [&](const DamBoundary& b, int side, double x_end,
                      double bc) -> std::array<double, 2> {
    const auto e = at(side == 0 ? 0 : n - 1);
    // An inflow series: not the gate state at t + dt/2 (the series' discharge then, in every
    // branch of gate_state) but the step's exact volume, the integral of h u over the step, so that a hydrograph's volume does not depend on where the steps fall
    // (a gate shut inside a step admitted the midpoint's flux: -0.07 % with outputs every
    // 0.013 s against 0.05 s). Its momentum flux is the step's mean too (series_momentum).
    if (b.volume) {
      const auto m = series_momentum(b, side, dt, x_end, hm[e], hum[e]);
      return {series_discharge(b, side, dt), m[0] + bc * m[1]};
    }
    const auto s = gate_state(b, side, t_ + 0.5 * dt, x_end, hm[e], hum[e]);
    return {s[0] * s[1], s[0] * s[1] * s[1] + 0.5 * bc * s[0] * s[0]};
  };
  std::array<double, 2> F_left{0.0, 0.0}, F_right{0.0, 0.0};
  const auto K_range = phys_.K_bounds();
  const double beta_lo = phys_.g_cos * K_range[0], beta_hi = phys_.g_cos * K_range[1];

  // --- 6. corrector onto the other grid ------------------------------------------------------
  // primary -> staggered: new cell j (j = 0..n) sits between old cells j-1 and j;
  // staggered -> primary: new cell j (j = 0..n-2) sits between old cells j and j+1.
  const int nn = on_b ? n - 1 : n + 1;
  const int shift = on_b ? 0 : -1;
  h_new_.assign(static_cast<std::size_t>(nn), 0.0);
  hu_new_.assign(static_cast<std::size_t>(nn), 0.0);
  for (int j = 0; j < nn; ++j) {
    const auto L = at(j + shift), R = at(j + shift + 1);
    double hn, q, hmid;
    bool held = false;
    const double bc = beta_face(L, R);  // K of the new cell
    if (half_left && j == 0) F_left = end_flux(left_, 0, x0_, bc);
    if (half_right && j == nn - 1) F_right = end_flux(right_, 1, x1_, bc);
    if (!on_b && j == 0 && half_left) {
      // half cell [x0, x0 + dx/2]: the left half of old cell 0's reconstruction, the end flux
      // in, the flux at old cell 0's centre out (widths dx/2: factor 2 lam)
      hn = h[R] - 0.25 * sh[R] + 2.0 * lam * (F_left[0] - g0[R]);
      q = hu[R] - 0.25 * shu[R] + 2.0 * lam * (F_left[1] - g1(R, bc));
      hmid = hm[R] - 0.25 * sh[R];  // source at the half cell's centre x0 + dx/4
    } else if (!on_b && j == nn - 1 && half_right) {
      hn = h[L] + 0.25 * sh[L] + 2.0 * lam * (g0[L] - F_right[0]);
      q = hu[L] + 0.25 * shu[L] + 2.0 * lam * (g1(L, bc) - F_right[1]);
      hmid = hm[L] + 0.25 * sh[L];
    } else if (on_b && j == 0 && half_left) {
      // old cell 0 is the half cell (its average counts as it is); old cell 1 gives its left
      // half; fluxes: the end flux in at x0, old cell 1's centre flux out
      hn = 0.5 * h[L] + 0.5 * (h[R] - 0.25 * sh[R]) - lam * (g0[R] - F_left[0]);
      q = 0.5 * hu[L] + 0.5 * (hu[R] - 0.25 * shu[R]) - lam * (g1(R, bc) - F_left[1]);
      hmid = 0.5 * hm[L] + 0.5 * (hm[R] - 0.25 * sh[R]);
    } else if (on_b && j == nn - 1 && half_right) {
      hn = 0.5 * (h[L] + 0.25 * sh[L]) + 0.5 * h[R] - lam * (F_right[0] - g0[L]);
      q = 0.5 * (hu[L] + 0.25 * shu[L]) + 0.5 * hu[R] - lam * (F_right[1] - g1(L, bc));
      hmid = 0.5 * (hm[L] + 0.25 * sh[L]) + 0.5 * hm[R];
    } else {
      hn = 0.5 * (h[L] + h[R]) + 0.125 * (sh[L] - sh[R]) - lam * (g0[R] - g0[L]);
      q = 0.5 * (hu[L] + hu[R]) + 0.125 * (shu[L] - shu[R]) - lam * (g1(R, bc) - g1(L, bc));
      hmid = 0.5 * (hm[L] + hm[R]);
      // Coming to rest. The momentum after the step without friction is
      //   q*(beta) = A - lam beta dP,  A = inertia, advection and gravity,
      //   dP = (h_R^2 - h_L^2)/2 of the predicted depths (the pressure of the new cell).
      // Material at rest is statically indeterminate: its earth pressure can take any K
      // between K_act and K_pas (the two Rankine limits of the Mohr-Coulomb material). The cell
      // is at rest after the step if some such K lets the friction impulse absorb q*:
      //   min over beta in [beta_act, beta_pas] of |q*(beta)| <= dt g cos(zeta) tan(delta) h,
      // which for a layer at rest is |g sin(zeta) h - g cos(zeta) K h h_x| <= g cos(zeta)
      // tan(delta) h for some admissible K. Otherwise it moves with the K of its strain rate
      // (bc) and the friction reduces |hu| by its bound. With one K (Active, Passive,
      // Isotropic) the test is the usual one.
      const double A = 0.5 * (hu[L] + hu[R]) + 0.125 * (shu[L] - shu[R]) -
                       lam * (g1(R, 0.0) - g1(L, 0.0)) + dt * phys_.g_sin * hmid;
      const double dP = 0.5 * (hm[R] * hm[R] - hm[L] * hm[L]);
      held = comes_to_rest(A - lam * beta_lo * dP, A - lam * beta_hi * dP,
                           dt * phys_.g_cos * phys_.tan_delta * hmid,
                           on_b ? wall_side(j, nn) : 0);
    }
    q += dt * phys_.g_sin * hmid;
    const double fric = dt * phys_.g_cos * phys_.tan_delta * hmid;
    q = held ? 0.0 : std::copysign(std::max(std::abs(q) - fric, 0.0), q);
    // A near-dry new cell: its velocity q / hn is the ratio of two small differences and not
    // bounded by the scheme. The Riemann invariants u +- 2 sqrt(beta h) of the homogeneous
    // system take no value outside those of the cells the update reads (L-1 .. R+1), and a
    // cell of vanishing depth has u = R+ = R-, so its velocity lies in
    // [min(u - 2c), max(u + 2c)] of those cells, widened by what gravity adds in the step
    // (friction only brakes). A layer leaving a wall at 10 m/s, faster than 2c, opens a vacuum
    // there (the exact velocity stays in [u0 - 2 c0, u0]); cells of 1e-6 - 1e-3 m in it ran at
    // 20-82 m/s (an independent run, 2026-12-05). Applied below a tenth of the stencil's
    // deepest cell: a wet cell keeps the scheme's own velocity.
    if (hn > cfg_.dry_depth && !held && !wall_centred(j, nn, !on_b)) {  // (a wall cell: u = 0)
      double hmax = 0.0, rmax = -std::numeric_limits<double>::infinity(), rmin = -rmax;
      for (std::size_t k = L - 1; k <= R + 1; ++k) {
        hmax = std::max(hmax, h[k]);
        if (h[k] <= cfg_.dry_depth) continue;
        const double c = std::sqrt(beta_hi * h[k]);
        rmax = std::max(rmax, u[k] + 2.0 * c);
        rmin = std::min(rmin, u[k] - 2.0 * c);
      }
      if (hn < kThinFraction * hmax && rmax >= rmin) {
        const double du = dt * std::abs(phys_.g_sin);
        const double um = std::clamp(q / hn, rmin - du, rmax + du);
        if (um != q / hn) {
          q = um * hn;
          ++bounds_new_;
        }
      }
    }
    h_new_[static_cast<std::size_t>(j)] = hn;
    hu_new_[static_cast<std::size_t>(j)] = wall_centred(j, nn, !on_b) ? 0.0 : q;
  }

  // --- 7. what crossed the channel ends in this step (exact, from the update above) ---------
  // Summing the corrector over the new grid (end cells of a staggered grid weighted 1/2)
  // telescopes to old mass + the boundary terms below; they are recorded so that the mass
  // ledger closes to round-off (docs/numerics.md, "mass ledger"). At a prescribed inflow the
  // term is dt F exactly. At Outflow, Wall and Periodic ends the ghosts copy or mirror the
  // interior, so the slope and depth terms below vanish or cancel and what is booked is a flux
  // times dt; at an interface they are the overlap's half-cell terms, which the neighbour books
  // with the opposite sign to within the mismatch the coupled model reports.
  // The dx terms are the averaging onto the other grid (independent of dt); the dt terms are
  // the flux through the end (out_flux_new_, PendingStep::out_flux).
  double in_left, in_right, out_flux;
  if (!on_b) {
    const auto a = at(-1), b = at(0), c = at(n - 1), d = at(n);
    in_left = dx_ * (0.25 * (h[a] - h[b]) + (sh[a] + sh[b]) / 16.0) + 0.5 * dt * (g0[a] + g0[b]);
    out_flux = 0.5 * dt * (g0[c] + g0[d]);
    in_right = dx_ * (0.25 * (h[d] - h[c]) - (sh[c] + sh[d]) / 16.0) - out_flux;
  } else {
    in_left = dx_ * sh[at(0)] / 8.0 + dt * g0[at(0)];
    out_flux = dt * g0[at(n - 1)];
    in_right = -dx_ * sh[at(n - 1)] / 8.0 - out_flux;
  }
  if (half_left) in_left = dt * F_left[0];
  if (half_right) in_right = -(out_flux = dt * F_right[0]);
  in_new_ = in_left;
  out_new_ = -in_right;
  out_flux_new_ = out_flux;

  // --- 8. positivity and dry cells ------------------------------------------------------------
  fixes_new_ = 0;
  fix_positivity(h_new_, hu_new_, !on_b);
  for (std::size_t k = 0; k < h_new_.size(); ++k)
    if (h_new_[k] <= cfg_.dry_depth) hu_new_[k] = 0.0;
  t_new_ = t_ + dt;
  dt_min_ = steps_ == 0 ? dt : std::min(dt_min_, dt);
  dt_max_ = std::max(dt_max_, dt);
}

// ---------------------------------------------------------------------------------------------
// Semi-discrete central scheme (Kurganov & Tadmor 2000), DAM->Time stepping = Semi-discrete
// ---------------------------------------------------------------------------------------------
// The staggered scheme above averages its piecewise-linear reconstruction onto a grid shifted
// by dx/2 in every step, whatever dt; where the limiter clips (fronts, kinks, extrema) each
// average smooths by O(dx^2), so its numerical diffusion grows like dx^2 / dt and a run with
// dt held far below the stable step diffuses (docs/validation.md: Setup II to 0.1 s, the front
// at 0.14 m with dt = 4e-4 s and 0.29 m with 1e-6 s). Kurganov & Tadmor average only over the
// local Riemann fans, of width 2 a dt, and in the limit dt -> 0 obtain the semi-discrete form
//
//   d/dt w_j = -(H_{j+1/2} - H_{j-1/2}) / dx + S_j,
//   H_{j+1/2} = (f(w^-) + f(w^+)) / 2 - a_{j+1/2} (w^+ - w^-) / 2,
//
// w^-/+ the reconstructions of cells j and j+1 at the face (slopes as in the staggered scheme:
// Minmod or Beam-Warming, hu' = u h' in front cells), a the largest local speed |u| +
// sqrt(beta h) of the two. Its numerical viscosity is O(a dx), independent of dt, so a run
// converges as dt -> 0. Heun's method (the two-stage SSP Runge-Kutta scheme) integrates it in
// time: w1 = w + dt L(w), w2 = w1 + dt L(w1), w^{n+1} = (w + w2)/2, stable and positive for
// a dt / dx <= 1/2. The pressure part of the momentum flux is taken with the cell's own K,
// -beta_j (P_{j+1/2} - P_{j-1/2}) / dx with P = (h^-^2 + h^+^2)/4 (K fixed inside the cell, as
// in the staggered scheme), and each stage applies the bounded friction and the rest test of
// the staggered scheme. A prescribed inflow end is a face with the flux of the inflow state at
// the stage's time (so h_in u_in dt enters in a step: the mean of the two stages' fluxes);
// walls, outflow, periodic ends and interfaces use the ghost cells of the primary grid.
void DamSolver::euler_stage(const std::vector<double>& h0, const std::vector<double>& hu0,
                            double t, double dt, std::vector<double>& h1,
                            std::vector<double>& hu1, double& in, double& out) {
  const int n = n_;
  const double lam = dt / dx_;
  auto at = [](int j) { return static_cast<std::size_t>(j + G); };
  std::vector<double> h(static_cast<std::size_t>(n + 2 * G)), hu(h.size());
  std::copy(h0.begin(), h0.end(), h.begin() + G);
  std::copy(hu0.begin(), hu0.end(), hu.begin() + G);
  fill_ghosts(h, hu, n, false, t);
  const double dry = cfg_.dry_depth;
  std::vector<double> u(h.size()), beta(h.size());
  for (int j = -2; j < n + 2; ++j) u[at(j)] = velocity(h[at(j)], hu[at(j)]);
  for (int j = -2; j < n + 2; ++j) {
    const int jm = std::max(j - 1, -2), jp = std::min(j + 1, n + 1);
    const double ux = wet_ux(u[at(jm)], h[at(jm)] > dry, j - jm, u[at(j)], u[at(jp)],
                             h[at(jp)] > dry, jp - j, dx_);
    beta[at(j)] = phys_.g_cos * phys_.K(ux);
  }
  // slopes on cells -1 .. n
  std::vector<double> sh(h.size(), 0.0), shu(h.size(), 0.0);
  auto limit = [&](double dm, double dp, int j) {
    // Beam-Warming only where |h'| <= h (as in step_once, bw_ok); else minmod
    const auto k = at(j);
    const double d = u[k] >= 0.0 ? h[k] - h[k - 1] : h[k + 1] - h[k];
    if (cfg_.scheme == Scheme::Minmod || h[k] <= dry || std::abs(d) > h[k] || u[k] == 0.0)
      return minmod(dm, dp);  // at rest (u = 0): no upwind side, as in step_once
    return u[at(j)] > 0.0 ? dm : dp;
  };
  for (int j = -1; j <= n; ++j) {
    const auto k = at(j);
    sh[k] = limit(h[k] - h[k - 1], h[k + 1] - h[k], j);
    shu[k] = limit(hu[k] - hu[k - 1], hu[k + 1] - hu[k], j);
    if (h[k] > dry && (h[k - 1] <= dry || h[k + 1] <= dry)) shu[k] = u[k] * sh[k];
  }
  // face fluxes at faces f = 0..n (face f between cells f-1 and f, at x0 + f dx):
  // mass Hm, advective momentum Ha (hu^2/h part with its dissipation), pressure P (h^2/2)
  std::vector<double> Hm(static_cast<std::size_t>(n + 1)), Ha(Hm.size()), P(Hm.size());
  for (int f = 0; f <= n; ++f) {
    const auto L = at(f - 1), R = at(f);
    const auto fs = static_cast<std::size_t>(f);
    const DamBoundary* end = f == 0 ? &left_ : f == n ? &right_ : nullptr;
    if (end && end->type == BoundaryType::Inflow && end->prescribed) {
      const auto e = at(f == 0 ? 0 : n - 1);
      const int side = f == 0 ? 0 : 1;
      const double x_end = f == 0 ? x0_ : x1_;
      if (end->volume) {
        // an inflow series: both stages take the step's exact mean discharge (their mean is
        // then the step's volume; the stages' trapezoid rule depended on where steps fell) and
        // its mean momentum flux (series_momentum)
        const auto m = series_momentum(*end, side, dt, x_end, h[e], hu[e]);
        Hm[fs] = series_discharge(*end, side, dt);
        Ha[fs] = m[0];
        P[fs] = m[1];
      } else {
        const auto s = gate_state(*end, side, t, x_end, h[e], hu[e]);
        Hm[fs] = s[0] * s[1];
        Ha[fs] = s[0] * s[1] * s[1];
        P[fs] = 0.5 * s[0] * s[0];
      }
      continue;
    }
    double hl = std::max(0.0, h[L] + 0.5 * sh[L]), hr = std::max(0.0, h[R] - 0.5 * sh[R]);
    double ql = hu[L] + 0.5 * shu[L], qr = hu[R] - 0.5 * shu[R];
    if (hl <= dry) hl = 0.0, ql = 0.0;
    if (hr <= dry) hr = 0.0, qr = 0.0;
    const double ul = hl > 0.0 ? ql / hl : 0.0, ur = hr > 0.0 ? qr / hr : 0.0;
    const double a = std::max(std::abs(ul) + std::sqrt(beta[L] * hl),
                              std::abs(ur) + std::sqrt(beta[R] * hr));
    Hm[fs] = 0.5 * (ql + qr) - 0.5 * a * (hr - hl);
    Ha[fs] = 0.5 * (ql * ul + qr * ur) - 0.5 * a * (qr - ql);
    P[fs] = 0.25 * (hl * hl + hr * hr);
  }
  // update, with the bounded friction and the rest test of the staggered scheme
  const auto K_range = phys_.K_bounds();
  const double beta_lo = phys_.g_cos * K_range[0], beta_hi = phys_.g_cos * K_range[1];
  h1.assign(static_cast<std::size_t>(n), 0.0);
  hu1.assign(h1.size(), 0.0);
  for (int j = 0; j < n; ++j) {
    const auto k = at(j);
    const auto fl = static_cast<std::size_t>(j), fr = static_cast<std::size_t>(j + 1);
    h1[fl] = h[k] - lam * (Hm[fr] - Hm[fl]);
    const double A = hu[k] - lam * (Ha[fr] - Ha[fl]) + dt * phys_.g_sin * h[k];
    const double dP = P[fr] - P[fl];
    const double fric = dt * phys_.g_cos * phys_.tan_delta * h[k];
    const double q = A - lam * beta[k] * dP;
    hu1[fl] = comes_to_rest(A - lam * beta_lo * dP, A - lam * beta_hi * dP, fric, wall_side(j, n))
                  ? 0.0
                  : std::copysign(std::max(std::abs(q) - fric, 0.0), q);
  }
  in = dt * Hm.front();
  out = dt * Hm.back();
  fix_positivity(h1, hu1, false);
  for (std::size_t k = 0; k < h1.size(); ++k)
    if (h1[k] <= dry) hu1[k] = 0.0;
}

void DamSolver::step_semidiscrete(double dt) {
  fixes_new_ = 0;
  std::vector<double> h1, hu1, h2, hu2;
  double in1, out1, in2, out2;
  euler_stage(h_, hu_, t_, dt, h1, hu1, in1, out1);
  euler_stage(h1, hu1, t_ + dt, dt, h2, hu2, in2, out2);
  h_new_.assign(h_.size(), 0.0);
  hu_new_.assign(h_.size(), 0.0);
  for (std::size_t k = 0; k < h_.size(); ++k) {
    h_new_[k] = 0.5 * (h_[k] + h2[k]);
    // The stages never reverse the momentum, so neither does their mean. A cell that both
    // stages bring to rest (the first within dt from the state at t, the second from rest) has
    // stopped within the step: hu = 0 exactly, not the Heun mean hu^n / 2 (which would halve a
    // resting deposit's momentum every step and never reach 0).
    hu_new_[k] = (hu1[k] == 0.0 && hu2[k] == 0.0) ? 0.0 : 0.5 * (hu_[k] + hu2[k]);
    if (h_new_[k] <= cfg_.dry_depth) hu_new_[k] = 0.0;
  }
  in_new_ = 0.5 * (in1 + in2);
  out_new_ = 0.5 * (out1 + out2);
  out_flux_new_ = out_new_;  // a face flux times dt: no averaging term
  t_new_ = t_ + dt;
  dt_min_ = steps_ == 0 ? dt : std::min(dt_min_, dt);
  dt_max_ = std::max(dt_max_, dt);
}

// A negative depth (possible at wet/dry fronts with the limiter-free variant, and in rare
// round-off cases otherwise) is set to zero and its deficit is taken from the nearest wet cells,
// so h >= 0 holds and mass is conserved to round-off. Each fix is counted in summary.json.
void DamSolver::fix_positivity(std::vector<double>& h, std::vector<double>& hu, bool on_b) {
  const int n = static_cast<int>(h.size());
  auto weight = [&](int j) { return (on_b && (j == 0 || j == n - 1)) ? 0.5 : 1.0; };
  for (int j = 0; j < n; ++j) {
    auto k = static_cast<std::size_t>(j);
    if (h[k] >= 0.0) continue;
    ++fixes_new_;
    double deficit = -h[k] * weight(j);  // mass units / dx
    h[k] = 0.0;
    hu[k] = 0.0;
    for (int r = 1; r < n && deficit > 0.0; ++r) {
      for (int s : {j - r, j + r}) {
        if (s < 0 || s >= n || deficit <= 0.0) continue;
        auto ks = static_cast<std::size_t>(s);
        const double avail = h[ks] * weight(s);
        if (avail <= 0.0) continue;
        const double take = std::min(avail, deficit);
        const double frac = take / avail;
        h[ks] -= take / weight(s);
        hu[ks] *= (1.0 - frac);
        deficit -= take;
      }
    }
  }
}

core::Health DamSolver::check() const {
  core::Health hl;
  // the tentative state: on the other grid after a staggered step, the primary one otherwise
  const bool on_b = cfg_.time_stepping == TimeStepping::Staggered && !staggered_;
  const int n = static_cast<int>(h_new_.size());
  for (int j = 0; j < n; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const double x = x0_ + (on_b ? j : j + 0.5) * dx_;
    auto bad = [&](const char* q, double v, const char* why) {
      hl.ok = false;
      hl.quantity = q;
      hl.x = x;
      hl.value = v;
      hl.reason = why;
    };
    if (!std::isfinite(h_new_[k])) { bad("h", h_new_[k], "depth is not finite"); return hl; }
    if (!std::isfinite(hu_new_[k])) { bad("hu", hu_new_[k], "discharge is not finite"); return hl; }
    if (h_new_[k] < 0.0) { bad("h", h_new_[k], "negative depth"); return hl; }
    const double uv = velocity(h_new_[k], hu_new_[k]);
    if (std::abs(uv) > core::kMaxVelocity) { bad("u", uv, core::kMaxVelocityReason); return hl; }
  }
  return hl;
}

void DamSolver::accept() {
  h_.swap(h_new_);
  hu_.swap(hu_new_);
  staggered_ = staggered_new_;
  t_ = t_new_;
  ++steps_;
  mass_in_ += in_new_;
  mass_out_ += out_new_;
  last_transfer_ = {in_new_, out_new_};
  positivity_fixes_ += fixes_new_;
  thin_bounds_ += bounds_new_;
}

// Mass handed over at the left end between two steps (see the declaration). The cells are those
// of the current grid from the left end: on the staggered grid the first is the end cell centred
// at x0, of which mass() counts the half inside [x0, x0 + dx/2] (weight 1/2). Positive mass goes into the first cell;
// a removal leaves every cell at least half its depth, so it never empties one or flips a sign.
double DamSolver::take_interface_mass(double m, double u_dry) {
  if (h_.empty() || m == 0.0 || !std::isfinite(m)) return 0.0;
  auto width = [&](std::size_t k) { return (staggered_ && k == 0 ? 0.5 : 1.0) * dx_; };
  double placed = 0.0;
  if (m > 0.0) {
    const double w = width(0), h0 = h_[0];
    h_[0] += m / w;
    hu_[0] = h0 > cfg_.dry_depth ? hu_[0] * (h_[0] / h0) : h_[0] * u_dry;
    placed = m;
  } else {
    double rest = -m;
    for (std::size_t k = 0; k < h_.size() && rest > 0.0; ++k) {
      if (!(h_[k] > cfg_.dry_depth)) continue;
      const double take = std::min(rest, 0.5 * h_[k] * width(k)), h0 = h_[k];
      h_[k] -= take / width(k);
      hu_[k] *= h_[k] / h0;
      rest -= take;
      placed -= take;
    }
  }
  mass_in_ += placed;
  return placed;
}

// ---------------------------------------------------------------------------------------------
// Output
// ---------------------------------------------------------------------------------------------
void DamSolver::primary(std::vector<double>& h, std::vector<double>& hu) const {
  if (!staggered_) {
    h = h_;
    hu = hu_;
    return;
  }
  // Exact averages of the staggered minmod/upwind reconstruction over the primary cells.
  const int n = static_cast<int>(h_.size());
  std::vector<double> ph(static_cast<std::size_t>(n + 2 * G)), phu(ph.size());
  std::copy(h_.begin(), h_.end(), ph.begin() + G);
  std::copy(hu_.begin(), hu_.end(), phu.begin() + G);
  fill_ghosts(ph, phu, n, true, t_);
  auto at = [](int j) { return static_cast<std::size_t>(j + G); };
  auto sl = [&](const std::vector<double>& v, int j) {
    const double dm = v[at(j)] - v[at(j - 1)], dp = v[at(j + 1)] - v[at(j)];
    return wall_centred(j, n, true) ? 0.5 * (dm + dp) : minmod(dm, dp);
  };
  // The end cell at an Inflow end is the half cell inside the channel (see step()): its value
  // is its average, whatever the reconstruction's slope, so its slope counts as 0 here.
  const bool half_left = left_.type == BoundaryType::Inflow && left_.prescribed;
  const bool half_right = right_.type == BoundaryType::Inflow && right_.prescribed;
  auto slope = [&](const std::vector<double>& v, int j) {
    if ((j == 0 && half_left) || (j == n - 1 && half_right)) return 0.0;
    return sl(v, j);
  };
  h.assign(static_cast<std::size_t>(n_), 0.0);
  hu.assign(static_cast<std::size_t>(n_), 0.0);
  for (int j = 0; j < n_; ++j) {
    h[static_cast<std::size_t>(j)] =
        0.5 * (ph[at(j)] + ph[at(j + 1)]) + 0.125 * (slope(ph, j) - slope(ph, j + 1));
    hu[static_cast<std::size_t>(j)] =
        0.5 * (phu[at(j)] + phu[at(j + 1)]) + 0.125 * (slope(phu, j) - slope(phu, j + 1));
  }
}

std::array<double, 2> DamSolver::sample(double x) const {
  const int n = static_cast<int>(h_.size());
  std::vector<double> ph(static_cast<std::size_t>(n + 2 * G)), phu(ph.size());
  std::copy(h_.begin(), h_.end(), ph.begin() + G);
  std::copy(hu_.begin(), hu_.end(), phu.begin() + G);
  // Zero-gradient ghosts (not the boundary conditions): a coupled neighbour's ghosts call
  // sample(), so sampling must not call back into the neighbour. The end cells therefore have
  // zero slope, which is also what a one-sided limiter gives at an interface.
  for (int g = 1; g <= G; ++g) {
    ph[static_cast<std::size_t>(G - g)] = ph[G];
    phu[static_cast<std::size_t>(G - g)] = phu[G];
    ph[static_cast<std::size_t>(n + G - 1 + g)] = ph[static_cast<std::size_t>(n + G - 1)];
    phu[static_cast<std::size_t>(n + G - 1 + g)] = phu[static_cast<std::size_t>(n + G - 1)];
  }
  auto at = [](int j) { return static_cast<std::size_t>(j + G); };
  const double off = staggered_ ? 0.0 : 0.5;  // centre of cell j: x0 + (j + off) dx
  int j = static_cast<int>(std::floor((x - x0_) / dx_ - off + 0.5));
  j = std::clamp(j, 0, n - 1);
  const double xi = (x - x0_) / dx_ - (j + off);  // in [-1/2, 1/2] inside the cell
  auto rec = [&](const std::vector<double>& v) {
    const double dm = v[at(j)] - v[at(j - 1)], dp = v[at(j + 1)] - v[at(j)];
    const double s = wall_centred(j, n, staggered_) ? 0.5 * (dm + dp) : minmod(dm, dp);
    return v[at(j)] + xi * s;
  };
  const double hh = std::max(0.0, rec(ph));
  return {hh, hh > cfg_.dry_depth ? rec(phu) / hh : 0.0};
}

core::Profile DamSolver::profile() const {
  std::vector<double> h, hu;
  primary(h, hu);
  core::Profile p;
  for (int j = 0; j < n_; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const double u = velocity(h[k], hu[k]);
    // shallowness eps = 1/Fr^2 = beta h / u^2 (paper section 4.1), with beta from the local K;
    // dry cells report 0, resting material is capped at core::kEpsCap.
    const int jm = std::max(j - 1, 0), jp = std::min(j + 1, n_ - 1);
    const auto km = static_cast<std::size_t>(jm), kp = static_cast<std::size_t>(jp);
    const double ux = wet_ux(velocity(h[km], hu[km]), h[km] > cfg_.dry_depth, j - jm, u,
                             velocity(h[kp], hu[kp]), h[kp] > cfg_.dry_depth, jp - j, dx_);
    double eps = 0.0;
    if (h[k] > cfg_.dry_depth) {
      const double beta = phys_.g_cos * phys_.K(ux);
      eps = u != 0.0 ? std::min(core::kEpsCap, beta * h[k] / (u * u)) : core::kEpsCap;
    }
    p.append(x0_ + (j + 0.5) * dx_, h[k] > cfg_.dry_depth ? h[k] : 0.0, u, eps, "1D");
  }
  return p;
}

core::MassBalance DamSolver::mass_balance() const {
  core::MassBalance m;
  m.initial = mass0_;
  m.current = mass();
  m.inflow = mass_in_;
  m.outflow = mass_out_;
  return m;
}

// The cell of the fastest characteristic |u| + sqrt(beta h) (see stable_dt()).
std::string DamSolver::dt_limit() const {
  const auto x = centres();
  double amax = 0.0, xa = 0.0;
  for (std::size_t k = 0; k < h_.size(); ++k) {
    const double a = std::abs(velocity(h_[k], hu_[k])) +
                     std::sqrt(std::max(0.0, phys_.g_cos * phys_.K(0.0) * h_[k]));
    if (a > amax) amax = a, xa = x[k];
  }
  if (amax <= 0.0) return "no wave speed (the channel dry or at rest)";
  std::ostringstream os;
  os << "the CFL limit: |u| + sqrt(beta h) = " << amax << " m/s (beta at K(0)) at x = " << xa
     << " m";
  return os.str();
}

// The fastest wet cell of the current grid (primary or staggered): |hu / h| where h > dry.
core::Speed DamSolver::max_speed() const {
  core::Speed s;
  s.quantity = "u_mean";
  const auto x = centres();
  for (std::size_t k = 0; k < h_.size(); ++k) {
    const double u = std::abs(velocity(h_[k], hu_[k]));
    if (u > s.value) {
      s.value = u;
      s.x = x[k];
    }
  }
  return s;
}

void DamSolver::write_fields(io::FieldWriter& w) const {
  std::vector<double> h, hu;
  primary(h, hu);
  std::vector<double> xn(static_cast<std::size_t>(n_ + 1));
  for (int j = 0; j <= n_; ++j) xn[static_cast<std::size_t>(j)] = x0_ + j * dx_;
  std::vector<double> u(h.size());
  for (std::size_t k = 0; k < h.size(); ++k) u[k] = velocity(h[k], hu[k]);
  auto& m = w.add_mesh("dam", std::move(xn), {0.0, 1.0});
  m.cell_fields.emplace_back("h", h);
  m.cell_fields.emplace_back("u", u);
  m.cell_fields.emplace_back("hu", hu);
}

void DamSolver::save(io::Checkpoint& c) const {
  c.set("dam/t", t_);
  c.set("dam/steps", static_cast<double>(steps_));
  c.set("dam/staggered", staggered_ ? 1.0 : 0.0);
  c.set("dam/cells", static_cast<double>(n_));
  c.set("dam/x0", x0_);
  c.set("dam/x1", x1_);
  c.set("dam/mass0", mass0_);
  c.set("dam/mass_in", mass_in_);
  c.set("dam/mass_out", mass_out_);
  c.set("dam/positivity_fixes", static_cast<double>(positivity_fixes_));
  c.set("dam/thin_velocity_bounds", static_cast<double>(thin_bounds_));
  c.set("dam/h", h_);
  c.set("dam/hu", hu_);
}

void DamSolver::load(const io::Checkpoint& c) {
  if (static_cast<int>(c.scalar("dam/cells")) != n_ || c.scalar("dam/x0") != x0_ ||
      c.scalar("dam/x1") != x1_) {
    std::ostringstream os;
    os << "checkpoint grid (" << c.scalar("dam/cells") << " cells on [" << c.scalar("dam/x0")
       << ", " << c.scalar("dam/x1") << "]) does not match the scene (" << n_ << " cells on ["
       << x0_ << ", " << x1_ << "])";
    throw params::InputError(os.str());
  }
  t_ = c.scalar("dam/t");
  steps_ = static_cast<long>(c.scalar("dam/steps"));
  staggered_ = c.scalar("dam/staggered") != 0.0;
  mass0_ = c.scalar("dam/mass0");
  mass_in_ = c.scalar("dam/mass_in");
  mass_out_ = c.scalar("dam/mass_out");
  positivity_fixes_ = static_cast<long>(c.scalar("dam/positivity_fixes"));
  thin_bounds_ = c.has_scalar("dam/thin_velocity_bounds")  // (checkpoints before 2026-12-07)
                     ? static_cast<long>(c.scalar("dam/thin_velocity_bounds"))
                     : 0;
  h_ = c.array("dam/h");
  hu_ = c.array("dam/hu");
  if (staggered_ && cfg_.time_stepping == TimeStepping::SemiDiscrete) {
    // a checkpoint of the staggered scheme, continued semi-discretely: project onto the
    // primary grid (exact averages of the reconstruction, mass conserved)
    std::vector<double> h, hu;
    primary(h, hu);
    h_.swap(h);
    hu_.swap(hu);
    staggered_ = false;
  }
}

void DamSolver::report(nlohmann::json& s) const {
  s["dam"] = {{"cells", n_},
              {"dx", dx_},
              {"scheme", cfg_.scheme == Scheme::Minmod ? "Minmod" : "Beam-Warming"},
              {"time_stepping",
               cfg_.time_stepping == TimeStepping::Staggered ? "Staggered" : "Semi-discrete"},
              {"steps", steps_},
              {"dt_min", dt_min_},
              {"dt_max", dt_max_},
              {"positivity_fixes", positivity_fixes_},
              {"thin_velocity_bounds", thin_bounds_},
              {"K_active", phys_.K_act},
              {"K_passive", phys_.K_pas}};
}

void DamSolver::set_boundary(int side, DamBoundary b) {
  (side == 0 ? left_ : right_) = std::move(b);
}

void DamSolver::set_cells(std::vector<double> h, std::vector<double> hu, double t, long steps,
                          bool staggered) {
  if (h.size() != static_cast<std::size_t>(n_ + (staggered ? 1 : 0)) || hu.size() != h.size())
    throw std::invalid_argument("DamSolver::set_cells: need one value per cell");
  staggered_ = staggered;
  h_ = std::move(h);
  hu_ = std::move(hu);
  t_ = t_new_ = t;
  steps_ = steps;
  mass0_ = mass();
  mass_in_ = mass_out_ = 0.0;
  last_transfer_ = {0.0, 0.0};
}

}  // namespace granflow::dam
