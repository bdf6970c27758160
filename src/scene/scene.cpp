// Scene files: assemble the valid parameter list of the scene's model from the components'
// own declarations, validate the user's file against it, check cross-parameter consistency, and
// build only the components the model uses.
#include "granflow/scene/scene.hpp"

#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/core/simulation.hpp"
#include "granflow/dam/dam_solver.hpp"
#include "granflow/dam/initial_condition.hpp"
#include "granflow/ndam/ndam_solver.hpp"
#include "granflow/ndam/rheology.hpp"
#include "granflow/coupling/build.hpp"
#include "granflow/coupling/domain_manager.hpp"
#include "granflow/coupling/factory.hpp"
#include "granflow/params/parameters.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include <unistd.h>

namespace granflow::scene {

using Teuchos::ParameterList;
using Teuchos::RCP;

const std::vector<std::string>& model_names() {
  static const std::vector<std::string> names{"DAM", "N-DAM", "Coupled"};
  return names;
}

namespace {

bool io_rank0(MPI_Comm comm) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  return rank == 0;
}

// A coupled scene's initial material comes from two lists: 'Initial condition' fills the 1D
// subdomains, 'N-DAM->Initial depth' (on [Initial x0, Initial x1)) the 2D ones. Material that
// one of them puts where the other model runs at t = 0 would be dropped without a word: refused.
// The DAM's dry depth against the gate: a cell shallower than it has u = 0, so a dry depth at
// or near the inflow depth keeps the inflowing layer from ever moving (a hostile-user run: Dry
// depth 1 m against a 6 cm gate piled 0.23 m of material in the first cells while
// profiles.csv, which reports dry cells as empty, showed an empty channel; with 0.01 m the
// profile hid 1.4 % of the mass). A tenth of the deepest opening keeps the gate's layer wet.
// The same holds for the initial layer (an independent run, session 37: Dry depth 0.01 m on a
// 5 mm block on 40 deg, steeper than delta, ran with exit 0 and u = 0 throughout while the
// scheme's diffusion spread the layer over twice its length, and profiles.csv showed an empty
// channel): a tenth of the initial condition's deepest layer.
void check_dry_depth(const Teuchos::ParameterList& p, const dam::DamConfig& cfg,
                     const core::Channel& channel) {
  // a tenth of `depth`, the layer named by `layer` (and `where`), `what` in the allowed range
  auto below_tenth = [&](double depth, const std::string& layer, const std::string& where,
                         const char* what) {
    // (with a relative margin: 0.1 x 0.1 rounds up to 0.010000000000000002, and a dry depth of
    // exactly a tenth, 0.01 m on a 0.1 m layer, passed (an independent run); 10 dry < depth
    // still let 0.0012 on 0.012 m through (a review))
    if (depth > 0.0 && !(cfg.dry_depth < 0.1 * depth * (1.0 - 1e-12)))
      params::fail(p.sublist("DAM"), "Dry depth", params::str(cfg.dry_depth),
                   "cells shallower than it do not move, and " + layer + " is only " +
                       params::str(depth) + " m deep" + where + "; allowed: < " +
                       params::str(0.1 * depth) + " m (a tenth of the " + what + " depth)");
  };
  if (channel.left.type == core::BoundaryType::Inflow)
    below_tenth(channel.left.inflow.max_depth(), "the gate's opening", " (Channel->Left boundary)",
                "inflow");
  if (!p.isSublist("Initial condition")) return;
  const auto& ic = p.sublist("Initial condition");
  const std::string type = ic.get<std::string>("Type");
  double h0 = 0.0;  // the initial condition's deepest layer
  if (type == "Uniform" || type == "Block") h0 = ic.get<double>("Depth");
  if (type == "Sine wave") h0 = ic.get<double>("Depth") * (1.0 + ic.get<double>("Amplitude"));
  if (type == "Dam break") h0 = std::max(ic.get<double>("Left depth"), ic.get<double>("Right depth"));
  below_tenth(h0, "the initial layer ('Initial condition', Type " + type + ")", "", "initial");
}

// A sine wave of the initial condition must be resolved by the DAM's cells: with N cells a
// wavenumber above N / 2 is sampled as another, longer wave (at a multiple of N every cell
// centre sits on a zero and the layer starts uniform; an independent run), without a word.
void check_sine_resolution(const Teuchos::ParameterList& p, const dam::DamConfig& cfg) {
  const auto& ic = p.sublist("Initial condition");
  if (ic.get<std::string>("Type") != "Sine wave") return;
  const int k = ic.get<int>("Wavenumber");
  if (2 * static_cast<long long>(k) > cfg.cells)
    params::fail(ic, "Wavenumber", std::to_string(k),
                 "the DAM's " + std::to_string(cfg.cells) +
                     " cells (DAM->Cells) sample at most Cells / 2 wavelengths on the channel; a "
                     "larger wavenumber is aliased to another wave; allowed: <= " +
                     std::to_string(cfg.cells / 2) + ", or more cells");
}

void check_initial_material(const Teuchos::ParameterList& p, const Teuchos::ParameterList* uic,
                            const core::Channel& channel, const coupling::Decomposition& layout) {
  const auto d = layout.normalised(channel.length);
  if (d.models.size() != d.interfaces.size() + 1) return;
  const double L = channel.length;
  const auto ic = dam::InitialCondition::from_parameters(p.sublist("Initial condition"), uic,
                                                         channel);
  using T = dam::InitialCondition::Type;
  std::vector<std::array<double, 2>> wet;  // intervals of the 1D initial condition's material
  switch (ic.type) {
    case T::Dry: break;
    case T::Uniform:
    case T::SineWave:
      if (ic.depth > 0.0) wet.push_back({0.0, L});
      break;
    case T::DamBreak:
      if (ic.left_depth > 0.0) wet.push_back({0.0, ic.position});
      if (ic.right_depth > 0.0) wet.push_back({ic.position, L});
      break;
    case T::Block:
      if (ic.depth > 0.0) wet.push_back({ic.start, ic.end});
      break;
  }
  const auto& nd = p.sublist("N-DAM");
  const double h2 = nd.get<double>("Initial depth");
  const double a2 = std::max(0.0, nd.get<double>("Initial x0"));
  const double b2 = std::min(L, nd.get<double>("Initial x1"));
  for (std::size_t i = 0; i < d.models.size(); ++i) {
    const auto [x0, x1] = d.extent(i, L);
    const std::string part = d.models[i] + " subdomain [" + params::str(x0) + ", " +
                             params::str(x1) + "] m";
    if (d.models[i] == "2D") {
      for (const auto& w : wet)
        if (std::min(w[1], x1) > std::max(w[0], x0))
          params::fail(p.sublist("Initial condition"), "Type", dam::to_string(ic.type),
                       "puts material on [" + params::str(std::max(w[0], x0)) + ", " +
                           params::str(std::min(w[1], x1)) + "] m, inside the " + part +
                           " at t = 0, whose material comes from 'N-DAM->Initial depth' (on "
                           "'Initial x0'..'Initial x1'); allowed: 'Initial condition' material in "
                           "1D subdomains only");
    } else if (h2 > 0.0 && std::min(b2, x1) > std::max(a2, x0)) {
      params::fail(nd, "Initial depth", params::str(h2),
                   "puts a layer on [" + params::str(std::max(a2, x0)) + ", " +
                       params::str(std::min(b2, x1)) + "] m, inside the " + part +
                       " at t = 0, whose material comes from 'Initial condition'; allowed: an "
                       "N-DAM initial layer in 2D subdomains only (set 'Initial x0' and "
                       "'Initial x1')");
    }
  }
}

// The 2D subdomains of a layout (static, or the start of an a priori or dynamic one): two 2D
// neighbours would be one 2D model cut by an interface that neither model's conditions describe,
// and a 2D subdomain narrower than kMinimumColumns columns of the 2D grid would be built on
// squeezed columns (the factory keeps at least that many; 1 mm on 10 mm columns gave cells of
// 0.25 x 10 mm and a run that diverged at its first steps). Both are refused at input, and so is
// a 1D subdomain narrower than as many cells of the DAM's grid (L / DAM->Cells): the factory
// squeezes those cells alike, and a 1D part of 0.1 mm between two 2D parts (four DAM cells of
// 25 um) ran with a mass defect of 1.5e-4 of the run's mass (a hostile-user run; 1e-17 with
// parts of a few cells).
constexpr int kMinimumColumns = coupling::SubdomainFactory::kMinimumCells;
void check_two_d_parts(const Teuchos::ParameterList& dec, const core::Channel& channel,
                       const coupling::Decomposition& layout, double dx2, double dx1) {
  // the a priori layout computes its interfaces: only a user's list is checked
  const bool users = layout.layout == "Static" ||
                     (layout.layout == "Dynamic" && layout.initial_layout == "Static");
  if (!users) return;
  const auto d = layout.normalised(channel.length);
  if (d.models.size() != d.interfaces.size() + 1) return;
  // a subdomain narrower than kMinimumColumns cells of its model's grid
  auto check_width = [&](bool two_d, double x0, double x1) {
    const double w = two_d ? dx2 : dx1;
    if (x1 - x0 >= (kMinimumColumns - 1e-9) * w) return;
    const std::string kind = two_d ? "2D" : "1D";
    params::fail(dec, "Interfaces", params::str(layout.interfaces),
                 "give the " + kind + " subdomain [" + params::str(x0) + ", " + params::str(x1) +
                     "] m, narrower than " + std::to_string(kMinimumColumns) +
                     (two_d ? " columns of the 2D grid (L / N-DAM->Cells x = "
                            : " cells of the DAM's grid (L / DAM->Cells = ") +
                     params::str(w) + " m); allowed: " + kind + " subdomains of at least " +
                     params::str(kMinimumColumns * w) + " m");
  };
  for (std::size_t i = 0; i < d.models.size(); ++i) {
    const bool two_d = d.models[i] == "2D";
    const auto [x0, x1] = d.extent(i, channel.length);
    if (two_d && i + 1 < d.models.size() && d.models[i + 1] == "2D")
      params::fail(dec, "Models", Teuchos::toString(dec.get<Teuchos::Array<std::string>>("Models")),
                   "two neighbouring subdomains are 2D (at x = " + params::str(x1) +
                       " m): one 2D model runs both; allowed: 1D subdomains between 2D ones "
                       "(or one 2D entry for the whole stretch)");
    check_width(two_d, x0, x1);
  }
}

// Output times a run may have (End time / Interval); see check_output.
constexpr double kMaxOutputTimes = 100000;

void add_scene_header(ParameterList& pl, const std::string& model) {
  params::add_string(pl, "Name", "unnamed", "scene name, echoed in summary.json");
  params::add_string(pl, "Description", "", "free text: what the scene reproduces");
  params::add_enum(pl, "Model", model,
                   "which model runs the scene: DAM (1D depth-averaged, paper section 3), "
                   "N-DAM (full 2D, paper section 2), Coupled (subdomains along the channel, "
                   "paper section 4: 1D subdomains with the DAM, 2D ones with the 2D free-surface chute; "
                   "the Decomposition list sets their layout, static, a priori or dynamic)",
                   model_names());
}
void add(ParameterList& pl, const RCP<const ParameterList>& sub, const std::string& doc) {
  pl.set(sub->name(), *sub, doc);
}

// The run directory must be one that the run can create or write into, and the output
// schedule one that the run can write: both would otherwise fail (exit 4) only once the run
// has started, after --check passed.
void check_output(const core::RunControl& rc, const ParameterList& out) {
  namespace fs = std::filesystem;
  const std::string& dir = rc.directory;
  if (dir.find_first_not_of(" \t\r\n") == std::string::npos)
    params::fail(out, "Directory", params::shown(dir),
                 "empty; allowed: the path of a directory (created if missing)");
  // The run writes a fixed set of files (run.json, summary.json, profiles.csv, fields.h5, ...)
  // into its directory and replaces them on the next run: the filesystem root would take them
  // (accepted before; as root a run wrote its six files into / ; an independent run).
  {
    std::error_code ec0;
    const fs::path abs = fs::absolute(fs::path(dir), ec0).lexically_normal();
    if (!ec0 && abs == abs.root_path())
      params::fail(out, "Directory", params::shown(dir),
                   "is the filesystem root, where the run would write and later replace its "
                   "files; allowed: a directory of its own (e.g. output/<scene>, created if "
                   "missing)");
  }
  // The deepest part of the path that exists must be a directory: the rest is created.
  std::error_code ec;
  fs::path existing = fs::path(dir);
  while (!existing.empty() && !fs::exists(existing, ec)) existing = existing.parent_path();
  if (existing.empty()) existing = ".";
  if (!fs::is_directory(existing, ec))
    params::fail(out, "Directory", params::shown(dir),
                 existing == fs::path(dir)
                     ? "exists and is not a directory; allowed: a directory, or a path to create"
                     : "'" + existing.string() + "' is a file, so the directory cannot be "
                                                 "created there; allowed: a path whose existing "
                                                 "part is a directory");
  if (access(existing.c_str(), W_OK | X_OK) != 0)
    params::fail(out, "Directory", params::shown(dir),
                 "'" + existing.string() + "' is not writable; allowed: a writable directory");
  // Every output time writes a profiles block, a fields snapshot and the checkpoint, and the
  // time step is shortened to hit it: more output times than this is a mistake in Interval
  // (1e-9 s to 0.1 s would be 1e8 snapshots and 1e8 steps), not a run.
  const double count = rc.end_time / rc.output_interval;
  if (count > kMaxOutputTimes) {
    std::ostringstream why;
    why << "End time " << params::str(rc.end_time) << " s / Interval gives "
        << params::str(std::floor(count)) << " output times (each writes profiles, fields and a "
        << "checkpoint and ends a time step); allowed: at most " << params::str(kMaxOutputTimes)
        << " output times, i.e. Interval >= " << params::str(rc.end_time / kMaxOutputTimes)
        << " s for this End time";
    params::fail(out, "Interval", params::str(rc.output_interval), why.str());
  }
}
}  // namespace

