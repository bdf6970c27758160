// Free-surface marker particles of the N-DAM (see include/granflow/markers/markers.hpp and
// docs/numerics.md, "Free surface: markers").
#include "granflow/markers/markers.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>

namespace granflow::ndam {

namespace {
constexpr int G = Field::G;
constexpr int kLeft = 0, kRight = 1, kBottom = 2, kTop = 3;
// [rows] an opening h_in within this of a row boundary ends at that row: h_in / s_z is computed
// in floating point, and an opening of exactly R rows must not get an empty row R + 1.
constexpr double kRowRoundOff = 1e-9;
// [markers] a row's inflow accumulator within this of a whole marker counts it as entered. At an
// output time the steps sum to t exactly, so h_in u_in t / a is a whole number of markers
// whenever u_in t is a multiple of the row spacing (Setup II at 5 mm: t = 0.25 s, 74 rows of
// 1.25 mm), and the summation's last bits, which differ with the step sequence and the rank
// count, decided whether that row went in at the step or one step later: one marker row at
// the gate between np 1 and np 2 of the coupled Setup II (an independent tester, 2026-12-04).
constexpr double kMarkerRoundOff = 1e-9;

// Largest double below v (keeps a reflected or clamped coordinate strictly inside [0, L)).
double below(double v) { return std::nextafter(v, -1.0e300); }

// floor(v) as an int, for |v| < 2^31 (a position in cells): the truncation corrected below 0.
// The same value as static_cast<int>(std::floor(v)), without the library floor, which the
// x86-64 baseline (no SSE4.1 round instruction) emulates in about ten instructions; the
// markers call it for every marker in every step.
inline int floor_int(double v) {
  const int i = static_cast<int>(v);
  return v < static_cast<double>(i) ? i - 1 : i;
}

// A number in [0, 1) from the integer n: the splitmix64 finaliser (Steele, Lea & Flood 2014),
// whose output bits are equidistributed for consecutive n; deterministic, no generator state.
double unit_hash(long long n) {
  std::uint64_t z = static_cast<std::uint64_t>(n) + 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53;  // the top 53 bits
}
}  // namespace

MarkerSet::MarkerSet(MPI_Comm comm, const Grid& grid, const Slab& slab, const MarkerConfig& cfg)
    : comm_(comm), grid_(grid), slab_(slab), cfg_(cfg), dx_(grid.dx()), dz_(grid.dz()) {
  if (cfg_.per_cell_x < 1 || cfg_.per_cell_z < 1)
    throw std::invalid_argument("markers: markers per cell must be >= 1 in x and z");
  if (slab_.nx_local < G)
    throw std::invalid_argument("markers: each rank needs at least " + std::to_string(G) +
                                " columns (has " + std::to_string(slab_.nx_local) + ")");
  const bool pl = cfg_.sides[kLeft] == MarkerBoundary::Periodic;
  const bool pr = cfg_.sides[kRight] == MarkerBoundary::Periodic;
  if (pl != pr) throw std::invalid_argument("markers: periodic needs both left and right sides");
  if (cfg_.sides[kBottom] == MarkerBoundary::Periodic || cfg_.sides[kTop] == MarkerBoundary::Periodic)
    throw std::invalid_argument("markers: periodic is only supported in x");
  int rank = 0, ranks = 1;
  MPI_Comm_rank(comm_, &rank);
  MPI_Comm_size(comm_, &ranks);
  if (rank != slab_.rank || ranks != slab_.ranks)
    throw std::invalid_argument("markers: the slab does not match the communicator");
  if (rank > 0) left_ = rank - 1;
  else if (pl) left_ = ranks - 1;
  if (rank < ranks - 1) right_ = rank + 1;
  else if (pr) right_ = 0;
  obst_.assign(static_cast<std::size_t>((slab_.nx_local + 2 * G) * grid_.nz), 0);
}

// ---------------------------------------------------------------------------------------------
// seeding and removal

// Every lattice position (a, b) of every open cell (gi, k) of this rank that `keep` accepts
// (given its lattice column jx, row jz and centre x, z) becomes a marker; the id follows from
// the position, so that seeding does not depend on the ranks.
long long MarkerSet::seed_lattice(
    const std::function<bool(long long jx, long long jz, double x, double z)>& keep) {
  const int nmx = cfg_.per_cell_x, nmz = cfg_.per_cell_z, nz = grid_.nz;
  const double sx = spacing_x(), sz = spacing_z();
  long long added = 0;
  for (int i = 0; i < slab_.nx_local; ++i) {
    const int gi = slab_.i0 + i;
    for (int k = 0; k < nz; ++k) {
      if (obst_[static_cast<std::size_t>((i + G) * nz + k)]) continue;
      for (int a = 0; a < nmx; ++a)
        for (int b = 0; b < nmz; ++b) {
          const double x = gi * dx_ + (a + 0.5) * sx, z = k * dz_ + (b + 0.5) * sz;
          if (!keep(static_cast<long long>(gi) * nmx + a, static_cast<long long>(k) * nmz + b,
                    x, z))
            continue;
          const long long id =
              seed_base_ + ((static_cast<long long>(gi) * nz + k) * nmx + a) * nmz + b;
          m_.push_back(Marker{x, z, id});
          ++added;
        }
    }
  }
  seed_base_ += static_cast<long long>(grid_.nx) * nz * nmx * nmz;
  return added;
}

long long MarkerSet::seed(const std::function<bool(double, double)>& inside) {
  return seed_lattice([&](long long, long long, double x, double z) { return inside(x, z); });
}

long long MarkerSet::seed_rectangle(double xa, double xb, double h) {
  const double sx = spacing_x(), sz = spacing_z();
  // the covered fraction of [lo, hi) by [a, b), snapped to 0 and 1 within round-off so that a
  // rectangle on the marker lattice seeds exactly seed()'s markers
  auto cover = [](double lo, double hi, double a, double b) {
    const double c = (std::min(hi, b) - std::max(lo, a)) / (hi - lo);
    return c < 1e-9 ? 0.0 : c > 1.0 - 1e-9 ? 1.0 : c;
  };
  // of a row of such markers j = j0..j1 this keeps round((j1 + 1) c) - round(j0 c): n c to
  // within one marker, whatever the row's start
  auto pick = [](long long j, double c) {
    return std::floor(static_cast<double>(j + 1) * c + 0.5) >
           std::floor(static_cast<double>(j) * c + 0.5);
  };
  return seed_lattice([&](long long jx, long long jz, double, double) {
    const double cx = cover(jx * sx, (jx + 1) * sx, xa, xb);
    const double cz = cover(jz * sz, (jz + 1) * sz, 0.0, h);
    if (cx == 0.0 || cz == 0.0) return false;
    // a partly covered row is thinned along x, a partly covered column along z
    return cz < 1.0 ? pick(jx, cx * cz) : cx < 1.0 ? pick(jz, cx) : true;
  });
}

long long MarkerSet::seed_depth(const std::function<double(double)>& h) {
  return seed([&h](double x, double z) { return z < h(x); });
}

long long MarkerSet::remove_if(const std::function<bool(double, double)>& pred) {
  const auto end = std::remove_if(m_.begin(), m_.end(),
                                  [&pred](const Marker& m) { return pred(m.x, m.z); });
  const long long n = static_cast<long long>(m_.end() - end);
  m_.erase(end, m_.end());
  removed_ += n;
  return n;
}

long long MarkerSet::take_back(long long n) {
  if (n <= 0 || slab_.i0 != 0) return 0;
  std::vector<std::size_t> first;  // markers of the first column
  for (std::size_t j = 0; j < m_.size(); ++j)
    if (m_[j].x < dx_) first.push_back(j);
  const auto take = static_cast<std::size_t>(std::min<long long>(n, static_cast<long long>(first.size())));
  if (take == 0) return 0;
  // the `take` nearest to the face (ties by id, so that every run takes the same ones)
  auto nearer = [&](std::size_t a, std::size_t b) {
    return m_[a].x < m_[b].x || (m_[a].x == m_[b].x && m_[a].id < m_[b].id);
  };
  std::nth_element(first.begin(), first.begin() + static_cast<std::ptrdiff_t>(take - 1), first.end(),
                   nearer);
  std::vector<char> drop(m_.size(), 0);
  for (std::size_t j = 0; j < take; ++j) drop[first[j]] = 1;
  std::size_t w = 0;
  for (std::size_t j = 0; j < m_.size(); ++j)
    if (!drop[j]) m_[w++] = m_[j];
  m_.resize(w);
  injected_ -= static_cast<long long>(take);
  return static_cast<long long>(take);
}

void MarkerSet::clear() {
  m_.clear();
  acc_.clear();
  injected_ = removed_ = 0;
}

// ---------------------------------------------------------------------------------------------
// inflow

void MarkerSet::inject(double dt, double h_in, const std::vector<double>& u_face, double volume) {
  inject_rows(dt, h_in, [&](double zb, double zt) {
    const int k = std::min(static_cast<int>(0.5 * (zb + zt) / dz_), grid_.nz - 1);
    if (k >= static_cast<int>(u_face.size()))
      throw std::invalid_argument("markers: inject() needs u_face for every row of the opening");
    return u_face[static_cast<std::size_t>(k)] * (zt - zb);
  }, volume);
}

void MarkerSet::inject(double dt, double h_in, const std::function<double(double)>& u_in,
                       double volume) {
  // 3-point Gauss-Legendre per strip: exact for profiles up to degree 5 in z.
  static const double xg[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)};
  static const double wg[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  inject_rows(dt, h_in, [&](double zb, double zt) {
    const double c = 0.5 * (zb + zt), r = 0.5 * (zt - zb);
    double q = 0.0;
    for (int j = 0; j < 3; ++j) q += wg[j] * u_in(c + r * xg[j]);
    return q * r;
  }, volume);
}

// A prescribed step volume (an inflow series: the exact integral of h u over the step) scales
// the strips' fluxes of the opening at the step's start, so that the step admits that volume
// and not the left-point rule's h(t) u(t) dt (a gate closing inside a step admitted a whole
// step's flux more or less: +0.2 % of a hydrograph's volume at 5 mm, docs/validation.md).
// Rows whose strip closes (the opening fell below them) hand their accumulator to the highest
// row still open, and when the whole opening closes the remainders of all rows become markers
// at once (their sum rounded; the rest, below half a marker, stays in row 0, owed or pending):
// a row's remainder, up to one marker, was lost at every closing before (-0.9 to -1.3 % of a
// hydrograph at 10 mm). A steady opening keeps its rows and injects as before.
void MarkerSet::inject_rows(double dt, double h_in,
                            const std::function<double(double, double)>& strip_flux,
                            double volume) {
  if (cfg_.sides[kLeft] != MarkerBoundary::Inflow)
    throw std::logic_error("markers: inject() needs an Inflow left side");
  if (slab_.i0 != 0 || dt <= 0.0) return;
  // Without a prescribed volume (a constant gate, a 1D-to-2D interface, whose ledger books the
  // rows' remainders as pending) the rows are handled as they always were.
  const bool series = volume >= 0.0;
  if (!series && h_in <= 0.0) return;
  const double sz = spacing_z(), a = marker_area();
  const double top = std::min(std::max(h_in, 0.0), grid_.lz);
  const int rows = std::max(0, static_cast<int>(std::ceil(top / sz - kRowRoundOff)));
  const double xmax = below(std::min(dx_, grid_.lx));
  auto emit = [&](int r, double x) {
    const long long id = kInjectedIdBase + inject_next_++;
    const double zb = r * sz, s = std::min((r + 1) * sz, grid_.lz) - zb;
    m_.push_back(Marker{std::clamp(x, 0.0, xmax), zb + unit_hash(id) * s, id});
    ++injected_;
  };
  if (rows == 0) {
    // a gate that opens inside the step: its volume enters at once (with the rows' remainders)
    if (volume > 0.0) {
      if (acc_.empty()) acc_.assign(1, 0.0);
      acc_[0] += volume / a;
    }
    if (acc_.empty()) return;
    // The opening is closed: what the rows still hold entered before (their sum, rounded).
    double total = 0.0;
    for (double v : acc_) total += v;
    const long long n = total > 0.0 ? std::llround(total) : 0;
    if (n == 0) return;
    long long left = n;
    for (std::size_t r = 0; r < acc_.size() && left > 0; ++r) {
      const long long take = std::min<long long>(
          left, std::max<long long>(0, std::llround(acc_[r])));
      for (long long j = 0; j < take; ++j) emit(static_cast<int>(r), 0.0);
      left -= take;
    }
    for (long long j = 0; j < left; ++j) emit(0, 0.0);
    std::fill(acc_.begin(), acc_.end(), 0.0);
    acc_[0] = total - static_cast<double>(n);
    return;
  }
  if (static_cast<int>(acc_.size()) < rows) acc_.resize(static_cast<std::size_t>(rows), 0.0);
  if (series)
    for (std::size_t r = static_cast<std::size_t>(rows); r < acc_.size(); ++r) {
      acc_[static_cast<std::size_t>(rows - 1)] += acc_[r];  // closed strips: to the top row
      acc_[r] = 0.0;
    }
  std::vector<double> q(static_cast<std::size_t>(rows), 0.0);
  double qsum = 0.0;
  for (int r = 0; r < rows; ++r) {
    const double zb = r * sz, zt = std::min((r + 1) * sz, top);
    if (zt - zb <= 0.0) continue;
    q[static_cast<std::size_t>(r)] = strip_flux(zb, zt);  // m^2/s through the strip
    if (q[static_cast<std::size_t>(r)] > 0.0) qsum += q[static_cast<std::size_t>(r)];
  }
  const double scale = volume >= 0.0 && qsum > 0.0 ? volume / (qsum * dt) : 1.0;
  for (int r = 0; r < rows; ++r) {
    const double zb = r * sz, zt = std::min((r + 1) * sz, top), s = zt - zb;
    if (s <= 0.0) continue;
    const double qr = q[static_cast<std::size_t>(r)] * scale;
    if (!(qr > 0.0)) continue;
    const double dn = qr * dt / a;  // markers entering this row during dt
    const double uf = qr / s;       // the strip's mean inflow velocity
    const double A = acc_[static_cast<std::size_t>(r)] + dn;
    const long long n = std::max<long long>(0, static_cast<long long>(std::floor(A + kMarkerRoundOff)));
    for (long long j = 1; j <= n; ++j) {
      // The j-th unit crossed x = 0 when the accumulator passed j, a fraction (A - j) / dn of
      // the step ago: it has travelled that fraction of uf dt since. Along z it sits at a
      // uniformly distributed height of its strip, not at the strip centre: markers at the
      // centres of every strip are material lines along the flow, one per strip, which a flow
      // that slows down by a factor F later spreads F times apart normal to it (the deposit in
      // front of a wall, a shock). Once F s_z > dz the cells between two lines hold no marker
      // and are Empty inside the material: a hole with p = 0 (issue 11: material injected at
      // 2.6 m/s by a 1D-to-2D interface comes to rest at the wall, F = 10 to 100). Heights
      // spread over the strip keep every part of the deformed strip sampled. The fraction comes
      // from a hash of the marker's id: the same on any number of ranks (only column 0 injects)
      // and across a restart (the id counter is in the checkpoint). x, the per-column counts
      // and the injected area are those of the strip-centre markers.
      const long long id = kInjectedIdBase + inject_next_++;
      const double x = std::clamp((A - static_cast<double>(j)) / dn * uf * dt, 0.0, xmax);
      m_.push_back(Marker{x, zb + unit_hash(id) * s, id});
    }
    acc_[static_cast<std::size_t>(r)] = A - static_cast<double>(n);
    injected_ += n;
  }
}

// ---------------------------------------------------------------------------------------------
// advection

std::array<double, 2> MarkerSet::velocity(const Field& u, const Field& w, double x,
                                          double z) const {
  const int nxl = slab_.nx_local, nz = grid_.nz;
  // x / dx and z / dz once for both grids (the arithmetic of each grid's offset is unchanged:
  // (x / dx) - 1/2 is what the w grid computed before). The markers' velocity was 7 % of a
  // 2.6 mm Setup II run, its four divisions on the critical path of each interpolation.
  const double gxc = x / dx_, gzc = z / dz_;
  // (a non-finite or far-away position, e.g. from a diverged velocity: refused before the cell
  // index is formed, which would overflow an int)
  if (!(std::abs(gxc) < 1e9 && std::abs(gzc) < 1e9))
    throw std::runtime_error("markers: position (" + std::to_string(x) + ", " + std::to_string(z) +
                             ") is not finite or far outside the box");
  // The bilinear sample of field f at the face (li, k) and its neighbours (li + 1, k + 1): the
  // column li + 1 lies a stride on in f's storage.
  const std::size_t stride = static_cast<std::size_t>(nz + 2);  // Field's column length
  auto bilinear = [&](const Field& f, int li, int k, double fx, double fz) {
    if (li < -G || li + 1 >= nxl + G || k < -1 || k + 1 > nz)
      throw std::runtime_error("markers: position (" + std::to_string(x) + ", " +
                               std::to_string(z) + ") outside the ghost layers of rank " +
                               std::to_string(slab_.rank) + " (CFL > 1?)");
    const double* c0 = f.data().data() + f.index(li, k);
    return (1 - fx) * (1 - fz) * c0[0] + fx * (1 - fz) * c0[stride] + (1 - fx) * fz * c0[1] +
           fx * fz * c0[stride + 1];
  };
  // u on the grid x = (gi) dx (faces), z = (k + 1/2) dz: NaSt2D's u-grid shifted by dz/2;
  // (fi, k) is the face at x = fi dx, z = (k + 1/2) dz.
  const int fi = floor_int(gxc), k = floor_int(gzc - 0.5);
  const double uu = bilinear(u, fi - 1 - slab_.i0, k, gxc - fi, (gzc - 0.5) - k);
  // w on the grid x = (gi + 1/2) dx, z = k dz (faces): shifted by dx/2; w(i, k) is the top face
  // of cell k, at z = (k + 1) dz.
  const int wi = floor_int(gxc - 0.5), wk = floor_int(gzc);
  const double ww = bilinear(w, wi - slab_.i0, wk - 1, (gxc - 0.5) - wi, gzc - wk);
  return {uu, ww};
}

void MarkerSet::wall(double& x, double& z) const {
  const auto rigid = [](MarkerBoundary b) {
    return b == MarkerBoundary::Wall || b == MarkerBoundary::Inflow;
  };
  if (x < 0.0 && rigid(cfg_.sides[kLeft])) x = std::min(-x, below(grid_.lx));
  if (x >= grid_.lx && rigid(cfg_.sides[kRight])) x = std::max(below(2.0 * grid_.lx - x), 0.0);
  if (z < 0.0 && rigid(cfg_.sides[kBottom])) z = std::min(-z, below(grid_.lz));
  if (z >= grid_.lz && rigid(cfg_.sides[kTop])) z = std::max(below(2.0 * grid_.lz - z), 0.0);
}

bool MarkerSet::obstacle_at(double x, double z) const {
  const int li = floor_int(x / dx_) - slab_.i0;
  const int k = floor_int(z / dz_);
  if (li < -G || li >= slab_.nx_local + G || k < 0 || k >= grid_.nz) return false;
  return obst_[static_cast<std::size_t>((li + G) * grid_.nz + k)] != 0;
}

void MarkerSet::advect(double dt, const Field& u0, const Field& w0, const Field& u1,
                       const Field& w1) {
  const double lx = grid_.lx, lz = grid_.lz;
  const bool periodic = cfg_.sides[kLeft] == MarkerBoundary::Periodic;
  const auto out = [this](int side) { return cfg_.sides[side] == MarkerBoundary::Outflow; };
  // wall() changes only positions outside [0, lx) x [0, lz): most markers skip the call; the
  // obstacle test only where the box has obstacles (the markers were 15 % of a 2.6 mm run)
  const auto inside = [lx, lz](double x, double z) {
    return x >= 0.0 && x < lx && z >= 0.0 && z < lz;
  };
  std::size_t keep = 0;
  for (std::size_t n = 0; n < m_.size(); ++n) {
    Marker m = m_[n];
    const auto v0 = velocity(u0, w0, m.x, m.z);
    double xs = m.x + dt * v0[0], zs = m.z + dt * v0[1];
    if (!inside(xs, zs)) wall(xs, zs);
    // A stage beyond an outflow side is evaluated on that side (the ghost layer is one cell).
    if (!periodic) xs = std::clamp(xs, 0.0, lx);
    zs = std::clamp(zs, 0.0, lz);
    const auto v1 = velocity(u1, w1, xs, zs);
    double xn = m.x + 0.5 * dt * (v0[0] + v1[0]);
    double zn = m.z + 0.5 * dt * (v0[1] + v1[1]);
    if (!inside(xn, zn)) wall(xn, zn);
    if (has_obstacles_ && obstacle_at(xn, zn)) {
      if (!obstacle_at(xn, m.z)) zn = m.z;
      else if (!obstacle_at(m.x, zn)) xn = m.x;
      else { xn = m.x; zn = m.z; }
    }
    if ((xn < 0.0 && out(kLeft)) || (xn >= lx && out(kRight)) || (zn < 0.0 && out(kBottom)) ||
        (zn >= lz && out(kTop))) {
      ++removed_;
      continue;
    }
    if (periodic) {
      if (xn >= lx) xn -= lx;
      else if (xn < 0.0) xn += lx;
      if (xn >= lx || xn < 0.0) xn = 0.0;  // -tiny + lx rounds to lx
    }
    m.x = xn;
    m.z = zn;
    m_[keep++] = m;
  }
  m_.resize(keep);
  migrate();
}

int MarkerSet::global_column(double x) const {
  const int gi = floor_int(x / dx_);
  return std::clamp(gi, 0, grid_.nx - 1);
}

int MarkerSet::cell_row(double z) const { return std::clamp(floor_int(z / dz_), 0, grid_.nz - 1); }

void MarkerSet::migrate() {
  if (slab_.ranks == 1) return;
  const int lo = slab_.i0, hi = slab_.i0 + slab_.nx_local;
  const MPI_Datatype bytes = MPI_BYTE;
  const int msz = static_cast<int>(sizeof(Marker));
  for (int round = 0;; ++round) {
    std::vector<Marker> keep, to_left, to_right;
    keep.reserve(m_.size());
    for (const Marker& m : m_) {
      const int gi = global_column(m.x);
      if (gi < lo) to_left.push_back(m);
      else if (gi >= hi) to_right.push_back(m);
      else keep.push_back(m);
    }
    long long moving = static_cast<long long>(to_left.size() + to_right.size()), any = 0;
    MPI_Allreduce(&moving, &any, 1, MPI_LONG_LONG, MPI_SUM, comm_);
    if (any == 0) return;
    if (round > slab_.ranks)
      throw std::runtime_error("markers: migration does not settle");
    m_.swap(keep);
    migrated_ += moving;
    // Non-periodic: a marker left of rank 0 or right of the last rank cannot exist (columns are
    // clamped), so MPI_PROC_NULL never receives anything that matters.
    const auto shift = [&](const std::vector<Marker>& out, int dest, int src, int tag) {
      int ns = static_cast<int>(out.size()), nr = 0;
      MPI_Sendrecv(&ns, 1, MPI_INT, dest, tag, &nr, 1, MPI_INT, src, tag, comm_, MPI_STATUS_IGNORE);
      std::vector<Marker> in(static_cast<std::size_t>(nr));
      MPI_Sendrecv(out.data(), ns * msz, bytes, dest, tag + 1, in.data(), nr * msz, bytes, src,
                   tag + 1, comm_, MPI_STATUS_IGNORE);
      m_.insert(m_.end(), in.begin(), in.end());
    };
    shift(to_left, left_, right_, 100);
    shift(to_right, right_, left_, 200);
  }
}

void MarkerSet::relocate(const std::vector<std::array<int, 4>>& moves) {
  if (moves.empty()) return;
  for (const auto& [di, dk, ti, tk] : moves) {
    if (di < slab_.i0 || di >= slab_.i0 + slab_.nx_local) continue;
    const double xc = (ti + 0.5) * dx_, zc = (tk + 0.5) * dz_;
    Marker* best = nullptr;
    double best_d = 0.0;
    for (Marker& m : m_) {
      if (global_column(m.x) != di ||
          cell_row(m.z) != dk)
        continue;
      const double d = (m.x - xc) * (m.x - xc) + (m.z - zc) * (m.z - zc);
      if (!best || d < best_d || (d == best_d && m.id < best->id)) best = &m, best_d = d;
    }
    if (!best) throw std::logic_error("markers: a void filled from a cell without markers");
    const double ex = 0.25 * spacing_x(), ez = 0.25 * spacing_z();
    best->x = std::clamp(best->x, ti * dx_ + ex, (ti + 1) * dx_ - ex);
    best->z = std::clamp(best->z, tk * dz_ + ez, (tk + 1) * dz_ - ez);
  }
  migrate();
}

// ---------------------------------------------------------------------------------------------
// obstacles and flags

void MarkerSet::halo(const std::vector<int>& first, const std::vector<int>& last,
                     std::vector<int>& ghost_left, std::vector<int>& ghost_right, int fill) const {
  const int n = static_cast<int>(first.size());
  ghost_left.assign(first.size(), fill);
  ghost_right.assign(first.size(), fill);
  if (left_ == MPI_PROC_NULL && right_ == MPI_PROC_NULL) return;
  MPI_Sendrecv(first.data(), n, MPI_INT, left_, 300, ghost_right.data(), n, MPI_INT, right_, 300,
               comm_, MPI_STATUS_IGNORE);
  MPI_Sendrecv(last.data(), n, MPI_INT, right_, 301, ghost_left.data(), n, MPI_INT, left_, 301,
               comm_, MPI_STATUS_IGNORE);
  if (left_ == MPI_PROC_NULL) ghost_left.assign(first.size(), fill);
  if (right_ == MPI_PROC_NULL) ghost_right.assign(first.size(), fill);
}

void MarkerSet::set_obstacles(const std::vector<CellFlag>& flags) {
  const int nxl = slab_.nx_local, nz = grid_.nz;
  if (static_cast<int>(flags.size()) != nxl * nz)
    throw std::invalid_argument("markers: flags must hold nx_local * nz cells");
  std::fill(obst_.begin(), obst_.end(), 0);
  std::vector<int> first(static_cast<std::size_t>(G * nz)), last(first.size()), gl, gr;
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) {
      const int o = flags[static_cast<std::size_t>(i * nz + k)] == CellFlag::Obstacle ? 1 : 0;
      obst_[static_cast<std::size_t>((i + G) * nz + k)] = static_cast<char>(o);
      if (i < G) first[static_cast<std::size_t>(i * nz + k)] = o;
      if (i >= nxl - G) last[static_cast<std::size_t>((i - (nxl - G)) * nz + k)] = o;
    }
  halo(first, last, gl, gr, 0);
  for (int j = 0; j < G * nz; ++j) {
    obst_[static_cast<std::size_t>(j)] = static_cast<char>(gl[static_cast<std::size_t>(j)]);
    obst_[static_cast<std::size_t>((nxl + G) * nz + j)] =
        static_cast<char>(gr[static_cast<std::size_t>(j)]);
  }
  // (once here, not per advection: most boxes have none, and advect() then skips the lookups)
  has_obstacles_ = std::find(obst_.begin(), obst_.end(), 1) != obst_.end();
}

