// Defaults in one place: for every component that reads a parameter list, the validated
// defaults (an empty list validated against getValidParameters() and read by from_parameters())
// are its default-constructed struct, field by field. getValidParameters() takes its defaults
// from that struct, so a default written in one place cannot disagree with the other; this test
// catches the parts it cannot copy (enum names, lists, what from_parameters() sets on its own).
// Comparisons are exact: the values are copied, never computed differently (tau_p is the same
// expression sin(deg2rad(phi)) on both sides).
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/core/simulation.hpp"
#include "granflow/coupling/coupled_model.hpp"
#include "granflow/dam/dam_solver.hpp"
#include "granflow/dam/initial_condition.hpp"
#include "granflow/ndam/config.hpp"
#include "granflow/ndam/rheology.hpp"
#include "granflow/params/parameters.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

using namespace granflow;

namespace {
// An empty list validated against `valid`: every parameter at its default.
Teuchos::ParameterList defaults_of(const Teuchos::ParameterList& valid) {
  Teuchos::ParameterList pl(valid.name());
  params::validate_and_set_defaults(pl, valid, "test");
  return pl;
}

void expect_same_series(const core::InflowSeries& a, const core::InflowSeries& b) {
  EXPECT_EQ(a.is_constant(), b.is_constant());
  for (double t : {0.0, 1.0, 100.0}) {
    EXPECT_EQ(a.depth(t), b.depth(t)) << "t = " << t;
    EXPECT_EQ(a.velocity(t), b.velocity(t)) << "t = " << t;
  }
}
}  // namespace

TEST(Defaults, MaterialIsItsStruct) {
  const core::Material d;
  const auto r =
      core::Material::from_parameters(defaults_of(*core::Material::getValidParameters()));
  EXPECT_EQ(r.gravity, d.gravity);
  EXPECT_EQ(r.density, d.density);
  EXPECT_EQ(r.internal_friction_deg, d.internal_friction_deg);
  EXPECT_EQ(r.bed_friction_deg, d.bed_friction_deg);
}

TEST(Defaults, ChannelIsItsStruct) {
  const core::Channel d;
  const auto r = core::Channel::from_parameters(defaults_of(*core::Channel::getValidParameters()),
                                                Teuchos::ParameterList("Channel"), "");
  EXPECT_EQ(r.length, d.length);
  EXPECT_EQ(r.slope_deg, d.slope_deg);
  EXPECT_EQ(r.left.type, d.left.type);
  EXPECT_EQ(r.right.type, d.right.type);
  expect_same_series(r.left.inflow, d.left.inflow);
  expect_same_series(r.right.inflow, d.right.inflow);
  // the struct's gate is the paper's Setup II (Inflow 6 cm at 0.37 m/s)
  EXPECT_EQ(d.left.type, core::BoundaryType::Inflow);
  EXPECT_EQ(d.left.inflow.depth(0.0), 0.06);
  EXPECT_EQ(d.left.inflow.velocity(0.0), 0.37);
}

// The struct's default left end is an inflow; a closed end read from a scene must not keep its
// gate data (the DAM and N-DAM read the series only at an Inflow end, but a closed end carries
// none).
TEST(Defaults, ChannelClosedEndCarriesNoInflow) {
  Teuchos::ParameterList pl("Channel");
  pl.sublist("Left boundary").set("Type", "Wall");
  const Teuchos::ParameterList user = pl;
  params::validate_and_set_defaults(pl, *core::Channel::getValidParameters(), "test");
  const auto r = core::Channel::from_parameters(pl, user, "");
  EXPECT_EQ(r.left.type, core::BoundaryType::Wall);
  expect_same_series(r.left.inflow, core::InflowSeries());
}

