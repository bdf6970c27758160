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
#include <deque>
#include <limits>
#include <string>

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
  // The no-slip clamps of the Coulomb faces are those of the solve's first evaluation (the
  // lagged step, q = p^n) in every later one (stuck_frozen_): decided anew at each q they make
  // P(q) jump and the fixed point cycle (ndam_solver.hpp).
  project(dt);
  if (!stuck_frozen_) {  // the first evaluation: its clamps, for the solve's later ones
    bed_stuck_first_ = bed_stuck_;
    wall_stuck_first_ = wall_stuck_;
    stuck_frozen_ = true;
    // The later evaluations' momentum matrices differ from this one only by nu_eff and the
    // friction factors at nearby trial pressures: they keep its last preconditioner while it
    // stays effective (a solve that fails with it is repeated with a fresh one). Measured on
    // Setup II at 5 mm to 1.5 s: the setups were 47 % of the nonlinear run's momentum time
    // (docs/validation.md). Released at the end of the solve, so that every step's first
    // assembly builds a fresh one, as the lagged run does (restarts stay exact).
    if (momentum_) momentum_->hold_preconditioner(true);
  }
  if (cfg_.momentum == Momentum::Implicit) {
    // The rotational correction of project(), -2 nu_rot div u*, at the predictor of the first
    // evaluation of the solve (q = p^n, the lagged step) instead of u*(q): see
    // solve_pressure_system. p_new_ += 2 nu_rot (div u*(q) - div u*(p^n)) undoes the change.
    const std::size_t n = static_cast<std::size_t>(nxl) * static_cast<std::size_t>(nz);
    const bool first = div_lagged_.size() != n;
    if (first) div_lagged_.assign(n, 0.0);
    for (int i = 0; i < nxl; ++i)
      for (int k = 0; k < nz; ++k) {
        const double chi = rotational_weight(i, k, dt);
        if (chi == 0.0) continue;
        const auto r = static_cast<std::size_t>(i * nz + k);
        const double d = divergence(u_star_, w_star_, i, k);
        if (first)
          div_lagged_[r] = d;
        else
          p_new_(i, k) += chi * nu_rot_(i, k) * (d - div_lagged_[r]);
      }
    if (!first) fill_scalar_ghosts(p_new_);
  }
  q_evaluated_ = q;
}

void NdamSolver::release_first_evaluation() {
  stuck_frozen_ = false;
  if (momentum_) momentum_->hold_preconditioner(false);
}

bool NdamSolver::pressure_dependent() const {
  return (!rheo_.newtonian() && rheo_.tau_p != 0.0) || cfg_.walls[1].kind == WallKind::Coulomb ||
         cfg_.walls[2].kind == WallKind::Coulomb;
}

