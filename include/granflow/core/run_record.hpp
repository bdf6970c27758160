#pragma once
// What a run records about itself so that its outputs cannot be mixed with another scene's:
//
//  - the validated parameter list as canonical text, one "path (type) = value" line per
//    parameter, doubles with 17 significant digits (exact), sorted; stored in every checkpoint
//    and in the run directory's run.json;
//  - the scene identity: a hash of those lines without the parameters a restart may change
//    (restart_may_change()). Two runs of one identity are the same simulation: a restart
//    continues it, a rerun replaces its files; a run of another identity is a different scene;
//  - the run directory's manifest run.json (identity, the files the run wrote) with the rules
//    that decide whether a run may write into a directory (plan_directory()).
#include "granflow/io/fields.hpp"

#include <Teuchos_ParameterList.hpp>
#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

namespace granflow::core {

/// "path (type) = value" lines of a validated list, sorted by path ("Channel->Slope angle").
/// An input file the scene names (Channel->Left boundary->Inflow series file, relative to
/// `scene_dir`) adds a line "<parameter> content (fnv1a) = <hash of its bytes>": a restart
/// whose series file was edited is then another scene, as an edited parameter is.
std::vector<std::string> canonical_parameters(const Teuchos::ParameterList& validated,
                                              const std::string& scene_dir = "");

/// The parameters that may differ between a run and its restart: labels (Name, Description),
/// the whole Time and Output lists, and the linear and nonlinear solvers' tolerances,
/// iteration limits and verbosity. Everything else defines the simulation.
bool restart_may_change(const std::string& path);

/// Hash (FNV-1a 64, hex) of the canonical lines without the restart-changeable ones.
std::string scene_identity(const std::vector<std::string>& canonical);

/// Differences between the canonical lines of an earlier run (`theirs`) and this scene
/// (`ours`) in the parameters that define the simulation, as readable items
/// ("'Channel->Slope angle' = 45 there, 50 here"); empty when they are the same scene.
std::vector<std::string> scene_differences(const std::vector<std::string>& theirs,
                                           const std::vector<std::string>& ours);

/// A parameter that a restart changed (one of those restart_may_change allows), as readable
/// values ("" where the parameter is not set on that side, its default applying).
struct ParameterChange {
  std::string parameter, before, after;
};
/// The changes between checkpoint `c`'s scene and the restart's (`ours`) in the parameters a
/// restart may change, except 'Output->Restart from' itself.
std::vector<ParameterChange> restart_changes(const io::Checkpoint& c,
                                             const std::vector<std::string>& ours);

/// Checkpoint texts written and read by the run driver.
constexpr const char* kSceneKey = "run/scene";        ///< canonical lines, '\n'-joined
constexpr const char* kIdentityKey = "run/identity";  ///< scene_identity()
constexpr const char* kRestartsKey = "run/restarts";  ///< summary.json's restarts, as JSON
constexpr const char* kFieldsIdKey = "run/fields_id";  ///< the field output's run id

/// Checks that checkpoint `c` (read from `file`) continues this scene: same identity (else
/// an InputError naming 'Output->Restart from' and each differing parameter) and an end time
/// after the checkpoint's time. Returns the checkpoint's time.
double check_restart(const io::Checkpoint& c, const std::string& file,
                     const std::vector<std::string>& ours, double end_time);

/// The run directory's record, run.json.
struct RunManifest {
  std::string scene;     ///< Name
  std::string model;     ///< Model
  std::string identity;  ///< scene_identity()
  std::vector<std::string> parameters;  ///< canonical lines
  std::vector<std::string> files;       ///< names (in the directory) the run wrote
  std::string status;                   ///< running, completed, interrupted, ...
};

/// Every file name a granflow run may write into its directory (also by older versions).
const std::vector<std::string>& output_file_names();

/// What a run does to its directory before it writes anything.
struct DirectoryPlan {
  std::vector<std::string> remove;          ///< earlier files to delete (full paths)
  std::vector<std::string> earlier_files;   ///< an earlier run of this scene: its manifest files
  bool same_scene = false;                  ///< run.json of this identity found
  /// a restart that continues the directory's own run (its checkpoint lies in the directory):
  /// the earlier files stay, cut back to the checkpoint time; a restart into another
  /// directory starts that directory's files afresh (rows of another history are not kept)
  bool continued = false;
  /// Said on stderr when the run starts: a restart from a checkpoint outside the directory
  /// into a directory that holds this scene's run, whose files are therefore replaced
  std::string note;
};

/// Decide whether a run of identity `ours` (canonical lines `lines`) may write into `dir`:
///  - missing or empty directory (of granflow files): yes;
///  - run.json of the same identity: yes; a fresh run removes the earlier run's files (all of
///    them, including the ones this run does not write), a restart keeps them (the driver cuts
///    profiles and fields back to the checkpoint time);
///  - granflow files without run.json (a granflow before it): the same as a run.json of this
///    identity when their summary.json records these parameters (parameters_json(), without
///    the restart-changeable ones), else like another identity;
///  - run.json of another identity, or granflow files without run.json: only with
///    `overwrite` (then those files are removed); otherwise an InputError naming the directory,
///    the files and the differing parameters.
/// Never removes `keep` (the checkpoint a restart reads) or files granflow does not write.
/// Reads only; the caller removes plan.remove.
DirectoryPlan plan_directory(const std::string& dir, const std::string& ours,
                             const std::vector<std::string>& lines, bool overwrite,
                             bool restart, const std::string& keep,
                             const Teuchos::ParameterList& validated);

/// std::filesystem::create_directories that tries again when a parent directory vanishes under
/// it (ENOENT): runs started side by side in one working directory create and probe-remove
/// the same parent ("output"). Other errors are thrown as by create_directories.
void create_run_directories(const std::string& dir);

/// What `granflow --check` asks of the run directory beyond plan_directory: that the run could
/// create it and write into it. The missing part of the path is created and a probe file
/// written, then both are removed again (an existing directory is left as it was). Throws an
/// InputError naming 'Output->Directory' otherwise (a path under /proc, a read-only file
/// system, a file where a directory is needed, no permission).
void probe_directory(const std::string& dir);

/// The validated list as JSON (summary.json "parameters").
nlohmann::json parameters_json(const Teuchos::ParameterList& validated);

/// An exclusive lock (flock) on the run directory while this object lives: a second granflow
/// started on the same directory (the same scene by mistake, or another) is refused with an
/// InputError instead of deleting the files the first one writes. The kernel releases the lock
/// when the process ends, however it ends. A directory that does not exist is not locked.
class DirectoryLock {
 public:
  explicit DirectoryLock(const std::string& dir);
  ~DirectoryLock();
  DirectoryLock(const DirectoryLock&) = delete;
  DirectoryLock& operator=(const DirectoryLock&) = delete;

 private:
  int fd_ = -1;
};

/// Writes `dir`/run.json atomically.
void write_manifest(const std::string& dir, const RunManifest& m);

}  // namespace granflow::core
