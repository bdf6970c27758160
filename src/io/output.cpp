#include "granflow/io/output.hpp"

#include <hdf5.h>

#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace granflow::io {

// ---------------------------------------------------------------------------------------------
// profiles.csv
// ---------------------------------------------------------------------------------------------
void ProfileWriter::open(const std::string& dir, bool append) {
  const std::string file = dir + "/profiles.csv";
  const bool exists = std::filesystem::exists(file);
  out_.open(file, append ? std::ios::app : std::ios::trunc);
  if (!out_) throw std::runtime_error("cannot write '" + file + "'");
  if (!append || !exists) out_ << "t,x,h,u_mean,eps,model\n";
  out_ << std::setprecision(10);
}

void ProfileWriter::write(double t, const core::Profile& p) {
  for (std::size_t i = 0; i < p.x.size(); ++i)
    out_ << t << ',' << p.x[i] << ',' << p.h[i] << ',' << p.u_mean[i] << ',' << p.eps[i] << ','
         << p.model[i] << '\n';
  out_.flush();
}

// ---------------------------------------------------------------------------------------------
// HDF5 helpers
// ---------------------------------------------------------------------------------------------
namespace {
struct H5Handle {
  hid_t id;
  herr_t (*close)(hid_t);
  H5Handle(hid_t i, herr_t (*c)(hid_t), const std::string& what) : id(i), close(c) {
    if (id < 0) throw std::runtime_error("HDF5: " + what);
  }
  ~H5Handle() {
    if (id >= 0) close(id);
  }
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
};

void write_dataset(hid_t loc, const std::string& name, const std::vector<double>& v,
                   hsize_t rows, hsize_t cols) {
  hsize_t dims[2] = {rows, cols};
  H5Handle space(H5Screate_simple(rows > 1 ? 2 : 1, rows > 1 ? dims : dims + 1, nullptr),
                 H5Sclose, "dataspace for " + name);
  H5Handle ds(H5Dcreate2(loc, name.c_str(), H5T_IEEE_F64LE, space.id, H5P_DEFAULT, H5P_DEFAULT,
                         H5P_DEFAULT),
              H5Dclose, "create dataset " + name);
  if (!v.empty() &&
      H5Dwrite(ds.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    throw std::runtime_error("HDF5: write " + name);
}

std::vector<double> read_dataset(hid_t loc, const std::string& name) {
  H5Handle ds(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose, "open dataset " + name);
  H5Handle space(H5Dget_space(ds.id), H5Sclose, "space of " + name);
  const hssize_t n = H5Sget_simple_extent_npoints(space.id);
  std::vector<double> v(static_cast<std::size_t>(n));
  if (n > 0 && H5Dread(ds.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    throw std::runtime_error("HDF5: read " + name);
  return v;
}

void write_attr(hid_t loc, const std::string& name, double v) {
  H5Handle space(H5Screate(H5S_SCALAR), H5Sclose, "scalar space");
  H5Handle a(H5Acreate2(loc, name.c_str(), H5T_IEEE_F64LE, space.id, H5P_DEFAULT, H5P_DEFAULT),
             H5Aclose, "attribute " + name);
  H5Awrite(a.id, H5T_NATIVE_DOUBLE, &v);
}

double read_attr(hid_t loc, const std::string& name) {
  H5Handle a(H5Aopen(loc, name.c_str(), H5P_DEFAULT), H5Aclose, "attribute " + name);
  double v = 0.0;
  H5Aread(a.id, H5T_NATIVE_DOUBLE, &v);
  return v;
}

std::vector<std::string> children(hid_t group) {
  H5G_info_t info;
  H5Gget_info(group, &info);
  std::vector<std::string> names;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    char buf[512];
    H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, i, buf, sizeof buf, H5P_DEFAULT);
    names.emplace_back(buf);
  }
  return names;
}

std::string step_name(std::size_t i) {
  std::ostringstream os;
  os << "step_" << std::setw(6) << std::setfill('0') << i;
  return os.str();
}
}  // namespace

// ---------------------------------------------------------------------------------------------
// fields.h5 + fields.xdmf
// ---------------------------------------------------------------------------------------------
void Hdf5FieldOutput::open(const std::string& dir, bool append) {
  dir_ = dir;
  times_.clear();
  layouts_.clear();
  const std::string file = dir + "/fields.h5";
  if (append && std::filesystem::exists(file)) {
    // Re-read the snapshots already there, so that the XDMF file keeps listing them.
    H5Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "open " + file);
    for (const auto& s : children(f.id)) {
      H5Handle g(H5Gopen2(f.id, s.c_str(), H5P_DEFAULT), H5Gclose, "open " + s);
      times_.push_back(read_attr(g.id, "time"));
      std::vector<FieldWriter::Mesh> meshes;
      for (const auto& m : children(g.id)) {
        H5Handle mg(H5Gopen2(g.id, m.c_str(), H5P_DEFAULT), H5Gclose, "open " + m);
        FieldWriter::Mesh mesh{m, read_dataset(mg.id, "x_nodes"), read_dataset(mg.id, "z_nodes"),
                               {}};
        for (const auto& fld : children(mg.id))
          if (fld != "x_nodes" && fld != "z_nodes") mesh.cell_fields.emplace_back(fld, std::vector<double>{});
        meshes.push_back(std::move(mesh));
      }
      layouts_.push_back(std::move(meshes));
    }
    return;
  }
  H5Handle f(H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
             "create " + file);
}

void Hdf5FieldOutput::write(double t, const FieldWriter& fields) {
  const std::string file = dir_ + "/fields.h5";
  {
    H5Handle f(H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose, "open " + file);
    const std::string sname = step_name(times_.size());
    H5Handle g(H5Gcreate2(f.id, sname.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
               "group " + sname);
    write_attr(g.id, "time", t);
    std::vector<FieldWriter::Mesh> layout;
    for (const auto& m : fields.meshes()) {
      H5Handle mg(H5Gcreate2(g.id, m.name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                  H5Gclose, "group " + m.name);
      write_dataset(mg.id, "x_nodes", m.x_nodes, 1, m.x_nodes.size());
      write_dataset(mg.id, "z_nodes", m.z_nodes, 1, m.z_nodes.size());
      const hsize_t nx = m.x_nodes.size() - 1, nz = m.z_nodes.size() - 1;
      FieldWriter::Mesh lm{m.name, m.x_nodes, m.z_nodes, {}};
      for (const auto& [name, v] : m.cell_fields) {
        if (v.size() != nx * nz) throw std::logic_error("field " + name + " has the wrong size");
        write_dataset(mg.id, name, v, nz, nx);
        lm.cell_fields.emplace_back(name, std::vector<double>{});
      }
      layout.push_back(std::move(lm));
    }
    H5Fflush(f.id, H5F_SCOPE_GLOBAL);
    times_.push_back(t);
    layouts_.push_back(std::move(layout));
  }
  write_xdmf();
}

void Hdf5FieldOutput::write_xdmf() const {
  const std::string tmp = dir_ + "/fields.xdmf.tmp";
  {
    std::ofstream x(tmp);
    x << std::setprecision(12);
    x << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
      << "  <Grid Name=\"time series\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (std::size_t s = 0; s < times_.size(); ++s) {
      const std::string sname = step_name(s);
      x << "   <Grid Name=\"" << sname << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
        << "    <Time Value=\"" << times_[s] << "\"/>\n";
      for (const auto& m : layouts_[s]) {
        const std::size_t nx = m.x_nodes.size(), nz = m.z_nodes.size();
        const std::string base = "fields.h5:/" + sname + "/" + m.name + "/";
        x << "    <Grid Name=\"" << m.name << "\" GridType=\"Uniform\">\n"
          << "     <Topology TopologyType=\"2DRectMesh\" Dimensions=\"" << nz << " " << nx
          << "\"/>\n"
          << "     <Geometry GeometryType=\"VXVY\">\n"
          << "      <DataItem Dimensions=\"" << nx
          << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << base
          << "x_nodes</DataItem>\n"
          << "      <DataItem Dimensions=\"" << nz
          << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << base
          << "z_nodes</DataItem>\n"
          << "     </Geometry>\n";
        for (const auto& f : m.cell_fields)
          x << "     <Attribute Name=\"" << f.first
            << "\" AttributeType=\"Scalar\" Center=\"Cell\">\n"
            << "      <DataItem Dimensions=\"" << nz - 1 << " " << nx - 1
            << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << base << f.first
            << "</DataItem>\n     </Attribute>\n";
        x << "    </Grid>\n";
      }
      x << "   </Grid>\n";
    }
    x << "  </Grid>\n </Domain>\n</Xdmf>\n";
  }
  std::filesystem::rename(tmp, dir_ + "/fields.xdmf");
}

// ---------------------------------------------------------------------------------------------
// checkpoint.h5: /scalars/<key> and /arrays/<key>, '/' in keys stored as ':'
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
}  // namespace

void write_checkpoint(const std::string& file, const Checkpoint& c) {
  const std::string tmp = file + ".tmp";
  {
    H5Handle f(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose,
               "create " + tmp);
    H5Handle s(H5Gcreate2(f.id, "scalars", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
               "group scalars");
    for (const auto& [k, v] : c.scalars()) write_dataset(s.id, enc(k), {v}, 1, 1);
    H5Handle a(H5Gcreate2(f.id, "arrays", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
               "group arrays");
    for (const auto& [k, v] : c.arrays()) write_dataset(a.id, enc(k), v, 1, v.size());
  }
  std::filesystem::rename(tmp, file);
}

Checkpoint read_checkpoint(const std::string& file) {
  if (!std::filesystem::exists(file)) throw std::runtime_error("no checkpoint file '" + file + "'");
  Checkpoint c;
  H5Handle f(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "open " + file);
  H5Handle s(H5Gopen2(f.id, "scalars", H5P_DEFAULT), H5Gclose, "group scalars in " + file);
  for (const auto& k : children(s.id)) c.set(dec(k), read_dataset(s.id, k).at(0));
  H5Handle a(H5Gopen2(f.id, "arrays", H5P_DEFAULT), H5Gclose, "group arrays in " + file);
  for (const auto& k : children(a.id)) c.set(dec(k), read_dataset(a.id, k));
  return c;
}

}  // namespace granflow::io