// Anderson-accelerated fixed point (Anderson 1965; Walker & Ni 2011, "type II", mixing 1) on
// q = P(q). With g_k = P(q_k) and f_k = g_k - q_k (so R(q_k) = -f_k / (p_ref sqrt(N))):
//     q_{k+1} = g_k - sum_j gamma_j (g_{k-j+1} - g_{k-j}),
//     gamma = argmin || f_k - sum_j gamma_j (f_{k-j+1} - f_{k-j}) ||_2  over the last m differences,
// i.e. the combination of the last m + 1 fixed-point images whose linearised mismatch is
// smallest. m = 0 is the plain iteration q <- P(q). Every iteration costs one predictor-
// projection (no finite-difference Jacobian products); the least-squares problem is m x m
// (normal equations, reduced over ranks, the same on every rank). Convergence as for Newton:
// ||R|| <= Absolute tolerance or <= Relative tolerance ||R(p^n)||. A failed solve returns the
// best iterate found. The last evaluation is at the returned q when it converged, so the
// step's state P(q) needs no extra projection.
solvers::NonlinearStats NdamSolver::anderson_fixed_point(std::vector<double>& q, double dt) {
  const auto t0 = Clock::now();
  const auto& prm = cfg_.pressure_newton;
  const double atol = prm.get<double>("Absolute tolerance");
  const double rtol = prm.get<double>("Relative tolerance");
  const int maxit = prm.get<int>("Max Newton iterations");
  const bool verbose = prm.get<bool>("Verbose") && mac_.slab.rank == 0;
  const std::size_t m = static_cast<std::size_t>(cfg_.anderson_depth);
  const int nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
  const std::size_t n = q.size();
  auto dot = [this](const std::vector<double>& a, const std::vector<double>& b) {
    double l = 0.0, g = 0.0;
    for (std::size_t r = 0; r < a.size(); ++r) l += a[r] * b[r];
    MPI_Allreduce(&l, &g, 1, MPI_DOUBLE, MPI_SUM, comm_);
    return g;
  };
  solvers::NonlinearStats st;
  std::vector<double> g(n), f(n), g_prev, f_prev, q_best = q;
  std::deque<std::vector<double>> dF, dG;  // the last m differences of f and of g
  double r_best = std::numeric_limits<double>::infinity();
  for (int k = 0;; ++k) {
    project_at(q, dt);
    ++stats_.newton_evaluations;
    ++st.residual_evaluations;
    for (int i = 0; i < nxl; ++i)
      for (int kk = 0; kk < nz; ++kk) {
        const auto r = static_cast<std::size_t>(i * nz + kk);
        g[r] = p_new_(i, kk);
        f[r] = g[r] - q[r];
      }
    const double res = std::sqrt(dot(f, f)) * newton_scale_;
    st.residual_history.push_back(res);
    if (k == 0) st.initial_residual = res;
    if (verbose) {
      std::size_t rmax = 0;
      for (std::size_t r = 0; r < n; ++r)
        if (std::abs(f[r]) > std::abs(f[rmax])) rmax = r;
      const int ci = mac_.slab.i0 + static_cast<int>(rmax) / nz, ck = static_cast<int>(rmax) % nz;
      std::fprintf(stderr, "  Anderson %d: ||R|| = %.3e; largest P(q) - q of rank 0: %.3e in cell (%d, %d), q %.4g, flag %d, nu_eff %.3g\n", k, res,
                   f[rmax], ci, ck, q[rmax], static_cast<int>(mac_.gflag(ci, ck)), nu_(ci - mac_.slab.i0, ck));
    }
    st.newton_iterations = k;
    if (res < r_best) {
      r_best = res;
      q_best = q;
    }
    const std::string norms = "||R|| = " + detail::gstr(std::min(res, r_best)) +
                              " (||R0|| = " + detail::gstr(st.initial_residual) +
                              ", absolute tolerance " + detail::gstr(atol) +
                              ", relative tolerance " + detail::gstr(rtol) + ")";
    if (!std::isfinite(res)) {
      st.reason = "non-finite residual norm (NaN or Inf) after " + std::to_string(k) +
                  " Anderson iterations";
      break;
    }
    if (res <= atol || res <= rtol * st.initial_residual) {
      st.converged = true;
      st.reason = "converged after " + std::to_string(k) + " Anderson iterations: " + norms;
      break;
    }
    if (k == maxit) {
      st.reason = "maximum iterations (" + std::to_string(maxit) + ") reached: " + norms;
      break;
    }
    if (k > 0 && m > 0) {
      std::vector<double> df(n), dg(n);
      for (std::size_t r = 0; r < n; ++r) {
        df[r] = f[r] - f_prev[r];
        dg[r] = g[r] - g_prev[r];
      }
      dF.push_back(std::move(df));
      dG.push_back(std::move(dg));
      if (dF.size() > m) {
        dF.pop_front();
        dG.pop_front();
      }
    }
    f_prev = f;
    g_prev = g;
    // gamma from the normal equations (dF^T dF) gamma = dF^T f, Tikhonov-shifted by 1e-10 of
    // the largest diagonal entry (differences that are almost parallel get tiny weights
    // instead of huge cancelling ones); Gaussian elimination of an m x m matrix.
    const std::size_t mk = dF.size();
    std::vector<double> A(mk * mk), b(mk), gamma(mk, 0.0);
    double dmax = 0.0;
    for (std::size_t a = 0; a < mk; ++a) {
      b[a] = dot(dF[a], f);
      for (std::size_t c = a; c < mk; ++c) A[a * mk + c] = A[c * mk + a] = dot(dF[a], dF[c]);
      dmax = std::max(dmax, A[a * mk + a]);
    }
    for (std::size_t a = 0; a < mk; ++a) A[a * mk + a] += 1e-10 * dmax;
    for (std::size_t c = 0; c < mk; ++c) {  // symmetric positive definite: no pivoting
      for (std::size_t a = c + 1; a < mk; ++a) {
        const double l = A[a * mk + c] / A[c * mk + c];
        for (std::size_t e = c; e < mk; ++e) A[a * mk + e] -= l * A[c * mk + e];
        b[a] -= l * b[c];
      }
    }
    for (std::size_t c = mk; c-- > 0;) {
      double v = b[c];
      for (std::size_t e = c + 1; e < mk; ++e) v -= A[c * mk + e] * gamma[e];
      gamma[c] = v / A[c * mk + c];
    }
    q = g;
    for (std::size_t a = 0; a < mk; ++a)
      for (std::size_t r = 0; r < n; ++r) q[r] -= gamma[a] * dG[a][r];
  }
  if (!st.converged) q = q_best;
  st.final_residual = r_best;
  st.seconds = detail::seconds_since(t0);
  return st;
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
// coupling. The rotational correction -2 nu_rot div u* of the implicit scheme (projection.cpp)
// is a splitting correction, not part of eq. (10): it is evaluated at t^n data, nu_rot =
// nu_eff(u^n, p^n) and the predictor u* of the lagged step (q = p^n, the first evaluation),
// so that P depends on q only through F of eq. (8) and the projection. With u*(q) in it the
// map had no root with q >= 0 in wall-column cells below the free surface of Setup II (the
// term changes by O(nu_rot div u*) when nu_eff(q) stiffens a cell, nu_rot up to 0.5 m^2/s
// there) and every solver stalled there (docs/numerics.md, "Where Newton stalled").
// The state of the step is P at the converged q (so u^{n+1} and p^{n+1} belong to
// one projection); a Newton solve that fails marks the step for check().
void NdamSolver::solve_pressure_system(double dt) {
  const auto t0 = Clock::now();
  const int nxl = mac_.slab.nx_local, nz = cfg_.grid.nz;
  const std::size_t n = static_cast<std::size_t>(nxl) * static_cast<std::size_t>(nz);
  newton_dt_ = dt;
  div_lagged_.clear();  // the first evaluation (at q0 = p^n) records div u* of the lagged step
  release_first_evaluation();  // the first evaluation decides the clamps, builds its own
  newton_scale_ = 1.0 / (std::abs(phys_.gz) * cfg_.grid.lz *
                         std::sqrt(static_cast<double>(cfg_.grid.nx) * nz));
  // sized to the slab of this step: a load-balance rebuild (relayout) changes nx_local, and a
  // trial field of the old width was written past its end on two ranks (heap corruption)
  if (p_trial_.nx_local() != nxl || p_trial_.nz() != nz) p_trial_ = Field(nxl, nz);
  // R(q) = (q - P(q)) / (p_ref sqrt(N)), the residual of NOX's Newton-Krylov
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
  if (!newton_ && cfg_.pressure_iteration == PressureIteration::NewtonKrylov) {
    newton_ = std::make_unique<solvers::NonlinearSystem>(
        comm_, static_cast<long long>(cfg_.grid.nx) * nz, mac_.p_gid(mac_.slab.i0, 0), nxl * nz,
        cfg_.pressure_newton, residual, solvers::NonlinearSystem::Matrix{});
  }
  std::vector<double> q(n);
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) q[static_cast<std::size_t>(i * nz + k)] = p_(i, k);
  const double inner = stats_.step_momentum + stats_.step_pressure;
  newton_stats_ = cfg_.pressure_iteration == PressureIteration::Anderson
                      ? anderson_fixed_point(q, dt)
                      : newton_->solve(q);
  if (!newton_stats_.converged && cfg_.pressure_iteration == PressureIteration::Anderson &&
      cfg_.anderson_fallback && std::isfinite(newton_stats_.final_residual)) {
    // Anderson stalled ('Anderson fallback' = Newton-Krylov): NOX's Newton-Krylov goes on from
    // its best iterate q to Anderson's own target max(atol, rtol ||R(p^n)||). Anderson is a
    // secant method on P, which has a kink where a resting cell crosses p = 0 (nu_eff = nu +
    // tau_y m_y in a cell at rest: d nu_eff / dp is 0 below and sin(phi) m_y = 54 s above);
    // where many cells sit at the kink its differences mix both sides and it stalls (Setup II
    // at 2.6 mm, t = 1.477 s: ||R|| between 1.0e-3 and 3.8e-3 for 18 iterations against
    // 5.8e-4, in the deposit's bed cells). Newton's directional derivatives, taken at the
    // iterate, stay on one side: 3 Newton steps (33 projections) reached 2.9e-4 there. Built
    // for the step (rare), with the 'Pressure Newton' settings and the target as its absolute
    // tolerance.
    Teuchos::ParameterList prm = cfg_.pressure_newton;
    const double target = std::max(prm.get<double>("Absolute tolerance"),
                                   prm.get<double>("Relative tolerance") *
                                       newton_stats_.initial_residual);
    prm.set("Absolute tolerance", target);
    prm.set("Relative tolerance", 0.0);
    solvers::NonlinearSystem nk(comm_, static_cast<long long>(cfg_.grid.nx) * nz,
                                mac_.p_gid(mac_.slab.i0, 0), nxl * nz, prm, residual,
                                solvers::NonlinearSystem::Matrix{});
    const std::string anderson = newton_stats_.reason;
    const auto fb = nk.solve(q);
    ++stats_.newton_fallbacks;
    if (fb.converged) ++stats_.newton_fallbacks_converged;
    newton_stats_.converged = fb.converged;
    newton_stats_.final_residual = fb.final_residual;
    newton_stats_.newton_iterations += fb.newton_iterations;
    newton_stats_.krylov_iterations += fb.krylov_iterations;
    newton_stats_.residual_history.insert(newton_stats_.residual_history.end(),
                                          fb.residual_history.begin(),
                                          fb.residual_history.end());
    newton_stats_.reason = anderson + "; then Newton-Krylov ('Anderson fallback') from its best "
                           "iterate: " + fb.reason;
  }
  // the state of the step: P at the returned iterate (re-evaluated unless it was the last one)
  if (q != q_evaluated_) project_at(q, dt);
  release_first_evaluation();
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
