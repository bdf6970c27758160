// N-DAM parameters: grid, momentum treatment, CFL and donor-cell weight, boundary condition per
// side, and the two linear solvers (Belos + preconditioner settings passed through).
#include "granflow/ndam/ndam_solver.hpp"
#include "granflow/solvers/nonlinear_system.hpp"

#include "granflow/params/parameters.hpp"

#include <cmath>
#include <sstream>

namespace granflow::ndam {

namespace {
const std::vector<std::string> kWallKinds{"No-slip", "Free-slip", "Moving lid", "Periodic",
                                          "Coulomb"};
const char* kSideNames[4] = {"Left", "Right", "Bottom", "Top"};

WallKind parse_wall(const std::string& s) {
  if (s == "No-slip") return WallKind::NoSlip;
  if (s == "Free-slip") return WallKind::FreeSlip;
  if (s == "Moving lid") return WallKind::MovingLid;
  if (s == "Coulomb") return WallKind::Coulomb;
  return WallKind::Periodic;
}
}  // namespace

const char* to_string(Momentum m) { return m == Momentum::Explicit ? "Explicit" : "Implicit"; }
const char* to_string(PressureCoupling c) {
  return c == PressureCoupling::Nonlinear ? "Nonlinear" : "Lagged";
}
const char* to_string(WallKind k) { return kWallKinds[static_cast<std::size_t>(k)].c_str(); }

// The momentum preconditioner switches on the stiffness S = nu_eff,max dt / h^2 (momentum.cpp):
// symmetric Gauss-Seidel while S is small (flows: 5-25 GMRES iterations, no setup), smoothed
// aggregation with u and w as two equations per node from S = kStiffThreshold on (deposits at
// rest, where S reaches 1e4: the column collapse needs 144 iterations per solve with fresh
// Gauss-Seidel, up to 385, and 19 with MueLu, up to 31). Measurements: docs/validation.md,
// "Momentum solve on deposits".
Teuchos::ParameterList NdamConfig::default_momentum_solver() {
  constexpr double kStiffThreshold = 300.0;
  auto pl = *solvers::LinearSystem::getValidParameters("N-DAM->Momentum solver", "GMRES",
                                                       "Ifpack2 RELAXATION", 1e-10);
  // No lagged preconditioner: the matrix is reassembled in a step only because nu_eff or dt
  // changed, and nu_eff changes by orders of magnitude where material starts or stops. A
  // preconditioner of the previous step's matrix (same pattern) then needed 775-1000 GMRES
  // iterations where a fresh one needs 13-18 (the lab chute's wall deposit at t = 2.3 s, both
  // with Gauss-Seidel and with MueLu), and the runs stopped there.
  pl.set("Preconditioner reuse", 0,
         "assemblies of the same sparsity pattern for which a preconditioner may be reused "
         "(lagged) before it is rebuilt. 0 (the default here): rebuild after every assembly; "
         "the momentum matrix is reassembled only when nu_eff or dt changed, and a lagged "
         "preconditioner failed where nu_eff jumps (material starting or stopping)");
  solvers::LinearSystem::add_stiff_switch(
      pl, "MueLu", kStiffThreshold,
      "S = nu_eff,max dt / min(dx, dz)^2, the largest viscous diffusion number of the step "
      "(nu_eff,max over the box, all ranks)");
  return pl;
}

// The pressure preconditioner switches on d, the distance in cells from the farthest pressure
// unknown to a Dirichlet cell (projection.cpp, dirichlet_distance). MueLu's setup, in each step
// whose free surface changed the pattern (nearly every step), costs about 6 ms for the 5000
// unknowns of Setup II at 1.3 mm besides its 10 CG iterations; CG with SSOR (omega from d)
// needs about 55 iterations at d = 47 there, at 0.1 ms each and no setup to speak of. A
// flowing layer is solved faster without MueLu, a deep deposit (and a box without a free
// surface, where d is unbounded) with it. Measurements: docs/validation.md, "Speed: the
// pressure preconditioner by the distance to the free surface".
Teuchos::ParameterList NdamConfig::default_pressure_solver() {
  constexpr double kDistanceThreshold = 64.0;
  auto pl = *solvers::LinearSystem::getValidParameters("N-DAM->Pressure solver", "CG",
                                                       "Ifpack2 RELAXATION", 1e-10);
  solvers::LinearSystem::add_stiff_switch(
      pl, "MueLu", kDistanceThreshold,
      "d, the largest distance in cells (steps between face neighbours through pressure "
      "unknowns) from a pressure unknown to a cell of given pressure (the free surface); 1e300 "
      "without one (a closed box: the stiff preconditioner at any threshold). Below the "
      "threshold Ifpack2 RELAXATION is SSOR with 'relaxation: damping factor' = "
      "2 / (1 + 4.5 / d) unless the Ifpack2 sublist sets one");
  return pl;
}

// The Newton solver of the pressure system: NonlinearSystem's list with the defaults that suit
// the fixed-point form R(q) = (q - P(q)) / p_ref (p_ref: see docs/numerics.md). Its Jacobian
// I - dP/dq is the identity plus the yield-stress coupling, so no preconditioner is needed (the
// Poisson operator is already inverted inside P) and GMRES converges in a few iterations;
// Jacobian-free because P contains the momentum and pressure solves.
Teuchos::ParameterList NdamConfig::default_pressure_newton() {
  Teuchos::ParameterList nl = *solvers::NonlinearSystem::getValidParameters();
  auto redefault = [&nl](const std::string& name, auto value) {
    const auto& e = nl.getEntry(name);
    const auto validator = e.validator();
    const std::string doc = e.docString();
    nl.set(name, value, doc, validator);
  };
  redefault("Method", std::string("Jacobian-free Newton-Krylov"));
  redefault("Preconditioner", std::string("None"));
  redefault("Absolute tolerance", 1e-5);
  redefault("Relative tolerance", 1e-2);
  // 25, not 10: in the resting deposit of Setup II at 2.6 mm (1.4-1.5 s) the lagged step moves
  // p by 8x its usual amount, cells cross p = 0 (the kink of tau_y = sin(phi) max(p, 0)) between
  // iterates, and Anderson converges slowly there: up to 17 iterations in the 520 steps from
  // 1.25 s, where 10 stopped the run at 1.416 s. Not a cure: another run of that scene still
  // stops at 1.443 s, cycling just above its tolerance (docs/validation.md); such a step is
  // now taken on by the Newton-Krylov fallback ('Anderson fallback'). Steps take 3 on average,
  // so the limit costs only where a solve would otherwise fail.
  redefault("Max Newton iterations", 25);
  redefault("Krylov tolerance", 1e-2);
  redefault("Max Krylov iterations", 50);
  return nl;
}

Teuchos::RCP<const Teuchos::ParameterList> NdamConfig::getValidParameters() {
  static Teuchos::RCP<const Teuchos::ParameterList> valid = [] {
    using namespace params;
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("N-DAM"));
    const NdamConfig d;
    add_int(*pl, "Cells x", d.grid.nx,
            "cells along the slope on [0, L] (L = Channel->Length); each MPI rank needs at "
            "least 2 columns",
            2, 100000);
    add_int(*pl, "Cells z", d.grid.nz, "cells normal to the slope on [0, Height]", 2, 100000);
    add_double(*pl, "Height", d.grid.lz,
               "Lz [m]: height of the box normal to the slope. The paper leaves the domain height "
               "open; 0.15 m holds the 0.11 m deposit of its Setup II",
               1e-6, 1e6);
    add_enum(*pl, "Momentum", to_string(d.momentum),
             "Explicit: the paper's scheme, viscous stress at t^n (dt also limited by the "
             "viscous condition); Implicit: viscous stress at t^{n+1} with nu_eff lagged, "
             "solved with Belos (dt from the advective CFL condition alone; the default for "
             "stiff, viscoplastic scenes)",
             {"Explicit", "Implicit"});
    add_double(*pl, "CFL", d.cfl,
               "safety factor tau of the time step dt = tau min(dx/|u|max, dz/|w|max) (and, "
               "explicit only, tau / (4 nu_eff,max (1/dx^2 + 1/dz^2))); with a free surface "
               "also min(tau, 0.5) dx / sqrt(g cos(zeta) h) of the deepest column (the "
               "explicit surface's stability: a wave Courant number of 1 woke resting "
               "deposits)",
               1e-4, 1.0);
    add_double(*pl, "Viscous surface number", d.viscous_surface_number,
               "K of the time-step limit dt <= K min(dx, dz)^2 / nu of the implicit momentum "
               "step with a free surface (nu the Newtonian 'Rheology->Viscosity'; 0: no such "
               "limit). The viscous stress is implicit, but the free surface's velocity "
               "conditions (the faces towards Empty cells) are set from the last iterate, and "
               "at large nu dt / dx^2 that explicit part amplified: Setup II with nu = 0.3 "
               "m^2/s at 5 mm diverged at nu dt / dx^2 = 36-48 (surface cells at 20-40 m/s "
               "behind the gate) and held at 30 at six output intervals; nu = 0.1-1 at 2.5 and 5 "
               "mm, to 2.5 s, held at 20 (docs/validation.md, 'A viscous step limit for the "
               "free surface'). At the default viscosity (0.003) it never binds. 20 is for "
               "stability, not accuracy: a viscous flow's position converges only below it "
               "(nu = 0.1, 5 mm: the material's centroid 4-8 % short at the CFL step, within "
               "2 % of its limit and independent of the output interval at 2.5)",
               0.0, 1e6);
    add_double(*pl, "Donor-cell weight", d.gamma,
               "gamma: blend of the convective terms between central differences (0) and "
               "donor-cell upwinding (1), NaSt2D's form. Where convection dominates, "
               "stability needs gamma >= max(|u| dt/dx, |w| dt/dz), i.e. gamma >= CFL (the "
               "default 0.5 with the default CFL 0.5; below it a chute is not protected by "
               "this condition: Setup II at 10 mm with gamma 0 stopped with exit 3 at 0.72 s "
               "on an earlier build; today it completes at 10 and 5 mm to 1.5 s, max |u| "
               "3.5 m/s as with the default, its depth 4-9 % (L2) from the default's while "
               "the chute flows at 5 mm); a viscous flow at cell Reynolds numbers "
               "|u| dx / nu below about 2 is stable with central differences (the shipped "
               "cavities at Re 100 and the Bingham cavity take gamma = 0)",
               0.0, 1.0);
    add_string(*pl, "Obstacles", "",  // d.obstacles: none
               "rigid obstacles inside the box as rectangles 'x0 x1 z0 z1' [m], separated by "
               "';' (e.g. '0.4 0.6 0 0.05; 0.8 0.9 0 0.1'): cells whose centre lies inside are "
               "obstacle cells with no-slip surfaces. Empty: none. The fluid cells must form "
               "one connected region");
    auto& b = pl->sublist("Boundaries", false,
                          "boundary condition of each side of the box [0, L] x [0, Height]");
    for (int s = 0; s < 4; ++s) {
      const std::string side(kSideNames[s]);
      const bool z_side = side == "Bottom" || side == "Top";
      const Wall& dw = d.walls[static_cast<std::size_t>(s)];
      add_enum(b, side, to_string(dw.kind),
               side + " side: No-slip wall, Free-slip wall, Moving lid (no-slip wall moving "
                      "tangentially with '" + side + " lid velocity'), Periodic (Left and "
                      "Right together only), or Coulomb (Bottom and Right only: the sliding law "
                      "(11)-(13) with delta = Material->Bed friction angle and 'Friction "
                      "regularisation' m_c). Not a Moving lid on a side that carries the "
                      "gate (Left with Channel inflow); in a coupled channel a side that is an "
                      "interface takes the interface's condition (a lid stays at x = 0)",
               kWallKinds);
      add_double(b, side + " lid velocity", dw.velocity,
                 std::string("[m/s] tangential velocity of a Moving lid on this side (") +
                     (z_side ? "u, along x" : "w, along z") + ")",
                 -1e6, 1e6);
    }
    add_bool(*pl, "Free surface", d.free_surface,
             "track the material by marker particles (paper section 2.3): cells with markers "
             "are Fluid/Surface, the others Empty (p = 0); needed for a chute with Channel "
             "inflow/outflow. false: the box is full (cavity, rest tests)");
    add_int(*pl, "Markers per cell", d.markers_per_cell,
            "markers per cell along x and along z (n x n per cell) of the free surface", 1, 16);
    add_bool(*pl, "Fill marker voids", d.fill_marker_voids,
             "move a marker into every cell without markers that is enclosed by material, "
             "the bed or walls (a void of the sampling, where a stretching flow spread the "
             "markers apart; its p = 0 would cut the pressure around it), from its neighbour "
             "with the most markers (where none keeps one, from the second ring), by about a "
             "cell (at most about two); mass is exact. Over the opening of a 1D-to-2D interface the side is "
             "open (the atmosphere over the 1D layer), so the air there is not a void "
             "(docs/numerics.md, 'Voids of the marker sampling'). false: the voids stay Empty "
             "cells");
    add_enum(*pl, "Surface cell mass",
             d.surface_mass_share ? "Material share"
                                  : (d.full_cell_weight ? "Full cell and weight" : "Full cell"),
             "mass of a partly filled Surface cell (its top side empty) in the momentum step. "
             "Material share (the default; Implicit momentum only, so a scene with Momentum = "
             "Explicit sets one of the other two): the rows of its faces weight mass and "
             "non-viscous forces by the share of the cells that holds material. "
             "Full cell: NaSt2D's (the default until session 45); such a cell is driven by gravity over its "
             "whole volume but held by the friction of the true depth, so a layer whose depth "
             "ends inside a cell slides ahead of its friction law (5 mm cells, 30/22/33 deg: "
             "+15 to +126 % at 0.46-4.3 cells), a viscous film flows as if as deep as its top "
             "cell, and a layer on a slope zeta below delta whose depth h ends inside its n-th "
             "cell does not stop where tan(zeta) n dz / h > tan(delta) (3.3 cells on 24 deg "
             "below delta = 28 deg accelerates). Full cell and "
             "weight: the same mass, and the bed friction and the yield pressure of the "
             "column's cells loaded with the weight of the full cells, so a plug follows its "
             "law and a layer below delta rests. The two consistent forms (Material share, "
             "Full cell and weight) take a column depth that shares each marker "
             "between its two nearest columns and is spread over about two cells: a plug "
             "follows its law within 1 % at 0.46-4.3 cells (2.5-10 mm, six angle sets, "
             "Regularisation 100 and, deeper than a cell, 1e4; the Material share within "
             "0.35 %), and within 1.5 % (5 mm) to 3 % (2.5 mm) in one partly filled row with "
             "Regularisation 1e4. docs/validation.md, 'The weight of the full cells', 'The plug "
             "law at any depth' and 'The bed's normal stress from the step's own balance' "
             "(scripts/plug_law.py)",
             {"Full cell", "Full cell and weight", "Material share"});
    add_enum(*pl, "Surface pressure",
             !d.ghost_surface ? "Surface cells"
                              : (d.ghost_wall_columns > 0 ? "Ghost fluid at walls" : "Ghost fluid"),
             "how the free surface enters the projection. Surface cells: NaSt2D's and the "
             "paper's; Surface cells are Dirichlet cells (p = 0 at the marker depth, "
             "hydrostatically offset to the cell centre) and their faces to Empty cells follow "
             "continuity, so nothing brakes a Surface cell's inflow (the one-column sheet at a "
             "wall impact). Ghost fluid: a Surface cell whose centre lies below the surface is "
             "a pressure unknown like a Fluid cell; p = 0 is imposed where the surface crosses "
             "the line to each Empty neighbour (a ghost value, Gibou et al. 2002) and those "
             "faces are momentum unknowns; the wall-impact sheet is braked (docs/numerics.md, "
             "\"Ghost-fluid free surface\"). Ghost fluid at walls: the ghost-fluid cells in the "
             "two columns next to a wall end of the channel (where a layer meets the wall), "
             "NaSt2D's Surface cells elsewhere (docs/numerics.md, \"Ghost fluid at walls\"). "
             "The ghost fluid not yet with Pressure coupling = Nonlinear",
             {"Surface cells", "Ghost fluid", "Ghost fluid at walls"});
    add_double(*pl, "Initial depth", d.initial_depth,
               "[m] free surface: material layer z < depth at t = 0 on [Initial x0, Initial x1) "
               "(0: the chute starts empty); the markers carry dx dz / n^2 each (n = 'Markers "
               "per cell') and those of a partly covered row are shared out over the columns: "
               "the layer's mean depth is the given one, a column's differs from it by less "
               "than a marker, dz / n^2 (6.5 mm in 5 mm cells with n = 4: columns of 6.25 and "
               "6.5625 mm)",
               0.0, 1e6);
    add_double(*pl, "Initial x0", d.initial_x0, "[m] start of the initial layer along the slope",
               -1e6, 1e6);
    add_double(*pl, "Initial x1", d.initial_x1, "[m] end of the initial layer along the slope",
               -1e6, 1e30);
    add_double(*pl, "Friction regularisation", d.m_c,
               "m_c [s/m] of the Coulomb friction factor c_F = tan(delta) (1 - exp(-m_c |u_b|)) "
               "(eq. 12): friction is fully mobilised above a sliding speed of a few 1/m_c. "
               "The paper leaves m_c open; 100 s/m (1/m_c = 1 cm/s, well below the chute's "
               "0.4-3 m/s) is the default",
               1e-6, 1e9);
    pl->set("Momentum solver", d.momentum_solver,
            "Belos solver of the implicit viscous stress. GMRES by default: with a free surface "
            "the matrix is not symmetric (faces on the empty side of a Surface cell and the "
            "open outflow face follow neighbouring unknowns), and CG fails there (measured: "
            "coupled Setup II with Bingham material stalled at t = 0.28 s); CG suits the "
            "symmetric positive definite closed and periodic boxes. Default preconditioner: "
            "one symmetric Gauss-Seidel sweep (Ifpack2 RELAXATION) while the stiffness "
            "nu_eff,max dt / h^2 is below 'Stiff threshold': there the 1/dt diagonal keeps "
            "the system well conditioned, and with the free surface the matrix changes every "
            "step, so an AMG setup per step cost more than the iterations it saves (Setup II: "
            "4-8 iterations with MueLu, 8-28 with SGS, about 6x less time). From the threshold "
            "on (deposits at rest, nu_eff dt / h^2 up to 1e4) MueLu ('Stiff preconditioner'; "
            "column collapse: 19 GMRES iterations per solve against 144 with SGS). With MueLu, "
            "u and w are two equations per node ('number of equations' = 2)");
    pl->set("Pressure solver", d.pressure_solver,
            "Belos solver of the pressure Poisson equation (symmetric positive definite: CG)");
    add_enum(*pl, "Pressure coupling", to_string(d.pressure_coupling),
             "how the pressure enters the yield stress tau_y = tau_c + tau_p p and the Coulomb "
             "law (13): Lagged: at t^n (one predictor-projection per step); Nonlinear: at "
             "t^{n+1}, the paper's nonlinear pressure system (10)+(13)+(14), solved in every "
             "step on the fixed-point form q = P(q) of one predictor-projection ('Pressure "
             "iteration'; tolerances in 'Pressure Newton'), the no-slip clamps of the Coulomb "
             "faces kept from the lagged step. With tau_p = 0 and no Coulomb side the "
             "system is linear and both are the same",
             {"Lagged", "Nonlinear"});
    pl->set("Pressure Newton", d.pressure_newton,
            "NOX solver of the nonlinear pressure system ('Pressure coupling' = Nonlinear). The "
            "residual is R(q) = (q - P(q)) / (p_ref sqrt(N)), p_ref = g cos(zeta) Height, N the "
            "cells of the box: ||R||_2 is the RMS pressure mismatch relative to the hydrostatic "
            "pressure at the bottom of the box. A step whose Newton solve does not converge "
            "stops the run with a diagnosis");
    add_enum(*pl, "Pressure Newton failure", d.newton_failure_continue ? "Continue" : "Stop",
             "what a step does whose nonlinear pressure solve does not reach its tolerance: "
             "Stop: the run stops with a diagnosis (the last good output and checkpoint are "
             "kept); Continue: the step keeps the solver's best iterate (smallest ||R|| found), prints a "
             "warning once and counts such steps and their worst ||R|| in summary.json "
             "(ndam.newton). Continue is for a reference run that meets a few cells where the "
             "system has no nearby root (measured on Setup II before the rotational correction "
             "was taken at the lagged predictor: the free surface at the end wall)",
             {"Stop", "Continue"});
    add_enum(*pl, "Load balance", d.balance_material ? "Material" : "Columns",
             "how the columns of the box are split into x-slabs over the MPI ranks: Material: "
             "by the work of each column (its material cells, and a small share for its empty "
             "ones), checked every few steps and rebuilt from the state when a rank holds more "
             "than 10 % above the mean (a chute filling from the gate, a deposit growing at "
             "the wall); Columns: equal numbers of columns, fixed. One rank: no effect. Full "
             "2D only: the 2D subdomains of a coupled channel keep the equal split (refused "
             "there)",
             {"Material", "Columns"});
    add_enum(*pl, "Pressure iteration",
             d.pressure_iteration == PressureIteration::Anderson ? "Anderson fixed point"
                                                                 : "Newton-Krylov",
             "solver of the nonlinear pressure system ('Pressure coupling' = Nonlinear): "
             "Anderson fixed point: q <- P(q) with Anderson mixing of the last 'Anderson depth' "
             "iterates, one predictor-projection per iteration (Setup II: 2-4 per step, a "
             "third of Newton's; docs/numerics.md); Newton-Krylov: NOX's Jacobian-free "
             "Newton-Krylov ('Pressure Newton' list: Krylov and line-search settings). Both use "
             "the tolerances, the iteration limit and the Verbose flag of 'Pressure Newton' "
             "(Absolute tolerance, Relative tolerance, Max Newton iterations)",
             {"Anderson fixed point", "Newton-Krylov"});
    add_int(*pl, "Anderson depth", d.anderson_depth,
            "'Pressure iteration' = Anderson fixed point: how many previous iterates the "
            "Anderson mixing combines (0: the plain fixed-point iteration q <- P(q))",
            0, 50);
    add_enum(*pl, "Anderson fallback", d.anderson_fallback ? "Newton-Krylov" : "None",
             "'Pressure iteration' = Anderson fixed point: what a step does whose Anderson "
             "iteration reaches 'Max Newton iterations' without its tolerance. Newton-Krylov: "
             "NOX's Jacobian-free Newton-Krylov goes on from Anderson's best iterate to the same "
             "target, ||R|| <= max(Absolute tolerance, Relative tolerance ||R(p^n)||), with the "
             "'Pressure Newton' settings (Setup II at 2.6 mm in the resting deposit: Anderson "
             "stalled at 1.0e-3 against 5.8e-4, Newton-Krylov reached 2.9e-4 in 3 Newton steps, "
             "33 projections; docs/validation.md); only if that fails too does 'Pressure Newton "
             "failure' act. None: 'Pressure Newton failure' acts on the Anderson result",
             {"Newton-Krylov", "None"});
    return pl;
  }();
  return valid;
}

