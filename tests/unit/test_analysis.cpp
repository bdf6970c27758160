// Run comparison and a priori layout (granflow-study) on synthetic profiles with known answers.
#include "granflow/analysis/profiles.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace granflow::analysis;

namespace {
ProfileAt uniform_profile(int n, double L, double h, double u) {
  ProfileAt p;
  for (int i = 0; i < n; ++i) {
    p.x.push_back((i + 0.5) * L / n);
    p.h.push_back(h);
    p.u.push_back(u);
    p.eps.push_back(0.0);
    p.model.push_back("1D");
  }
  return p;
}
}  // namespace

TEST(Compare, RelativeErrorsOfAKnownPerturbation) {
  auto ref = uniform_profile(100, 1.0, 0.02, 2.0);
  auto test = ref;
  for (auto& h : test.h) h *= 1.01;  // +1 % everywhere
  test.u[50] = 2.2;                   // +10 % at one point
  const auto e = compare(ref, test, 1e-3, 1e-3);
  // Exact values up to round-off of the arithmetic on O(1) numbers.
  EXPECT_NEAR(e.h.max_rel, 0.01, 1e-12);
  EXPECT_NEAR(e.h.l2_rel, 0.01, 1e-12);
  EXPECT_NEAR(e.u.max_rel, 0.1, 1e-12);
  EXPECT_NEAR(e.u.l2_rel, std::sqrt(0.2 * 0.2 / (100 * 4.0)), 1e-12);
  EXPECT_EQ(e.h.points, 100);
}

TEST(Compare, DryReferencePointsAreNotCompared) {
  auto ref = uniform_profile(10, 1.0, 0.02, 1.0);
  for (int i = 5; i < 10; ++i) ref.h[static_cast<std::size_t>(i)] = 0.0;
  auto test = ref;
  test.h[7] = 0.05;  // material where the reference is dry: outside the flowing part
  const auto e = compare(ref, test, 1e-3, 1e-3);
  EXPECT_EQ(e.h.points, 5);
  EXPECT_EQ(e.h.max_rel, 0.0);
}

TEST(Compare, AveragedVelocityOfALinearProfileIsItsMidpointValue) {
  // u = 3 x on [0, 1]: 1/l int_0^l 3x dx = 1.5 l; the midpoint rule is exact for linear data.
  auto p = uniform_profile(200, 1.0, 0.01, 0.0);
  for (std::size_t i = 0; i < p.x.size(); ++i) p.u[i] = 3.0 * p.x[i];
  EXPECT_NEAR(average_velocity(p, 0.2), 0.3, 1e-12);
}

TEST(Layout, TwoDeepRegionsWidenedByTheMarginWithOneDBetween) {
  // eps >= 0.1 on x < 0.05 (inlet) and x > 0.9 (wall): expect 2D [0, 0.05 + m],
  // 1D in between, 2D [0.9 - m, 1].
  auto p = uniform_profile(100, 1.0, 0.02, 1.0);
  for (std::size_t i = 0; i < p.x.size(); ++i)
    p.eps[i] = (p.x[i] < 0.05 || p.x[i] > 0.9) ? 1.0 : 0.01;
  const std::map<double, ProfileAt> run{{0.5, p}};
  const auto lay = propose_layout(run, 1.0, 0.1, 0.05, 0.02, 1e-3);
  ASSERT_EQ(lay.size(), 3u);
  EXPECT_EQ(lay[0].model, "2D");
  EXPECT_EQ(lay[1].model, "1D");
  EXPECT_EQ(lay[2].model, "2D");
  // Cell faces lie on multiples of 0.01; round-off only.
  EXPECT_NEAR(lay[0].x1, 0.10, 1e-12);
  EXPECT_NEAR(lay[2].x0, 0.85, 1e-12);
  EXPECT_NEAR(lay[2].x1, 1.0, 1e-12);
}

TEST(Layout, ShortOneDGapsAreAbsorbedAndDryCellsIgnored) {
  auto p = uniform_profile(100, 1.0, 0.02, 1.0);
  for (std::size_t i = 0; i < p.x.size(); ++i) {
    p.eps[i] = (p.x[i] < 0.3 || (p.x[i] > 0.32 && p.x[i] < 0.5)) ? 1.0 : 0.0;
    if (p.x[i] > 0.8) { p.h[i] = 0.0; p.eps[i] = 1e6; }  // dry: must not count
  }
  const auto lay = propose_layout({{0.1, p}}, 1.0, 0.1, 0.0, 0.05, 1e-3);
  ASSERT_EQ(lay.size(), 2u);
  EXPECT_EQ(lay[0].model, "2D");
  EXPECT_NEAR(lay[0].x1, 0.5, 1e-12);
  EXPECT_EQ(lay[1].model, "1D");
}
