#pragma once
// The run driver: advances any Stepper to the end time, writes the output contract
// (profiles.csv, fields.h5/.xdmf, checkpoint.h5, summary.json, run.json, and wall.csv, the load
// on the end wall at every accepted step), shows a progress line,
// stops a diverging run with a diagnosis while keeping its last good output and checkpoint, and
// ends an interrupted run (SIGINT, SIGTERM) after the step in progress with a checkpoint.
// A run owns its directory (core/run_record.hpp): it refuses one that holds another scene's
// files, replaces an earlier run of the same scene, and a restart cuts the outputs back to the
// checkpoint time.
#include "granflow/core/stepper.hpp"

#include <Teuchos_ParameterList.hpp>
#include <nlohmann/json_fwd.hpp>

#include <chrono>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace granflow::core {

/// "Time" and "Output" sublists.
struct RunControl {
  double end_time = 1.0;
  double max_dt = 1.0e-2;
  double min_dt = 1.0e-12;
  long max_steps = 100000000;
  std::string directory = "output";
  double output_interval = 0.05;
  bool fields = true;
  bool checkpoint = true;
  bool progress = true;
  std::string restart_from;
  std::string scene_dir;  ///< the scene file's directory (relative input file names)
  /// [s] wall.csv / summary.json: the impact peak is the largest load within this time after
  /// the material first reaches the end wall (later the growing deposit's load can exceed it)
  double impact_window = 0.05;
  bool overwrite = false;  ///< command line --overwrite: replace another scene's files
  /// [m/s] 'Time->Speed limit': a material speed above it stops the run as diverged (exit 3);
  /// 0: kSpeedLimitFactor times energy_bound, where the scene has one
  double speed_limit = 0.0;
  /// [m/s] the scene's energy bound (scene::energy_speed_bound; 0: none, e.g. a periodic
  /// channel), set by the application
  double energy_bound = 0.0;
  /// The speed above which the run stops (0: no limit) and what set it.
  double effective_speed_limit() const;
  std::string speed_limit_source() const;

  static Teuchos::RCP<const Teuchos::ParameterList> getValidTimeParameters();
  static Teuchos::RCP<const Teuchos::ParameterList> getValidOutputParameters();
  static RunControl from_parameters(const Teuchos::ParameterList& time,
                                    const Teuchos::ParameterList& output,
                                    const std::string& scene_dir);
};

/// 'Time->Speed limit' = 0 stops a run whose fastest material speed exceeds this many times
/// the scene's energy bound u_0 + sqrt(2 g (L |sin zeta| + H cos zeta)). The bound holds for
/// every particle in the absence of pressure work; impact jets and pressure-driven fronts were
/// measured at up to 2.2 times it (the ghost-fluid option at 65 deg, a dam-break front sqrt(2)
/// times), a failed discretisation at 12-460 times (a 2D part narrower than the deposit at a
/// wall: 58-2180 m/s against 4.7; docs/validation.md).
inline constexpr double kSpeedLimitFactor = 5.0;

/// Exit codes of a run (also documented in README.md).
enum ExitCode : int {
  kOk = 0,
  kUsage = 1,
  kInputError = 2,
  kDiverged = 3,
  kRuntimeError = 4,
  kStepLimit = 5,
  /// Interrupted by a signal: 128 + the signal number (130 SIGINT, 143 SIGTERM), the shell's
  /// convention for "ended by signal N", so that scripts and schedulers see an interruption;
  /// summary.json (status "interrupted") and checkpoint.h5 tell it from a kill.
  kInterruptedBase = 128
};

/// Record SIGINT and SIGTERM from now on (the application calls it before building the model,
/// which can take long): Simulation::run() then stops before its first step with a checkpoint
/// of the initial (or restart) state. A second signal takes the default action.
void catch_interrupts();

/// Checks done before anything is built or written, also by `granflow --check`: a restart's
/// checkpoint is readable, intact, of this scene and before the end time; the run directory may
/// be written (it holds no other scene's files, or rc.overwrite). Throws params::InputError.
void preflight(const Teuchos::ParameterList& validated, const RunControl& rc);

