#pragma once
// Building a coupled model from its parts' parameters: one DAM per 1D subdomain (cells of the
// channel-wide DAM size dx), interfaces wired between neighbours, and the a priori layout from
// a preliminary DAM run of the whole channel.
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/coupling/coupled_model.hpp"
#include "granflow/dam/dam_solver.hpp"

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

/// The coupled model of a static decomposition. 2D subdomains need the 2D chute model with a
/// free surface (issue 4) and are rejected with an InputError until it exists.
std::unique_ptr<CoupledModel> build(const Decomposition& d, const core::Material& m,
                                    const core::Channel& c, const dam::DamConfig& cfg,
                                    const DamInitialiser& init);

}  // namespace granflow::coupling
