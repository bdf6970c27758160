#pragma once
// The Trilinos layer of granflow: a distributed sparse linear system A x = b on Tpetra, solved by
// a Belos Krylov method with a MueLu (smoothed aggregation AMG) or Ifpack2 preconditioner.
//
// This header is the whole interface the models see: no Tpetra, Belos, MueLu or Ifpack2 type
// appears here (pimpl), so a change to a model recompiles no solver header. A model assembles
// the locally owned rows from (row, col, value) triplets in global numbering, calls end(), then
// solve() as often as it likes; the preconditioner is rebuilt only after the next end().
//
// Rows are distributed in contiguous blocks: this rank owns global rows
// [first_row, first_row + local_rows). All calls are collective over the communicator.
#include <mpi.h>

#include <Teuchos_ParameterList.hpp>
#include <Teuchos_RCP.hpp>

#include <memory>
#include <string>
#include <vector>

namespace granflow::solvers {

/// What one solve did (reported in summary.json and by the benchmark).
struct SolveStats {
  int iterations = 0;
  double residual = 0.0;    ///< achieved relative residual ||b - A x|| / ||b||
  bool converged = false;
  double setup_seconds = 0.0;  ///< preconditioner setup in this call (0 if reused)
  double solve_seconds = 0.0;  ///< Krylov iterations
  bool stiff = false;  ///< solved with the "Stiff preconditioner" (see set_stiffness)
};

/// Tpetra's (and Kokkos') initialisation for a main: holds a Tpetra::ScopeGuard. Create it
/// after Teuchos::GlobalMPISession (MPI is then left to the session) and before any
/// LinearSystem; it finalises Kokkos when it goes out of scope.
class Session {
 public:
  Session(int* argc, char*** argv);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class LinearSystem {
 public:
  /// `params` is a validated list of the form of getValidParameters() (Solver, Preconditioner,
  /// Tolerance, Max iterations, and the pass-through sublists "MueLu" and "Ifpack2").
  LinearSystem(MPI_Comm comm, long long global_rows, long long first_row, int local_rows,
               const Teuchos::ParameterList& params);
  ~LinearSystem();
  LinearSystem(const LinearSystem&) = delete;
  LinearSystem& operator=(const LinearSystem&) = delete;

  /// Start a new assembly (the previous matrix is discarded).
  void begin();
  /// The stiffness of the matrix assembled next, a number the model defines (the N-DAM
  /// momentum system: nu_eff,max dt / h^2). With a list that has the preconditioner switch
  /// (add_stiff_switch), end() selects the "Stiff preconditioner" when s >= "Stiff threshold",
  /// else "Preconditioner". Must be the same on every rank (the choice is collective). Kept
  /// until the next call; without any call the stiffness is 0.
  void set_stiffness(double s);
  /// The damping factor omega of the next "Ifpack2 RELAXATION" preconditioners built, unless
  /// the Ifpack2 sublist gives "relaxation: damping factor" itself: symmetric Gauss-Seidel
  /// becomes SSOR(omega), whose best omega approaches 2 as the problem grows (the N-DAM
  /// pressure: omega from the distance to the free surface). 0 (the default): Ifpack2's 1.
  void set_relaxation_damping(double omega);
  /// Add v to A(row, col); row must be locally owned; duplicates are summed. A row that gets
  /// no entry in an assembly is an identity row (x = b there): the models leave the rows of
  /// fixed faces and of cells without material empty, most rows of a chute's box.
  void add(long long row, long long col, double v);
  /// Finish the assembly (collective); the preconditioner is rebuilt at the next solve.
  void end();
  /// An assembly that changes some rows of the last one and keeps the others: the rows added
  /// between begin_update() and end_update() replace theirs, each with the sequence of
  /// (row, column) additions it had in the last full assembly (the N-DAM's friction re-solve:
  /// only the rows of the Coulomb faces change). end_update() is collective and returns false,
  /// changing nothing but forcing the next end() to a full assembly, when any rank's rows do
  /// not fit (another sequence, or the stiffness switch chose another preconditioner): the
  /// caller then assembles every row with begin() ... end().
  void begin_update();
  bool end_update();
  /// Solve A x = b for the local parts of b and x; x holds the initial guess on entry.
  SolveStats solve(const std::vector<double>& b, std::vector<double>& x);
  /// The next solve sets up a new preconditioner (a restart point: a lagged preconditioner is
  /// state that no checkpoint holds, so straight and restarted runs both rebuild here).
  void invalidate_preconditioner();
  /// While held, the assemblies that follow keep the current preconditioner (same pattern and
  /// type) as long as it stays effective (its last solve converged within 1.5 times the
  /// iterations of its first, plus 2), whatever 'Preconditioner reuse' says: for a sequence of
  /// nearby matrices inside one step, such as the N-DAM's nonlinear pressure iterations, whose
  /// matrices differ only by nu_eff at nearby trial pressures. A solve with a held
  /// preconditioner stops after 4 n + 20 iterations (n: the first solve with it), and any solve
  /// with a kept (held or lagged) preconditioner that does not converge is repeated from the
  /// same initial guess with a fresh one (counted in preconditioner_retries()).
  void hold_preconditioner(bool hold);

  long long global_rows() const;
  int local_rows() const;
  /// Totals since construction.
  long long total_iterations() const { return total_iterations_; }
  long long solves() const { return solves_; }
  /// Preconditioners built, their total setup seconds, and sparsity graphs built.
  long long preconditioner_setups() const;
  double preconditioner_setup_seconds() const;
  /// Seconds in the Krylov iterations of all solves (what solve() takes besides the setups).
  double krylov_seconds() const;
  long long pattern_builds() const;
  /// Solves repeated with a fresh preconditioner because a kept one did not converge.
  long long preconditioner_retries() const;
  /// Assemblies that added the previous one's (row, column) sequence and took the repeat path
  /// (values straight into their places; the matrix is the one a full assembly would give),
  /// and updates that end_update() applied.
  long long repeat_assemblies() const;

  /// Valid list of one linear solver: `name` is the list's name, `solver` and `preconditioner`
  /// the defaults ("CG" for symmetric positive definite systems).
  static Teuchos::RCP<const Teuchos::ParameterList> getValidParameters(
      const std::string& name, const std::string& solver, const std::string& preconditioner,
      double tolerance);
  /// Checks that cannot be expressed by validators (e.g. MueLu's direct coarse solver on more
  /// than one rank); throws params::InputError naming the parameter.
  static void check(const Teuchos::ParameterList& params, int ranks);
  /// Adds the preconditioner switch to a list of getValidParameters(): "Stiff preconditioner"
  /// (default `preconditioner`) replaces "Preconditioner" for the assemblies whose stiffness
  /// (set_stiffness) reaches "Stiff threshold" (default `threshold`); `meaning` says what the
  /// stiffness of this system is, for the documentation.
  static void add_stiff_switch(Teuchos::ParameterList& pl, const std::string& preconditioner,
                               double threshold, const std::string& meaning);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  long long total_iterations_ = 0, solves_ = 0;
};

}  // namespace granflow::solvers
