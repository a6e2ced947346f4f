/* One time step of a slab of chains: the one step function of the chain, for fix lattice/chain's
   owned pass (its slab of one rank), the host engine and the GPU engine (chain.h: one chain).
   Part of pylmp_lattice, GPL-2.0.

   The slab's free atoms come as runs (blocks of at most `block` atoms that follow each other in
   memory with consecutive IDs, in ID order), each with the index of the atom left of its first
   and right of its last (a chain end, an atom of the next run, or a slab-edge neighbour whose
   position the caller has set for this step). One pass over the runs does velocity Verlet's
   whole step, three runs at a time in one loop: the first half kick and drift of run b + 1, the
   inner bond forces of run b (its atoms moved one run earlier) and the forces, friction and
   second half kick of run b - 1 (its end bonds were computed after the loop one run earlier,
   once both its neighbours had moved), with FRONT the front record's hot part and then the
   caller's sampling of run b - 1's rows. Why one loop: the drift's and the kick's loads and
   stores overlap the law's division (a loop per stage took about 1.2x as long: 10^4 magnets, a
   standalone driver against the C loop's code); the same operations per atom as one loop per
   stage, so the same bits. R: double (the fix, the GPU engine) or lanes (device.h; the host
   engine: one chain per lane, x[i] atom i of every lane's chain). */

#ifndef PYLMP_LATTICE_KERNEL_STEP_H
#define PYLMP_LATTICE_KERNEL_STEP_H

#include "coulomb.h"
#include "device.h"
#include "front.h"

namespace pl_kernel {

struct Run {
  int first, last, left, right, chain;
};

/* the runs of one chain's free atoms 1 .. n - 2, each at most `block` long (step_runs' runs[b]
   of run_chain, chain.h), computed, not stored */
struct ChainRuns {
  int n, block;
  PL_HD static constexpr ChainRuns of(int n, int block) { return ChainRuns{n, block}; }
  PL_HD constexpr int count() const { return n > 2 ? (n - 2 + block - 1) / block : 0; }
  PL_HD constexpr Run operator[](int b) const
  {
    const int first = 1 + b * block, last = first + block - 1 < n - 2 ? first + block - 1 : n - 2;
    return Run{first, last, first - 1, last + 1, 0};
  }
};
/* the same for an n and block known at compile time (the GPU's short chains): the loops over
   the runs and their atoms unroll in step_runs' own code, so that a chain's arrays can live in
   registers (ptxas: benchmarks/gpu_resources.py) */
template <int N, int BLOCK> struct FixedRuns {
  static constexpr int n = N, block = BLOCK;
  PL_HD static constexpr FixedRuns of(int, int) { return FixedRuns{}; }
  PL_HD static constexpr int count() { return ChainRuns{N, BLOCK}.count(); }
  struct Table {
    Run r[count() > 0 ? count() : 1];
  };
  PL_HD static constexpr Table table()
  {
    Table t{};
    for (int b = 0; b < count(); b++) t.r[b] = ChainRuns{N, BLOCK}[b];
    return t;
  }
  /* from a table of constants, not computed: NVRTC's loop unrolling folds loads of constants
     before arithmetic (computed, the runs' loops did not unroll: ptxas, 2026-11-27) */
  PL_HD Run operator[](int b) const
  {
    constexpr Table t = table();
    return t.r[b];
  }
};
/* how many runs step_runs steps: nruns, or a FixedRuns' constant */
template <class Runs> PL_HD constexpr int run_count(const Runs &, int nruns) { return nruns; }
template <int N, int BLOCK> PL_HD constexpr int run_count(const FixedRuns<N, BLOCK> &runs, int)
{
  return runs.count();
}

/* step_runs' scratch, in R: two runs' bond forces and one run's velocities */
PL_HD constexpr int step_scratch(int block) { return 3 * block + 2; }

/* per-atom masses through slots: slot[i] (an atom type, or its own index) names its dt/2m, m and
   m g; one_type: every atom has slot 1 (no lookup); dtm: dt / m for step_runs' kicks of dt with
   friction (a division less per atom and step), or null */
template <class R> struct MassesT {
  const int *slot;
  const R *dtfm, *mass, *weight;
  bool one_type;
  const R *dtm = nullptr;
};
typedef MassesT<double> Masses;

/* the separations seen: smallest, largest and a NaN probe (their sum) */
template <class R> struct GapsT {
  R r_min, r_max, r_sum;
  PL_HD GapsT() : r_min(Lanes<R>::splat(infinity())), r_max(Lanes<R>::splat(-infinity())), r_sum(R()) {}
  PL_HD void add(R r)
  {
    r_min = r_min < r ? r_min : r;
    r_max = r_max > r ? r_max : r;
    r_sum += r;
  }
  /* a contact (r <= 0), a separation outside [lo, hi], or a NaN */
  PL_HD MaskOf<R> bad(double lo, double hi) const
  {
    return !(r_min > 0.0 && r_min >= lo && r_max <= hi) || isnan(r_sum);
  }
};
typedef GapsT<double> Gaps;

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
    r_min = r_min < r ? r_min : r;
    r_max = r_max > r ? r_max : r;
    r_sum += r;
    F[k] = law(r);
  }
  gaps.r_min = r_min, gaps.r_max = r_max, gaps.r_sum = r_sum;
}

