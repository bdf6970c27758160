// granflow-bench-ndam: wall time per step and per unknown of the N-DAM's momentum and pressure
// solves, with Krylov iteration counts, at several grid sizes (not a test: timings are machine
// dependent; results are recorded in docs/numerics.md).
//
//   granflow-bench-ndam [--steps N] [--rheology Newtonian|Bingham] [--momentum Implicit|Explicit]
//                       [--momentum-preconditioner MueLu|"Ifpack2 RILUK"|...]
//                       [n1 n2 ...]        (square cavity grids, default 64 256)
//   mpiexec -n 2 granflow-bench-ndam ...   (x-slabs over the ranks)
//
// Case: lid-driven cavity, Re = 100 (nu = 0.01 m^2/s, lid 1 m/s, unit box), dt from the
// advective CFL 0.5. The first 5 steps (start-up, first preconditioner setups) are not timed;
// the next N are. Bingham: tau_y = 1 m^2/s^2, m_y = 1000 s, so nu_eff reaches ~1e3 m^2/s and the
// implicit matrix and its preconditioner are rebuilt every step.
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/ndam/ndam_solver.hpp"
#include "granflow/params/parameters.hpp"
#include "granflow/solvers/linear_system.hpp"

#include <Teuchos_GlobalMPISession.hpp>
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

using namespace granflow;

namespace {
std::unique_ptr<ndam::NdamSolver> cavity(int n, const std::string& rheology,
                                         const std::string& momentum, const std::string& prec,
                                         int ranks) {
  Teuchos::ParameterList p("N-DAM");
  p.set("Cells x", n);
  p.set("Cells z", n);
  p.set("Height", 1.0);
  p.set("Momentum", momentum);
  p.set("Donor-cell weight", 0.5);
  p.sublist("Boundaries").set("Top", "Moving lid");
  p.sublist("Boundaries").set("Top lid velocity", 1.0);
  p.sublist("Momentum solver").set("Preconditioner", prec);
  const Teuchos::ParameterList user = p;
  params::validate_and_set_defaults(p, *ndam::NdamConfig::getValidParameters(), "bench");
  core::Channel ch;
  ch.length = 1.0;
  ch.slope_deg = 0.0;
  ch.left.type = ch.right.type = core::BoundaryType::Wall;
  core::Material m;
  m.gravity = 0.0;
  Teuchos::ParameterList r("Rheology");
  r.set("Model", rheology);
  r.set("Viscosity", 0.01);
  if (rheology == "Bingham") {
    r.set("Yield stress", 1.0);
    r.set("Regularisation", 1000.0);
  }
  const Teuchos::ParameterList ruser = r;
  params::validate_and_set_defaults(r, *ndam::Rheology::getValidParameters(), "bench");
  return std::make_unique<ndam::NdamSolver>(
      MPI_COMM_WORLD, ndam::NdamConfig::from_parameters(p, &user, ch, ranks),
      ndam::Rheology::from_parameters(r, &ruser, m), ndam::NdamPhysics::from(m, ch));
}
}  // namespace

int main(int argc, char** argv) {
  Teuchos::GlobalMPISession mpi(&argc, &argv, nullptr);
  solvers::Session session(&argc, &argv);
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  int steps = 20;
  std::string rheology = "Newtonian", momentum = "Implicit", prec = "MueLu";
  std::vector<int> sizes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--steps" && i + 1 < argc) steps = std::atoi(argv[++i]);
    else if (a == "--rheology" && i + 1 < argc) rheology = argv[++i];
    else if (a == "--momentum" && i + 1 < argc) momentum = argv[++i];
    else if (a == "--momentum-preconditioner" && i + 1 < argc) prec = argv[++i];
    else if (a == "--help") {
      if (rank == 0)
        std::printf("usage: granflow-bench-ndam [--steps N] [--rheology Newtonian|Bingham] "
                    "[--momentum Implicit|Explicit] [--momentum-preconditioner MueLu|'Ifpack2 RILUK'|"
                    "'Ifpack2 RELAXATION'|None] [n ...]\n");
      return 0;
    } else sizes.push_back(std::atoi(a.c_str()));
  }
  if (sizes.empty()) sizes = {64, 256};
  if (rank == 0)
    std::printf("# N-DAM benchmark: cavity Re=100, %s, %s momentum (%s), %d rank(s), %d timed steps\n"
                "# %8s %10s | %10s %9s %6s | %10s %9s %6s | %10s\n",
                rheology.c_str(), momentum.c_str(), prec.c_str(), ranks, steps, "cells", "unknowns",
                "mom s/step", "us/unk", "its", "p s/step", "us/unk", "its", "step s");
  for (int n : sizes) {
    auto s = cavity(n, rheology, momentum, prec, ranks);
    for (int q = 0; q < 5; ++q) {
      s->step(std::min(s->stable_dt(), 0.5 / n));
      s->accept();
    }
    double tm = 0, tp = 0, ttot = 0;
    long mi = 0, pi = 0;
    for (int q = 0; q < steps; ++q) {
      const auto t0 = std::chrono::steady_clock::now();
      s->step(std::min(s->stable_dt(), 0.5 / n));
      s->accept();
      ttot += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      tm += s->last_seconds("momentum");
      tp += s->last_seconds("pressure");
      mi += s->last_momentum_solve().iterations;
      pi += s->last_pressure_solve().iterations;
    }
    const double cells = double(n) * n;
    if (rank == 0)
      std::printf("  %8.0f %10.0f | %10.4f %9.3f %6.1f | %10.4f %9.3f %6.1f | %10.4f\n", cells,
                  3 * cells, tm / steps, 1e6 * tm / steps / (2 * cells), double(mi) / steps,
                  tp / steps, 1e6 * tp / steps / cells, double(pi) / steps, ttot / steps);
  }
  return 0;
}