std::vector<int> MarkerSet::cell_counts() const {
  const int nz = grid_.nz;
  std::vector<int> c(static_cast<std::size_t>(slab_.nx_local * nz), 0);
  for (const Marker& m : m_) {
    const int i = global_column(m.x) - slab_.i0;
    const int k = cell_row(m.z);
    if (i >= 0 && i < slab_.nx_local) ++c[static_cast<std::size_t>(i * nz + k)];
  }
  return c;
}

void MarkerSet::update_flags(std::vector<CellFlag>& flags, std::vector<std::uint8_t>* empty_sides) const {
  const int nxl = slab_.nx_local, nz = grid_.nz;
  const std::size_t ncell = static_cast<std::size_t>(nxl * nz);
  if (flags.empty()) flags.assign(ncell, CellFlag::Fluid);
  if (flags.size() != ncell)
    throw std::invalid_argument("markers: flags must hold nx_local * nz cells");
  const std::vector<int> count = cell_counts();
  std::vector<char> obstacle(ncell);
  std::vector<int> full(ncell);  // 1: not empty (markers or obstacle)
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) {
      const std::size_t c = static_cast<std::size_t>(i * nz + k);
      obstacle[c] = flags[c] == CellFlag::Obstacle || obst_[static_cast<std::size_t>((i + G) * nz + k)];
      full[c] = (obstacle[c] || count[c] > 0) ? 1 : 0;
    }
  std::vector<int> first(full.begin(), full.begin() + nz), last(full.end() - nz, full.end()), gl, gr;
  halo(first, last, gl, gr, 1);  // outside the box (no neighbour rank) counts as not empty
  if (empty_sides) empty_sides->assign(ncell, 0);
  for (int i = 0; i < nxl; ++i)
    for (int k = 0; k < nz; ++k) {
      const std::size_t c = static_cast<std::size_t>(i * nz + k);
      if (obstacle[c]) { flags[c] = CellFlag::Obstacle; continue; }
      const int l = i > 0 ? full[c - static_cast<std::size_t>(nz)] : gl[static_cast<std::size_t>(k)];
      const int r = i < nxl - 1 ? full[c + static_cast<std::size_t>(nz)] : gr[static_cast<std::size_t>(k)];
      const int b = k > 0 ? full[c - 1] : 1;
      const int t = k < nz - 1 ? full[c + 1] : 1;
      std::uint8_t mask = 0;
      flags[c] = classify_cell(count[c] > 0, !l, !r, !b, !t, mask);
      if (empty_sides) (*empty_sides)[c] = mask;
    }
}

