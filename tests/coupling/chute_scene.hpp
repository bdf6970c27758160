#pragma once
// Coupled-chute scenes for the tests, written as XML and built through the scene interface
// (scene::load and scene::build_model, as the granflow app does), and small helpers.
#include "granflow/core/simulation.hpp"
#include "granflow/coupling/coupled_model.hpp"
#include "granflow/dam/dam_solver.hpp"
#include "granflow/scene/scene.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

namespace granflow::test {

/// A chute scene in the style of the paper's Setup I/II (zeta = 50 deg, phi = 33, delta = 22,
/// silo gate h_in = 0.06 m, u_in = 0.37 m/s, Drucker-Prager with Coulomb sliding) at a coarse
/// resolution: dx = dz = 10 mm in 2D, dx = 10 mm in 1D.
struct Chute {
  std::string name = "chute";
  std::string model = "Coupled";
  std::string models = "2D, 1D, 2D";
  std::string interfaces = "0.2, 0.7";
  std::string decomposition_extra;  // further Decomposition parameters (XML lines)
  std::string layout = "Static";
  int dam_cells_per_column = 1;  // DAM cells per 2D column
  double length = 1.0;
  bool wall = false;  // rigid wall at x = L (Setup II), else open end (Setup I)
  double end_time = 0.5;
  double slope = 50.0;
  double cell = 0.01;
  // N-DAM->Height, with 'Cells z' = height / cell. 0.3 m (the 1.5 s scenes' box), not the
  // shipped 0.15 m: Setup II's deposit reaches 0.145 m at the wall by about 1 s at 10 mm, and a
  // column that reaches the top of the box stops the run (NdamSolver::check)
  double height = 0.3;
  double cfl = 0.5;  // N-DAM CFL
  double gravity = -1.0;  // Material->Gravity [m/s^2]; < 0: the default (9.81)
  std::string ndam_extra;  // further N-DAM parameters or sublists (XML lines)
  bool gate = true;  // the silo gate at x = 0 (h_in = 0.06 m, u_in = 0.37 m/s), else a wall
  std::string left_side = "No-slip";  // N-DAM->Boundaries->Left (the gate's side)
  std::string top_extra;  // further top-level lists (XML lines), e.g. an Initial condition
  // Froude similarity: lengths x froude_scale, times and speeds x sqrt(froude_scale), with nu,
  // m_c, m_y and every dimensional default the scene depends on (time-step bounds, the DAM's dry
  // depth and earth-pressure switch, the domain manager's lengths, times and rest speed, the
  // interface's mass relaxation) written out and scaled with them; the cell counts stay. Powers
  // of four scale every operation exactly in binary floating point. The extra XML lines above
  // are written as given (not scaled).
  double froude_scale = 1.0;