class Simulation {
 public:
  Simulation(std::string scene_name, const Teuchos::ParameterList& validated,
             std::unique_ptr<Stepper> model, RunControl rc);
  /// Run to the end time; returns an ExitCode. summary.json is written in every case.
  int run();
  const Stepper& model() const { return *model_; }
  /// Where the run ended, as summary.json says: before a step the speed limit rejected
  double final_time() const { return rejected_from_ >= 0.0 ? rejected_from_ : model_->time(); }
  long final_steps() const { return model_->steps() - (rejected_from_ >= 0.0 ? 1 : 0); }
  MassBalance final_mass_balance() const {
    return rejected_from_ >= 0.0 ? last_good_mass_ : model_->mass_balance();
  }
  /// Build provenance for summary.json (version, commit, build type, compiler, Trilinos),
  /// given by the application, which is the only target that compiles the generated file.
  void set_build_info(std::map<std::string, std::string> info) { build_info_ = std::move(info); }
  /// The scene's memory estimate of the ranks on this node [B] (scene/memory.hpp), reported in
  /// summary.json beside the measured peak.
  void set_memory_estimate(double bytes) { memory_estimate_ = bytes; }

 private:
  int advance(const io::Checkpoint& restart);
  void write_output();        // write_output_files(); a failed write stops the run (exit 4)
  void write_output_files();
  void sample_wall();
  nlohmann::json wall_summary() const;
  void write_checkpoint();
  /// A run stopped between steps (a signal, 'Max steps'): the last accepted state into
  /// checkpoint.h5 (also with 'Checkpoint' = false: it is what a restart needs), timed as output.
  void checkpoint_stopped_state();
  int interrupted(int signal);
  void write_summary(const std::string& status, const std::string& reason, int code);
  void show_progress(bool final, bool at_output);

  std::string scene_name_;
  const Teuchos::ParameterList& params_;
  std::unique_ptr<Stepper> model_;
  RunControl rc_;
  double t0_ = 0.0;
  std::chrono::steady_clock::time_point wall0_, last_progress_;
  /// CPU seconds of this process (user + system) when run() began: the start-up before it (MPI,
  /// the scene's validation, the models' set-up) is not the method's cost (cpu_time.run_seconds)
  double cpu0_ = 0.0;
  std::map<std::string, double> phase_seconds_;
  int outputs_ = 0;
  /// the layout at each output where it changed (time, pieces)
  std::vector<std::pair<double, std::vector<LayoutPiece>>> layouts_;
  double last_output_t_ = 0.0;
  double last_dt_ = 0.0;
  /// stderr: the run's fastest material speed above RunControl::energy_bound, if it is
  void warn_above_energy_bound() const;
  Speed max_speed_;          ///< fastest material velocity over the accepted states so far
  double max_speed_t_ = 0.0;  ///< its time
  /// A step that the speed limit rejected after the model took it: its start time, and the
  /// summary reports the run as ending there (final_time, steps), not after it (-1: none)
  double rejected_from_ = -1.0;
  double rejected_dt_ = 0.0;
  MassBalance last_good_mass_;  ///< the mass balance before the latest step (of the last accepted state)
  void track_speed();
  void track_speed(const Speed& s);  ///< record a speed the caller has measured
  int stop_diverged(const std::string& status, const std::string& headline,
                    const std::string& reason);
  long last_progress_step_ = -1;
  double origin_ = 0.0;   ///< time of the scene's start; outputs at origin + k Interval
  long next_index_ = 1;   ///< k of the next output time
  bool restarted_ = false;
  bool continued_ = false;  ///< a restart that continues its directory's own history
  double restart_time_ = 0.0;
  /// every restart of the run so far, in order (JSON text: time, checkpoint, changed
  /// parameters), kept in the checkpoint so that a chain of restarts reports all of them
  std::string restarts_ = "[]";
  /// the field output's run id of the checkpoint restarted from ("" for none)
  std::string fields_id_;
  std::vector<std::string> canonical_;  ///< validated parameters (run_record.hpp)
  std::string identity_;
  std::vector<std::string> files_;      ///< files this run (and its earlier parts) wrote
  std::map<std::string, std::string> build_info_;
  double memory_estimate_ = 0.0;
  struct MemorySample {
    double t, resident, peak, heap, material;  ///< [s], [B], [B], [B], [m^2]
  };
  std::vector<MemorySample> memory_samples_;  ///< at each output (summary.json "memory")
  struct Io;
  std::shared_ptr<Io> io_;
};

}  // namespace granflow::core
