// Conservative state conversion for a change of the coupled layout (conversion.hpp).
#include "granflow/coupling/conversion.hpp"

#include "granflow/dam/dam_solver.hpp"
#include "granflow/ndam/ndam_solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace granflow::coupling {

namespace {
// Two positions are the same node when they agree to round-off of the channel coordinates.
bool same_node(double a, double b) { return std::abs(a - b) <= 1e-12 * (1.0 + std::abs(a)); }

// Below this |u_mean| a neighbouring 2D column is at rest and has no profile shape to lend:
// a new column then starts as a plug (eq. 25 needs a moving profile). In units of the grid's
// gravity-wave speed sqrt(g cos(zeta) dz), so that a scene scaled by Froude similarity takes the
// same branch: 0.9 mm/s at 5 mm cells on 50 deg (1 mm/s, a constant, before 2026-12-06).
constexpr double kShapeSpeedWaves = 0.005;
}  // namespace

std::array<double, 2> ChannelField::integral(double a, double b) const {
  std::array<double, 2> s{0.0, 0.0};
  if (!(b > a) || x.empty()) return s;
  auto it = std::upper_bound(x.begin(), x.end(), a);
  std::size_t i = it == x.begin() ? 0 : static_cast<std::size_t>(it - x.begin()) - 1;
  for (; i + 1 < x.size() && x[i] < b; ++i) {
    const double l = std::max(a, x[i]), r = std::min(b, x[i + 1]);
    if (r > l) {
      s[0] += h[i] * (r - l);
      s[1] += hu[i] * (r - l);
    }
  }
  return s;
}

std::array<double, 2> ChannelField::average(double a, double b) const {
  auto it = std::upper_bound(x.begin(), x.end(), a);
  if (it != x.begin()) {
    const auto i = static_cast<std::size_t>(it - x.begin()) - 1;
    if (i + 1 < x.size() && same_node(x[i], a) && same_node(x[i + 1], b)) return {h[i], hu[i]};
    // a may lie a round-off below the node of cell i + 1
    if (i + 2 < x.size() && same_node(x[i + 1], a) && same_node(x[i + 2], b))
      return {h[i + 1], hu[i + 1]};
  }
  const auto s = integral(a, b);
  return {s[0] / (b - a), s[1] / (b - a)};
}

ChannelField channel_field(const std::vector<Subdomain>& parts, std::size_t first,
                           std::size_t count) {
  ChannelField f;
  auto add = [&f](double l, double r, double h, double hu) {
    if (f.x.empty()) f.x.push_back(l);
    f.x.back() = l;  // the same node as the previous part's end
    f.x.push_back(r);
    f.h.push_back(h);
    f.hu.push_back(hu);
  };
  for (std::size_t p = first; p < first + count; ++p) {
    const Subdomain& s = parts[p];
    if (s.dam) {
      const auto& d = *s.dam;
      const double dx = d.dx();
      const auto& h = d.h();
      const auto& hu = d.hu();
      const std::size_t n = h.size();
      for (std::size_t j = 0; j < n; ++j) {
        // primary: [x0 + j dx, x0 + (j + 1) dx]; staggered: centred on x0 + j dx, the end
        // cells clipped to their halves inside the part
        double l = s.x0 + (static_cast<double>(j) - (d.staggered() ? 0.5 : 0.0)) * dx;
        double r = l + dx;
        l = std::max(l, s.x0);
        r = j + 1 == n ? s.x1 : std::min(r, s.x1);
        add(l, r, h[j], hu[j]);
      }
    } else {
      const auto prof = s.ndam->profile();
      const double dx = s.ndam->grid().dx();
      const std::size_t n = prof.h.size();
      for (std::size_t j = 0; j < n; ++j) {
        const double l = s.x0 + static_cast<double>(j) * dx;
        const double r = j + 1 == n ? s.x1 : l + dx;
        add(l, r, prof.h[j], prof.h[j] * prof.u_mean[j]);
      }
    }
  }
  return f;
}

