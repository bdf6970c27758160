// N-DAM output contract: the depth-averaged profile (h and u_mean of eq. 21, eps of section
// 4.1), the mass balance of the marker area, the HDF5 field snapshot, the checkpoint (save and
// load) and the statistics of summary.json.
#include "stencil.hpp"

#include "granflow/io/fields.hpp"
#include "granflow/params/parameters.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

namespace granflow::ndam {

std::vector<double> NdamSolver::gather_u() const { return mac_.gather_cells(u_, false); }
std::vector<double> NdamSolver::gather_w() const { return mac_.gather_cells(w_, false); }
std::vector<double> NdamSolver::gather_p() const { return mac_.gather_cells(p_, false); }
std::vector<double> NdamSolver::gather_nu() const { return mac_.gather_cells(nu_, false); }

core::Profile NdamSolver::profile() const {
  if (cfg_.free_surface) {
    // h and u_mean of eq. (21) from the markers (MarkerSet::profile: count-based depth), eps =
    // |w_mean| / |u_mean| (section 4.1); gathered at every accept().
    core::Profile p;
    for (int gi = 0; gi < cfg_.grid.nx; ++gi) {
      const auto q = static_cast<std::size_t>(gi);
      const double um = col_u_[q], wm = col_w_[q];
      const double eps = um != 0.0 ? std::min(core::kEpsCap, std::abs(wm) / std::abs(um)) : 0.0;
      p.append(cfg_.x0 + (gi + 0.5) * cfg_.grid.dx(), col_h_[q], um, eps, "2D");
    }
    return p;
  }
  // Depth averages of the cell-centred velocities over the fluid cells of each column; h is
  // the fluid height of the column (Lz in a box without obstacles); eps = |w_mean| / |u_mean|
  // (paper section 4.1).
  const int nz = cfg_.grid.nz;
  std::vector<double> local;
  for (int i = 0; i < mac_.slab.nx_local; ++i) {
    double um = 0.0, wm = 0.0;
    int n = 0;
    for (int k = 0; k < nz; ++k) {
      if (!mac_.fluid(mac_.slab.i0 + i, k)) continue;
      um += 0.5 * (u_(i, k) + u_(i - 1, k));
      wm += 0.5 * (w_(i, k) + w_(i, k - 1));
      ++n;
    }
    local.push_back(n > 0 ? um / n : 0.0);
    local.push_back(n > 0 ? wm / n : 0.0);
    local.push_back(n * cfg_.grid.dz());
  }
  const auto all = mac_.gather_columns(local);
  core::Profile p;
  for (int gi = 0; gi < cfg_.grid.nx; ++gi) {
    const double um = all[static_cast<std::size_t>(3 * gi)];
    const double wm = all[static_cast<std::size_t>(3 * gi + 1)];
    const double eps = um != 0.0 ? std::min(core::kEpsCap, std::abs(wm) / std::abs(um)) : 0.0;
    p.append((gi + 0.5) * cfg_.grid.dx(), all[static_cast<std::size_t>(3 * gi + 2)], um, eps,
             "2D");
  }
  return p;
}

core::MassBalance NdamSolver::mass_balance() const {
  // Incompressible and closed (or periodic): the mass per unit width is the fluid area, which
  // cannot change; the discrete divergence (reported separately) measures how well the velocity
  // field respects it.
  core::MassBalance m;
  if (cfg_.free_surface) {
    // the marker area (m^2 per unit width): initial, now, injected at the gate, removed at the
    // outflow; the defect is the marker count's, i.e. exactly 0 unless markers are lost.
    m.initial = mass0_;
    m.current = marker_mass_.area;
    m.inflow = marker_mass_.injected_area;
    m.outflow = marker_mass_.removed_area;
    // a gate's fractions of a marker (an interface's pending mass is the coupled ledger's,
    // Interface::carried)
    if (cfg_.inflow && !inflow_mass_) m.pending_inflow = marker_mass_.pending_area;
    return m;
  }
  m.initial = m.current = static_cast<double>(fluid_cells_) * cfg_.grid.dx() * cfg_.grid.dz();
  return m;
}

// The fastest material cell: the speed |(u_c, w_c)| of the cell-centred velocity (the mean of
// the cell's two faces in each direction, as fields.h5 writes it) over the Fluid and Surface
// cells. A face value alone is a boundary value where the cell has an empty side (continuity
// sends a layer's whole flux through its one free face). Collective: the largest over the
// ranks, its place from the rank that holds it.
core::Speed NdamSolver::max_speed() const {
  const int nz = cfg_.grid.nz, nxl = mac_.slab.nx_local;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  double best[3] = {0.0, 0.0, 0.0};  // |v|, x, z
  for (int i = 0; i < nxl; ++i) {
    const int gi = mac_.slab.i0 + i;
    for (int k = 0; k < nz; ++k) {
      if (!mac_.fluid(gi, k)) continue;
      const double uc = 0.5 * (u_(i - 1, k) + u_(i, k)), wc = 0.5 * (w_(i, k - 1) + w_(i, k));
      const double v = std::hypot(uc, wc);
      if (v > best[0]) best[0] = v, best[1] = (gi + 0.5) * dx, best[2] = (k + 0.5) * dz;
    }
  }
  struct {
    double v;
    int rank;
  } mine{best[0], mac_.slab.rank}, top{};
  MPI_Allreduce(&mine, &top, 1, MPI_DOUBLE_INT, MPI_MAXLOC, comm_);
  MPI_Bcast(best, 3, MPI_DOUBLE, top.rank, comm_);
  core::Speed s;
  s.value = best[0];
  s.x = cfg_.x0 + best[1];
  s.z = best[2];
  s.quantity = "|u|";
  return s;
}

void NdamSolver::write_fields(io::FieldWriter& wr) const {
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz;
  std::vector<double> xn(static_cast<std::size_t>(nx + 1)), zn(static_cast<std::size_t>(nz + 1));
  for (int i = 0; i <= nx; ++i) xn[static_cast<std::size_t>(i)] = cfg_.x0 + i * cfg_.grid.dx();
  for (int k = 0; k <= nz; ++k) zn[static_cast<std::size_t>(k)] = k * cfg_.grid.dz();
  Field uc(mac_.slab.nx_local, nz), wc(mac_.slab.nx_local, nz), dv(mac_.slab.nx_local, nz),
      fl(mac_.slab.nx_local, nz), pk(mac_.slab.nx_local, nz);
  for (int i = 0; i < mac_.slab.nx_local; ++i)
    for (int k = 0; k < nz; ++k) {
      const bool f = mac_.fluid(mac_.slab.i0 + i, k);
      uc(i, k) = f ? 0.5 * (u_(i, k) + u_(i - 1, k)) : 0.0;
      wc(i, k) = f ? 0.5 * (w_(i, k) + w_(i, k - 1)) : 0.0;
      dv(i, k) = f ? divergence(u_, w_, i, k) : 0.0;
      fl(i, k) = static_cast<double>(flag(mac_.slab.i0 + i, k));
      pk(i, k) = p_(i, k) * phys_.density;
    }
  auto& m = wr.add_mesh("ndam", std::move(xn), std::move(zn));
  m.cell_fields.emplace_back("u", mac_.gather_cells(uc, true));
  m.cell_fields.emplace_back("w", mac_.gather_cells(wc, true));
  m.cell_fields.emplace_back("p", mac_.gather_cells(p_, true));
  m.cell_fields.emplace_back("p_Pa", mac_.gather_cells(pk, true));
  m.cell_fields.emplace_back("nu_eff", mac_.gather_cells(nu_, true));
  m.cell_fields.emplace_back("div_u", mac_.gather_cells(dv, true));
  m.cell_fields.emplace_back("flag", mac_.gather_cells(fl, true));
}

bool NdamSolver::end_wall() const {
  return cfg_.free_surface && !cfg_.periodic_x() && !cfg_.outflow_right;
}

// The load on the end wall x = L from the wall column i = nx - 1 (owned by the last rank,
// broadcast). Per unit width, rho times (docs/numerics.md, "Wall load"):
//   force  = sum_k (p_k + g sin(zeta) dx / 2) dz                       over the material cells,
//   normal = sum_k (p_k + g sin(zeta) dx / 2 - 2 nu_k (0 - u*_{nx-2,k}) / dx) dz,
//   shear  = -sum_k tau_xz(L, z_k) dz,   tau_xz = nu_c (w*_ghost,k - w*_{nx-1,k}) / dx  (w faces).
// The pressure p^{n+1} is taken to the wall by the downslope gravity over the half cell (the
// wall holds the half cell's weight; the value the Coulomb law of the end wall uses,
// boundaries.cpp). The viscous stresses are the ones the step applied: nu_eff of the step (t^n)
// and the velocity u*, w* of the implicit viscous solve, with the ghost w* beyond the wall (the
// Coulomb Robin factor of the step, or the mirror of a no-slip or free-slip wall) and the
// stencil's corner viscosity nu_c (zero at a corner on the free surface); the wall face is
// wall-normal (u = 0), so du/dz does not enter tau_xz. Not u^{n+1}: where the material is
// (nearly) rigid, nu_eff ~ tau_y m_y and nu_eff dt / dx^2 reaches 10^3, so the projection's
// change of u, dt grad phi, changes 2 nu_eff D by more than the stress itself (measured: the
// impulse balance of a block hitting a wall, tests/ndam/test_ndam_wall.cpp, misses 30 % of
// the block's momentum with u^{n+1}, 1 % with u*). Material cells count whole (dz): the Surface
// cell's pressure is the free-surface value, about 0.
std::optional<core::WallLoad> NdamSolver::wall_load() const {
  if (!end_wall()) return std::nullopt;
  const int nx = cfg_.grid.nx, nz = cfg_.grid.nz, nxl = mac_.slab.nx_local;
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz(), rho = phys_.density;
  double v[5] = {0.0, 0.0, 0.0, 0.0, 0.0};  // force, normal, shear, p_foot, depth
  const int last = mac_.slab.ranks - 1;
  if (mac_.slab.rank == last) {
    // u*, w* of the last step; a state that has not been stepped since it was built or loaded
    // has only u, w (import_state sets u* = u).
    const Field& us = u_star_;
    const Field& ws = w_star_;
    const int i = nxl - 1, gi = nx - 1;
    for (int k = 0; k < nz; ++k) {
      if (!mac_.fluid(gi, k)) continue;
      const double pw = p_(i, k) + 0.5 * dx * phys_.gx;
      const double ux = (0.0 - us(i - 1, k)) / dx;
      v[0] += rho * pw * dz;
      v[1] += rho * (pw - 2.0 * nu_(i, k) * ux) * dz;
    }
    for (int k = 0; k < nz - 1; ++k) {
      const double wg = detail::value(w_ref(i + 1, k), ws);
      v[2] -= rho * nu_corner(i, k) * (wg - ws(i, k)) / dx * dz;
    }
    v[3] = mac_.fluid(gi, 0) ? rho * p_(i, 0) : 0.0;
    v[4] = col_h_.empty() ? 0.0 : col_h_[static_cast<std::size_t>(gi)];
  }
  MPI_Bcast(v, 5, MPI_DOUBLE, last, comm_);
  // contact: the marker depth of the wall column reaches a cell height (a coupled run's 2D part
  // sees the DAM front's thin film up to 0.05 s before the layer itself)
  return core::WallLoad{v[0], v[1], v[2], v[3], v[4], v[4] >= dz};
}

NdamState NdamSolver::export_state() const {
  NdamState s;
  s.t = t_;
  s.steps = steps_;
  s.nx = cfg_.grid.nx;
  s.nz = cfg_.grid.nz;
  s.u = gather_u();
  s.w = gather_w();
  s.p = gather_p();
  if (markers_) {
    // all markers (gathered, sorted by id), the gate's accumulators (rank 0 owns column 0), the
    // id counters (maxima over the ranks) and the global counters
    s.markers = markers_->gather();
    s.inflow_accumulators = markers_->inflow_accumulators();
    int n = static_cast<int>(s.inflow_accumulators.size());
    MPI_Bcast(&n, 1, MPI_INT, 0, comm_);
    s.inflow_accumulators.resize(static_cast<std::size_t>(n));
    MPI_Bcast(s.inflow_accumulators.data(), n, MPI_DOUBLE, 0, comm_);
    const MarkerState st = markers_->save();
    long long loc[2] = {st.inject_next, st.seed_base}, mx[2] = {0, 0};
    MPI_Allreduce(loc, mx, 2, MPI_LONG_LONG, MPI_MAX, comm_);
    s.inject_next = mx[0];
    s.seed_base = mx[1];
    s.injected = marker_mass_.injected;
    s.removed = marker_mass_.removed;
    s.mass0 = mass0_;
    s.inflow_owed = inflow_owed_;
    s.inflow_held = inflow_held_;
  }
  // the lagged Coulomb ghosts (a u + b): the owners' faces of every column, and the G ghost
  // faces beyond each end of the box (rank 0 and the last rank own those)
  {
    const int G = Field::G, nxl = mac_.slab.nx_local;
    auto bed = [&](const std::vector<double>& v) {
      const std::vector<double> own(v.begin() + G, v.begin() + G + nxl);
      const auto all = mac_.gather_columns(own);
      std::vector<double> ends(static_cast<std::size_t>(2 * G), 0.0);
      for (int q = 0; q < G; ++q) {
        ends[static_cast<std::size_t>(q)] = v[static_cast<std::size_t>(q)];
        ends[static_cast<std::size_t>(G + q)] = v[static_cast<std::size_t>(nxl + G + q)];
      }
      MPI_Bcast(ends.data(), G, MPI_DOUBLE, 0, comm_);
      MPI_Bcast(ends.data() + G, G, MPI_DOUBLE, mac_.slab.ranks - 1, comm_);
      std::vector<double> r(ends.begin(), ends.begin() + G);
      r.insert(r.end(), all.begin(), all.end());
      r.insert(r.end(), ends.begin() + G, ends.end());
      return r;
    };
    auto wall = [&](std::vector<double> v) {
      MPI_Bcast(v.data(), static_cast<int>(v.size()), MPI_DOUBLE, mac_.slab.ranks - 1, comm_);
      return v;
    };
    s.bed_factor = bed(bed_a_);
    s.bed_offset = bed(bed_b_);
    s.wall_factor = wall(wall_a_);
    s.wall_offset = wall(wall_b_);
    s.momentum_dt = momentum_dt_;
    s.friction_dt = friction_dt_;
    if (bed_stress_.nx_local() == nxl) {
      std::vector<double> own(static_cast<std::size_t>(nxl));
      for (int i = 0; i < nxl; ++i) own[static_cast<std::size_t>(i)] = bed_stress_(i, 0);
      s.bed_stress = mac_.gather_columns(own);
    }
  }
  s.surface_applied = true;
  return s;
}

// The state of `s` on this box: fields, markers (this rank takes those of its columns; the
// global counters go to rank 0, since MarkerSet::mass() sums the ranks' counters; every rank
// gets the gate's accumulators, of which only column 0's owner injects and counts them,
// MarkerSet::inflow_pending_markers), flags from the markers, and everything derived from them.
void NdamSolver::import_state(const NdamState& s) {
  if (s.nx != cfg_.grid.nx || s.nz != cfg_.grid.nz) {
    std::ostringstream os;
    os << "N-DAM state grid (" << s.nx << " x " << s.nz << " cells) does not match the box ("
       << cfg_.grid.nx << " x " << cfg_.grid.nz << ")";
    throw params::InputError(os.str());
  }
  t_ = s.t;
  steps_ = s.steps;
  mac_.scatter_cells(s.u, u_);
  mac_.scatter_cells(s.w, w_);
  mac_.scatter_cells(s.p, p_);
  if (markers_) {
    MarkerState st;
    const double dx = cfg_.grid.dx();
    for (const Marker& m : s.markers) {
      const int gi = std::clamp(static_cast<int>(std::floor(m.x / dx)), 0, cfg_.grid.nx - 1);
      if (gi >= mac_.slab.i0 && gi < mac_.slab.i0 + mac_.slab.nx_local) st.markers.push_back(m);
    }
    st.inflow_accumulators = s.inflow_accumulators;
    st.inject_next = s.inject_next;
    st.seed_base = s.seed_base;
    st.injected = mac_.slab.rank == 0 ? s.injected : 0;
    st.removed = mac_.slab.rank == 0 ? s.removed : 0;
    markers_->load(st);
    mass0_ = s.mass0;
    inflow_owed_ = inflow_owed_new_ = s.inflow_owed;
    inflow_held_ = inflow_held_new_ = s.inflow_held;
    marker_mass_ = markers_->mass();
    const auto old_flags = mac_.flags;
    update_flags(*markers_, mac_.flags, mac_.empty_mask, mac_.depth);
    mac_.classify_surface_pressure();
    if (mac_.flags != old_flags || mac_.ghost_surface) flags_changed_ = true;
    if (cfg_.inflow) inflow_now_ = cfg_.inflow(t_);
  }
  fluid_cells_ = 0;
  for (int gi = 0; gi < cfg_.grid.nx; ++gi)
    for (int k = 0; k < cfg_.grid.nz; ++k)
      if (mac_.p_unknown(gi, k)) ++fluid_cells_;
  momentum_dt_ = s.momentum_dt;
  friction_dt_ = s.friction_dt;
  const int G = Field::G, nxl = mac_.slab.nx_local;
  const bool factors = s.bed_factor.size() == static_cast<std::size_t>(cfg_.grid.nx + 2 * G) &&
                       s.wall_factor.size() == static_cast<std::size_t>(cfg_.grid.nz);
  // the ghosts the straight run's next step reads: the lagged ones of its last step (a state
  // of a version without the offsets b had b = 0)
  auto set_factors = [&] {
    const bool offsets =
        s.bed_offset.size() == s.bed_factor.size() && s.wall_offset.size() == s.wall_factor.size();
    for (int i = -G; i < nxl + G; ++i) {
      const int gi = mac_.slab.i0 + i;
      if (gi >= -G && gi < cfg_.grid.nx + G) {
        const auto f = static_cast<std::size_t>(i + G), g = static_cast<std::size_t>(gi + G);
        bed_a_[f] = s.bed_factor[g];
        bed_b_[f] = offsets ? s.bed_offset[g] : 0.0;
      }
    }
    exchange_bed_factors();
    wall_a_ = s.wall_factor;
    wall_b_ = offsets ? s.wall_offset : std::vector<double>(wall_a_.size(), 0.0);
  };
  if (factors) set_factors();
  // the bed's normal stress of the last step's balance (record_bed_stress), or none
  bed_stress_ = Field();
  if (s.bed_stress.size() == static_cast<std::size_t>(cfg_.grid.nx)) {
    bed_stress_ = Field(nxl, cfg_.grid.nz, std::numeric_limits<double>::quiet_NaN());
    for (int i = 0; i < nxl; ++i)
      bed_stress_(i, 0) = s.bed_stress[static_cast<std::size_t>(mac_.slab.i0 + i)];
    fill_scalar_ghosts(bed_stress_);
  }
  fill_velocity_ghosts(u_, w_, !s.surface_applied);
  fill_scalar_ghosts(p_);
  if (!factors) {
    // a state without them (a box rebuilt from converted columns): from the state itself
    update_viscosity(p_);
    fill_velocity_ghosts(u_, w_);
  }
  update_viscosity(p_);
  if (factors) set_factors();  // update_viscosity set them anew: step() reads the lagged ones
  if (markers_) update_profile_cache();
  u_new_ = u_;
  w_new_ = w_;
  p_new_ = p_;
  // No step has run on this state: the wall load takes its viscous stresses from u, w (the
  // next step overwrites these; nothing a step reads depends on them).
  u_star_ = u_;
  w_star_ = w_;
}

void NdamSolver::save(io::Checkpoint& c) const {
  const NdamState s = export_state();
  c.set("ndam/t", s.t);
  c.set("ndam/steps", static_cast<double>(s.steps));
  c.set("ndam/nx", static_cast<double>(s.nx));
  c.set("ndam/nz", static_cast<double>(s.nz));
  c.set("ndam/u", s.u);
  c.set("ndam/w", s.w);
  c.set("ndam/p", s.p);
  if (markers_) {
    // an id is stored as two doubles, its high and low 31 bits, since injected ids start at
    // 2^62, beyond a double's 53 bits
    std::vector<double> xs, zs, ids;
    for (const auto& m : s.markers) {
      xs.push_back(m.x);
      zs.push_back(m.z);
      ids.push_back(static_cast<double>(m.id >> 31));
      ids.push_back(static_cast<double>(m.id & ((1LL << 31) - 1)));
    }
    c.set("ndam/markers_x", xs);
    c.set("ndam/markers_z", zs);
    c.set("ndam/markers_id", ids);
    c.set("ndam/markers_accumulators", s.inflow_accumulators);
    // counters are stored as doubles: exact below 2^53 (they count markers)
    if (s.inject_next >= (1LL << 53) || s.seed_base >= (1LL << 53))
      throw std::logic_error("N-DAM checkpoint: a marker id counter beyond 2^53 (inject_next " +
                             std::to_string(s.inject_next) + ", seed_base " +
                             std::to_string(s.seed_base) + ") would not be stored exactly");
    c.set("ndam/markers_inject_next", static_cast<double>(s.inject_next));
    c.set("ndam/markers_seed_base", static_cast<double>(s.seed_base));
    c.set("ndam/markers_injected", static_cast<double>(s.injected));
    c.set("ndam/markers_removed", static_cast<double>(s.removed));
    c.set("ndam/mass0", s.mass0);
    c.set("ndam/inflow_owed", s.inflow_owed);
    c.set("ndam/inflow_held", s.inflow_held);
  }
  c.set("ndam/bed_factor", s.bed_factor);
  c.set("ndam/wall_factor", s.wall_factor);
  c.set("ndam/bed_offset", s.bed_offset);
  c.set("ndam/wall_offset", s.wall_offset);
  c.set("ndam/momentum_dt", s.momentum_dt);
  if (!s.bed_stress.empty()) {
    // NaN (no balance there) as 0 with a mask: a checkpoint holds finite numbers only
    std::vector<double> v(s.bed_stress.size(), 0.0), has(s.bed_stress.size(), 0.0);
    for (std::size_t q = 0; q < v.size(); ++q)
      if (std::isfinite(s.bed_stress[q])) {
        v[q] = s.bed_stress[q];
        has[q] = 1.0;
      }
    c.set("ndam/bed_stress", v);
    c.set("ndam/bed_stress_set", has);
  }
  c.set("ndam/friction_dt", s.friction_dt);
  c.set("ndam/surface_applied", s.surface_applied ? 1.0 : 0.0);
  // the slabs of a split by the work of the columns (load_balance.cpp): a restart on as many
  // ranks continues on them (its rebuilds then repeat the straight run's)
  if (!slab_starts_.empty())
    c.set("ndam/slab_starts", std::vector<double>(slab_starts_.begin(), slab_starts_.end()));
}

void NdamSolver::load(const io::Checkpoint& c) {
  if (static_cast<int>(c.scalar("ndam/nx")) != cfg_.grid.nx ||
      static_cast<int>(c.scalar("ndam/nz")) != cfg_.grid.nz) {
    std::ostringstream os;
    os << "checkpoint grid (" << c.scalar("ndam/nx") << " x " << c.scalar("ndam/nz")
       << " cells) does not match the scene (" << cfg_.grid.nx << " x " << cfg_.grid.nz << ")";
    throw params::InputError(os.str());
  }
  NdamState s;
  s.t = c.scalar("ndam/t");
  s.steps = static_cast<long>(c.scalar("ndam/steps"));
  s.nx = cfg_.grid.nx;
  s.nz = cfg_.grid.nz;
  s.u = c.array("ndam/u");
  s.w = c.array("ndam/w");
  s.p = c.array("ndam/p");
  if (markers_) {
    const auto& xs = c.array("ndam/markers_x");
    const auto& zs = c.array("ndam/markers_z");
    const auto& ids = c.array("ndam/markers_id");
    for (std::size_t q = 0; q < xs.size(); ++q)
      s.markers.push_back(Marker{xs[q], zs[q],
                                 (static_cast<long long>(ids[2 * q]) << 31) +
                                     static_cast<long long>(ids[2 * q + 1])});
    s.inflow_accumulators = c.array("ndam/markers_accumulators");
    s.inject_next = static_cast<long long>(c.scalar("ndam/markers_inject_next"));
    // checkpoints of a box the domain manager built before the counter was a count held
    // kInjectedIdBase + n, rounded to a double (not exact: such a restart is not bit for bit)
    if (s.inject_next >= kInjectedIdBase) s.inject_next -= kInjectedIdBase;
    s.seed_base = static_cast<long long>(c.scalar("ndam/markers_seed_base"));
    s.injected = static_cast<long long>(c.scalar("ndam/markers_injected"));
    s.removed = static_cast<long long>(c.scalar("ndam/markers_removed"));
    s.mass0 = c.scalar("ndam/mass0");
    if (c.scalars().count("ndam/inflow_owed")) s.inflow_owed = c.scalar("ndam/inflow_owed");
    if (c.scalars().count("ndam/inflow_held")) s.inflow_held = c.scalar("ndam/inflow_held");
  }
  if (c.arrays().count("ndam/bed_factor")) {
    s.bed_factor = c.array("ndam/bed_factor");
    s.wall_factor = c.array("ndam/wall_factor");
    if (c.arrays().count("ndam/bed_offset")) {
      s.bed_offset = c.array("ndam/bed_offset");
      s.wall_offset = c.array("ndam/wall_offset");
    }
    s.momentum_dt = c.scalar("ndam/momentum_dt");
    if (c.scalars().count("ndam/friction_dt")) s.friction_dt = c.scalar("ndam/friction_dt");
  }
  if (c.arrays().count("ndam/bed_stress") && c.arrays().count("ndam/bed_stress_set")) {
    s.bed_stress = c.array("ndam/bed_stress");
    const auto& has = c.array("ndam/bed_stress_set");
    for (std::size_t q = 0; q < s.bed_stress.size(); ++q)
      if (q >= has.size() || has[q] == 0.0) s.bed_stress[q] = std::numeric_limits<double>::quiet_NaN();
  }
  s.surface_applied = c.scalars().count("ndam/surface_applied") &&
                      c.scalar("ndam/surface_applied") != 0.0;
  // The checkpoint's slabs when it was written on as many ranks (else the equal split).
  std::vector<int> starts;
  if (c.arrays().count("ndam/slab_starts")) {
    const auto& a = c.array("ndam/slab_starts");
    if (static_cast<int>(a.size()) == mac_.slab.ranks + 1)
      for (double v : a) starts.push_back(static_cast<int>(v));
  }
  if (starts != slab_starts_) relayout(starts);
  import_state(s);
}

void NdamSolver::restart_point() {
  pressure_->invalidate_preconditioner();
  if (momentum_) momentum_->invalidate_preconditioner();
}

NdamStatistics NdamSolver::statistics() const {
  NdamStatistics s = stats_;
  s.retired_pressure_setups += pressure_->preconditioner_setups();
  s.retired_pressure_setup_seconds += pressure_->preconditioner_setup_seconds();
  s.retired_pressure_krylov_seconds += pressure_->krylov_seconds();
  s.retired_pressure_patterns += pressure_->pattern_builds();
  s.retired_preconditioner_retries += pressure_->preconditioner_retries();
  if (momentum_) {
    s.retired_preconditioner_retries += momentum_->preconditioner_retries();
    s.retired_momentum_setups += momentum_->preconditioner_setups();
    s.retired_momentum_setup_seconds += momentum_->preconditioner_setup_seconds();
    s.retired_momentum_krylov_seconds += momentum_->krylov_seconds();
    s.retired_momentum_patterns += momentum_->pattern_builds();
  }
  return s;
}

void NdamSolver::report(nlohmann::json& s) const {
  auto avg = [](long long its, long long n) { return n > 0 ? double(its) / double(n) : 0.0; };
  s["ndam"] = {
      {"cells_x", cfg_.grid.nx},
      {"cells_z", cfg_.grid.nz},
      {"dx", cfg_.grid.dx()},
      {"dz", cfg_.grid.dz()},
      {"ranks", mac_.slab.ranks},
      {"momentum", cfg_.momentum == Momentum::Explicit ? "Explicit" : "Implicit"},
      {"rheology", rheo_.name()},
      {"steps", steps_},
      {"dt_min", stats_.dt_min},
      {"dt_max", stats_.dt_max},
      {"max_divergence", stats_.max_divergence},
      {"max_nu_eff", max_nu_eff()},
      {"pressure_solves", stats_.pressure_solves},
      {"pressure_krylov_iterations", stats_.pressure_iterations},
      {"pressure_krylov_iterations_per_solve", avg(stats_.pressure_iterations, stats_.pressure_solves)},
      {"pressure_worst_relative_residual", stats_.worst_pressure_residual},
      {"pressure_max_krylov_iterations", stats_.pressure_max_iterations},
      {"pressure_stiff_solves", stats_.pressure_stiff_solves},
      {"pressure_max_surface_distance_cells", stats_.pressure_max_distance},
      {"momentum_solves", stats_.momentum_solves},
      {"momentum_krylov_iterations", stats_.momentum_iterations},
      {"momentum_krylov_iterations_per_solve", avg(stats_.momentum_iterations, stats_.momentum_solves)},
      {"momentum_worst_relative_residual", stats_.worst_momentum_residual},
      {"momentum_max_krylov_iterations", stats_.momentum_max_iterations},
      {"momentum_stiff_solves", stats_.momentum_stiff_solves},
      {"momentum_stiff_krylov_iterations_per_solve",
       avg(stats_.momentum_stiff_iterations, stats_.momentum_stiff_solves)},
      {"momentum_stiff_max_krylov_iterations", stats_.momentum_stiff_max_iterations},
      {"unconverged_solves", stats_.unconverged_solves},
      {"load_balance",
       {{"checks", stats_.balance_checks},
        {"rebuilds", stats_.rebalances},
        {"seconds", stats_.rebalance_seconds},
        {"mean_imbalance", stats_.balance_checks > 0
                               ? stats_.imbalance_sum / static_cast<double>(stats_.balance_checks)
                               : 1.0},
        {"max_imbalance", stats_.balance_checks > 0 ? stats_.imbalance_max : 1.0},
        {"note", "imbalance: the work (material cells) of the most loaded rank over the mean, "
                 "at each check before a rebuild"}}},
      {"pressure_preconditioner_setups",
       pressure_->preconditioner_setups() + stats_.retired_pressure_setups},
      {"pressure_preconditioner_setup_seconds",
       pressure_->preconditioner_setup_seconds() + stats_.retired_pressure_setup_seconds},
      {"pressure_krylov_seconds",
       pressure_->krylov_seconds() + stats_.retired_pressure_krylov_seconds},
      {"pressure_pattern_builds", pressure_->pattern_builds() + stats_.retired_pressure_patterns},
      {"momentum_pattern_builds",
       (momentum_ ? momentum_->pattern_builds() : 0LL) + stats_.retired_momentum_patterns},
      {"momentum_preconditioner_setups",
       (momentum_ ? momentum_->preconditioner_setups() : 0LL) + stats_.retired_momentum_setups},
      {"momentum_preconditioner_setup_seconds",
       (momentum_ ? momentum_->preconditioner_setup_seconds() : 0.0) +
           stats_.retired_momentum_setup_seconds},
      {"momentum_krylov_seconds",
       (momentum_ ? momentum_->krylov_seconds() : 0.0) + stats_.retired_momentum_krylov_seconds},
      {"preconditioner_retries",
       pressure_->preconditioner_retries() +
           (momentum_ ? momentum_->preconditioner_retries() : 0LL) +
           stats_.retired_preconditioner_retries},
      {"free_surface", cfg_.free_surface}};
  if (cfg_.free_surface) {
    s["ndam"]["markers"] = marker_mass_.count;
    s["ndam"]["marker_area"] = marker_mass_.area;
    s["ndam"]["seconds_markers_last_step"] = stats_.step_markers;
    s["ndam"]["marker_void_fills"] = {
        {"markers", stats_.marker_void_fills},
        {"steps", stats_.marker_void_steps},
        {"note", "markers moved into enclosed voids of the sampling, each by about a cell (at most about two) "
                 "(docs/numerics.md, 'Voids of the marker sampling')"}};
    // What the gate or the interface admitted that is not yet markers: the rows' fractions of a
    // marker (under one marker per open marker row) and an interface's owed and held mass. The
    // mass balance counts markers (net_in = the injected markers), so this is the part of
    // int h u dt at the left end that the balance does not show yet.
    if (cfg_.inflow || inflow_mass_) {
      s["ndam"]["inflow_pending_area"] = inflow_pending();
      s["ndam"]["inflow_pending_note"] =
          "m^2 admitted at the left end and not yet a marker (the open marker rows' fractions "
          "of a marker, an interface's owed and held mass); mass_balance counts the injected "
          "markers";
    }
  }
  // The nonlinear pressure system (Pressure coupling = Nonlinear): Newton and Krylov (GMRES)
  // iterations per step, residual evaluations (each one predictor-projection).
  s["ndam"]["pressure_coupling"] =
      cfg_.pressure_coupling == PressureCoupling::Nonlinear ? "Nonlinear" : "Lagged";
  if (stats_.newton_solves > 0)
    s["ndam"]["newton"] = {{"solves", stats_.newton_solves},
                           {"newton_iterations", stats_.newton_iterations},
                           {"newton_iterations_per_step", avg(stats_.newton_iterations, stats_.newton_solves)},
                           {"newton_iterations_max", stats_.newton_max_iterations},
                           {"krylov_iterations", stats_.newton_krylov},
                           {"krylov_iterations_per_step", avg(stats_.newton_krylov, stats_.newton_solves)},
                           {"residual_evaluations", stats_.newton_evaluations},
                           {"residual_evaluations_per_step", avg(stats_.newton_evaluations, stats_.newton_solves)},
                           {"anderson_fallbacks", stats_.newton_fallbacks},
                           {"anderson_fallbacks_converged", stats_.newton_fallbacks_converged},
                           {"worst_final_residual", stats_.newton_worst_residual},
                           {"unconverged_steps_continued", stats_.newton_continued},
                           {"worst_residual_continued", stats_.newton_continued_worst},
                           {"seconds", stats_.newton_seconds}};
  // The Coulomb friction of the momentum step (Newton's method on the step's mean friction
  // factor, boundaries.cpp): momentum solves beyond the first of a step, the most solves of a
  // step, and the steps that stopped at the limit with their worst residual (units of the
  // Coulomb bound tan(delta) N).
  if (cfg_.momentum == Momentum::Implicit &&
      (cfg_.walls[1].kind == WallKind::Coulomb || cfg_.walls[2].kind == WallKind::Coulomb))
    s["ndam"]["friction"] = {{"extra_momentum_solves", stats_.friction_solves},
                             {"max_solves_per_step", stats_.friction_max_solves},
                             {"unconverged_steps", stats_.friction_unconverged},
                             {"worst_unconverged_residual", stats_.friction_worst_residual}};
  // Wall time per phase over the accepted steps (this rank): momentum predictor, pressure
  // solve, markers (advection, injection, flags), and the rest of the step (viscosity,
  // correction, ghost exchange).
  s["ndam"]["seconds"] = {{"momentum", stats_.total_momentum},
                          {"pressure", stats_.total_pressure},
                          {"markers", stats_.total_markers},
                          {"other", stats_.total_other}};
}

}  // namespace granflow::ndam
