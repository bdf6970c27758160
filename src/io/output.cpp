#include "granflow/io/output.hpp"

#include "granflow/params/parameters.hpp"

#include <hdf5.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <random>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

namespace granflow::io {

namespace {
// Output times are compared with the round-off of t += dt (the run driver's tolerance).
bool after(double t, double t_keep) { return t > t_keep + 1e-9 * std::max(1.0, std::abs(t_keep)); }

// room kept on the disk for what a stop writes (set_stop_reserve)
std::uintmax_t g_stop_reserve = 64 * 1024;
// the room held (hold_stop_reserve): an unlinked file of the run directory, open as g_reserve_fd,
// so that the kernel frees it however the process ends (a named file was left behind by a
// killed run, and a restart then held more than it counted); its directory and bytes held
std::string g_reserve_dir;
int g_reserve_fd = -1;
std::uintmax_t g_reserve_held = 0;

// Grows the held room to g_stop_reserve; where the disk has no room for more, what it held stays
// held. Held counts the blocks the file has (a file system may answer fallocate with a sparse
// file, ZFS, or glibc's fallback may write zeros that a compressing one does not store).
void grow_reserve() {
  if (g_reserve_fd < 0 || g_reserve_held >= g_stop_reserve) return;
  if (::posix_fallocate(g_reserve_fd, 0, static_cast<off_t>(g_stop_reserve)) != 0 &&
      ::ftruncate(g_reserve_fd, static_cast<off_t>(g_reserve_held)) != 0)
    g_reserve_held = 0;
  struct stat st {};
  if (::fstat(g_reserve_fd, &st) == 0)
    g_reserve_held = std::min<std::uintmax_t>(
        g_stop_reserve, static_cast<std::uintmax_t>(st.st_blocks) * 512u);
  else
    g_reserve_held = 0;  // not known: the room checks keep the whole reserve free
}

std::string kib(std::uintmax_t bytes) { return std::to_string((bytes + 1023) / 1024) + " kB"; }

// Before an output is written: a full disk stops the run while what the stop itself writes
// (summary.json, run.json, the index) still fits in `reserve` (an independent run on a 2 MB file
// system found a summary.json of 0 bytes). A disk that fills after the check fails the write
// itself, which keeps the previous file (write_file_atomic).
bool same_file_system(const std::string& a, const std::string& b);

void check_room(const std::string& dir, std::uintmax_t need, std::uintmax_t reserve,
                const std::string& what) {
  const std::uintmax_t kept = reserve;  // for the message: all that is kept
  // the part of the reserve that the reserve file already holds is not free any more
  if (g_reserve_held > 0 && reserve > 0 &&
      same_file_system(dir, g_reserve_dir))
    reserve -= std::min(reserve, g_reserve_held);
  struct statvfs st {};
  if (statvfs(dir.c_str(), &st) != 0) return;  // not known: the write itself reports a full disk
  const std::uintmax_t room = static_cast<std::uintmax_t>(st.f_bavail) * st.f_frsize;
  if (room < need + reserve)
    throw std::runtime_error("the file system of '" + dir + "' has " + kib(room) + " free; " +
                             what + " needs about " + kib(need) +
                             (kept > 0 ? " and " + kib(kept) +
                                                " are kept for the run's summary"
                                          : std::string()) +
                             ": free space there, or write fewer or smaller outputs "
                             "(Output->Interval, Output->Fields)");
}

// whether two existing paths lie on one file system (their room is then shared)
bool same_file_system(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  if (::stat(a.c_str(), &sa) != 0 || ::stat(b.c_str(), &sb) != 0) return true;
  return sa.st_dev == sb.st_dev;
}

// check_room for `file`, in the directory that holds it
void check_room_for(const std::string& file, std::uintmax_t need, const std::string& what) {
  const std::string dir = std::filesystem::path(file).parent_path().string();
  check_room(dir.empty() ? "." : dir, need, g_stop_reserve, what);
}

// "cannot write 'file': No space left on device" (errno of the failed call; 0: none known)
std::runtime_error write_error(const std::string& file, int err) {
  return std::runtime_error("cannot write '" + file + "'" +
                            (err != 0 ? std::string(": ") + std::strerror(err) : std::string()));
}

// Opens a CSV time series `file` with `header` for appending. keep_until < 0 (a fresh run):
// truncated to the header. A restart (keep_until >= 0 and the file exists): the header and the
// rows up to the checkpoint time are kept, in a new file that replaces the old one only once
// complete. `row_time(line, t)` parses a row's time; false for a row cut short by a killed run
// (skipped). `kept(line, t)` sees each kept row (may be empty).
void open_series(std::ofstream& out, const std::string& file, const char* header,
                 double keep_until, int precision,
                 const std::function<bool(const std::string&, double&)>& row_time,
                 const std::function<void(const std::string&, double)>& kept) {
  if (keep_until >= 0.0 && std::filesystem::exists(file)) {
    std::ifstream in(file);
    const std::string tmp = file + ".tmp";
    std::ofstream cut(tmp, std::ios::trunc);
    if (!cut) throw std::runtime_error("cannot write '" + tmp + "'");
    cut << header << '\n';
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      double t = 0.0;
      if (!row_time(line, t)) continue;  // a row cut short by a killed run
      if (after(t, keep_until)) break;   // rows are in time order
      cut << line << '\n';
      if (kept) kept(line, t);
    }
    cut.close();
    if (!cut) throw std::runtime_error("cannot write '" + tmp + "'");
    std::filesystem::rename(tmp, file);
    out.open(file, std::ios::app);
  } else {
    out.open(file, std::ios::trunc);
    if (out) out << header << '\n';
  }
  if (!out) throw write_error(file, errno);
  out << std::setprecision(precision);
}
}  // namespace

void set_stop_reserve(std::uintmax_t bytes) {
  g_stop_reserve = std::max<std::uintmax_t>(bytes, 64 * 1024);
  grow_reserve();
}

