#pragma once
// Memory a scene needs, estimated before anything is allocated, and the memory the machine
// can give, so that a scene too large for the machine stops with exit code 2 and the numbers
// instead of being killed by the kernel or failing with std::bad_alloc hours in.
#include "granflow/scene/scene.hpp"

#include <string>
#include <utility>
#include <vector>

namespace granflow::scene {

struct MemoryEstimate {
  double bytes = 0.0;  ///< peak resident memory of the ranks on this node [B]
  std::vector<std::pair<std::string, double>> parts;  ///< what it is made of [B]
  std::string summary() const;  ///< "2.3 GB (fields and solvers 1.9 GB, markers 0.4 GB, ...)"
};

/// Estimate of the peak resident memory of the scene's run on the `node_ranks` of `ranks`
/// ranks on this node. Per model (docs/numerics.md, "Memory estimate", constants measured
/// with /usr/bin/time on this code): a fixed part per rank (libraries), cells x bytes per cell
/// (fields, matrices, preconditioners, Krylov vectors: GMRES restart + 1 vectors), markers
/// (n x n per cell of the material the box can hold: the initial layer plus all inflow up to
/// the end time).
MemoryEstimate estimate_memory(const Scene& s, int ranks = 1, int node_ranks = 1);

struct MachineMemory {
  double total = 0.0;      ///< physical memory (sysconf), or the cgroup limit if lower [B]
  double available = 0.0;  ///< MemAvailable of /proc/meminfo (or the cgroup's room) [B]
};
MachineMemory machine_memory();

/// Throws params::InputError when the estimate exceeds the available memory, naming the scene's
/// size parameters, the estimate and the machine's memory.
void check_memory(const Scene& s, const MemoryEstimate& e, const MachineMemory& m);

/// "1.5 GB", "320 MB"
std::string format_bytes(double b);

}  // namespace granflow::scene