// ---------------------------------------------------------------------------------------------
// depth, profiles, mass

std::vector<double> MarkerSet::depth() const {
  const int nxl = slab_.nx_local;
  const double a = marker_area();
  std::vector<double> h(static_cast<std::size_t>(nxl), 0.0);
  if (cfg_.depth == DepthMethod::Count) {
    for (const Marker& m : m_) {
      const int i = global_column(m.x) - slab_.i0;
      if (i >= 0 && i < nxl) h[static_cast<std::size_t>(i)] += 1.0;
    }
    for (double& v : h) v *= a / dx_;
    return h;
  }
  std::vector<std::vector<double>> zs(static_cast<std::size_t>(nxl));
  for (const Marker& m : m_) {
    const int i = global_column(m.x) - slab_.i0;
    if (i >= 0 && i < nxl) zs[static_cast<std::size_t>(i)].push_back(m.z);
  }
  const std::size_t nrow = static_cast<std::size_t>(cfg_.per_cell_x);
  for (std::size_t i = 0; i < h.size(); ++i) {
    auto& z = zs[i];
    if (z.size() >= nrow) {
      std::nth_element(z.begin(), z.begin() + static_cast<std::ptrdiff_t>(nrow - 1), z.end(),
                       std::greater<double>());
      h[i] = z[nrow - 1] + 0.5 * spacing_z();
    } else {
      h[i] = a * static_cast<double>(z.size()) / dx_;
    }
  }
  return h;
}

