#pragma once
// Initial state of a DAM channel ("Initial condition" sublist): dry, uniform, dam break, block,
// or a sine wave (smooth periodic data for convergence studies).
#include "granflow/core/channel.hpp"
#include "granflow/dam/dam_solver.hpp"

#include <Teuchos_ParameterList.hpp>

namespace granflow::dam {

/// The values of the "Initial condition" list; each Type reads only its own (see the list's
/// docs). getValidParameters() takes its defaults from a default-constructed one.
struct InitialCondition {
  enum class Type { Dry, Uniform, DamBreak, Block, SineWave };
  Type type = Type::Dry;
  double depth = 0.05;        ///< [m] Uniform, Block, Sine wave
  double velocity = 0.0;      ///< [m/s] Uniform, Block, Sine wave, Dam break
  double left_depth = 0.1;    ///< [m] Dam break: upstream of Position
  double right_depth = 0.0;   ///< [m] Dam break: downstream of Position
  double position = 0.5;      ///< [m] Dam break
  double start = 0.0;         ///< [m] Block
  double end = 0.1;           ///< [m] Block
  double amplitude = 0.1;     ///< [-] Sine wave, relative to Depth
  int wavenumber = 1;         ///< Sine wave: wavelengths on the channel

  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();
  /// Reads a validated list; checks that only parameters of the chosen type were given (`user`,
  /// the list as written, may be null) and that positions lie in the channel.
  static InitialCondition from_parameters(const Teuchos::ParameterList& validated,
                                          const Teuchos::ParameterList* user,
                                          const core::Channel& channel);
  /// Sets the solver state (absolute channel coordinates; the sine wave's period is the
  /// channel length).
  void apply(const core::Channel& channel, DamSolver& dam) const;
  /// from_parameters(validated, user, channel).apply(channel, dam).
  static void apply(const Teuchos::ParameterList& validated, const Teuchos::ParameterList* user,
                    const core::Channel& channel, DamSolver& dam);
};

/// The name of a Type in the list ("Dam break", ...).
const char* to_string(InitialCondition::Type t);

}  // namespace granflow::dam