RCP<const ParameterList> valid_parameters(const std::string& model) {
  auto pl = Teuchos::rcp(new ParameterList("granflow"));
  add_scene_header(*pl, model);
  add(*pl, core::Material::getValidParameters(), "granular material");
  add(*pl, core::Channel::getValidParameters(), "inclined channel and its two ends");
  add(*pl, core::RunControl::getValidTimeParameters(), "end time and time-step bounds");
  add(*pl, core::RunControl::getValidOutputParameters(), "run directory and output schedule");
  if (model == "DAM") {
    add(*pl, dam::DamConfig::getValidParameters(), "depth-averaged model numerics");
    add(*pl, dam::InitialCondition::getValidParameters(), "initial state of the channel");
  }
  if (model == "Coupled") {
    add(*pl, coupling::Decomposition::getValidParameters(),
        "subdomains along the channel and their models");
    add(*pl, dam::DamConfig::getValidParameters(),
        "numerics of the 1D subdomains ('Cells' is for the whole channel: dx = L / Cells)");
    add(*pl, dam::InitialCondition::getValidParameters(), "initial state of the channel");
    add(*pl, ndam::NdamConfig::getValidParameters(),
        "numerics of the 2D subdomains ('Free surface' true; cells for the whole channel)");
    add(*pl, ndam::Rheology::getValidParameters(), "viscoplastic rheology of the 2D subdomains");
  }
  if (model == "N-DAM") {
    add(*pl, ndam::NdamConfig::getValidParameters(), "full 2D model numerics and boundaries");
    add(*pl, ndam::Rheology::getValidParameters(), "viscoplastic rheology of the 2D model");
  }
  return pl;
}

