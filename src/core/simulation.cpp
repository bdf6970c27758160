#include "granflow/core/simulation.hpp"

#include "granflow/core/run_record.hpp"
#include "granflow/io/output.hpp"
#include "granflow/params/parameters.hpp"

#include <nlohmann/json.hpp>

#include <mpi.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <functional>
#include <sstream>
#include <utility>

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
            "stop (exit code 5) after this many steps, counted from the scene's start (a "
            "restart continues the count); checkpoint.h5 then holds the stopped state",
            1, 2000000000);
    add_double(*pl, "Speed limit", d.speed_limit,
               "[m/s] a material speed above this stops the run as diverged (exit code 3, with "
               "a diagnosis; the last good output and checkpoint are kept). 0: " +
                   params::str(kSpeedLimitFactor) +
                   " times the scene's energy bound u_0 + sqrt(2 g (L |sin zeta| + H cos "
                   "zeta)) (u_0 the fastest of the gate or its series, the initial velocity "
                   "and the lids; L the channel length; H the 2D box height) in a 2D or "
                   "coupled free-surface channel that is not periodic, no limit otherwise "
                   "(summary.json speed_limit says which)",
               0.0, 1e6);
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
               "run directory for profiles.csv, fields.h5/.xdmf, checkpoint.h5, summary.json "
               "(and wall.csv when the channel ends at a wall in a 2D model, or in a dynamic layout "
               "that may make the part there 2D); "
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
               "'Directory'. The directory's earlier files are continued (cut back to the "
               "checkpoint time) only when the checkpoint lies in 'Directory'; from elsewhere "
               "they are replaced, with a note on stderr");
    add_double(*pl, "Impact window", d.impact_window,
               "[s] channels that end at a wall (wall.csv, the wall load at every accepted "
               "step): summary.json reports as the impact peak the largest load within this "
               "time after the material first reaches the wall (the wall column holds a cell "
               "height of it), beside the peak of the whole run (which the growing deposit can "
               "reach later)",
               1e-9, 1e9);
    return pl;
  }();
  return valid;
}

RunControl RunControl::from_parameters(const Teuchos::ParameterList& time,
                                       const Teuchos::ParameterList& out,
                                       const std::string& scene_dir) {
  RunControl r;
  r.scene_dir = scene_dir;
  r.end_time = time.get<double>("End time");
  r.max_dt = time.get<double>("Max time step");
  r.min_dt = time.get<double>("Min time step");
  r.max_steps = time.get<int>("Max steps");
  r.speed_limit = time.get<double>("Speed limit");
  r.directory = out.get<std::string>("Directory");
  r.output_interval = out.get<double>("Interval");
  r.fields = out.get<bool>("Fields");
  r.checkpoint = out.get<bool>("Checkpoint");
  r.progress = out.get<bool>("Progress");
  r.restart_from = out.get<std::string>("Restart from");
  r.impact_window = out.get<double>("Impact window");
  if (!r.restart_from.empty() && !std::filesystem::exists(r.restart_from))
    params::fail(out, "Restart from", r.restart_from,
                 "no such file; allowed: the checkpoint.h5 of an earlier run, or empty");
  // the loop's time resolution is 1e-9 s (eps_t in run()): a shorter positive End time ran
  // no step and reported "completed at t = 0" (an independent run)
  if (r.end_time > 0.0 && r.end_time < 1e-9)
    params::fail(time, "End time", params::str(r.end_time),
                 "below the run's time resolution of 1e-9 s, so no step would be taken; "
                 "allowed: 0 (the initial state only) or >= 1e-9");
  if (r.min_dt >= r.max_dt)
    params::fail(time, "Min time step", params::str(r.min_dt),
                 "must be smaller than 'Max time step' = " + params::str(r.max_dt));
  return r;
}

double RunControl::effective_speed_limit() const {
  if (speed_limit > 0.0) return speed_limit;
  return energy_bound > 0.0 ? kSpeedLimitFactor * energy_bound : 0.0;
}

std::string RunControl::speed_limit_source() const {
  if (speed_limit > 0.0) return "Time->Speed limit";
  if (energy_bound > 0.0)
    return params::str(kSpeedLimitFactor) +
           " x the energy bound u_0 + sqrt(2 g (L |sin zeta| + H cos zeta)) = " +
           params::str(energy_bound) + " m/s";
  return "none (Time->Speed limit = 0 and no energy bound for this scene)";
}

struct Simulation::Io {
  io::ProfileWriter profiles;
  io::Hdf5FieldOutput fields;
  io::WallWriter wall;
  bool wall_on = false;  // the model ends at a wall: wall.csv (every rank knows it)
  std::unique_ptr<DirectoryLock> lock;  // rank 0, for the whole run
};

Simulation::Simulation(std::string scene_name, const Teuchos::ParameterList& validated,
                       std::unique_ptr<Stepper> model, RunControl rc)
    : scene_name_(std::move(scene_name)), params_(validated), model_(std::move(model)),
      rc_(std::move(rc)), io_(std::make_shared<Io>()) {}

namespace {
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

bool mpi_active(int* size = nullptr) {
  int init = 0, fin = 0;
  MPI_Initialized(&init);
  if (init) MPI_Finalized(&fin);
  if (!init || fin) return false;
  int n = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &n);
  if (size) *size = n;
  return true;
}

// An InputError found on rank 0 (which alone looks at the run directory) stops every rank.
void agree_on_error(std::string& message) {
  int n = 1;
  if (!mpi_active(&n) || n == 1) return;
  int len = static_cast<int>(message.size());
  MPI_Bcast(&len, 1, MPI_INT, 0, MPI_COMM_WORLD);
  message.resize(static_cast<std::size_t>(len));
  MPI_Bcast(message.data(), len, MPI_CHAR, 0, MPI_COMM_WORLD);
}

// Rank 0 writes the run's files; a write that fails there (a full disk, a lost directory)
// must stop every rank at the same point, or the others wait in the next step's collectives.
// Every rank calls this; the error (rank 0's message) is thrown on all of them.
void on_io_rank(const std::function<void()>& write) {
  std::string err;
  if (io_rank()) {
    try {
      write();
    } catch (const std::exception& e) {
      err = e.what();
      if (err.empty()) err = "a write failed";
    }
  }
  agree_on_error(err);
  if (!err.empty()) throw std::runtime_error(err);
}

