/* The exact Coulomb stick-slip kick shared by fix lattice/friction and fix lattice/chain.
   Part of pylmp_lattice, GPL-2.0. The scheme is documented in fix_lattice_friction.cpp. */

#ifndef PYLMP_LATTICE_COULOMB_H
#define PYLMP_LATTICE_COULOMB_H

#include <cmath>

namespace LAMMPS_NS {

/* One atom's kick of length `kick` from velocity v0 under the other forces fx and the
   friction limit `limit`, both held constant over the kick. Returns the constant total
   force that reproduces the exact Coulomb solution; `stuck` says the atom ends the kick at
   rest (then v and f must be set to exactly zero). */

inline double coulomb_kick(double v0, double fx, double limit, double dvdf, bool &stuck)
{
  stuck = false;
  if (v0 == 0.0) {
    if (std::fabs(fx) <= limit) stuck = true;
    return stuck ? 0.0 : fx - std::copysign(limit, fx);
  }
  const double s = std::copysign(1.0, v0);
  double ftot = fx - s * limit;
  const double v1 = v0 + dvdf * ftot;
  if (s * v1 <= 0.0) {    // the velocity reaches zero within the kick
    if (std::fabs(fx) <= limit) {
      stuck = true;
      return 0.0;
    }
    // moves off the other way for the rest of the kick, a time m v1 / ftot
    ftot = (v1 * (fx + s * limit) / ftot - v0) / dvdf;
  }
  return ftot;
}

/* The friction work of the kicks of one step, split at the full step (see the friction
   fix's header): a stuck atom's loss is settled now; a slipping atom's velocity goes
   v0, v0 + h, v0 + 2h over the kick, so its halves are -ffric kick/4 (2 v0 + h) and
   -ffric kick/4 (2 v0 + 3h). */

struct CoulombWork {
  double now = 0.0, sum_fv = 0.0, sum_fh = 0.0;

  void stuck(double v0, double m, double kick, double fx) { now += 0.5 * v0 * (m * v0 + kick * fx); }
  void slip(double v0, double fx, double ftot, double dvdf)
  {
    const double ffric = ftot - fx;
    sum_fv += ffric * v0;
    sum_fh += ffric * (0.5 * dvdf * ftot);
  }
  /* add this step's work to `done`, and keep the part due at the next step in `pending`;
     the setup's half kick from v(0) replaces the half planned at the end of the last run */
  void settle(double kick, bool setup_kick, double &done, double &pending) const
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

}    // namespace LAMMPS_NS

#endif
