// N-DAM inflow and outflow: the silo gate at x = x0 and the 2D side of the paper's interfaces.
//
//  1D-to-2D interface (eqs. 24-27): the 2D inflow column takes the mean velocity of the 1D side,
//      u_mean^2D(x_IF) = u^1D(x_IF)                                           (24)
//    with the profile shape of the neighbouring 2D column, d/dx d/dz u = 0      (25)
//    the pressure of the depth-averaged model, p = g cos(zeta)(h - z)(1 + K)/2 (26)
//    and w from continuity, du/dx + dw/dz = 0                                 (27)
//    (w is the projection's: the inflow column stays in the projection unless eq. (26) is
//    imposed as a Dirichlet value). With an exact mass provider the step lets in exactly what
//    the DAM upstream let out in the same step; what cannot enter is carried (pending mass).
//  Silo gate: u = u_in over the opening 0 <= z < h_in (Uniform) or the interior shape (25).
//  2D-to-1D interface: an open outflow that continues the lagged velocity gradient.
// The markers that enter are injected row by row (MarkerSet::inject) with the face velocities.
#include "stencil.hpp"

#include "granflow/params/parameters.hpp"

#include <algorithm>
#include <cmath>

namespace granflow::ndam {

namespace {
// Exact transfer through a 1D-to-2D interface (eq. 24: the 2D side's mean velocity is the 1D
// side's). The opening takes the provider's |u_mean| and lets the step's mass in through its
// depth, mass / (dt |u_mean|), up to kInflowDeepen times the provider's depth (at the DAM's tip
// the reconstruction's depth at x_IF lags the flux that its ledger lets out); beyond that the
// velocity rises, up to |u_mean| + a speed floor. While the provider's u_mean is below the
// floor (0.089 m/s at 5 mm cells on 50 deg, a few per cent of the chute's 0.4-3 m/s: a front
// arriving) the opening keeps the provider's depth and the velocity carries the mass, up to the
// same cap. Before
// 2026-12-02 the velocity always carried the mass through the provider's depth; every
// fluctuation of the step's mass then became one of the inflow velocity (below, the DAM's
// averaging term), and the first 2D columns ran the slower the shorter the step (10 mm, a third
// of the stable step: 1.2 % slower; 5 mm, steps of 2e-4 s: 4-5 %). Earlier still the velocity
// took up to 1.5 |u_mean| + 0.1 m/s and the tip's first markers were the fastest cells of every
// coupled run (5.05 m/s against the 4.48 m/s bound of the free-slip case; docs/validation.md,
// "Stability suite").
constexpr double kInflowDeepen = 1.5;
// Below this inflow depth, in cells, the step takes nothing: a film of 1/50 of a cell (0.1 mm at
// the paper's 5 mm) would need u = mass / (dt h) far above the cap to carry the mass. What is
// not taken is carried to the next steps (pending mass), so no mass is lost.
constexpr double kInflowMinDepthCells = 1.0 / 50.0;
// The speed floor in units of the grid's gravity-wave speed sqrt(g cos(zeta) dz). Both
// thresholds are in units of the grid, so that a scene scaled by Froude similarity (lengths x s,
// times and speeds x sqrt(s)) takes the same branches: until 2026-12-06 they were 1e-4 m and
// 0.1 m/s, and Setup II scaled by 4 departed by 4 % in h at 0.5 s where the DAM's tip arrived
// (`DomainManager.FroudeScaledSetupIIIsTheScaledRun`).
constexpr double kInflowSpeedupFloorWaves = 0.5;
// A first interior column whose mean velocity is below this has no profile shape to copy
// (eq. 25): it is at rest or empty, and the opening takes the uniform profile.
constexpr double kShapeMinMean = 1e-12;  // [m/s]
// The largest ratio of an inflow face to the opening's mean velocity that the copied shape may
// give (eq. 25). Chute profiles stay well below it: a plug 1, Bagnold's 5/3, a Newtonian
// half-parabola 3/2. A disturbed first column (a row still fast while the rows beside it have
// stopped or turned back) has a small positive mean and one row far above it, and the copy then
// scaled that row by um / mean: faces of +195 m/s from a 1.27 m/s inflow in the cascade of
// docs/validation.md ("Beyond the impact"). Such a shape is blended towards the uniform one,
// s = 1 + theta (s_copy - 1) with the largest theta in [0, 1] that keeps s <= kShapeMax; both
// shapes have the mean 1 over the opening, so the blend lets in the same mass.
constexpr double kShapeMax = 2.0;
// The DAM's ledger term of a step is dt times its end flux plus an averaging term of the
// staggered scheme (DamSolver::PendingStep::out_flux), O(dx^2 h_x) whatever dt and alternating in
// sign with the grid from step to step (with a mean of 1-2 % of the step's mass in steady Setup
// I): only the sum over steps is smooth. In steps of 2e-4 s (Setup I coupled, 5 mm) it was
// 5-20 % of a step's mass; in a step that lands on an output time (1/93 of the stable one in
// Setup II coupled) it outweighed the flux with either sign. The averaging terms wait in a pool
// of their own (inflow_held_) that enters at the rate the flow crosses one 2D cell, a fraction
// min(1, dt (|u_mean| + u_floor) / dx) of the pool per step: a time scale of the flow and the
// grid, not of dt. A step lets in at most kHeldRelease of its flux's mass from the pool (or the
// step's own averaging term, where that is more, so that the pool drains as fast as it fills),
// so that the opening's depth stays within that fraction of the DAM's: the pool also takes the
// carried mass of a gate that a move made interior (coupling::rebuild), up to one marker per
// row, which would otherwise open the new first column a row deeper than the layer.
constexpr double kHeldRelease = 0.1;
}  // namespace

// The gate state of a step (lagged at t^n): {h_in, u_in} from the provider; with an exact mass
// (a 1D-to-2D interface) the velocity that lets in what the upstream side let out; then the
// boundary faces with it.
void NdamSolver::gate_state(double dt) {
  inflow_now_ = cfg_.inflow ? cfg_.inflow(t_) : std::array<double, 2>{0.0, 0.0};
  inflow_owed_new_ = inflow_owed_;
  inflow_held_new_ = inflow_held_;
  if (inflow_mass_) {
    if (const auto m = inflow_mass_(t_, dt)) {
      // Exact transfer: the step lets in what the upstream side let out (plus what earlier
      // steps could not take), at the DAM's u_mean through an opening whose depth the mass sets
      // (up to kInflowDeepen h, then faster up to |u_mean| + u_floor), from a depth of at least
      // kInflowMinDepthCells dz; the rest waits for the next steps. The DAM's
      // averaging term (m->held) joins the held pool, of which the step lets in its share.
      const double h = inflow_now_[0], um = std::abs(inflow_now_[1]);
      const double dz = cfg_.grid.dz();
      const double u_floor = kInflowSpeedupFloorWaves * std::sqrt(std::abs(phys_.gz) * dz);
      const double ucap = um + u_floor;
      const double pool = inflow_held_ + m->held;
      const double share = std::min(1.0, dt * ucap / cfg_.grid.dx());
      const double cap = std::max(kHeldRelease * std::abs(m->mass - m->held), std::abs(m->held));
      const double release = std::clamp(share * pool, -cap, cap);
      const double flowing = (m->mass - m->held) + inflow_owed_ + release;
      double u = 0.0, depth = h;
      if (h > kInflowMinDepthCells * dz && flowing > 0.0) {
        if (um > u_floor) {  // eq. (24): the DAM's u_mean; the mass sets the depth
          u = um;
          depth = flowing / (dt * u);
          if (depth > kInflowDeepen * h) {
            depth = kInflowDeepen * h;
            u = std::min(flowing / (dt * depth), ucap);
          }
        } else {  // a front arriving: the velocity carries the mass
          u = std::min(flowing / (dt * h), ucap);
          if (u == ucap) depth = std::min(flowing / (dt * ucap), kInflowDeepen * h);
        }
      }
      inflow_now_ = {depth, u};
      inflow_held_new_ = pool - release;
      inflow_owed_new_ = flowing - u * dt * depth;
    }
  }
  fill_velocity_ghosts(u_, w_);
}

// Inflow velocity of row k of the gate opening 0 <= z < h_in: the material velocity of the row
// (u_in(z) on its open part), like every face of a partly filled Surface cell inside the box; the
// mass that enters is the markers' (accept(): each row's open part times its face value, so the
// total is h_in u_mean). Uniform: u_in(z) = u_in. CopyInterior (eq. 25): the shape of the first
// interior column u(0,k), scaled so that its mean over the opening [0, h_in] is u_in.
// A row only partly below h_in is the top material row: it carries the full material velocity
// like the interior faces of that row (not u_in times its open part, which slows the top row and,
// copied back through the profile shape, turns the profile over; docs/numerics.md).
double NdamSolver::inflow_face(int k) const {
  const double h = inflow_now_[0], um = inflow_now_[1], dz = cfg_.grid.dz();
  if (!(h > 0.0)) return 0.0;
  const double open = std::clamp((h - k * dz) / dz, 0.0, 1.0);
  if (open <= 0.0) return 0.0;
  if (cfg_.inflow_shape == InflowShape::Uniform || mac_.slab.i0 != 0) return um;
  // shape from column 0 (this rank owns it): mean of the shape over the opening. Rows where
  // column 0 flows back (u < 0: a shock from the wall reaching the interface, a viscous layer
  // turning over behind the opening) take no part: an inflow face lets nothing out, and markers
  // enter only through rows of positive flux (MarkerSet::inject_rows), so a negative row's share
  // was booked as mass let in that no marker carried (the static lab chute, whose shock reaches
  // the 1D -> 2D interface at 1.8 m near 2.1 s: 9.3e-4 m^2 made).
  double q = 0.0, top = 0.0;
  for (int kk = 0; kk < cfg_.grid.nz; ++kk) {
    const double o = std::clamp((h - kk * dz) / dz, 0.0, 1.0);
    if (o <= 0.0) break;
    q += o * dz * std::max(u_(0, kk), 0.0);
    top = std::max(top, u_(0, kk));
  }
  const double mean = q / h;
  if (!(mean > kShapeMinMean)) return um;  // no shape yet (or none flowing in): uniform
  if (top <= kShapeMax * mean) return um * std::max(u_(0, k), 0.0) / mean;
  const double theta = (kShapeMax - 1.0) / (top / mean - 1.0);  // the bounded blend (kShapeMax)
  return um * (1.0 + theta * (std::max(u_(0, k), 0.0) / mean - 1.0));
}

// Lagged gradient continued through an open outflow (NdamConfig::outflow_extrapolate): the
// difference of the last two interior faces of row k in the current state u_, where both are
// material faces and it is positive; 0 otherwise (zero gradient) and on ranks that do not own
// the end. The accelerating chute it is there for changes by a dx / u^2 = 1.5 % per cell at the
// 2D -> 1D interface of Setup I (5 mm, a = 5 m/s^2, u = 1.3 m/s; 3 % at 10 mm); with zero
// gradient the last two or three columns there ran up to 4 % slow (Setup II coupled at 5 mm:
// u_mean L2 2.6 % against full 2D at 0.75 s instead of 0.8 %).
// Only an accelerating difference is continued. The projection takes the outflow face as given
// (no phi flux through it), so an outflow slower than the interior leaves a divergence deficit
// in the last cell that the projection removes by slowing the interior faces, which makes the
// lagged difference more negative: a feedback. A layer released from rest on 25 deg (delta 22,
// 2D [0, 1] / 1D [1, 2] m; an independent run, 2026-12-06) ran into the bound below within
// 0.2 s and its rigid plug was braked whole: 0.75 / 0.64 of a t at t = 1 s at 5 / 2.5 mm (full
// 2D 1.02), its bed pressure up to 2.2 times hydrostatic. With the difference taken at 0 or
// above: 1.00-1.05 / 1.00-1.02; the shipped coupled scenes never continue a decelerating
// difference (setup2_coupled.xml's profiles.csv identical). It is also bounded above by
// kOutflowSlopeMax of the last face's speed: unbounded, the lagged difference fed itself back
// where a deep viscous layer reached the end of the gate's 2D part (nu = 0.3 m^2/s: 39-710 m/s
// in its last columns, depending on the output interval; 2.3-2.8 m/s bounded;
// docs/validation.md, "Stability suite").
constexpr double kOutflowSlopeMax = 0.05;
double NdamSolver::outflow_slope(int k) const {
  const int nx = cfg_.grid.nx, i = nx - 2 - mac_.slab.i0;
  if (!cfg_.outflow_extrapolate || mac_.slab.i0 + mac_.slab.nx_local != nx || i - 1 < -Field::G) return 0.0;
  if (!mac_.u_unknown(i, k) || !mac_.u_unknown(i - 1, k)) return 0.0;
  const double bound = kOutflowSlopeMax * std::abs(u_(i, k));
  return std::clamp(u_(i, k) - u_(i - 1, k), 0.0, bound);
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
  cfg_.inflow_volume = nullptr;  // an interface's inflow: its own ledger (inflow_mass_)
  cfg_.inflow_shape = shape;
  cfg_.inflow_pressure = pressure;
  cfg_.inflow_K = K;
  inflow_mass_ = std::move(mass);  // the carried mass inflow_owed_ is state: it stays
  inflow_now_ = cfg_.inflow ? cfg_.inflow(t_) : std::array<double, 2>{0.0, 0.0};
  mac_.dirichlet_inflow_column = pressure == InflowPressure::Dirichlet;
  flags_changed_ = true;  // the Dirichlet cells of eq. (26) may have changed
  fill_velocity_ghosts(u_, w_);
  update_profile_cache();  // u_mean of the inflow column reads the new inflow face
}

// Markers of the gate: the open part of each row enters with the material velocity of its
// face in the new state, u(-1, k) (the owner of column 0 injects).
void NdamSolver::inject_markers(double dt, MarkerSet& markers) const {
  if (!cfg_.inflow || mac_.slab.i0 != 0) return;
  // An inflow series admits the exact volume of the step (and flushes its rows' remainders
  // when the gate closes: MarkerSet::inject); a constant gate or a 1D-to-2D interface the
  // strips' fluxes at t^n.
  const double volume = cfg_.inflow_volume ? cfg_.inflow_volume(t_, t_ + dt) : -1.0;
  if (!(inflow_now_[0] > 0.0) && volume < 0.0) return;
  std::vector<double> uf(static_cast<std::size_t>(cfg_.grid.nz), 0.0);
  const double dz = cfg_.grid.dz();
  for (int k = 0; k < cfg_.grid.nz; ++k) {
    const double open = std::clamp((inflow_now_[0] - k * dz) / dz, 0.0, 1.0);
    if (open > 0.0) uf[static_cast<std::size_t>(k)] = u_new_(-1, k);  // material velocity of the open part
  }
  markers.inject(dt, inflow_now_[0], uf, volume);
}

std::vector<double> NdamSolver::inflow_faces() const {
  std::vector<double> f(static_cast<std::size_t>(cfg_.grid.nz), 0.0);
  if (mac_.slab.i0 == 0 && !cfg_.periodic_x())  // the owner of column 0; the others add zeros
    for (int k = 0; k < cfg_.grid.nz; ++k) f[static_cast<std::size_t>(k)] = u_(-1, k);
  MPI_Allreduce(MPI_IN_PLACE, f.data(), cfg_.grid.nz, MPI_DOUBLE, MPI_SUM, comm_);
  return f;
}

double NdamSolver::inflow_pending() const {
  if (!markers_) return 0.0;
  const double acc = markers_->inflow_pending_markers();
  double all = 0.0;
  MPI_Allreduce(&acc, &all, 1, MPI_DOUBLE, MPI_SUM, comm_);
  return inflow_owed_ + inflow_held_ + all * markers_->marker_area();
}

}  // namespace granflow::ndam
