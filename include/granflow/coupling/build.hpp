#pragma once
// Building a coupled model from its parts' parameters: one DAM per 1D subdomain (cells of the
// channel-wide DAM size dx), interfaces wired between neighbours, and the a priori layout from
// a preliminary DAM run of the whole channel.
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/coupling/coupled_model.hpp"
#include "granflow/coupling/factory.hpp"
#include "granflow/dam/dam_solver.hpp"
#include "granflow/ndam/ndam_solver.hpp"

#include <mpi.h>

#include <functional>
#include <memory>

namespace granflow::coupling {

/// The a priori layout (paper section 4.1): runs the DAM on the whole channel to `end_time`,
/// sampling eps every `interval`, and returns `d` with models/interfaces replaced by the
/// proposed layout (2D where eps >= d.eps_threshold, widened by d.margin).
Decomposition a_priori_layout(Decomposition d, const core::Material& m, const core::Channel& c,
                              const dam::DamConfig& cfg, const DamInitialiser& init,
                              double end_time, double interval);

/// The coupled model of a decomposition: its parts built by a SubdomainFactory at t = 0 and
/// connected by the interfaces of interface.hpp. Without `two_d`, a 2D subdomain is an
/// InputError. Zero-length subdomains are left out first (Decomposition::normalised).
std::unique_ptr<CoupledModel> build(const Decomposition& d, const core::Material& m,
                                    const core::Channel& c, const dam::DamConfig& cfg,
                                    const DamInitialiser& init, const TwoD* two_d = nullptr);

}  // namespace granflow::coupling
