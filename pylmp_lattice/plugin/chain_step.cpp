/* fix lattice/chain: the two step paths (see the header of fix_lattice_chain.cpp).
   Part of pylmp_lattice, GPL-2.0.

   In LAMMPS's arrays: the force pass (run_forces), after the drift of initial_integrate.
   Owning the state: the whole step in one pass over the fix's arrays (own_step), after the
   slab edges are exchanged on several ranks. Both do the same operations in the same order,
   so they give the same bits. */

#include "fix_lattice_chain.h"

#include "atom.h"
#include "comm.h"
#include "fix_lattice_front.h"
#include "output.h"
#include "update.h"

#include <ctime>

using namespace LAMMPS_NS;

/* all forces of the step in the atom arrays; `kick` is the length of the velocity kick they
   will make (for the friction), kick_v applies its second half here */

void FixLatticeChain::forces(double kick, bool setup_kick, bool kick_v)
{
  int bad = 0;
  law.dispatch([&](auto F) {
    if (friction) {
      if (kick_v) run_forces<true, true>(F, kick, setup_kick, bad);
      else run_forces<true, false>(F, kick, setup_kick, bad);
    } else {
      if (kick_v) run_forces<false, true>(F, kick, setup_kick, bad);
      else run_forces<false, false>(F, kick, setup_kick, bad);
    }
  });
  end_forces();
  check_gaps(bad);
}

/* the impactors' push and the held ends' zero force */

void FixLatticeChain::end_forces()
{
  const Column x = column(atom->x, xs), f = column(atom->f, fs);
  for (const End &e : impactors) f[e.i] = -law.force(x[e.other] - x[e.i]);
  for (const End &e : held) f[e.i] = 0.0;
}

/* each chain's friction work of this step's kicks, settled (see coulomb.h) */

void FixLatticeChain::settle_work(double kick, bool setup_kick)
{
  for (bigint c = 0; c < nchains; c++) {
    works[c].settle(kick, setup_kick, work_done[c], work_pending[c]);
    works[c] = pl_kernel::CoulombWork();
  }
}

/* the kernel's view of the mass slots (see the header) */

pl_kernel::Masses FixLatticeChain::masses() const
{
  return pl_kernel::Masses{slots(), dtfm.data(), mass_of.data(), weight.data(), one_type};
}

/* the force pass in the atom arrays (KICK: with the second half kick) */

template <bool FRICTION, bool KICK, class Law>
void FixLatticeChain::run_forces(const Law law, double kick, bool setup_kick, int &bad)
{
  using pl_kernel::detail::kick_run;
  constexpr auto TO = KICK ? pl_kernel::detail::KickTo::in_place : pl_kernel::detail::KickTo::none;
  // restrict: stores to v, f and the bond forces cannot change the law's coefficients
  const double *__restrict x = atom->x[0];
  double *__restrict v = atom->v[0];
  double *__restrict f = atom->f[0];
  double *__restrict F = bond_force.data();
  const pl_kernel::Masses ms = masses();
  // the block's positions, contiguous: X[0] left neighbour, X[1..len] the block, X[len+1]
  // right neighbour
  double *__restrict X = scratch.data();
  pl_kernel::Gaps gaps;
  for (const Run &run : runs) {
    const int first = run.first, len = run.last - first + 1;
    pl_kernel::CoulombWork work;
    if constexpr (FRICTION) work = works[run.chain];
    for (int k = 0; k < len; k++) X[1 + k] = x[3 * (first + k)];
    X[0] = x[3 * run.left];
    X[len + 1] = x[3 * run.right];
    pl_kernel::bond_forces(law, X, len + 1, F, gaps);
    // LAMMPS's arrays: an atom's x component every 3 doubles
    double *fo = f + 3 * first, *vr = v + 3 * first;
    if (one_type) kick_run<FRICTION, true, TO, 3>(F, first, len, ms, fr, kick, vr, fo, work);
    else kick_run<FRICTION, false, TO, 3>(F, first, len, ms, fr, kick, vr, fo, work);
    if constexpr (FRICTION) works[run.chain] = work;
  }
  if (FRICTION) settle_work(kick, setup_kick);
  if (gaps.bad(range_lo, range_hi)) bad = 1;
}

