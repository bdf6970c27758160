#pragma once
// The output contract (DESIGN.md section 6) of a run directory:
//   profiles.csv   t, x, h, u_mean, eps, model  (depth-averaged in every model)
//   fields.h5      one group per snapshot, cell fields on rectilinear meshes
//   fields.xdmf    temporal collection over fields.h5 that ParaView opens; rewritten after each
//                  snapshot so that a run that stops early leaves a readable file
//   checkpoint.h5  the last good state (written atomically: temporary file, then rename)
//   summary.json   written by the run driver
#include "granflow/core/stepper.hpp"
#include "granflow/io/fields.hpp"

#include <fstream>
#include <string>
#include <vector>

namespace granflow::io {

class ProfileWriter {
 public:
  ProfileWriter() = default;
  /// Opens (truncates, or appends when `append`) `dir`/profiles.csv.
  void open(const std::string& dir, bool append);
  void write(double t, const core::Profile& p);

 private:
  std::ofstream out_;
};

class Hdf5FieldOutput {
 public:
  Hdf5FieldOutput() = default;
  /// `append`: keep the snapshots already in `dir`/fields.h5 (restart).
  void open(const std::string& dir, bool append);
  void write(double t, const FieldWriter& fields);
  int snapshots() const { return static_cast<int>(times_.size()); }

 private:
  void write_xdmf() const;
  std::string dir_;
  std::vector<double> times_;
  std::vector<std::vector<FieldWriter::Mesh>> layouts_;  // meshes of each snapshot
};

void write_checkpoint(const std::string& file, const Checkpoint& c);
Checkpoint read_checkpoint(const std::string& file);

}  // namespace granflow::io