  std::string xml() const {
    const double L = froude_scale, T = std::sqrt(froude_scale), U = T;
    // the defaults that a scaled scene writes out, from the components that own them
    const coupling::Decomposition dd;
    const dam::DamConfig dc;
    const core::RunControl rc;
    // the shortest form that reads back as the same double (std::to_string's 6 decimals would
    // lose a scaled 1e-6): 0.06 stays "0.06"
    const auto num = [](double v) {
      char b[32];
      for (int digits = 6; digits <= 17; ++digits) {
        std::snprintf(b, sizeof b, "%.*g", digits, v);
        if (std::stod(b) == v) break;
      }
      return std::string(b);
    };
    const auto scaled = [&](const char* name, double v) {
      return std::string("\n    <Parameter name=\"") + name + "\" type=\"double\" value=\"" +
             num(v) + "\"/>";
    };
    // a comma-separated list of lengths, each times f (written as given when f = 1)
    const auto scaled_list = [&](const std::string& list, double f) {
      if (f == 1.0) return list;
      std::string out;
      std::size_t a = 0;
      while (a < list.size()) {
        const std::size_t b = std::min(list.find(',', a), list.size());
        out += (out.empty() ? "" : ", ") + num(std::stod(list.substr(a, b - a)) * f);
        a = b + 1;
      }
      return out;
    };
    const int nx = static_cast<int>(std::lround(length / cell));
    const std::string n = std::to_string(nx);
    std::string s = R"x(<ParameterList name="granflow">
  <Parameter name="Name" type="string" value=")x" + name + R"x("/>
  <Parameter name="Model" type="string" value=")x" + model + R"x("/>)x" + top_extra;
    if (model == "Coupled")
      s += R"x(
  <ParameterList name="Decomposition">
    <Parameter name="Models" type="Array(string)" value="{)x" + models + R"x(}"/>
    <Parameter name="Interfaces" type="Array(double)" value="{)x" + scaled_list(interfaces, L) + R"x(}"/>
    <Parameter name="Layout" type="string" value=")x" + layout + R"x("/>)x" +
           (froude_scale != 1.0 ? scaled("Interface mass relaxation", dd.interface_mass_relaxation * T) : std::string()) +
           (froude_scale != 1.0 && layout != "Static"
                ? scaled("Margin", dd.margin * L) + scaled("Minimum length", dd.min_length * L)
                : std::string()) +
           (froude_scale != 1.0 && layout == "Dynamic"
                ? scaled("Hold time", dd.hold_time * T) +
                      scaled("Check interval", dd.check_interval * T) +
                      scaled("Rest speed", dd.rest_speed * U)
                : std::string()) +
           decomposition_extra + R"x(
  </ParameterList>
  <ParameterList name="DAM">
    <Parameter name="Cells" type="int" value=")x" + std::to_string(nx * dam_cells_per_column) + R"x("/>
    <Parameter name="Scheme" type="string" value="Beam-Warming"/>)x" +
           (froude_scale != 1.0 ? scaled("Dry depth", dc.dry_depth * L) +
                                      scaled("Earth pressure smoothing", dc.k_smoothing / T)
                                : std::string()) + R"x(
  </ParameterList>)x";
    s += R"x(
  <ParameterList name="Material">
    <Parameter name="Internal friction angle" type="double" value="33"/>
    <Parameter name="Bed friction angle" type="double" value="22"/>
    <Parameter name="Density" type="double" value="1440"/>)x" +
         (gravity >= 0.0 ? "\n    <Parameter name=\"Gravity\" type=\"double\" value=\"" +
                               std::to_string(gravity) + "\"/>"
                         : std::string()) + R"x(
  </ParameterList>
  <ParameterList name="Channel">
    <Parameter name="Length" type="double" value=")x" + num(length * L) + R"x("/>
    <Parameter name="Slope angle" type="double" value=")x" + std::to_string(slope) + R"x("/>
    <ParameterList name="Left boundary">)x" + (gate ? R"x(
      <Parameter name="Type" type="string" value="Inflow"/>
      <Parameter name="Inflow depth" type="double" value=")x" + num(0.06 * L) + R"x("/>
      <Parameter name="Inflow velocity" type="double" value=")x" + num(0.37 * U) + R"x("/>)x" : R"x(
      <Parameter name="Type" type="string" value="Wall"/>)x") + R"x(
    </ParameterList>
    <ParameterList name="Right boundary">
      <Parameter name="Type" type="string" value=")x" + (wall ? "Wall" : "Outflow") + R"x("/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="N-DAM">
    <Parameter name="Cells x" type="int" value=")x" + n + R"x("/>
    <Parameter name="Cells z" type="int" value=")x" + std::to_string(std::lround(height / cell)) + R"x("/>
    <Parameter name="Height" type="double" value=")x" + num(height * L) + R"x("/>
    <Parameter name="Momentum" type="string" value="Implicit"/>
    <Parameter name="CFL" type="double" value=")x" + std::to_string(cfl) + R"x("/>)x" + ndam_extra + R"x(
    <Parameter name="Free surface" type="bool" value="true"/>
    <Parameter name="Friction regularisation" type="double" value=")x" + num(100 / U) + R"x("/>
    <ParameterList name="Boundaries">
      <Parameter name="Left" type="string" value=")x" + left_side + R"x("/>
      <Parameter name="Right" type="string" value=")x" + (wall ? "Coulomb" : "Free-slip") + R"x("/>
      <Parameter name="Bottom" type="string" value="Coulomb"/>
      <Parameter name="Top" type="string" value="Free-slip"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Rheology">
    <Parameter name="Model" type="string" value="Drucker-Prager"/>
    <Parameter name="Viscosity" type="double" value=")x" + num(0.003 * L * L / T) + R"x("/>
    <Parameter name="Yield stress" type="double" value="0"/>
    <Parameter name="Regularisation" type="double" value=")x" + num(100 * T) + R"x("/>
  </ParameterList>
  <ParameterList name="Time">
    <Parameter name="End time" type="double" value=")x" + num(end_time * T) + R"x("/>)x" +
         (froude_scale != 1.0 ? scaled("Max time step", rc.max_dt * T) : std::string()) + R"x(
  </ParameterList>
  <ParameterList name="Output">
    <Parameter name="Directory" type="string" value="out_)x" + name + R"x("/>
  </ParameterList>