/* Owning the state, the whole step in one pass over the fix's arrays: the chain kernel's step
   for this rank's slab (kernel/step.h), the same operations as initial_integrate, run_forces<KICK>
   and the front record's sample. */

template <bool FRICTION, bool FRONT, class Law>
void FixLatticeChain::own_step(const Law law, int &bad)
{
  FrontHook hook{this};
  const pl_kernel::FrontPass<FrontHook> pass{FRONT ? front->mark : nullptr, start_gate.data(), &hook};
  pl_kernel::Gaps gaps;
  pl_kernel::step_runs<FRICTION, FRONT>(law, runs.data(), static_cast<int>(runs.size()), xs, vs, fs, masses(), fr,
                                        update->dt, works.data(), scratch.data(), BLOCK, pass, gaps);
  if (FRICTION) settle_work(update->dt, false);
  if (gaps.bad(range_lo, range_hi)) bad = 1;
}

/* The owned step for every law, friction and record, compiled twice where the compiler can
   (x86-64 with GCC's or Clang's target_clones): for AVX2 and for the baseline, chosen once at
   load time by the CPU. flatten inlines the whole pass (the kernel's step_runs and its loop) into
   each copy, so the hot loop is compiled for that copy's instructions. No FMA (AVX2 alone has
   none, and -ffp-contract=off): each copy does the same IEEE operations in the same order, so
   both give the same bits (the separations' sum, a NaN probe only, is added in another order).
   AVX2: 1.2-1.4x the pass's speed at 10^4 magnets (benchmarks/bench_engine.py). */

#ifndef PASS_COPIES    // a build may set it (-DPASS_COPIES=...: tests of one copy alone)
#if defined(__x86_64__) && defined(__has_attribute)
#if __has_attribute(target_clones) && __has_attribute(flatten)
#define PASS_COPIES __attribute__((target_clones("avx2", "default"), flatten))
#endif
#endif
#endif
#ifndef PASS_COPIES
#define PASS_COPIES
#endif

PASS_COPIES void FixLatticeChain::own_steps(bool record, int &bad)
{
  law.dispatch([&](auto F) {
    if (friction) {
      if (record) own_step<true, true>(F, bad);
      else own_step<true, false>(F, bad);
    } else {
      if (record) own_step<false, true>(F, bad);
      else own_step<false, false>(F, bad);
    }
  });
}

/* owning the state: the step's one pass, with the front record sampled inside it */

/* CPU time of this thread (several ranks only: a system call) */
static double thread_cpu()
{
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

void FixLatticeChain::own_pass()
{
  const bool ranks = comm->nprocs > 1;
  const double w0 = ranks ? MPI_Wtime() : 0.0;
  if (ranks) send_edges();
  const double w1 = ranks ? MPI_Wtime() : 0.0, c1 = ranks ? thread_cpu() : 0.0;
  FrontRecord::Sample sample;
  const bool record = front && front->begin_sample(sample);
  if (record && !front_summarised) summarise_front();
  int bad = 0;
  own_steps(record, bad);
  end_forces();
  if (record) {
    sample_front_ends();
    front->end_sample();
  }
  const double c2 = ranks ? thread_cpu() : 0.0, w2 = ranks ? MPI_Wtime() : 0.0;
  check_gaps(bad);
  if (ranks) {
    pass_cpu += c2 - c1;
    const double exchange = (w1 - w0) + (MPI_Wtime() - w2);
    exchange_wall += exchange;
    exchange_min = exchange < exchange_min ? exchange : exchange_min;
    owned_steps++;
  }
  if (update->ntimestep == output->next) scatter();
}
