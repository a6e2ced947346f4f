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
   rest (then v and f must be set to exactly zero). R: double or lanes (device.h), each lane's
   case a select; the turning case's divisions run only where a lane turns. */
template <class R>
PL_HD inline R coulomb_kick(R v0, R fx, R limit, R dvdf, MaskOf<R> &stuck)
{
  using L = Lanes<R>;
  const MaskOf<R> rest = v0 == 0.0, holds = fabs(fx) <= limit;
  const R s = copysign(L::splat(1.0), v0);
  R ftot = fx - s * limit;
  const R v1 = v0 + dvdf * ftot;
  const MaskOf<R> turns = s * v1 <= 0.0 && !rest;    // the velocity reaches zero within the kick
  // at rest it stays there or slips off; turning it stops or moves off the other way for the
  // rest of the kick, a time m v1 / ftot
  if (L::any(turns && !holds)) ftot = turns ? (v1 * (fx + s * limit) / ftot - v0) / dvdf : ftot;
  ftot = rest ? fx - copysign(limit, fx) : ftot;
  stuck = holds && (rest || turns);
  return stuck ? L::splat(0.0) : ftot;
}

/* The friction work of the kicks of one step, split at the full step: a stuck atom's loss is
   settled now; a slipping atom's velocity goes v0, v0 + h, v0 + 2h over the kick, so its halves
   are -ffric kick/4 (2 v0 + h) and -ffric kick/4 (2 v0 + 3h). Per lane with lanes. */
template <class R> struct CoulombWorkT {
  R now = R(), sum_fv = R(), sum_fh = R();

  /* an atom's kick: stuck (its loss now) or slipping with total force ftot */
  PL_HD void add(MaskOf<R> stuck, R v0, R m, double kick, R fx, R ftot, R dvdf)
  {
    const R ffric = ftot - fx;
    now = stuck ? now + 0.5 * v0 * (m * v0 + kick * fx) : now;
    sum_fv = stuck ? sum_fv : sum_fv + ffric * v0;
    sum_fh = stuck ? sum_fh : sum_fh + ffric * (0.5 * dvdf * ftot);
  }
  /* add this step's work to `done`, and keep the part due at the next step in `pending`;
     the setup's half kick from v(0) replaces the half planned at the end of the last run */
  PL_HD void settle(double kick, bool setup_kick, R &done, R &pending) const
  {
    R next = R(), current = now;
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
typedef CoulombWorkT<double> CoulombWork;

/* The friction coefficients: limit L = mu (m g + p (F_left + F_right)), clipped at zero should
   the bonds ever attract. */
struct Friction {
  double mu = 0.0, p = 0.0, g = 0.0;

  template <class R> PL_HD R limit(R weight, R f_left, R f_right) const
  {
    const R normal = weight + p * (f_left + f_right);
    return normal > 0.0 ? mu * normal : Lanes<R>::splat(0.0);
  }

  /* one atom of mass m and weight m g (precomputed by the caller, as m * g), velocity v (after
     the first half kick) and other force fx = f_left - f_right, for a kick of length `kick`:
     the total force of the exact stick-slip kick; v becomes 0 if the atom sticks (the force is
     then 0); the work goes to `work`; dvdf: kick / m, or null (then computed here) */
  template <class R>
  PL_HD R kick_force(R m, R weight, R f_left, R f_right, R fx, double kick, R &v, CoulombWorkT<R> &work,
                     const R *dvdf_of = nullptr) const
  {
    const R dvdf = dvdf_of ? *dvdf_of : kick / m;
    const R v0 = v;
    MaskOf<R> stuck;
    const R ftot = coulomb_kick(v0, fx, limit(weight, f_left, f_right), dvdf, stuck);
    work.add(stuck, v0, m, kick, fx, ftot, dvdf);
    v = stuck ? Lanes<R>::splat(0.0) : v0;
    return ftot;
  }
};

}    // namespace pl_kernel

#endif
