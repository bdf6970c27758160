#include "granflow/analysis/budget.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace granflow::analysis {

namespace {
bool material(double flag) { return flag == 1.0 || flag == 2.0; }  // Fluid or Surface

double sgn(double v) { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); }

// d/dx of a column quantity: centred, one-sided at the ends.
std::vector<double> ddx(const std::vector<double>& f, double dx) {
  const std::size_t n = f.size();
  std::vector<double> d(n, 0.0);
  if (n < 2) return d;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t l = i == 0 ? 0 : i - 1, r = i + 1 == n ? i : i + 1;
    d[i] = (f[r] - f[l]) / (static_cast<double>(r - l) * dx);
  }
  return d;
}
}  // namespace

ColumnIntegrals column_integrals(const Snapshot2D& s, const BudgetPhysics& ph) {
  const int nx = s.nx, nz = s.nz;
  if (static_cast<int>(s.h.size()) != nx || s.u.size() != static_cast<std::size_t>(nx * nz) ||
      s.p.size() != s.u.size() || s.nu.size() != s.u.size() || s.flag.size() != s.u.size())
    throw std::invalid_argument("budget: snapshot fields do not match its grid");
  auto at = [&](const std::vector<double>& f, int i, int k) {
    return f[static_cast<std::size_t>(k * nx + i)];
  };
  // u_x at a cell centre from the cell-centred u: centred between material neighbours,
  // one-sided next to an empty one (the free surface, the front), 0 in a lone cell.
  auto ux = [&](int i, int k) {
    const bool l = i > 0 && material(at(s.flag, i - 1, k));
    const bool r = i + 1 < nx && material(at(s.flag, i + 1, k));
    if (l && r) return (at(s.u, i + 1, k) - at(s.u, i - 1, k)) / (2.0 * s.dx);
    if (r) return (at(s.u, i + 1, k) - at(s.u, i, k)) / s.dx;
    if (l) return (at(s.u, i, k) - at(s.u, i - 1, k)) / s.dx;
    return 0.0;
  };
  const double g_cos = ph.g * std::cos(ph.zeta);
  ColumnIntegrals c;
  for (auto* v : {&c.h, &c.Q, &c.M, &c.P, &c.T, &c.p_b, &c.tau_applied, &c.tau_bound})
    v->assign(static_cast<std::size_t>(nx), 0.0);
  for (int i = 0; i < nx; ++i) {
    const auto q = static_cast<std::size_t>(i);
    double h = s.h[q];
    if (ph.cell_weights) {
      h = 0.0;
      for (int k = 0; k < nz; ++k)
        if (material(at(s.flag, i, k))) h += s.dz;
    }
    c.h[q] = h;
    if (!(h > 0.0)) continue;
    for (int k = 0; k < nz; ++k) {
      // the profile's weights, or the material cells whole
      const double len = ph.cell_weights ? (material(at(s.flag, i, k)) ? s.dz : 0.0)
                                         : std::clamp(h - k * s.dz, 0.0, s.dz);
      if (!ph.cell_weights && len <= 0.0) break;
      const double u = at(s.u, i, k);
      c.Q[q] += len * u;
      c.M[q] += len * u * u;
      c.P[q] += len * at(s.p, i, k);
      c.T[q] += len * 2.0 * at(s.nu, i, k) * ux(i, k);
    }
    if (!material(at(s.flag, i, 0))) continue;
    // The bed: p taken to z = 0 hydrostatically (as the Coulomb law of boundaries.cpp), the
    // compressive normal stress N = p_b + 2 nu u_x (13), the friction factor (12), and the
    // Robin ghost's clamp at no-slip (the stress never exceeds 2 nu u_b / dz).
    const double pb = at(s.p, i, 0) + 0.5 * s.dz * g_cos, nub = at(s.nu, i, 0);
    const double ub = at(s.u, i, 0);
    c.p_b[q] = pb;
    if (ph.bed == "Coulomb") {
      const double N = std::max(0.0, pb + 2.0 * nub * ux(i, 0));
      const double cf = ph.tan_delta * (1.0 - std::exp(-ph.m_c * std::abs(ub)));
      c.tau_applied[q] = sgn(ub) * std::min(cf * N, 2.0 * nub * std::abs(ub) / s.dz);
      c.tau_bound[q] = sgn(ub) * ph.tan_delta * std::max(0.0, pb);
    } else if (ph.bed == "No-slip") {
      c.tau_applied[q] = c.tau_bound[q] = 2.0 * nub * ub / s.dz;
    }  // Free-slip: no stress
  }
  return c;
}

