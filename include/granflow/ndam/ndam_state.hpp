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
};

}  // namespace granflow::ndam