</ParameterList>
)x";
    return s;
  }

  /// The scene file's path: in the test temporary directory (not the working directory, which
  /// is the repository when a test binary is started from there), with the writing process's
  /// id so that two suites running at once (a CI clone beside a build) do not share it.
  std::string scene_file(long pid) const {
    return ::testing::TempDir() + "test_coupled_2d_" + name + "_" + std::to_string(pid) + ".xml";
  }
  /// Writes the scene file and builds its model through the scene interface.
  std::unique_ptr<core::Stepper> build() const {
    const std::string file = scene_file(static_cast<long>(::getpid()));
    std::ofstream(file) << xml();
    auto model = scene::build_model(scene::load(file));
    std::remove(file.c_str());
    return model;
  }
  /// The same under MPI: rank 0 of MPI_COMM_WORLD writes the file, every rank builds the model
  /// with its 2D parts on `comm` (MPI_COMM_SELF: a serial copy on each rank).
  std::unique_ptr<core::Stepper> build(MPI_Comm comm) const {
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    long pid = static_cast<long>(::getpid());  // rank 0's, the name every rank reads
    MPI_Bcast(&pid, 1, MPI_LONG, 0, MPI_COMM_WORLD);
    const std::string file = scene_file(pid);
    if (rank == 0) std::ofstream(file) << xml();
    MPI_Barrier(MPI_COMM_WORLD);
    auto model = scene::build_model(scene::load(file), comm);
    MPI_Barrier(MPI_COMM_WORLD);
    if (rank == 0) std::remove(file.c_str());
    return model;
  }
};

inline void run(core::Stepper& s, double t_end) {
  while (s.time() < t_end - 1e-12) {
    s.step(std::min(s.stable_dt(), t_end - s.time()));
    const auto h = s.check();
    ASSERT_TRUE(h.ok) << h.reason << " at x = " << h.x;
    s.accept();
  }
}

inline const coupling::CoupledModel& coupled(const core::Stepper& s) {
  return dynamic_cast<const coupling::CoupledModel&>(s);
}

/// Relative L2 difference of b against a (reference) over the columns where a.h > h_min.
inline double rel_l2(const std::vector<double>& a, const std::vector<double>& b,
              const std::vector<double>& ha, double h_min) {
  double num = 0, den = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (ha[i] <= h_min) continue;
    num += (b[i] - a[i]) * (b[i] - a[i]);
    den += a[i] * a[i];
  }
  // no material in the reference: no agreement to speak of (NaN fails every comparison;
  // 0 read as perfect agreement: an audit of the suite, session 44)
  return den > 0 ? std::sqrt(num / den) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace granflow::test
