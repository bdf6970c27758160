// The run's files on a full disk (io::write_file_atomic, io::write_checkpoint): a write that
// fails keeps the previous file and says why. An independent run (session 40) filled a 2 MB
// file system: fields.xdmf was cut inside its XML (a failed write renamed over the good index),
// summary.json left at 0 bytes, and HDF5's failed flush of checkpoint.h5.tmp crashed the
// process at exit. The run now checks the room before each output (cli.full_disk_stops_with_a_
// summary), so these paths are reached only when the disk fills between that check and the
// write; here they are reached on purpose: the temporary file is a link to /dev/full, whose
// writes fail with ENOSPC.
#include "granflow/io/fields.hpp"
#include "granflow/io/output.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

using namespace granflow;
namespace fs = std::filesystem;

namespace {

// a scratch directory under the system's temporary directory (the tests wrote into the
// current directory, and a run from the repository's root left them there)
std::string scratch(const std::string& name) {
  return (fs::temp_directory_path() / ("granflow_" + name + "_" + std::to_string(::getpid())))
      .string();
}

std::string slurp(const std::string& f) {
  std::ifstream in(f, std::ios::binary);
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

// a fresh directory with `name`.tmp linked to /dev/full (false: no /dev/full here)
bool full_disk_for(const std::string& dir, const std::string& name) {
  if (!fs::exists("/dev/full")) return false;
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::create_symlink("/dev/full", dir + "/" + name + ".tmp");
  return true;
}

}  // namespace

TEST(OutputFiles, AFailedWriteKeepsThePreviousFileAndSaysWhy) {
  const std::string dir = scratch("test_io_atomic");
  if (!full_disk_for(dir, "summary.json")) GTEST_SKIP() << "no /dev/full";
  const std::string file = dir + "/summary.json";
  {
    std::ofstream(file) << "{\"status\": \"running\"}\n";
  }
  const std::string big(1 << 16, 'x');  // beyond stdio's buffer: fwrite itself fails
  for (const std::string& text : {std::string("{\"status\": \"completed\"}\n"), big}) {
    try {
      io::write_file_atomic(file, text);
      ADD_FAILURE() << "a write to /dev/full succeeded";
    } catch (const std::runtime_error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("No space left on device"), std::string::npos) << m;
      EXPECT_NE(m.find("its previous version is kept"), std::string::npos) << m;
      EXPECT_NE(m.find(file), std::string::npos) << m;
    }
    EXPECT_EQ(slurp(file), "{\"status\": \"running\"}\n");  // untouched
    EXPECT_FALSE(fs::exists(fs::symlink_status(file + ".tmp")));  // nothing left behind
    fs::create_symlink("/dev/full", file + ".tmp");
  }
  // and where nothing fails, the new text replaces the old one
  fs::remove(file + ".tmp");
  io::write_file_atomic(file, "{}\n");
  EXPECT_EQ(slurp(file), "{}\n");
  fs::remove_all(dir);
}

TEST(OutputFiles, AWriteIntoAMissingDirectoryNamesTheFile) {
  const std::string file = scratch("test_io_missing_dir") + "/sub/run.json";
  fs::remove_all(scratch("test_io_missing_dir"));
  try {
    io::write_file_atomic(file, "{}");
    ADD_FAILURE() << "a write into a missing directory succeeded";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("cannot write '" + file + "': No such file or directory"), std::string::npos)
        << m;
  }
}

// The checkpoint is built in memory and written as one image: a full disk fails in that write,
// the last checkpoint stays readable (a restart from it is what the stop promises), and HDF5
// holds no file open afterwards (the process crashed at exit before).
TEST(OutputFiles, ACheckpointThatCannotBeWrittenKeepsTheLastOne) {
  const std::string dir = scratch("test_io_checkpoint");
  if (!full_disk_for(dir, "checkpoint.h5")) GTEST_SKIP() << "no /dev/full";
  const std::string file = dir + "/checkpoint.h5";
  fs::remove(file + ".tmp");
  io::Checkpoint first;
  first.set("run/time", 0.5);
  first.set("markers", std::vector<double>(20000, 1.25));  // 160 kB: larger than any buffer
  first.set_text("scene", "first");
  io::write_checkpoint(file, first);
  fs::create_symlink("/dev/full", file + ".tmp");
  io::Checkpoint second = first;
  second.set("run/time", 0.75);
  try {
    io::write_checkpoint(file, second);
    ADD_FAILURE() << "a checkpoint was written to /dev/full";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(fs::symlink_status(file + ".tmp")));
  const auto back = io::read_checkpoint(file);
  EXPECT_EQ(back.scalar("run/time"), 0.5);
  EXPECT_EQ(back.array("markers"), first.array("markers"));
  EXPECT_EQ(back.text("scene"), "first");
  // the next checkpoint, with room again, replaces it
  io::write_checkpoint(file, second);
  EXPECT_EQ(io::read_checkpoint(file).scalar("run/time"), 0.75);
  fs::remove_all(dir);
}