ColumnProfile MarkerSet::profile(const Field& u, const Field& w,
                                 const std::vector<double>* h) const {
  ColumnProfile p;
  p.h = h ? *h : depth();
  const int nxl = slab_.nx_local, nz = grid_.nz;
  p.x.resize(p.h.size());
  p.u_mean.assign(p.h.size(), 0.0);
  p.w_mean.assign(p.h.size(), 0.0);
  for (int i = 0; i < nxl; ++i) {
    const std::size_t c = static_cast<std::size_t>(i);
    p.x[c] = (slab_.i0 + i + 0.5) * dx_;
    const double h = p.h[c];
    if (!(h > 0.0)) continue;
    double su = 0.0, sw = 0.0;
    for (int k = 0; k < nz; ++k) {
      const double len = std::clamp(h - k * dz_, 0.0, dz_);
      if (len <= 0.0) break;
      su += len * 0.5 * (u(i - 1, k) + u(i, k));
      sw += len * 0.5 * (w(i, k - 1) + w(i, k));
    }
    p.u_mean[c] = su / h;
    p.w_mean[c] = sw / h;
  }
  return p;
}

MarkerMass MarkerSet::mass() const {
  long long loc[3] = {static_cast<long long>(m_.size()), injected_, removed_}, glob[3] = {0, 0, 0};
  MPI_Allreduce(loc, glob, 3, MPI_LONG_LONG, MPI_SUM, comm_);
  MarkerMass r;
  const double a = marker_area();
  r.count = glob[0];
  r.injected = glob[1];
  r.removed = glob[2];
  r.area = a * static_cast<double>(r.count);
  r.injected_area = a * static_cast<double>(r.injected);
  r.removed_area = a * static_cast<double>(r.removed);
  const double acc = inflow_pending_markers();
  MPI_Allreduce(&acc, &r.pending_area, 1, MPI_DOUBLE, MPI_SUM, comm_);
  r.pending_area *= a;
  return r;
}

