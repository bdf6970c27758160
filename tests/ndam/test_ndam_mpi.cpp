// np = 2 equals np = 1 (issue 3, item 7). Run under `mpiexec -n 2`: every case is run once
// distributed over the two ranks (x-slabs, MPI_COMM_WORLD) and once serially on each rank
// (MPI_COMM_SELF), and the gathered fields are compared.
//
// Tolerance: every linear solve stops at a relative residual of 1e-10, and the two runs use
// different preconditioners (MueLu aggregates and Gauss-Seidel sweeps are per rank), so their
// solutions differ by up to ~ tolerance x condition number per solve; time stepping carries these
// differences along without amplifying them (the cases are stable). Measured max differences
// are ~1e-12 .. 1e-10 m/s; asserted: 1e-8 m/s for velocities (1e-8 of the lid speed) and
// 1e-7 m^2/s^2 for the pressure (scale ~ 1-10 m^2/s^2).
#include "ndam_test_util.hpp"

#include <gtest/gtest.h>

#include <cstdio>

using namespace ndam_test;

namespace {
struct Diff {
  double u, w, p;
};
Diff compare(const Case& c, int steps, double dt) {
  auto par = make(c, MPI_COMM_WORLD);
  auto ser = make(c, MPI_COMM_SELF);
  for (int n = 0; n < steps; ++n) {
    // the same dt on both (stable_dt agrees to round-off; a fixed dt keeps the runs in step)
    par->step(dt);
    par->accept();
    ser->step(dt);
    ser->accept();
  }
  return {max_abs_diff(par->gather_u(), ser->gather_u()),
          max_abs_diff(par->gather_w(), ser->gather_w()),
          max_abs_diff(par->gather_p(), ser->gather_p())};
}
bool rank0() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r == 0;
}
void expect_equal(const char* name, const Diff& d) {
  if (rank0())
    std::printf("[np=2 vs np=1] %-36s max diff u %.2e w %.2e p %.2e\n", name, d.u, d.w, d.p);
  EXPECT_LT(d.u, 1e-8) << name;
  EXPECT_LT(d.w, 1e-8) << name;
  EXPECT_LT(d.p, 1e-7) << name;
}
}  // namespace

TEST(NdamMpi, RunsOnTwoRanks) {
  int ranks = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  EXPECT_EQ(ranks, 2) << "run this test with mpiexec -n 2";
}

TEST(NdamMpi, CavityExplicitAndImplicit) {
  for (const char* mom : {"Explicit", "Implicit"}) {
    Case c;
    c.nx = 24;
    c.nz = 16;
    c.lz = 0.75;
    c.momentum = mom;
    c.gamma = 0.5;
    expect_equal((std::string("cavity Re=100 ") + mom).c_str(), compare(c, 40, 0.01));
  }
}

TEST(NdamMpi, BinghamCavityImplicit) {
  Case c;
  c.nx = 21;  // uneven slabs: 11 + 10 columns
  c.nz = 20;
  c.rheology = "Bingham";
  c.yield = 0.1;
  c.m_y = 1000;
  c.gamma = 0.5;
  expect_equal("Bingham cavity implicit", compare(c, 30, 0.02));
}

TEST(NdamMpi, CavityWithObstacleAcrossSlabs) {
  // The block covers columns 9..14 of 24, across the slab boundary between columns 11 and 12.
  for (const char* mom : {"Explicit", "Implicit"}) {
    Case c;
    c.nx = 24;
    c.nz = 16;
    c.lz = 0.75;
    c.momentum = mom;
    c.gamma = 0.5;
    c.obstacles = "0.38 0.62 0 0.3";
    expect_equal((std::string("cavity with block ") + mom).c_str(), compare(c, 40, 0.01));
  }
}

