#pragma once
// The subdomain factory of the coupled model: builds a 1D or 2D subdomain on [x0, x1] of the
// channel, at t = 0 from the scene's initial state, or at time t from a given state (the cells
// of a DAM, the state of an N-DAM box), with the boundary sides its neighbours need. The scene
// builder and the domain manager both build their parts here; the interfaces then connect them.
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/coupling/interface.hpp"
#include "granflow/coupling/subdomain.hpp"
#include "granflow/dam/dam_solver.hpp"
#include "granflow/ndam/ndam_solver.hpp"

#include <mpi.h>

#include <functional>
#include <optional>
#include <vector>

namespace granflow::coupling {

/// Sets the initial state of a DAM (absolute channel coordinates).
using DamInitialiser = std::function<void(dam::DamSolver&)>;

/// What a 2D subdomain is built from: the free-surface N-DAM chute configured for the whole
/// channel (its cell size and gate), the rheology and the physics. Each 2D subdomain gets the
/// part [x0, x1] of that box.
struct TwoD {
  MPI_Comm comm = MPI_COMM_WORLD;
  ndam::NdamConfig cfg;
  ndam::Rheology rheology;
  ndam::NdamPhysics physics;
};

/// Which neighbours a subdomain has (an end of the channel has none on that side).
struct Neighbours {
  bool upstream = false, downstream = false;
};

class SubdomainFactory {
 public:
  /// Cells a subdomain gets at the least (a shorter one is built on squeezed cells; a user's
  /// static layout with a narrower 2D part is refused at input, scene.cpp).
  static constexpr int kMinimumCells = 4;
  /// `interface_pressure`: "Rheology", "Dirichlet" or "None" (Decomposition). Without `two_d`
  /// a 2D subdomain is an InputError.
  SubdomainFactory(const core::Material& m, const core::Channel& c, const dam::DamConfig& cfg,
                   DamInitialiser init, const TwoD* two_d, const std::string& interface_pressure);

  double length() const { return channel_.length; }
  bool has_2d() const { return two_d_.has_value(); }
  /// Cell sizes of the channel-wide grids [m].
  double dx_1d() const { return channel_.length / dam_cfg_.cells; }
  double dx_2d() const;
  const InterfaceOptions& interface_options() const { return iface_; }
  const core::Channel& channel() const { return channel_; }
  const core::Material& material() const { return material_; }
  const dam::DamPhysics& dam_physics() const { return dam_phys_; }
  const dam::DamConfig& dam_config() const { return dam_cfg_; }
  /// The channel-wide 2D configuration (only when has_2d()).
  const TwoD& two_d() const { return *two_d_; }

  /// t = 0: the scene's initial state on [x0, x1] (the DAM's initial condition; the N-DAM's
  /// initial layer at rest).
  Subdomain initial(const std::string& kind, double x0, double x1, Neighbours n) const;
  /// A DAM on [x0, x1] with the given cell averages (cells of size dx_1d()).
  Subdomain dam(double x0, double x1, std::vector<double> h, std::vector<double> hu, double t,
                long steps, Neighbours n, bool staggered = false) const;
  /// An N-DAM box on [x0, x1] from a state of its grid; `stats` continues the run's counters.
  Subdomain ndam(double x0, double x1, const ndam::NdamState& s,
                 const ndam::NdamStatistics& stats, Neighbours n) const;
  /// Cells of a subdomain on [x0, x1] (1D: of size dx_1d(), 2D: columns of size dx_2d()).
  int dam_cells(double x0, double x1) const;
  /// The N-DAM configuration of a 2D subdomain on [x0, x1]: the channel-wide box cut to it, an
  /// open outflow towards a downstream neighbour, no gate when an upstream neighbour feeds it.
  ndam::NdamConfig ndam_config(double x0, double x1, Neighbours n) const;

 private:
  dam::DamBoundary dam_boundary(int side, Neighbours n) const;
  core::Material material_;
  core::Channel channel_;
  dam::DamConfig dam_cfg_;
  dam::DamPhysics dam_phys_;
  DamInitialiser init_;
  std::optional<TwoD> two_d_;
  InterfaceOptions iface_;
};

}  // namespace granflow::coupling