double MarkerSet::inflow_pending_markers() const {
  // Only the rank of column 0 injects (inject_rows); an imported state gives every rank a
  // copy of the accumulators, which on the others never changes. Summed over all ranks, the
  // two-rank runs reported the pending part twice (a review).
  double acc = 0.0;
  if (slab_.i0 == 0)
    for (double v : acc_) acc += v;
  return acc;
}

long long MarkerSet::global_count() const { return mass().count; }

std::vector<Marker> MarkerSet::gather() const {
  const int msz = static_cast<int>(sizeof(Marker));
  int nloc = static_cast<int>(m_.size()) * msz;
  std::vector<int> counts(static_cast<std::size_t>(slab_.ranks)), displs(counts.size(), 0);
  MPI_Allgather(&nloc, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_);
  int total = 0;
  for (std::size_t r = 0; r < counts.size(); ++r) {
    displs[r] = total;
    total += counts[r];
  }
  std::vector<Marker> all(static_cast<std::size_t>(total / msz));
  MPI_Allgatherv(m_.data(), nloc, MPI_BYTE, all.data(), counts.data(), displs.data(), MPI_BYTE,
                 comm_);
  std::sort(all.begin(), all.end(), [](const Marker& a, const Marker& b) { return a.id < b.id; });
  return all;
}

