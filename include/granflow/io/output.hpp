#pragma once
// The output contract (DESIGN.md section 6) of a run directory:
//   profiles.csv   t, x, h, u_mean, eps, model  (depth-averaged in every model)
//   wall.csv       t, force, normal_force, shear, p_foot, depth, contact: the load on the end
//                  wall at every accepted step (models that end at a wall, core::WallLoad)
//   fields.h5      the snapshots' index: one external link per snapshot, step_NNNNNN ->
//                  fields.h5.d/step_NNNNNN.h5 (HDF5 readers follow it as a group)
//   fields.h5.d/   one file per snapshot: the attribute time, a group per mesh with its node
//                  coordinates and cell fields on the rectilinear mesh
//   fields.xdmf    temporal collection over fields.h5 that ParaView opens; rewritten after each
//                  snapshot so that a run that stops early leaves a readable file
//   checkpoint.h5  the last good state (written atomically: temporary file, then rename), with
//                  texts (the validated scene) and a checksum of everything in it
//   summary.json, run.json   written by the run driver
// HDF5's own error printing is switched off: every failure becomes an exception whose message
// says which file and what HDF5 reported, and the caller decides what the user sees.
#include "granflow/core/stepper.hpp"
#include "granflow/io/fields.hpp"

#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace granflow::io {

/// A checkpoint that cannot be used: not readable as HDF5 (truncated, not a checkpoint), written
/// by a granflow without the scene record, or with data that do not match its checksum.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ProfileWriter {
 public:
  ProfileWriter() = default;
  /// Opens `dir`/profiles.csv: a new file, or (`keep_until` finite, a restart) the existing one
  /// cut after its last row with t <= keep_until (+ round-off), so that a restart from a
  /// checkpoint at keep_until never repeats the rows of later output times.
  void open(const std::string& dir, double keep_until = -1.0);
  /// Throws std::runtime_error naming the file and the system's reason when the rows cannot
  /// be written (a full disk: the run stops, its last checkpoint kept).
  void write(double t, const core::Profile& p);

 private:
  std::ofstream out_;
  std::string file_;
};

/// wall.csv: the load on the end wall (core::WallLoad) at the initial state and after every
/// accepted step, and the extremes of the series for summary.json.
class WallWriter {
 public:
  /// A quantity's extremes over the samples in contact (the wall column holds a cell height
  /// of material; t_max < 0: no such sample yet), its largest value in the impact window, and
  /// its last value. Samples before the contact are left out of max and min: a film thinner
  /// than a cell at the wall carries the viscous normal stress 2 nu_eff u_x of a cell it barely
  /// fills, up to 20 times the impact's load (5.2 kN/m against 246 N/m measured on Setup II).
  struct Extreme {
    double max = 0.0, t_max = -1.0, min = 0.0, t_min = -1.0, last = 0.0;
    double impact = 0.0, t_impact = -1.0;  ///< largest value in the impact window
    void add(double t, double v, bool contact, bool impact_window);
  };
  struct Series {
    long samples = 0;
    double t_first = 0.0, t_last = 0.0;
    double t_contact = -1.0;  ///< first sample with WallLoad::contact (-1: none yet)
    Extreme force, normal, shear, p_foot, depth;
  };
  WallWriter() = default;
  /// Opens `dir`/wall.csv: a new file, or (`keep_until` >= 0, a restart) the existing one cut
  /// after its last row with t <= keep_until (+ round-off); the series statistics then start
  /// from the rows kept, so that summary.json of a restarted run covers the whole run.
  /// The impact window: [t_contact, t_contact + impact_window].
  void open(const std::string& dir, double keep_until = -1.0, double impact_window = 0.05);
  /// Appends a row (buffered: flush() at output times, checkpoints and the end of the run).
  void write(double t, const core::WallLoad& w);
  void flush();
  const Series& series() const { return series_; }
  /// The series' statistics as numbers for the checkpoint, and back: a restart into another
  /// directory has no earlier rows to read, and takes the statistics from its checkpoint.
  std::vector<double> state() const;
  void restore(const std::vector<double>& state);

 private:
  void add(double t, const core::WallLoad& w);
  std::ofstream out_;
  std::string file_;
  Series series_;
  double impact_window_ = 0.05;
};

