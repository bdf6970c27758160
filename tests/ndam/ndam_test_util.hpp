#pragma once
// Helpers of the N-DAM tests: build a solver from a few numbers through the same validated
// parameter lists a scene uses, run it to a steady state, and sample it.
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/ndam/ndam_solver.hpp"
#include "granflow/params/parameters.hpp"

#include <mpi.h>

#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace ndam_test {

using namespace granflow;

struct Case {
  int nx = 16, nz = 16;
  double lx = 1.0, lz = 1.0;
  std::string momentum = "Implicit";
  double cfl = 0.5, gamma = 0.0;
  std::array<std::string, 4> walls{"No-slip", "No-slip", "No-slip", "Moving lid"};
  double lid = 1.0;  // top lid velocity when walls[3] == "Moving lid"
  std::string rheology = "Newtonian";
  double nu = 0.01, yield = 0.0, m_y = 100.0, phi_deg = 33.0;
  double slope_deg = 0.0, gravity = 0.0;
  double tol = 1e-10;
  std::string preconditioner = "MueLu";
  std::string obstacles;  // "x0 x1 z0 z1; ..."
  // pressure in tau_y and (13): "Lagged" or "Nonlinear" (NOX); Newton overrides when > 0
  std::string coupling = "Lagged";
  int newton_max = 0;
  double newton_abs_tol = 0.0;
  bool newton_continue = false;  // 'Pressure Newton failure' = Continue
  std::string pressure_iteration = "Anderson fixed point";  // or "Newton-Krylov"
};

inline std::unique_ptr<ndam::NdamSolver> make(const Case& c, MPI_Comm comm = MPI_COMM_WORLD) {
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  Teuchos::ParameterList n("N-DAM");
  n.set("Cells x", c.nx);
  n.set("Cells z", c.nz);
  n.set("Height", c.lz);
  n.set("Momentum", c.momentum);
  n.set("CFL", c.cfl);
  n.set("Donor-cell weight", c.gamma);
  if (!c.obstacles.empty()) n.set("Obstacles", c.obstacles);
  n.set("Pressure coupling", c.coupling);
  if (c.newton_continue) n.set("Pressure Newton failure", "Continue");
  if (c.coupling == "Nonlinear") n.set("Pressure iteration", c.pressure_iteration);
  if (c.newton_max > 0) n.sublist("Pressure Newton").set("Max Newton iterations", c.newton_max);
  if (c.newton_abs_tol > 0.0) {
    n.sublist("Pressure Newton").set("Absolute tolerance", c.newton_abs_tol);
    n.sublist("Pressure Newton").set("Relative tolerance", c.newton_abs_tol);
  }
  auto& b = n.sublist("Boundaries");
  const char* sides[4] = {"Left", "Right", "Bottom", "Top"};
  for (int s = 0; s < 4; ++s) {
    b.set(sides[s], c.walls[static_cast<std::size_t>(s)]);
    if (c.walls[static_cast<std::size_t>(s)] == "Moving lid")
      b.set(std::string(sides[s]) + " lid velocity", c.lid);
  }
  for (const char* sv : {"Momentum solver", "Pressure solver"}) {
    n.sublist(sv).set("Tolerance", c.tol);
    n.sublist(sv).set("Preconditioner", c.preconditioner);
  }
  const Teuchos::ParameterList user = n;
  params::validate_and_set_defaults(n, *ndam::NdamConfig::getValidParameters(), "test");

  core::Channel ch;
  ch.length = c.lx;
  ch.slope_deg = c.slope_deg;
  const bool per = c.walls[0] == "Periodic";
  ch.left.type = ch.right.type = per ? core::BoundaryType::Periodic : core::BoundaryType::Wall;
  core::Material m;
  m.gravity = c.gravity;
  m.internal_friction_deg = c.phi_deg;
  m.bed_friction_deg = 0.0;

  Teuchos::ParameterList r("Rheology");
  r.set("Model", c.rheology);
  r.set("Viscosity", c.nu);
  if (c.rheology != "Newtonian") {
    r.set("Yield stress", c.yield);
    r.set("Regularisation", c.m_y);
  }
  const Teuchos::ParameterList ruser = r;
  params::validate_and_set_defaults(r, *ndam::Rheology::getValidParameters(), "test");
  const auto cfg = ndam::NdamConfig::from_parameters(n, &user, ch, ranks);
  const auto rheo = ndam::Rheology::from_parameters(r, &ruser, m);
  return std::make_unique<ndam::NdamSolver>(comm, cfg, rheo, ndam::NdamPhysics::from(m, ch));
}

/// One step with dt = min(stable dt, dt_max); returns the step's max |u^{n+1} - u^n| / dt.
inline double advance(ndam::NdamSolver& s, double dt_max, double* max_div = nullptr) {
  const auto u0 = s.gather_u(), w0 = s.gather_w();
  const double dt = std::min(s.stable_dt(), dt_max);
  s.step(dt);
  s.accept();
  if (max_div) *max_div = std::max(*max_div, s.max_divergence());
  const auto u1 = s.gather_u(), w1 = s.gather_w();
  double d = 0.0;
  for (std::size_t q = 0; q < u0.size(); ++q)
    d = std::max({d, std::abs(u1[q] - u0[q]), std::abs(w1[q] - w0[q])});
  return d / dt;
}

/// Steps until the velocity changes slower than `rate` [m/s^2] or t reaches t_max.
inline void run_to_steady(ndam::NdamSolver& s, double t_max, double rate, double dt_max,
                          double* max_div = nullptr) {
  while (s.time() < t_max)
    if (advance(s, dt_max, max_div) < rate) break;
}

inline double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double d = 0.0;
  for (std::size_t q = 0; q < a.size(); ++q) d = std::max(d, std::abs(a[q] - b[q]));
  return d;
}
inline double max_abs(const std::vector<double>& a) {
  double d = 0.0;
  for (double v : a) d = std::max(d, std::abs(v));
  return d;
}

}  // namespace ndam_test