// ---------------------------------------------------------------------------------------------
// holes

std::vector<std::array<int, 2>> enclosed_voids(const std::vector<CellFlag>& flags, int nx, int nz,
                                               VoidSides sides) {
  if (static_cast<int>(flags.size()) != nx * nz)
    throw std::invalid_argument("enclosed_voids: flags must hold nx * nz cells");
  const auto at = [nz](int gi, int k) { return static_cast<std::size_t>(gi * nz + k); };
  // Flood fill of the Empty cells connected to the atmosphere (top row) or an open side.
  std::vector<char> open(flags.size(), 0);
  std::vector<std::array<int, 2>> stack;
  const auto seed = [&](int gi, int k) {
    if (flags[at(gi, k)] == CellFlag::Empty && !open[at(gi, k)]) {
      open[at(gi, k)] = 1;
      stack.push_back({gi, k});
    }
  };
  // Above its highest cell that is not Empty, a column is Empty up to the top row: open. That
  // part (most of the box) is marked in one pass per column, and the fill starts from the
  // Empty cells beside it, below the neighbour column's top; the open set is the one a fill
  // from the top row finds (a connected component does not depend on where the fill starts).
  std::vector<int> top(static_cast<std::size_t>(nx));
  for (int gi = 0; gi < nx; ++gi) {
    const int k = column_top(&flags[at(gi, 0)], nz);
    top[static_cast<std::size_t>(gi)] = k;
    std::fill(open.begin() + static_cast<std::ptrdiff_t>(at(gi, k)),
              open.begin() + static_cast<std::ptrdiff_t>(at(gi, nz - 1)) + 1, 1);
  }
  for (int gi = 0; gi < nx; ++gi)
    for (int k = top[static_cast<std::size_t>(gi)]; k < nz; ++k) {
      if (gi > 0 && k < top[static_cast<std::size_t>(gi) - 1]) seed(gi - 1, k);
      if (gi + 1 < nx && k < top[static_cast<std::size_t>(gi) + 1]) seed(gi + 1, k);
    }
  for (int gi = 0; gi < nx; ++gi) seed(gi, nz - 1);
  for (int k = 0; k < nz; ++k) {
    if (k >= sides.left_from) seed(0, k);
    if (k >= sides.right_from) seed(nx - 1, k);
  }
  while (!stack.empty()) {
    const auto [gi, k] = stack.back();
    stack.pop_back();
    if (gi > 0) seed(gi - 1, k);
    if (gi + 1 < nx) seed(gi + 1, k);
    if (k > 0) seed(gi, k - 1);
    if (k + 1 < nz) seed(gi, k + 1);
  }
  std::vector<std::array<int, 2>> holes;
  for (int gi = 0; gi < nx; ++gi)
    for (int k = 0; k < top[static_cast<std::size_t>(gi)]; ++k)
      if (flags[at(gi, k)] == CellFlag::Empty && !open[at(gi, k)]) holes.push_back({gi, k});
  return holes;
}