/* one free atom's total force from its bonds' forces left and right (slot t), with friction the
   exact stick-slip kick of length `kick`: v (after the first half kick) becomes 0 if it sticks;
   dtm: ms.dtm where kick is step_runs' dt, else null */
template <bool FRICTION, class R>
PL_HD inline R total_force(R left, R right, int t, const MassesT<R> &ms, const Friction &fr, double kick, R &v,
                           CoulombWorkT<R> &work, const R *dtm = nullptr)
{
  const R fx = left - right;
  if constexpr (!FRICTION) {
    return fx;
  } else {
    return fr.kick_force(ms.mass[t], ms.weight[t], left, right, fx, kick, v, work, dtm ? dtm + t : nullptr);
  }
}

/* the front record of the runs' atoms, as the step needs it: per atom its largest |v| (mark)
   and its start gate (its chain's start level while it waits; while not, a value no v reaches:
   infinity, or NaN; -infinity: counted as starting at every step); Hook is the
   caller's: sample_block(b, v_before, starting) samples run b's rows (v_before: the run's
   velocities of the previous step; starting: an atom reached its start gate now, a mask with
   lanes) */
template <class HookT, class R = double, class Gates = const R *> struct FrontPass {
  using Hook = HookT;
  R *mark;
  Gates gate;    // gate[i]: atom i's start gate (an array, or a view that computes it)
  HookT *hook;
};
/* PER_ATOM: the hook samples each atom right after its kick, sample_atom(i, v_before), instead of
   a run after its kicks (one chain in a GPU thread: no run's velocities kept in registers) */
struct NoFront {
  static constexpr bool PER_ATOM = false;
  PL_HD void sample_block(int, const double *, bool) {}
};

