#include "granflow/core/simulation.hpp"

#include "granflow/io/output.hpp"
#include "granflow/params/parameters.hpp"

#include <nlohmann/json.hpp>

#include <mpi.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

namespace granflow::core {

using Clock = std::chrono::steady_clock;

Teuchos::RCP<const Teuchos::ParameterList> RunControl::getValidTimeParameters() {
  static Teuchos::RCP<const Teuchos::ParameterList> valid = [] {
    using namespace params;
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("Time"));
    const RunControl d;
    add_double(*pl, "End time", d.end_time, "[s] simulated time at which the run ends", 0.0, 1e9);
    add_double(*pl, "Max time step", d.max_dt,
               "[s] upper bound on dt (the models' stability limits apply below it)", 1e-12, 1e6);
    add_double(*pl, "Min time step", d.min_dt,
               "[s] a stable dt below this stops the run as diverged (with a diagnosis)", 0.0,
               1.0);
    add_int(*pl, "Max steps", static_cast<int>(d.max_steps),
            "stop (exit code 5) after this many steps", 1, 2000000000);
    return pl;
  }();
  return valid;
}

Teuchos::RCP<const Teuchos::ParameterList> RunControl::getValidOutputParameters() {
  static Teuchos::RCP<const Teuchos::ParameterList> valid = [] {
    using namespace params;
    auto pl = Teuchos::rcp(new Teuchos::ParameterList("Output"));
    const RunControl d;
    add_string(*pl, "Directory", d.directory,
               "run directory for profiles.csv, fields.h5/.xdmf, checkpoint.h5, summary.json; "
               "relative to the current working directory; created if missing");
    add_double(*pl, "Interval", d.output_interval,
               "[s] simulated time between outputs (profiles, fields, checkpoint); the time step "
               "is shortened to hit each output time exactly",
               1e-9, 1e9);
    add_bool(*pl, "Fields", d.fields, "write HDF5 field snapshots with an XDMF index");
    add_bool(*pl, "Checkpoint", d.checkpoint, "write checkpoint.h5 at every output time");
    add_bool(*pl, "Progress", d.progress, "show a live progress line on stderr");
    add_string(*pl, "Restart from", d.restart_from,
               "checkpoint.h5 of an earlier run of the same scene to resume from (empty: start "
               "from the initial condition); relative to the current working directory, like "
               "'Directory'");
    return pl;
  }();
  return valid;
}

RunControl RunControl::from_parameters(const Teuchos::ParameterList& time,
                                       const Teuchos::ParameterList& out,
                                       const std::string& /*scene_dir*/) {
  RunControl r;
  r.end_time = time.get<double>("End time");
  r.max_dt = time.get<double>("Max time step");
  r.min_dt = time.get<double>("Min time step");
  r.max_steps = time.get<int>("Max steps");
  r.directory = out.get<std::string>("Directory");
  r.output_interval = out.get<double>("Interval");
  r.fields = out.get<bool>("Fields");
  r.checkpoint = out.get<bool>("Checkpoint");
  r.progress = out.get<bool>("Progress");
  r.restart_from = out.get<std::string>("Restart from");
  if (!r.restart_from.empty() && !std::filesystem::exists(r.restart_from))
    params::fail(out, "Restart from", r.restart_from,
                 "no such file; allowed: the checkpoint.h5 of an earlier run, or empty");
  if (r.min_dt >= r.max_dt)
    params::fail(time, "Min time step", params::str(r.min_dt),
                 "must be smaller than 'Max time step' = " + params::str(r.max_dt));
  return r;
}

struct Simulation::Io {
  io::ProfileWriter profiles;
  io::Hdf5FieldOutput fields;
};

Simulation::Simulation(std::string scene_name, const Teuchos::ParameterList& validated,
                       std::unique_ptr<Stepper> model, RunControl rc)
    : scene_name_(std::move(scene_name)), params_(validated), model_(std::move(model)),
      rc_(std::move(rc)), io_(std::make_shared<Io>()) {}