NdamConfig NdamConfig::from_parameters(const Teuchos::ParameterList& pl,
                                       const Teuchos::ParameterList* user,
                                       const core::Channel& channel, int ranks) {
  NdamConfig c;
  c.grid.nx = pl.get<int>("Cells x");
  c.grid.nz = pl.get<int>("Cells z");
  c.grid.lx = channel.length;
  c.grid.lz = pl.get<double>("Height");
  c.momentum = pl.get<std::string>("Momentum") == "Explicit" ? Momentum::Explicit
                                                             : Momentum::Implicit;
  c.cfl = pl.get<double>("CFL");
  c.viscous_surface_number = pl.get<double>("Viscous surface number");
  c.free_surface = pl.get<bool>("Free surface");
  // (the surface cell mass is a setting of the free surface: without one every material cell
  // is full, and a closed box with Momentum = Explicit does not meet the share's refusal)
  const std::string mass = pl.get<std::string>("Surface cell mass");
  c.surface_mass_share = c.free_surface && mass == "Material share";
  c.full_cell_weight = c.free_surface && mass == "Full cell and weight";
  if (c.surface_mass_share && c.momentum == Momentum::Explicit)
    params::fail(pl, "Surface cell mass", "Material share",
                 "the material share weights the mass of the implicit momentum step; with "
                 "Momentum = Explicit it would divide the explicit viscous stress by it; "
                 "allowed with Explicit: Full cell or Full cell and weight (Material share is "
                 "the default: a scene with Momentum = Explicit and a free surface sets one of "
                 "them)");
  {
    const std::string sp = pl.get<std::string>("Surface pressure");
    c.ghost_surface = sp != "Surface cells";
    c.ghost_wall_columns = sp == "Ghost fluid at walls" ? kGhostWallColumns : 0;
  }
  c.gamma = pl.get<double>("Donor-cell weight");
  if (c.grid.nx < 2 * ranks)
    params::fail(pl, "Cells x", Teuchos::toString(c.grid.nx),
                 "too few columns for " + std::to_string(ranks) +
                     " MPI ranks; allowed: >= 2 per rank (" + std::to_string(2 * ranks) + ")");

  const auto& b = pl.sublist("Boundaries");
  const Teuchos::ParameterList* ub =
      user && user->isSublist("Boundaries") ? &user->sublist("Boundaries") : nullptr;
  for (int s = 0; s < 4; ++s) {
    const std::string side = kSideNames[s];
    Wall w;
    w.kind = parse_wall(b.get<std::string>(side));
    w.velocity = b.get<double>(side + " lid velocity");
    if (w.kind == WallKind::Periodic && s >= 2)
      params::fail(b, side, "Periodic",
                   "the box is periodic only along the slope; allowed on Bottom/Top: No-slip, "
                   "Free-slip, Moving lid");
    if (w.kind != WallKind::MovingLid && ub && ub->isParameter(side + " lid velocity"))
      params::fail(b, side + " lid velocity", params::str(w.velocity),
                   "given for a side of type '" + b.get<std::string>(side) +
                       "'; allowed only with " + side + " = Moving lid");
    // a lid is a wall that moves: without its speed it would be a No-slip wall by default
    if (w.kind == WallKind::MovingLid && ub && !ub->isParameter(side + " lid velocity"))
      params::fail(b, side, "Moving lid",
                   "needs '" + side + " lid velocity' (its tangential speed); allowed: give '" +
                       side + " lid velocity', or another side type");
    c.walls[static_cast<std::size_t>(s)] = w;
  }
  const bool pl_ = c.walls[0].kind == WallKind::Periodic, pr = c.walls[1].kind == WallKind::Periodic;
  if (pl_ != pr)
    params::fail(b, "Right", b.get<std::string>("Right"),
                 "Periodic must be set on Left and Right together (Left is '" +
                     b.get<std::string>("Left") + "'); allowed: Periodic on both or on neither");
  c.markers_per_cell = pl.get<int>("Markers per cell");
  c.fill_marker_voids = pl.get<bool>("Fill marker voids");
  c.balance_material = pl.get<std::string>("Load balance") == "Material";
  c.initial_depth = pl.get<double>("Initial depth");
  c.initial_x0 = pl.get<double>("Initial x0");
  c.initial_x1 = pl.get<double>("Initial x1");
  c.m_c = pl.get<double>("Friction regularisation");
  for (int s : {0, 3})
    if (c.walls[static_cast<std::size_t>(s)].kind == WallKind::Coulomb)
      params::fail(b, kSideNames[s], "Coulomb",
                   "the sliding law is applied on the bed and the end wall; allowed on " +
                       std::string(kSideNames[s]) + ": No-slip, Free-slip, Moving lid" +
                       (s == 0 ? ", Periodic" : ""));
  if (c.initial_depth > 0.0 && !c.free_surface)
    params::fail(pl, "Initial depth", params::str(c.initial_depth),
                 "an initial layer needs 'Free surface' = true; allowed: 0");
  // A layer on an empty or outside range would start the run with no material, silently.
  if (c.initial_depth > 0.0 && !(c.initial_x1 > c.initial_x0))
    params::fail(pl, "Initial x1", params::str(c.initial_x1),
                 "must be greater than 'Initial x0' = " + params::str(c.initial_x0) +
                     " (the layer lies on [Initial x0, Initial x1)); allowed: > " +
                     params::str(c.initial_x0));
  if (c.initial_depth > 0.0 && (c.initial_x0 >= channel.length || c.initial_x1 <= 0.0))
    params::fail(pl, c.initial_x0 >= channel.length ? "Initial x0" : "Initial x1",
                 params::str(c.initial_x0 >= channel.length ? c.initial_x0 : c.initial_x1),
                 "the layer [" + params::str(c.initial_x0) + ", " + params::str(c.initial_x1) +
                     ") m lies outside the channel [0, " + params::str(channel.length) +
                     "] m; allowed: Initial x0 < " + params::str(channel.length) +
                     " and Initial x1 > 0");
  // The top of the box (Grid::material_limit): refused here, before the run that it would stop.
  const double top = c.grid.material_limit();
  if (c.initial_depth >= top)
    params::fail(pl, "Initial depth", params::str(c.initial_depth),
                 "the layer's surface must stay below the upper half of the box's top cell, "
                 "where a column stops the run; allowed: < Height - dz / 2 = " +
                     params::str(top) + " m (Height " + params::str(c.grid.lz) +
                     " m, Cells z " + std::to_string(c.grid.nz) + ")");
  // The channel ends: a full box needs Wall/Wall (or Periodic); the free-surface chute also
  // takes the silo gate (Left Inflow, Channel->Left boundary depth and velocity) and an open
  // outflow (Right Outflow), so 1D and 2D scenes of one setup read the same Channel.
  const bool ch_periodic = channel.left.type == core::BoundaryType::Periodic;
  c.wall_left = channel.left.type == core::BoundaryType::Wall;
  if (c.free_surface && !ch_periodic) {
    const bool lok = channel.left.type == core::BoundaryType::Wall ||
                     channel.left.type == core::BoundaryType::Inflow;
    const bool rok = channel.right.type == core::BoundaryType::Wall ||
                     channel.right.type == core::BoundaryType::Outflow;
    // (the full path in the message, as every other input error gives it)
    Teuchos::ParameterList root("granflow");
    Teuchos::ParameterList& where = root.sublist("Channel");
    if (!lok || pl_)
      params::fail(where.sublist("Left boundary"), "Type", core::to_string(channel.left.type),
                   "the free-surface N-DAM chute; allowed: Inflow or Wall (with N-DAM "
                   "Boundaries Left not Periodic)");
    if (!rok)
      params::fail(where.sublist("Right boundary"), "Type", core::to_string(channel.right.type),
                   "the free-surface N-DAM chute; allowed: Outflow or Wall");
    if (channel.left.type == core::BoundaryType::Inflow) {
      // The box's left side is the gate: its tangential condition (the w ghost) holds over the
      // whole side, the opening included, so a lid there drove the inflow (w = -2 m/s in the
      // gate column and u twice the inflow velocity at its foot; an independent run)
      if (c.walls[0].kind == WallKind::MovingLid)
        params::fail(b, "Left", "Moving lid",
                     "the channel's left end is the gate (Channel->Left boundary: Type = "
                     "Inflow), and the side's condition would act across the opening too; "
                     "allowed: No-slip, Free-slip");
      const core::InflowSeries series = channel.left.inflow;
      c.inflow = [series](double t) {
        return std::array<double, 2>{series.depth(t), series.velocity(t)};
      };
      if (!series.is_constant())
        c.inflow_volume = [series](double t0, double t1) { return series.discharge(t0, t1); };
      // (a series names its file and its largest depth: the depth alone stood where the file
      // name belongs; an independent run)
      if (series.max_depth() >= top)
        params::fail(where.sublist("Left boundary"),
                     series.is_constant() ? "Inflow depth" : "Inflow series file",
                     series.is_constant()
                         ? params::str(series.max_depth())
                         : series.file() + " (its largest depth h = " +
                               params::str(series.max_depth()) + " m)",
                     "the gate opening must lie below the upper half of the 2D box's top cell, "
                     "where a column stops the run; allowed: < N-DAM->Height - dz / 2 = " +
                         params::str(top) + " m (Height " + params::str(c.grid.lz) +
                         " m, Cells z " + std::to_string(c.grid.nz) + ")");
    }
    if (channel.right.type == core::BoundaryType::Outflow) {
      // The open end is the box's right side whatever Boundaries->Right says: a wall kind set
      // there had no effect (a Moving lid's 1000 m/s still raised the speed limit's bound; an
      // independent run), so only the outflow's own Free-slip is accepted
      if (ub && ub->isParameter("Right") && c.walls[1].kind != WallKind::FreeSlip)
        params::fail(b, "Right", b.get<std::string>("Right"),
                     "the channel's right end is open (Channel->Right boundary: Type = Outflow), "
                     "so the box's right side is the outflow, with zero-gradient w; allowed: "
                     "Free-slip, or leave it out");
      c.outflow_right = true;
      c.walls[1].kind = WallKind::FreeSlip;  // zero-gradient w at the open end
    }
  } else if (ch_periodic != pl_ ||
             (!ch_periodic && (channel.left.type != core::BoundaryType::Wall ||
                               channel.right.type != core::BoundaryType::Wall))) {
    // (the full path in the message, as every other input error gives it)
    Teuchos::ParameterList root("granflow");
    Teuchos::ParameterList& where = root.sublist("Channel");
    params::fail(where.sublist("Left boundary"), "Type", core::to_string(channel.left.type),
                 std::string("the channel ends and the N-DAM box's sides must agree: ") +
                     (pl_ ? "the box is periodic along x (N-DAM->Boundaries->Left and Right = "
                            "Periodic); allowed: Periodic, or sides that are not Periodic"
                          : std::string("the box is closed at x = 0 and x = L; allowed: Wall (a "
                                        "gate or an open end needs 'Free surface' true)") +
                                (ch_periodic ? ", or N-DAM->Boundaries->Left and Right = "
                                               "Periodic for a periodic channel"
                                             : "")));
  }
  // Obstacles: "x0 x1 z0 z1; ..."
  {
    const std::string spec = pl.get<std::string>("Obstacles");
    std::stringstream all(spec);
    std::string item;
    while (std::getline(all, item, ';')) {
      if (item.find_first_not_of(" \t\n") == std::string::npos) continue;
      std::istringstream is(item);
      std::array<double, 4> r{};
      std::string extra;
      if (!(is >> r[0] >> r[1] >> r[2] >> r[3]) || (is >> extra))
        params::fail(pl, "Obstacles", spec,
                     "'" + item + "' is not four numbers 'x0 x1 z0 z1'; allowed: rectangles "
                     "'x0 x1 z0 z1' separated by ';'");
      if (!(r[0] < r[1] && r[2] < r[3]) || r[0] < 0 || r[1] > c.grid.lx || r[2] < 0 ||
          r[3] > c.grid.lz)
        params::fail(pl, "Obstacles", spec,
                     "rectangle '" + item + "' is empty or leaves the box; allowed: 0 <= x0 < "
                     "x1 <= L = " + params::str(c.grid.lx) + ", 0 <= z0 < z1 <= Height = " +
                     params::str(c.grid.lz));
      c.obstacles.push_back(r);
    }
  }
  c.momentum_solver = pl.sublist("Momentum solver");
  c.pressure_solver = pl.sublist("Pressure solver");
  c.pressure_coupling = pl.get<std::string>("Pressure coupling") == "Nonlinear"
                            ? PressureCoupling::Nonlinear
                            : PressureCoupling::Lagged;
  c.pressure_newton = pl.sublist("Pressure Newton");
  // Measured (docs/validation.md, "Ghost-fluid free surface"): with the Surface cells'
  // pressures unknown, the yield stress's kink at p = 0 lies in the cells of the surface, and
  // the fixed point stalled (Setup II at 10 mm: ||R|| 3.8e-4 against 8.2e-5 at 0.54 s; the
  // gate chute of the tests 1.8e-3 against 1e-5 at its first steps).
  // With 'Ghost fluid at walls' the ghost cells lie next to a wall end only: a channel without
  // one (Setup I: gate and open outflow) runs NaSt2D's surface everywhere, and the nonlinear
  // system with it (an independent run found it refused there).
  const bool wall_end = channel.left.type == core::BoundaryType::Wall ||
                        channel.right.type == core::BoundaryType::Wall;
  if (c.pressure_coupling == PressureCoupling::Nonlinear && c.ghost_surface && c.free_surface &&
      (c.ghost_wall_columns == 0 || wall_end))
    params::fail(pl, "Pressure coupling", "Nonlinear",
                 "the nonlinear pressure system does not converge yet with 'Surface pressure' = " +
                     pl.get<std::string>("Surface pressure") +
                     (c.ghost_wall_columns > 0 ? " in a channel with a wall end" : "") +
                     "; allowed with it: Lagged (or Nonlinear with 'Surface pressure' = Surface "
                     "cells)");
  c.newton_failure_continue = pl.get<std::string>("Pressure Newton failure") == "Continue";
  c.pressure_iteration = pl.get<std::string>("Pressure iteration") == "Newton-Krylov"
                             ? PressureIteration::NewtonKrylov
                             : PressureIteration::Anderson;
  c.anderson_depth = pl.get<int>("Anderson depth");
  c.anderson_fallback = pl.get<std::string>("Anderson fallback") == "Newton-Krylov";
  // Options of a part of the model that the scene does not use are refused by name, as an
  // unused rheology parameter is: an independent run found 'Surface pressure' in a closed box
  // and 'Pressure iteration' with the lagged coupling accepted without effect.
  auto unused = [&](const char* name, const std::string& why) {
    params::fail_if_given(pl, user, name, why);
  };
  if (!c.free_surface)
    for (const char* name :
         {"Surface pressure", "Surface cell mass", "Markers per cell", "Fill marker voids",
          "Viscous surface number"})
      unused(name, "a setting of the free surface, and 'Free surface' = false; allowed: leave "
                   "it out, or 'Free surface' = true");
  // (an independent run: with Explicit, 20 and 1e-3 gave the same steps to the last bit)
  if (c.momentum == Momentum::Explicit)
    unused("Viscous surface number",
           "a step limit of the implicit momentum step, and 'Momentum' = Explicit (whose "
           "viscous limit is part of the CFL condition); allowed: leave it out, or 'Momentum' "
           "= Implicit");
  if (c.initial_depth == 0.0)
    for (const char* name : {"Initial x0", "Initial x1"})
      unused(name, "the extent of the initial layer, and 'Initial depth' = 0 (no layer); "
                   "allowed: leave it out, or 'Initial depth' > 0");
  // (an independent run: accepted with a No-slip bed and a Free-slip end wall)
  if (c.walls[1].kind != WallKind::Coulomb && c.walls[2].kind != WallKind::Coulomb)
    unused("Friction regularisation",
           "m_c of the Coulomb sliding law, and no side is Coulomb (Bottom = " +
               pl.sublist("Boundaries").get<std::string>("Bottom") +
               ", Right = " + pl.sublist("Boundaries").get<std::string>("Right") +
               "); allowed: leave it out, or Bottom or Right = Coulomb");
  if (c.pressure_coupling == PressureCoupling::Lagged)
    for (const char* name :
         {"Pressure iteration", "Anderson depth", "Anderson fallback", "Pressure Newton failure"})
      unused(name, "a setting of the nonlinear pressure system, and 'Pressure coupling' = "
                   "Lagged; allowed: leave it out, or 'Pressure coupling' = Nonlinear");
  if (c.pressure_newton.get<std::string>("Method") != "Jacobian-free Newton-Krylov")
    params::fail(pl.sublist("Pressure Newton"), "Method", c.pressure_newton.get<std::string>("Method"),
                 "the pressure system's residual contains the momentum and pressure solves, so "
                 "its Jacobian is not assembled; allowed: Jacobian-free Newton-Krylov");
  // Both tolerances 0: no solve can stop before 'Max Newton iterations' (an exact fixed point
  // in floating point), so the first step stops the run (found by an independent run: exit 3
  // at t = 0.066 s); refused here instead
  if (c.pressure_coupling == PressureCoupling::Nonlinear &&
      c.pressure_newton.get<double>("Absolute tolerance") == 0.0 &&
      c.pressure_newton.get<double>("Relative tolerance") == 0.0)
    params::fail(pl.sublist("Pressure Newton"), "Absolute tolerance", "0",
                 "with 'Relative tolerance' = 0 as well no nonlinear pressure solve can reach "
                 "its tolerance; allowed: at least one of the two above 0");
  if (c.pressure_newton.get<std::string>("Preconditioner") != "None")
    params::fail(pl.sublist("Pressure Newton"), "Preconditioner",
                 c.pressure_newton.get<std::string>("Preconditioner"),
                 "the fixed-point form of the pressure system has a Jacobian close to the "
                 "identity and no assembled matrix to build a preconditioner from; allowed: None");
  solvers::LinearSystem::check(c.momentum_solver, ranks);
  solvers::LinearSystem::check(c.pressure_solver, ranks);
  return c;
}

NdamPhysics NdamPhysics::from(const core::Material& m, const core::Channel& c) {
  NdamPhysics p;
  p.gx = c.g_sin(m.gravity);
  p.gz = -c.g_cos(m.gravity);
  p.density = m.density;
  p.tan_delta = std::tan(core::deg2rad(m.bed_friction_deg));
  return p;
}

}  // namespace granflow::ndam