// A field snapshot that cannot be written (the disk filled between the room check and the
// write; an independent run, session 40: HDF5's own write of fields.h5 failed, and the process
// crashed in HDF5's shutdown at exit, 139). Each snapshot is now built in memory and written as
// its own file of fields.h5.d by a checked write; fields.h5 is the index of links to them. The
// failed snapshot leaves nothing behind, the index and fields.xdmf list the earlier ones, the
// next snapshot is written when there is room again, and the test binary ends normally.
TEST(OutputFiles, AFieldSnapshotThatCannotBeWrittenKeepsTheEarlierOnes) {
  const std::string dir = scratch("test_io_fields");
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  fs::remove_all(dir);
  fs::create_directories(dir);
  io::Hdf5FieldOutput out;
  out.open(dir);
  auto snapshot = [](double t) {
    io::FieldWriter w;
    auto& m = w.add_mesh("ndam", {0.0, 0.5, 1.0}, {0.0, 0.25, 0.5});
    m.cell_fields.emplace_back("h", std::vector<double>{t, t + 1, t + 2, t + 3});
    return w;
  };
  out.write(0.0, snapshot(0.0));
  out.write(0.1, snapshot(0.1));
  const std::string tmp = dir + "/fields.h5.d/step_000002.h5.tmp";
  fs::create_symlink("/dev/full", tmp);
  try {
    out.write(0.2, snapshot(0.2));
    ADD_FAILURE() << "a snapshot was written to /dev/full";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("cannot write '" + dir + "/fields.h5.d/step_000002.h5': No space left on device"),
              std::string::npos)
        << m;
  }
  EXPECT_FALSE(fs::exists(fs::symlink_status(tmp)));
  EXPECT_FALSE(fs::exists(dir + "/fields.h5.d/step_000002.h5"));
  EXPECT_EQ(out.snapshots(), 2);
  {
    const io::FieldReader r(dir + "/fields.h5");
    ASSERT_EQ(r.size(), 2u);
    EXPECT_EQ(r.time(1), 0.1);
    const auto meshes = r.read(1);
    ASSERT_EQ(meshes.size(), 1u);
    EXPECT_EQ(meshes[0].cell_fields.at(0).second, (std::vector<double>{0.1, 1.1, 2.1, 3.1}));
  }
  const std::string xdmf = slurp(dir + "/fields.xdmf");
  EXPECT_NE(xdmf.find("fields.h5.d/step_000001.h5:/ndam/h"), std::string::npos);
  EXPECT_EQ(xdmf.find("step_000002"), std::string::npos);
  // the snapshot's file written, the index's write failing: the file goes again (fields.h5.d
  // holds what the index lists), the old index stays
  fs::create_symlink("/dev/full", dir + "/fields.h5.tmp");
  EXPECT_THROW(out.write(0.2, snapshot(0.2)), std::runtime_error);
  EXPECT_FALSE(fs::exists(dir + "/fields.h5.d/step_000002.h5"));
  EXPECT_FALSE(fs::exists(fs::symlink_status(dir + "/fields.h5.tmp")));
  EXPECT_EQ(io::FieldReader(dir + "/fields.h5").size(), 2u);
  // room again: the output goes on
  out.write(0.2, snapshot(0.2));
  const io::FieldReader r(dir + "/fields.h5");
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r.read(2)[0].cell_fields.at(0).second, (std::vector<double>{0.2, 1.2, 2.2, 3.2}));
  fs::remove_all(dir);
}