TEST(NdamMpi, PeriodicSlopeFlow) {
  // Periodic in x (the wrap crosses the rank boundary), gravity down a 30 deg slope, a lid and a
  // no-slip bed: a sheared, accelerating flow with hydrostatic pressure in z.
  for (const char* mom : {"Explicit", "Implicit"}) {
    Case c;
    c.nx = 16;
    c.nz = 8;
    c.lx = 0.4;
    c.lz = 0.1;
    c.walls = {"Periodic", "Periodic", "No-slip", "Moving lid"};
    c.lid = -0.2;
    c.gravity = 9.81;
    c.slope_deg = 30;
    c.nu = 0.05;
    c.momentum = mom;
    expect_equal((std::string("periodic slope flow ") + mom).c_str(), compare(c, 30, 0.001));
  }
}

// The free-surface chute (issue 4): silo gate inflow, markers across the slab boundary, Coulomb
// bed and end wall, Drucker-Prager. The flags follow from the marker counts, and markers move
// with velocities that differ between the runs by ~1e-12, so a marker could in principle land
// in another cell; with the tolerance below such a flip would show as an O(0.1) difference.
#include "ndam_chute_util.hpp"
namespace {
// The chute c on two ranks against one, 160 steps of 2 ms (the front crosses the slab boundary
// at x = 0.15 m): the fields to expect_equal's tolerances, the depths to 1e-12, the same mass.
void compare_chute(const char* what, const ndam_chute::FsCase& c) {
  auto par = ndam_chute::make_fs(c, MPI_COMM_WORLD);
  auto ser = ndam_chute::make_fs(c, MPI_COMM_SELF);
  for (int n = 0; n < 160; ++n) {
    par->step(0.002);
    par->accept();
    ser->step(0.002);
    ser->accept();
  }
  expect_equal(what, {max_abs_diff(par->gather_u(), ser->gather_u()),
                      max_abs_diff(par->gather_w(), ser->gather_w()),
                      max_abs_diff(par->gather_p(), ser->gather_p())});
  const auto pa = par->profile(), se = ser->profile();
  EXPECT_LT(max_abs_diff(pa.h, se.h), 1e-12);
  EXPECT_GT(*std::max_element(pa.h.begin(), pa.h.end()), 0.0);
  EXPECT_DOUBLE_EQ(par->mass_balance().current, ser->mass_balance().current);
  if (rank0())
    std::printf("[np=2 vs np=1] %s: front at %.3f m, marker area %.6f m^2\n", what,
                [&] { double f = 0; for (std::size_t q = 0; q < pa.x.size(); ++q) if (pa.h[q] > 0) f = pa.x[q]; return f; }(),
                par->mass_balance().current);
}
}  // namespace

// The initial layer off the marker lattice (MarkerSet::seed_rectangle thins its partly covered
// top row and end columns by a rule on the global lattice index): two ranks seed the same
// markers as one, so the initial marker area and depths are equal exactly, and the layer
// [0.0137, 0.2621) m x 21.3 mm crosses the slab boundary at 0.15 m.
TEST(NdamMpi, InitialLayerOffTheLatticeIsTheSameOnTwoRanks) {
  auto c = ndam_chute::closed_pool(30, 10, 0.3, 0.1, 0.0213);
  c.init_x0 = 0.0137;
  c.init_x1 = 0.2621;
  auto par = ndam_chute::make_fs(c, MPI_COMM_WORLD);
  auto ser = ndam_chute::make_fs(c, MPI_COMM_SELF);
  EXPECT_EQ(par->mass_balance().current, ser->mass_balance().current);
  const auto pa = par->profile(), se = ser->profile();
  EXPECT_EQ(max_abs_diff(pa.h, se.h), 0.0);
  EXPECT_GT(par->mass_balance().current, 0.0);
}

TEST(NdamMpi, FreeSurfaceChute) {
  compare_chute("free-surface chute (DP, Coulomb)", ndam_chute::gate_chute());
}

