#pragma once
// One subdomain of the coupled model: an interval [x0, x1] of the channel and the model that
// runs it, a DAM ("1D") or an N-DAM free-surface box ("2D").
#include "granflow/core/stepper.hpp"

#include <array>
#include <memory>
#include <string>

namespace granflow::dam {
class DamSolver;
}
namespace granflow::ndam {
class NdamSolver;
}

namespace granflow::coupling {

struct Subdomain {
  std::string kind;  ///< "1D" or "2D"
  double x0 = 0.0, x1 = 0.0;
  std::unique_ptr<core::Stepper> model;
  dam::DamSolver* dam = nullptr;     ///< the model, when 1D
  ndam::NdamSolver* ndam = nullptr;  ///< the model, when 2D

  bool one_d() const { return dam != nullptr; }
  /// Depth-averaged state {h, u_mean} of the current (accepted) state at x in [x0, x1]: the
  /// DAM's reconstruction, or the 2D column containing x (eq. 21 from the markers).
  std::array<double, 2> sample(double x) const;
  /// Mass [m^2] that entered at x0 and left at x1 in the last accepted step.
  std::array<double, 2> last_transfer() const;
};

}  // namespace granflow::coupling
