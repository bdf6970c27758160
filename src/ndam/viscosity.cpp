// N-DAM viscosity: the effective viscosity of the viscoplastic rheology at the cell centres,
// evaluated on the state at t^n (paper eqs. 4-6):
//   nu_eff = nu + tau_y / ||D|| (1 - exp(-m_y ||D||)),   ||D|| = sqrt(2 tr D^2),
//   tau_y  = tau_c + tau_p max(p, 0)   (Drucker-Prager: tau_p = sin(phi); Bingham: tau_p = 0).
// D at a cell centre: the normal rates from the faces of the cell, the shear rate
// (du/dz + dw/dx)/2 averaged from the four corners. Cells that are not material get the mean of
// their material neighbours (they enter the corner averages on surfaces). The Coulomb factors of
// the walls are updated with it (boundaries.cpp), since they need nu_eff at the wall.
#include "stencil.hpp"

#include <cmath>

namespace granflow::ndam {

void NdamSolver::update_viscosity(const Field& p_yield) {
  if (rheo_.newtonian()) {
    nu_.fill(rheo_.nu);
    update_friction(p_yield);
    return;
  }
  const double dx = cfg_.grid.dx(), dz = cfg_.grid.dz();
  const int nz = cfg_.grid.nz;
  // shear rate du/dz + dw/dx at the top-right corner of cell (i, k)
  auto shear = [&](int i, int k) {
    return (u_(i, k + 1) - u_(i, k)) / dz + (w_(i + 1, k) - w_(i, k)) / dx;
  };
  for (int i = 0; i < mac_.slab.nx_local; ++i) {
    // 'Surface cell mass' = Full cell and weight: the momentum step drives the column's cells
    // as full cells, while p is hydrostatic from the markers' depth h below the top H of its
    // full cells. The yield pressure of the cells that stand on the bed takes the weight of
    // the full cells, p + g cos(zeta) (H - h), as the bed friction does (boundaries.cpp):
    // otherwise the partly filled top cell, driven by g sin(zeta) dz, is held by a yield stress
    // of sin(phi) g cos(zeta) (h - k dz) only and creeps over the cell below (a 20 deg layer
    // below delta = 22 deg at 1-1.5 cm/s; docs/validation.md, "The weight of the full cells").
    int top = -1;
    const double weight = std::abs(phys_.gz) * full_cell_excess(mac_.slab.i0 + i, &top);
    for (int k = 0; k < mac_.top(mac_.slab.i0 + i); ++k) {  // (above: Empty cells)
      if (!mac_.fluid(mac_.slab.i0 + i, k)) continue;
      const double d11 = (u_(i, k) - u_(i - 1, k)) / dx;
      const double d22 = (w_(i, k) - w_(i, k - 1)) / dz;
      const double d12 =
          0.125 * (shear(i, k) + shear(i - 1, k) + shear(i, k - 1) + shear(i - 1, k - 1));
      const double normD = std::sqrt(2.0 * (d11 * d11 + d22 * d22 + 2.0 * d12 * d12));
      // the inflow column of a 1D-to-2D interface (InflowPressure::Rheology): tau_y from the
      // pressure of eq. (26), the 1D side's pressure at x_IF
      const bool p26 = cfg_.inflow_pressure == InflowPressure::Rheology && mac_.slab.i0 + i == 0 &&
                       !cfg_.periodic_x();
      nu_(i, k) =
          rheo_.nu_eff(normD, p26 ? inflow_p26(k) : p_yield(i, k) + (k <= top ? weight : 0.0));
      if (cfg_.free_surface) normD_(i, k) = normD;
    }
  }
  fill_scalar_ghosts(nu_);
  if (has_obstacles_ || cfg_.free_surface) {
    // Obstacle cells enter the corner averages of nu_eff on their surfaces: give them the mean
    // of their fluid neighbours (a mirror, as at the box walls).
    for (int i = 0; i < mac_.slab.nx_local; ++i) {
      // from empty_from on no cell has a material neighbour: nu
      const int ke = mac_.empty_from(i);
      for (int k = ke; k < nz; ++k) nu_(i, k) = rheo_.nu;
      for (int k = 0; k < ke; ++k) {
        const int gi = mac_.slab.i0 + i;
        if (mac_.fluid(gi, k)) continue;
        double sum = 0.0;
        int n = 0;
        const int di[4] = {1, -1, 0, 0}, dk[4] = {0, 0, 1, -1};
        for (int q = 0; q < 4; ++q)
          if (mac_.fluid(gi + di[q], k + dk[q])) {
            sum += nu_(i + di[q], k + dk[q]);
            ++n;
          }
        nu_(i, k) = n > 0 ? sum / n : rheo_.nu;
      }
    }
    fill_scalar_ghosts(nu_);
  }
  update_friction(p_yield);
}

}  // namespace granflow::ndam
