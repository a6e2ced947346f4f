/* Coulomb friction with stick-slip: the one home of the friction rule, for fix lattice/chain,
   fix lattice/friction, the host engine and the GPU engine. Part of pylmp_lattice, GPL-2.0. The
   scheme is documented in fix_lattice_friction.cpp. */

#ifndef PYLMP_LATTICE_KERNEL_COULOMB_H
#define PYLMP_LATTICE_KERNEL_COULOMB_H

#include "device.h"

namespace pl_kernel {

/* One atom's kick of length `kick` from velocity v0 under the other forces fx and the
   friction limit `limit`, both held constant over the kick. Returns the constant total
   force that reproduces the exact Coulomb solution; `stuck` says the atom ends the kick at
   rest (then v and f must be set to exactly zero). */
PL_HD inline double coulomb_kick(double v0, double fx, double limit, double dvdf, bool &stuck)
{
  stuck = false;
  if (v0 == 0.0) {
    if (fabs(fx) <= limit) stuck = true;
    return stuck ? 0.0 : fx - copysign(limit, fx);
  }
  const double s = copysign(1.0, v0);
  double ftot = fx - s * limit;
  const double v1 = v0 + dvdf * ftot;
  if (s * v1 <= 0.0) {    // the velocity reaches zero within the kick
    if (fabs(fx) <= limit) {
      stuck = true;
      return 0.0;
    }
    // moves off the other way for the rest of the kick, a time m v1 / ftot
    ftot = (v1 * (fx + s * limit) / ftot - v0) / dvdf;
  }
  return ftot;
}

/* The friction work of the kicks of one step, split at the full step: a stuck atom's loss is
   settled now; a slipping atom's velocity goes v0, v0 + h, v0 + 2h over the kick, so its halves
   are -ffric kick/4 (2 v0 + h) and -ffric kick/4 (2 v0 + 3h). */
struct CoulombWork {
  double now = 0.0, sum_fv = 0.0, sum_fh = 0.0;

  PL_HD void stuck(double v0, double m, double kick, double fx) { now += 0.5 * v0 * (m * v0 + kick * fx); }
  PL_HD void slip(double v0, double fx, double ftot, double dvdf)
  {
    const double ffric = ftot - fx;
    sum_fv += ffric * v0;
    sum_fh += ffric * (0.5 * dvdf * ftot);
  }
  /* add this step's work to `done`, and keep the part due at the next step in `pending`;
     the setup's half kick from v(0) replaces the half planned at the end of the last run */
  PL_HD void settle(double kick, bool setup_kick, double &done, double &pending) const
  {
    double next = 0.0, current = now;
    if (setup_kick) {
      next -= kick * (sum_fv + sum_fh);
    } else {
      current -= 0.25 * kick * (2.0 * sum_fv + sum_fh);
      next -= 0.25 * kick * (2.0 * sum_fv + 3.0 * sum_fh);
      done += pending;
    }
    done += current;
    pending = next;
  }
};

/* The friction coefficients: limit L = mu (m g + p (F_left + F_right)), clipped at zero should
   the bonds ever attract. */
struct Friction {
  double mu = 0.0, p = 0.0, g = 0.0;

  PL_HD double limit(double weight, double f_left, double f_right) const
  {
    const double normal = weight + p * (f_left + f_right);
    return normal > 0.0 ? mu * normal : 0.0;
  }

  /* one atom of mass m and weight m g (precomputed by the caller, as m * g), velocity v (after
     the first half kick) and other force fx = f_left - f_right, for a kick of length `kick`:
     the total force of the exact stick-slip kick; v becomes 0 if the atom sticks (the force is
     then 0); the work goes to `work` */
  PL_HD double kick_force(double m, double weight, double f_left, double f_right, double fx, double kick, double &v,
                          CoulombWork &work) const
  {
    const double dvdf = kick / m;
    const double v0 = v;
    bool stuck;
    const double ftot = coulomb_kick(v0, fx, limit(weight, f_left, f_right), dvdf, stuck);
    if (stuck) work.stuck(v0, m, kick, fx), v = 0.0;
    else work.slip(v0, fx, ftot, dvdf);
    return ftot;
  }
};

}    // namespace pl_kernel

#endif
