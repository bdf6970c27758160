#pragma once
// Plain containers the models fill for output; the HDF5/XDMF and checkpoint files are written by
// io/hdf5_output.cpp, so no model includes HDF5.
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace granflow::io {

/// One field snapshot: a set of meshes, each a rectilinear grid given by its node coordinates
/// (z_nodes = {0, 1} for a 1D model drawn as a strip), with cell-centred fields.
class FieldWriter {
 public:
  struct Mesh {
    std::string name;
    std::vector<double> x_nodes, z_nodes;
    std::vector<std::pair<std::string, std::vector<double>>> cell_fields;  ///< z-major
  };
  Mesh& add_mesh(const std::string& name, std::vector<double> x_nodes,
                 std::vector<double> z_nodes) {
    meshes_.push_back(Mesh{name, std::move(x_nodes), std::move(z_nodes), {}});
    return meshes_.back();
  }
  const std::vector<Mesh>& meshes() const { return meshes_; }

 private:
  std::vector<Mesh> meshes_;
};

/// Named scalars and arrays that restore a run exactly, and texts that record what wrote them
/// (the run driver stores the validated scene there; see core/run_record.hpp).
class Checkpoint {
 public:
  void set(const std::string& key, double v) { scalars_[key] = v; }
  void set(const std::string& key, std::vector<double> v) { arrays_[key] = std::move(v); }
  void set_text(const std::string& key, std::string v) { texts_[key] = std::move(v); }
  bool has_scalar(const std::string& key) const { return scalars_.count(key) != 0; }
  bool has_text(const std::string& key) const { return texts_.count(key) != 0; }
  const std::string& text(const std::string& key) const {
    auto it = texts_.find(key);
    if (it == texts_.end()) throw std::runtime_error("checkpoint has no entry '" + key + "'");
    return it->second;
  }
  double scalar(const std::string& key) const {
    auto it = scalars_.find(key);
    if (it == scalars_.end()) throw std::runtime_error("checkpoint has no entry '" + key + "'");
    return it->second;
  }
  const std::vector<double>& array(const std::string& key) const {
    auto it = arrays_.find(key);
    if (it == arrays_.end()) throw std::runtime_error("checkpoint has no entry '" + key + "'");
    return it->second;
  }
  const std::map<std::string, double>& scalars() const { return scalars_; }
  const std::map<std::string, std::vector<double>>& arrays() const { return arrays_; }
  const std::map<std::string, std::string>& texts() const { return texts_; }

 private:
  std::map<std::string, double> scalars_;
  std::map<std::string, std::vector<double>> arrays_;
  std::map<std::string, std::string> texts_;
};

}  // namespace granflow::io
