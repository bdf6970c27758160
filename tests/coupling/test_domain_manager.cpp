// The runtime domain manager (Decomposition->Layout = Dynamic) and the conservative state
// conversion it moves interfaces with, on coarse chutes (10 mm cells) built through the XML scene
// interface.
#include "granflow/coupling/conversion.hpp"
#include "granflow/coupling/coupled_model.hpp"
#include "granflow/coupling/domain_manager.hpp"
#include "granflow/coupling/factory.hpp"
#include "granflow/dam/dam_solver.hpp"
#include "granflow/ndam/ndam_solver.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "chute_scene.hpp"

using namespace granflow;
using namespace granflow::test;

namespace {

coupling::CoupledModel& coupled_mut(core::Stepper& s) {
  return dynamic_cast<coupling::CoupledModel&>(s);
}

// Moves the interfaces of `m` to the layout `plan` (the whole channel) as the manager does.
coupling::ConversionRecord move_to(coupling::CoupledModel& m, const std::vector<coupling::Piece>& plan) {
  coupling::ConversionRecord rec;
  auto parts = coupling::rebuild(m.parts(), 0, m.parts().size(), plan, *m.factory(), rec);
  m.replace_parts(0, m.parts().size(), std::move(parts));
  return rec;
}

// |u_mean| jump across each interface: first column downstream against last upstream, relative.
double interface_jump(const core::Stepper& s) {
  const auto& c = coupled(s);
  const auto p = s.profile();
  double worst = 0.0;
  for (std::size_t i = 0; i < c.interfaces(); ++i) {
    const double x = c.interface(i).x();
    std::size_t k = 0;
    while (k + 1 < p.x.size() && p.x[k + 1] < x) ++k;
    if (p.h[k] < 1e-3 || p.h[k + 1] < 1e-3) continue;
    worst = std::max(worst, std::abs(p.u_mean[k + 1] - p.u_mean[k]) / std::abs(p.u_mean[k]));
  }
  return worst;
}

}  // namespace

// A move in steady supercritical flow (Setup I, open end): the interfaces of the paper's layout
// shift by 5 cells each; the flow must not notice beyond the layout's own effect.
TEST(DomainManager, MoveInSteadySupercriticalFlowSendsNoReflection) {
  Chute s;
  s.name = "dm_steady";
  s.length = 1.0;
  s.end_time = 1.2;
  auto a = s.build();
  s.name = "dm_steady_b";
  auto b = s.build();
  run(*a, 0.9);
  run(*b, 0.9);
  const double jump0 = interface_jump(*a);
  const auto before = b->profile();
  auto rec = move_to(coupled_mut(*b), {{"2D", 0.0, 0.25}, {"1D", 0.25, 0.65}, {"2D", 0.65, 1.0}});
  {
    const auto after = b->profile();
    for (std::size_t i = 0; i < after.x.size(); ++i)
      if ((after.x[i] > 0.18 && after.x[i] < 0.28) || (after.x[i] > 0.62 && after.x[i] < 0.72))
        std::printf("x %.3f %s h %.5f -> %.5f u %.4f -> %.4f\n", after.x[i], after.model[i].c_str(), before.h[i], after.h[i], before.u_mean[i], after.u_mean[i]);
  }
  std::printf("[measured] move: mass %.6e -> %.6e (defect %.2e), momentum %.6e -> %.6e, "
              "remainder %.2e given back %.2e; columns to 2D %d, to 1D %d\n",
              rec.mass_before, rec.mass_after, rec.defect(), rec.momentum_before,
              rec.momentum_after, rec.remainder, rec.remainder_given_back, rec.columns_to_2d,
              rec.columns_to_1d);
  double worst_jump = interface_jump(*b);
  std::printf("[measured] jump static %.3e, right after the move %.3e\n", jump0, worst_jump);
  for (int k = 0; k < 40; ++k) {
    const double t = 0.9 + 0.3 * (k + 1) / 40.0;
    run(*a, t);
    run(*b, t);
    worst_jump = std::max(worst_jump, interface_jump(*b));
    const auto pa = a->profile(), pb = b->profile();
    double du = 0.0;
    for (std::size_t i = 0; i < pa.x.size(); ++i)
      if (pa.h[i] > 2e-3) du = std::max(du, std::abs(pb.u_mean[i] - pa.u_mean[i]) / pa.u_mean[i]);
    if (k % 8 == 0 || k == 39)
      std::printf("[measured] t = %.3f: jump %.3e (static %.3e), max |du|/u moved vs static %.3e\n", t,
                  interface_jump(*b), interface_jump(*a), du);
  }
  EXPECT_LT(worst_jump, 1.0);
}
