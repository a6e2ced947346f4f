/* One time step of a slab of chains: the one step function of the chain, for fix lattice/chain's
   owned pass (its slab of one rank), the host engine and the GPU engine (chain.h: one chain).
   Part of pylmp_lattice, GPL-2.0.

   The slab's free atoms come as runs (blocks of at most `block` atoms that follow each other in
   memory with consecutive IDs, in ID order), each with the index of the atom left of its first
   and right of its last (a chain end, an atom of the next run, or a slab-edge neighbour whose
   position the caller has set for this step). One pass over the runs does velocity Verlet's
   whole step: the first half kick and drift of the next run, then the bond forces, friction and
   second half kick of this one (both neighbours of a run have moved when its forces are due),
   and, with FRONT, the front record's hot part and the caller's sampling of the run's rows. */

#ifndef PYLMP_LATTICE_KERNEL_STEP_H
#define PYLMP_LATTICE_KERNEL_STEP_H

#include "coulomb.h"
#include "device.h"
#include "front.h"

namespace pl_kernel {

struct Run {
  int first, last, left, right, chain;
};

/* per-atom masses through slots: slot[i] (an atom type, or its own index) names its dt/2m, m and
   m g; one_type: every atom has slot 1 (no lookup) */
struct Masses {
  const int *slot;
  const double *dtfm, *mass, *weight;
  bool one_type;
};

/* the separations seen: smallest, largest and a NaN probe (their sum) */
struct Gaps {
  double r_min, r_max, r_sum;
  PL_HD Gaps() : r_min(infinity()), r_max(-infinity()), r_sum(0.0) {}
  PL_HD void add(double r)
  {
    r_min = r < r_min ? r : r_min;
    r_max = r > r_max ? r : r_max;
    r_sum += r;
  }
  /* a contact (r <= 0), a separation outside [lo, hi], or a NaN */
  PL_HD bool bad(double lo, double hi) const { return !(r_min > 0.0 && r_min >= lo && r_max <= hi) || isnan(r_sum); }
};

/* the bond forces F[k] = law(X[k + 1] - X[k]), k < nbonds, of consecutive positions X, their
   separations added to gaps (vectorised reductions) */
template <class LawT>
PL_HD inline void bond_forces(const LawT law, const double *PL_RESTRICT X, int nbonds, double *PL_RESTRICT F,
                              Gaps &gaps)
{
  double r_min = gaps.r_min, r_max = gaps.r_max, r_sum = gaps.r_sum;
  PL_SIMD_REDUCE
  for (int k = 0; k < nbonds; k++) {
    const double r = X[k + 1] - X[k];
    r_min = r < r_min ? r : r_min;
    r_max = r > r_max ? r : r_max;
    r_sum += r;
    F[k] = law(r);
  }
  gaps.r_min = r_min, gaps.r_max = r_max, gaps.r_sum = r_sum;
}

/* one free atom's total force from its bonds' forces left and right (slot t), with friction the
   exact stick-slip kick of length `kick`: v (after the first half kick) becomes 0 if it sticks */
template <bool FRICTION>
PL_HD inline double total_force(double left, double right, int t, const Masses &ms, const Friction &fr, double kick,
                                double &v, CoulombWork &work)
{
  const double fx = left - right;
  if constexpr (!FRICTION) {
    return fx;
  } else {
    return fr.kick_force(ms.mass[t], ms.weight[t], left, right, fx, kick, v, work);
  }
}

/* the front record of the runs' atoms, as the step needs it: per atom its largest |v| (mark)
   and its start gate (its chain's start level while it waits, else infinity); Hook is the
   caller's: sample_block(b, v_before, starting) samples run b's rows (v_before: the run's
   velocities of the previous step; starting: an atom reached its start gate now) */
template <class Hook> struct FrontPass {
  double *mark;
  const double *gate;
  Hook *hook;
};
struct NoFront {
  PL_HD void sample_block(int, const double *, bool) {}
};

namespace detail {
/* where a run's second half kick goes: nowhere (LAMMPS's force pass without it), onto the
   velocities it read (in place) or into a separate row */
enum class KickTo { none, in_place, out };

/* the forces of a run's atoms from its bond forces F (F[k] left of atom first + k) into fb and
   their second half kick from vh into vb (or in place): the arrays' atoms STRIDE doubles apart.
   MARK: with the front record's hot part in the same loop (mark: each atom's largest |v|; any:
   set if an atom's new v reaches its start gate), so that the kick's stores and the record's
   share one pass; `any` is an integer OR, which vectorises without reordering a sum */
template <bool FRICTION, bool ONE_TYPE, KickTo TO = KickTo::out, int STRIDE = 1, bool MARK = false>
PL_HD inline void kick_run(const double *PL_RESTRICT F, const int first, const int len, const Masses &ms,
                           const Friction &fr, double kick, double *PL_RESTRICT vh, double *PL_RESTRICT fb,
                           double *PL_RESTRICT vb, CoulombWork &work, double *PL_RESTRICT mark = nullptr,
                           const double *PL_RESTRICT gate = nullptr, long long *any = nullptr)
{
  const double half_kick = ONE_TYPE ? ms.dtfm[1] : 0.0;
  long long reached = 0;
  for (int k = 0; k < len; k++) {
    const int t = FRICTION || !ONE_TYPE ? ms.slot[first + k] : 1;
    const double ftot = total_force<FRICTION>(F[k], F[k + 1], t, ms, fr, kick, vh[STRIDE * k], work);
    fb[STRIDE * k] = ftot;
    if constexpr (TO != KickTo::none) {
      const double vn = vh[STRIDE * k] + (ONE_TYPE ? half_kick : ms.dtfm[t]) * ftot;
      (TO == KickTo::in_place ? vh : vb)[STRIDE * k] = vn;
      if constexpr (MARK) {
        mark[k] = front::mark_max(mark[k], vn);
        reached |= vn >= gate[k];
      }
    }
  }
  if constexpr (MARK) *any = reached;
}

/* velocity Verlet's first half kick and drift of ndrift atoms (x, v, f, slots from their first;
   vh: the velocities after the half kick, v0: before it, if KEEP), and the forces F[k] = law(X[k + 1] -
   X[k]) of nbonds bonds of consecutive positions X of another run, their separations added to
   gaps: one loop over both where they overlap, so that the drift's loads and stores run while
   the law's division does (the bonds' atoms have drifted before, the drift's are not read) */
template <bool ONE_TYPE, bool KEEP, class LawT>
PL_HD inline void drift_and_bonds(const LawT law, const double *PL_RESTRICT X, int nbonds, double *PL_RESTRICT F,
                                  Gaps &gaps, double *PL_RESTRICT x, const double *PL_RESTRICT v,
                                  const double *PL_RESTRICT f, const int *PL_RESTRICT slot, int ndrift,
                                  const double *PL_RESTRICT dtfm_of, double dtv, double *PL_RESTRICT vh,
                                  double *PL_RESTRICT v0)
{
  const double half_kick = ONE_TYPE ? dtfm_of[1] : 0.0;
  auto drift = [&](int k) {
    if constexpr (KEEP) v0[k] = v[k];
    vh[k] = v[k] + (ONE_TYPE ? half_kick : dtfm_of[slot[k]]) * f[k];
    x[k] += dtv * vh[k];
  };
  const int both = nbonds < ndrift ? nbonds : ndrift;
  double r_min = gaps.r_min, r_max = gaps.r_max, r_sum = gaps.r_sum;
  PL_SIMD_REDUCE
  for (int k = 0; k < both; k++) {
    drift(k);
    const double r = X[k + 1] - X[k];
    r_min = r < r_min ? r : r_min;
    r_max = r > r_max ? r : r_max;
    r_sum += r;
    F[k] = law(r);
  }
  gaps.r_min = r_min, gaps.r_max = r_max, gaps.r_sum = r_sum;
  bond_forces(law, X + both, nbonds - both, F + both, gaps);
  for (int k = both; k < ndrift; k++) drift(k);
}
}    // namespace detail

/* The whole step of the runs' atoms (the chain ends are the caller's: it has placed the
   impactors at this step's position before). x, v, f: the slab's arrays along x; works: per
   chain, this step's friction work (each run adds to its chain's, in ID order); scratch: 4 block
   + block + 1 doubles; gaps: every bond left of a run's atom and right of its last. */
template <bool FRICTION, bool FRONT, class LawT, class Hook>
PL_HD void step_runs(const LawT law, const Run *runs, int nruns, double *PL_RESTRICT x, double *PL_RESTRICT v,
                     double *PL_RESTRICT f, const Masses &ms, const Friction &fr, double dt, CoulombWork *works,
                     double *scratch, int block, const FrontPass<Hook> &front, Gaps &gaps)
{
  const int *PL_RESTRICT type = ms.slot;
  const bool one_type = ms.one_type;
  const double dtv = dt, kick = dt;
  // per run in flight (two): the velocities after the first half kick, and before it (for the
  // front record's hook); then the run's bond forces, F[k] left of atom first + k
  double *PL_RESTRICT half[2] = {scratch, scratch + block};
  double *PL_RESTRICT before[2] = {scratch + 2 * block, scratch + 3 * block};
  double *PL_RESTRICT F = scratch + 4 * block;
  // the inner bonds of run b (none for b < 0) with the first half kick and drift of run b + 1 (with
  // last step's forces; none past the last run): one loop for one atom type and one for several
  auto drift_and_bonds = [&](int b) {
    const int first = b >= 0 ? runs[b].first : 0, nbonds = b >= 0 ? runs[b].last - runs[b].first : 0;
    const int next = b + 1 < nruns ? runs[b + 1].first : 0, ndrift = b + 1 < nruns ? runs[b + 1].last - next + 1 : 0;
    double *vh = half[(b + 1) % 2], *v0 = before[(b + 1) % 2];
    if (one_type)
      detail::drift_and_bonds<true, FRONT>(law, x + first, nbonds, F + 1, gaps, x + next, v + next, f + next, nullptr, ndrift,
                                    ms.dtfm, dtv, vh, v0);
    else
      detail::drift_and_bonds<false, FRONT>(law, x + first, nbonds, F + 1, gaps, x + next, v + next, f + next, type + next,
                                     ndrift, ms.dtfm, dtv, vh, v0);
  };
  drift_and_bonds(-1);
  for (int b = 0; b < nruns; b++) {
    const Run &run = runs[b];
    const int first = run.first, last = run.last, len = last - first + 1;
    CoulombWork work;
    if constexpr (FRICTION) work = works[run.chain];
    drift_and_bonds(b);
    // the two end bonds (both neighbours have moved now)
    const double r_left = x[first] - x[run.left], r_right = x[run.right] - x[last];
    gaps.add(r_left);
    gaps.add(r_right);
    F[0] = law(r_left);
    F[len] = law(r_right);
    // the forces and the second half kick, with the front record's largest |v| of every atom (it
    // may change at every step: atoms ahead of the front feel round-off forces from unequal
    // gaps) and whether a waiting atom reaches the start level now; one loop for one atom type
    // and one for several (a test inside would keep the loop from vectorising)
    double *PL_RESTRICT vh = half[b % 2];
    double *PL_RESTRICT fb = f + first;
    double *PL_RESTRICT vb = v + first;
    using detail::KickTo;
    long long starting = 0;
    double *mark = FRONT ? front.mark + first : nullptr;
    const double *gate = FRONT ? front.gate + first : nullptr;
    if (one_type)
      detail::kick_run<FRICTION, true, KickTo::out, 1, FRONT>(F, first, len, ms, fr, kick, vh, fb, vb, work, mark, gate,
                                                              &starting);
    else
      detail::kick_run<FRICTION, false, KickTo::out, 1, FRONT>(F, first, len, ms, fr, kick, vh, fb, vb, work, mark,
                                                               gate, &starting);
    if constexpr (FRICTION) works[run.chain] = work;
    if constexpr (FRONT) front.hook->sample_block(b, before[b % 2], starting != 0);
  }
}

}    // namespace pl_kernel

#endif
