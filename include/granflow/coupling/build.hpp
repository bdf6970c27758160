#pragma once
// Building a coupled model from its parts' parameters: one DAM per 1D subdomain (cells of the
// channel-wide DAM size dx), interfaces wired between neighbours, and the a priori layout from
// a preliminary DAM run of the whole channel.
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/coupling/coupled_model.hpp"
#include "granflow/dam/dam_solver.hpp"
#include "granflow/ndam/ndam_solver.hpp"

#include <mpi.h>

#include <functional>
#include <memory>

namespace granflow::coupling {

/// Sets the initial state of a DAM (absolute channel coordinates).
using DamInitialiser = std::function<void(dam::DamSolver&)>;

/// The a priori layout (paper section 4.1): runs the DAM on the whole channel to `end_time`,
/// sampling eps every `interval`, and returns `d` with models/interfaces replaced by the
/// proposed layout (2D where eps >= d.eps_threshold, widened by d.margin).
Decomposition a_priori_layout(Decomposition d, const core::Material& m, const core::Channel& c,
                              const dam::DamConfig& cfg, const DamInitialiser& init,
                              double end_time, double interval);

/// What a 2D subdomain is built from: the free-surface N-DAM chute configured for the whole
/// channel (its cell size and gate), the rheology and the physics. Each 2D subdomain gets the
/// part [x0, x1] of that box.
struct TwoD {
  MPI_Comm comm = MPI_COMM_WORLD;
  ndam::NdamConfig cfg;
  ndam::Rheology rheology;
  ndam::NdamPhysics physics;
};

/// The coupled model of a static decomposition. Without `two_d`, a 2D subdomain is an
/// InputError. Interfaces (flow from left to right):
///   1D | 1D  both sides' ghosts sample the neighbour (DamSolver::sample);
///   2D -> 1D the 1D ghosts take {h, u_mean} of the 2D column where they lie (eqs. 19-21); the
///            2D side is an open outflow continuing the lagged velocity gradient;
///   1D -> 2D the 2D inflow takes h of the 1D reconstruction at x_IF and exactly the mass the
///            DAM lets out in the step (eq. 24), the profile shape of the first interior 2D
///            column (eq. 25), p of eq. (26) with K = K_act as set by d.interface_pressure,
///            w from continuity (27), markers injected up to h; the 1D ghosts beyond x_IF read
///            the 2D columns.
/// Zero-length subdomains are left out first (Decomposition::normalised).
std::unique_ptr<CoupledModel> build(const Decomposition& d, const core::Material& m,
                                    const core::Channel& c, const dam::DamConfig& cfg,
                                    const DamInitialiser& init, const TwoD* two_d = nullptr);

}  // namespace granflow::coupling