Scene load(const std::string& file) {
  Scene s;
  s.file = file;
  s.dir = std::filesystem::path(file).parent_path().string();
  // Values are converted strictly from the XML text (params::to_parameter_list) against the
  // model's valid list, so that every type, text and range is checked before Teuchos fills in
  // the defaults. The model decides which sublists exist, so its element is read first (a
  // duplicate or a wrong type of it is reported by the full read below).
  const auto doc = params::parse_xml(file);
  std::string model = "DAM";
  for (int c = 0; c < doc.root.numChildren(); ++c) {
    const auto& x = doc.root.getChild(c);
    if (x.getTag() != "Parameter" || !x.hasAttribute("name") || x.getAttribute("name") != "Model" ||
        !x.hasAttribute("value"))
      continue;
    model = x.getAttribute("value");
    const auto& names = model_names();
    if (std::find(names.begin(), names.end(), model) == names.end()) {
      std::string allowed;
      for (const auto& n : names) allowed += (allowed.empty() ? "" : ", ") + n;
      throw params::InputError(file + ": parameter 'granflow->Model' = " + params::shown(model) +
                               ": unknown model; allowed: " + allowed);
    }
    break;
  }
  auto user = params::to_parameter_list(doc, valid_parameters(model).get());
  s.user = Teuchos::rcp(new ParameterList(*user));
  params::validate_and_set_defaults(*user, *valid_parameters(model), file);
  s.params = user;
  s.model = model;
  s.name = user->get<std::string>("Name");
  // Cross-parameter checks happen when the components are read; do it once now so that an
  // inconsistent scene stops before anything runs.
  try {
    const auto m = core::Material::from_parameters(user->sublist("Material"));
    const auto c = core::Channel::from_parameters(
        user->sublist("Channel"),
        s.user->isSublist("Channel") ? s.user->sublist("Channel") : ParameterList("Channel"),
        s.dir);
    (void)m;
    (void)c;
    // the tanh switch's width belongs to the Savage-Hutter K (an independent run: accepted with
    // 'Earth pressure' = Active, results unchanged)
    if (s.user->isSublist("DAM") &&
        user->sublist("DAM").get<std::string>("Earth pressure") != "Savage-Hutter")
      params::fail_if_given(user->sublist("DAM"), &s.user->sublist("DAM"),
                            "Earth pressure smoothing",
                            "the width of the switch between K_act and K_pas, and 'Earth "
                            "pressure' = " + user->sublist("DAM").get<std::string>("Earth pressure") +
                                " (K fixed); allowed: leave it out, or 'Earth pressure' = "
                                "Savage-Hutter");
    const auto rc =
        core::RunControl::from_parameters(user->sublist("Time"), user->sublist("Output"), s.dir);
    check_output(rc, user->sublist("Output"));
  } catch (const params::InputError& e) {
    throw params::InputError(file + ": " + e.what());
  }
  return s;
}

