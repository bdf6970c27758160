#pragma once
// The nonlinear solve layer of granflow: a distributed nonlinear system F(p) = 0 (the N-DAM
// pressure system (10)+(13)+(14), nonlinear in p through tau_y = tau_p p), solved by Newton's
// method from NOX with Belos GMRES inner solves on Tpetra, through Thyra and Stratimikos.
//
// This header is the whole interface the models see: no NOX, Thyra, Tpetra, Belos, MueLu or
// Ifpack2 type appears here (pimpl).
//
// The model supplies two callbacks; both are called collectively (every rank calls them at the
// same time, in the same order), so they may do their own ghost exchange:
// - residual(p, F): p and F are the local parts, global rows [first_row, first_row + local_rows).
// - matrix(p, m): the locally owned rows of a sparse matrix at p, as (row, col, value) triplets in
//   global numbering (duplicates are summed). With "Newton-Krylov (analytic Jacobian)" it must be
//   the Jacobian dF/dp (Newton's quadratic convergence depends on it); with "Jacobian-free
//   Newton-Krylov" it is only the matrix the preconditioner is built from (e.g. the Laplacian
//   part of the pressure operator), and Jacobian-vector products are finite differences of F.
//
// solve(p) never fails silently: a run that does not reach the tolerance returns
// converged = false with the reason (maximum Newton iterations, non-finite residual, failed line
// search, an exception from a callback or from Trilinos), never converged = true. A callback
// that throws must throw on every rank (the others would otherwise wait in a collective).
//
// Typical use (the N-DAM pressure system, one solve per time step):
//   NonlinearSystem ns(comm, n_global, first, n_local, params.sublist("Nonlinear solver"),
//                      [&](const auto& p, auto& F) { exchange(p); pressure_residual(p, F); },
//                      [&](const auto& p, Triplets& m) { exchange(p); pressure_matrix(p, m); });
//   auto st = ns.solve(p);   // p: last step's pressure as the initial guess
//   if (!st.converged) stop_with(st.reason);
#include <mpi.h>

#include <Teuchos_ParameterList.hpp>
#include <Teuchos_RCP.hpp>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace granflow::solvers {

/// Sparse matrix rows handed over by the model: entry k is A(rows[k], cols[k]) += values[k].
struct Triplets {
  std::vector<long long> rows, cols;
  std::vector<double> values;
  void add(long long row, long long col, double v) {
    rows.push_back(row);
    cols.push_back(col);
    values.push_back(v);
  }
  void clear() {
    rows.clear();
    cols.clear();
    values.clear();
  }
  size_t size() const { return values.size(); }
};

/// What one nonlinear solve did (for summary.json and the benchmark).
struct NonlinearStats {
  bool converged = false;
  std::string reason;                 ///< why it stopped (always set)
  int newton_iterations = 0;
  long long krylov_iterations = 0;    ///< total over all Newton steps
  double initial_residual = 0.0;      ///< ||F(p0)||_2
  double final_residual = 0.0;        ///< ||F(p)||_2 at the returned p
  std::vector<double> residual_history;  ///< ||F||_2 at p0 and after each Newton step
  int residual_evaluations = 0;       ///< calls of the residual callback (JFNK: incl. FD ones)
  int matrix_evaluations = 0;         ///< calls of the matrix callback
  int preconditioner_builds = 0;
  double seconds = 0.0;               ///< wall time of solve()
  double preconditioner_seconds = 0.0;  ///< assembly from triplets + preconditioner setup
};

class NonlinearSystem {
 public:
  using Residual = std::function<void(const std::vector<double>& p, std::vector<double>& F)>;
  using Matrix = std::function<void(const std::vector<double>& p, Triplets& m)>;

  /// `params` is a list of the form of getValidParameters() (validated here; missing entries
  /// take their defaults). Rows are distributed in contiguous blocks in rank order over `comm`.
  NonlinearSystem(MPI_Comm comm, long long global_rows, long long first_row, int local_rows,
                  const Teuchos::ParameterList& params, Residual residual, Matrix matrix);
  ~NonlinearSystem();
  NonlinearSystem(const NonlinearSystem&) = delete;
  NonlinearSystem& operator=(const NonlinearSystem&) = delete;

  /// Solve F(p) = 0 (collective); p holds the initial guess on entry and the last Newton
  /// iterate on return (also when converged = false).
  NonlinearStats solve(std::vector<double>& p);

  long long global_rows() const;
  int local_rows() const;

  /// Valid list "Nonlinear solver" with validators and documented defaults:
  ///   Method                   "Newton-Krylov (analytic Jacobian)" | "Jacobian-free Newton-Krylov"
  ///   Absolute tolerance       1e-8  (converged when ||F||_2 <= absolute tolerance or
  ///   Relative tolerance       1e-8   ||F||_2 <= relative tolerance * ||F(p0)||_2)
  ///   Max Newton iterations    20
  ///   Globalization            "Backtracking line search" | "Polynomial line search" |
  ///                            "Full step" (NOX's trust regions fail through NOX::Thyra in 13.2)
  ///   Krylov solver            "GMRES" | "CG" (CG only for symmetric positive definite J)
  ///   Krylov tolerance         1e-6  (relative; initial value with Eisenstat-Walker forcing)
  ///   Forcing term             "Constant" | "Eisenstat-Walker 1" | "Eisenstat-Walker 2"
  ///   Max Krylov iterations    300,  GMRES restart 40
  ///   Preconditioner           "MueLu" | "Ifpack2 RILUK" | "Ifpack2 RELAXATION" | "None"
  ///   Reuse preconditioner     false (true: built once per solve() at p0)
  ///   FD lambda                1e-4  (JFNK perturbation; 1e-6 diverged on this machine)
  ///   Verbose                  false (NOX iteration output on rank 0)
  ///   MueLu, Ifpack2           pass-through sublists (MueLu: SA, relaxation coarse solve)
  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace granflow::solvers