// --- interrupts ---------------------------------------------------------------------------
// The handler only records the signal; the time loop looks at it between steps, so the step in
// progress (a linear solve, an MPI exchange) ends normally and every rank stops at the same
// step. A second signal ends the run at once, by the signal's default action, after one line
// that says so (only async-signal-safe calls: write, sigaction, raise); the first one left the
// process silently (a hostile-user run: "did it crash?").
volatile std::sig_atomic_t g_signal = 0;
extern "C" void on_signal(int sig) {
  if (g_signal == 0) {
    g_signal = sig;
    return;
  }
  // a hangup may come more than once (the shell passes it on, the terminal sends it): only a
  // second SIGINT or SIGTERM means "now"
  if (sig == SIGHUP) return;
  static const char kMessage[] =
      "granflow: a second interrupt: stopping at once, without finishing the step in progress; "
      "the files written so far stay as they are (run.json still says 'running')\n";
  const ssize_t written = ::write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
  (void)written;
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  sigaction(sig, &dfl, nullptr);
  raise(sig);  // delivered when the handler returns: the default action ends the process
}

// SIGHUP too: a closed terminal or ssh session ended a run by the default action, without a
// summary (an independent run); now it stops as an interrupt does (exit 129). A run started
// under nohup (SIGHUP ignored) keeps ignoring it: it is meant to outlive its terminal.
void install(struct sigaction* old_int, struct sigaction* old_term, struct sigaction* old_hup) {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGINT, &sa, old_int);
  sigaction(SIGTERM, &sa, old_term);
  struct sigaction hup {};
  sigaction(SIGHUP, nullptr, &hup);
  if (old_hup) *old_hup = hup;
  if (hup.sa_handler != SIG_IGN) sigaction(SIGHUP, &sa, nullptr);
}

// For the run: our handler (again), the previous ones restored afterwards. A signal that came
// before (while the model was built, see catch_interrupts()) stays pending, and the handler
// stays, so that a second signal still ends the process.
class SignalGuard {
 public:
  SignalGuard() : installed_(g_signal == 0) {
    if (installed_) install(&old_int_, &old_term_, &old_hup_);
  }
  ~SignalGuard() {
    if (!installed_) return;
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
    sigaction(SIGHUP, &old_hup_, nullptr);
  }
  SignalGuard(const SignalGuard&) = delete;
  SignalGuard& operator=(const SignalGuard&) = delete;

 private:
  bool installed_;
  struct sigaction old_int_ {}, old_term_ {}, old_hup_ {};
};

// The signal as all ranks agree on it (once per step: one integer MPI_Allreduce, so a signal
// that reaches the ranks at different times still stops them at the same step).
int pending_signal() {
  int local = g_signal, n = 1;
  if (!mpi_active(&n) || n == 1) return local;
  int global = 0;
  MPI_Allreduce(&local, &global, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  return global;
}

const char* signal_name(int sig) {
  return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : sig == SIGHUP ? "SIGHUP" : "a signal";
}

std::string joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

io::Checkpoint read_restart(const std::string& file) {
  try {
    return io::read_checkpoint(file);
  } catch (const io::CheckpointError& e) {
    throw params::InputError("parameter 'granflow->Output->Restart from' = " + params::shown(file) +
                             ": " + e.what() + "; allowed: an intact checkpoint.h5 of this scene");
  }
}

std::string host_name() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

// Peak resident set of this process (VmHWM of /proc/self/status) [B]; -1 if unknown.
// A line "Name:   123 kB" of /proc/self/status in bytes (-1 where there is none).
double proc_status_bytes(const char* name) {
  std::ifstream in("/proc/self/status");
  const std::string key = std::string(name) + ":";
  for (std::string line; std::getline(in, line);)
    if (line.rfind(key, 0) == 0) return std::stod(line.substr(key.size())) * 1024.0;
  return -1.0;
}
double peak_resident() { return proc_status_bytes("VmHWM"); }

// CPU seconds of this process so far, user and system (getrusage).
std::pair<double, double> process_cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return {ru.ru_utime.tv_sec + 1e-6 * ru.ru_utime.tv_usec,
          ru.ru_stime.tv_sec + 1e-6 * ru.ru_stime.tv_usec};
}
double current_resident() { return proc_status_bytes("VmRSS"); }

// Bytes the program holds from malloc now (all arenas: small blocks in use plus mmapped ones)
// [B]; -1 where the C library does not say. Unlike the resident set, which moves with the pages
// malloc keeps or returns and with the MPI runtime's threads (0.5 MB between identical runs),
// this counts only what the code has allocated and not freed: the quantity a leak grows.
double heap_in_use() {
#if defined(__GLIBC__) && ((__GLIBC__ > 2) || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  const struct mallinfo2 mi = mallinfo2();
  return static_cast<double>(mi.uordblks + mi.hblkhd);
#else
  return -1.0;
#endif
}

std::string mpi_library() {
  char buf[MPI_MAX_LIBRARY_VERSION_STRING] = {0};
  int len = 0;
  MPI_Get_library_version(buf, &len);
  std::string s(buf, static_cast<std::size_t>(std::max(len, 0)));
  const auto nl = s.find_first_of("\n,");
  return nl == std::string::npos ? s : s.substr(0, nl);
}
}  // namespace

void catch_interrupts() { install(nullptr, nullptr, nullptr); }

void preflight(const Teuchos::ParameterList& validated, const RunControl& rc) {
  const auto canonical = canonical_parameters(validated, rc.scene_dir);
  const auto identity = scene_identity(canonical);
  if (!rc.restart_from.empty())
    check_restart(read_restart(rc.restart_from), rc.restart_from, canonical, rc.end_time);
  std::string err;
  if (io_rank()) {
    try {
      const DirectoryLock probe(rc.directory);  // refused while another run holds it
      plan_directory(rc.directory, identity, canonical, rc.overwrite, !rc.restart_from.empty(),
                     rc.restart_from, validated);
      probe_directory(rc.directory);
    } catch (const params::InputError& e) {
      err = e.what();
    } catch (const std::exception& e) {  // e.g. no permission to read the directory
      err = "parameter 'granflow->Output->Directory' = " + params::shown(rc.directory) + ": " +
            e.what();
    }
  }
  agree_on_error(err);
  if (!err.empty()) throw params::InputError(err);
}