std::unique_ptr<core::Stepper> build_model(const Scene& s, MPI_Comm comm) {
  const auto& p = *s.params;
  try {
    const auto material = core::Material::from_parameters(p.sublist("Material"));
    const auto channel = core::Channel::from_parameters(
        p.sublist("Channel"),
        s.user->isSublist("Channel") ? s.user->sublist("Channel") : ParameterList("Channel"),
        s.dir);
    const ParameterList* uic =
        s.user->isSublist("Initial condition") ? &s.user->sublist("Initial condition") : nullptr;
    if (s.model == "Coupled") {
      const auto cfg = dam::DamConfig::from_parameters(p.sublist("DAM"));
      check_dry_depth(p, cfg, channel);
      check_sine_resolution(p, cfg);
      auto d = coupling::Decomposition::from_parameters(
          p.sublist("Decomposition"), channel,
          s.user->isSublist("Decomposition") ? &s.user->sublist("Decomposition") : nullptr);
      // The factory keeps this for the whole run (a restart of a dynamic layout rebuilds parts
      // with it), so it owns copies of what it reads, not references into this function.
      const auto init = [ic = p.sublist("Initial condition"),
                         user_ic = uic ? std::make_shared<const ParameterList>(*uic) : nullptr,
                         channel](dam::DamSolver& dam) {
        dam::InitialCondition::apply(ic, user_ic.get(), channel, dam);
      };
      const bool dynamic = d.layout == "Dynamic";
      if (d.layout == "A priori" || (dynamic && d.initial_layout == "A priori"))
        d = coupling::a_priori_layout(d, material, channel, cfg, init,
                                      p.sublist("Time").get<double>("End time"),
                                      p.sublist("Output").get<double>("Interval"));
      check_initial_material(p, uic, channel, d);
      const bool any_2d = std::find(d.models.begin(), d.models.end(), "2D") != d.models.end();
      // a dynamic layout may create 2D subdomains later: it always configures the 2D model
      if (!any_2d && !dynamic) {
        // A Static layout of 1D subdomains only builds no 2D model: the 2D lists of the scene
        // would be accepted without effect (a reviewer, 2026-12-05). (An a priori layout that
        // comes out all 1D is the DAM run's result, not the user's choice: not refused.)
        if (d.layout == "Static")
          for (const char* list : {"N-DAM", "Rheology"})
            if (s.user->isSublist(list) && s.user->sublist(list).numParams() > 0) {
              const auto& ul = s.user->sublist(list);
              params::fail_if_given(
                  p.sublist(list), &ul, ul.name(ul.begin()),
                  "a setting of the 2D subdomains, and the Static layout " +
                      Teuchos::toString(
                          p.sublist("Decomposition").get<Teuchos::Array<std::string>>("Models")) +
                      " has none; allowed: leave the " + list +
                      " list out, or a layout with a 2D subdomain");
            }
        return coupling::build(d, material, channel, cfg, init);
      }
      int ranks = 1;
      MPI_Comm_size(comm, &ranks);
      auto user_sub = [&](const char* n) {
        return s.user->isSublist(n) ? &s.user->sublist(n) : nullptr;
      };
      coupling::TwoD two_d;
      two_d.comm = comm;
      // before the 2D configuration, whose channel checks would otherwise speak of a closed
      // box (a reviewer: "allowed: Wall" for a coupled scene with 'Free surface' false)
      if (!p.sublist("N-DAM").get<bool>("Free surface"))
        params::fail(p.sublist("N-DAM"), "Free surface", "false",
                     "2D subdomains of a coupled channel need the free-surface chute; allowed: "
                     "true");
      two_d.cfg = ndam::NdamConfig::from_parameters(p.sublist("N-DAM"), user_sub("N-DAM"),
                                                    channel, ranks);
      // the 2D parts of a coupled channel keep the equal split of their columns over the ranks
      // (docs/numerics.md, "MPI"; an independent run: accepted and without effect)
      params::fail_if_given(p.sublist("N-DAM"), user_sub("N-DAM"), "Load balance",
                            "a setting of a full 2D box's x-slabs, and the 2D subdomains of a "
                            "coupled channel keep the equal split of their columns over the "
                            "ranks; allowed: leave it out");
      two_d.rheology =
          ndam::Rheology::from_parameters(p.sublist("Rheology"), user_sub("Rheology"), material);
      two_d.physics = ndam::NdamPhysics::from(material, channel);
      if (dynamic) {
        // The manager moves interfaces by whole slots, between nodes common to both grids (the
        // slot is the coarser of a 2D column and a 1D cell, DomainManager). An initial interface
        // elsewhere (0.2 m on 769 columns per metre) starts on the nearest node, said on stderr
        // when the user gave it: kept off it, the first check would move it, or within round-off
        // of a node keep it there and a later conversion would miss the sliver. The a priori
        // layout's interfaces lie on the DAM's cells, which need not be nodes either (0.09 m on
        // slots of 0.02 m): off a node, its first move made 2-5 % of the run's mass (a
        // hostile-user run, 2026-12-05).
        const double w =
            coupling::DomainManager::slot_width(channel.length / cfg.cells, two_d.cfg.grid.dx());
        for (double& x : d.interfaces) {
          const double on = std::round(x / w) * w;
          if (std::abs(x - on) > 1e-12 * std::max(1.0, channel.length)) {
            if (io_rank0(comm) && d.initial_layout == "Static")
              std::cerr << "granflow: note: parameter 'granflow->Decomposition->Interfaces' = "
                        << params::str(x) << " lies between the nodes common to the 2D columns "
                        << "and the 1D cells (multiples of " << params::str(w)
                        << " m); the Dynamic layout starts from the nearest, " << params::str(on)
                        << " m\n";
            x = on;
          }
        }
        // A margin as long as the channel asks for 2D everywhere from the first check on
        // (a test does it on purpose: the dynamic run then equals full 2D); a user who meant
        // a coupled run is told (an independent run: Margin 2 m on a 1.5 m chute, accepted
        // without a word, all 2D from 0.05 s)
        if (d.margin >= channel.length && io_rank0(comm))
          std::cerr << "granflow: note: parameter 'granflow->Decomposition->Margin' = "
                    << params::str(d.margin) << " m is not shorter than the channel ("
                    << params::str(channel.length) << " m): the first slot that asks for 2D "
                    << "makes the whole channel 2D, and the coupling is off from then on\n";
      }
      check_two_d_parts(p.sublist("Decomposition"), channel, d, two_d.cfg.grid.dx(),
                        channel.length / cfg.cells);
      auto coupled = coupling::build(d, material, channel, cfg, init, &two_d);
      if (dynamic)
        coupled->set_domain_manager(
            std::make_unique<coupling::DomainManager>(d, coupled->factory()));
      return coupled;
    }
    if (s.model == "DAM") {
      const auto cfg = dam::DamConfig::from_parameters(p.sublist("DAM"));
      check_dry_depth(p, cfg, channel);
      check_sine_resolution(p, cfg);
      const auto phys = dam::DamPhysics::from(material, channel, cfg);
      auto dam = std::make_unique<dam::DamSolver>(0.0, channel.length, cfg, phys,
                                                  dam::DamBoundary::from(channel.left),
                                                  dam::DamBoundary::from(channel.right));
      dam::InitialCondition::apply(p.sublist("Initial condition"), uic, channel, *dam);
      return dam;
    }
    if (s.model == "N-DAM") {
      // The 2D model runs on the communicator of the run (the app's GlobalMPISession).
      int ranks = 1;
      MPI_Comm_size(comm, &ranks);
      auto user_sub = [&](const char* n) {
        return s.user->isSublist(n) ? &s.user->sublist(n) : nullptr;
      };
      const auto cfg =
          ndam::NdamConfig::from_parameters(p.sublist("N-DAM"), user_sub("N-DAM"), channel, ranks);
      const auto rheo =
          ndam::Rheology::from_parameters(p.sublist("Rheology"), user_sub("Rheology"), material);
      return std::make_unique<ndam::NdamSolver>(comm, cfg, rheo,
                                                ndam::NdamPhysics::from(material, channel));
    }
  } catch (const params::InputError& e) {
    throw params::InputError(s.file + ": " + e.what());
  }
  throw params::InputError(s.file + ": model '" + s.model + "' is not available");
}

