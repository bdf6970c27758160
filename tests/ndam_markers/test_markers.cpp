// Tests of the free-surface marker module (include/granflow/markers/markers.hpp).
//
// Velocity fields are built from a stream function psi sampled at the cell corners:
//   u(i,k) = (psi(x_f, z_top) - psi(x_f, z_bot)) / dz,   w(i,k) = -(psi(x_r, z_f) - psi(x_l, z_f)) / dx,
// so the discrete divergence of every test field is zero to round-off, as the projection of the
// N-DAM solver makes it. Ghost columns and rows are filled from the same formula (with the x
// index wrapped for periodic boxes, so that every decomposition sees bit-identical values).
//
// MarkersMpi.* run under `mpiexec -n 2` (ctest markers.mpi_np2): each rank advances the set
// distributed over MPI_COMM_WORLD and a serial copy on MPI_COMM_SELF and compares them.
#include "granflow/markers/markers.hpp"

#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <vector>

using namespace granflow::ndam;

namespace {

const double kPi = std::acos(-1.0);
constexpr int G = Field::G;
using Psi = std::function<double(double, double)>;

// u and w of `psi` (times `scale`) on the slab, ghosts included.
void fill_from_psi(const Grid& g, const Slab& s, bool periodic, const Psi& psi, double scale,
                   Field& u, Field& w) {
  u = Field(s.nx_local, g.nz);
  w = Field(s.nx_local, g.nz);
  const double dx = g.dx(), dz = g.dz();
  const auto X = [&](int j) {
    if (periodic) j = ((j % g.nx) + g.nx) % g.nx;
    return j * dx;
  };
  for (int i = -G; i < s.nx_local + G; ++i) {
    const int gi = s.i0 + i;
    for (int k = -1; k <= g.nz; ++k) {
      u(i, k) = scale * (psi(X(gi + 1), (k + 1) * dz) - psi(X(gi + 1), k * dz)) / dz;
      w(i, k) = -scale * (psi(X(gi + 1), (k + 1) * dz) - psi(X(gi), (k + 1) * dz)) / dx;
    }
  }
}

Field scaled(const Field& f, double c) {
  Field r = f;
  for (double& v : r.data()) v *= c;
  return r;
}

double max_displacement(const std::vector<Marker>& a, const std::vector<Marker>& b) {
  EXPECT_EQ(a.size(), b.size());
  double e = 0.0;
  for (std::size_t n = 0; n < std::min(a.size(), b.size()); ++n) {
    EXPECT_EQ(a[n].id, b[n].id);
    e = std::max(e, std::hypot(a[n].x - b[n].x, a[n].z - b[n].z));
  }
  return e;
}

std::vector<Marker> sorted(std::vector<Marker> m) {
  std::sort(m.begin(), m.end(), [](const Marker& a, const Marker& b) { return a.id < b.id; });
  return m;
}

// Checks every owned cell against the flag rules, recomputed independently from the counts of a
// serial set (one rank: every neighbour is local). Returns the number of violations.
int flag_violations(const Grid& g, bool periodic, const std::vector<int>& count,
                    const std::vector<CellFlag>& flags, const std::vector<std::uint8_t>& mask,
                    const std::vector<char>& obstacle) {
  int bad = 0;
  const int nx = g.nx, nz = g.nz;
  const auto full = [&](int i, int k) {
    if (k < 0 || k >= nz) return true;  // outside the box: not empty
    if (i < 0 || i >= nx) {
      if (!periodic) return true;
      i = (i + nx) % nx;
    }
    const std::size_t c = static_cast<std::size_t>(i * nz + k);
    return obstacle[c] || count[c] > 0;
  };
  for (int i = 0; i < nx; ++i)
    for (int k = 0; k < nz; ++k) {
      const std::size_t c = static_cast<std::size_t>(i * nz + k);
      if (obstacle[c]) {
        bad += flags[c] != CellFlag::Obstacle;
        bad += count[c] != 0;  // markers are kept out of obstacle cells
        continue;
      }
      if (count[c] == 0) {
        bad += flags[c] != CellFlag::Empty;
        bad += mask[c] != 0;
        continue;
      }
      std::uint8_t m = 0;
      if (!full(i - 1, k)) m |= empty_side::Left;
      if (!full(i + 1, k)) m |= empty_side::Right;
      if (!full(i, k - 1)) m |= empty_side::Bottom;
      if (!full(i, k + 1)) m |= empty_side::Top;
      bad += mask[c] != m;
      bad += flags[c] != (m ? CellFlag::Surface : CellFlag::Fluid);
    }
  return bad;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Advection: second order in time

// Solid-body rotation u = -omega (z - zc), w = omega (x - xc), period 1. The field is linear, so
// the bilinear interpolation is exact and the error after one period is the time error alone.
// For Heun's method the phase error per step is (omega dt)^3 / 6, i.e. r (2 pi)^3 / (6 n^2)
// after n steps of one period: exactly second order. Measured (r <= 0.3):
//   n = 64: 3.02e-3, 128: 7.56e-4, 256: 1.89e-4, 512: 4.73e-5; orders 2.000, 2.000, 2.000.
TEST(MarkersAdvection, SolidBodyRotationSecondOrder) {
  const Grid g{32, 32, 1.0, 1.0};
  const Slab s = Slab::split(g.nx, 0, 1);
  const double omega = 2.0 * kPi;
  Field u, w;
  fill_from_psi(g, s, false,
                [&](double x, double z) {
                  return -0.5 * omega * ((x - 0.5) * (x - 0.5) + (z - 0.5) * (z - 0.5));
                },
                1.0, u, w);
  std::vector<double> err;
  for (int n : {64, 128, 256, 512}) {
    MarkerSet ms(MPI_COMM_SELF, g, s, MarkerConfig{});
    ms.seed([](double x, double z) { return std::hypot(x - 0.5, z - 0.5) < 0.3; });
    const auto start = sorted(ms.markers());
    for (int step = 0; step < n; ++step) ms.advect(1.0 / n, u, w);
    EXPECT_EQ(ms.markers().size(), start.size());
    err.push_back(max_displacement(sorted(ms.markers()), start));
  }
  for (std::size_t j = 0; j + 1 < err.size(); ++j) {
    const double order = std::log2(err[j] / err[j + 1]);
    std::printf("solid-body rotation: e(n) = %.3e, e(2n) = %.3e, order %.3f\n", err[j],
                err[j + 1], order);
    // Measured 2.00 (see above); 1.9 leaves room for compiler-dependent round-off only.
    EXPECT_GT(order, 1.9);
  }
  // Absolute level: the asymptotic phase error r (2 pi)^3 / (6 n^2) = 3.0e-3 at r = 0.3, n = 64;
  // 10 % above it allows for the O(n^-4) term.
  EXPECT_LT(err[0], 1.1 * 0.3 * std::pow(2.0 * kPi, 3) / (6.0 * 64 * 64));
}

// Time-reversed single vortex (LeVeque 1996): psi = sin^2(pi x) sin^2(pi z) / pi on a 32 x 32
// grid, scaled by cos(pi t / T), T = 2. The interpolated velocity is f(x) g(t) with
// int_0^T g = 0, so the exact trajectories of the interpolated field return to their start at T
// whatever the spatial error; the return error measures the time integration with a velocity
// that changes in time (v^n at t_n and v^{n+1} at t_{n+1} in Heun's stages). Measured:
//   n = 100: 1.07e-4, 200: 1.35e-5, 400: 1.68e-6, 800: 2.09e-7; orders 2.99, 3.01, 3.00.
// The return is better than second order because the second half of the period retraces the
// first in reverse and the leading O(dt^2) error of the two halves cancels; the pure order-2
// checks are the rotation above and the unsteady vortex against a reference below.
TEST(MarkersAdvection, ReversingVortexSecondOrder) {
  const Grid g{32, 32, 1.0, 1.0};
  const Slab s = Slab::split(g.nx, 0, 1);
  const double T = 2.0;
  Field u, w;
  fill_from_psi(g, s, false,
                [](double x, double z) {
                  const double a = std::sin(kPi * x), b = std::sin(kPi * z);
                  return a * a * b * b / kPi;
                },
                1.0, u, w);
  std::vector<double> err;
  for (int n : {100, 200, 400, 800}) {
    MarkerSet ms(MPI_COMM_SELF, g, s, MarkerConfig{});
    ms.seed([](double x, double z) { return std::hypot(x - 0.5, z - 0.75) < 0.15; });
    const auto start = sorted(ms.markers());
    const double dt = T / n;
    for (int step = 0; step < n; ++step) {
      const double c0 = std::cos(kPi * step * dt / T), c1 = std::cos(kPi * (step + 1) * dt / T);
      ms.advect(dt, scaled(u, c0), scaled(w, c0), scaled(u, c1), scaled(w, c1));
    }
    EXPECT_EQ(ms.markers().size(), start.size());
    err.push_back(max_displacement(sorted(ms.markers()), start));
  }
  for (std::size_t j = 0; j + 1 < err.size(); ++j) {
    const double order = std::log2(err[j] / err[j + 1]);
    std::printf("reversing vortex: e(n) = %.3e, e(2n) = %.3e, order %.3f\n", err[j], err[j + 1],
                order);
    // Measured 3.0 (see above); asserting > 1.9 keeps the check to what the scheme guarantees.
    EXPECT_GT(order, 1.9);
  }
}

// The same vortex over [0, 1] only (g = cos(pi t / 2) decays from 1 to 0: no symmetry to cancel
// errors), against a reference integrated with classical RK4 and 4000 steps in the same
// interpolated field (RK4 error ~1e-13 there). This is the check that the two Heun stages use
// the velocity of their own time level: with v^n in both stages the order would drop to 1.
// Measured: n = 50: 4.91e-4, 100: 1.20e-4, 200: 3.14e-5, 400: 7.85e-6; orders 2.03, 1.94, 2.00,
// 1.99 over the whole range.
TEST(MarkersAdvection, UnsteadyVortexSecondOrderAgainstReference) {
  const Grid g{32, 32, 1.0, 1.0};
  const Slab s = Slab::split(g.nx, 0, 1);
  Field u, w;
  fill_from_psi(g, s, false,
                [](double x, double z) {
                  const double a = std::sin(kPi * x), b = std::sin(kPi * z);
                  return a * a * b * b / kPi;
                },
                1.0, u, w);
  const auto gt = [](double t) { return std::cos(0.5 * kPi * t); };
  MarkerSet probe(MPI_COMM_SELF, g, s, MarkerConfig{});
  probe.seed([](double x, double z) { return std::hypot(x - 0.5, z - 0.75) < 0.15; });
  std::vector<Marker> ref = sorted(probe.markers());
  {
    const int n = 4000;
    const double h = 1.0 / n;
    for (Marker& m : ref) {
      double x = m.x, z = m.z;
      for (int j = 0; j < n; ++j) {
        const double t = j * h;
        const auto k1 = probe.velocity(u, w, x, z);
        const auto k2 = probe.velocity(u, w, x + 0.5 * h * gt(t) * k1[0], z + 0.5 * h * gt(t) * k1[1]);
        const auto k3 = probe.velocity(u, w, x + 0.5 * h * gt(t + 0.5 * h) * k2[0],
                                       z + 0.5 * h * gt(t + 0.5 * h) * k2[1]);
        const auto k4 = probe.velocity(u, w, x + h * gt(t + 0.5 * h) * k3[0],
                                       z + h * gt(t + 0.5 * h) * k3[1]);
        x += h / 6.0 * (gt(t) * k1[0] + 2.0 * gt(t + 0.5 * h) * (k2[0] + k3[0]) + gt(t + h) * k4[0]);
        z += h / 6.0 * (gt(t) * k1[1] + 2.0 * gt(t + 0.5 * h) * (k2[1] + k3[1]) + gt(t + h) * k4[1]);
      }
      m.x = x;
      m.z = z;
    }
  }
  std::vector<double> err;
  for (int n : {50, 100, 200, 400}) {
    MarkerSet ms(MPI_COMM_SELF, g, s, MarkerConfig{});
    ms.seed([](double x, double z) { return std::hypot(x - 0.5, z - 0.75) < 0.15; });
    const double dt = 1.0 / n;
    for (int step = 0; step < n; ++step) {
      const double c0 = gt(step * dt), c1 = gt((step + 1) * dt);
      ms.advect(dt, scaled(u, c0), scaled(w, c0), scaled(u, c1), scaled(w, c1));
    }
    err.push_back(max_displacement(sorted(ms.markers()), ref));
  }
  for (std::size_t j = 0; j + 1 < err.size(); ++j) {
    const double order = std::log2(err[j] / err[j + 1]);
    std::printf("unsteady vortex vs RK4: e(n) = %.3e, e(2n) = %.3e, order %.3f\n", err[j],
                err[j + 1], order);
    // Pairwise orders are 2.03, 1.94, 2.00 (the maximum over markers switches marker); 1.8
    // bounds that scatter. The fit over the whole range below is the sharp check.
    EXPECT_GT(order, 1.8);
  }
  const double fit = std::log2(err.front() / err.back()) / 3.0;  // n from 50 to 400
  std::printf("unsteady vortex vs RK4: order over n = 50..400: %.3f\n", fit);
  EXPECT_GT(fit, 1.9);  // measured 1.99
}

// The interpolation reproduces the staggered values where it should: u at u-faces, w at
// w-faces (the shifted grids of NaSt2D), and a linear field everywhere.
TEST(MarkersAdvection, InterpolationHitsFaceValues) {
  const Grid g{8, 6, 0.8, 0.3};
  const Slab s = Slab::split(g.nx, 0, 1);
  Field u(s.nx_local, g.nz), w(s.nx_local, g.nz);
  for (int i = -G; i < s.nx_local + G; ++i)
    for (int k = -1; k <= g.nz; ++k) {
      u(i, k) = 100.0 * i + k;       // arbitrary, not linear in the faces' positions
      w(i, k) = -7.0 * i + 3.0 * k * k;
    }
  MarkerSet ms(MPI_COMM_SELF, g, s, MarkerConfig{});
  for (int i = 0; i < g.nx; ++i)
    for (int k = 0; k < g.nz; ++k) {
      const auto vu = ms.velocity(u, w, (i + 1) * g.dx() - 1e-12, (k + 0.5) * g.dz());
      EXPECT_NEAR(vu[0], u(i, k), 1e-8);  // 1e-12 m off the face: weight 1e-11 on a neighbour
      const auto vw = ms.velocity(u, w, (i + 0.5) * g.dx(), (k + 1) * g.dz() - 1e-12);
      EXPECT_NEAR(vw[1], w(i, k), 1e-8);
    }
}

// ---------------------------------------------------------------------------------------------
// Cellular flow: count exact, flags consistent; rest: everything fixed

// Periodic x, walls in z, a half-filled box stirred by two counter-rotating cell pairs, with an
// obstacle block in the upper half. Every step: the global count is exact (markers are neither
// created nor lost: integer bookkeeping, tolerance 0), every cell's flag and empty-side mask
// agree with the rules recomputed from the counts, and no marker enters the obstacle.
TEST(MarkersFlags, CellularFlowCountAndFlagsConsistent) {
  const Grid g{48, 24, 2.0, 1.0};
  const Slab s = Slab::split(g.nx, 0, 1);
  MarkerConfig cfg;
  cfg.sides = {MarkerBoundary::Periodic, MarkerBoundary::Periodic, MarkerBoundary::Wall,
               MarkerBoundary::Wall};
  Field u, w;
  fill_from_psi(g, s, true,
                [&](double x, double z) {
                  return 0.1 * std::sin(2.0 * kPi * x / g.lx * 2.0) * std::sin(kPi * z / g.lz);
                },
                1.0, u, w);
  std::vector<CellFlag> flags(static_cast<std::size_t>(g.nx * g.nz), CellFlag::Fluid);
  std::vector<char> obstacle(flags.size(), 0);
  for (int i = 20; i < 24; ++i)
    for (int k = 15; k < 19; ++k) {
      flags[static_cast<std::size_t>(i * g.nz + k)] = CellFlag::Obstacle;
      obstacle[static_cast<std::size_t>(i * g.nz + k)] = 1;
    }
  MarkerSet ms(MPI_COMM_SELF, g, s, cfg);
  ms.set_obstacles(flags);
  ms.seed_depth([](double) { return 0.45; });
  const long long n0 = ms.global_count();
  ASSERT_GT(n0, 0);
  std::vector<std::uint8_t> mask;
  ms.update_flags(flags, &mask);
  const auto flags0 = flags;
  int bad = 0, changed = 0;
  for (int step = 0; step < 300; ++step) {
    ms.advect(0.02, u, w);
    ASSERT_EQ(ms.global_count(), n0) << "step " << step;
    ms.update_flags(flags, &mask);
    bad += flag_violations(g, true, ms.cell_counts(), flags, mask, obstacle);
  }
  for (std::size_t c = 0; c < flags.size(); ++c) changed += flags[c] != flags0[c];
  EXPECT_EQ(bad, 0);
  EXPECT_GT(changed, 20);  // the surface did move (otherwise the test would be vacuous)
  const MarkerMass mm = ms.mass();
  EXPECT_EQ(mm.count, n0);
  EXPECT_EQ(mm.removed, 0);
  EXPECT_DOUBLE_EQ(mm.area, n0 * ms.marker_area());
}

// A pool at rest (u = w = 0): positions, flags, depth stay exactly as seeded (no velocity, no
// round-off: x + dt/2 (0 + 0) = x), the top marker row's cells are Surface with the Top bit only,
// the cells below are Fluid, above Empty.
TEST(MarkersFlags, PoolAtRestStaysFixed) {
  const Grid g{40, 20, 1.0, 0.5};
  const Slab s = Slab::split(g.nx, 0, 1);
  for (double h0 : {0.2, 0.2137}) {
    MarkerSet ms(MPI_COMM_SELF, g, s, MarkerConfig{});
    ms.seed_depth([h0](double) { return h0; });
    Field u(s.nx_local, g.nz), w(s.nx_local, g.nz);
    std::vector<CellFlag> flags;
    std::vector<std::uint8_t> mask;
    ms.update_flags(flags, &mask);
    const auto flags0 = flags;
    const auto h0v = ms.depth();
    const auto m0 = sorted(ms.markers());
    const int ktop = static_cast<int>(std::floor((h0 - 0.5 * ms.spacing_z()) / g.dz()));
    for (int i = 0; i < g.nx; ++i)
      for (int k = 0; k < g.nz; ++k) {
        const std::size_t c = static_cast<std::size_t>(i * g.nz + k);
        if (k < ktop) {
          EXPECT_EQ(flags[c], CellFlag::Fluid);
        }
        if (k == ktop) {
          EXPECT_EQ(flags[c], CellFlag::Surface);
          EXPECT_EQ(mask[c], empty_side::Top);
        }
        if (k > ktop) {
          EXPECT_EQ(flags[c], CellFlag::Empty);
        }
      }
    for (int step = 0; step < 100; ++step) {
      ms.advect(0.01, u, w);
      ms.update_flags(flags, &mask);
    }
    EXPECT_EQ(flags, flags0);
    EXPECT_EQ(ms.depth(), h0v);
    EXPECT_EQ(max_displacement(sorted(ms.markers()), m0), 0.0);
  }
}

// ---------------------------------------------------------------------------------------------
// Depth

// A seeded layer of depth h: the markers sit at (b + 1/2) s_z < h, so each sub-column holds
// round(h / s_z) markers and both depth definitions give h to within s_z / 2 (half a marker
// spacing), the tolerance of the brief. For a linear h(x) the Count depth averages the rounded
// sub-column depths, whose mean is h at the column centre: still s_z / 2. The Top depth follows
// the n_x-th highest marker, i.e. roughly the lowest sub-column top: s_z / 2 + |h'| dx / 2.
TEST(MarkersDepth, SeededLayerWithinHalfSpacing) {
  const Grid g{20, 40, 1.0, 1.0};
  const Slab s = Slab::split(g.nx, 0, 1);
  for (DepthMethod method : {DepthMethod::Count, DepthMethod::Top}) {
    MarkerConfig cfg;
    cfg.depth = method;
    for (double h0 : {0.1, 0.1234, 0.3, 0.50001, 0.777}) {
      MarkerSet ms(MPI_COMM_SELF, g, s, cfg);
      ms.seed_depth([h0](double) { return h0; });
      for (double h : ms.depth()) EXPECT_LE(std::abs(h - h0), 0.5 * ms.spacing_z() + 1e-12);
    }
    MarkerSet ms(MPI_COMM_SELF, g, s, cfg);
    const auto hx = [](double x) { return 0.2 + 0.3 * x; };
    ms.seed_depth(hx);
    const auto h = ms.depth();
    const double tol = 0.5 * ms.spacing_z() + (method == DepthMethod::Top ? 0.15 * g.dx() : 0.0);
    for (int i = 0; i < g.nx; ++i)
      EXPECT_LE(std::abs(h[static_cast<std::size_t>(i)] - hx((i + 0.5) * g.dx())), tol + 1e-12);
  }
}

// One stray marker far above a layer: Count moves by one marker's area per width, s_z / n_x;
// Top does not move (it ignores up to n_x - 1 markers above the top full row).
TEST(MarkersDepth, RobustToStrayMarker) {
  const Grid g{20, 40, 1.0, 1.0};
  const Slab s = Slab::split(g.nx, 0, 1);
  for (DepthMethod method : {DepthMethod::Count, DepthMethod::Top}) {
    MarkerConfig cfg;
    cfg.depth = method;
    MarkerSet ms(MPI_COMM_SELF, g, s, cfg);
    ms.seed_depth([](double) { return 0.3; });
    const auto h0 = ms.depth();
    ms.add({Marker{5.5 * g.dx(), 0.9, -1}});
    const auto h1 = ms.depth();
    const double jump = method == DepthMethod::Count ? ms.spacing_z() / cfg.per_cell_x : 0.0;
    EXPECT_NEAR(h1[5] - h0[5], jump, 1e-12);
    EXPECT_EQ(h1[4], h0[4]);
  }
}

// Depth-averaged velocity (eq. 21) of a linear shear u = a z in a layer of depth h (cell-aligned
// and not): the cell-centre samples integrate a linear profile exactly over full cells; in the
// partial top cell the sample at the cell centre stands for the part below h, an error of at
// most a dz / 2 times the partial fraction, divided by h/dz cells: bound a dz^2 / (2 h).
TEST(MarkersDepth, DepthAveragedVelocity) {
  const Grid g{10, 20, 1.0, 1.0};
  const Slab s = Slab::split(g.nx, 0, 1);
  const double a = 2.0;
  Field u, w;
  fill_from_psi(g, s, false, [a](double, double z) { return 0.5 * a * z * z; }, 1.0, u, w);
  for (double h0 : {0.3, 0.3333}) {
    MarkerSet ms(MPI_COMM_SELF, g, s, MarkerConfig{});
    ms.seed_depth([h0](double) { return h0; });
    const ColumnProfile p = ms.profile(u, w);
    for (std::size_t i = 0; i < p.h.size(); ++i) {
      const double exact = 0.5 * a * p.h[i];
      EXPECT_NEAR(p.u_mean[i], exact, a * g.dz() * g.dz() / (2.0 * p.h[i]) + 1e-12);
      EXPECT_NEAR(p.w_mean[i], 0.0, 1e-12);
      EXPECT_NEAR(p.x[i], (i + 0.5) * g.dx(), 1e-15);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Inflow and outflow

namespace {
// Channel of the silo-gate scene at a coarse grid: opening h_in (not a multiple of the marker
// spacing), linear inflow profile U(z) = u_mean (0.5 + z / h_in) (mean u_mean over the opening).
// The channel carries the same shear u = U(z) at every height (divergence-free, w = 0; only the
// material below h_in is marked), so the velocity a strip's markers move with, interpolated
// bilinearly from the cell-row means of a linear profile, is exactly the strip's mean inflow
// velocity: the test isolates the injection (a face only partly open would otherwise show the
// solver's discretisation of the gate corner).
struct Channel {
  Grid g{60, 24, 0.3, 0.12};
  double h_in = 0.0607, u_mean = 0.37;
  double U(double z) const { return u_mean * (0.5 + z / h_in); }
  double Q(double z) const { return u_mean * (0.5 * z + 0.5 * z * z / h_in); }  // int_0^z U
  // mean inflow velocity over the opening part of the face of each cell row
  std::vector<double> u_face() const {
    std::vector<double> f(static_cast<std::size_t>(g.nz), 0.0);
    for (int k = 0; k < g.nz; ++k) {
      const double zb = k * g.dz(), zt = std::min((k + 1) * g.dz(), h_in);
      if (zt > zb) f[static_cast<std::size_t>(k)] = (Q(zt) - Q(zb)) / (zt - zb);
    }
    return f;
  }
  Psi psi(double wiggle) const {
    return [this, wiggle](double x, double z) {
      const double sz = std::sin(kPi * z / g.lz);
      return Q(z) + wiggle * std::sin(2.0 * kPi * x / g.lx) * sz * sz;
    };
  }
  MarkerConfig cfg() const {
    MarkerConfig c;
    c.sides = {MarkerBoundary::Inflow, MarkerBoundary::Outflow, MarkerBoundary::Wall,
               MarkerBoundary::Wall};
    return c;
  }
};
// A varying time step, as the CFL control gives (the accumulators must not care).
double dt_of(int step) { return 0.002 * (1.0 + 0.3 * std::sin(0.7 * step)); }
}  // namespace

// Over 400 steps (t = 0.8 s; the front leaves through the outflow after about 0.55 s) the
// injected area equals h_in u_mean t minus the accumulators' fractions, i.e. it lies in
// (Q t - R A_m, Q t] with R the number of injection rows: within one marker row (R A_m =
// s_x h_in rounded up to full rows), the brief's tolerance. The marker count obeys the integer
// ledger count = injected - removed exactly. In the interior the layer's mean depth is h_in
// within s_z / 2, and the depth of each column scatters about it as a random placement of the
// markers does (see the bound below).
TEST(MarkersInflow, InjectionMatchesFluxOverManySteps) {
  const Channel ch;
  const Slab s = Slab::split(ch.g.nx, 0, 1);
  Field u, w;
  fill_from_psi(ch.g, s, false, ch.psi(0.0), 1.0, u, w);
  MarkerSet ms(MPI_COMM_SELF, ch.g, s, ch.cfg());
  const auto profile = [&ch](double z) { return ch.U(z); };
  const double Q = ch.Q(ch.h_in);
  ASSERT_NEAR(Q, ch.h_in * ch.u_mean, 1e-15);
  double t = 0.0;
  for (int step = 0; step < 400; ++step) {
    const double dt = dt_of(step);
    ms.advect(dt, u, w);
    ms.inject(dt, ch.h_in, profile);
    t += dt;
    if (step % 50 == 49 || step == 399) {
      const MarkerMass mm = ms.mass();
      const double rows = std::ceil(ch.h_in / ms.spacing_z());
      EXPECT_LE(mm.injected_area, Q * t + 1e-12);
      EXPECT_GT(mm.injected_area, Q * t - rows * ms.marker_area());
      EXPECT_EQ(mm.count, mm.injected - mm.removed);
    }
  }
  const MarkerMass mm = ms.mass();
  std::printf("inflow: t = %.4f, injected area %.6e, h_in u_mean t = %.6e, rel. deficit %.2e, "
              "removed %lld\n",
              t, mm.injected_area, Q * t, (Q * t - mm.injected_area) / (Q * t), mm.removed);
  EXPECT_GT(mm.removed, 0);  // the outflow was exercised
  // Columns the slowest (bottom) row has passed: 0.5 u_mean t = 0.148 m, i.e. columns < 29.
  const auto h = ms.depth();
  double mean = 0, rms = 0, worst = 0;
  for (int i = 0; i < 26; ++i) {
    const double d = h[static_cast<std::size_t>(i)] - ch.h_in;
    mean += d / 26;
    rms += d * d / 26;
    worst = std::max(worst, std::abs(d));
  }
  rms = std::sqrt(rms);
  std::printf("inflow: depth of columns 0-25 - h_in: mean %.2e m, rms %.2e m, worst %.2e m "
              "(s_z = %.2e m)\n",
              mean, rms, worst, ms.spacing_z());
  // The mean over the columns is the injected area (above) per length: within s_z / 2 of h_in.
  EXPECT_LE(std::abs(mean), 0.5 * ms.spacing_z());
  // Column by column the count varies: each marker sits at a random height of its strip, and in
  // the shear U(z) markers of one strip at different heights drift apart along x (by
  // u_mean s_z / h_in t = 3 mm after 0.4 s, more than half a column), so the count of a column
  // is that of points placed at random rather than on a lattice. Independent placement (Poisson)
  // bounds its standard deviation by sqrt(R n_x) markers, i.e. sqrt(R / n_x) s_z = 3.5 s_z for
  // the R = 49 rows; measured: rms 1.0 s_z, worst 1.9 s_z (the jittered rows are sub-Poisson).
  const double rows = std::ceil(ch.h_in / ms.spacing_z());
  EXPECT_LE(rms, std::sqrt(rows / ms.config().per_cell_x) * ms.spacing_z());
}

// When h_in u_in t is a whole number of markers at a time the steps land on (an output time, as
// the app shortens its steps to hit them), that many have entered, whatever the step sequence:
// Setup II's gate (h_in = 0.06 m, u_in = 0.37 m/s, 1.25 mm marker spacing) at t = 0.25 s, 48 rows
// of 74 markers. The sequences' sums reach t with different last bits; before the accumulator's
// round-off allowance (kMarkerRoundOff) every one of them had rows whose last marker waited for
// the next step (measured: 0 of 40 complete), and which rows depended on the sequence: np 2
// differed from np 1 by a marker row at the gate of the coupled Setup II. Tolerance 0 on the
// count.
TEST(MarkersInflow, WholeMarkersEnterAtTheStepThatCompletesThemWhateverTheSequence) {
  const Grid g{60, 24, 0.3, 0.12};
  const Slab s = Slab::split(g.nx, 0, 1);
  MarkerConfig c;
  c.sides = {MarkerBoundary::Inflow, MarkerBoundary::Outflow, MarkerBoundary::Wall,
             MarkerBoundary::Wall};
  const double h_in = 0.06, u_in = 0.37, t_end = 0.25;
  std::vector<double> u_face(static_cast<std::size_t>(g.nz), 0.0);
  for (int k = 0; k < 12; ++k) u_face[static_cast<std::size_t>(k)] = u_in;
  int exact = 0;
  for (int seq = 0; seq < 40; ++seq) {
    MarkerSet ms(MPI_COMM_SELF, g, s, c);
    const long long expected =
        std::llround(h_in / ms.spacing_z()) * std::llround(u_in * t_end / ms.spacing_x());
    ASSERT_EQ(expected, 48LL * 74LL);
    double t = 0.0;
    for (int step = 0; t < t_end; ++step) {
      // a CFL-like varying step, shortened to land on t_end as the app lands on output times
      const double dt = std::min(0.002 * (1.0 + 0.3 * std::sin(0.7 * step + 0.37 * seq)), t_end - t);
      ms.inject(dt, h_in, u_face);
      t = (t_end - t == dt) ? t_end : t + dt;
    }
    SCOPED_TRACE("sequence " + std::to_string(seq));
    EXPECT_EQ(ms.mass().injected, expected);
    if (ms.mass().injected == expected) ++exact;
  }
  std::printf("whole markers: %d of 40 step sequences entered all 48 x 74 markers by t = 0.25 s\n",
              exact);
}

// A restart from save()/load() in the middle of an inflow run reproduces the straight run bit for
// bit (positions, ids, accumulators, counters): tolerance 0.
TEST(MarkersInflow, SaveLoadReproducesStraightRun) {
  const Channel ch;
  const Slab s = Slab::split(ch.g.nx, 0, 1);
  Field u, w;
  fill_from_psi(ch.g, s, false, ch.psi(0.002), 1.0, u, w);
  const auto uf = ch.u_face();
  const auto run = [&](MarkerSet& ms, int from, int to) {
    for (int n = from; n < to; ++n) {
      ms.advect(dt_of(n), u, w);
      ms.inject(dt_of(n), ch.h_in, uf);
    }
  };
  MarkerSet straight(MPI_COMM_SELF, ch.g, s, ch.cfg()), first(MPI_COMM_SELF, ch.g, s, ch.cfg());
  run(straight, 0, 300);
  run(first, 0, 170);
  MarkerSet second(MPI_COMM_SELF, ch.g, s, ch.cfg());
  second.load(first.save());
  run(second, 170, 300);
  EXPECT_EQ(max_displacement(sorted(second.markers()), sorted(straight.markers())), 0.0);
  EXPECT_EQ(second.inflow_accumulators(), straight.inflow_accumulators());
  const MarkerMass a = second.mass(), b = straight.mass();
  EXPECT_EQ(a.count, b.count);
  EXPECT_EQ(a.injected, b.injected);
  EXPECT_EQ(a.removed, b.removed);
}

// Injected material that slows down keeps every cell it covers marked (issue 11). The gate lets
// in a 5 mm layer at U0 = 2.5 m/s; the frozen, exactly divergence-free strain flow
// psi = (U0 - a x) z (u = U0 - a x, w = a z, a = 9 1/s) slows it down along x and thickens it
// along z as the deposit in front of a wall does: on the streamline from height z0 the
// material sits at z = z0 U0 / u(x), so the layer fills z < h(x) = h_in U0 / u(x) and its
// markers keep their density (the flow preserves area). By x = 0.25 m it has slowed down by
// F = U0 / u = 10. Markers at the centres of the four strips of the opening are four
// streamlines, F s_z apart (12.5 mm at F = 10, more than a cell), with empty cells between them
// (measured with strip-centre injection: 6 of the 102 cells inside the layer empty, the first
// at F = 5.8; fewer than the spacing suggests because the lines climb steeply across the cells
// near the stagnation line); at random heights of their strips they sample the whole layer. Asserted at the end (t = 0.35 s, the layer is steady for
// x < 0.25 m after 0.26 s): every cell that lies entirely inside the layer (top below
// h(x) at its left edge) and downstream of the first column holds markers, and their mean
// count is the lattice's n_x n_z = 16 (area conservation; 10 % allows for the cells the
// layer's edge cuts at the bottom of its column strip).
TEST(MarkersInflow, DeceleratedLayerLeavesNoEmptyCellInside) {
  const Grid g{60, 30, 0.3, 0.15};
  const Slab s = Slab::split(g.nx, 0, 1);
  const double U0 = 2.5, a = 9.0, h_in = 0.005;
  Field u, w;
  fill_from_psi(g, s, false, [&](double x, double z) { return (U0 - a * x) * z; }, 1.0, u, w);
  MarkerConfig c;
  c.sides = {MarkerBoundary::Inflow, MarkerBoundary::Outflow, MarkerBoundary::Wall,
             MarkerBoundary::Wall};
  MarkerSet ms(MPI_COMM_SELF, g, s, c);
  std::vector<double> uf(static_cast<std::size_t>(g.nz), 0.0);
  uf[0] = U0;  // the opening is the bottom cell row
  const double dt = 1e-3;  // U0 dt / dx = 0.5
  for (int n = 0; n < 350; ++n) {
    ms.advect(dt, u, w);
    ms.inject(dt, h_in, uf);
  }
  const auto count = ms.cell_counts();
  int inside = 0, empty = 0;
  double sum = 0.0;
  double first_empty_F = 0.0;
  for (int i = 1; i < g.nx; ++i) {
    const double x0 = i * g.dx();
    if (U0 - a * (x0 + g.dx()) < 0.1 * U0) break;  // beyond F = 10
    const double h = h_in * U0 / (U0 - a * x0);
    for (int k = 0; (k + 1) * g.dz() <= h; ++k) {
      const int n = count[static_cast<std::size_t>(i * g.nz + k)];
      ++inside;
      sum += n;
      if (n == 0) {
        ++empty;
        if (first_empty_F == 0.0) first_empty_F = U0 / (U0 - a * x0);
      }
    }
  }
  std::printf("decelerated layer: %d cells inside, %d empty (first at F = %.2f), mean count "
              "%.2f\n",
              inside, empty, first_empty_F, sum / inside);
  EXPECT_GT(inside, 80);  // the layer has thickened over several cells (not a vacuous check)
  EXPECT_EQ(empty, 0);
  EXPECT_NEAR(sum / inside, 16.0, 1.6);
}

// The hole check on hand-made flag fields (rows drawn top first: '.' Empty, 'F' Fluid, 'S'
// Surface): the case (the bed cell at the wall Empty under Surface and Fluid cells), a
// void inside a deposit, the air under a free jet's overhang (open to the atmosphere around the
// jet: not a hole), and an Empty pocket that only an open outflow side connects to the outside.
TEST(MarkersFlags, EnclosedVoidsAreHolesOverhangsAreNot) {
  const auto flags = [](const std::vector<std::string>& rows) {
    const int nz = static_cast<int>(rows.size()), nx = static_cast<int>(rows[0].size());
    std::vector<CellFlag> f(static_cast<std::size_t>(nx * nz));
    for (int k = 0; k < nz; ++k)
      for (int gi = 0; gi < nx; ++gi) {
        const char c = rows[static_cast<std::size_t>(nz - 1 - k)][static_cast<std::size_t>(gi)];
        f[static_cast<std::size_t>(gi * nz + k)] =
            c == '.' ? CellFlag::Empty : c == 'S' ? CellFlag::Surface : CellFlag::Fluid;
      }
    return f;
  };
  // wall at the right end: the bottom cell at the wall is a hole, as is the deposit's inner void
  const std::vector<std::string> deposit{"......", "....SS", "..SFFF", ".SF.FF", "SFFFF."};
  const auto h = enclosed_voids(flags(deposit), 6, 5);
  ASSERT_EQ(h.size(), 2u);
  EXPECT_EQ(h[0], (std::array<int, 2>{3, 1}));
  EXPECT_EQ(h[1], (std::array<int, 2>{5, 0}));
  // a jet leaving a step over the empty bed: the air under it reaches the top around its tip
  const std::vector<std::string> jet{".......", "SSSS...", "....S..", ".......", "FF....."};
  EXPECT_TRUE(enclosed_voids(flags(jet), 7, 5).empty());
  // a pocket against the right side: a hole at a wall, open at an outflow
  const std::vector<std::string> pocket{"......", "SSSSSS", "FFFF..", "FFFFFF"};
  EXPECT_EQ(enclosed_voids(flags(pocket), 6, 4).size(), 2u);
  EXPECT_TRUE(enclosed_voids(flags(pocket), 6, 4, false, true).empty());
  // The first columns of a 2D part fed through a 1D-to-2D interface at its left side, a shock's
  // deposit brought up to it: the incoming layer (rows 0-1) runs under the deposit, whose face
  // overhangs it and meets the side at rows 4-5, and the air between them (column 0 rows 1-3,
  // column 1 rows 2-3) touches the side above the opening, where the atmosphere lies over the
  // 1D layer: open. At a closed side (a silo gate's lip, a wall), or where the opening reaches
  // over the pocket (the side open from row 4 only: the pocket is inside the layer that enters),
  // the same cells are a hole.
  const std::vector<std::string> toe{"......", "SSSSSS", "FFFFFF", "..FFFF", "..FFFF", ".SFFFF",
                                     "FFFFFF"};
  const auto closed = enclosed_voids(flags(toe), 6, 7);
  ASSERT_EQ(closed.size(), 5u);
  EXPECT_EQ(closed[0], (std::array<int, 2>{0, 1}));
  EXPECT_TRUE(enclosed_voids(flags(toe), 6, 7, VoidSides{2, VoidSides::kClosed}).empty());
  EXPECT_TRUE(enclosed_voids(flags(toe), 6, 7, VoidSides{3, VoidSides::kClosed}).empty());
  EXPECT_EQ(enclosed_voids(flags(toe), 6, 7, VoidSides{4, VoidSides::kClosed}).size(), 5u);
  EXPECT_EQ(enclosed_voids(flags(toe), 6, 7, VoidSides{VoidSides::kClosed, 0}).size(), 5u);
  // the first open row above a layer of depth h (rows of dz = 0.005 m): its bottom at or above h
  EXPECT_EQ(first_row_above(0.0, 0.005, 7), 0);      // no layer: every row open
  EXPECT_EQ(first_row_above(0.004, 0.005, 7), 1);    // inside row 0
  EXPECT_EQ(first_row_above(0.010, 0.005, 7), 2);    // on the bottom of row 2
  EXPECT_EQ(first_row_above(0.010 + 1e-14, 0.005, 7), 2);  // a round-off above it (< 1e-9 rows)
  EXPECT_EQ(first_row_above(0.0101, 0.005, 7), 3);
  EXPECT_EQ(first_row_above(1.0, 0.005, 7), 7);      // deeper than the box: closed
}

// ---------------------------------------------------------------------------------------------
// MPI: np = 2 equals np = 1

namespace {
int world_rank() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}
int world_size() {
  int r = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &r);
  return r;
}
template <class T>
std::vector<T> gather_cells(const std::vector<T>& local) {
  const int n = static_cast<int>(local.size() * sizeof(T));
  std::vector<int> counts(static_cast<std::size_t>(world_size())), displs(counts.size(), 0);
  MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  int total = 0;
  for (std::size_t r = 0; r < counts.size(); ++r) {
    displs[r] = total;
    total += counts[r];
  }
  std::vector<T> all(static_cast<std::size_t>(total) / sizeof(T));
  MPI_Allgatherv(local.data(), n, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE,
                 MPI_COMM_WORLD);
  return all;  // ranks own consecutive columns, cells i * nz + k: the global order
}

// Advances a distributed set (MPI_COMM_WORLD) and a serial one (MPI_COMM_SELF) side by side and
// compares markers (ids, positions), flags with masks, and depths. Every operation a marker
// undergoes is the same floating-point sequence in both (global indices, identical ghost
// values), so the positions agree exactly; the assertion allows 1e-14 m only as a guard.
void compare_runs(const Grid& g, const MarkerConfig& cfg, const std::vector<CellFlag>& gflags,
                  const std::function<void(MarkerSet&)>& init,
                  const std::function<void(MarkerSet&, const Slab&, int)>& step, int steps) {
  const Slab s1 = Slab::split(g.nx, 0, 1);
  const Slab sp = Slab::split(g.nx, world_rank(), world_size());
  MarkerSet serial(MPI_COMM_SELF, g, s1, cfg), dist(MPI_COMM_WORLD, g, sp, cfg);
  const auto local_flags = [&](const Slab& s) {
    return std::vector<CellFlag>(gflags.begin() + s.i0 * g.nz,
                                 gflags.begin() + (s.i0 + s.nx_local) * g.nz);
  };
  std::vector<CellFlag> f1 = local_flags(s1), fp = local_flags(sp);
  serial.set_obstacles(f1);
  dist.set_obstacles(fp);
  init(serial);
  init(dist);
  std::vector<std::uint8_t> m1, mp;
  for (int n = 0; n < steps; ++n) {
    step(serial, s1, n);
    step(dist, sp, n);
    if (n % 25 == 24 || n == steps - 1) {
      const auto a = serial.gather(), b = dist.gather();
      ASSERT_EQ(a.size(), b.size()) << "step " << n;
      EXPECT_EQ(dist.global_count(), static_cast<long long>(a.size()));
      EXPECT_LE(max_displacement(a, b), 1e-14) << "step " << n;
      serial.update_flags(f1, &m1);
      dist.update_flags(fp, &mp);
      EXPECT_EQ(gather_cells(fp), f1) << "step " << n;
      EXPECT_EQ(gather_cells(mp), m1) << "step " << n;
      EXPECT_EQ(gather_cells(dist.depth()), serial.depth()) << "step " << n;
      const MarkerMass ma = serial.mass(), mb = dist.mass();
      EXPECT_EQ(ma.count, mb.count);
      EXPECT_EQ(ma.injected, mb.injected);
      EXPECT_EQ(ma.removed, mb.removed);
    }
  }
  long long sent = dist.migrated(), sent_all = 0;
  MPI_Allreduce(&sent, &sent_all, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  if (world_size() > 1) {
    EXPECT_GT(sent_all, 0);  // markers did cross the slab boundaries
  }
  if (world_rank() == 0)
    std::printf("np = %d vs np = 1: %zu markers agree after %d steps (%lld migrations)\n",
                world_size(), serial.markers().size(), steps, sent_all);
}
}  // namespace

// Periodic cellular flow with a time-dependent amplitude and an obstacle block straddling the
// rank boundary: markers cross the slab boundary and the periodic seam both ways.
TEST(MarkersMpi, PeriodicCellularFlowMatchesSerial) {
  const Grid g{40, 20, 2.0, 1.0};
  MarkerConfig cfg;
  cfg.sides = {MarkerBoundary::Periodic, MarkerBoundary::Periodic, MarkerBoundary::Wall,
               MarkerBoundary::Wall};
  std::vector<CellFlag> gflags(static_cast<std::size_t>(g.nx * g.nz), CellFlag::Fluid);
  for (int i = 18; i < 22; ++i)
    for (int k = 13; k < 16; ++k) gflags[static_cast<std::size_t>(i * g.nz + k)] = CellFlag::Obstacle;
  const Psi psi = [&](double x, double z) {
    return 0.15 * std::sin(2.0 * kPi * x / g.lx * 2.0 + 0.3) * std::sin(kPi * z / g.lz);
  };
  compare_runs(
      g, cfg, gflags, [](MarkerSet& m) { m.seed_depth([](double x) { return 0.4 + 0.1 * x; }); },
      [&](MarkerSet& m, const Slab& s, int n) {
        Field u, w;
        fill_from_psi(g, s, true, psi, 1.0, u, w);
        const double dt = 0.02, c0 = 1.0 + 0.5 * std::sin(0.05 * n),
                     c1 = 1.0 + 0.5 * std::sin(0.05 * (n + 1));
        m.advect(dt, scaled(u, c0), scaled(w, c0), scaled(u, c1), scaled(w, c1));
      },
      200);
}

// Inflow channel with an x-dependent wiggle (w != 0): injection on rank 0, removal at the outflow
// on the last rank, markers migrating downstream.
TEST(MarkersMpi, InflowChannelMatchesSerial) {
  const Channel ch;
  const auto uf = ch.u_face();
  std::vector<CellFlag> gflags(static_cast<std::size_t>(ch.g.nx * ch.g.nz), CellFlag::Fluid);
  compare_runs(
      ch.g, ch.cfg(), gflags, [](MarkerSet&) {},
      [&](MarkerSet& m, const Slab& s, int n) {
        Field u, w;
        fill_from_psi(ch.g, s, false, ch.psi(0.002), 1.0, u, w);
        m.advect(dt_of(n), u, w);
        m.inject(dt_of(n), ch.h_in, uf);
      },
      350);
}

// Marker voids filled (MarkerSet::relocate, NdamSolver::fill_marker_voids): moves between the
// two slabs of a seeded layer, both ways, every step, and one within a slab; on 2 ranks the
// markers that moved, where they went, the flags and the depths are the serial set's.
TEST(MarkersMpi, RelocateAcrossSlabsMatchesSerial) {
  const Grid g{40, 20, 2.0, 1.0};
  MarkerConfig cfg;
  std::vector<CellFlag> gflags(static_cast<std::size_t>(g.nx * g.nz), CellFlag::Fluid);
  compare_runs(
      g, cfg, gflags, [](MarkerSet& m) { m.seed_depth([](double) { return 0.4; }); },
      [&](MarkerSet& m, const Slab&, int n) {
        const int k = n % 8;  // rows of the layer (8 of 20 rows seeded), 16 markers a cell
        m.relocate({{19, k, 20, k}, {21, 7 - k, 20, 7 - k}, {5, k, 5, 8}});
      },
      50);
}

// A move takes the donor's marker nearest to the target's centre, puts it a quarter of the
// marker spacing inside the target's nearest edge and keeps every marker's area: the counts of
// the two cells change by one, the total not at all.
TEST(MarkersFlags, RelocateMovesTheNearestMarkerTheLeastDistance) {
  const Grid g{6, 5, 0.6, 0.5};
  MarkerConfig cfg;
  MarkerSet m(MPI_COMM_SELF, g, Slab::split(g.nx, 0, 1), cfg);
  m.seed_depth([](double) { return 0.2; });  // rows 0-1 full, 16 markers a cell
  const auto before = m.cell_counts();
  const auto nearest = [&]() {  // cell (2, 1)'s marker nearest to (2, 2)'s centre
    const double xc = 2.5 * g.dx(), zc = 2.5 * g.dz();
    const auto d2 = [&](const Marker& a) {
      return (a.x - xc) * (a.x - xc) + (a.z - zc) * (a.z - zc);
    };
    const Marker* b = nullptr;
    for (const Marker& mk : m.markers())
      if (mk.x >= 0.2 && mk.x < 0.3 && mk.z >= 0.1 && mk.z < 0.2 &&
          (!b || d2(mk) < d2(*b) || (d2(mk) == d2(*b) && mk.id < b->id)))
        b = &mk;
    return *b;
  }();
  m.relocate({{2, 1, 2, 2}});
  const auto after = m.cell_counts();
  const auto at = [&](int i, int k) { return static_cast<std::size_t>(i * g.nz + k); };
  EXPECT_EQ(after[at(2, 1)], before[at(2, 1)] - 1);
  EXPECT_EQ(after[at(2, 2)], 1);
  EXPECT_EQ(m.global_count(), static_cast<long long>(6 * 2 * 16));
  for (const Marker& mk : m.markers())
    if (mk.id == nearest.id) {
      EXPECT_DOUBLE_EQ(mk.x, nearest.x);  // straight up: x inside the target already
      EXPECT_DOUBLE_EQ(mk.z, 0.2 + 0.25 * m.spacing_z());
    }
}

// The donors of a void (ndam::void_fill_moves) on a 5 x 5 box of Fluid cells with one Empty
// cell (2, 2) in its middle: a 4-neighbour that keeps a marker gives first; where every
// 4-neighbour holds one marker (the ring that the static lab chute's expanding inflow leaves),
// the second ring gives, the cell with the most markers, never through an Obstacle; a void with
// no donor is left. Counts are the total of the moves (mass exact).
TEST(MarkersFlags, VoidTakesItsMarkerFromTheNearestRingThatCanGive) {
  const int nx = 5, nz = 5;
  const auto at = [](int i, int k) { return static_cast<std::size_t>(i * 5 + k); };
  const auto box = [&](double fill) {
    std::vector<double> c(static_cast<std::size_t>(nx * nz), fill);
    c[at(2, 2)] = 0.0;
    return c;
  };
  std::vector<CellFlag> flags(static_cast<std::size_t>(nx * nz), CellFlag::Fluid);
  flags[at(2, 2)] = CellFlag::Empty;
  using Move = std::array<int, 4>;
  // every cell with 4 markers: the cell below gives (the first of the equal 4-neighbours)
  auto mv = void_fill_moves(box(4.0), flags, nx, nz, VoidSides{});
  ASSERT_EQ(mv.size(), 1u);
  EXPECT_EQ(mv[0], (Move{2, 1, 2, 2}));
  // the 4-neighbours hold 1 marker each but the right one 2: it gives, though a diagonal holds 9
  auto c = box(1.0);
  c[at(3, 2)] = 2.0;
  c[at(1, 1)] = 9.0;
  mv = void_fill_moves(c, flags, nx, nz, VoidSides{});
  ASSERT_EQ(mv.size(), 1u);
  EXPECT_EQ(mv[0], (Move{3, 2, 2, 2}));
  // a ring of single markers: the second ring's fullest cell gives, the one two cells above (4)
  // before the diagonal below-left (3)
  c = box(1.0);
  c[at(1, 1)] = 3.0;
  c[at(2, 4)] = 4.0;
  mv = void_fill_moves(c, flags, nx, nz, VoidSides{});
  ASSERT_EQ(mv.size(), 1u);
  EXPECT_EQ(mv[0], (Move{2, 4, 2, 2}));
  // ... but not through an Obstacle between them: then the diagonal
  auto blocked = flags;
  blocked[at(2, 3)] = CellFlag::Obstacle;
  mv = void_fill_moves(c, blocked, nx, nz, VoidSides{});
  ASSERT_EQ(mv.size(), 1u);
  EXPECT_EQ(mv[0], (Move{1, 1, 2, 2}));
  // ... nor through two Obstacles beside a diagonal; the fullest reachable cell two below
  blocked[at(1, 2)] = CellFlag::Obstacle;
  c[at(2, 0)] = 5.0;
  blocked[at(2, 1)] = CellFlag::Obstacle;  // (1, 1) now reached only through obstacles
  mv = void_fill_moves(c, blocked, nx, nz, VoidSides{});
  EXPECT_TRUE(mv.empty());  // and (2, 0) only through the obstacle (2, 1): nothing
  blocked[at(2, 1)] = CellFlag::Fluid;  // through (2, 1): (2, 0) with 5 before (1, 1) with 3
  mv = void_fill_moves(c, blocked, nx, nz, VoidSides{});
  ASSERT_EQ(mv.size(), 1u);
  EXPECT_EQ(mv[0], (Move{2, 0, 2, 2}));
  // single markers everywhere: no cell can give, the void is left (nothing made)
  EXPECT_TRUE(void_fill_moves(box(1.0), flags, nx, nz, VoidSides{}).empty());
  // a 3 x 3 void in a 7 x 7 box of 4-marker cells fills from its rim: its eight rim cells take
  // a marker each from a neighbour, its centre none in this step (no marker jumps across the
  // void), and the markers are only moved (the total is kept)
  {
    const int n7 = 7;
    const auto at7 = [](int i, int k) { return static_cast<std::size_t>(i * 7 + k); };
    std::vector<double> c7(49, 4.0);
    std::vector<CellFlag> f7(49, CellFlag::Fluid);
    for (int i = 2; i <= 4; ++i)
      for (int k = 2; k <= 4; ++k) {
        c7[at7(i, k)] = 0.0;
        f7[at7(i, k)] = CellFlag::Empty;
      }
    const auto m7 = void_fill_moves(c7, f7, n7, n7, VoidSides{});
    EXPECT_EQ(m7.size(), 8u);
    std::vector<double> after = c7;
    for (const auto& m : m7) {
      EXPECT_FALSE(m[2] == 3 && m[3] == 3) << "the centre filled across the void";
      EXPECT_EQ(std::abs(m[0] - m[2]) + std::abs(m[1] - m[3]), 1) << "a rim cell from beyond";
      after[at7(m[0], m[1])] -= 1.0;
      after[at7(m[2], m[3])] += 1.0;
    }
    double total = 0.0;
    for (const double v : after) total += v;
    EXPECT_EQ(total, 40.0 * 4.0);
  }
  // a void that reaches an open side is not a void: an Empty column 2 open at the top
  auto open = flags;
  for (int k = 2; k < nz; ++k) open[at(2, k)] = CellFlag::Empty;
  EXPECT_TRUE(void_fill_moves(box(4.0), open, nx, nz, VoidSides{}).empty());
}

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  if (world_rank() != 0) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  int rc = RUN_ALL_TESTS(), any = 0;
  MPI_Allreduce(&rc, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return any;
}
