#pragma once
// Model problems for solvers::NonlinearSystem (used by tests/solvers/test_nonlinear_system.cpp
// and apps/granflow-bench-nox.cpp): cell-centred finite differences on the unit square with
// n x n unknowns at (i + 1) h, (j + 1) h, h = 1 / (n + 1), homogeneous Dirichlet boundary values,
// and a manufactured exact solution p_e = A sin(pi x) sin(pi y) (>= 0 inside).
//
// - Cubic:    -Laplace p + sigma p^3 = f.
// - Granular: -div((1 + tau max(p, 0)) grad p) = f, a pressure-dependent coefficient shaped like
//             the N-DAM's tau_y = tau_p p (tau = sin(phi)); face coefficients from the average
//             of the two cell values (second order).
//
// Unknowns are numbered row by row (k = j n + i); each rank owns a contiguous block of grid rows
// j in [j0, j1) and exchanges one ghost row with each neighbour inside the residual (collective),
// as the N-DAM does.
#include "granflow/solvers/nonlinear_system.hpp"

#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace granflow::testing {

struct NonlinearPoisson {
  enum class Kind { Cubic, Granular };
  Kind kind = Kind::Cubic;
  int n = 0;
  double h = 0, A = 1.0, sigma = 0.0, tau = 0.0;
  MPI_Comm comm = MPI_COMM_WORLD;
  int rank = 0, size = 1, j0 = 0, j1 = 0;
  long long first = 0;
  int nlocal = 0;
  std::vector<double> f;               // right-hand side, local rows
  mutable std::vector<double> lo, hi;  // ghost rows j0 - 1 and j1 (zeros at the boundary)

