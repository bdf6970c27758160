// N-DAM nonlinear pressure system (paper section 2.3: eqs. 10 + 13 + 14 with tau_y and the
// Coulomb law at the new pressure), 'Pressure coupling' = Nonlinear.
//
// With a pressure-dependent yield stress tau_y = tau_c + tau_p p (6) and the sliding law (13),
// F of eq. (8), and hence the right-hand side of the pressure equation (10), depend on p itself.
// One step is the fixed point q = P(q) of the predictor-projection P whose nu_eff and friction
// factors are evaluated at the trial pressure q; NOX's Newton-Krylov method solves
// R(q) = q - P(q) = 0 (solvers/nonlinear_system). The paper used Powell's hybrid method.
#include "stencil.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace granflow::ndam {

using detail::Clock;

// P(q): nu_eff(u^n, q) and the friction factors at the trial pressure q (this rank's cells,
// i * nz + k), then one predictor-projection into u_new_, w_new_, p_new_.
void NdamSolver::project_at(const std::vector<double>& q, double dt) {
  const int nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
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
  const int nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
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
      ++stats_.newton_evaluations;
    };
    newton_ = std::make_unique<solvers::NonlinearSystem>(
        comm_, static_cast<long long>(cfg_.grid.nx) * nz, mac_.p_gid(mac_.slab.i0, 0), nxl * nz,
        cfg_.pressure_newton, residual, solvers::NonlinearSystem::Matrix{});
  }
  std::vector<double> q(n);
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) q[static_cast<std::size_t>(i * nz + k)] = p_(i, k);
  const double inner = stats_.step_momentum + stats_.step_pressure;
  newton_stats_ = newton_->solve(q);
  // the state of the step: P at the returned iterate (re-evaluated unless it was the last one)
  if (q != q_evaluated_) project_at(q, dt);
  ++stats_.newton_solves;
  stats_.newton_iterations += newton_stats_.newton_iterations;
  stats_.newton_krylov += newton_stats_.krylov_iterations;
  stats_.newton_max_iterations = std::max(stats_.newton_max_iterations, newton_stats_.newton_iterations);
  stats_.newton_worst_residual = std::max(stats_.newton_worst_residual, newton_stats_.final_residual);
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
        if (r > loc.v) loc = {r, (mac_.slab.i0 + i) * nz + k};
      }
    MPI_Allreduce(&loc, &glob, 1, MPI_DOUBLE_INT, MPI_MAXLOC, comm_);
    newton_fail_cell_ = {(glob.cell / nz + 0.5) * cfg_.grid.dx() + cfg_.x0,
                         (glob.cell % nz + 0.5) * cfg_.grid.dz(), glob.v};
  }
  if (newton_failed_ && cfg_.newton_failure_continue) {
    // 'Pressure Newton failure' = Continue: the step keeps the best iterate NOX returned (the
    // line search only accepts decreasing ||R||); counted and reported, never silent.
    newton_failed_ = false;
    ++stats_.newton_continued;
    stats_.newton_continued_worst = std::max(stats_.newton_continued_worst, newton_stats_.final_residual);
    if (stats_.newton_continued == 1 && mac_.slab.rank == 0)
      std::fprintf(stderr,
                   "\ngranflow: warning: the N-DAM pressure Newton solve did not converge in the "
                   "step from t = %g s (%s); continuing with its best iterate ('Pressure Newton "
                   "failure' = Continue); such steps are counted in summary.json "
                   "(ndam.newton.unconverged_steps_continued)\n",
                   t_, newton_stats_.reason.c_str());
  }
  // Newton's own work (NOX, GMRES vectors) counts as pressure time; the momentum predictors
  // inside the residual evaluations stay in the momentum phase.
  const double total = detail::seconds_since(t0);
  stats_.newton_seconds += total;
  stats_.step_pressure += std::max(0.0, total - (stats_.step_momentum + stats_.step_pressure - inner));
}

}  // namespace granflow::ndam