void hold_stop_reserve(const std::string& dir) {
  release_stop_reserve();
#ifdef O_TMPFILE
  g_reserve_fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
#endif
  if (g_reserve_fd < 0) {  // no O_TMPFILE here: a named file, unlinked at once
    const std::string f = dir + "/.granflow_reserve";
    g_reserve_fd = ::open(f.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
    if (g_reserve_fd >= 0) ::unlink(f.c_str());
  }
  if (g_reserve_fd < 0) return;  // nothing held: the room checks keep the whole reserve free
  g_reserve_dir = dir;
  g_reserve_held = 0;
  grow_reserve();
}

void release_stop_reserve() {
  if (g_reserve_fd >= 0) ::close(g_reserve_fd);
  g_reserve_fd = -1;
  g_reserve_held = 0;
  g_reserve_dir.clear();
}

int write_probe(const std::string& dir) {
  const std::string probe = dir + "/.granflow_check_" + std::to_string(::getpid());
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  const int err = fd < 0 ? errno : 0;
  if (fd >= 0) {
    ::close(fd);
    ::unlink(probe.c_str());
  }
  return err;
}

void write_file_atomic(const std::string& file, const void* data, std::size_t size) {
  const std::string tmp = file + ".tmp";
  errno = 0;
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw write_error(file, errno);
  int err = 0;
  if (std::fwrite(data, 1, size, f) != size) err = errno ? errno : EIO;
  if (std::fflush(f) != 0 && err == 0) err = errno ? errno : EIO;
  // On the disk before the rename makes it the file: a power loss or a crash of the machine
  // right after the rename could otherwise leave an empty or partial checkpoint where a whole
  // one was (about 1 ms a file on this machine's ext4). A special file (EINVAL, EROFS) has
  // nothing to sync.
  if (err == 0 && ::fsync(::fileno(f)) != 0 && errno != EINVAL && errno != EROFS) err = errno;
  if (std::fclose(f) != 0 && err == 0) err = errno ? errno : EIO;
  if (err == 0) {
    std::error_code ec;
    std::filesystem::rename(tmp, file, ec);
    if (!ec) {
      // and the rename itself (the directory's entry); a failure here leaves the new file in
      // place, so it is not an error of the write
      const std::string dir = std::filesystem::path(file).parent_path().string();
      const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
      if (fd >= 0) {
        ::fsync(fd);
        ::close(fd);
      }
      return;
    }
    err = ec.value();
  }
  std::error_code ignored;
  std::filesystem::remove(tmp, ignored);
  throw std::runtime_error("cannot write '" + file + "': " + std::strerror(err) +
                           (std::filesystem::exists(file, ignored)
                                ? " (its previous version is kept)"
                                : ""));
}

// ---------------------------------------------------------------------------------------------
// profiles.csv
// ---------------------------------------------------------------------------------------------
void ProfileWriter::open(const std::string& dir, double keep_until) {
  file_ = dir + "/profiles.csv";
  // a restart keeps the rows up to the checkpoint time (open_series)
  open_series(out_, file_, "t,x,h,u_mean,eps,model", keep_until, 10,
              [](const std::string& line, double& t) {
                char* end = nullptr;
                t = std::strtod(line.c_str(), &end);
                return end != line.c_str() && *end == ',';
              },
              nullptr);
}

void ProfileWriter::write(double t, const core::Profile& p) {
  std::ostringstream rows;
  rows.precision(out_.precision());
  for (std::size_t i = 0; i < p.x.size(); ++i)
    rows << t << ',' << p.x[i] << ',' << p.h[i] << ',' << p.u_mean[i] << ',' << p.eps[i] << ','
         << p.model[i] << '\n';
  const std::string text = rows.str();
  // room for the rows and for what the stop writes (summary.json, run.json): a full disk
  // stops the run while its summary can still be written
  check_room_for(file_, text.size(),
                 "writing the profiles at t = " + params::str(t) + " s (profiles.csv)");
  out_ << text;
  // A row that did not reach the disk stops the run (a full disk: the rows went on being
  // computed to the end, profiles.csv cut inside a row, and the run then blamed run.json; an
  // independent run). A restart from the last checkpoint cuts the file back to its time.
  errno = 0;
  out_.flush();
  if (!out_) throw write_error(file_, errno);
}

// ---------------------------------------------------------------------------------------------
// wall.csv
// ---------------------------------------------------------------------------------------------
void WallWriter::Extreme::add(double t, double v, bool contact, bool impact_window) {
  if (contact && (t_max < 0.0 || v > max)) max = v, t_max = t;
  if (contact && (t_min < 0.0 || v < min)) min = v, t_min = t;
  if (impact_window && (t_impact < 0.0 || v > impact)) impact = v, t_impact = t;
  last = v;
}

void WallWriter::add(double t, const core::WallLoad& w) {
  const bool first = series_.samples == 0;
  if (first) series_.t_first = t;
  series_.t_last = t;
  if (series_.t_contact < 0.0 && w.contact) series_.t_contact = t;
  const bool in = series_.t_contact >= 0.0 && t <= series_.t_contact + impact_window_;
  series_.force.add(t, w.force, w.contact, in);
  series_.normal.add(t, w.normal, w.contact, in);
  series_.shear.add(t, w.shear, w.contact, in);
  series_.p_foot.add(t, w.p_foot, w.contact, in);
  series_.depth.add(t, w.depth, w.contact, in);
  ++series_.samples;
}

void WallWriter::open(const std::string& dir, double keep_until, double impact_window) {
  series_ = Series{};
  impact_window_ = impact_window;
  // A restart keeps the rows up to the checkpoint time (open_series) and reads them back into
  // the series' statistics; they are written with 17 digits, so that the statistics read back
  // are the straight run's to the last bit.
  double v[7];
  auto parse = [&v](const std::string& line, double& t) {
    const char* c = line.c_str();
    for (int q = 0; q < 7; ++q) {
      char* end = nullptr;
      v[q] = std::strtod(c, &end);
      if (end == c || (q == 6 ? *end != '\0' : *end != ',')) return false;
      c = end + 1;
    }
    t = v[0];
    return true;
  };
  file_ = dir + "/wall.csv";
  open_series(out_, file_, "t,force,normal_force,shear,p_foot,depth,contact",
              keep_until, 17, parse, [&](const std::string&, double t) {
                add(t, core::WallLoad{v[1], v[2], v[3], v[4], v[5], v[6] != 0.0});
              });
}

void WallWriter::write(double t, const core::WallLoad& w) {
  out_ << t << ',' << w.force << ',' << w.normal << ',' << w.shear << ',' << w.p_foot << ','
       << w.depth << ',' << (w.contact ? 1 : 0) << '\n';
  // flushed by the caller's schedule (every output time and at the end): one flush per step
  // would be a system call per step
  add(t, w);
}

void WallWriter::flush() {
  errno = 0;
  out_.flush();
  if (!out_) throw write_error(file_, errno);
}

std::vector<double> WallWriter::state() const {
  std::vector<double> v{static_cast<double>(series_.samples), series_.t_first, series_.t_last,
                        series_.t_contact};
  for (const Extreme* e : {&series_.force, &series_.normal, &series_.shear, &series_.p_foot,
                           &series_.depth})
    v.insert(v.end(), {e->max, e->t_max, e->min, e->t_min, e->last, e->impact, e->t_impact});
  return v;
}

void WallWriter::restore(const std::vector<double>& v) {
  if (v.size() != 4 + 5 * 7)
    throw std::runtime_error("checkpoint: the wall series holds " + std::to_string(v.size()) +
                             " numbers; allowed: 39");
  series_.samples = static_cast<long>(v[0]);
  series_.t_first = v[1];
  series_.t_last = v[2];
  series_.t_contact = v[3];
  std::size_t q = 4;
  for (Extreme* e : {&series_.force, &series_.normal, &series_.shear, &series_.p_foot,
                     &series_.depth}) {
    e->max = v[q++], e->t_max = v[q++], e->min = v[q++], e->t_min = v[q++];
    e->last = v[q++], e->impact = v[q++], e->t_impact = v[q++];
  }
}

// ---------------------------------------------------------------------------------------------
// HDF5 helpers
// ---------------------------------------------------------------------------------------------
namespace {
// HDF5 prints its error stack to stderr by default; switch that off (once, before the first
// call) and put the innermost and outermost descriptions of the stack into our exceptions.
void quiet_hdf5() {
  static const bool done = [] {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    return true;
  }();
  (void)done;
}

herr_t collect_error(unsigned n, const H5E_error2_t* e, void* data) {
  auto* v = static_cast<std::vector<std::string>*>(data);
  std::string d = e->desc ? e->desc : "";
  if (d.empty() && e->func_name) d = e->func_name;
  if (!d.empty() && (v->empty() || v->back() != d)) v->push_back(d);
  (void)n;
  return 0;
}

std::string hdf5_error_text() {
  std::vector<std::string> stack;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, collect_error, &stack);
  H5Eclear2(H5E_DEFAULT);
  if (stack.empty()) return "";
  if (stack.size() == 1) return " (" + stack.front() + ")";
  return " (" + stack.front() + ": " + stack.back() + ")";
}

struct H5Handle {
  hid_t id;
  herr_t (*close)(hid_t);
  H5Handle(hid_t i, herr_t (*c)(hid_t), const std::string& what) : id(i), close(c) {
    if (id < 0) throw std::runtime_error("HDF5: cannot " + what + hdf5_error_text());
  }
  ~H5Handle() {
    if (id >= 0) close(id);
  }
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  H5Handle(H5Handle&& o) noexcept : id(o.id), close(o.close) { o.id = -1; }
};

// rows x cols values; a single row is a 1-D dataset unless `matrix` (cell fields keep the
// shape of their mesh's cells, nz x nx, so that the XDMF's declared shape is the dataset's and
// ParaView maps one value to each cell also for the 1D models' one-row strip).
void write_dataset(hid_t loc, const std::string& name, const std::vector<double>& v,
                   hsize_t rows, hsize_t cols, bool matrix = false) {
  hsize_t dims[2] = {rows, cols};
  const bool two = rows > 1 || matrix;
  H5Handle space(H5Screate_simple(two ? 2 : 1, two ? dims : dims + 1, nullptr),
                 H5Sclose, "dataspace for " + name);
  H5Handle ds(H5Dcreate2(loc, name.c_str(), H5T_IEEE_F64LE, space.id, H5P_DEFAULT, H5P_DEFAULT,
                         H5P_DEFAULT),
              H5Dclose, "create dataset " + name);
  if (!v.empty() &&
      H5Dwrite(ds.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    throw std::runtime_error("HDF5: cannot write " + name + hdf5_error_text());
}

std::vector<double> read_dataset(hid_t loc, const std::string& name) {
  H5Handle ds(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose, "open dataset " + name);
  H5Handle space(H5Dget_space(ds.id), H5Sclose, "space of " + name);
  const hssize_t n = H5Sget_simple_extent_npoints(space.id);
  if (n < 0) throw std::runtime_error("HDF5: cannot read the size of " + name + hdf5_error_text());
  std::vector<double> v(static_cast<std::size_t>(n));
  if (n > 0 && H5Dread(ds.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    throw std::runtime_error("HDF5: cannot read " + name + hdf5_error_text());
  return v;
}

// Strings: a scalar dataset (texts of the checkpoint) or attribute (its checksum) of a
// fixed-length, NUL-padded string type.
H5Handle string_type(std::size_t n) {
  H5Handle t(H5Tcopy(H5T_C_S1), H5Tclose, "copy the string type");
  H5Tset_size(t.id, std::max<std::size_t>(n, 1));
  H5Tset_strpad(t.id, H5T_STR_NULLPAD);
  return t;
}

void write_text(hid_t loc, const std::string& name, const std::string& v) {
  const auto type = string_type(v.size());
  H5Handle space(H5Screate(H5S_SCALAR), H5Sclose, "create a scalar space");
  H5Handle ds(H5Dcreate2(loc, name.c_str(), type.id, space.id, H5P_DEFAULT, H5P_DEFAULT,
                         H5P_DEFAULT),
              H5Dclose, "create dataset " + name);
  std::string buf = v.empty() ? std::string(1, '\0') : v;
  if (H5Dwrite(ds.id, type.id, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0)
    throw std::runtime_error("HDF5: cannot write " + name + hdf5_error_text());
}

std::string read_string(std::size_t size, const std::function<herr_t(hid_t, void*)>& rd,
                        const std::string& name) {
  const auto type = string_type(size);
  std::string buf(std::max<std::size_t>(size, 1), '\0');
  if (rd(type.id, buf.data()) < 0)
    throw std::runtime_error("HDF5: cannot read " + name + hdf5_error_text());
  buf.resize(std::min(std::strlen(buf.c_str()), buf.size()));  // drop the NUL padding
  return buf;
}

std::string read_text(hid_t loc, const std::string& name) {
  H5Handle ds(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose, "open dataset " + name);
  H5Handle ft(H5Dget_type(ds.id), H5Tclose, "read the type of " + name);
  if (H5Tget_class(ft.id) != H5T_STRING)
    throw std::runtime_error("HDF5: " + name + " is not a string");
  return read_string(
      H5Tget_size(ft.id),
      [&](hid_t t, void* b) { return H5Dread(ds.id, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, b); }, name);
}

void write_string_attr(hid_t loc, const std::string& name, const std::string& v) {
  const auto type = string_type(v.size());
  H5Handle space(H5Screate(H5S_SCALAR), H5Sclose, "create a scalar space");
  H5Handle a(H5Acreate2(loc, name.c_str(), type.id, space.id, H5P_DEFAULT, H5P_DEFAULT),
             H5Aclose, "create attribute " + name);
  if (H5Awrite(a.id, type.id, v.data()) < 0)
    throw std::runtime_error("HDF5: cannot write attribute " + name + hdf5_error_text());
}

std::string read_string_attr(hid_t loc, const std::string& name) {
  H5Handle a(H5Aopen(loc, name.c_str(), H5P_DEFAULT), H5Aclose, "open attribute " + name);
  H5Handle ft(H5Aget_type(a.id), H5Tclose, "read the type of attribute " + name);
  if (H5Tget_class(ft.id) != H5T_STRING)
    throw std::runtime_error("HDF5: attribute " + name + " is not a string");
  return read_string(H5Tget_size(ft.id), [&](hid_t t, void* b) { return H5Aread(a.id, t, b); },
                     "attribute " + name);
}

void write_attr(hid_t loc, const std::string& name, double v) {
  H5Handle space(H5Screate(H5S_SCALAR), H5Sclose, "scalar space");
  H5Handle a(H5Acreate2(loc, name.c_str(), H5T_IEEE_F64LE, space.id, H5P_DEFAULT, H5P_DEFAULT),
             H5Aclose, "create attribute " + name);
  if (H5Awrite(a.id, H5T_NATIVE_DOUBLE, &v) < 0)
    throw std::runtime_error("HDF5: cannot write attribute " + name + hdf5_error_text());
}

double read_attr(hid_t loc, const std::string& name) {
  H5Handle a(H5Aopen(loc, name.c_str(), H5P_DEFAULT), H5Aclose, "open attribute " + name);
  double v = 0.0;
  if (H5Aread(a.id, H5T_NATIVE_DOUBLE, &v) < 0)
    throw std::runtime_error("HDF5: cannot read attribute " + name + hdf5_error_text());
  return v;
}

std::vector<std::string> children(hid_t group) {
  H5G_info_t info;
  if (H5Gget_info(group, &info) < 0)
    throw std::runtime_error("HDF5: cannot list a group" + hdf5_error_text());
  std::vector<std::string> names;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    char buf[512];
    if (H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, i, buf, sizeof buf,
                           H5P_DEFAULT) < 0)
      throw std::runtime_error("HDF5: cannot read a link name" + hdf5_error_text());
    names.emplace_back(buf);
  }
  return names;
}

// fields.h5 is read by viewers (ParaView, h5py, a monitoring script) while the run goes on.
// HDF5's file lock then failed the run's next output ("unable to lock file, errno = 11": exit 4
// after 3 s of a reader holding the file; an independent run). The run writes no file through
// HDF5 now (file_image), and reads the earlier snapshots at a restart without a lock, so a
// reader holding them never stops it.
H5Handle unlocked_access() {
  H5Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "create a file access property list");
  if (H5Pset_file_locking(fapl.id, false, true) < 0)
    throw std::runtime_error("HDF5: cannot switch off file locking" + hdf5_error_text());
  return fapl;
}

std::string step_name(std::size_t i) {
  std::ostringstream os;
  os << "step_" << std::setw(6) << std::setfill('0') << i;
  return os.str();
}
}  // namespace

// ---------------------------------------------------------------------------------------------
// fields.h5 + fields.h5.d/ + fields.xdmf
// ---------------------------------------------------------------------------------------------
namespace {
// Builds an HDF5 file in memory (the core driver without a backing store) with `fill` and
// returns its bytes: HDF5 never writes to the disk, our write_file_atomic does, checked. A disk
// that filled inside HDF5's own write of fields.h5 left the library with a file it could not
// close, and the process crashed in HDF5's shutdown at MPI_Finalize (SIGSEGV in
// H5F__close_cb, exit 139, after the summary; an independent run, session 40; reproduced with a
// 512 kB tmpfs filled between two snapshots).
std::vector<char> file_image(const std::string& what, const std::function<void(hid_t)>& fill) {
  std::vector<char> image;
  H5Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "create a file access property list");
  if (H5Pset_fapl_core(fapl.id, 1 << 20, 0) < 0)
    throw std::runtime_error("HDF5: cannot build " + what + " in memory" + hdf5_error_text());
  H5Handle f(H5Fcreate(what.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.id), H5Fclose,
             "create the image of " + what);
  fill(f.id);
  if (H5Fflush(f.id, H5F_SCOPE_GLOBAL) < 0)
    throw std::runtime_error("HDF5: cannot flush the image of " + what + hdf5_error_text());
  const ssize_t n = H5Fget_file_image(f.id, nullptr, 0);
  if (n <= 0) throw std::runtime_error("HDF5: cannot size the image of " + what + hdf5_error_text());
  image.resize(static_cast<std::size_t>(n));
  if (H5Fget_file_image(f.id, image.data(), image.size()) != n)
    throw std::runtime_error("HDF5: cannot copy the image of " + what + hdf5_error_text());
  return image;
}

// The snapshots' directory beside fields.h5, and a snapshot's file name in it.
const char* const kSnapshotDir = "fields.h5.d";
// In a fields.h5.d that is a link: the run directory whose snapshots it holds (claim_snapshots).
const char* const kOwnerFile = ".granflow_run";
std::string snapshot_file(const std::string& name) { return name + ".h5"; }

bool ends_with(const std::string& f, const std::string& tail) {
  return f.size() >= tail.size() && f.compare(f.size() - tail.size(), tail.size(), tail) == 0;
}
// step_NNNNNN.h5, six or more digits: a snapshot's file (a copy such as step_000003_copy.h5 is
// the user's, and is neither read nor removed)
bool is_snapshot_name(const std::string& f) {
  if (f.rfind("step_", 0) != 0 || !ends_with(f, ".h5") || f.size() < 14) return false;
  for (std::size_t i = 5; i + 3 < f.size(); ++i)
    if (!std::isdigit(static_cast<unsigned char>(f[i]))) return false;
  return true;
}
// what the run itself leaves in fields.h5.d: snapshots, a write cut short (.tmp), a snapshot
// that could not be read at a restart (.broken), the owner mark
bool is_run_file(const std::string& f) {
  if (f == kOwnerFile || is_snapshot_name(f)) return true;
  for (const char* tail : {".tmp", ".broken", ".duplicate", ".other_run"})
    if (ends_with(f, tail) && is_snapshot_name(f.substr(0, f.size() - std::strlen(tail))))
      return true;
  return false;
}
// A run's field output carries an id (16 hex digits, drawn when the output starts afresh, kept
// across restarts) in fields.h5 and in every snapshot's file: HDF5 looks for an external link's
// file beside fields.h5 and then in the current directory, so a fields.h5 copied without its
// fields.h5.d, read from inside another run's directory, served that run's snapshots (an
// independent run: granflow-study mixed two runs without a word; ParaView crashed on the
// shapes). FieldReader refuses a snapshot whose id is not the index's.
std::string new_run_id() {
  std::random_device rd;
  const std::uint64_t v = (static_cast<std::uint64_t>(rd()) << 32) ^ rd() ^
                          static_cast<std::uint64_t>(
                              std::chrono::steady_clock::now().time_since_epoch().count());
  char buf[32];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}
std::string run_id_of(hid_t loc) {  // "" where there is none (an older file)
  if (H5Aexists(loc, "run") <= 0) {
    H5Eclear2(H5E_DEFAULT);
    return "";
  }
  return read_string_attr(loc, "run");
}

bool has_snapshots(const std::string& sdir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(sdir, ec)) return false;
  for (const auto& e : std::filesystem::directory_iterator(sdir, ec)) {
    const std::string n = e.path().filename().string();
    if (n != kOwnerFile && is_run_file(n)) return true;
  }
  return false;
}

// A fields.h5.d that is a link (to a directory on a larger disk) is shared by every copy of the
// run directory (cp -r copies the link), and a fresh run or a restart in one copy removed the
// other's snapshots (a review of the change). The checks, for a link:
// - it points at an existing directory that the run can write into (a read-only mount ran a
//   whole leg before it failed at the first output; an independent run);
// - not into another run directory's own fields.h5.d (--overwrite replaced that run's
//   snapshots);
// - its mark (.granflow_run: the run directory whose snapshots it holds) is this run's, or it
//   holds no snapshots (the run then marks it);
// - no other granflow uses it now (two runs started together on one empty directory both
//   marked it and wrote into it: an exclusive flock on the directory, held for the run).
// `take` marks the directory and takes the lock; without it (plan_directory, --check) only the
// checks. A directory of the run directory's own needs only to be writable.
int g_snapshot_lock_fd = -1;
std::string g_snapshot_lock_path;

void check_snapshot_dir(const std::string& dir, const std::string& sdir, bool take) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const bool link = fs::is_symlink(sdir, ec);
  if (link && !fs::exists(sdir, ec))
    throw std::runtime_error("'" + sdir + "' is a link to '" + fs::read_symlink(sdir, ec).string() +
                             "', which does not exist; allowed: a link to an existing "
                             "directory, or no fields.h5.d (the run creates it)");
  if (take) fs::create_directories(sdir);
  if (!fs::exists(sdir, ec)) return;
  if (!fs::is_directory(sdir, ec))
    throw std::runtime_error("'" + sdir + "' is not a directory; allowed: a directory (or a "
                             "link to one) for the field snapshots, or none");
  if (const int err = write_probe(sdir))
    throw std::runtime_error("'" + sdir + "' cannot be written (" + std::strerror(err) +
                             "); allowed: a directory the run can write into");
  if (!link) return;
  const fs::path target = fs::canonical(sdir, ec), me = fs::canonical(dir, ec);
  for (fs::path p = target; !p.empty() && p != p.parent_path(); p = p.parent_path()) {
    const fs::path holder = p.parent_path();  // into another run's fields.h5.d, or below it
    if (p.filename() == kSnapshotDir && fs::exists(holder / "run.json", ec) &&
        !fs::equivalent(holder, me, ec))
      throw std::runtime_error("'" + sdir + "' links to '" + target.string() +
                               "', inside the field snapshots of the run directory '" +
                               holder.string() + "'; allowed: a link to a directory of this "
                               "run's own");
  }
  if (take && g_snapshot_lock_path != target.string()) {
    if (g_snapshot_lock_fd >= 0) ::close(g_snapshot_lock_fd);
    g_snapshot_lock_fd = ::open(target.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (g_snapshot_lock_fd >= 0 && ::flock(g_snapshot_lock_fd, LOCK_EX | LOCK_NB) != 0) {
      ::close(g_snapshot_lock_fd);
      g_snapshot_lock_fd = -1;
      g_snapshot_lock_path.clear();
      throw std::runtime_error("'" + sdir + "' links to '" + target.string() +
                               "', which another running granflow writes into; allowed: a "
                               "link to a directory of this run's own");
    }
    g_snapshot_lock_path = target.string();
  }
  const std::string mark = sdir + "/" + kOwnerFile;
  std::string owner;
  {
    std::ifstream in(mark);
    std::getline(in, owner);
  }
  const bool mine = owner == me.string() || (fs::exists(owner, ec) && fs::equivalent(owner, me, ec));
  if (!owner.empty() && !mine && has_snapshots(sdir))
    throw std::runtime_error(
        "'" + sdir + "' links to '" + target.string() + "', which holds the field snapshots of " +
        (fs::exists(owner, ec) ? "the run in '" + owner + "'"
                               : "a run once in '" + owner + "' (no longer there)") +
        ": two runs cannot share it (a copy of a run directory copies the link). Allowed: a "
        "link to a directory of this run's own (for a copy: replace the link by a directory, or "
        "copy with cp -rL); only if that run was moved here, remove '" + mark + "'");
  if (take && !mine) write_file_atomic(mark, me.string() + "\n");
}

void claim_snapshots(const std::string& dir, const std::string& sdir) {
  check_snapshot_dir(dir, sdir, true);
}

// fields.h5 itself: one external link per snapshot, step_NNNNNN -> fields.h5.d/step_NNNNNN.h5:/
// (HDF5 resolves the relative target beside fields.h5 first; h5py, ParaView and FieldReader
// follow the links as if the groups were in the file).
std::vector<char> index_image(const std::string& file, const std::vector<std::string>& names,
                              const std::string& run_id) {
  return file_image(file, [&](hid_t f) {
    write_string_attr(f, "format",
                      "granflow field snapshots: one external link per output time to "
                      "fields.h5.d/step_NNNNNN.h5, whose root holds the attribute time and a "
                      "group per mesh");
    write_string_attr(f, "run", run_id);
    for (const auto& s : names) {
      const std::string target = std::string(kSnapshotDir) + "/" + snapshot_file(s);
      if (H5Lcreate_external(target.c_str(), "/", f, s.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0)
        throw std::runtime_error("HDF5: cannot link " + s + " in " + file + hdf5_error_text());
    }
  });
}
}  // namespace

namespace {
// What a restart finds of the earlier snapshots (Hdf5FieldOutput::open).
struct SnapshotScan {
  std::map<std::string, double> found;          // name -> time, readable and the run's
  std::map<std::string, std::string> file_run;  // name -> the file's run id ("" before ids)
  std::vector<std::string> unreadable;          // files to set aside as .broken
  std::vector<std::string> notes;               // what the note at the restart says
  std::set<std::string> unlisted;  // files a readable index does not list
};

// 1. The snapshot files in fields.h5.d, each with its time and run id.
void scan_snapshot_files(const std::string& sdir, hid_t fapl, SnapshotScan& scan) {
  for (const auto& e : std::filesystem::directory_iterator(sdir)) {
    const std::string n = e.path().filename().string();
    if (!is_snapshot_name(n)) continue;
    const std::string s = n.substr(0, n.size() - 3);
    try {
      H5Handle f(H5Fopen(e.path().c_str(), H5F_ACC_RDONLY, fapl), H5Fclose, "open " + n);
      scan.found[s] = read_attr(f.id, "time");
      scan.file_run[s] = run_id_of(f.id);
    } catch (const std::runtime_error&) {
      scan.unreadable.push_back(s);
      H5Eclear2(H5E_DEFAULT);
    }
  }
}

// 2b. A fields.h5 of a granflow before 2026-12-07 holds its snapshots as groups: each one up to
// the checkpoint is copied into its own file. Reading a group may fail (it is left out);
// writing its file may not (a full disk): that stops the restart with fields.h5 untouched.
void convert_group(hid_t index, const std::string& s, const std::string& file,
                   const std::string& sdir, double keep_until, std::string& run_id,
                   SnapshotScan& scan, std::set<std::string>& listed) {
  double t = 0.0;
  std::vector<char> image;
  try {
    H5Handle g(H5Gopen2(index, s.c_str(), H5P_DEFAULT), H5Gclose, "open " + s);
    t = read_attr(g.id, "time");
    if (after(t, keep_until)) return;
    if (run_id.empty()) run_id = new_run_id();
    image = file_image(s, [&](hid_t out) {
      write_attr(out, "time", t);
      write_string_attr(out, "run", run_id);
      for (const auto& m : children(g.id))
        if (H5Ocopy(g.id, m.c_str(), out, m.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0)
          throw std::runtime_error("HDF5: cannot copy " + s + "/" + m + " of " + file +
                                   hdf5_error_text());
    });
  } catch (const std::runtime_error&) {
    scan.notes.push_back(s + " (a group in fields.h5) cannot be read");
    H5Eclear2(H5E_DEFAULT);
    return;
  }
  const std::string to = sdir + "/" + snapshot_file(s);
  check_room_for(to, image.size(), "copying snapshot " + s + " of fields.h5");
  write_file_atomic(to, image.data(), image.size());
  scan.found[s] = t;
  scan.file_run[s] = run_id;
  listed.insert(s);
}

// 2. The old index: its run id, and the snapshots it lists (only those are the run's). An index
// that cannot be read is rebuilt from the files, unless there are none (an older fields.h5 would
// be replaced by an empty index). Another run's index (copied over this one's: a restart took
// its list and id and deleted four of its own snapshots; an independent run) is rebuilt from the
// run's files, when some carry the checkpoint's id (`expected_id`); a checkpoint copied in from
// another run of the scene, whose id no file has, leaves the directory's index and files as
// they are. An index whose files are all missing (a run directory moved without fields.h5.d)
// stops the restart.
void read_index(const std::string& file, const std::string& sdir, hid_t fapl, double keep_until,
                const std::string& expected_id, std::string& run_id, SnapshotScan& scan) {
  if (!std::filesystem::exists(file)) {
    if (!scan.found.empty()) scan.notes.push_back("fields.h5 is missing: rebuilt from the files");
    return;
  }
  const hid_t opened = H5Fopen(file.c_str(), H5F_ACC_RDONLY, fapl);
  if (opened < 0) {
    const std::string why = hdf5_error_text();
    if (scan.found.empty() && scan.unreadable.empty())
      throw std::runtime_error(
          "cannot read '" + file + "'" + why + " and '" + sdir +
          "' holds no snapshot files, so the snapshots before the checkpoint cannot be kept; "
          "allowed: a readable fields.h5, or move it away to restart with a new field output");
    scan.notes.push_back("fields.h5 cannot be read" + why + ": rebuilt from the files");
    return;
  }
  H5Handle f(opened, H5Fclose, "open " + file);
  const std::string index_id = run_id_of(f.id);
  bool expected_files = false;
  for (const auto& [name, id] : scan.file_run) expected_files = expected_files || id == expected_id;
  const bool foreign = !expected_id.empty() && !index_id.empty() && index_id != expected_id &&
                       expected_files;
  run_id = foreign || index_id.empty() ? expected_id : index_id;
  if (foreign) {
    scan.notes.push_back("fields.h5 is another run's index (run id " + index_id +
                         ", this run's " + expected_id + "): rebuilt from the files");
    return;
  }
  std::set<std::string> listed;
  for (const auto& s : children(f.id)) {
    H5L_info_t info;
    if (H5Lget_info(f.id, s.c_str(), &info, H5P_DEFAULT) < 0) continue;
    if (info.type == H5L_TYPE_EXTERNAL) listed.insert(s);
    else if (info.type == H5L_TYPE_HARD && is_snapshot_name(snapshot_file(s)))
      convert_group(f.id, s, file, sdir, keep_until, run_id, scan, listed);
  }
  // a file the index does not list: a write the run did not finish (after the checkpoint, cut
  // back anyway), a copy placed there (an independent run copied step_000001.h5 to
  // step_000099.h5: it was taken as a second snapshot at 0.05 s; one_per_time sets it aside),
  // or a snapshot of the run put back by hand (it was deleted without a word: taken back)
  for (const auto& [name, t] : scan.found)
    if (!listed.count(name)) scan.unlisted.insert(name);
  std::vector<std::string> missing;
  for (const auto& l : listed)
    if (!scan.found.count(l) &&
        std::find(scan.unreadable.begin(), scan.unreadable.end(), l) == scan.unreadable.end())
      missing.push_back(l);
  if (!missing.empty() && missing.size() == listed.size() && scan.found.empty()) {
    std::error_code ec;  // the empty directory the start made (a fields.h5.d moved back in
    if (!std::filesystem::is_symlink(sdir, ec) && std::filesystem::is_empty(sdir, ec))
      std::filesystem::remove(sdir, ec);  // would nest inside it)
    throw std::runtime_error(
        "'" + file + "' lists " + std::to_string(listed.size()) + " snapshots and '" + sdir +
        "' holds none of their files (a run directory moved without it?); allowed: fields.h5.d "
        "back beside fields.h5, or fields.h5 moved away to restart with a new field output");
  }
  for (const auto& l : missing) scan.notes.push_back(l + " is listed but has no file");
}

// 4. One snapshot per output time: a file copied over another (an independent run: times
// 0, 0.05, 0.05, 0 and 0.1, 0.15 lost, without a word) or a copy beside the original. The one
// the index lists, else the lowest number, is kept; the others are set aside as .duplicate.
// An unlisted file whose time is new is a snapshot of the run put back: taken, and said.
void one_per_time(const std::string& sdir, SnapshotScan& scan) {
  std::vector<std::pair<double, std::string>> order;
  for (const auto& [s, t] : scan.found) order.emplace_back(t, s);
  std::sort(order.begin(), order.end(), [&](const auto& a, const auto& b) {
    if (a.first != b.first) return a.first < b.first;
    const bool la = !scan.unlisted.count(a.second), lb = !scan.unlisted.count(b.second);
    return la != lb ? la : a.second < b.second;
  });
  for (std::size_t k = 0; k < order.size(); ++k) {
    const auto& [t, s] = order[k];
    const bool same_time =
        k > 0 && std::abs(t - order[k - 1].first) <= 1e-9 * std::max(1.0, std::abs(t));
    if (same_time) {
      std::error_code ec;
      std::filesystem::rename(sdir + "/" + snapshot_file(s),
                              sdir + "/" + snapshot_file(s) + ".duplicate", ec);
      scan.notes.push_back(s + " repeats the time " + params::str(t) + " s of " +
                           order[k - 1].second + " (kept as " + snapshot_file(s) + ".duplicate)");
      scan.found.erase(s);
    } else if (scan.unlisted.count(s)) {
      scan.notes.push_back(s + " (t = " + params::str(t) +
                           " s) was not listed in fields.h5: taken back");
    }
  }
}

// 3. Files of another run (copied in): not this run's snapshots; set aside, not removed.
void set_aside_other_runs(const std::string& sdir, const std::string& run_id, SnapshotScan& scan) {
  for (auto it = scan.found.begin(); it != scan.found.end();) {
    const std::string& id = scan.file_run[it->first];
    if (run_id.empty() || id.empty() || id == run_id) {
      ++it;
      continue;
    }
    std::error_code ec;
    std::filesystem::rename(sdir + "/" + snapshot_file(it->first),
                            sdir + "/" + snapshot_file(it->first) + ".other_run", ec);
    scan.notes.push_back(it->first + " is another run's (kept as " + snapshot_file(it->first) +
                         ".other_run)");
    it = scan.found.erase(it);
  }
}
}  // namespace

// Each snapshot is its own file, fields.h5.d/step_NNNNNN.h5, built in memory and written whole
// (write_file_atomic); fields.h5 is the index of links to them, rebuilt in memory and replaced
// after each snapshot. So a full disk fails in our checked writes (the snapshot's file is not
// made, the index still lists the earlier ones), never inside HDF5.
// A restart (keep_until >= 0) keeps the snapshots up to the checkpoint time (a run stopped
// between its field output and its checkpoint wrote later ones; the restart writes them again):
// the files the old index lists, rebuilt into a new index, so that an index that was cut or
// lost is no loss.
void Hdf5FieldOutput::open(const std::string& dir, double keep_until,
                           const std::string& expected_id) {
  namespace fs = std::filesystem;
  quiet_hdf5();
  dir_ = dir;
  times_.clear();
  names_.clear();
  layouts_.clear();
  next_index_ = 0;
  run_id_.clear();
  const std::string file = dir + "/fields.h5";
  const std::string sdir = dir + "/" + kSnapshotDir;
  claim_snapshots(dir, sdir);
  const auto fapl = unlocked_access();
  SnapshotScan scan;
  std::vector<std::pair<std::string, double>> kept;  // (name, time), in time order
  if (keep_until >= 0.0 && (fs::exists(file) || has_snapshots(sdir))) {
    scan_snapshot_files(sdir, fapl.id, scan);
    read_index(file, sdir, fapl.id, keep_until, expected_id, run_id_, scan);
    if (run_id_.empty()) run_id_ = expected_id;
    if (run_id_.empty())  // no index (lost, or older) and no checkpoint id: the files' id
      for (const auto& [s, t] : scan.found)
        if (!after(t, keep_until) && !scan.file_run[s].empty()) {
          run_id_ = scan.file_run[s];
          break;
        }
    set_aside_other_runs(sdir, run_id_, scan);
    // (after the checkpoint: the restart writes them again)
    for (auto it = scan.found.begin(); it != scan.found.end();)
      it = after(it->second, keep_until) && scan.unlisted.count(it->first) ? scan.found.erase(it)
                                                                           : std::next(it);
    one_per_time(sdir, scan);
    for (const auto& [s, t] : scan.found)
      if (!after(t, keep_until)) kept.emplace_back(s, t);
    std::sort(kept.begin(), kept.end(),
              [](const auto& a, const auto& b) { return a.second < b.second; });
  } else if (keep_until >= 0.0) {
    scan.notes.push_back("no snapshot of the earlier part is there (neither fields.h5 nor its "
                         "files): the field output starts again with this part");
  }
  const std::vector<std::string>& unreadable = scan.unreadable;
  if (run_id_.empty()) run_id_ = new_run_id();
  for (const auto& [s, t] : kept) names_.push_back(s);
  // The new index first, then the files it does not list go: a failed write leaves the old
  // index and every file it lists.
  const auto index = index_image(file, names_, run_id_);
  check_room_for(file, index.size(), "writing the field index (fields.h5)");
  write_file_atomic(file, index.data(), index.size());
  for (const auto& s : unreadable) {  // set aside, not deleted (a permission, a passing error)
    std::error_code ec;
    fs::rename(sdir + "/" + snapshot_file(s), sdir + "/" + snapshot_file(s) + ".broken", ec);
  }
  std::set<std::string> keep_files{kOwnerFile};
  for (const auto& [s, t] : kept) keep_files.insert(snapshot_file(s));
  for (const auto& e : fs::directory_iterator(sdir)) {
    const std::string n = e.path().filename().string();
    const bool set_aside = ends_with(n, ".broken") || ends_with(n, ".duplicate") ||
                           ends_with(n, ".other_run");
    if (is_run_file(n) && !keep_files.count(n) && !(keep_until >= 0.0 && set_aside))
      fs::remove(e.path());
  }
  if (!unreadable.empty() || !scan.notes.empty()) {
    std::string items;
    for (const auto& s : unreadable)
      items += (items.empty() ? "" : "; ") + s + " cannot be read (kept as " + snapshot_file(s) +
               ".broken)";
    for (const auto& s : scan.notes) items += (items.empty() ? "" : "; ") + s;
    std::cerr << "granflow: note: the field output in " << dir << " at the restart: " << items
              << "; fields.h5 lists the " << kept.size() << " snapshots up to the checkpoint\n";
  }
  names_.clear();
  for (const auto& [s, t] : kept) {
    H5Handle f(H5Fopen((sdir + "/" + snapshot_file(s)).c_str(), H5F_ACC_RDONLY, fapl.id),
               H5Fclose, "open " + snapshot_file(s));
    times_.push_back(t);
    names_.push_back(s);
    std::vector<FieldWriter::Mesh> meshes;
    for (const auto& m : children(f.id)) {
      H5Handle mg(H5Gopen2(f.id, m.c_str(), H5P_DEFAULT), H5Gclose, "open " + s + "/" + m);
      FieldWriter::Mesh mesh{m, read_dataset(mg.id, "x_nodes"), read_dataset(mg.id, "z_nodes"),
                             {}};
      for (const auto& fld : children(mg.id))
        if (fld != "x_nodes" && fld != "z_nodes")
          mesh.cell_fields.emplace_back(fld, std::vector<double>{});
      meshes.push_back(std::move(mesh));
    }
    layouts_.push_back(std::move(meshes));
    // step_NNNNNN: the next snapshot gets the next number after the largest kept one.
    next_index_ = std::max<std::size_t>(next_index_, std::stoul(s.substr(5)) + 1);
  }
  // an unreadable file keeps its number (its .broken copy is not overwritten)
  for (const auto& s : unreadable)
    next_index_ = std::max<std::size_t>(next_index_, std::stoul(s.substr(5)) + 1);
  if (keep_until >= 0.0) write_xdmf();
}

FieldReader::FieldReader(const std::string& file) : file_(file) {
  quiet_hdf5();
  H5Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "open " + file);
  const std::string run = run_id_of(f.id);
  std::vector<std::pair<double, std::string>> snaps;
  for (const auto& s : children(f.id)) {
    H5Handle g(H5Gopen2(f.id, s.c_str(), H5P_DEFAULT), H5Gclose,
               "open " + s + " in " + file + " (its file in fields.h5.d beside it)");
    // (a snapshot without an id was written before ids; it is taken as it is)
    const std::string id = run_id_of(g.id);
    if (!id.empty() && id != run)
      throw std::runtime_error(
          "snapshot " + s + " read through " + file + " is another run's (run id " + id +
          ", the index's " + (run.empty() ? std::string("none") : run) +
          "): a file " + snapshot_file(s) + " missing from the fields.h5.d beside " + file +
          " is looked for by HDF5 in the current directory too; keep fields.h5.d with "
          "fields.h5");
    snaps.emplace_back(read_attr(g.id, "time"), s);
  }
  std::sort(snaps.begin(), snaps.end());
  for (const auto& [t, s] : snaps) {
    times_.push_back(t);
    groups_.push_back(s);
  }
}

std::vector<FieldWriter::Mesh> FieldReader::read(std::size_t i) const {
  quiet_hdf5();
  H5Handle f(H5Fopen(file_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "open " + file_);
  const std::string& s = groups_.at(i);
  H5Handle g(H5Gopen2(f.id, s.c_str(), H5P_DEFAULT), H5Gclose, "open " + s + " in " + file_);
  std::vector<FieldWriter::Mesh> meshes;
  for (const auto& m : children(g.id)) {
    H5Handle mg(H5Gopen2(g.id, m.c_str(), H5P_DEFAULT), H5Gclose, "open " + s + "/" + m);
    FieldWriter::Mesh mesh{m, read_dataset(mg.id, "x_nodes"), read_dataset(mg.id, "z_nodes"), {}};
    for (const auto& fld : children(mg.id))
      if (fld != "x_nodes" && fld != "z_nodes")
        mesh.cell_fields.emplace_back(fld, read_dataset(mg.id, fld));
    meshes.push_back(std::move(mesh));
  }
  return meshes;
}

void Hdf5FieldOutput::write(double t, const FieldWriter& fields) {
  quiet_hdf5();
  const std::string sname = step_name(next_index_);
  const std::string file = dir_ + "/fields.h5";
  const std::string snap = dir_ + "/" + kSnapshotDir + "/" + snapshot_file(sname);
  std::vector<FieldWriter::Mesh> layout;
  const auto image = file_image(snapshot_file(sname), [&](hid_t f) {
    write_attr(f, "time", t);
    write_string_attr(f, "run", run_id_);
    for (const auto& m : fields.meshes()) {
      H5Handle mg(H5Gcreate2(f, m.name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                  H5Gclose, "create group " + m.name);
      write_dataset(mg.id, "x_nodes", m.x_nodes, 1, m.x_nodes.size());
      write_dataset(mg.id, "z_nodes", m.z_nodes, 1, m.z_nodes.size());
      const hsize_t nx = m.x_nodes.size() - 1, nz = m.z_nodes.size() - 1;
      FieldWriter::Mesh lm{m.name, m.x_nodes, m.z_nodes, {}};
      for (const auto& [name, v] : m.cell_fields) {
        if (v.size() != nx * nz) throw std::logic_error("field " + name + " has the wrong size");
        write_dataset(mg.id, name, v, nz, nx, true);
        lm.cell_fields.emplace_back(name, std::vector<double>{});
      }
      layout.push_back(std::move(lm));
    }
  });
  auto names = names_;
  names.push_back(sname);
  const auto index = index_image(file, names, run_id_);
  // the snapshot and the new index; the reserve: the XDMF index twice (old and new) and the
  // room kept for the run's summary. A fields.h5.d linked to another disk is checked there.
  const std::string what =
      "writing the field output at t = " + params::str(t) + " s (fields.h5.d/" +
      snapshot_file(sname) + ")";
  const std::string sdir = dir_ + "/" + kSnapshotDir;
  if (same_file_system(dir_, sdir)) {
    check_room(dir_, image.size() + index.size(), 2 * xdmf_bytes_ + g_stop_reserve, what);
  } else {
    check_room(sdir, image.size(), 0, what);
    check_room(dir_, index.size(), 2 * xdmf_bytes_ + g_stop_reserve,
               "writing the field index (fields.h5) at t = " + params::str(t) + " s");
  }
  write_file_atomic(snap, image.data(), image.size());
  try {
    write_file_atomic(file, index.data(), index.size());
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(snap, ec);  // not listed: the directory holds what the index does
    throw;
  }
  times_.push_back(t);
  names_.push_back(sname);
  layouts_.push_back(std::move(layout));
  ++next_index_;
  write_xdmf();
}

// The index: one temporal collection per mesh ("dam", "ndam"), each holding that mesh at every
// output time. It was one temporal collection of spatial collections (a snapshot of all meshes
// per time): ParaView's XDMF readers then named the blocks "dam[k]" and "ndam[k]" at the k-th
// time, so a block picked by name (Extract Block, /Root/ndam) was empty after t = 0 (checked
// with pvbatch, ParaView 5.11, the lab chute's 31 outputs). Now the XDMF reader names them
// "dam" and "ndam" and Xdmf3ReaderT numbers them 0 and 1 at every time.
void Hdf5FieldOutput::write_xdmf() const {
  // Written whole, then renamed over the old index (write_file_atomic): a write that failed
  // (a full disk) was renamed over a good fields.xdmf, leaving XML cut at 4096 or 20480 bytes
  // (an independent run).
  std::vector<std::string> meshes;  // in order of first appearance
  for (const auto& layout : layouts_)
    for (const auto& m : layout)
      if (std::find(meshes.begin(), meshes.end(), m.name) == meshes.end()) meshes.push_back(m.name);
  std::ostringstream x;
  x << std::setprecision(12);
  x << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n";
  for (const auto& mesh : meshes) {
    x << "  <Grid Name=\"" << mesh << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (std::size_t s = 0; s < times_.size(); ++s) {
      const std::string& sname = names_[s];
      for (const auto& m : layouts_[s]) {
        if (m.name != mesh) continue;
        const std::size_t nx = m.x_nodes.size(), nz = m.z_nodes.size();
        // the snapshot's own file, relative to fields.xdmf (ParaView reads it from there, not
        // through fields.h5's links, which HDF5 may also resolve in the current directory)
        const std::string base =
            std::string(kSnapshotDir) + "/" + snapshot_file(sname) + ":/" + m.name + "/";
        // The cell fields' declared shape is the dataset's, nz - 1 x nx - 1 (also 1 x nx - 1 for
        // the 1D models' one-row strip: ParaView's XDMF reader needs the cells' shape there).
        std::ostringstream cells;
        cells << nz - 1 << " " << nx - 1;
        x << "   <Grid Name=\"" << m.name << "\" GridType=\"Uniform\">\n"
          << "    <Time Value=\"" << times_[s] << "\"/>\n"
          << "    <Topology TopologyType=\"2DRectMesh\" Dimensions=\"" << nz << " " << nx
          << "\"/>\n"
          << "    <Geometry GeometryType=\"VXVY\">\n"
          << "     <DataItem Dimensions=\"" << nx
          << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << base
          << "x_nodes</DataItem>\n"
          << "     <DataItem Dimensions=\"" << nz
          << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << base
          << "z_nodes</DataItem>\n"
          << "    </Geometry>\n";
        for (const auto& f : m.cell_fields)
          x << "    <Attribute Name=\"" << f.first
            << "\" AttributeType=\"Scalar\" Center=\"Cell\">\n"
            << "     <DataItem Dimensions=\"" << cells.str()
            << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << base << f.first
            << "</DataItem>\n    </Attribute>\n";
        x << "   </Grid>\n";
      }
    }
    x << "  </Grid>\n";
  }
  x << " </Domain>\n</Xdmf>\n";
  const std::string text = x.str();
  write_file_atomic(dir_ + "/fields.xdmf", text);
  xdmf_bytes_ = text.size();
}

bool field_output_has_id(const std::string& dir, const std::string& id, bool& any_id) {
  quiet_hdf5();
  any_id = false;
  const auto fapl = unlocked_access();
  // the index first (it carries the run's id in every ordinary case), then the files, until
  // one carries `id`
  auto carries = [&](const std::string& f) {
    const hid_t h = H5Fopen(f.c_str(), H5F_ACC_RDONLY, fapl.id);
    if (h < 0) {
      H5Eclear2(H5E_DEFAULT);
      return false;
    }
    H5Handle file(h, H5Fclose, "open " + f);
    try {
      const std::string its = run_id_of(file.id);
      any_id = any_id || !its.empty();
      return its == id;
    } catch (const std::runtime_error&) {
      H5Eclear2(H5E_DEFAULT);
      return false;
    }
  };
  std::error_code ec;
  if (std::filesystem::exists(dir + "/fields.h5", ec) && carries(dir + "/fields.h5")) return true;
  const std::string sdir = dir + "/" + kSnapshotDir;
  if (std::filesystem::is_directory(sdir, ec))
    for (const auto& e : std::filesystem::directory_iterator(sdir, ec))
      if (is_snapshot_name(e.path().filename().string()) && carries(e.path().string()))
        return true;
  return false;
}

void check_field_snapshots(const std::string& dir) {
  check_snapshot_dir(dir, dir + "/" + kSnapshotDir, false);
}

void remove_field_snapshots(const std::string& sdir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(sdir, ec)) {
    fs::remove(sdir, ec);
    return;
  }
  // a linked directory of another run's is refused (claim_snapshots), not emptied
  claim_snapshots(fs::path(sdir).parent_path().string(), sdir);
  for (const auto& e : fs::directory_iterator(sdir)) {
    const std::string n = e.path().filename().string();
    if (is_run_file(n) && n != kOwnerFile) fs::remove(e.path());
  }
  // a link to a directory elsewhere (a larger disk) stays for the next run; an empty
  // directory of our own goes
  if (!fs::is_symlink(sdir, ec) && fs::is_empty(sdir, ec)) fs::remove(sdir, ec);
}

void truncate_fields(const std::string& dir, double t_keep) {
  if (!std::filesystem::exists(dir + "/fields.h5")) return;
  Hdf5FieldOutput f;
  f.open(dir, std::max(t_keep, 0.0));
}

std::string hdf5_version() {
  unsigned maj = 0, min = 0, rel = 0;
  H5get_libversion(&maj, &min, &rel);
  return std::to_string(maj) + "." + std::to_string(min) + "." + std::to_string(rel);
}

// ---------------------------------------------------------------------------------------------
// checkpoint.h5: /scalars/<key>, /arrays/<key>, /texts/<key> ('/' in keys stored as ':'), and
// the root attributes "format" and "checksum"
// ---------------------------------------------------------------------------------------------
namespace {
std::string enc(std::string k) {
  for (auto& c : k) if (c == '/') c = ':';
  return k;
}
std::string dec(std::string k) {
  for (auto& c : k) if (c == ':') c = '/';
  return k;
}
const char* kFormat = "granflow checkpoint 2";

struct Fnv1a {
  std::uint64_t h = 1469598103934665603ULL;
  void bytes(const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ULL;
  }
  void text(const std::string& s) {
    const std::uint64_t n = s.size();
    bytes(&n, sizeof n);
    bytes(s.data(), s.size());
  }
};

std::string hex(std::uint64_t v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "fnv1a64:%016llx", static_cast<unsigned long long>(v));
  return buf;
}
}  // namespace

std::uint64_t checksum(const Checkpoint& c) {
  // Lengths before contents, so that moving a byte from one entry to the next changes the sum.
  Fnv1a f;
  for (const auto& [k, v] : c.scalars()) {
    f.text(k);
    f.bytes(&v, sizeof v);
  }
  for (const auto& [k, v] : c.arrays()) {
    f.text(k);
    const std::uint64_t n = v.size();
    f.bytes(&n, sizeof n);
    f.bytes(v.data(), v.size() * sizeof(double));
  }
  for (const auto& [k, v] : c.texts()) {
    f.text(k);
    f.text(v);
  }
  return f.h;
}

void write_checkpoint(const std::string& file, const Checkpoint& c) {
  quiet_hdf5();
  // The file is built in memory (HDF5's core driver without a backing store) and written as
  // one image by write_file_atomic: HDF5 never writes to the disk here.
  const auto image = file_image(file, [&](hid_t f) {
    write_string_attr(f, "format", kFormat);
    write_string_attr(f, "checksum", hex(checksum(c)));
    H5Handle s(H5Gcreate2(f, "scalars", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
               "create group scalars");
    for (const auto& [k, v] : c.scalars()) write_dataset(s.id, enc(k), {v}, 1, 1);
    H5Handle a(H5Gcreate2(f, "arrays", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
               "create group arrays");
    for (const auto& [k, v] : c.arrays()) write_dataset(a.id, enc(k), v, 1, v.size());
    H5Handle x(H5Gcreate2(f, "texts", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
               "create group texts");
    for (const auto& [k, v] : c.texts()) write_text(x.id, enc(k), v);
  });
  check_room_for(file, image.size(), "writing the checkpoint (checkpoint.h5)");
  write_file_atomic(file, image.data(), image.size());
}

Checkpoint read_checkpoint(const std::string& file) {
  quiet_hdf5();
  if (!std::filesystem::exists(file)) throw CheckpointError("no checkpoint file '" + file + "'");
  const htri_t is_h5 = H5Fis_hdf5(file.c_str());
  if (is_h5 <= 0) {
    H5Eclear2(H5E_DEFAULT);
    throw CheckpointError("'" + file + "' is not an HDF5 file (truncated, or not a checkpoint)");
  }
  Checkpoint c;
  std::string stored;
  try {
    H5Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "open " + file);
    if (H5Aexists(f.id, "checksum") <= 0 || H5Aexists(f.id, "format") <= 0) {
      const bool old = H5Lexists(f.id, "scalars", H5P_DEFAULT) > 0 &&
                       H5Lexists(f.id, "arrays", H5P_DEFAULT) > 0;
      H5Eclear2(H5E_DEFAULT);
      if (!old)
        throw CheckpointError("'" + file + "' is an HDF5 file but not a granflow checkpoint");
      throw CheckpointError("'" + file +
                            "' was written by an older granflow: it has no scene record and no "
                            "checksum, so it cannot be checked against this scene; rerun the scene "
                            "from its start");
    }
    const std::string format = read_string_attr(f.id, "format");
    if (format != kFormat)
      throw CheckpointError("'" + file + "' has the format '" + format +
                            "'; this granflow reads '" + kFormat + "'");
    stored = read_string_attr(f.id, "checksum");
    H5Handle s(H5Gopen2(f.id, "scalars", H5P_DEFAULT), H5Gclose, "open group scalars");
    for (const auto& k : children(s.id)) {
      const auto v = read_dataset(s.id, k);
      if (v.size() != 1)
        throw std::runtime_error("scalar " + dec(k) + " has " + std::to_string(v.size()) +
                                 " values");
      c.set(dec(k), v[0]);
    }
    H5Handle a(H5Gopen2(f.id, "arrays", H5P_DEFAULT), H5Gclose, "open group arrays");
    for (const auto& k : children(a.id)) c.set(dec(k), read_dataset(a.id, k));
    H5Handle x(H5Gopen2(f.id, "texts", H5P_DEFAULT), H5Gclose, "open group texts");
    for (const auto& k : children(x.id)) c.set_text(dec(k), read_text(x.id, k));
  } catch (const CheckpointError&) {
    throw;
  } catch (const std::exception& e) {
    throw CheckpointError("'" + file + "' cannot be read (truncated or corrupted?): " + e.what());
  }
  const std::string actual = hex(checksum(c));
  if (actual != stored)
    throw CheckpointError("'" + file + "' is corrupted: its data have the checksum " + actual +
                          ", the file records " + stored);
  return c;
}

}  // namespace granflow::io