void Simulation::write_checkpoint() {
  io::Checkpoint c;
  c.set("run/time", model_->time());
  c.set("run/origin", origin_);
  // the run's fastest state so far, so that a restarted run's summary covers the whole run
  c.set("run/max_speed", std::vector<double>{max_speed_.value, max_speed_t_, max_speed_.x,
                                              max_speed_.z});
  c.set_text("run/max_speed_quantity", max_speed_.quantity);
  // and the wall load's statistics (a restart into another directory has no rows to re-read)
  if (io_rank() && io_->wall_on) c.set("run/wall_series", io_->wall.state());
  // the layouts of the outputs so far (summary.json's positions_over_time, which a restart
  // lost before: it began at the first output after the restart), one line per entry, the
  // numbers with 17 digits so that they read back as the same doubles
  {
    std::ostringstream os;
    os << std::setprecision(17);
    for (const auto& [lt, pieces] : layouts_) {
      os << lt;
      for (const auto& p : pieces) os << ' ' << p.model << ' ' << p.x0 << ' ' << p.x1;
      os << '\n';
    }
    c.set_text("run/layouts", os.str());
  }
  c.set_text(kSceneKey, joined(canonical_));
  c.set_text(kIdentityKey, identity_);
  c.set_text(kRestartsKey, restarts_);
  // the field output's run id (rank 0 writes the checkpoint; a run with Fields off keeps the
  // one it restarted with, so that a later leg with Fields on recognises the files)
  c.set_text(kFieldsIdKey, rc_.fields && io_rank() ? io_->fields.run_id() : fields_id_);
  model_->save(c);
  on_io_rank([&] { io::write_checkpoint(rc_.directory + "/checkpoint.h5", c); });
  model_->restart_point();  // a restart from here and the run itself continue alike
}

std::vector<LayoutPiece> Stepper::layout_pieces() const {
  const auto p = profile();
  if (p.x.size() < 2) return {};
  const double half = 0.5 * (p.x[1] - p.x[0]);  // cell centres -> channel ends
  return {{p.model.front(), p.x.front() - half, p.x.back() + half}};
}

// The wall load of the current state, one row of wall.csv. Sampled at the initial state and
// after every accepted step, not at the output times: the impact peak lasts a few steps, and a
// series sampled at the output interval would report whatever the interval happens to catch.
void Simulation::sample_wall() {
  if (!io_->wall_on) return;
  const auto w = model_->wall_load();  // collective
  if (w && io_rank()) io_->wall.write(model_->time(), *w);
}

// An output that cannot be written (a full disk) stops the run (exit 4) with what is kept.
void Simulation::write_output() {
  try {
    write_output_files();
  } catch (const params::InputError&) {
    throw;
  } catch (const std::exception& e) {
    std::ostringstream os;
    os << e.what() << "; the output at t = " << model_->time() << " s is incomplete";
    if (outputs_ > 0)
      os << "; the outputs to t = " << last_output_t_ << " s"
         << (rc_.checkpoint ? " and their checkpoint" : "") << " are kept";
    throw std::runtime_error(os.str());
  }
}

void Simulation::write_output_files() {
  const auto t1 = Clock::now();
  const double t = model_->time();
  // Room kept for what a stop writes: summary.json grows with the run (the domain manager's
  // log of moves, the memory samples and layouts per output; 118 kB after 96 moves, 6-23 kB
  // for a run without moves): twice the models' statistics so far, 1 kB per output and 64 kB
  // (run.json, the index).
  {
    nlohmann::json stats;
    model_->report(stats);
    io::set_stop_reserve(64 * 1024 + 2 * stats.dump().size() +
                         1024 * static_cast<std::uintmax_t>(outputs_ + 1));
  }
  {
    const auto profile = model_->profile();
    on_io_rank([&] { io_->profiles.write(t, profile); });
  }
  // the layout at this output (a dynamic layout changes it between outputs)
  {
    auto pieces = model_->layout_pieces();
    auto same = [](const std::vector<LayoutPiece>& a, const std::vector<LayoutPiece>& b) {
      if (a.size() != b.size()) return false;
      for (std::size_t i = 0; i < a.size(); ++i)
        if (a[i].model != b[i].model || a[i].x0 != b[i].x0 || a[i].x1 != b[i].x1) return false;
      return true;
    };
    if (layouts_.empty() || !same(layouts_.back().second, pieces))
      layouts_.emplace_back(t, std::move(pieces));
  }
  if (io_->wall_on) on_io_rank([&] { io_->wall.flush(); });
  // memory at this output against the material it holds (issue 14 item 5: the memory a run
  // needs grows with its material cells and markers, not with its steps)
  memory_samples_.push_back(
      {t, current_resident(), peak_resident(), heap_in_use(), model_->mass_balance().current});
  if (rc_.fields) {
    io::FieldWriter w;
    model_->write_fields(w);
    on_io_rank([&] { io_->fields.write(t, w); });
  }
  if (rc_.checkpoint) write_checkpoint();
  ++outputs_;
  last_output_t_ = t;
  phase_seconds_["output"] += std::chrono::duration<double>(Clock::now() - t1).count();
  show_progress(false, true);
}

// A run that cannot go on (exit code 3): summary.json with the status and reason, the reason
// on stderr; the state of this step is not written, so the last output and checkpoint stay.
int Simulation::stop_diverged(const std::string& status, const std::string& headline,
                              const std::string& reason) {
  write_summary(status, reason, kDiverged);
  if (io_rank())
    std::cerr << "\ngranflow: " << headline << reason
              << "; the last good output and checkpoint are kept in " << rc_.directory << "\n";
  return kDiverged;
}

// The fastest velocity of the current state against the run's largest so far (every accepted
// state, from the first one of this run: a restart counts from its checkpoint).
void Simulation::track_speed() { track_speed(model_->max_speed()); }

