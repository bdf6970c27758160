#pragma once
// Initial state of a DAM channel ("Initial condition" sublist): dry, uniform, dam break, block,
// or a sine wave (smooth periodic data for convergence studies).
#include "granflow/core/channel.hpp"
#include "granflow/dam/dam_solver.hpp"

#include <Teuchos_ParameterList.hpp>

namespace granflow::dam {

struct InitialCondition {
  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();
  /// Checks that only parameters of the chosen type were given and that positions lie in the
  /// channel; sets the solver state.
  static void apply(const Teuchos::ParameterList& validated, const Teuchos::ParameterList* user,
                    const core::Channel& channel, DamSolver& dam);
};

}  // namespace granflow::dam