namespace detail {
/* a bool as a type (std::integral_constant, which NVRTC lacks) */
template <bool B> struct Bool {
  static constexpr bool value = B;
  PL_HD constexpr operator bool() const { return B; }
};

/* where a run's second half kick goes: nowhere (LAMMPS's force pass without it) or onto the
   velocities it read (in place) */
enum class KickTo { none, in_place };

/* one free atom's force from its bonds' forces left and right into f and its second half kick
   of v (after the first half kick) in place (TO), with slot t's mass terms (h: one type's
   dt/2m); MARK: the front record's hot part too (mark: its largest |v|; starting: counts 1 if
   its new v reaches its start gate, as a double, which vectorises with the doubles, and a sum of
   ones is exact in any order) */
template <bool FRICTION, bool ONE_TYPE, KickTo TO, bool MARK = false, class R>
PL_HD inline void kick_atom(R left, R right, int t, R h, const MassesT<R> &ms, const Friction &fr, double kick, R &v,
                            R &f, CoulombWorkT<R> &work, R *mark = nullptr, R gate = R(), R *starting = nullptr,
                            const R *dtm = nullptr)
{
  const R ftot = total_force<FRICTION>(left, right, t, ms, fr, kick, v, work, dtm);
  f = ftot;
  if constexpr (TO == KickTo::in_place) {
    const R vn = v + (ONE_TYPE ? h : ms.dtfm[t]) * ftot;
    v = vn;
    if constexpr (MARK) {
      *mark = front::mark_max(*mark, vn);
      *starting += vn >= gate ? Lanes<R>::splat(1.0) : Lanes<R>::splat(0.0);
    }
  }
}

/* kick_atom for a run's atoms first .. first + len - 1 from its bond forces F (F[k] left of
   atom first + k): v and f STRIDE doubles apart */
template <bool FRICTION, bool ONE_TYPE, KickTo TO, int STRIDE = 1>
PL_HD inline void kick_run(const double *PL_RESTRICT F, const int first, const int len, const Masses &ms,
                           const Friction &fr, double kick, double *PL_RESTRICT v, double *PL_RESTRICT f,
                           CoulombWork &work)
{
  const double h = ONE_TYPE ? ms.dtfm[1] : 0.0;
  for (int k = 0; k < len; k++) {
    const int t = FRICTION || !ONE_TYPE ? ms.slot[first + k] : 1;
    kick_atom<FRICTION, ONE_TYPE, TO>(F[k], F[k + 1], t, h, ms, fr, kick, v[STRIDE * k], f[STRIDE * k], work);
  }
}

/* The stages of the owned pass on the slab's arrays (x, v, f along x; see step_runs). Between
   its drift and its kick a run's f holds the velocities after the first half kick (its forces of
   the last step are spent then, and nothing else reads them in between), so that v keeps the
   velocities before it for the front record's sampling of atoms that start now. */
template <bool FRICTION, bool FRONT, bool ONE_TYPE, class LawT, class R, class Front> struct Stages {
  const LawT law;
  R *PL_RESTRICT x;
  R *PL_RESTRICT v;
  R *PL_RESTRICT f;
  const MassesT<R> &ms;
  const Friction &fr;
  double dt;
  R h;
  const Front &front;

  /* first half kick and drift of atom i */
  PL_HD void drift(int i) const
  {
    const R vh = v[i] + (ONE_TYPE ? h : ms.dtfm[ms.slot[i]]) * f[i];
    f[i] = vh;
    x[i] += dt * vh;
  }
  /* a bond's force from its separation r, added to the separations seen */
  PL_HD R bond_of(R r, R &r_min, R &r_max, R &r_sum) const
  {
    r_min = r_min < r ? r_min : r;
    r_max = r_max > r ? r_max : r;
    r_sum += r;
    return law(r);
  }
  /* the force of the bond right of atom i (to atom i + 1) */
  PL_HD R bond(int i, R &r_min, R &r_max, R &r_sum) const
  {
    return bond_of(x[i + 1] - x[i], r_min, r_max, r_sum);
  }
  /* force and second half kick of atom i, F its left and right bonds' forces; v_old: where its
     velocity before the step goes (FRONT; a PER_ATOM hook samples the atom now instead) */
  PL_HD void kick(int i, const R *F, R *v_old, CoulombWorkT<R> &work, R &starting) const
  {
    const int t = FRICTION || !ONE_TYPE ? ms.slot[i] : 1;
    R vh = f[i], ftot;
    const R before = v[i];
    if constexpr (FRONT) {
      kick_atom<FRICTION, ONE_TYPE, KickTo::in_place, true>(F[0], F[1], t, h, ms, fr, dt, vh, ftot, work,
                                                             front.mark + i, front.gate[i], &starting, ms.dtm);
    } else {
      kick_atom<FRICTION, ONE_TYPE, KickTo::in_place, false, R>(F[0], F[1], t, h, ms, fr, dt, vh, ftot, work, nullptr,
                                                                 R(), nullptr, ms.dtm);
    }
    v[i] = vh;
    f[i] = ftot;
    if constexpr (FRONT) {
      if constexpr (Front::Hook::PER_ATOM) front.hook->sample_atom(i, before);
      else *v_old = before;
    }
  }
};
}    // namespace detail

/* The whole step of the runs' atoms (the chain ends are the caller's: it has placed the
   impactors at this step's position before). x, v, f: the slab's arrays along x; works: per
   chain, this step's friction work (each run adds to its chain's, in ID order); scratch:
   step_scratch(block) R; gaps: every bond left of a run's atom and right of its last. */