TEST(Defaults, RunControlIsItsStruct) {
  const core::RunControl d;
  const auto r = core::RunControl::from_parameters(
      defaults_of(*core::RunControl::getValidTimeParameters()),
      defaults_of(*core::RunControl::getValidOutputParameters()), "");
  EXPECT_EQ(r.end_time, d.end_time);
  EXPECT_EQ(r.max_dt, d.max_dt);
  EXPECT_EQ(r.min_dt, d.min_dt);
  EXPECT_EQ(r.max_steps, d.max_steps);
  EXPECT_EQ(r.directory, d.directory);
  EXPECT_EQ(r.output_interval, d.output_interval);
  EXPECT_EQ(r.fields, d.fields);
  EXPECT_EQ(r.checkpoint, d.checkpoint);
  EXPECT_EQ(r.progress, d.progress);
  EXPECT_EQ(r.restart_from, d.restart_from);
  EXPECT_EQ(r.impact_window, d.impact_window);
}

TEST(Defaults, DamConfigIsItsStruct) {
  const dam::DamConfig d;
  const auto r =
      dam::DamConfig::from_parameters(defaults_of(*dam::DamConfig::getValidParameters()));
  EXPECT_EQ(r.cells, d.cells);
  EXPECT_EQ(r.scheme, d.scheme);
  EXPECT_EQ(r.cfl, d.cfl);
  EXPECT_EQ(r.earth_pressure, d.earth_pressure);
  EXPECT_EQ(r.k_smoothing, d.k_smoothing);
  EXPECT_EQ(r.dry_depth, d.dry_depth);
  EXPECT_EQ(r.bed_friction_deg, d.bed_friction_deg);
}

TEST(Defaults, InitialConditionIsItsStruct) {
  const dam::InitialCondition d;
  const auto r = dam::InitialCondition::from_parameters(
      defaults_of(*dam::InitialCondition::getValidParameters()), nullptr, core::Channel{});
  EXPECT_EQ(r.type, d.type);
  EXPECT_EQ(r.depth, d.depth);
  EXPECT_EQ(r.velocity, d.velocity);
  EXPECT_EQ(r.left_depth, d.left_depth);
  EXPECT_EQ(r.right_depth, d.right_depth);
  EXPECT_EQ(r.position, d.position);
  EXPECT_EQ(r.start, d.start);
  EXPECT_EQ(r.end, d.end);
  EXPECT_EQ(r.amplitude, d.amplitude);
  EXPECT_EQ(r.wavenumber, d.wavenumber);
}

// The N-DAM list on a closed box (the default N-DAM is a full box, which needs walls at both
// channel ends) of the default channel length.
TEST(Defaults, NdamConfigIsItsStruct) {
  const ndam::NdamConfig d;
  core::Channel box;
  box.left.type = box.right.type = core::BoundaryType::Wall;
  const auto r = ndam::NdamConfig::from_parameters(
      defaults_of(*ndam::NdamConfig::getValidParameters()), nullptr, box, 1);
  EXPECT_EQ(r.grid.nx, d.grid.nx);
  EXPECT_EQ(r.grid.nz, d.grid.nz);
  EXPECT_EQ(r.grid.lx, d.grid.lx);  // the channel's length
  EXPECT_EQ(r.grid.lz, d.grid.lz);
  EXPECT_EQ(r.momentum, d.momentum);
  EXPECT_EQ(r.cfl, d.cfl);
  EXPECT_EQ(r.gamma, d.gamma);
  for (std::size_t s = 0; s < 4; ++s) {
    EXPECT_EQ(r.walls[s].kind, d.walls[s].kind) << "side " << s;
    EXPECT_EQ(r.walls[s].velocity, d.walls[s].velocity) << "side " << s;
  }
  EXPECT_EQ(r.obstacles, d.obstacles);
  EXPECT_TRUE(Teuchos::haveSameValues(r.momentum_solver, d.momentum_solver, true));
  EXPECT_TRUE(Teuchos::haveSameValues(r.pressure_solver, d.pressure_solver, true));
  EXPECT_EQ(r.pressure_coupling, d.pressure_coupling);
  EXPECT_TRUE(Teuchos::haveSameValues(r.pressure_newton, d.pressure_newton, true));
  EXPECT_EQ(r.newton_failure_continue, d.newton_failure_continue);
  EXPECT_EQ(r.free_surface, d.free_surface);
  EXPECT_EQ(r.markers_per_cell, d.markers_per_cell);
  EXPECT_EQ(r.initial_depth, d.initial_depth);
  EXPECT_EQ(r.initial_x0, d.initial_x0);
  EXPECT_EQ(r.initial_x1, d.initial_x1);
  EXPECT_EQ(static_cast<bool>(r.inflow), static_cast<bool>(d.inflow));
  EXPECT_EQ(r.inflow_shape, d.inflow_shape);
  EXPECT_EQ(r.inflow_pressure, d.inflow_pressure);
  EXPECT_EQ(r.inflow_K, d.inflow_K);
  EXPECT_EQ(r.outflow_right, d.outflow_right);
  EXPECT_EQ(r.outflow_extrapolate, d.outflow_extrapolate);
  EXPECT_EQ(r.m_c, d.m_c);
  EXPECT_EQ(r.x0, d.x0);
  // the solver lists are the full validated lists (an NdamSolver can be built from `d`)
  EXPECT_EQ(d.momentum_solver.get<std::string>("Solver"), "GMRES");
  EXPECT_EQ(d.pressure_solver.get<std::string>("Solver"), "CG");
  EXPECT_EQ(d.pressure_newton.get<std::string>("Method"), "Jacobian-free Newton-Krylov");
}

