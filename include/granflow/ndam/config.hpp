#pragma once
// N-DAM configuration: the numerical parameters of the 2D model (the "N-DAM" sublist), the
// boundary condition of each side of the box, and the physical constants the model is given.
// Read and validated by config.cpp (getValidParameters / from_parameters); the model itself is
// ndam_solver.hpp.
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/ndam/grid.hpp"

#include <Teuchos_ParameterList.hpp>

#include <array>
#include <functional>
#include <string>
#include <vector>

namespace granflow::ndam {

enum class Momentum { Explicit, Implicit };
/// How the pressure enters tau_y and the Coulomb law (13): at t^n (Lagged) or at t^{n+1}
/// (Nonlinear: the nonlinear pressure system solved by NOX in every step).
enum class PressureCoupling { Lagged, Nonlinear };
/// The solver of the nonlinear pressure system (docs/numerics.md, "Pressure coupling").
enum class PressureIteration { Anderson, NewtonKrylov };
enum class Side : int { Left = 0, Right = 1, Bottom = 2, Top = 3 };
/// Coulomb: the sliding law (11)-(13) with c_F = tan(delta) (1 - exp(-m_c |u_t|)) (Bottom and
/// Right only; delta = 0 is free slip).
enum class WallKind { NoSlip, FreeSlip, MovingLid, Periodic, Coulomb };
/// Velocity profile over the opening of the silo gate (free-surface chute, left side).
///  Uniform: u = u_in over 0 <= z < h_in (plug flow out of the silo; the documented default).
///  CopyInterior: the shape of the first interior 2D column u(0, z) scaled to the mean u_in
///                (eq. 25, d/dx d/dz u = 0; used by the 2D side of a 1D-to-2D interface).
enum class InflowShape { Uniform, CopyInterior };
/// How the pressure of eq. (26), p = g cos(zeta)(h - z)(1 + K)/2, enters at the inflow side.
///  None:      not at all (a silo gate; the inflow column's pressure is solved like any other).
///  Dirichlet: the paper's literal reading: the material cells of the inflow column are
///             Dirichlet cells of the projection with that p, so continuity is not enforced
///             there (measured: the 2D flow behind a 1D-to-2D interface decelerates).
///  Rheology:  the inflow column stays in the projection (div u = 0, p solved); eq. (26) is the
///             pressure its yield stress tau_y = tau_c + tau_p p sees (the 1D side's pressure
///             at x_IF, where the 2D pressure is still adjusting to the injected state).
enum class InflowPressure { None, Dirichlet, Rheology };
/// The names of the "N-DAM" list's values ('Momentum', 'Pressure coupling', a side's kind).
const char* to_string(Momentum m);
const char* to_string(PressureCoupling c);
const char* to_string(WallKind k);

/// Boundary condition of one side of the box. `velocity` is the tangential wall velocity of a
/// moving lid (u on bottom/top, w on left/right).
struct Wall {
  WallKind kind = WallKind::NoSlip;
  double velocity = 0.0;
};

/// Numerical parameters of the N-DAM ("N-DAM" sublist). getValidParameters() takes its defaults
/// from a default-constructed one. The members without a parameter of their own (the gate, the
/// open outflow, x0, the interface options) come from the Channel (from_parameters) or from the
/// coupled model (SubdomainFactory, Interface).
/// 'Surface pressure' = Ghost fluid at walls: the columns next to a wall end of the channel
/// whose Surface cells are ghost-fluid cells. The wall-impact sheet of NaSt2D's surface is one
/// column wide at every resolution (docs/validation.md). Of 2, 3 and 4 columns measured on the
/// stability suite, 2 was best (with 3 or 4 the nu = 1e-5 case reached 5.8 / 5.4 m/s at the
/// edge of the zone, x = 0.983 m, against 4.37 m/s with 2).
constexpr int kGhostWallColumns = 2;

struct NdamConfig {
  Grid grid{64, 32, 1.0, 0.15};  ///< lx: the Channel's length (from_parameters)
  Momentum momentum = Momentum::Implicit;
  double cfl = 0.5;
  /// 'Viscous surface number' K: with the implicit momentum step and a free surface,
  /// dt <= K min(dx, dz)^2 / nu (nu the Newtonian viscosity); 0: no such limit.
  double viscous_surface_number = 20.0;
  double gamma = 0.5;  ///< donor-cell weight of the convective terms (0: central, 1: upwind)
  /// By Side: no-slip walls, free-slip top (the lid of a box that holds a free surface).
  std::array<Wall, 4> walls{Wall{}, Wall{}, Wall{}, Wall{WallKind::FreeSlip, 0.0}};
  /// Obstacle rectangles {x0, x1, z0, z1} [m]: cells whose centre lies inside are obstacles
  /// (rigid, no-slip surfaces).
  std::vector<std::array<double, 4>> obstacles;
  /// Belos lists (solvers::LinearSystem) of the implicit viscous step and of the projection.
  Teuchos::ParameterList momentum_solver = default_momentum_solver();
  Teuchos::ParameterList pressure_solver = default_pressure_solver();
  PressureCoupling pressure_coupling = PressureCoupling::Lagged;
  /// "Pressure Newton": NonlinearSystem's list with the defaults of the pressure system.
  Teuchos::ParameterList pressure_newton = default_pressure_newton();
  /// 'Pressure Newton failure' = Continue: an unconverged step keeps NOX's best iterate
  /// (counted in summary.json) instead of stopping the run.
  bool newton_failure_continue = false;
  /// 'Load balance' = Material: on several ranks the x-slabs follow the material cells
  /// (rebalanced as the material moves, load_balance.cpp); false: equal columns.
  bool balance_material = true;
  /// How the nonlinear pressure system is solved ('Pressure iteration'): the Anderson-
  /// accelerated fixed point q <- P(q) (default) or NOX's Jacobian-free Newton-Krylov.
  PressureIteration pressure_iteration = PressureIteration::Anderson;
  int anderson_depth = 5;  ///< 'Anderson depth': differences kept by the Anderson mixing
  /// 'Anderson fallback' = Newton-Krylov: a step whose Anderson iteration stalls is taken on
  /// by NOX's Newton-Krylov from Anderson's best iterate, to the same target
  bool anderson_fallback = true;