template <bool FRICTION, bool FRONT, class LawT, class Hook, class R, class Gates, class Runs>
PL_HD void step_runs(const LawT law, const Runs runs, int nruns, R *PL_RESTRICT x, R *PL_RESTRICT v,
                     R *PL_RESTRICT f, const MassesT<R> &ms, const Friction &fr, double dt, CoulombWorkT<R> *works,
                     R *scratch, int block, const FrontPass<Hook, R, Gates> &front, GapsT<R> &gaps)
{
  nruns = run_count(runs, nruns);
  auto pass = [&](auto one_type) {
    const detail::Stages<FRICTION, FRONT, decltype(one_type)::value, LawT, R, FrontPass<Hook, R, Gates>> S{
        law, x, v, f, ms, fr, dt, one_type ? ms.dtfm[1] : Lanes<R>::splat(0.0), front};
    // per run in flight: its bond forces (two runs), F[k] left of atom first + k; the kicked
    // run's velocities before the step (FRONT)
    R *PL_RESTRICT bonds[2] = {scratch, scratch + block + 1};
    R *PL_RESTRICT v_old = scratch + 2 * block + 2;
    R r_min = gaps.r_min, r_max = gaps.r_max, r_sum = gaps.r_sum;
    PL_UNROLL
    for (int b = -1; b <= nruns; b++) {
      // drift run d = b + 1, inner bonds of run b, kick run k = b - 1 (each if there is one)
      const int d = b + 1, k = b - 1;
      const int nd = d < nruns ? runs[d].last - runs[d].first + 1 : 0;
      const int nb = b >= 0 && b < nruns ? runs[b].last - runs[b].first : 0;
      const int nk = k >= 0 ? runs[k].last - runs[k].first + 1 : 0;
      const int id = nd ? runs[d].first : 0, ib = nb ? runs[b].first : 0, ik = nk ? runs[k].first : 0;
      R *PL_RESTRICT Fb = bonds[(b + 2) % 2];
      const R *PL_RESTRICT Fk = bonds[(k + 2) % 2];
      CoulombWorkT<R> work;
      if constexpr (FRICTION)
        if (nk) work = works[runs[k].chain];
      R starting = R();
      // one loop over what all three have (friction: the kick apart, in ID order: its work is a
      // sum), then the rest of each; with lanes each atom is a vector op already
      int both = nd < nb ? nd : nb;
      if (!FRICTION) both = both < nk ? both : nk;
      if constexpr (Lanes<R>::W == 1) {
        PL_SIMD_STEP
        PL_UNROLL
        for (int j = 0; j < both; j++) {
          S.drift(id + j);
          Fb[j + 1] = S.bond(ib + j, r_min, r_max, r_sum);
          if constexpr (!FRICTION) S.kick(ik + j, Fk + j, v_old + j, work, starting);
        }
      } else {
        PL_UNROLL
        for (int j = 0; j < both; j++) {
          S.drift(id + j);
          Fb[j + 1] = S.bond(ib + j, r_min, r_max, r_sum);
          if constexpr (!FRICTION) S.kick(ik + j, Fk + j, v_old + j, work, starting);
        }
      }
      PL_UNROLL
      for (int j = both; j < nd; j++) S.drift(id + j);
      {    // the separations seen in registers (GCC keeps lanes' references in memory)
        R mn = r_min, mx = r_max, sm = r_sum;
        PL_UNROLL
        for (int j = both; j < nb; j++) Fb[j + 1] = S.bond(ib + j, mn, mx, sm);
        r_min = mn, r_max = mx, r_sum = sm;
      }
      {    // the friction work and starts in registers, as the separations
        CoulombWorkT<R> w = work;
        R st = starting;
        PL_UNROLL
        for (int j = FRICTION ? 0 : both; j < nk; j++) S.kick(ik + j, Fk + j, v_old + j, w, st);
        work = w, starting = st;
      }
      if (b >= 0 && b < nruns) {    // run b's end bonds: both its neighbours have moved now
        const Run run = runs[b];
        const int len = run.last - run.first + 1;
        Fb[0] = S.bond_of(x[run.first] - x[run.left], r_min, r_max, r_sum);
        Fb[len] = S.bond_of(x[run.right] - x[run.last], r_min, r_max, r_sum);
      }
      if (nk) {
        if constexpr (FRICTION) works[runs[k].chain] = work;
        if constexpr (FRONT && !Hook::PER_ATOM) front.hook->sample_block(k, v_old, starting > 0.0);
      }
    }
    gaps.r_min = r_min, gaps.r_max = r_max, gaps.r_sum = r_sum;
  };
  if constexpr (Lanes<R>::W == 1) {    // lanes: a mass per lane, never one type
    if (ms.one_type) return pass(detail::Bool<true>());
  }
  pass(detail::Bool<false>());
}

}    // namespace pl_kernel

#endif
