// Restarts continue bit for bit: a model saved into a checkpoint at t1 and loaded into a freshly
// built model of the same scene takes the same next steps as the model that ran on (issue 13
// item 3; issue 10 item 4 for the dynamic layout). Both are stepped with the same time steps, so
// what is compared is the model state alone (the driver's output schedule is tested with the
// app in tests/cli).
#include "granflow/io/fields.hpp"
#include "granflow/ndam/ndam_solver.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "chute_scene.hpp"

using namespace granflow;
using namespace granflow::test;

namespace {

struct Divergence {
  int first_step = -1;  // first step after the restart whose profile differs (-1: none)
  double dh = 0.0, du = 0.0;
};

// Runs `straight` to t1, checkpoints it into a new model of the same scene, then steps both
// `steps` times with the straight run's dt and compares h and u_mean after every step.
Divergence restart_and_compare(const Chute& c, double t1, int steps) {
  auto straight = c.build();
  straight->adapt();
  while (straight->time() < t1 - 1e-12) {
    straight->step(std::min(straight->stable_dt(), t1 - straight->time()));
    EXPECT_TRUE(straight->check().ok);
    straight->accept();
    straight->adapt();
  }
  io::Checkpoint ck;
  straight->save(ck);
  Chute c2 = c;
  c2.name += "_restarted";
  auto restarted = c2.build();
  restarted->load(ck);
  if (std::getenv("GF_SELFLOAD")) straight->load(ck);
  if (const auto* na = dynamic_cast<const ndam::NdamSolver*>(straight.get())) {
    const auto* nb = dynamic_cast<const ndam::NdamSolver*>(restarted.get());
    const auto ua = na->gather_u(), ub = nb->gather_u(), wa = na->gather_w(), wb = nb->gather_w();
    const int nz = na->grid().nz;
    for (std::size_t i = 0; i < ua.size(); ++i) {
      if (ua[i] != ub[i]) std::printf("DBG u diff gi %zu k %zu: %.17g vs %.17g flags %d %d\n", i / nz, i % nz, ua[i], ub[i], (int)na->flag(i/nz, i%nz), (int)nb->flag(i/nz,i%nz));
      if (wa[i] != wb[i]) std::printf("DBG w diff gi %zu k %zu: %.17g vs %.17g flag %d\n", i / nz, i % nz, wa[i], wb[i], (int)na->flag(i/nz, i%nz));
    }
  }
  Divergence d;
  for (int n = 0; n < steps; ++n) {
    const double dt = straight->stable_dt();
    EXPECT_EQ(dt, restarted->stable_dt()) << "step " << n;
    straight->step(dt);
    restarted->step(dt);
    EXPECT_TRUE(straight->check().ok);
    straight->accept();
    restarted->accept();
    straight->adapt();
    restarted->adapt();
    if (n == 0) if (const auto* na = dynamic_cast<const ndam::NdamSolver*>(straight.get())) {
      const auto* nb = dynamic_cast<const ndam::NdamSolver*>(restarted.get());
      const auto ua = na->gather_u(), ub = nb->gather_u(), pa = na->gather_p(), pb = nb->gather_p();
      const int nz = na->grid().nz;
      int shown = 0;
      for (std::size_t i = 0; i < ua.size() && shown < 15; ++i)
        if (ua[i] != ub[i] || pa[i] != pb[i]) { ++shown; std::printf("DBG step0 gi %zu k %zu: u %.17g vs %.17g p %.6g vs %.6g flag %d\n", i / nz, i % nz, ua[i], ub[i], pa[i], pb[i], (int)na->flag(i/nz, i%nz)); }
      const auto ma = na->markers()->gather(), mb = nb->markers()->gather();
      std::printf("DBG markers %zu vs %zu\n", ma.size(), mb.size());
      for (std::size_t i = 0; i < std::min(ma.size(), mb.size()); ++i)
        if (ma[i].id != mb[i].id || ma[i].x != mb[i].x || ma[i].z != mb[i].z) { std::printf("DBG marker %zu differs %lld %.17g %.17g vs %lld %.17g %.17g\n", i, ma[i].id, ma[i].x, ma[i].z, mb[i].id, mb[i].x, mb[i].z); break; }
    }
    const auto a = straight->profile(), b = restarted->profile();
    if (a.x.size() != b.x.size()) {
      if (d.first_step < 0) d.first_step = n;
      continue;
    }
    for (std::size_t i = 0; i < a.x.size(); ++i) {
      const double eh = std::abs(a.h[i] - b.h[i]), eu = std::abs(a.u_mean[i] - b.u_mean[i]);
      if ((eh > 0.0 || eu > 0.0) && d.first_step < 0) d.first_step = n;
      d.dh = std::max(d.dh, eh);
      d.du = std::max(d.du, eu);
    }
  }
  return d;
}

}  // namespace

TEST(Restart, NdamChuteContinuesBitForBit) {
  Chute c;
  c.name = "rs_ndam";
  c.model = "N-DAM";
  c.wall = true;
  const auto d = restart_and_compare(c, 0.35, 60);
  std::printf("[measured] N-DAM restart at 0.35 s: first differing step %d, max |dh| %.3e m, "
              "max |du| %.3e m/s over 60 steps\n", d.first_step, d.dh, d.du);
  EXPECT_EQ(d.first_step, -1);
}

TEST(Restart, NdamChuteNoReuse) {
  Chute c;
  c.name = "rs_ndam_noreuse";
  c.model = "N-DAM";
  c.wall = true;
  c.ndam_extra = R"x(
    <ParameterList name="Momentum solver"><Parameter name="Preconditioner reuse" type="int" value="0"/></ParameterList>
    <ParameterList name="Pressure solver"><Parameter name="Preconditioner reuse" type="int" value="0"/></ParameterList>)x";
  const auto d = restart_and_compare(c, 0.35, 60);
  std::printf("[measured] N-DAM restart (no reuse) at 0.35 s: first differing step %d, max |dh| %.3e m, "
              "max |du| %.3e m/s over 60 steps\n", d.first_step, d.dh, d.du);
  EXPECT_EQ(d.first_step, -1);
}