namespace {

// An old 2D part's state, for copying its columns.
struct OldBox {
  double x0 = 0.0, x1 = 0.0, dx = 0.0;
  ndam::NdamState state;
  ndam::NdamStatistics stats;
  std::vector<double> u_mean;              // eq. (21) per column
  std::vector<std::vector<std::size_t>> column_markers;  // marker indices per column
};

// The planned columns of a new 2D part before it is built.
struct NewBox {
  std::size_t piece = 0;
  int nx = 0, nz = 0;
  double dx = 0.0, dz = 0.0;
  std::vector<int> src_box, src_col;  // per column: the old box and column copied, or -1
  std::vector<double> mass, momentum;  // per filled column, from the field [m^2, m^3/s]
  double held = 0.0;                   // inflow mass to carry, into its held pool [m^2]
};

}  // namespace

std::vector<Subdomain> rebuild(const std::vector<Subdomain>& parts, std::size_t first,
                               std::size_t count, const std::vector<Piece>& plan,
                               const SubdomainFactory& factory, ConversionRecord& rec) {
  if (plan.empty() || count == 0) throw std::invalid_argument("coupling::rebuild: empty plan");
  const double a = parts[first].x0, b = parts[first + count - 1].x1;
  const double t = parts[first].model->time();
  const ChannelField field = channel_field(parts, first, count);
  const auto before = field.integral(a, b);
  rec.mass_before = before[0];
  rec.momentum_before = before[1];

  // The old 2D parts of the interval (collective export).
  std::vector<OldBox> old;
  for (std::size_t p = first; p < first + count; ++p) {
    if (!parts[p].ndam) continue;
    OldBox o;
    o.x0 = parts[p].x0;
    o.x1 = parts[p].x1;
    o.dx = parts[p].ndam->grid().dx();
    o.state = parts[p].ndam->export_state();
    o.stats = parts[p].ndam->statistics();
    o.u_mean = parts[p].ndam->profile().u_mean;
    o.column_markers.resize(static_cast<std::size_t>(o.state.nx));
    for (std::size_t q = 0; q < o.state.markers.size(); ++q) {
      const int gi = std::clamp(static_cast<int>(std::floor(o.state.markers[q].x / o.dx)), 0,
                                o.state.nx - 1);
      o.column_markers[static_cast<std::size_t>(gi)].push_back(q);
    }
    old.push_back(std::move(o));
  }
  auto old_box_at = [&](double x) -> int {
    for (std::size_t q = 0; q < old.size(); ++q)
      if (x > old[q].x0 && x < old[q].x1) return static_cast<int>(q);
    return -1;
  };
  auto old_dam_at = [&](double l, double r) -> const dam::DamSolver* {
    const dam::DamSolver* best = nullptr;
    double overlap = 0.0;
    for (std::size_t p = first; p < first + count; ++p) {
      if (!parts[p].dam) continue;
      const double o = std::min(r, parts[p].x1) - std::max(l, parts[p].x0);
      if (o > overlap) {
        overlap = o;
        best = parts[p].dam;
      }
    }
    return best;
  };

  // --- plan the 2D columns ----------------------------------------------------------------
  std::vector<NewBox> boxes;
  const double area = [&] {
    if (!factory.has_2d()) return 0.0;
    const auto& c = factory.two_d().cfg;
    const double dx2 = factory.dx_2d(), dz2 = c.grid.dz();
    return dx2 * dz2 / (c.markers_per_cell * c.markers_per_cell);
  }();
  for (std::size_t i = 0; i < plan.size(); ++i) {
    if (plan[i].kind != "2D") continue;
    const Piece& pc = plan[i];
    NewBox nb;
    nb.piece = i;
    const auto cfg2 = factory.ndam_config(pc.x0, pc.x1, Neighbours{true, true});
    nb.nx = cfg2.grid.nx;
    nb.nz = cfg2.grid.nz;
    nb.dx = cfg2.grid.dx();
    nb.dz = cfg2.grid.dz();
    nb.src_box.assign(static_cast<std::size_t>(nb.nx), -1);
    nb.src_col.assign(static_cast<std::size_t>(nb.nx), -1);
    nb.mass.assign(static_cast<std::size_t>(nb.nx), 0.0);
    nb.momentum.assign(static_cast<std::size_t>(nb.nx), 0.0);
    for (int j = 0; j < nb.nx; ++j) {
      const double l = pc.x0 + j * nb.dx, r = j + 1 == nb.nx ? pc.x1 : l + nb.dx;
      const int q = old_box_at(0.5 * (l + r));
      if (q >= 0) {
        nb.src_box[static_cast<std::size_t>(j)] = q;
        nb.src_col[static_cast<std::size_t>(j)] = std::clamp(
            static_cast<int>(std::floor((0.5 * (l + r) - old[static_cast<std::size_t>(q)].x0) /
                                        old[static_cast<std::size_t>(q)].dx)),
            0, old[static_cast<std::size_t>(q)].state.nx - 1);
      } else {
        const auto s = field.integral(l, r);
        nb.mass[static_cast<std::size_t>(j)] = s[0];
        nb.momentum[static_cast<std::size_t>(j)] = s[1];
        ++rec.columns_to_2d;
      }
    }
    boxes.push_back(std::move(nb));
  }
  // Inflow mass pending at an old 1D-to-2D interface (the gate's fractional markers and the
  // carried mass) that does not stay where it was: it goes to the first new 2D part that
  // contains or follows the old interface, to be injected at that part's upstream interface.
  std::vector<std::pair<double, double>> pending_to_dam;  // (old interface x, mass)
  for (const auto& o : old) {
    bool kept = false;
    for (const auto& nb : boxes) kept = kept || same_node(plan[nb.piece].x0, o.x0);
    if (kept) continue;  // the same gate: its accumulators are copied
    double acc = 0.0;
    for (double v : o.state.inflow_accumulators) acc += v;
    const double pending = o.state.inflow_owed + o.state.inflow_held + acc * area;
    if (pending == 0.0) continue;
    NewBox* to = nullptr;
    for (auto& nb : boxes)
      if (plan[nb.piece].x1 > o.x0 + 1e-12) {
        to = &nb;
        break;
      }
    // A box at the channel's upstream end (the gate part) has no upstream interface to inject
    // owed mass through: its inflow is the gate's. Such mass (a 2D part behind a vanished DAM,
    // merged into the gate part: 7.8e-6 m^2 in a hostile-user five-part layout, where it was
    // dropped from the ledger, relative defect -8e-4) is booked as unplaced instead.
    if (to && to->piece == 0 && first == 0) {
      rec.pending_lost += pending;
      continue;
    }
    if (to) {
      to->held += pending;
      continue;
    }
    // No 2D part follows: the old interface's upstream side (a DAM) has already let this mass
    // out, so it goes back into the 1D part that now covers the old interface, at the old
    // interface's place (below, once that part's cells are built).
    pending_to_dam.push_back({o.x0, pending});
  }
  for (std::size_t p = first; p < first + count; ++p)
    if (parts[p].ndam) {
      // columns of an old 2D part that become 1D
      const double dx = parts[p].ndam->grid().dx();
      for (int g = 0; g < parts[p].ndam->grid().nx; ++g) {
        const double xc = parts[p].x0 + (g + 0.5) * dx;
        bool in2d = false;
        for (const auto& pc : plan)
          if (pc.kind == "2D" && xc > pc.x0 && xc < pc.x1) in2d = true;
        if (!in2d) ++rec.columns_to_1d;
      }
    }

  // Marker counts of the filled columns: the fraction of a marker that one column cannot take
  // is carried to the next filled column (error diffusion), so a box's filled columns leave one
  // remainder below one marker in all, and no column is more than one marker off its mass.
  std::vector<std::vector<long long>> nmark(boxes.size());
  std::vector<double> box_remainder(boxes.size(), 0.0);
  for (std::size_t q = 0; q < boxes.size(); ++q) {
    nmark[q].assign(static_cast<std::size_t>(boxes[q].nx), 0);
    double carry = 0.0;
    for (int j = 0; j < boxes[q].nx; ++j) {
      if (boxes[q].src_box[static_cast<std::size_t>(j)] >= 0) continue;
      const double m = boxes[q].mass[static_cast<std::size_t>(j)] + carry;
      const long long n = m > 0.0 ? static_cast<long long>(std::floor(m / area + 1e-9)) : 0;
      nmark[q][static_cast<std::size_t>(j)] = n;
      carry = m - static_cast<double>(n) * area;
    }
    box_remainder[q] = carry;
    rec.remainder += carry;
  }

  // --- the 1D cells ----------------------------------------------------------------------------
  struct NewDam {
    std::vector<double> h, hu;
    bool staggered = false;
    long steps = 0;
  };
  std::vector<NewDam> dams(plan.size());
  for (std::size_t i = 0; i < plan.size(); ++i) {
    if (plan[i].kind != "1D") continue;
    const Piece& pc = plan[i];
    const int n = factory.dam_cells(pc.x0, pc.x1);
    const double dx = (pc.x1 - pc.x0) / n;
    const dam::DamSolver* src = old_dam_at(pc.x0, pc.x1);
    NewDam& d = dams[i];
    d.staggered = src && src->staggered();
    d.steps = src ? src->steps() : 0;
    const int cells = n + (d.staggered ? 1 : 0);
    for (int j = 0; j < cells; ++j) {
      double l = pc.x0 + (j - (d.staggered ? 0.5 : 0.0)) * dx, r = l + dx;
      l = std::max(l, pc.x0);
      r = j + 1 == cells ? pc.x1 : std::min(r, pc.x1);
      const auto v = field.average(l, r);
      d.h.push_back(v[0]);
      d.hu.push_back(v[1]);
    }
  }
  // Pending inflow without a 2D part to take it: into the cell of the 1D part just downstream
  // of the old interface (where the 2D part would have injected it), at that cell's velocity
  // (hu grows with h, u_mean kept); the cell's width on the DAM's grid phase (the staggered
  // grid's end cells are half cells inside the part).
  for (const auto& [x, m] : pending_to_dam) {
    std::size_t i = 0;
    while (i + 1 < plan.size() && !(x + 1e-12 < plan[i].x1)) ++i;
    NewDam& d = dams[i];
    if (plan[i].kind != "1D" || d.h.empty()) {
      rec.pending_lost += m;
      continue;
    }
    const Piece& pd = plan[i];
    const int n = factory.dam_cells(pd.x0, pd.x1);
    const double dx = (pd.x1 - pd.x0) / n;
    const double xi = (x + 1e-12 - pd.x0) / dx + (d.staggered ? 0.5 : 0.0);
    const auto c = static_cast<std::size_t>(
        std::clamp(static_cast<int>(std::floor(xi)), 0, static_cast<int>(d.h.size()) - 1));
    const bool half = d.staggered && (c == 0 || c + 1 == d.h.size());
    const double w = half ? 0.5 * dx : dx;
    const double u = d.h[c] > 0.0 ? d.hu[c] / d.h[c] : 0.0;
    d.h[c] += m / w;
    d.hu[c] += m / w * u;
    rec.pending_to_1d += m;
  }
  // The remainders go back to the DAM cell next to the filled columns (mass exact), else to the
  // inflow of a 2D part behind a 1D-to-2D interface; what finds no place stays booked.
  double rest = rec.remainder;
  if (rest != 0.0) {
    for (std::size_t q = 0; q < boxes.size() && rest != 0.0; ++q) {
      const std::size_t i = boxes[q].piece;
      int j_first = -1, j_last = -1;
      for (int j = 0; j < boxes[q].nx; ++j)
        if (boxes[q].src_box[static_cast<std::size_t>(j)] < 0) {
          if (j_first < 0) j_first = j;
          j_last = j;
        }
      if (j_first < 0) continue;
      const double mine = box_remainder[q];
      NewDam* to = nullptr;
      bool at_end = false;  // the DAM's last cell (upstream of the box) or its first
      if (j_first == 0 && i > 0 && plan[i - 1].kind == "1D") {
        to = &dams[i - 1];
        at_end = true;
      } else if (j_last == boxes[q].nx - 1 && i + 1 < plan.size() && plan[i + 1].kind == "1D") {
        to = &dams[i + 1];
      }
      if (to && !to->h.empty()) {
        const Piece& pd = plan[at_end ? i - 1 : i + 1];
        const int n = factory.dam_cells(pd.x0, pd.x1);
        const double dx = (pd.x1 - pd.x0) / n;
        // into the two DAM cells next to the box, in proportion to their widths, at their own
        // velocity (hu grows with h, u_mean is kept)
        const std::size_t n_cells = to->h.size();
        const std::size_t c0 = at_end ? n_cells - 1 : 0, c1 = at_end ? n_cells - 2 : 1;
        const double w0 = to->staggered ? 0.5 * dx : dx, w1 = n_cells > 1 ? dx : 0.0;
        for (const auto& [c, w] : {std::pair<std::size_t, double>{c0, w0}, {c1, w1}}) {
          if (!(w > 0.0)) continue;
          const double dh = mine * (w / (w0 + w1)) / w;
          const double u = to->h[c] > 0.0 ? to->hu[c] / to->h[c] : 0.0;
          to->h[c] += dh;
          to->hu[c] += dh * u;
        }
        rec.remainder_given_back += mine;
        rest -= mine;
      } else if (i > 0 || first > 0) {
        boxes[q].held += mine;  // injected later through the upstream interface
        rec.remainder_given_back += mine;
        rec.remainder_to_inflow += mine;
        rest -= mine;
      }
    }
    rec.remainder_unplaced = rest;
  }

  // --- build the parts ---------------------------------------------------------------------------
  std::vector<Subdomain> out;
  const bool up_outside = first > 0, down_outside = first + count < parts.size();
  std::size_t box_index = 0;
  for (std::size_t i = 0; i < plan.size(); ++i) {
    const Piece& pc = plan[i];
    const Neighbours nbr{i > 0 || up_outside, i + 1 < plan.size() || down_outside};
    if (pc.kind == "1D") {
      NewDam& d = dams[i];
      out.push_back(factory.dam(pc.x0, pc.x1, std::move(d.h), std::move(d.hu), t, d.steps, nbr,
                                d.staggered));
      continue;
    }
    NewBox& nb = boxes[box_index];
    const auto& mk = nmark[box_index];
    ++box_index;
    const int nx = nb.nx, nz = nb.nz;
    const auto ncell = static_cast<std::size_t>(nx * nz);
    ndam::NdamState st;
    st.t = t;
    st.nx = nx;
    st.nz = nz;
    st.u.assign(ncell, 0.0);
    st.w.assign(ncell, 0.0);
    st.p.assign(ncell, 0.0);
    // the bed's normal stress of the last step's balance: copied columns keep theirs, filled
    // ones have none (NaN: their first step takes eq. (13) from p)
    st.bed_stress.assign(static_cast<std::size_t>(nx), std::numeric_limits<double>::quiet_NaN());
    ndam::NdamStatistics stats;
    bool first_stats = true;
    for (const auto& o : old) {
      if (!(o.x1 > pc.x0 && o.x0 < pc.x1)) continue;
      if (first_stats) stats = o.stats;
      else stats.merge(o.stats);
      first_stats = false;
      st.steps = std::max(st.steps, o.state.steps);
      st.seed_base = std::max(st.seed_base, o.state.seed_base);
      st.inject_next = std::max(st.inject_next, o.state.inject_next);
      if (same_node(o.x0, pc.x0)) {  // the same upstream end: its gate state continues
        st.inflow_accumulators = o.state.inflow_accumulators;
        st.inflow_owed = o.state.inflow_owed;
        st.inflow_held = o.state.inflow_held;
        st.injected = o.state.injected;
      }
      if (same_node(o.x1, pc.x1)) st.removed = o.state.removed;
    }
    if (first_stats) st.steps = parts[first].model->steps();
    // Filled markers take ids of the box's injected range, kInjectedIdBase + its counter (the
    // counter continues the old boxes' largest; ids are hashed into the injected markers'
    // heights, so a restart must see the same counter, and a counter that held 2^62 itself lost
    // its last bits in the checkpoint's double and overflowed the ids)
    // The carried mass of a vanished gate and the columns' remainders enter through the held
    // pool, spread over the next steps (NdamSolver::gate_state): let in at once, the vanished
    // gate's fractional markers (up to one marker per row, 2.1e-5 m^2 in a 1D -> 2D move of the
    // suite at 10 mm, 60 % of a step's mass) opened the new first 2D column a row deeper than
    // the layer, and it filled and slowed for 0.01 s (u_mean 2.18 against 2.53 m/s).
    st.inflow_held += nb.held;
    // centre velocity of column j (cell k) and its depth, for copied and filled columns
    std::vector<std::vector<double>> uc(static_cast<std::size_t>(nx),
                                        std::vector<double>(static_cast<std::size_t>(nz), 0.0));
    std::vector<double> hcol(static_cast<std::size_t>(nx), 0.0);
    for (int j = 0; j < nx; ++j) {
      const int q = nb.src_box[static_cast<std::size_t>(j)];
      if (q < 0) continue;
      const OldBox& o = old[static_cast<std::size_t>(q)];
      const int g = nb.src_col[static_cast<std::size_t>(j)];
      for (int k = 0; k < nz; ++k) {
        const auto dst = static_cast<std::size_t>(j * nz + k);
        const auto src = static_cast<std::size_t>(g * nz + k);
        st.u[dst] = o.state.u[src];
        st.w[dst] = o.state.w[src];
        st.p[dst] = o.state.p[src];
        const double ul = g > 0 ? o.state.u[src - static_cast<std::size_t>(nz)] : o.state.u[src];
        uc[static_cast<std::size_t>(j)][static_cast<std::size_t>(k)] = 0.5 * (ul + o.state.u[src]);
      }
      for (std::size_t m : o.column_markers[static_cast<std::size_t>(g)]) {
        ndam::Marker mm = o.state.markers[m];
        const double frac = std::clamp(mm.x - g * o.dx, 0.0, nb.dx * (1.0 - 1e-12));
        mm.x = j * nb.dx + frac;
        st.markers.push_back(mm);
      }
      if (o.state.bed_stress.size() == static_cast<std::size_t>(o.state.nx))
        st.bed_stress[static_cast<std::size_t>(j)] = o.state.bed_stress[static_cast<std::size_t>(g)];
      hcol[static_cast<std::size_t>(j)] =
          static_cast<double>(o.column_markers[static_cast<std::size_t>(g)].size()) * area / nb.dx;
    }
    // filled columns: markers, u(z) (eq. 25), p (eq. 26)
    const auto& cfg2 = factory.two_d().cfg;
    const int nmx = cfg2.markers_per_cell, nmz = cfg2.markers_per_cell;
    const double sx = nb.dx / nmx, sz = nb.dz / nmz;
    const double gcos = std::abs(factory.two_d().physics.gz), K = factory.interface_options().K;
    const double shape_speed = kShapeSpeedWaves * std::sqrt(gcos * nb.dz);  // rest: a plug
    for (int j = 0; j < nx; ++j) {
      if (nb.src_box[static_cast<std::size_t>(j)] >= 0) continue;
      const long long n = mk[static_cast<std::size_t>(j)];
      const long long full = n / nmx, partial = n % nmx;
      if ((full + (partial ? 1 : 0)) * sz > cfg2.grid.lz)
        throw std::runtime_error("domain manager: the 1D depth " +
                                 std::to_string(nb.mass[static_cast<std::size_t>(j)] / nb.dx) +
                                 " m at x = " + std::to_string(pc.x0 + (j + 0.5) * nb.dx) +
                                 " m does not fit into the 2D box of height " +
                                 std::to_string(cfg2.grid.lz) + " m (N-DAM->Height)");
      for (long long r = 0; r < full; ++r)
        for (int q = 0; q < nmx; ++q)
          st.markers.push_back(ndam::Marker{j * nb.dx + (q + 0.5) * sx, (r + 0.5) * sz,
                                            ndam::kInjectedIdBase + st.inject_next++});
      for (long long q = 0; q < partial; ++q) {
        const auto slot = static_cast<int>(std::floor((q + 0.5) * nmx / partial));
        st.markers.push_back(ndam::Marker{j * nb.dx + (slot + 0.5) * sx, (full + 0.5) * sz,
                                          ndam::kInjectedIdBase + st.inject_next++});
      }
      const double h = static_cast<double>(n) * area / nb.dx;
      hcol[static_cast<std::size_t>(j)] = h;
      const double M = nb.mass[static_cast<std::size_t>(j)];
      const double um = M > 0.0 ? nb.momentum[static_cast<std::size_t>(j)] / M : 0.0;
      // the shape of the nearest copied column (eq. 25: d/dx d/dz u = 0), plug if it rests
      int nbj = -1;
      for (int d = 1; d < nx && nbj < 0; ++d) {
        if (j - d >= 0 && nb.src_box[static_cast<std::size_t>(j - d)] >= 0) nbj = j - d;
        else if (j + d < nx && nb.src_box[static_cast<std::size_t>(j + d)] >= 0) nbj = j + d;
      }
      std::vector<double> phi(static_cast<std::size_t>(nz), 1.0);
      if (nbj >= 0) {
        const OldBox& o = old[static_cast<std::size_t>(nb.src_box[static_cast<std::size_t>(nbj)])];
        const double unb = o.u_mean[static_cast<std::size_t>(nb.src_col[static_cast<std::size_t>(nbj)])];
        const double hnb = hcol[static_cast<std::size_t>(nbj)];
        const int knb = static_cast<int>(std::ceil(hnb / nb.dz));
        if (std::abs(unb) > shape_speed && knb >= 2 && h > 0.0)
          for (int k = 0; k < nz; ++k) {
            const double zeta = std::min(1.0, (k + 0.5) * nb.dz / h);
            const double s = std::clamp(zeta * hnb / nb.dz - 0.5, 0.0, knb - 1.0);
            const int k0 = static_cast<int>(std::floor(s)), k1 = std::min(k0 + 1, knb - 1);
            const double f = s - k0;
            const auto& u = uc[static_cast<std::size_t>(nbj)];
            phi[static_cast<std::size_t>(k)] =
                ((1.0 - f) * u[static_cast<std::size_t>(k0)] + f * u[static_cast<std::size_t>(k1)]) / unb;
          }
      }
      double mean = 0.0;
      for (int k = 0; k < nz; ++k) mean += std::clamp(h - k * nb.dz, 0.0, nb.dz) * phi[static_cast<std::size_t>(k)];
      mean = h > 0.0 ? mean / h : 0.0;
      const double c = std::abs(mean) > 1e-12 ? um / mean : um;
      for (int k = 0; k < nz; ++k) {
        const double len = std::clamp(h - k * nb.dz, 0.0, nb.dz);
        const double zc = (k + 0.5) * nb.dz;
        uc[static_cast<std::size_t>(j)][static_cast<std::size_t>(k)] =
            len > 0.0 ? c * (std::abs(mean) > 1e-12 ? phi[static_cast<std::size_t>(k)] : 1.0) : 0.0;
        st.p[static_cast<std::size_t>(j * nz + k)] =
            zc < h ? gcos * (h - zc) * (1.0 + K) / 2.0 : 0.0;  // eq. (26)
      }
    }
    // faces next to a filled column: the mean of the two centre profiles; then w from
    // continuity (27) upward from the bed in the filled columns
    for (int j = 0; j < nx; ++j) {
      const bool filled = nb.src_box[static_cast<std::size_t>(j)] < 0;
      const bool next_filled = j + 1 < nx && nb.src_box[static_cast<std::size_t>(j + 1)] < 0;
      const bool adjacent_copy =
          j + 1 < nx && !filled && !next_filled &&
          nb.src_box[static_cast<std::size_t>(j)] == nb.src_box[static_cast<std::size_t>(j + 1)] &&
          nb.src_col[static_cast<std::size_t>(j + 1)] == nb.src_col[static_cast<std::size_t>(j)] + 1;
      if (!filled && !next_filled && (adjacent_copy || j + 1 == nx)) continue;  // copied face
      for (int k = 0; k < nz; ++k) {
        const double l = uc[static_cast<std::size_t>(j)][static_cast<std::size_t>(k)];
        const double r = j + 1 < nx ? uc[static_cast<std::size_t>(j + 1)][static_cast<std::size_t>(k)] : l;
        st.u[static_cast<std::size_t>(j * nz + k)] = 0.5 * (l + r);
      }
    }
    for (int j = 0; j < nx; ++j) {
      if (nb.src_box[static_cast<std::size_t>(j)] >= 0) continue;
      const double h = hcol[static_cast<std::size_t>(j)];
      double wb = 0.0;
      for (int k = 0; k < nz; ++k) {
        const auto q = static_cast<std::size_t>(j * nz + k);
        if (!(h > k * nb.dz)) {
          st.w[q] = 0.0;
          continue;
        }
        const double ur = st.u[q];
        const double ul = j > 0 ? st.u[q - static_cast<std::size_t>(nz)]
                                : uc[static_cast<std::size_t>(j)][static_cast<std::size_t>(k)];
        wb -= nb.dz * (ur - ul) / nb.dx;
        st.w[q] = k + 1 < nz ? wb : 0.0;
      }
    }
    std::sort(st.markers.begin(), st.markers.end(),
              [](const ndam::Marker& x, const ndam::Marker& y) { return x.id < y.id; });
    const double m_now = static_cast<double>(st.markers.size()) * area;
    st.mass0 = m_now - static_cast<double>(st.injected) * area + static_cast<double>(st.removed) * area;
    out.push_back(factory.ndam(pc.x0, pc.x1, st, stats, nbr));
  }
  // the field of the new parts, for the record
  const ChannelField after = channel_field(out, 0, out.size());
  const auto aft = after.integral(a, b);
  rec.mass_after = aft[0];
  rec.momentum_after = aft[1];
  return out;
}

}  // namespace granflow::coupling