ColumnBudget momentum_budget(const std::vector<ColumnIntegrals>& cols,
                             const std::vector<double>& times, double x0, double dx,
                             const BudgetPhysics& ph) {
  const std::size_t ns = cols.size();
  if (ns < 2 || times.size() != ns)
    throw std::invalid_argument("budget: needs at least two snapshots (with their times)");
  const std::size_t n = cols.front().h.size();
  const double span = times.back() - times.front();
  if (!(span > 0.0)) throw std::invalid_argument("budget: the snapshots span no time");
  // trapezoid weights of the time mean over [t_first, t_last]
  std::vector<double> wt(ns, 0.0);
  for (std::size_t j = 0; j + 1 < ns; ++j) {
    const double d = times[j + 1] - times[j];
    wt[j] += 0.5 * d / span;
    wt[j + 1] += 0.5 * d / span;
  }
  auto mean = [&](std::vector<double> ColumnIntegrals::*f) {
    std::vector<double> m(n, 0.0);
    for (std::size_t j = 0; j < ns; ++j) {
      const auto& v = cols[j].*f;
      if (v.size() != n) throw std::invalid_argument("budget: snapshots on different grids");
      for (std::size_t i = 0; i < n; ++i) m[i] += wt[j] * v[i];
    }
    return m;
  };
  const auto h = mean(&ColumnIntegrals::h), Q = mean(&ColumnIntegrals::Q);
  const auto M = mean(&ColumnIntegrals::M), P = mean(&ColumnIntegrals::P);
  const auto T = mean(&ColumnIntegrals::T), pb = mean(&ColumnIntegrals::p_b);
  const auto ta = mean(&ColumnIntegrals::tau_applied), tb = mean(&ColumnIntegrals::tau_bound);
  const auto Mx = ddx(M, dx), Px = ddx(P, dx), Tx = ddx(T, dx);
  const double g_sin = ph.g * std::sin(ph.zeta);
  ColumnBudget b;
  b.t0 = times.front();
  b.t1 = times.back();
  b.snapshots = static_cast<int>(ns);
  for (std::size_t i = 0; i < n; ++i) {
    b.x.push_back(x0 + (static_cast<double>(i) + 0.5) * dx);
    b.h.push_back(h[i]);
    b.u_mean.push_back(h[i] > 0.0 ? Q[i] / h[i] : 0.0);
    b.alpha.push_back(Q[i] != 0.0 ? M[i] * h[i] / (Q[i] * Q[i]) : 0.0);
    b.dQdt.push_back((cols.back().Q[i] - cols.front().Q[i]) / span);
    b.flux.push_back(Mx[i]);
    b.gravity.push_back(g_sin * h[i]);
    b.pressure.push_back(-Px[i]);
    b.viscous.push_back(Tx[i]);
    b.friction.push_back(-ta[i]);
    b.friction_bound.push_back(-tb[i]);
    b.p_b.push_back(pb[i]);
    const double lhs = b.dQdt.back() + b.flux.back();
    const double rhs = b.gravity.back() + b.pressure.back() + b.viscous.back();
    b.residual.push_back(lhs - rhs - b.friction.back());
    b.residual_bound.push_back(lhs - rhs - b.friction_bound.back());
  }
  return b;
}

ColumnBudget dam_budget(const std::vector<std::vector<double>>& h,
                        const std::vector<std::vector<double>>& u,
                        const std::vector<double>& times, double x0, double dx,
                        const BudgetPhysics& ph, const std::function<double(double)>& K) {
  const double g_cos = ph.g * std::cos(ph.zeta);
  std::vector<ColumnIntegrals> cols;
  for (std::size_t j = 0; j < h.size(); ++j) {
    const std::size_t n = h[j].size();
    if (u.at(j).size() != n) throw std::invalid_argument("dam budget: h and u differ in size");
    const auto ux = ddx(u[j], dx);
    ColumnIntegrals c;
    for (auto* v : {&c.h, &c.Q, &c.M, &c.P, &c.T, &c.p_b, &c.tau_applied, &c.tau_bound})
      v->assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const double hi = h[j][i], ui = u[j][i];
      c.h[i] = hi;
      c.Q[i] = hi * ui;
      c.M[i] = hi * ui * ui;
      c.P[i] = K(ux[i]) * g_cos * hi * hi / 2.0;
      c.p_b[i] = g_cos * hi;
      c.tau_applied[i] = c.tau_bound[i] = sgn(ui) * ph.tan_delta * g_cos * hi;
    }
    cols.push_back(std::move(c));
  }
  return momentum_budget(cols, times, x0, dx, ph);
}

StretchBudget stretch(const ColumnBudget& b, double xa, double xb) {
  StretchBudget s;
  s.xa = xa;
  s.xb = xb;
  const double dx = b.x.size() > 1 ? b.x[1] - b.x[0] : 0.0;
  double qsum = 0.0;
  for (std::size_t i = 0; i < b.x.size(); ++i) {
    if (b.x[i] < xa || b.x[i] > xb) continue;
    ++s.columns;
    qsum += b.h[i] * b.u_mean[i];
    s.dQdt += b.dQdt[i] * dx;
    s.flux += b.flux[i] * dx;
    s.gravity += b.gravity[i] * dx;
    s.pressure += b.pressure[i] * dx;
    s.viscous += b.viscous[i] * dx;
    s.friction += b.friction[i] * dx;
    s.friction_bound += b.friction_bound[i] * dx;
    s.residual += b.residual[i] * dx;
    s.residual_bound += b.residual_bound[i] * dx;
  }
  s.q = s.columns > 0 ? qsum / s.columns : 0.0;
  return s;
}

}  // namespace granflow::analysis