namespace {
nlohmann::json to_json(const Teuchos::ParameterList& pl) {
  nlohmann::json j = nlohmann::json::object();
  for (auto it = pl.begin(); it != pl.end(); ++it) {
    const auto& name = pl.name(it);
    const auto& e = pl.entry(it);
    if (e.isList()) {
      j[name] = to_json(pl.sublist(name));
    } else if (e.isType<double>()) {
      j[name] = e.getValue<double>(nullptr);
    } else if (e.isType<int>()) {
      j[name] = e.getValue<int>(nullptr);
    } else if (e.isType<bool>()) {
      j[name] = e.getValue<bool>(nullptr);
    } else {
      j[name] = Teuchos::toString(e.getAny(false));
    }
  }
  return j;
}

std::string fmt_seconds(double s) {
  std::ostringstream os;
  os.setf(std::ios::fixed);
  if (s < 60) os.precision(1), os << s << " s";
  else if (s < 3600) os.precision(1), os << s / 60 << " min";
  else os.precision(2), os << s / 3600 << " h";
  return os.str();
}

// Under mpiexec every rank runs this driver (the models' output calls gather over the ranks and
// are collective), but only rank 0 touches the run directory's files and the progress line.
bool io_rank() {
  int init = 0;
  MPI_Initialized(&init);
  if (!init) return true;
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  return rank == 0;
}
}  // namespace

void Simulation::write_output() {
  const auto t1 = Clock::now();
  const double t = model_->time();
  const auto profile = model_->profile();
  if (io_rank()) io_->profiles.write(t, profile);
  if (rc_.fields) {
    io::FieldWriter w;
    model_->write_fields(w);
    if (io_rank()) io_->fields.write(t, w);
  }
  if (rc_.checkpoint) {
    io::Checkpoint c;
    c.set("run/time", t);
    model_->save(c);
    if (io_rank()) io::write_checkpoint(rc_.directory + "/checkpoint.h5", c);
    model_->restart_point();
  }
  ++outputs_;
  last_output_t_ = t;
  phase_seconds_["output"] += std::chrono::duration<double>(Clock::now() - t1).count();
}

void Simulation::write_summary(const std::string& status, const std::string& reason,
                               int code) const {
  nlohmann::json s;
  s["scene"] = scene_name_;
  s["model"] = model_->model_name();
  s["parameters"] = to_json(params_);
  s["status"] = status;
  s["reason"] = reason;
  s["exit_code"] = code;
  s["start_time"] = t0_;
  s["final_time"] = model_->time();
  s["steps"] = model_->steps();
  const double wall = std::chrono::duration<double>(Clock::now() - wall0_).count();
  s["wall_time"] = {{"total", wall}};
  for (const auto& [k, v] : phase_seconds_) s["wall_time"][k] = v;
  const auto m = model_->mass_balance();
  s["mass_balance"] = {{"unit", "m^2 (per unit channel width)"},
                       {"initial", m.initial},
                       {"final", m.current},
                       {"net_in_through_left_end", m.inflow},
                       {"net_out_through_right_end", m.outflow},
                       {"defect", m.defect()},
                       {"relative_defect",
                        m.defect() / std::max({std::abs(m.initial), std::abs(m.current),
                                               std::abs(m.inflow), 1e-300})}};
  nlohmann::json stats = nlohmann::json::object();
  model_->report(stats);
  s["solver_statistics"] = stats;
  // Layout of the models along the channel (static interfaces: the same at every time). A
  // coupled model reports its subdomains; a single model covers the channel.
  nlohmann::json subdomains = nlohmann::json::array();
  if (stats.contains("coupled")) {
    for (const auto& p : stats["coupled"]["subdomains"])
      subdomains.push_back({{"model", p["model"]}, {"x0", p["x0"]}, {"x1", p["x1"]}});
  } else {
    const auto p = model_->profile();
    if (p.x.size() > 1) {  // cell centres -> channel ends
      const double half = 0.5 * (p.x[1] - p.x[0]);
      subdomains.push_back(
          {{"model", p.model.front()}, {"x0", p.x.front() - half}, {"x1", p.x.back() + half}});
    }
  }
  nlohmann::json layout = nlohmann::json::array();
  layout.push_back({{"t", t0_}, {"subdomains", subdomains}});
  s["interfaces"] = {{"positions_over_time", layout}, {"moves", 0}};
  s["outputs"] = {{"snapshots", outputs_}, {"directory", rc_.directory}};
  if (!io_rank()) return;
  // Serialise before the file is opened, and replace bytes that are not UTF-8 instead of
  // throwing: a string that slipped through must not leave a 0-byte summary.json at the end of
  // a run whose results are on disk.
  const std::string text = s.dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
  std::ofstream f(rc_.directory + "/summary.json");
  f << text << "\n";
}

