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
  long long unconverged_solves = 0;
  double worst_pressure_residual = 0.0, worst_momentum_residual = 0.0;
  // preconditioner work of the linear systems that earlier layouts owned (added at a rebuild)
  long long retired_pressure_setups = 0, retired_momentum_setups = 0;
  long long retired_pressure_patterns = 0, retired_momentum_patterns = 0;
  double retired_pressure_setup_seconds = 0.0, retired_momentum_setup_seconds = 0.0;

  // the nonlinear pressure system (NOX), 'Pressure coupling' = Nonlinear
  long long newton_solves = 0, newton_iterations = 0, newton_krylov = 0, newton_evaluations = 0;
  int newton_max_iterations = 0;
  long long newton_continued = 0;  ///< unconverged steps kept ('Pressure Newton failure')
  double newton_continued_worst = 0.0, newton_worst_residual = 0.0, newton_seconds = 0.0;

  // wall time of the last step by phase, and the totals over the accepted steps [s]
  double step_momentum = 0.0, step_pressure = 0.0, step_markers = 0.0, step_other = 0.0;
  double total_momentum = 0.0, total_pressure = 0.0, total_markers = 0.0, total_other = 0.0;

  /// Books a step of size dt (at step()).
  void record_dt(double dt) {
    dt_min = dt_max == 0.0 ? dt : std::min(dt_min, dt);
    dt_max = std::max(dt_max, dt);
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