void Simulation::track_speed(const Speed& s) {
  if (s.value > max_speed_.value || max_speed_.quantity.empty()) {
    max_speed_ = s;
    max_speed_t_ = model_->time();
  }
}

// summary.json's "wall_load": the extremes of the wall.csv series (the whole run, also across
// restarts: the writer re-reads the rows it keeps).
nlohmann::json Simulation::wall_summary() const {
  const auto& sr = io_->wall.series();
  // null where the series has no sample in contact (the wall never reached)
  auto opt = [](double v, double t) { return t >= 0.0 ? nlohmann::json(v) : nlohmann::json(); };
  auto peak = [&opt](const io::WallWriter::Extreme& e) {
    nlohmann::json q{{"peak", opt(e.max, e.t_max)}, {"peak_time", opt(e.t_max, e.t_max)},
                     {"final", e.last}};
    q["impact_peak"] = e.t_impact >= 0.0 ? nlohmann::json(e.impact) : nlohmann::json();
    q["impact_peak_time"] = e.t_impact >= 0.0 ? nlohmann::json(e.t_impact) : nlohmann::json();
    return q;
  };
  nlohmann::json j;
  j["file"] = "wall.csv";
  // (a dynamic layout with a 1D part at the wall samples nothing until that part becomes 2D:
  // the DAM does not resolve the wall's pressure field; an independent run found the claim
  // "the initial state" false there)
  j["sampling"] = "the initial state and every accepted step while the part at the wall is 2D "
                  "(a coupled run's 1D part at the wall, which a dynamic layout may make 2D "
                  "later, has no rows)";
  j["units"] = {{"force", "N/m"}, {"normal_force", "N/m"}, {"shear", "N/m"}, {"p_foot", "Pa"},
                {"depth", "m"}};
  j["note"] = "loads on the end wall per unit width: force = rho int p dz (p taken to the wall), "
              "normal_force = rho int (p - 2 nu_eff u_x) dz, shear = rho int tau_xz dz (+: up "
              "the wall), p_foot = rho p of the bottom cell of the wall column "
              "(docs/numerics.md, 'Wall load'); impact_peak: the largest value within "
              "impact_window (Output->Impact window) after the first contact (the wall column "
              "holds one cell height of material); peak, max, min: over every sample in "
              "contact (a film thinner than a cell before it is left out; wall.csv has every "
              "row); final: the last sample, in contact or not (a film's row carries the "
              "viscous normal stress of a cell it barely fills: read it with its depth)";
  j["samples"] = sr.samples;
  j["first_contact_time"] = sr.t_contact >= 0.0 ? nlohmann::json(sr.t_contact) : nlohmann::json();
  j["impact_window"] = rc_.impact_window;
  j["force"] = peak(sr.force);
  j["normal_force"] = peak(sr.normal);
  j["p_foot"] = peak(sr.p_foot);
  j["depth"] = peak(sr.depth);
  j["shear"] = {{"max", opt(sr.shear.max, sr.shear.t_max)},
                {"max_time", opt(sr.shear.t_max, sr.shear.t_max)},
                {"min", opt(sr.shear.min, sr.shear.t_min)},
                {"min_time", opt(sr.shear.t_min, sr.shear.t_min)}, {"final", sr.shear.last}};
  return j;
}