double energy_speed_bound(const Scene& s) {
  const auto& p = *s.params;
  if (s.model != "N-DAM" && s.model != "Coupled") return 0.0;
  const auto& nd = p.sublist("N-DAM");
  if (!nd.get<bool>("Free surface") && s.model == "N-DAM") return 0.0;
  const auto& ch = p.sublist("Channel");
  const auto& walls = nd.sublist("Boundaries");
  auto periodic = [](const std::string& t) { return t == "Periodic"; };
  if (periodic(ch.sublist("Left boundary").get<std::string>("Type")) ||
      periodic(ch.sublist("Right boundary").get<std::string>("Type")) ||
      periodic(walls.get<std::string>("Left")))
    return 0.0;
  const auto channel = core::Channel::from_parameters(
      ch, s.user->isSublist("Channel") ? s.user->sublist("Channel") : ParameterList("Channel"),
      s.dir);
  double u0 = channel.left.type == core::BoundaryType::Inflow ? channel.left.inflow.max_speed()
                                                              : 0.0;
  for (const char* lid : {"Left lid velocity", "Right lid velocity", "Bottom lid velocity",
                          "Top lid velocity"})
    u0 = std::max(u0, std::abs(walls.get<double>(lid)));
  // the height material can fall from: the 2D box, or a deeper initial DAM layer (a dam break's
  // front runs at 2 sqrt(g h0), sqrt(2) times the free fall from h0)
  double height = nd.get<double>("Height");
  if (p.isSublist("Initial condition")) {
    const auto& ic = p.sublist("Initial condition");
    if (ic.get<std::string>("Type") != "Dry") {
      u0 = std::max(u0, std::abs(ic.get<double>("Velocity")));
      for (const char* d : {"Depth", "Left depth", "Right depth"})
        height = std::max(height, ic.get<double>(d) * (1.0 + ic.get<double>("Amplitude")));
    }
  }
  const double g = p.sublist("Material").get<double>("Gravity");
  const double z = channel.slope_deg * M_PI / 180.0;
  const double drop = channel.length * std::abs(std::sin(z)) + height * std::cos(z);
  return u0 + std::sqrt(2.0 * g * std::max(drop, 0.0));
}

std::string parameter_reference() {
  std::ostringstream os;
  os << "# granflow scene parameters\n\n"
     << "Generated by `granflow --parameters` from the components' valid parameter lists "
        "(`getValidParameters()`); do not edit by hand. A test checks that this file matches "
        "the code.\n\n"
     << "A scene is a Teuchos ParameterList XML file whose top list (`<ParameterList "
        "name=\"granflow\">`, or without a name) holds the parameters below. "
        "Which sublists are valid depends on `Model`. Each parameter must be given with the type "
        "listed here, at most once per list; values are read strictly (a double is one decimal "
        "number, an int a whole number that fits an int, a bool `true` or `false`, an array "
        "`{a, b}` with comma-separated entries, text UTF-8), and anything else stops the run "
        "with exit code 2.\n";
  for (const auto& m : model_names()) {
    os << "\n## Model `" << m << "`\n\n";
    os << params::reference_markdown(*valid_parameters(m), 3);
  }
  return os.str();
}

}  // namespace granflow::scene
