#pragma once
// Counters and timers of an N-DAM run, in one place. They belong to the run, not to the box: a
// subdomain that is rebuilt for a new extent (the domain manager) hands them to its successor,
// so summary.json counts every step of the run.
#include <algorithm>

namespace granflow::ndam {

struct NdamStatistics {
  // time steps
  double dt_min = 0.0, dt_max = 0.0;
  double max_divergence = 0.0;  ///< largest max |div u| of an accepted state [1/s]

  // linear solves (Belos): pressure projection and implicit momentum predictor
  long long pressure_solves = 0, pressure_iterations = 0;
  long long momentum_solves = 0, momentum_iterations = 0;
  // pressure solves with the stiff preconditioner (MueLu from 'Stiff threshold' on), the most
  // iterations of one, and the largest distance d (cells) from an unknown to the free surface
  long long pressure_stiff_solves = 0;
  int pressure_max_iterations = 0;
  double pressure_max_distance = 0.0;
  // momentum solves with the stiff preconditioner ('Stiff threshold') and their iterations;
  // the most iterations of one momentum solve, and of one with the stiff preconditioner
  long long momentum_stiff_solves = 0, momentum_stiff_iterations = 0;
  int momentum_max_iterations = 0, momentum_stiff_max_iterations = 0;
  long long unconverged_solves = 0;
  double worst_pressure_residual = 0.0, worst_momentum_residual = 0.0;
  // preconditioner work of the linear systems that earlier layouts owned (added at a rebuild)
  long long retired_pressure_setups = 0, retired_momentum_setups = 0;
  long long retired_pressure_patterns = 0, retired_momentum_patterns = 0;
  double retired_pressure_setup_seconds = 0.0, retired_momentum_setup_seconds = 0.0;
  double retired_pressure_krylov_seconds = 0.0, retired_momentum_krylov_seconds = 0.0;
  long long retired_preconditioner_retries = 0;  // solves repeated with a fresh preconditioner

  // markers moved into enclosed voids of the sampling (NdamSolver::fill_marker_voids), and the
  // steps that moved any
  long long marker_void_fills = 0, marker_void_steps = 0;

  // the Coulomb friction of the step (Newton's method in the momentum step): solves beyond the
  // first of a step, the most solves of a step, steps that stopped at the limit and their worst
  // residual (in units of the Coulomb bound)
  long long friction_solves = 0, friction_unconverged = 0;
  int friction_max_solves = 0;
  double friction_worst_residual = 0.0;

  // the nonlinear pressure system (NOX), 'Pressure coupling' = Nonlinear
  long long newton_solves = 0, newton_iterations = 0, newton_krylov = 0, newton_evaluations = 0;
  int newton_max_iterations = 0;
  long long newton_fallbacks = 0, newton_fallbacks_converged = 0;  ///< 'Anderson fallback' steps
  long long newton_continued = 0;  ///< unconverged steps kept ('Pressure Newton failure')
  double newton_continued_worst = 0.0, newton_worst_residual = 0.0, newton_seconds = 0.0;

  // wall time of the last step by phase, and the totals over the accepted steps [s]
  double step_momentum = 0.0, step_pressure = 0.0, step_markers = 0.0, step_other = 0.0;
  double total_momentum = 0.0, total_pressure = 0.0, total_markers = 0.0, total_other = 0.0;

  // the x-slabs over the ranks ('Load balance', load_balance.cpp): rebuilds, their seconds, and
  // the load of the most loaded rank over the mean, summed over the checks (for the mean)
  long long rebalances = 0, balance_checks = 0;
  double rebalance_seconds = 0.0, imbalance_sum = 0.0, imbalance_max = 0.0;

  /// Books a step of size dt (at step()).
  void record_dt(double dt) {
    dt_min = dt_max == 0.0 ? dt : std::min(dt_min, dt);
    dt_max = std::max(dt_max, dt);
  }
  /// The counters of two boxes whose parts became one box (the domain manager).
  void merge(const NdamStatistics& o) {
    dt_min = dt_max == 0.0 ? o.dt_min : (o.dt_max == 0.0 ? dt_min : std::min(dt_min, o.dt_min));
    dt_max = std::max(dt_max, o.dt_max);
    max_divergence = std::max(max_divergence, o.max_divergence);
    pressure_solves += o.pressure_solves;
    pressure_iterations += o.pressure_iterations;
    momentum_solves += o.momentum_solves;
    momentum_iterations += o.momentum_iterations;
    momentum_stiff_solves += o.momentum_stiff_solves;
    pressure_stiff_solves += o.pressure_stiff_solves;
    pressure_max_iterations = std::max(pressure_max_iterations, o.pressure_max_iterations);
    pressure_max_distance = std::max(pressure_max_distance, o.pressure_max_distance);
    momentum_stiff_iterations += o.momentum_stiff_iterations;
    momentum_max_iterations = std::max(momentum_max_iterations, o.momentum_max_iterations);
    momentum_stiff_max_iterations =
        std::max(momentum_stiff_max_iterations, o.momentum_stiff_max_iterations);
    unconverged_solves += o.unconverged_solves;
    worst_pressure_residual = std::max(worst_pressure_residual, o.worst_pressure_residual);
    worst_momentum_residual = std::max(worst_momentum_residual, o.worst_momentum_residual);
    retired_pressure_setups += o.retired_pressure_setups;
    retired_momentum_setups += o.retired_momentum_setups;
    retired_pressure_patterns += o.retired_pressure_patterns;
    retired_momentum_patterns += o.retired_momentum_patterns;
    retired_pressure_setup_seconds += o.retired_pressure_setup_seconds;
    retired_momentum_setup_seconds += o.retired_momentum_setup_seconds;
    retired_pressure_krylov_seconds += o.retired_pressure_krylov_seconds;
    retired_momentum_krylov_seconds += o.retired_momentum_krylov_seconds;
    retired_preconditioner_retries += o.retired_preconditioner_retries;
    friction_solves += o.friction_solves;
    friction_unconverged += o.friction_unconverged;
    friction_max_solves = std::max(friction_max_solves, o.friction_max_solves);
    friction_worst_residual = std::max(friction_worst_residual, o.friction_worst_residual);
    newton_solves += o.newton_solves;
    newton_iterations += o.newton_iterations;
    newton_krylov += o.newton_krylov;
    newton_evaluations += o.newton_evaluations;
    newton_fallbacks += o.newton_fallbacks;
    newton_fallbacks_converged += o.newton_fallbacks_converged;
    newton_max_iterations = std::max(newton_max_iterations, o.newton_max_iterations);
    newton_continued += o.newton_continued;
    newton_continued_worst = std::max(newton_continued_worst, o.newton_continued_worst);
    newton_worst_residual = std::max(newton_worst_residual, o.newton_worst_residual);
    newton_seconds += o.newton_seconds;
    total_momentum += o.total_momentum;
    total_pressure += o.total_pressure;
    total_markers += o.total_markers;
    total_other += o.total_other;
    rebalances += o.rebalances;
    balance_checks += o.balance_checks;
    rebalance_seconds += o.rebalance_seconds;
    imbalance_sum += o.imbalance_sum;
    imbalance_max = std::max(imbalance_max, o.imbalance_max);
  }
  /// Adds the last step's phase times to the totals (at accept()).
  void accept_times() {
    total_momentum += step_momentum;
    total_pressure += step_pressure;
    total_markers += step_markers;
    total_other += step_other;
  }
};

}  // namespace granflow::ndam
