#pragma once
// A scene: one Teuchos ParameterList XML file. Its "Model" decides which components are built
// and therefore which sublists are valid; every component declares its own valid list, and
// valid_parameters(model) assembles them (defaults live only in those declarations).
#include "granflow/core/stepper.hpp"

#include <Teuchos_ParameterList.hpp>

#include <mpi.h>

#include <memory>
#include <string>
#include <vector>

namespace granflow::scene {

/// Models a scene can run. Only the DAM exists so far; the 2D and coupled models register here.
const std::vector<std::string>& model_names();

struct Scene {
  std::string file;  ///< path of the XML file
  std::string dir;   ///< its directory (relative file names in the scene resolve against it)
  std::string name;
  std::string model;
  Teuchos::RCP<Teuchos::ParameterList> params;      ///< validated, defaults filled in
  Teuchos::RCP<const Teuchos::ParameterList> user;  ///< as written in the file
};

/// The complete valid list of a scene running `model`.
Teuchos::RCP<const Teuchos::ParameterList> valid_parameters(const std::string& model);

/// Read, validate and check a scene file; throws params::InputError with a clear message.
Scene load(const std::string& file);

/// Build the model the scene asks for (only the components it uses) with its initial state.
/// The 2D model runs on `comm` (the run's communicator; tests build serial copies on
/// MPI_COMM_SELF to compare with a distributed run).
std::unique_ptr<core::Stepper> build_model(const Scene& s, MPI_Comm comm = MPI_COMM_WORLD);

/// [m/s] The fastest speed the scene's energy allows a particle without pressure work,
/// u_0 + sqrt(2 g (L |sin zeta| + H cos zeta)): u_0 the fastest of the gate (or its series),
/// the initial velocity and the 2D box's lids, L the channel length, H the 2D box height.
/// 0 (no bound) for the DAM alone (its fronts are checked by the DAM itself), a 2D box without
/// a free surface, and a periodic channel (a layer there accelerates without end).
/// core::RunControl::energy_bound; 'Time->Speed limit' = 0 stops a run at kSpeedLimitFactor
/// times it.
double energy_speed_bound(const Scene& s);

/// Markdown reference of every model's parameters (docs/parameters.md).
std::string parameter_reference();

}  // namespace granflow::scene
