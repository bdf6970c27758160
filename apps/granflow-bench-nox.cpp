// granflow-bench-nox: Newton/Krylov iteration counts and wall times of solvers::NonlinearSystem
// (NOX + Belos GMRES + MueLu on Tpetra) on the model problems of the tests
// (tests/solvers/nonlinear_poisson.hpp), for docs/numerics.md. Not a test.
//
//   mpiexec -n <np> granflow-bench-nox [--ew] [n ...]   (default n = 200 500: N = 40k, 250k)
//   --ew: Eisenstat-Walker forcing (choice 2) instead of the constant Krylov tolerance 1e-6
//
// Problems (p0 = 0, converged at ||F|| <= 1e-8 ||F0||, the solver's defaults otherwise):
//   cubic:    -Laplace p + 10 p^3 = f, p_e = 4 sin(pi x) sin(pi y)
//   granular: -div((1 + sin(33 deg) max(p, 0)) grad p) = f, p_e = 5 sin(pi x) sin(pi y)
// Methods: analytic Jacobian (MueLu on the Jacobian, rebuilt every Newton step) and JFNK
// (MueLu on the Laplacian built once per solve for cubic; on the Picard matrix, rebuilt every
// step, for granular).
#include "../tests/solvers/nonlinear_poisson.hpp"

#include "granflow/solvers/linear_system.hpp"
#include "granflow/solvers/nonlinear_system.hpp"

#include <Teuchos_GlobalMPISession.hpp>
#include <mpi.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  Teuchos::GlobalMPISession mpi(&argc, &argv, nullptr);
  int rc = 0;
  {
    granflow::solvers::Session session(&argc, &argv);
    int rank = 0, size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    std::vector<int> ns;
    bool ew = false;
    for (int a = 1; a < argc; ++a) {
      if (std::string(argv[a]) == "--ew")
        ew = true;
      else
        ns.push_back(std::atoi(argv[a]));
    }
    if (ns.empty()) ns = {200, 500};
    using P = granflow::testing::NonlinearPoisson;
    const double tau = std::sin(33.0 * std::acos(-1.0) / 180.0);
    if (rank == 0)
      std::printf("| problem | method | N | np | Newton | Krylov | F evals | prec. builds | "
                  "prec. s | total s | max error |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (int n : ns)
      for (int granular = 0; granular < 2; ++granular)
        for (int jfnk = 0; jfnk < 2; ++jfnk) {
          P pb(MPI_COMM_WORLD, n, granular ? P::Kind::Granular : P::Kind::Cubic,
               granular ? 5.0 : 4.0, granular ? tau : 10.0);
          Teuchos::ParameterList prm("Nonlinear solver");
          prm.set("Method", std::string(jfnk ? "Jacobian-free Newton-Krylov"
                                             : "Newton-Krylov (analytic Jacobian)"));
          if (jfnk && !granular) prm.set("Reuse preconditioner", true);
          if (ew) {
            prm.set("Forcing term", std::string("Eisenstat-Walker 2"));
            prm.set("Krylov tolerance", 1e-2);
          }
          const int which = !jfnk ? 0 : granular ? 1 : 2;
          auto sys = pb.make(prm, which);
          std::vector<double> p(static_cast<size_t>(pb.nlocal), 0.0);
          MPI_Barrier(MPI_COMM_WORLD);
          const auto s = sys.solve(p);
          const double err = pb.max_error(p);
          if (!s.converged) rc = 1;
          if (rank == 0)
            std::printf("| %s | %s | %lld | %d | %d | %lld | %d | %d | %.2f | %.2f | %.1e |%s\n",
                        granular ? "granular" : "cubic",
                        jfnk ? (granular ? "JFNK, Picard prec." : "JFNK, Laplacian prec.")
                             : "analytic J",
                        static_cast<long long>(n) * n, size, s.newton_iterations,
                        s.krylov_iterations, s.residual_evaluations, s.preconditioner_builds, s.preconditioner_seconds,
                        s.seconds, err, s.converged ? "" : (" " + s.reason).c_str());
          std::fflush(stdout);
        }
  }
  return rc;
}