int first_row_above(double depth, double dz, int nz) {
  const double rows = std::ceil(std::max(0.0, depth) / dz - 1e-9);
  return static_cast<int>(std::min<double>(rows, nz));
}

std::vector<std::array<int, 4>> void_fill_moves(std::vector<double> counts,
                                                const std::vector<CellFlag>& flags, int nx,
                                                int nz, VoidSides sides) {
  if (static_cast<int>(counts.size()) != nx * nz)
    throw std::invalid_argument("void_fill_moves: counts must hold nx * nz cells");
  const auto voids = enclosed_voids(flags, nx, nz, sides);
  const auto at = [nz](int gi, int k) { return static_cast<std::size_t>(gi * nz + k); };
  const auto inside = [nx, nz](int gi, int k) { return gi >= 0 && gi < nx && k >= 0 && k < nz; };
  // the second ring is reached through a cell of the ring around the void that held markers
  // before this step's moves (not an obstacle, not a void cell): a void ringed by single
  // markers takes from beyond them; a larger void fills from its rim, one layer per step
  const std::vector<double> held = counts;  // the ring as it was before this step's moves
  const auto through = [&](int gi, int k) {
    return inside(gi, k) && flags[at(gi, k)] != CellFlag::Obstacle && held[at(gi, k)] >= 1.0;
  };
  std::vector<std::array<int, 4>> moves;
  for (const auto& [gi, k] : voids) {
    int di = -1, dk = -1;
    double most = 1.0;  // a donor keeps a marker
    const auto consider = [&](int ni, int nk) {
      if (!inside(ni, nk) || !(counts[at(ni, nk)] > most)) return;
      most = counts[at(ni, nk)];
      di = ni;
      dk = nk;
    };
    for (const auto& [ni, nk] : {std::pair{gi, k - 1}, std::pair{gi - 1, k},
                                 std::pair{gi + 1, k}, std::pair{gi, k + 1}})
      consider(ni, nk);
    if (di < 0) {  // the second ring, the fullest cell; on ties the diagonals (the nearer)
      for (const auto& [oi, ok] : {std::pair{-1, -1}, std::pair{1, -1}, std::pair{-1, 1},
                                   std::pair{1, 1}})
        if (through(gi + oi, k) || through(gi, k + ok)) consider(gi + oi, k + ok);
      for (const auto& [oi, ok] : {std::pair{0, -2}, std::pair{-2, 0}, std::pair{2, 0},
                                   std::pair{0, 2}})
        if (through(gi + oi / 2, k + ok / 2)) consider(gi + oi, k + ok);
    }
    if (di < 0) continue;
    counts[at(di, dk)] -= 1.0;
    counts[at(gi, k)] += 1.0;
    moves.push_back({di, dk, gi, k});
  }
  return moves;
}

MarkerState MarkerSet::save() const {
  return MarkerState{m_, acc_, seed_base_, inject_next_, injected_, removed_, migrated_};
}

void MarkerSet::load(const MarkerState& s) {
  m_ = s.markers;
  acc_ = s.inflow_accumulators;
  seed_base_ = s.seed_base;
  inject_next_ = s.inject_next;
  injected_ = s.injected;
  removed_ = s.removed;
  migrated_ = s.migrated;
}

}  // namespace granflow::ndam
