/* The impactor's prescribed motion: the one home of the drive, for fix lattice/chain (each
   chain's first atom), fix lattice/impactor (one atom), the host engine and the GPU engine. Its
   Python twin is pylmp_lattice/impactor.py (tests/test_plugin.py binds them). Part of pylmp_lattice,
   GPL-2.0.

   constant: u = V t; ramp: v rises linearly to V over T, then constant; sine: v = V sin(pi t / T)
   for t < T, then at rest; rest: held in place; measured: the not-a-knot spline of a series of
   u or v (fitted by fit_measured, fit.h), held at its last position after the data or an error. */

#ifndef PYLMP_LATTICE_KERNEL_DRIVE_H
#define PYLMP_LATTICE_KERNEL_DRIVE_H

#include "device.h"

namespace pl_kernel {

/* A measured motion: knots t, values y (u or v), second derivatives d2y and yint, the integral
   of the spline from t[0] at each knot; the arrays are the owner's. */
struct Measured {
  int n = 0;
  const double *t = nullptr, *y = nullptr, *d2y = nullptr, *yint = nullptr;
  bool given_velocity = false;    // y is v (else u)
  bool hold_after = false;        // past the data: held at the last position (else an error)

  /* displacement u from the first sample and velocity ud at time tau after t[0]; returns false
     past the data (beyond a round-off `slack`) without hold_after: the caller stops the run */
  PL_HD bool at(double tau, double slack, double &u, double &ud) const
  {
    double time = t[0] + tau;
    // a run meant to end on the last sample may overshoot it by round-off
    const bool past_end = time > t[n - 1] + slack;
    if (past_end && !hold_after) return false;
    time = time < t[n - 1] ? time : t[n - 1];
    // the last knot at or before time (upper_bound - 1), at most n - 2
    int lo = 0, hi = n;
    while (lo < hi) {
      const int mid = (lo + hi) / 2;
      if (t[mid] <= time) lo = mid + 1;
      else hi = mid;
    }
    int k = lo - 1;
    k = k < n - 2 ? k : n - 2;
    const double h = t[k + 1] - t[k];
    const double A = (t[k + 1] - time) / h, B = 1.0 - A;
    const double c = h * h / 6.0;
    const double value = A * y[k] + B * y[k + 1] + c * ((A * A * A - A) * d2y[k] + (B * B * B - B) * d2y[k + 1]);
    const double slope = (y[k + 1] - y[k]) / h +
        h / 6.0 * (-(3.0 * A * A - 1.0) * d2y[k] + (3.0 * B * B - 1.0) * d2y[k + 1]);
    if (given_velocity) {
      const double integral = yint[k] + h * (0.5 * (1.0 - A * A) * y[k] + 0.5 * B * B * y[k + 1]) +
          h * c * ((0.25 * (1.0 - A * A * A * A) - 0.5 * (1.0 - A * A)) * d2y[k] +
                   (0.25 * B * B * B * B - 0.5 * B * B) * d2y[k + 1]);
      u = integral;
      ud = value;
    } else {
      u = value - y[0];
      ud = slope;
    }
    if (past_end) ud = 0.0;    // holding the last position
    return true;
  }
};

struct Drive {
  enum Profile { CONSTANT, RAMP, SINE, REST, MEASURED };
  Profile profile = REST;
  double V = 0.0, T = 0.0;    // peak velocity; ramp time or pulse length
  Measured measured;
  /* the host's u, ud of steps 0 .. path_steps - 1 (at(step dt), pairs), or none: the GPU engine's
     sine drive, since CUDA's sin and cos are within 1-2 ulp where glibc's round correctly, and
     one ulp of the impactor at one step parts the chains by 1e-11 after thousands */
  const double *path = nullptr;
  long long path_steps = 0;

  /* displacement u and velocity ud at time t from the origin; dt: the time step (a measured
     run meant to end on the last sample may overshoot it by round-off); false: past the end of
     a measured drive that does not hold */
  PL_HD bool at(double t, double dt, double &u, double &ud) const
  {
    switch (profile) {
      case CONSTANT:
        u = V * t;
        ud = V;
        return true;
      case RAMP:
        u = t < T ? V * t * t / (2.0 * T) : V * (t - 0.5 * T);
        ud = t < T ? V * t / T : V;
        return true;
      case SINE:
        u = t < T ? V * T / PI * (1.0 - cos(PI * t / T)) : 2.0 * V * T / PI;
        ud = t < T ? V * sin(PI * t / T) : 0.0;
        return true;
      case MEASURED:
        return measured.at(t, 1.0e-6 * dt, u, ud);
      default:    // REST
        u = ud = 0.0;
        return true;
    }
  }

  /* at(step dt): from the path where it has the step */
  PL_HD bool at_step(long long step, double dt, double &u, double &ud) const
  {
    if (step < path_steps) {
      u = path[2 * step], ud = path[2 * step + 1];
      return true;
    }
    return at(static_cast<double>(step) * dt, dt, u, ud);
  }
};

}    // namespace pl_kernel

#endif
