#pragma once
// Helpers of the free-surface N-DAM tests: a solver with markers, Coulomb walls and the chute
// ends built through the same validated parameter lists a scene uses.
#include "ndam_test_util.hpp"

#include <gtest/gtest.h>

#include <algorithm>

namespace ndam_chute {

using namespace granflow;

struct FsCase {
  int nx = 10, nz = 20;
  double lx = 0.1, lz = 0.1;
  double slope_deg = 50.0, phi_deg = 33.0, delta_deg = 22.0;
  std::string rheology = "Drucker-Prager";
  double nu = 0.003, m_y = 100.0, m_c = 100.0, yield = 0.0;
  double depth = 0.05;
  double init_x0 = 0.0, init_x1 = 1e30;  // the initial layer on [init_x0, init_x1)
  std::array<std::string, 4> walls{"Periodic", "Periodic", "Coulomb", "Free-slip"};
  std::string left = "Periodic", right = "Periodic";  // Channel ends
  double h_in = 0.06, u_in = 0.37;
  std::string series_file;  // 'Inflow series file' of an Inflow left end (instead of h_in, u_in)
  std::string momentum = "Implicit";
  double cfl = 0.5;
  // pressure in tau_y and (13): "Lagged" or "Nonlinear" (NOX); Newton overrides when > 0
  std::string coupling = "Lagged";
  int newton_max = 0;
  double newton_abs_tol = 0.0;
  std::string pressure_iteration = "Anderson fixed point";  // or "Newton-Krylov"
  double x0 = 0.0;  // grid origin along the slope (NdamConfig::x0, as a 2D subdomain has)
  std::string surface_mass = "Full cell";  // 'Surface cell mass' ("Material share")
  // 'Surface pressure' ("Surface cells", "Ghost fluid", "Ghost fluid at walls"); empty: the
  // default, except with Nonlinear coupling, which needs NaSt2D's Surface cells
  std::string surface_pressure;
  double pressure_threshold = -1.0;  // 'Pressure solver->Stiff threshold' when >= 0
};

/// The box of `c`; from `state` (NdamSolver's state constructor) when one is given.
inline std::unique_ptr<ndam::NdamSolver> make_fs(const FsCase& c, MPI_Comm comm = MPI_COMM_WORLD,
                                                 const ndam::NdamState* state = nullptr) {
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  Teuchos::ParameterList n("N-DAM");
  n.set("Cells x", c.nx);
  n.set("Cells z", c.nz);
  n.set("Height", c.lz);
  n.set("Momentum", c.momentum);
  n.set("CFL", c.cfl);
  n.set("Donor-cell weight", 0.5);
  n.set("Free surface", true);
  n.set("Initial depth", c.depth);
  if (c.depth > 0.0) {  // the layer's extent (refused without a layer, as an unused option)
    n.set("Initial x0", c.init_x0);
    n.set("Initial x1", c.init_x1);
  }
  // (refused without a Coulomb side, as an unused option)
  if (c.walls[1] == "Coulomb" || c.walls[2] == "Coulomb") n.set("Friction regularisation", c.m_c);
  n.set("Pressure coupling", c.coupling);
  if (c.coupling == "Nonlinear") n.set("Pressure iteration", c.pressure_iteration);
  n.set("Surface cell mass", c.surface_mass);
  if (!c.surface_pressure.empty()) n.set("Surface pressure", c.surface_pressure);
  else if (c.coupling == "Nonlinear") n.set("Surface pressure", std::string("Surface cells"));
  if (c.newton_max > 0) n.sublist("Pressure Newton").set("Max Newton iterations", c.newton_max);
  if (c.newton_abs_tol > 0.0) {
    n.sublist("Pressure Newton").set("Absolute tolerance", c.newton_abs_tol);
    n.sublist("Pressure Newton").set("Relative tolerance", c.newton_abs_tol);
  }
  auto& b = n.sublist("Boundaries");
  const char* sides[4] = {"Left", "Right", "Bottom", "Top"};
  for (int s = 0; s < 4; ++s) b.set(sides[s], c.walls[static_cast<std::size_t>(s)]);
  for (const char* sv : {"Momentum solver", "Pressure solver"}) n.sublist(sv).set("Tolerance", 1e-10);
  if (c.pressure_threshold >= 0.0)
    n.sublist("Pressure solver").set("Stiff threshold", c.pressure_threshold);
  const Teuchos::ParameterList user = n;
  params::validate_and_set_defaults(n, *ndam::NdamConfig::getValidParameters(), "test");

  Teuchos::ParameterList chp("Channel");
  chp.set("Length", c.lx);
  chp.set("Slope angle", c.slope_deg);
  chp.sublist("Left boundary").set("Type", c.left);
  if (c.left == "Inflow" && !c.series_file.empty()) {
    chp.sublist("Left boundary").set("Inflow series file", c.series_file);
  } else if (c.left == "Inflow") {
    chp.sublist("Left boundary").set("Inflow depth", c.h_in);
    chp.sublist("Left boundary").set("Inflow velocity", c.u_in);
  }
  chp.sublist("Right boundary").set("Type", c.right);
  const Teuchos::ParameterList chuser = chp;
  params::validate_and_set_defaults(chp, *core::Channel::getValidParameters(), "test");
  const auto ch = core::Channel::from_parameters(chp, chuser, ".");
  core::Material m;
  m.gravity = 9.81;
  m.internal_friction_deg = c.phi_deg;
  m.bed_friction_deg = c.delta_deg;

  Teuchos::ParameterList r("Rheology");
  r.set("Model", c.rheology);
  r.set("Viscosity", c.nu);
  if (c.rheology != "Newtonian") {
    r.set("Yield stress", c.yield);
    r.set("Regularisation", c.m_y);
  }
  const Teuchos::ParameterList ruser = r;
  params::validate_and_set_defaults(r, *ndam::Rheology::getValidParameters(), "test");
  auto cfg = ndam::NdamConfig::from_parameters(n, &user, ch, ranks);
  cfg.x0 = c.x0;
  const auto rheo = ndam::Rheology::from_parameters(r, &ruser, m);
  if (state)
    return std::make_unique<ndam::NdamSolver>(comm, cfg, rheo, ndam::NdamPhysics::from(m, ch),
                                              *state);
  return std::make_unique<ndam::NdamSolver>(comm, cfg, rheo, ndam::NdamPhysics::from(m, ch));
}

/// Mean u over the material of the layer (the columns' u_mean weighted by their depth h).
inline double layer_mean_u(const ndam::NdamSolver& s) {
  const auto p = s.profile();
  double sum = 0.0, hs = 0.0;
  for (std::size_t q = 0; q < p.x.size(); ++q) {
    sum += p.u_mean[q] * p.h[q];
    hs += p.h[q];
  }
  return hs > 0.0 ? sum / hs : 0.0;
}

/// The plug law of the model's own regularised friction (12): a layer that slides as a rigid
/// plug from rest on a slope zeta with bed friction delta,
///   u' = g sin(zeta) - g cos(zeta) tan(delta) (1 - exp(-m_c u)),   u(0) = 0,
/// integrated by RK4 with steps of 1e-5 s (its error, O(h^4) with the stiffest rate
/// g cos tan(delta) m_c ~ 500 1/s, is below 1e-12 m/s), sampled at the increasing `times`.
inline std::vector<double> plug_law(double zeta_deg, double delta_deg, double m_c,
                                    const std::vector<double>& times, double g = 9.81) {
  const double z = core::deg2rad(zeta_deg), d = core::deg2rad(delta_deg);
  const double S = g * std::sin(z), F = g * std::cos(z) * std::tan(d);
  auto f = [&](double u) { return S + F * std::expm1(-m_c * std::abs(u)); };
  std::vector<double> out;
  double u = 0.0, t = 0.0;
  for (double T : times) {
    while (t < T - 1e-13) {
      const double h = std::min(1e-5, T - t);
      const double k1 = f(u), k2 = f(u + 0.5 * h * k1), k3 = f(u + 0.5 * h * k2),
                   k4 = f(u + h * k3);
      u += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
      t += h;
    }
    out.push_back(u);
  }
  return out;
}

/// Steps s to each of the increasing `times` as the app does (dt = min(stable dt, dt_max), the
/// last two steps before an output split evenly rather than leaving a sliver) and returns
/// layer_mean_u there; fails the test on an unhealthy step.
inline std::vector<double> mean_u_at(ndam::NdamSolver& s, const std::vector<double>& times,
                                     double dt_max) {
  std::vector<double> u;
  for (double T : times) {
    while (s.time() < T - 1e-12) {
      const double to_target = T - s.time();
      double dt = std::min(s.stable_dt(), dt_max);
      if (to_target <= dt) dt = to_target;
      else if (to_target < 1.5 * dt) dt = 0.5 * to_target;
      s.step(dt);
      const auto h = s.check();
      if (!h.ok) {
        ADD_FAILURE() << h.quantity << " " << h.reason << " at x = " << h.x;
        return u;
      }
      s.accept();
    }
    u.push_back(layer_mean_u(s));
  }
  return u;
}

/// A Newtonian pool of the given depth in a closed box on a horizontal bed (no-slip walls and
/// bed, free-slip lid).
inline FsCase closed_pool(int nx, int nz, double lx, double lz, double depth) {
  FsCase c;
  c.nx = nx;
  c.nz = nz;
  c.lx = lx;
  c.lz = lz;
  c.slope_deg = 0.0;
  c.depth = depth;
  c.rheology = "Newtonian";
  c.walls = {"No-slip", "No-slip", "No-slip", "Free-slip"};
  c.left = c.right = "Wall";
  return c;
}

/// The silo gate (h_in = 4 cm, u_in = 0.37 m/s) feeding an empty 0.3 m Drucker-Prager chute
/// with a Coulomb bed and end wall, 30 x 10 cells of 1 cm: the pressure changes in every step
/// as the layer spreads, and the front crosses x = 0.15 m (the slab boundary at np = 2).
inline FsCase gate_chute(const std::string& coupling = "Lagged") {
  FsCase c;
  c.nx = 30;
  c.nz = 10;
  c.lx = 0.3;
  c.walls = {"No-slip", "Coulomb", "Coulomb", "Free-slip"};
  c.left = "Inflow";
  c.right = "Wall";
  c.h_in = 0.04;
  c.depth = 0.0;
  c.coupling = coupling;
  return c;
}

/// The 3 cm Drucker-Prager layer (issue 11 item 1) on a periodic Coulomb incline of
/// nx x 24 cells of (lx / nx) x 2.5 mm, slope / delta / phi in deg, m_c = 100 s/m, released
/// from rest.
inline FsCase plug_3cm(double zeta, double delta, double phi, int nx = 4, double lx = 0.02) {
  FsCase c;
  c.nx = nx;
  c.lx = lx;
  c.nz = 24;
  c.lz = 0.06;
  c.depth = 0.03;
  c.slope_deg = zeta;
  c.delta_deg = delta;
  c.phi_deg = phi;
  c.m_c = 100.0;
  return c;
}

/// The plug test of NdamCoulomb.PlugFromRestFollowsTheRegularisedLaw (see there) with the given
/// 'Surface pressure': a 3 cm layer (4 x 24 cells of 5 x 2.5 mm, periodic) released from rest
/// on three angle sets, at the CFL step and at half of it; u_mean within 1 % of the law at every
/// output from 0.05 to 1 s, the error not growing as dt halves, and the layer a plug.
inline void expect_plug_from_rest_follows_law(const std::string& surface_pressure) {
  struct Angles {
    double zeta, delta, phi;
  };
  std::vector<double> times;
  for (int q = 1; q <= 20; ++q) times.push_back(0.05 * q);
  for (const Angles& an : {Angles{40, 25, 35}, Angles{30, 20, 30}, Angles{40, 30, 35.5}}) {
    const auto law = plug_law(an.zeta, an.delta, 100.0, times);
    std::vector<double> err[2];
    for (int half = 0; half < 2; ++half) {
      FsCase c = plug_3cm(an.zeta, an.delta, an.phi);
      c.cfl = half ? 0.25 : 0.5;
      c.surface_pressure = surface_pressure;
      auto s = make_fs(c);
      const auto u = mean_u_at(*s, times, 0.01);
      ASSERT_EQ(u.size(), times.size());
      for (std::size_t q = 0; q < times.size(); ++q) {
        err[half].push_back(u[q] / law[q] - 1.0);
        EXPECT_LT(std::abs(err[half][q]), 0.01)
            << an.zeta << "/" << an.delta << "/" << an.phi << " CFL " << c.cfl << " t = "
            << times[q] << ": u_mean " << u[q] << " law " << law[q];
      }
      const auto uf = s->gather_u();
      const int top = static_cast<int>(c.depth / (c.lz / c.nz)) - 2;  // last full Fluid row
      const double ub = uf[static_cast<std::size_t>(c.nz)], ut = uf[static_cast<std::size_t>(c.nz + top)];
      EXPECT_LT(std::abs(ut - ub), 0.01 * ub);
      std::printf("plug (%s) %g/%g/%g CFL %.2f: u_mean/law - 1 = %+.4f %% (0.05 s) %+.4f %% (0.5 s) "
                  "%+.4f %% (1 s); u_top - u_bottom %.2e m/s at u = %.3f m/s\n",
                  surface_pressure.c_str(), an.zeta, an.delta, an.phi, c.cfl, 100 * err[half][0],
                  100 * err[half][9], 100 * err[half][19], ut - ub, ub);
    }
    // halving dt: the error at each output does not grow (1e-5: round-off of u / law)
    for (std::size_t q = 0; q < times.size(); ++q)
      EXPECT_LE(std::abs(err[1][q]), std::abs(err[0][q]) + 1e-5)
          << an.zeta << "/" << an.delta << " t = " << times[q];
  }
}


}  // namespace ndam_chute