TEST(Defaults, RheologyIsItsStruct) {
  const ndam::Rheology d;
  const auto r = ndam::Rheology::from_parameters(
      defaults_of(*ndam::Rheology::getValidParameters()), nullptr, core::Material{});
  EXPECT_EQ(r.model, d.model);
  EXPECT_EQ(r.nu, d.nu);
  EXPECT_EQ(r.tau_c, d.tau_c);
  EXPECT_EQ(r.tau_p, d.tau_p);
  EXPECT_EQ(r.m_y, d.m_y);
  EXPECT_EQ(d.model, ndam::RheologyModel::DruckerPrager);  // the paper's rheology
}

// The struct's tau_p is Drucker-Prager's sin(phi); a Newtonian or Bingham rheology read from a
// scene has no pressure-dependent yield stress, and a Newtonian one no yield stress at all.
TEST(Defaults, RheologyModelsSetTheirOwnYieldCoefficients) {
  for (const char* model : {"Newtonian", "Bingham"}) {
    Teuchos::ParameterList pl("Rheology");
    pl.set("Model", model);
    if (std::string(model) == "Bingham") pl.set("Yield stress", 0.5);
    params::validate_and_set_defaults(pl, *ndam::Rheology::getValidParameters(), "test");
    const auto r = ndam::Rheology::from_parameters(pl, nullptr, core::Material{});
    EXPECT_EQ(r.tau_p, 0.0) << model;
    EXPECT_EQ(r.tau_c, std::string(model) == "Bingham" ? 0.5 : 0.0) << model;
    EXPECT_EQ(r.yield_stress(1.0e3), r.tau_c) << model;
  }
}

TEST(Defaults, DecompositionIsItsStruct) {
  const coupling::Decomposition d;
  const auto r = coupling::Decomposition::from_parameters(
      defaults_of(*coupling::Decomposition::getValidParameters()), core::Channel{});
  EXPECT_EQ(r.models, d.models);
  EXPECT_EQ(r.interfaces, d.interfaces);
  EXPECT_EQ(r.layout, d.layout);
  EXPECT_EQ(r.eps_threshold, d.eps_threshold);
  EXPECT_EQ(r.margin, d.margin);
  EXPECT_EQ(r.min_length, d.min_length);
  EXPECT_EQ(r.interface_pressure, d.interface_pressure);
  EXPECT_EQ(r.initial_layout, d.initial_layout);
  EXPECT_EQ(r.eps_lower, d.eps_lower);
  EXPECT_EQ(r.hold_time, d.hold_time);
  EXPECT_EQ(r.check_interval, d.check_interval);
  EXPECT_EQ(r.rest_speed, d.rest_speed);
  EXPECT_EQ(r.shock_indicator, d.shock_indicator);
  EXPECT_EQ(r.subcycling, d.subcycling);
}