void Simulation::write_summary(const std::string& status, const std::string& reason, int code) {
  nlohmann::json s;
  s["scene"] = scene_name_;
  s["model"] = model_->model_name();
  s["identity"] = identity_;
  s["parameters"] = parameters_json(params_);
  // An inflow series replaces 'Inflow depth' and 'Inflow velocity' (channel.cpp refuses them
  // beside it), whose defaults the validated list still holds: the record of the run leaves
  // them out rather than report an inflow that did not happen (an independent run, session 44).
  if (s["parameters"].contains("Channel"))
    for (auto& [side, b] : s["parameters"]["Channel"].items())
      if (b.is_object() && b.contains("Inflow series file") &&
          b["Inflow series file"].is_string() && !b["Inflow series file"].get<std::string>().empty()) {
        b.erase("Inflow depth");
        b.erase("Inflow velocity");
      }
  s["status"] = status;
  s["reason"] = reason;
  s["exit_code"] = code;
  s["start_time"] = t0_;
  s["final_time"] = final_time();
  s["steps"] = final_steps();
  if (restarted_) {
    s["restart"] = {{"from", rc_.restart_from}, {"checkpoint_time", restart_time_}};
    s["restarts"] = nlohmann::json::parse(restarts_);
    s["restarts_note"] = "every restart of this run in order: the checkpoint's time and file, "
                         "and the parameters that leg changed ('before' the earlier part's "
                         "value, '' where not set); 'parameters' above are the last leg's. A "
                         "checkpoint written before 2026-12-07 carries no earlier restarts";
  }
  // the fastest material velocity of the accepted states (the stability suite's bound)
  s["speed_limit"] = {{"value", rc_.effective_speed_limit()},
                      {"energy_bound", rc_.energy_bound},
                      {"source", rc_.speed_limit_source()},
                      {"unit", "m/s"}};
  if (rc_.energy_bound > 0.0)
    s["speed_limit"]["max_speed_over_energy_bound"] = max_speed_.value / rc_.energy_bound;
  s["max_speed"] = {{"value", max_speed_.value}, {"t", max_speed_t_}, {"x", max_speed_.x},
                    {"z", max_speed_.z}, {"quantity", max_speed_.quantity},
                    {"unit", "m/s"}};
  // Provenance: which code, built how, ran where (tells runs and benchmarks apart).
  nlohmann::json prov = nlohmann::json::object();
  for (const auto& [k, v] : build_info_) prov[k] = v;
  int ranks = 1;
  mpi_active(&ranks);
  prov["ranks"] = ranks;
  prov["host"] = host_name();
  prov["hdf5_version"] = io::hdf5_version();
  prov["mpi_library"] = mpi_library();
  s["provenance"] = prov;
  s["memory"] = {{"estimate_bytes", memory_estimate_},
                 {"peak_resident_bytes_rank0", peak_resident()},
                 {"note", "estimate: all ranks on this node, before the run (granflow --check); "
                          "peak: VmHWM of rank 0; at_outputs: rank 0's resident set (VmRSS) "
                          "and its peak so far (VmHWM) at each output of this run (a restart "
                          "starts a new list), the bytes held from malloc then (heap_bytes, "
                          "glibc mallinfo2; -1 elsewhere), with the material area then [m^2]"}};
  s["memory"]["at_outputs"] = nlohmann::json::array();
  for (const auto& m : memory_samples_)
    s["memory"]["at_outputs"].push_back({{"t", m.t}, {"resident_bytes", m.resident},
                                         {"peak_bytes", m.peak}, {"heap_bytes", m.heap},
                                         {"material_m2", m.material}});
  const double wall = std::chrono::duration<double>(Clock::now() - wall0_).count();
  s["wall_time"] = {{"total", wall}};
  for (const auto& [k, v] : phase_seconds_) s["wall_time"][k] = v;
  // CPU time of this process (rank 0; user + system), for comparisons of methods
  // (compare_layouts.py, pareto.py). On two shared cores other jobs inflate it as well as the
  // wall time (identical runs spread by up to 60 %; docs/validation.md, "Error against run
  // time"). run_seconds: from the start of the run on, the span wall_time.total measures; the
  // process's start-up before it (MPI, the scene's validation, the models' set-up: 0.25-0.4 s
  // here) is a fixed cost that made a 1D run's cost 7-10 times its computing in the
  // error-against-run-time report (an independent run)
  {
    const auto [user, sys] = process_cpu_seconds();
    s["cpu_time"] = {{"process_seconds", user + sys}, {"user", user}, {"system", sys},
                     {"run_seconds", user + sys - cpu0_},
                     {"note", "rank 0, this process (a restart starts again from 0); "
                              "process_seconds includes the start-up before the run, "
                              "run_seconds is the run itself (the span of wall_time.total)"}};
  }
  const auto m = final_mass_balance();
  if (rejected_from_ >= 0.0)
    s["rejected_step"] = {{"from", rejected_from_},
                          {"dt", rejected_dt_},
                          {"note", "the step the speed limit rejected: not written; final_time, "
                                   "steps, max_speed and mass_balance end before it, the "
                                   "solver statistics count its solves"}};
  s["mass_balance"] = {{"unit", "m^2 (per unit channel width)"},
                       {"initial", m.initial},
                       {"final", m.current},
                       {"net_in_through_left_end", m.inflow},
                       {"net_out_through_right_end", m.outflow},
                       {"pending_at_left_end", m.pending_inflow},
                       {"defect", m.defect()},
                       {"relative_defect",
                        m.defect() / std::max({std::abs(m.initial), std::abs(m.current),
                                               std::abs(m.inflow), 1e-300})}};
  nlohmann::json stats = nlohmann::json::object();
  model_->report(stats);
  // counters of solves, iterations and seconds are this process's; a model's "steps" (and the
  // top-level "steps") count the whole run, from the checkpoint on after a restart
  stats["note"] = restarted_
                      ? "counts of solves, iterations, evaluations and seconds since this "
                        "process restarted at t = " + std::to_string(restart_time_) +
                            " s; 'steps' of the whole run"
                      : "counts of solves, iterations, evaluations and seconds of this run";
  s["solver_statistics"] = stats;
  // Layout of the models along the channel at every output where it changed (a static one:
  // one entry), and the domain manager's moves between outputs (summary of its log).
  long long moves = 0;
  if (stats.contains("coupled") && stats["coupled"].contains("domain_manager"))
    moves = stats["coupled"]["domain_manager"]["moves"].get<long long>();
  auto entries = layouts_;
  if (entries.empty()) entries.emplace_back(model_->time(), model_->layout_pieces());
  nlohmann::json layout = nlohmann::json::array();
  for (const auto& [t, pieces] : entries) {
    nlohmann::json sub = nlohmann::json::array();
    for (const auto& p : pieces) sub.push_back({{"model", p.model}, {"x0", p.x0}, {"x1", p.x1}});
    layout.push_back({{"t", t}, {"subdomains", sub}});
  }
  s["interfaces"] = {{"positions_over_time", layout}, {"moves", moves}};
  // the files of this run that exist now (a run stopped before its first output or checkpoint
  // has not written them: a restart into a new directory, stopped in its first step, listed
  // fields.xdmf and checkpoint.h5; an independent run); summary.json itself is being written
  std::vector<std::string> written;
  for (const auto& f : files_)
    if (f == "summary.json" || std::filesystem::exists(rc_.directory + "/" + f))
      written.push_back(f);
  // output_times: written by this run (a restart counts from its start); field_snapshots: held
  // by fields.h5 (a restart into its own directory keeps the earlier ones: it reported 7 for a
  // file of 25 before, an independent run)
  // A restart into its own directory with Fields off keeps the earlier snapshots (cut back to
  // its start): it reported 0 for a fields.h5 of 10 (an independent run)
  int snapshots = 0;
  if (io_rank()) {
    const std::string f5 = rc_.directory + "/fields.h5";
    if (rc_.fields) {
      snapshots = io_->fields.snapshots();
    } else if (std::filesystem::exists(f5)) {
      try {
        snapshots = static_cast<int>(io::FieldReader(f5).size());
      } catch (const std::exception&) {
        snapshots = 0;  // unreadable: the summary still gets written
      }
    }
  }
  s["outputs"] = {{"output_times", outputs_},
                  {"output_times_note", "output times written by this run (a restart counts "
                                        "from its start); field_snapshots: the snapshots "
                                        "fields.h5 holds"},
                  {"field_snapshots", snapshots},
                  {"directory", rc_.directory},
                  {"files", written}};
  if (io_->wall_on) s["wall_load"] = wall_summary();
  if (!io_rank()) return;
  // wall.csv's last rows: a flush that fails (a full disk) is said in the summary, which is
  // written all the same (it threw before, and a stop then left no summary at all)
  if (io_->wall_on) {
    try {
      io_->wall.flush();
    } catch (const std::exception& e) {
      s["wall_csv_error"] = e.what();
    }
  }
  // Serialise before the file is opened, and replace bytes that are not UTF-8 instead of
  // throwing: a string that slipped through must not leave a 0-byte summary.json at the end of
  // a run whose results are on disk.
  const std::string text = s.dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
  // Written whole and then renamed (io::write_file_atomic): on a full disk it was cut to 0
  // bytes (an independent run); now the previous summary stays and the error is reported.
  // The room held for it since the start is given back first.
  io::release_stop_reserve();
  io::write_file_atomic(rc_.directory + "/summary.json", text + "\n");
  write_manifest(rc_.directory, RunManifest{scene_name_, model_->model_name(), identity_,
                                            canonical_, files_, status});
}

