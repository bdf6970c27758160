// main() of the N-DAM tests: MPI (Teuchos::GlobalMPISession), then Tpetra/Kokkos
// (solvers::Session, a Tpetra::ScopeGuard), then GoogleTest. Under mpiexec every rank runs the
// tests; only rank 0 prints, and the exit code is the worst over the ranks.
#include "granflow/solvers/linear_system.hpp"

#include <Teuchos_GlobalMPISession.hpp>
#include <gtest/gtest.h>
#include <mpi.h>

int main(int argc, char** argv) {
  Teuchos::GlobalMPISession mpi(&argc, &argv, nullptr);
  int rc = 0;
  {
    granflow::solvers::Session session(&argc, &argv);
    ::testing::InitGoogleTest(&argc, argv);
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    if (rank != 0) {
      auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
      delete listeners.Release(listeners.default_result_printer());
    }
    const int local = RUN_ALL_TESTS();
    MPI_Allreduce(&local, &rc, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  }
  return rc;
}