class Hdf5FieldOutput {
 public:
  Hdf5FieldOutput() = default;
  /// Opens `dir`/fields.h5: a new file, or (`keep_until` >= 0, a restart) the existing one with
  /// the snapshots after keep_until (+ round-off) removed, and the XDMF index rewritten to match.
  /// `expected_id`: the run id the checkpoint recorded (a restart): an index or snapshot file
  /// of another id is not taken as this run's.
  void open(const std::string& dir, double keep_until = -1.0,
            const std::string& expected_id = "");
  void write(double t, const FieldWriter& fields);
  const std::string& run_id() const { return run_id_; }
  int snapshots() const { return static_cast<int>(times_.size()); }

 private:
  void write_xdmf() const;
  std::string dir_;
  std::vector<double> times_;
  std::vector<std::string> names_;                       // group of each snapshot
  std::vector<std::vector<FieldWriter::Mesh>> layouts_;  // meshes of each snapshot
  std::size_t next_index_ = 0;                           // step_NNNNNN of the next snapshot
  mutable std::size_t xdmf_bytes_ = 0;                   // size of the index last written
  std::string run_id_;  // in fields.h5 and every snapshot's file (FieldReader checks it)
};

/// Reads the snapshots of a run's fields.h5 (granflow-study budget): their times, and one
/// snapshot's meshes with all their cell fields. Throws std::runtime_error naming the file.
class FieldReader {
 public:
  explicit FieldReader(const std::string& file);
  std::size_t size() const { return times_.size(); }
  /// Snapshots in time order.
  double time(std::size_t i) const { return times_.at(i); }
  std::vector<FieldWriter::Mesh> read(std::size_t i) const;

 private:
  std::string file_;
  std::vector<double> times_;
  std::vector<std::string> groups_;
};

/// Room (bytes, at least 64 kB) that an output must leave free on its file system for what a
/// stop writes (summary.json, run.json): the rows and snapshots check it before they are
/// written, and a full disk stops the run while its summary still fits.
void set_stop_reserve(std::uintmax_t bytes);
/// Holds that room in an unlinked file of `dir` (allocated with posix_fallocate, grown with
/// set_stop_reserve; the kernel frees it however the process ends), so that a disk that another
/// process has filled still has it when the run stops: another process took it before, and 4 of
/// 7 such stops left no summary (an independent run). The room checks count the held bytes
/// (the file's blocks) as kept. Never throws.
void hold_stop_reserve(const std::string& dir);
/// Frees the held room just before the stop writes its summary.
void release_stop_reserve();

/// Creates and removes a file in `dir`: 0 when the run can write there, else the errno.
int write_probe(const std::string& dir);

/// Writes `file` atomically: the bytes go to file.tmp, which replaces `file` only once every
/// byte is written, synced to the disk (fsync) and closed; otherwise file.tmp is removed, `file` stays as it was, and
/// std::runtime_error names the file and the system's reason (e.g. "No space left on device").
void write_file_atomic(const std::string& file, const void* data, std::size_t size);
inline void write_file_atomic(const std::string& file, const std::string& text) {
  write_file_atomic(file, text.data(), text.size());
}

/// Writes `file` atomically (write_file_atomic) with a checksum over every entry. The HDF5 file
/// is built in memory and written as one image, so that a full disk fails in our write (the
/// old checkpoint kept, a message) and never inside the HDF5 library, whose failed flush left
/// a file handle that crashed the process at exit (an independent run, session 40).
void write_checkpoint(const std::string& file, const Checkpoint& c);
/// Reads and verifies a checkpoint; throws CheckpointError with a message for the user when the
/// file is unreadable, has no checksum (older format) or its data do not match the checksum.
Checkpoint read_checkpoint(const std::string& file);
/// FNV-1a (64 bit) over the keys and the bytes of the values of all entries: detects truncation
/// and flipped bytes; not a cryptographic hash.
std::uint64_t checksum(const Checkpoint& c);

/// Whether the field output in run directory `dir` (fields.h5, then its snapshot files) carries
/// run id `id`; `any_id`: whether any of them carries an id at all (files before ids do not).
bool field_output_has_id(const std::string& dir, const std::string& id, bool& any_id);

/// Refuses (std::runtime_error naming it) a run directory `dir` whose fields.h5.d is a link to
/// a directory that does not exist or that holds another run's snapshots.
void check_field_snapshots(const std::string& dir);

/// Removes the snapshot files (step_NNNNNN.h5) of a run's fields.h5.d, and the directory when
/// it is then empty (a link to a directory elsewhere is kept).
void remove_field_snapshots(const std::string& sdir);

/// Cut `dir`/fields.h5 and fields.xdmf (when they exist) back to the snapshots at t <= t_keep.
void truncate_fields(const std::string& dir, double t_keep);

/// "major.minor.release" of the HDF5 library linked in (for summary.json).
std::string hdf5_version();

}  // namespace granflow::io