  // --- free-surface chute ---------------------------------------------------------------------
  /// Material tracked by markers: cells with markers are Fluid/Surface, the others Empty (p = 0).
  bool free_surface = false;
  int markers_per_cell = 4;  ///< n_x = n_z of the marker sub-lattice
  /// a marker into each enclosed void cell of the sampling (NdamSolver::fill_marker_voids)
  bool fill_marker_voids = true;
  /// 'Surface cell mass' = Material share: the momentum rows of faces next to a partly filled
  /// Surface cell (top side empty) weight their mass and their non-viscous forces by the
  /// material share of the face's cells (momentum.cpp); false: every cell as a full cell.
  /// The default since session 45: the full cell of NaSt2D lets a layer whose depth ends
  /// inside a cell run away below its friction angle (docs/validation.md, "The material
  /// share as the default").
  bool surface_mass_share = true;
  /// 'Surface cell mass' = Full cell and weight: every cell a full cell, and the Coulomb bed
  /// friction loaded with the weight of the full cells of its columns (the empty part of a
  /// column's top material cell added to the markers' depth), as the momentum step drives
  /// them: a plug then follows its friction law at any depth (boundaries.cpp,
  /// update_friction; the yield pressure in viscosity.cpp; the shared column depth col_hs_)
  bool full_cell_weight = false;
  /// 'Surface pressure' = Ghost fluid: Surface cells whose centre lies below the free surface
  /// are pressure unknowns, with p = 0 imposed at the surface's position on the faces to their
  /// Empty neighbours (a ghost value), and those faces are momentum unknowns
  /// (free_surface.cpp); false ('Surface cells'): NaSt2D's Surface cells as Dirichlet cells
  /// whose empty faces follow continuity.
  bool ghost_surface = true;
  /// With ghost_surface: > 0 confines the ghost-fluid cells to this many columns next to a wall
  /// end of the channel ('Surface pressure' = Ghost fluid at walls, the default since
  /// 2026-12-05: NaSt2D's Surface cells elsewhere); 0: everywhere ('Ghost fluid').
  int ghost_wall_columns = kGhostWallColumns;
  bool wall_left = false;  ///< the box's left end is a wall of the channel (no gate, no interface)
  /// Initial layer z < initial_depth on initial_x0 <= x < initial_x1 (0: no initial material);
  /// the default end 1e30 m lies beyond any channel: the layer reaches the end of the box.
  double initial_depth = 0.0, initial_x0 = 0.0, initial_x1 = 1e30;
  /// Silo gate at x = x0 (left side): {h_in, u_in} at time t; empty function: no inflow.
  std::function<std::array<double, 2>(double t)> inflow;
  /// An inflow series (not a constant gate): the volume per unit width that enters in
  /// [t0, t1], the exact integral of h u (InflowSeries::discharge); empty function otherwise.
  std::function<double(double t0, double t1)> inflow_volume;
  InflowShape inflow_shape = InflowShape::Uniform;
  /// How the pressure of eq. (26) enters on the inflow column (see InflowPressure).
  InflowPressure inflow_pressure = InflowPressure::None;
  double inflow_K = 1.0;  ///< earth pressure coefficient K of eq. (26)
  bool outflow_right = false;  ///< open outflow at x = x0 + L (else the Right wall)
  /// Open outflow: u continues beyond the last interior face with the lagged (t^n) gradient of
  /// the last two interior faces where it accelerates, instead of zero gradient (the 2D side of
  /// a 2D-to-1D interface inside an accelerating flow; the channel's own open end keeps zero
  /// gradient; NdamSolver::outflow_slope).
  bool outflow_extrapolate = false;
  double m_c = 100.0;  ///< [s/m] regularisation of the Coulomb friction factor (12)
  double x0 = 0.0;     ///< grid origin along the slope [m] (2D subdomains of the coupled model)

  bool periodic_x() const { return walls[0].kind == WallKind::Periodic; }
  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();
  /// The validated defaults of the 'Momentum solver', 'Pressure solver' and 'Pressure Newton'
  /// sublists (the solvers' own lists with the defaults that suit the N-DAM's systems).
  static Teuchos::ParameterList default_momentum_solver();
  static Teuchos::ParameterList default_pressure_solver();
  static Teuchos::ParameterList default_pressure_newton();
  /// Reads a validated "N-DAM" list. `user` is the list as written (or null); the box length
  /// is the Channel's; `ranks` is checked against the columns (each rank needs >= 2 columns).
  static NdamConfig from_parameters(const Teuchos::ParameterList& validated,
                                    const Teuchos::ParameterList* user,
                                    const core::Channel& channel, int ranks);
};

/// Physical constants the N-DAM uses (passed, never global).
struct NdamPhysics {
  double gx = 0.0;    ///< g sin(zeta)
  double gz = -9.81;  ///< -g cos(zeta)
  double density = 1440.0;
  double tan_delta = 0.0;  ///< tan of the bed friction angle (Coulomb walls)
  static NdamPhysics from(const core::Material& m, const core::Channel& c);
};

}  // namespace granflow::ndam
