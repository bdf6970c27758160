#pragma once
// Internal to the N-DAM's translation units (not installed): the velocity sample `Ref` through
// which every boundary value enters the stencils, and small helpers shared by the step files.
//
// Boundary values enter through `Ref`: every velocity sample the stencils touch is written as
// a * (unknown) + b, where ghost values of no-slip/moving walls are 2 U_wall - u_inside,
// free-slip ghosts are u_inside, Coulomb ghosts a_F u_inside (the sliding law as a Robin
// condition), wall-normal faces are fixed (a = 0), and periodic columns wrap. The explicit
// operator evaluates the same Refs that the implicit one assembles, so the two treatments share
// one discretisation.
#include "granflow/ndam/ndam_solver.hpp"

#include <chrono>
#include <sstream>
#include <string>

namespace granflow::ndam {

/// A velocity sample as a * x[gid] + b: gid is the global unknown (or -1 when a == 0), loc the
/// position of x in this rank's field (with its ghosts filled, a * field[loc] + b is its value).
struct NdamSolver::Ref {
  long long gid = -1;
  std::size_t loc = 0;
  double a = 0.0, b = 0.0;
  bool friction = false;  ///< through a Coulomb wall's ghost (changes with the friction factors)
};

namespace detail {

/// The value of a sample in the field it refers to (ghosts filled).
inline double value(const NdamSolver::Ref& r, const Field& f) {
  return r.a == 0.0 ? r.b : r.a * f.data()[r.loc] + r.b;
}

using Clock = std::chrono::steady_clock;
inline double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}
inline double allreduce_max(double v, MPI_Comm c) {
  double r = v;
  MPI_Allreduce(&v, &r, 1, MPI_DOUBLE, MPI_MAX, c);
  return r;
}
inline double allreduce_sum(double v, MPI_Comm c) {
  double r = v;
  MPI_Allreduce(&v, &r, 1, MPI_DOUBLE, MPI_SUM, c);
  return r;
}
inline std::string gstr(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace detail
}  // namespace granflow::ndam
