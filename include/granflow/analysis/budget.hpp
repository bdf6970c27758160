#pragma once
// The depth-averaged x-momentum budget of a 2D (N-DAM) chute run, from its output fields
// (granflow-study budget; issue 11 item 4). Integrating the x-momentum equation of the 2D model
// (per unit density) over the depth, with the kinematic condition at the free surface and the
// traction-free surface, gives
//
//   d/dt int_0^h u dz + d/dx int_0^h u^2 dz
//       = g sin(zeta) h - d/dx int_0^h p dz + d/dx int_0^h 2 nu_eff u_x dz - tau_b + R,
//
// i.e. with u_mean = 1/h int u dz and the shape factor alpha = <u^2> / <u>^2,
//   d(h u_mean)/dt + d(alpha h u_mean^2)/dx = gravity + pressure + viscous - friction + R.
// The shear stress integrates to its values at the bed (tau_b, the Coulomb law there) and at the
// surface (zero); the normal viscous/plastic stress 2 nu_eff u_x stays as a depth-integrated
// divergence. R is what the 2D solution leaves unbalanced when the budget is evaluated on its
// output fields with centred differences: a discretisation loss (it shrinks with dx) or the
// error of the evaluation itself (also O(dx)). The DAM closes the same budget with alpha = 1,
// int p dz = K g cos(zeta) h^2 / 2, no viscous term and tau_b = tan(delta) g cos(zeta) h.
//
// Column integrals take the cell-centre values with the weights of the profile's u_mean (eq. 21,
// MarkerSet::profile): full cells below the marker depth h and the fraction (h - k dz) / dz of
// the cell containing it, so that int u dz is exactly h u_mean of profiles.csv; or
// (BudgetPhysics::cell_weights) every material cell whole.
#include <functional>
#include <string>
#include <vector>

namespace granflow::analysis {

/// The physics of the run (from its summary.json parameters).
struct BudgetPhysics {
  double g = 9.81;
  double zeta = 0.0;          ///< slope [rad]
  double tan_delta = 0.0;     ///< bed friction
  double m_c = 100.0;         ///< friction regularisation [s/m] (eq. 12)
  std::string bed = "Coulomb";  ///< the N-DAM's Bottom wall: Coulomb, No-slip or Free-slip
  /// Column weights: false, the markers' depth (the profile's u_mean, eq. 21); true, every
  /// material (Fluid or Surface) cell whole, h = their number times dz: the column the discrete
  /// momentum equation moves and weighs (a Surface cell is a full cell of its unknowns, its
  /// gravity and its pressure). The two differ by up to a cell height.
  bool cell_weights = false;
};

/// One 2D snapshot: cell-centred fields, z-major (k * nx + i), as fields.h5 stores them, and
/// the marker depth of each column (profiles.csv).
struct Snapshot2D {
  double t = 0.0;
  int nx = 0, nz = 0;
  double x0 = 0.0, dx = 0.0, dz = 0.0;
  std::vector<double> u, p, nu, flag;  ///< p and nu per unit density (m^2/s^2, m^2/s)
  std::vector<double> h;               ///< per column
};

/// The column integrals of one snapshot (per unit width and density).
struct ColumnIntegrals {
  std::vector<double> h, Q, M, P, T;  ///< h, int u, int u^2, int p, int 2 nu u_x  (dz)
  std::vector<double> p_b;            ///< bottom pressure taken to the bed (+ g cos dz / 2)
  std::vector<double> tau_applied;    ///< the bed stress the model's Coulomb law applies
  std::vector<double> tau_bound;      ///< tan(delta) p_b sgn(u_b)
};
ColumnIntegrals column_integrals(const Snapshot2D& s, const BudgetPhysics& ph);

/// The budget of each column, the time means over the snapshots (terms in m^2/s^2 per unit
/// density; times rho: N/m^2), every term on the right-hand side with its sign:
///   residual = dQdt + flux - gravity - pressure - viscous - friction (friction = -tau_b).
struct ColumnBudget {
  std::vector<double> x, h, u_mean, alpha;
  std::vector<double> dQdt, flux, gravity, pressure, viscous, friction, friction_bound;
  std::vector<double> residual, residual_bound;  ///< with the applied / the bound friction
  std::vector<double> p_b;                       ///< mean bottom pressure [m^2/s^2]
  double t0 = 0.0, t1 = 0.0;
  int snapshots = 0;
};
/// The time-mean budget of snapshots of one run (same grid; at least two, in time order):
/// dQ/dt = (Q(t_last) - Q(t_first)) / (t_last - t_first) (the time mean of the derivative),
/// the x-derivatives centred on the time means (one-sided at the ends).
ColumnBudget momentum_budget(const std::vector<ColumnIntegrals>& columns,
                             const std::vector<double>& times, double x0, double dx,
                             const BudgetPhysics& ph);

/// The same budget with the DAM's closure from its depth-averaged profiles (alpha = 1,
/// int p dz = K g cos(zeta) h^2 / 2 with K(u_x) given, tau_b = tan(delta) g cos(zeta) h
/// sgn(u)): h and u_mean of each snapshot on cell centres x0 + (i + 1/2) dx.
ColumnBudget dam_budget(const std::vector<std::vector<double>>& h,
                        const std::vector<std::vector<double>>& u,
                        const std::vector<double>& times, double x0, double dx,
                        const BudgetPhysics& ph, const std::function<double(double)>& K);

/// Sums of the terms times dx over the columns with centres in [xa, xb] [m^3/s^2], and the mean
/// discharge there: each sum / q is the velocity change that term gives the flow over the
/// stretch in a steady state (d(alpha u_mean) = term dx / q).
struct StretchBudget {
  double xa = 0.0, xb = 0.0, q = 0.0;
  double dQdt = 0.0, flux = 0.0, gravity = 0.0, pressure = 0.0, viscous = 0.0, friction = 0.0,
         friction_bound = 0.0, residual = 0.0, residual_bound = 0.0;
  int columns = 0;
};
StretchBudget stretch(const ColumnBudget& b, double xa, double xb);

}  // namespace granflow::analysis
