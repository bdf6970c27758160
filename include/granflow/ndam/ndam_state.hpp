#pragma once
// The state of an N-DAM box that its next step reads, gathered on every rank: what a checkpoint
// stores and what a box is rebuilt from (a restart, or the domain manager's new extent).
// Indices as grid.hpp: u(gi, k) on the right face of cell (gi, k), w(gi, k) on its top face,
// p(gi, k) at its centre, all gi * nz + k. Markers in box coordinates (x in [0, Lx)).
#include "granflow/markers/markers.hpp"

#include <vector>

namespace granflow::ndam {

struct NdamState {
  double t = 0.0;
  long steps = 0;
  int nx = 0, nz = 0;
  std::vector<double> u, w, p;
  // free surface
  std::vector<Marker> markers;              ///< all markers, sorted by id
  std::vector<double> inflow_accumulators;  ///< fractional markers of the gate rows
  long long inject_next = 0, seed_base = 0;  ///< id counters (maxima over the ranks)
  long long injected = 0, removed = 0;       ///< global marker counters
  double mass0 = 0.0;                        ///< marker area at t = 0 [m^2]
  double inflow_owed = 0.0;                  ///< inflow mass carried to later steps [m^2]
  double inflow_held = 0.0;                  ///< averaging terms of the 1D side held back [m^2]
  // lagged factors the next step's ghost values read (empty: computed from this state)
  // (the Coulomb ghosts are affine: u(gi, -1) = a u(gi, 0) + b, w(nx, k) = a w(nx - 1, k) + b)
  std::vector<double> bed_factor;   ///< a of u(gi, -1), gi = -G .. nx + G - 1
  std::vector<double> bed_offset;   ///< b of u(gi, -1) [m/s] (empty: 0)
  std::vector<double> wall_factor;  ///< a of w(nx, k), k = 0 .. nz - 1
  std::vector<double> wall_offset;  ///< b of w(nx, k) [m/s] (empty: 0)
  /// -sigma_zz of the bottom cells in the last step's vertical balance, gi = 0 .. nx - 1, NaN
  /// where none (NdamSolver::record_bed_stress; empty: the first step takes eq. (13) from p)
  std::vector<double> bed_stress;
  double momentum_dt = -1.0;        ///< dt of the assembled momentum matrix (Newtonian reuse)
  /// the step limit of the Coulomb friction's start-up (NdamSolver::stable_dt) [s]; <= 0: none
  double friction_dt = -1.0;
  /// u and w already hold the free-surface conditions of the markers' flags (an exported state):
  /// loading does not apply them again (they are not idempotent).
  bool surface_applied = false;
};

}  // namespace granflow::ndam