void Simulation::show_progress(bool final, bool at_output) {
  if (!rc_.progress || !io_rank()) return;
  // On a terminal: one line rewritten in place (at most 4 times a second). In a log (stderr a
  // file or a pipe): one plain line per output time and one at the end.
  const bool tty = isatty(fileno(stderr));
  const auto now = Clock::now();
  if (!final) {
    if (tty && std::chrono::duration<double>(now - last_progress_).count() < 0.25) return;
    if (!tty && !at_output) return;
  }
  if (!tty && model_->steps() == last_progress_step_) return;  // this line is in the log
  last_progress_ = now;
  last_progress_step_ = model_->steps();
  const double wall = std::chrono::duration<double>(now - wall0_).count();
  const double t = model_->time();
  const double done = (t - t0_) / std::max(rc_.end_time - t0_, 1e-300);
  const double left = done > 0 ? std::max(0.0, wall * (1.0 - done) / done) : 0.0;  // no -0.0
  char buf[256];
  std::snprintf(buf, sizeof buf, "t = %.4f / %.4f s | dt = %.3e s | step %ld | wall %s | left ~%s",
                t, rc_.end_time, last_dt_, model_->steps(), fmt_seconds(wall).c_str(),
                fmt_seconds(left).c_str());
  std::cerr << (tty ? "\r" : "") << buf << (tty ? "   " : "\n");
  if (final && tty) std::cerr << "\n";
  std::cerr.flush();
}

void Simulation::checkpoint_stopped_state() {
  const auto t1 = Clock::now();
  write_checkpoint();
  phase_seconds_["output"] += std::chrono::duration<double>(Clock::now() - t1).count();
  if (std::find(files_.begin(), files_.end(), "checkpoint.h5") == files_.end())
    files_.push_back("checkpoint.h5");
}

int Simulation::interrupted(int sig) {
  // The last accepted state goes into the checkpoint; profiles and fields stay at the output
  // times.
  checkpoint_stopped_state();
  std::ostringstream os;
  os << signal_name(sig) << " received; stopped after step " << model_->steps() << " at t = "
     << model_->time() << " s; checkpoint.h5 holds this state (resume with 'Output->Restart "
     << "from')";
  const int code = kInterruptedBase + sig;
  write_summary("interrupted", os.str(), code);
  show_progress(true, false);
  if (io_rank()) std::cerr << "granflow: " << os.str() << "\n";
  return code;
}

int Simulation::run() {
  wall0_ = last_progress_ = Clock::now();
  {
    const auto [user, sys] = process_cpu_seconds();
    cpu0_ = user + sys;
  }
  const SignalGuard signals;
  canonical_ = canonical_parameters(params_, rc_.scene_dir);
  identity_ = scene_identity(canonical_);
  restarted_ = !rc_.restart_from.empty();
  io::Checkpoint ck;
  if (restarted_) {
    ck = read_restart(rc_.restart_from);
    restart_time_ = check_restart(ck, rc_.restart_from, canonical_, rc_.end_time);
    // What this leg changed (End time, output interval, a solver tolerance ...): summary.json
    // recorded only the last leg's parameters, so a restarted run did not say that its first
    // part ran with another tolerance (noticed in session 40).
    nlohmann::json legs = nlohmann::json::array();
    if (ck.has_text(kRestartsKey)) {
      try {
        legs = nlohmann::json::parse(ck.text(kRestartsKey));
      } catch (const std::exception&) {
        legs = nlohmann::json::array();  // the checksum held; an unparsable history is dropped
      }
      if (!legs.is_array()) legs = nlohmann::json::array();
    }
    nlohmann::json changed = nlohmann::json::array();
    for (const auto& c : restart_changes(ck, canonical_))
      changed.push_back({{"parameter", c.parameter}, {"before", c.before}, {"after", c.after}});
    legs.push_back({{"t", restart_time_}, {"from", rc_.restart_from}, {"changed", changed}});
    // (bytes that are not UTF-8 in a path or a value are replaced, as in summary.json)
    restarts_ = legs.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    if (ck.has_text(kFieldsIdKey)) fields_id_ = ck.text(kFieldsIdKey);
  }
  // Take the run directory: rank 0 decides (and removes an earlier run's files); every rank
  // learns the verdict.
  std::string err;
  DirectoryPlan plan;
  if (io_rank()) {
    try {
      // Refusals first (a file in the way, another scene), then under the lock for real.
      plan_directory(rc_.directory, identity_, canonical_, rc_.overwrite, restarted_,
                     rc_.restart_from, params_);
      create_run_directories(rc_.directory);
      io_->lock = std::make_unique<DirectoryLock>(rc_.directory);
      plan = plan_directory(rc_.directory, identity_, canonical_, rc_.overwrite, restarted_,
                            rc_.restart_from, params_);
      for (const auto& f : plan.remove) {
        if (std::filesystem::path(f).filename() == "fields.h5.d") io::remove_field_snapshots(f);
        else std::filesystem::remove(f);
      }
      if (!plan.note.empty()) std::cerr << "granflow: note: " << plan.note << "\n";
    } catch (const params::InputError& e) {
      err = e.what();
    } catch (const std::exception& e) {
      err = "parameter 'granflow->Output->Directory' = " + params::shown(rc_.directory) +
            ": cannot prepare the run directory: " + e.what();
    }
  }
  agree_on_error(err);
  if (!err.empty()) throw params::InputError(err);
  files_ = {"run.json", "summary.json", "profiles.csv"};
  io_->wall_on = model_->end_wall();
  if (io_->wall_on) files_.push_back("wall.csv");
  if (rc_.fields) files_.insert(files_.end(), {"fields.h5", "fields.h5.d", "fields.xdmf"});
  if (rc_.checkpoint) files_.push_back("checkpoint.h5");
  int continued = plan.continued ? 1 : 0;  // rank 0 decided
  MPI_Bcast(&continued, 1, MPI_INT, 0, MPI_COMM_WORLD);
  continued_ = continued != 0;
  if (continued_)  // the earlier parts of this run wrote into this directory too
    for (const auto& f : plan.earlier_files)
      if (std::find(files_.begin(), files_.end(), f) == files_.end()) files_.push_back(f);
  on_io_rank([&] {
    write_manifest(rc_.directory, RunManifest{scene_name_, model_->model_name(), identity_,
                                              canonical_, files_, "running"});
  });
  on_io_rank([&] { io::hold_stop_reserve(rc_.directory); });
  // A continued run with Checkpoint off leaves the earlier part's checkpoint in the directory: a
  // restart from it goes back to its time and cuts this part's outputs (noticed in session 40;
  // said, not changed: it is the last restartable state the directory has).
  if (continued_ && !rc_.checkpoint && io_rank() &&
      std::filesystem::exists(rc_.directory + "/checkpoint.h5"))
    std::cerr << "granflow: note: Output->Checkpoint is off: " << rc_.directory
              << "/checkpoint.h5 stays the earlier part's (t = " << params::str(restart_time_)
              << " s); a restart from it cuts this part's outputs back to that time\n";
  // From here on the directory is this run's: whatever stops it leaves a summary.json.
  auto summary_then_rethrow = [&](const std::string& status, const char* what, int code) {
    try {
      write_summary(status, what, code);
    } catch (const std::exception& e) {  // the original error is the one to report
      // but the missing summary is said (a disk filled by another process left none, and
      // stderr said nothing of it; an independent run)
      if (io_rank())
        std::cerr << "granflow: warning: summary.json could not be written: " << e.what()
                  << "\n";
    }
  };
  try {
    return advance(ck);
  } catch (const params::InputError& e) {
    summary_then_rethrow("invalid_input", e.what(), kInputError);
    throw;
  } catch (const std::exception& e) {
    summary_then_rethrow("error", e.what(), kRuntimeError);
    throw;
  }
}