// The same chute with the ghost-fluid free surface ('Surface pressure' = Ghost fluid): the
// inside Surface cells and their ghost distances follow from the gathered marker counts (the
// same on every rank), and ghost faces cross the slab boundary with the front; the same
// tolerances.
TEST(NdamMpi, FreeSurfaceChuteGhostFluid) {
  auto c = ndam_chute::gate_chute();
  c.surface_pressure = "Ghost fluid";
  compare_chute("free-surface chute, ghost fluid", c);
}

// The same chute with the nonlinear pressure coupling (NOX on R(q) = q - P(q)): the Newton
// iterates are distributed vectors, so np = 2 reproduces np = 1 to the Newton and linear
// tolerances (the JFNK finite differences and GMRES see reductions in another order): asserted
// with expect_equal's tolerances after 60 steps (the front crosses the slab boundary later; the
// Newton path is the thing under test here), and the same Newton iteration counts.
TEST(NdamMpi, FreeSurfaceChuteNonlinearPressure) {
  const auto c = ndam_chute::gate_chute("Nonlinear");
  auto par = ndam_chute::make_fs(c, MPI_COMM_WORLD);
  auto ser = ndam_chute::make_fs(c, MPI_COMM_SELF);
  long long its_par = 0, its_ser = 0;
  for (int n = 0; n < 60; ++n) {
    par->step(0.002);
    ASSERT_TRUE(par->check().ok);
    its_par += par->last_newton_solve().newton_iterations;
    par->accept();
    ser->step(0.002);
    ASSERT_TRUE(ser->check().ok);
    its_ser += ser->last_newton_solve().newton_iterations;
    ser->accept();
  }
  EXPECT_EQ(par->newton_solves(), 60);
  EXPECT_EQ(its_par, its_ser);
  expect_equal("free-surface chute, nonlinear pressure",
               {max_abs_diff(par->gather_u(), ser->gather_u()),
                max_abs_diff(par->gather_w(), ser->gather_w()),
                max_abs_diff(par->gather_p(), ser->gather_p())});
}

// The same chute with the nonlinear coupling on slabs that the load balance rebuilds as the
// front advances (adapt() after every accepted step, as the driver does; 'Load balance' =
// Material, the default). Found by an independent run: the trial pressure of the nonlinear solve
// kept the width of the slab it was first built on, so after a rebuild that widened a rank's
// slab project_at wrote past its end (a segfault or 'double free' on two ranks, np 1 clean).
// Asserted: the run goes on through at least one rebuild (measured 9 in 150 steps), every step's
// nonlinear solve converges, and np = 2 agrees with np = 1 with expect_equal's tolerances
// (measured 2.3e-10 m/s, 2.5e-10 m^2/s^2: here the two runs take the same Anderson iterations;
// in longer runs a solve that stops one iteration apart leaves the Anderson tolerance between
// them, docs/validation.md).
TEST(NdamMpi, NonlinearPressureAcrossSlabRebuilds) {
  const auto c = ndam_chute::gate_chute("Nonlinear");
  auto par = ndam_chute::make_fs(c, MPI_COMM_WORLD);
  auto ser = ndam_chute::make_fs(c, MPI_COMM_SELF);
  int rebuilds = 0;
  for (int n = 0; n < 150; ++n) {
    par->step(0.002);
    ASSERT_TRUE(par->check().ok) << "step " << n;
    par->accept();
    if (par->adapt()) ++rebuilds;
    ser->step(0.002);
    ASSERT_TRUE(ser->check().ok) << "step " << n;
    ser->accept();
  }
  EXPECT_EQ(par->newton_solves(), 150);
  EXPECT_GE(rebuilds, 1);
  const Diff d{max_abs_diff(par->gather_u(), ser->gather_u()),
               max_abs_diff(par->gather_w(), ser->gather_w()),
               max_abs_diff(par->gather_p(), ser->gather_p())};
  if (rank0()) std::printf("[np=2 vs np=1] nonlinear: %d slab rebuilds in 150 steps\n", rebuilds);
  expect_equal("nonlinear, across slab rebuilds", d);
}
