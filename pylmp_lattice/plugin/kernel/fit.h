/* The splines' fits, on the host only (the plugin when it reads a table or a measured drive,
   the host engine from its arguments; the GPU engine gets the fitted arrays): the storage is the
   caller's, so the kernel's Spline and Drive stay plain pointers. Part of pylmp_lattice, GPL-2.0. */

#ifndef PYLMP_LATTICE_KERNEL_FIT_H
#define PYLMP_LATTICE_KERNEL_FIT_H

#include "drive.h"
#include "law.h"

#include <vector>

namespace pl_kernel {

/* Clamped spline on a uniform grid of n points from `first` with spacing `step`: first
   derivatives given at both ends; tridiagonal solve for d2y. yd2: 2 n doubles (the caller's). */
inline Spline fit_spline(double first, double step, const double *y, int n, double slope_lo, double slope_hi,
                         double *yd2)
{
  const double dx = step;
  std::vector<double> d2(n), w(n);
  d2[0] = -0.5;
  w[0] = 3.0 / dx * ((y[1] - y[0]) / dx - slope_lo);
  for (int i = 1; i < n - 1; i++) {
    const double p = 0.5 * d2[i - 1] + 2.0;
    d2[i] = -0.5 / p;
    w[i] = (3.0 * (y[i + 1] - 2.0 * y[i] + y[i - 1]) / (dx * dx) - 0.5 * w[i - 1]) / p;
  }
  const double wn = 3.0 / dx * (slope_hi - (y[n - 1] - y[n - 2]) / dx);
  d2[n - 1] = (wn - 0.5 * w[n - 2]) / (0.5 * d2[n - 2] + 1.0);
  for (int i = n - 2; i >= 0; i--) d2[i] = d2[i] * d2[i + 1] + w[i];
  for (int i = 0; i < n; i++) {
    yd2[2 * i] = y[i];
    yd2[2 * i + 1] = d2[i];
  }
  return Spline::on_grid(first, step, n, yd2);
}

/* A bond_style table's law: n rows r, U, F on a uniform grid (checked by the caller) and the
   end slopes fp_lo, fp_hi of F, as bond_style table spline reads them. storage: 4 n doubles. */
inline Law fit_table(const double *r, const double *u, const double *f, int n, double fp_lo, double fp_hi,
                     double *storage)
{
  const double step = (r[n - 1] - r[0]) / (n - 1);
  fit_spline(r[0], step, f, n, fp_lo, fp_hi, storage);
  fit_spline(r[0], step, u, n, -f[0], -f[n - 1], storage + 2 * n);
  return Law::table(r[0], step, n, storage);
}

/* Not-a-knot cubic spline of a measured drive: the third derivative is continuous at t[1] and
   t[n-2]. Eliminating d2y[0] and d2y[n-1] with these conditions leaves a tridiagonal system for
   d2y[1..n-2], solved by the Thomas algorithm. t, y: n >= 4 samples (t increasing); storage: 2 n
   doubles (d2y, then the integral of the spline from t[0] at each knot). */
inline Measured fit_measured(const double *t, const double *y, int n, bool given_velocity, bool hold_after,
                             double *storage)
{
  std::vector<double> h(n - 1), lo(n), di(n), up(n), rhs(n);
  for (int i = 0; i < n - 1; i++) h[i] = t[i + 1] - t[i];
  for (int i = 1; i < n - 1; i++) {
    lo[i] = h[i - 1];
    di[i] = 2.0 * (h[i - 1] + h[i]);
    up[i] = h[i];
    rhs[i] = 6.0 * ((y[i + 1] - y[i]) / h[i] - (y[i] - y[i - 1]) / h[i - 1]);
  }
  // d2y[0] = ((h0 + h1) d2y[1] - h0 d2y[2]) / h1, and its mirror image at the right end
  di[1] += h[0] * (h[0] + h[1]) / h[1];
  up[1] -= h[0] * h[0] / h[1];
  const double a = h[n - 3], b = h[n - 2];
  di[n - 2] += b * (a + b) / a;
  lo[n - 2] -= b * b / a;

  for (int i = 2; i < n - 1; i++) {
    const double w = lo[i] / di[i - 1];
    di[i] -= w * up[i - 1];
    rhs[i] -= w * rhs[i - 1];
  }
  double *d2y = storage, *yint = storage + n;
  for (int i = 0; i < n; i++) d2y[i] = 0.0;
  d2y[n - 2] = rhs[n - 2] / di[n - 2];
  for (int i = n - 3; i >= 1; i--) d2y[i] = (rhs[i] - up[i] * d2y[i + 1]) / di[i];
  d2y[0] = ((h[0] + h[1]) * d2y[1] - h[0] * d2y[2]) / h[1];
  d2y[n - 1] = ((a + b) * d2y[n - 2] - b * d2y[n - 3]) / a;

  yint[0] = 0.0;
  for (int i = 0; i < n - 1; i++)
    yint[i + 1] = yint[i] + 0.5 * h[i] * (y[i] + y[i + 1]) - h[i] * h[i] * h[i] * (d2y[i] + d2y[i + 1]) / 24.0;
  return Measured{n, t, y, d2y, yint, given_velocity, hold_after};  // its fields, in order (drive.h)
}

}    // namespace pl_kernel

#endif