void Simulation::show_progress(bool final) {
  if (!rc_.progress || !io_rank()) return;
  const auto now = Clock::now();
  const bool tty = isatty(fileno(stderr));
  const double since = std::chrono::duration<double>(now - last_progress_).count();
  if (!final && since < (tty ? 0.25 : 5.0)) return;
  last_progress_ = now;
  const double wall = std::chrono::duration<double>(now - wall0_).count();
  const double t = model_->time();
  const double done = (t - t0_) / std::max(rc_.end_time - t0_, 1e-300);
  const double left = done > 0 ? wall * (1.0 - done) / done : 0.0;
  char buf[256];
  std::snprintf(buf, sizeof buf, "t = %.4f / %.4f s | dt = %.3e s | step %ld | wall %s | left ~%s",
                t, rc_.end_time, last_dt_, model_->steps(), fmt_seconds(wall).c_str(),
                fmt_seconds(left).c_str());
  std::cerr << (tty ? "\r" : "") << buf << (tty ? "   " : "\n");
  if (final && tty) std::cerr << "\n";
  std::cerr.flush();
}

int Simulation::run() {
  wall0_ = last_progress_ = Clock::now();
  std::filesystem::create_directories(rc_.directory);
  const bool restart = !rc_.restart_from.empty();
  if (restart) {
    const auto c = io::read_checkpoint(rc_.restart_from);
    model_->load(c);
  }
  t0_ = model_->time();
  if (io_rank()) {
    io_->profiles.open(rc_.directory, restart);
    if (rc_.fields) io_->fields.open(rc_.directory, restart);
  }
  if (!restart) {
    model_->adapt();  // the layout of t0 (a dynamic layout's first check)
    write_output();
  }

  // The time loop:  dt = min(stable dt, output and end times);  step;  check;  accept.
  double next_output = t0_ + rc_.output_interval;
  const double eps_t = 1e-9 * std::max(1.0, rc_.end_time);  // round-off of t += dt
  while (model_->time() < rc_.end_time - eps_t) {
    if (model_->steps() >= rc_.max_steps) {
      write_summary("step_limit",
                    "reached 'Max steps' = " + std::to_string(rc_.max_steps) +
                        " before the end time",
                    kStepLimit);
      show_progress(true);
      std::cerr << "granflow: stopped at the step limit (t = " << model_->time() << " s)\n";
      return kStepLimit;
    }
    const double t = model_->time();
    const double stable = model_->stable_dt();
    if (!(stable >= rc_.min_dt)) {
      std::ostringstream os;
      os << "stable time step " << stable << " s fell below 'Min time step' = " << rc_.min_dt
         << " s at t = " << t << " s";
      write_summary("diverged", os.str(), kDiverged);
      std::cerr << "\ngranflow: run stopped: " << os.str()
                << "; the last good output and checkpoint are kept in " << rc_.directory << "\n";
      return kDiverged;
    }
    // Land exactly on the next output or end time; split the last two steps before it evenly
    // rather than leaving a sliver step.
    const double to_target = std::min(next_output, rc_.end_time) - t;
    double dt = std::min({stable, rc_.max_dt});
    if (to_target <= dt) dt = to_target;
    else if (to_target < 1.5 * dt) dt = 0.5 * to_target;
    const auto t1 = Clock::now();
    model_->step(dt);
    const auto t2 = Clock::now();
    const Health hl = model_->check();
    phase_seconds_["step"] += std::chrono::duration<double>(t2 - t1).count();
    phase_seconds_["check"] += std::chrono::duration<double>(Clock::now() - t2).count();
    if (!hl.ok) {
      std::ostringstream os;
      os << hl.reason << ": " << hl.quantity << " = " << hl.value << " at x = " << hl.x
         << " m, in the step from t = " << t << " s with dt = " << dt << " s";
      write_summary("diverged", os.str(), kDiverged);
      std::cerr << "\ngranflow: run diverged: " << os.str()
                << "; the last good output and checkpoint are kept in " << rc_.directory << "\n";
      return kDiverged;
    }
    model_->accept();
    last_dt_ = dt;
    // between accepted steps: the model may change its layout (the domain manager)
    const auto t3 = Clock::now();
    model_->adapt();
    phase_seconds_["layout"] += std::chrono::duration<double>(Clock::now() - t3).count();
    if (model_->time() >= next_output - eps_t) {
      write_output();
      next_output += rc_.output_interval;
    }
    show_progress(false);
  }
  if (outputs_ == 0 || std::abs(model_->time() - last_output_t_) > eps_t)
    write_output();  // final state if the end time is not an output time
  show_progress(true);
  write_summary("completed", "reached the end time", kOk);
  return kOk;
}

}  // namespace granflow::core
