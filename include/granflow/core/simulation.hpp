#pragma once
// The run driver: advances any Stepper to the end time, writes the output contract
// (profiles.csv, fields.h5/.xdmf, checkpoint.h5, summary.json), shows a progress line, and stops
// a diverging run with a diagnosis while keeping its last good output and checkpoint.
#include "granflow/core/stepper.hpp"

#include <Teuchos_ParameterList.hpp>

#include <chrono>
#include <map>
#include <memory>
#include <string>

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

  static Teuchos::RCP<const Teuchos::ParameterList> getValidTimeParameters();
  static Teuchos::RCP<const Teuchos::ParameterList> getValidOutputParameters();
  static RunControl from_parameters(const Teuchos::ParameterList& time,
                                    const Teuchos::ParameterList& output,
                                    const std::string& scene_dir);
};

/// Exit codes of a run (also documented in README.md).
enum ExitCode : int {
  kOk = 0,
  kUsage = 1,
  kInputError = 2,
  kDiverged = 3,
  kRuntimeError = 4,
  kStepLimit = 5
};

class Simulation {
 public:
  Simulation(std::string scene_name, const Teuchos::ParameterList& validated,
             std::unique_ptr<Stepper> model, RunControl rc);
  /// Run to the end time; returns an ExitCode. summary.json is written in every case.
  int run();
  const Stepper& model() const { return *model_; }

 private:
  void write_output();
  void write_summary(const std::string& status, const std::string& reason, int code) const;
  void show_progress(bool final);

  std::string scene_name_;
  const Teuchos::ParameterList& params_;
  std::unique_ptr<Stepper> model_;
  RunControl rc_;
  double t0_ = 0.0;
  std::chrono::steady_clock::time_point wall0_, last_progress_;
  std::map<std::string, double> phase_seconds_;
  int outputs_ = 0;
  double last_output_t_ = 0.0;
  double last_dt_ = 0.0;
  struct Io;
  std::shared_ptr<Io> io_;
};

}  // namespace granflow::core
