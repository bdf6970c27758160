// The preconditioner switch of solvers::LinearSystem (add_stiff_switch, set_stiffness) on the
// model problem of the N-DAM momentum system in a deposit: a vector diffusion equation
// (I + S L) x = b on an n x n grid, u and w interleaved as two equations per node, L the 5-point
// Laplacian with h = 1 and Dirichlet walls. S plays nu_eff dt / h^2: the N-DAM momentum matrix
// is (I/dt + V) and a deposit at rest reaches S = 1e4 (docs/numerics.md, "Linear solvers").
#include "granflow/solvers/linear_system.hpp"

#include <Teuchos_GlobalMPISession.hpp>
#include <gtest/gtest.h>
#include <mpi.h>

#include <cmath>
#include <cstdio>
#include <vector>

using granflow::solvers::LinearSystem;
using granflow::solvers::SolveStats;

namespace {

constexpr int kN = 64;  // nodes per direction; 2 kN^2 rows

Teuchos::ParameterList switch_list(double threshold, int reuse) {
  auto pl = *LinearSystem::getValidParameters("Test solver", "GMRES", "Ifpack2 RELAXATION", 1e-10);
  LinearSystem::add_stiff_switch(pl, "MueLu", threshold, "S of the model problem");
  pl.sublist("MueLu").set("number of equations", 2);
  pl.set("Preconditioner reuse", reuse);
  return pl;
}

// Assembles (I + S L) for both components and solves it for b = 1 from x = 0.
SolveStats assemble_and_solve(LinearSystem& ls, double s) {
  const long long rows = 2LL * kN * kN;
  ls.begin();
  for (int i = 0; i < kN; ++i)
    for (int j = 0; j < kN; ++j)
      for (int c = 0; c < 2; ++c) {
        const long long r = 2LL * (i * kN + j) + c;
        ls.add(r, r, 1.0 + 4.0 * s);
        const int di[4] = {-1, 1, 0, 0}, dj[4] = {0, 0, -1, 1};
        for (int q = 0; q < 4; ++q) {
          const int ii = i + di[q], jj = j + dj[q];
          if (ii < 0 || ii >= kN || jj < 0 || jj >= kN) continue;  // Dirichlet wall: 0
          ls.add(r, 2LL * (ii * kN + jj) + c, -s);
        }
      }
  ls.set_stiffness(s);
  ls.end();
  std::vector<double> b(static_cast<std::size_t>(rows), 1.0), x(b.size(), 0.0);
  return ls.solve(b, x);
}

}  // namespace

// Gauss-Seidel's iterations grow with S (about sqrt(S) until the grid's smoothest mode sets
// the count: on 64^2 from S of a few hundred on), the AMG's stay flat; the switch picks the
// preconditioner per assembly from the stiffness set before it, in both directions, on one
// matrix pattern, and a change of type rebuilds the preconditioner even where a lagged one of
// the same pattern would be reused ('Preconditioner reuse' 10 in the switching system).
TEST(LinearSystemStiffSwitch, AmgAboveTheThresholdKeepsIterationsFlat) {
  const long long rows = 2LL * kN * kN;
  LinearSystem sgs(MPI_COMM_WORLD, rows, 0, static_cast<int>(rows), switch_list(1e300, 0));
  LinearSystem sw(MPI_COMM_WORLD, rows, 0, static_cast<int>(rows), switch_list(300.0, 10));
  int sgs_1e4 = 0, amg_1e4 = 0, sgs_1 = 0;
  bool was_stiff = false;
  for (double s : {1.0, 100.0, 1e4, 1.0, 1e4}) {
    const SolveStats a = assemble_and_solve(sgs, s), b = assemble_and_solve(sw, s);
    std::printf("[measured] S = %g: Gauss-Seidel %d iterations (residual %.1e), switch %s %d "
                "iterations (residual %.1e)\n",
                s, a.iterations, a.residual, b.stiff ? "MueLu" : "Gauss-Seidel", b.iterations,
                b.residual);
    ASSERT_TRUE(a.converged && b.converged) << "S = " << s;
    // the true residual within the tolerance (both solvers test the true residual)
    EXPECT_LE(a.residual, 1e-10);
    EXPECT_LE(b.residual, 1e-10);
    EXPECT_FALSE(a.stiff);                // no switch below an unreachable threshold
    EXPECT_EQ(b.stiff, s >= 300.0);       // the switch follows the stiffness of each assembly
    // Right after a MueLu assembly the switch builds a fresh Gauss-Seidel (the same iterations
    // as the system without a switch), not the lagged MueLu; at S = 100 it lags the S = 1
    // Gauss-Seidel as 'Preconditioner reuse' allows (measured 73 iterations against 63 fresh).
    if (!b.stiff && was_stiff) {
      EXPECT_EQ(b.iterations, a.iterations) << "S = " << s;
    }
    // and back at S = 1e4 a fresh MueLu again (the same iterations as the first one)
    if (b.stiff && amg_1e4 > 0) {
      EXPECT_EQ(b.iterations, amg_1e4);
    }
    was_stiff = b.stiff;
    if (s == 1e4) sgs_1e4 = a.iterations, amg_1e4 = b.iterations;
    if (s == 1.0) sgs_1 = a.iterations;
  }
  // Measured: Gauss-Seidel 12 iterations at S = 1, 63 at 100 and 74 at 1e4, MueLu 10 at 1e4.
  // Asserted: Gauss-Seidel grows by more than 3x from S = 1 to 1e4, MueLu stays within the
  // issue's 30 and below a third of Gauss-Seidel's (the deposit: 19 against 144, 7.5x).
  EXPECT_GT(sgs_1e4, 3 * sgs_1);
  EXPECT_LE(amg_1e4, 30);
  EXPECT_LT(3 * amg_1e4, sgs_1e4);
}

int main(int argc, char** argv) {
  Teuchos::GlobalMPISession mpi(&argc, &argv, nullptr);
  int rc = 0;
  {
    granflow::solvers::Session session(&argc, &argv);
    ::testing::InitGoogleTest(&argc, argv);
    rc = RUN_ALL_TESTS();
  }
  return rc;
}