int Simulation::advance(const io::Checkpoint& ck) {
  if (restarted_) model_->load(ck);
  t0_ = model_->time();
  // Outputs fall on origin + k Interval, origin the start of the scene's first run (kept in the
  // checkpoint), so a restart from any checkpoint (an output time, an interrupt, an end time
  // that is no output time) writes at the same times as a straight run. k Interval, not a sum
  // of Intervals: the same double in both runs.
  origin_ = restarted_ && ck.has_scalar("run/origin") ? ck.scalar("run/origin") : t0_;
  if (restarted_ && ck.has_text("run/layouts")) {
    layouts_.clear();
    std::istringstream is(ck.text("run/layouts"));
    for (std::string line; std::getline(is, line);) {
      std::istringstream ls(line);
      double lt = 0.0;
      if (!(ls >> lt) || lt > t0_ + 1e-12 * (1.0 + std::abs(t0_))) continue;
      std::vector<LayoutPiece> pieces;
      for (LayoutPiece p; ls >> p.model >> p.x0 >> p.x1;) pieces.push_back(p);
      layouts_.emplace_back(lt, std::move(pieces));
    }
  }
  if (restarted_ && ck.arrays().count("run/max_speed") && ck.has_text("run/max_speed_quantity")) {
    const auto& v = ck.array("run/max_speed");
    max_speed_ = Speed{v.at(0), v.at(2), v.at(3), ck.text("run/max_speed_quantity")};
    max_speed_t_ = v.at(1);
  }
  const double eps_t = 1e-9 * std::max(1.0, rc_.end_time);  // round-off of t += dt
  auto output_time = [&](long k) { return origin_ + static_cast<double>(k) * rc_.output_interval; };
  next_index_ = 1;
  if (restarted_) {
    next_index_ =
        std::max(1L, static_cast<long>(std::floor((t0_ - origin_) / rc_.output_interval)));
    while (output_time(next_index_) <= t0_ + eps_t) ++next_index_;
    while (next_index_ > 1 && output_time(next_index_ - 1) > t0_ + eps_t) --next_index_;
  }
  // (on rank 0, which alone touches the files; an error there stops every rank)
  on_io_rank([&] {
    // A restart cuts profiles and fields back to the checkpoint time: a run stopped after its
    // output and before its checkpoint (or interrupted) must not leave rows or snapshots the
    // restart writes again.
    const double keep = continued_ ? t0_ : -1.0;
    io_->profiles.open(rc_.directory, keep);
    if (io_->wall_on) {
      io_->wall.open(rc_.directory, keep, rc_.impact_window);
      // Into another directory the earlier rows are not at hand: the statistics up to the
      // checkpoint come from it (a restart from 0.65 s into a new directory reported the
      // first contact at 0.65 s and a third of the impact's peak; an independent run).
      if (restarted_ && !continued_ && ck.arrays().count("run/wall_series"))
        io_->wall.restore(ck.array("run/wall_series"));
    }
    // the run id of the field output the checkpoint belongs to (a continued run's index and
    // files must carry it; a checkpoint written before 2026-12-07 has none)
    if (rc_.fields) io_->fields.open(rc_.directory, keep, continued_ ? fields_id_ : "");
    else if (continued_) io::truncate_fields(rc_.directory, t0_);
    // A continued run's summary.json is the earlier part's ("completed" at its end time): a
    // restart killed before its own summary left that one beside profiles.csv rows past it (an
    // independent run). Now that its files are cut back to the checkpoint, it has none until
    // it stops, as a fresh run; run.json says "running".
    if (continued_) {
      std::error_code ec;
      std::filesystem::remove(rc_.directory + "/summary.json", ec);
    }
  });
  if (!restarted_) {
    model_->adapt();  // the layout of t0 (a dynamic layout's first check)
    sample_wall();
    write_output();
  }
  track_speed();

  // The time loop:  dt = min(stable dt, output and end times);  step;  check;  accept.
  double next_output = output_time(next_index_);
  while (model_->time() < rc_.end_time - eps_t) {
    if (const int sig = pending_signal()) return interrupted(sig);
    if (model_->steps() >= rc_.max_steps) {
      // As at an interrupt, the stopped (accepted) state goes into the checkpoint: it held
      // the last output's state before, so a restart repeated the steps since then (an
      // independent run: stopped at step 100, t = 0.385 s, checkpoint of step 86, 0.35 s).
      checkpoint_stopped_state();
      std::ostringstream os;
      os << "reached 'Max steps' = " << rc_.max_steps << " before the end time; stopped after step "
         << model_->steps() << " at t = " << model_->time()
         << " s; checkpoint.h5 holds this state (resume with 'Output->Restart from' and a "
            "larger 'Max steps': the count runs from the scene's start)";
      write_summary("step_limit", os.str(), kStepLimit);
      show_progress(true, false);
      if (io_rank()) std::cerr << "granflow: stopped at the step limit: " << os.str() << "\n";
      return kStepLimit;
    }
    const double t = model_->time();
    const double stable = model_->stable_dt();
    if (!(stable >= rc_.min_dt)) {
      std::ostringstream os;
      os << "stable time step " << stable << " s fell below 'Min time step' = " << rc_.min_dt
         << " s at t = " << t << " s";
      if (const std::string lim = model_->dt_limit(); !lim.empty()) os << ", set by " << lim;
      return stop_diverged("diverged", "run stopped: ", os.str());
    }
    // Land exactly on the next output or end time; split the last two steps before it evenly
    // rather than leaving a sliver step. An end time that is an output time (to round-off: 0.6
    // against 6 x 0.1) is that output time, so that a run that ends there and one that goes on
    // take the same steps to it (a restart from the first then continues the second bit for bit).
    const double end = std::abs(rc_.end_time - next_output) <= eps_t ? next_output : rc_.end_time;
    const double to_target = std::min(next_output, end) - t;
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
      os << hl.reason << ": " << hl.quantity << " = " << hl.value;
      if (hl.where.empty()) os << " at x = " << hl.x << " m";
      else os << " " << hl.where;
      os << ", in the step from t = " << t << " s with dt = " << dt << " s";
      // a limit of the scene (hl.limit: the top of the 2D box) stops the run like a divergence,
      // but says what it is
      return hl.limit ? stop_diverged("stopped", "run stopped at a limit of the scene: ", os.str())
                      : stop_diverged("diverged", "run diverged: ", os.str());
    }
    last_good_mass_ = model_->mass_balance();  // what the summary reports if the step is rejected
    model_->accept();
    last_dt_ = dt;
    // A speed far above what the scene's energy allows: the discretisation has failed. The
    // step is rejected: not written (the last output and checkpoint stay), and neither its
    // speed nor its time enter summary.json's max_speed, final_time and steps (an independent
    // run found the rejected step's 2.0133 m/s reported as the run's fastest accepted state).
    const Speed sp = model_->max_speed();
    if (const double lim = rc_.effective_speed_limit(); lim > 0.0 && sp.value > lim) {
      rejected_from_ = t;
      rejected_dt_ = dt;
      std::ostringstream os;
      os << "material speed above the limit (" << rc_.speed_limit_source() << ": " << lim
         << " m/s): " << sp.quantity << " = " << sp.value << " m/s at x = " << sp.x
         << " m, z = " << sp.z << " m, in the step from t = " << t << " s with dt = " << dt
         << " s";
      return stop_diverged("diverged", "run diverged: ", os.str());
    }
    track_speed(sp);
    // between accepted steps: the model may change its layout (the domain manager)
    const auto t3 = Clock::now();
    try {
      model_->adapt();
    } catch (const params::InputError&) {
      throw;
    } catch (const std::exception& e) {
      // a layout change that failed (a conversion fault): the state is not to be trusted, so
      // nothing of it is written; the outputs and checkpoint of the last output time stay
      std::ostringstream os;
      os << "layout change after the step to t = " << model_->time() << " s failed: " << e.what();
      write_summary("failed", os.str(), kRuntimeError);
      if (io_rank())
        std::cerr << "\ngranflow: error: " << os.str()
                  << "; the last good output and checkpoint are kept in " << rc_.directory << "\n";
      return kRuntimeError;
    }
    phase_seconds_["layout"] += std::chrono::duration<double>(Clock::now() - t3).count();
    sample_wall();
    if (model_->time() >= next_output - eps_t) {
      write_output();
      next_output = output_time(++next_index_);
    }
    show_progress(false, false);
  }
  if (outputs_ == 0 || std::abs(model_->time() - last_output_t_) > eps_t)
    write_output();  // final state if the end time is not an output time
  show_progress(true, false);
  write_summary("completed", "reached the end time", kOk);
  warn_above_energy_bound();
  return kOk;
}