  NonlinearPoisson(MPI_Comm c, int n_, Kind k, double A_, double coef)
      : kind(k), n(n_), h(1.0 / (n_ + 1)), A(A_), comm(c) {
    (kind == Kind::Cubic ? sigma : tau) = coef;
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &size);
    j0 = static_cast<int>(static_cast<long long>(n) * rank / size);
    j1 = static_cast<int>(static_cast<long long>(n) * (rank + 1) / size);
    first = static_cast<long long>(j0) * n;
    nlocal = (j1 - j0) * n;
    lo.assign(static_cast<size_t>(n), 0.0);
    hi.assign(static_cast<size_t>(n), 0.0);
    f.resize(static_cast<size_t>(nlocal));
    const double pi = std::acos(-1.0);
    for (int j = j0; j < j1; ++j)
      for (int i = 0; i < n; ++i) {
        const double x = (i + 1) * h, y = (j + 1) * h;
        const double s = std::sin(pi * x), t = std::sin(pi * y);
        const double p = A * s * t;
        double v;
        if (kind == Kind::Cubic) {
          v = 2 * pi * pi * p + sigma * p * p * p;
        } else {
          const double px = A * pi * std::cos(pi * x) * t, py = A * pi * s * std::cos(pi * y);
          v = (1 + tau * p) * 2 * pi * pi * p - tau * (px * px + py * py);
        }
        f[idx(i, j)] = v;
      }
  }
  size_t idx(int i, int j) const { return static_cast<size_t>((j - j0) * n + i); }
  double exact(int i, int j) const {
    const double pi = std::acos(-1.0);
    return A * std::sin(pi * (i + 1) * h) * std::sin(pi * (j + 1) * h);
  }

  // Ghost rows from the neighbouring ranks (collective).
  void exchange(const std::vector<double>& p) const {
    const int down = rank > 0 ? rank - 1 : MPI_PROC_NULL;
    const int up = rank < size - 1 ? rank + 1 : MPI_PROC_NULL;
    std::fill(lo.begin(), lo.end(), 0.0);
    std::fill(hi.begin(), hi.end(), 0.0);
    if (size == 1) return;
    const double* first_row = nlocal > 0 ? p.data() : lo.data();
    const double* last_row = nlocal > 0 ? p.data() + nlocal - n : hi.data();
    MPI_Sendrecv(last_row, n, MPI_DOUBLE, up, 0, lo.data(), n, MPI_DOUBLE, down, 0, comm,
                 MPI_STATUS_IGNORE);
    MPI_Sendrecv(first_row, n, MPI_DOUBLE, down, 1, hi.data(), n, MPI_DOUBLE, up, 1, comm,
                 MPI_STATUS_IGNORE);
  }
  // p at (i, j) including ghost rows and the zero boundary.
  double at(const std::vector<double>& p, int i, int j) const {
    if (i < 0 || i >= n || j < 0 || j >= n) return 0.0;
    if (j < j0) return lo[static_cast<size_t>(i)];
    if (j >= j1) return hi[static_cast<size_t>(i)];
    return p[idx(i, j)];
  }
  double k(double pa, double pb) const { return 1.0 + tau * std::max(0.5 * (pa + pb), 0.0); }
  double dk(double pa, double pb) const { return 0.5 * (pa + pb) > 0 ? 0.5 * tau : 0.0; }

  void residual(const std::vector<double>& p, std::vector<double>& F) const {
    exchange(p);
    const double ih2 = 1.0 / (h * h);
    static const int di[4] = {-1, 1, 0, 0}, dj[4] = {0, 0, -1, 1};
    for (int j = j0; j < j1; ++j)
      for (int i = 0; i < n; ++i) {
        const double pa = p[idx(i, j)];
        double r = 0;
        for (int q = 0; q < 4; ++q) {
          const double pb = at(p, i + di[q], j + dj[q]);
          r -= (kind == Kind::Cubic ? 1.0 : k(pa, pb)) * (pb - pa) * ih2;
        }
        if (kind == Kind::Cubic) r += sigma * pa * pa * pa;
        F[idx(i, j)] = r - f[idx(i, j)];
      }
  }

  // which = 0: exact Jacobian; 1: Picard/"Laplacian part" (coefficient frozen at p, no
  // derivative of the coefficient, no cubic term); 2: the plain Laplacian.
  void matrix(const std::vector<double>& p, solvers::Triplets& m, int which) const {
    exchange(p);
    const double ih2 = 1.0 / (h * h);
    static const int di[4] = {-1, 1, 0, 0}, dj[4] = {0, 0, -1, 1};
    for (int j = j0; j < j1; ++j)
      for (int i = 0; i < n; ++i) {
        const long long row = static_cast<long long>(j) * n + i;
        const double pa = p[idx(i, j)];
        double diag = 0;
        for (int q = 0; q < 4; ++q) {
          const int ib = i + di[q], jb = j + dj[q];
          const bool inside = ib >= 0 && ib < n && jb >= 0 && jb < n;
          const double pb = at(p, ib, jb);
          double kf = 1.0, dkf = 0.0;
          if (kind == Kind::Granular && which != 2) {
            kf = k(pa, pb);
            if (which == 0) dkf = dk(pa, pb);
          }
          // d/dpa and d/dpb of -kf (pb - pa) / h^2
          diag += (kf - dkf * (pb - pa)) * ih2;
          if (inside) m.add(row, static_cast<long long>(jb) * n + ib, (-kf - dkf * (pb - pa)) * ih2);
        }
        if (kind == Kind::Cubic && which == 0) diag += 3 * sigma * pa * pa;
        m.add(row, row, diag);
      }
  }

  // max |p - p_e| over all ranks
  double max_error(const std::vector<double>& p) const {
    double e = 0;
    for (int j = j0; j < j1; ++j)
      for (int i = 0; i < n; ++i) e = std::max(e, std::abs(p[idx(i, j)] - exact(i, j)));
    double g = 0;
    MPI_Allreduce(&e, &g, 1, MPI_DOUBLE, MPI_MAX, comm);
    return g;
  }

  solvers::NonlinearSystem make(const Teuchos::ParameterList& params, int which) const {
    return solvers::NonlinearSystem(
        comm, static_cast<long long>(n) * n, first, nlocal, params,
        [this](const std::vector<double>& p, std::vector<double>& F) { residual(p, F); },
        [this, which](const std::vector<double>& p, solvers::Triplets& m) {
          matrix(p, m, which);
        });
  }
};

}  // namespace granflow::testing