// A run that completes with a material speed above the scene's energy bound (below the speed
// limit, which stops it) says so: no parcel can fall that fast, so the speed is energy that
// pressure work moved between parcels (a wall-impact jet) or that the scheme made. An
// independent run (session 37) completed a Bingham chute at 1.16 times the bound, with a
// pressure field of +-600 kPa in a 5 cm layer, without a word.
void Simulation::warn_above_energy_bound() const {
  if (!(rc_.energy_bound > 0.0) || !(max_speed_.value > rc_.energy_bound) || !io_rank()) return;
  std::ostringstream os;
  os.precision(3);
  os << "granflow: warning: the fastest material speed, " << max_speed_.value << " m/s (t = "
     << max_speed_t_ << " s, x = " << max_speed_.x << " m, z = " << max_speed_.z
     << " m), is " << max_speed_.value / rc_.energy_bound
     << " times the scene's energy bound " << rc_.energy_bound
     << " m/s (u_0 + sqrt(2 g (L |sin zeta| + H cos zeta)), the speed of a parcel that "
        "fell the whole box without friction): a jet driven by pressure (a wall impact) or a "
        "numerical defect; check the fields there (summary.json max_speed; docs/validation.md, "
        "'What the failing cases show')\n";
  std::cerr << os.str();
}

}  // namespace granflow::core
