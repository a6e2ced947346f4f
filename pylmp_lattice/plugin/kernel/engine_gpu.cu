/* The GPU engine's kernels: one thread per short chain, one block per long one, each running
   the chain kernel's run_chain (chain.h). Compiled at run time by NVRTC through CuPy (pylmp_lattice/engines/gpu.py, with -I
   this folder and the batch's -D options, below). Part of pylmp_lattice, GPL-2.0.

   Short chains (n = PL_LOCAL_N, up to 64, the ensembles' case): pl_run_short_chains_gpu is
   compiled for the batch's n and runs of at most PL_BLOCK free atoms (FixedRuns, step.h), so
   the loops over the atoms unroll; where the loop over the runs does too (one run: PL_BLOCK =
   n - 2), a chain's arrays (x, v, f, masses, scratch) are indexed by constants and ptxas keeps
   them in registers as far as they fit (one of each mass term for a batch of one mass,
   PL_ONE_MASS); the marks (and, with PL_SHARED_ARRAYS > 1, x, v, f) in the thread's row of
   shared memory; the start gates as bits (chain.h's BitGates); the rest, and the front record's
   rows (touched only for the few atoms between their start and both peaks, which PL_SAMPLING 1
   lists during the step and samples after it, 2 marks in a bit mask, 0 samples at each atom's
   kick: chain.h's Sampling), in per-thread local memory. At ece083f (arrays
   of 32 or 64, loops over a run-time n) all of it was local memory: 12.6 kB a thread for 21
   magnets with friction and record, 638 MB for the threads an H100/H200 holds at once, 13x its
   L2 (benchmarks/gpu_resources.py prints both; bench_gpu.py --variants times the choices).
   CUDA interleaves local memory by thread (word k of the 32 threads of a warp is one 128-byte
   line), so when the warp's threads step their chains in lockstep every access is coalesced;
   only the inputs (x, v, masses, levels) are read from global memory once, and only the
   record's NOUT output columns (not its NCOL columns of running state) and the final x, v are
   written back: the per-chain record leaves the chip compact, 7 doubles per magnet.
   Long chains (over 64 magnets): pl_run_long_chains_gpu, a block per chain, each thread on a
   segment of PL_BLOCK free atoms or fewer, as a slab of fix lattice/chain on an MPI rank (below).
   Its one thread a chain on chain-major rows of global arrays that it replaced ran 10^3 chains
   of 1000 magnets on an H200 at 0.2x the C loop on 16 cores (1000 threads, a thirtieth of the
   device, none coalesced); the block per chain ran them at 7.6-7.8x (2026-11-28).

   A module is compiled for one batch (engines/gpu.py's compile_options): PL_LOCAL_N > 0 builds
   the short chains' kernel for chains that long (PL_BLOCK its runs, PL_THREADS its block's
   threads, PL_ONE_MASS, PL_SHARED_ARRAYS and PL_SAMPLING as above, PL_ROW_COPY chain.h's
   sample_cold copying each due row whole), 0 the long chains'
   kernel (PL_BLOCK its segments, PL_THREADS the most threads a block); PL_LAW_KIND (Law::Kind), PL_LAW_Q (a power law's q), PL_FRICTION and PL_RECORD pick the
   one case of chain.h's dispatch the batch runs. With every case in it (11 laws x friction x record, twice)
   NVRTC took 3 minutes to machine code for sm_90 per module; with one, seconds. */

#include "chain.h"

#if !defined(PL_LOCAL_N) || !defined(PL_BLOCK) || !defined(PL_LAW_KIND) || !defined(PL_LAW_Q) || !defined(PL_FRICTION) \
    || !defined(PL_RECORD) || !defined(PL_ONE_MASS) || !defined(PL_THREADS) || !defined(PL_SHARED_ARRAYS) \
    || !defined(PL_SAMPLING)
#error "engine_gpu.cu is compiled for one batch: -DPL_LOCAL_N, -DPL_BLOCK, -DPL_LAW_KIND, -DPL_LAW_Q, -DPL_FRICTION, -DPL_RECORD, -DPL_ONE_MASS, -DPL_THREADS, -DPL_SHARED_ARRAYS, -DPL_SAMPLING"
#endif

using namespace pl_kernel;

namespace {
/* The batch's setup: chain.h's chain_setup, from the host's fits. Each kernel sets S.block, the
   length of its runs, itself; `block` stays a parameter so that an older revision's kernel
   (bench_gpu.py --reference-kernel, ece083f's, which read it) takes the same arguments. */
__device__ ChainSetup make_setup(int n, long long steps, double dt, int block, int law_kind, const double *law_values,
                                 int table_n, double table_x0, double table_dx, const double *table_yd2,
                                 int drive_profile, double V, double T, int measured_n, const double *measured_t,
                                 const double *measured_y, const double *measured_fit, int given_velocity,
                                 int hold_after, int friction, double mu, double p, double g, double range_lo,
                                 double range_hi, int record, const double *drive_path, long long drive_path_steps)
{
  // the host's fits (engine_cpu.cpp: pl_fit_table, pl_fit_measured)
  const Law table = Law::table(table_x0, table_dx, table_n, table_yd2);
  const Measured measured{measured_n, measured_t, measured_y, measured_fit, measured_fit + measured_n,
                          given_velocity != 0, hold_after != 0};
  ChainSetup S = chain_setup(n, steps, dt, block, law_kind, law_values, table, drive_profile, V, T, measured,
                             friction != 0, mu, p, g, range_lo, range_hi, record != 0);
  S.drive.path = drive_path, S.drive.path_steps = drive_path_steps;    // the host's (pl_drive_path)
  return S;
}

/* the law types of Law::dispatch this module runs: the batch's alone */
template <class T> struct Compiled {
  static constexpr bool value = false;
};
template <int Q> struct Compiled<laws::PowerInt<Q>> {
  static constexpr bool value = PL_LAW_KIND == Law::POWER && Law::qint_of(PL_LAW_Q) == Q;
};
template <> struct Compiled<laws::Power> {
  static constexpr bool value = PL_LAW_KIND == Law::POWER && Law::qint_of(PL_LAW_Q) == 0;
};
template <> struct Compiled<laws::Linear> {
  static constexpr bool value = PL_LAW_KIND == Law::LINEAR;
};
template <> struct Compiled<laws::Table> {
  static constexpr bool value = PL_LAW_KIND == Law::TABLE;
};

/* chain.h's run_chain for the compiled case alone; a chain of another case is not run and keeps
   end step -1, which the host refuses (a module built for another batch never passes unseen) */
template <class Runs, detail::Sampling SAMPLING, class Team = detail::Solo>
__device__ void run_compiled(const ChainSetup &S, ChainData &d, const Team team = Team())
{
  d.end_step[0] = -1;
  dispatch_chain(S, [&](auto law, auto friction, auto record) {
    if constexpr (Compiled<decltype(law)>::value && decltype(friction)::value == (PL_FRICTION != 0) &&
                  decltype(record)::value == (PL_RECORD != 0))
      detail::run_chain<decltype(friction)::value, decltype(record)::value, Runs, SAMPLING>(law, S, d, team);
  });
}
}    // namespace

#define PL_SETUP_PARAMS                                                                                             \
  int chains, int n, long long steps, double dt, int block, int law_kind, const double *law_values, int table_n,   \
      double table_x0, double table_dx, const double *table_yd2, int drive_profile, double V, double T,            \
      int measured_n, const double *measured_t, const double *measured_y, const double *measured_fit,             \
      int given_velocity, int hold_after, int friction, double mu, double p, double g, double range_lo,           \
      double range_hi, int record, const double *drive_path, long long drive_path_steps
#define PL_SETUP_ARGS                                                                                               \
  n, steps, dt, block, law_kind, law_values, table_n, table_x0, table_dx, table_yd2, drive_profile, V, T,           \
      measured_n, measured_t, measured_y, measured_fit, given_velocity, hold_after, friction, mu, p, g, range_lo,  \
      range_hi, record, drive_path, drive_path_steps

#if PL_LOCAL_N > 0
/* each atom's mass slot as constants: 0, 1, ..., N - 1 (each atom its own), or 1 for all where
   every magnet of the batch has one mass (PL_ONE_MASS); once the loops unroll, the mass terms are
   read at constant indices, which lets them live in registers: N of each, or one */
template <int N> struct Slots {
  int slot[N];
};
template <int N> constexpr Slots<N> mass_slots(bool one_mass)
{
  Slots<N> out{};
  for (int i = 0; i < N; i++) out.slot[i] = one_mass ? 1 : i;
  return out;
}

/* n = PL_LOCAL_N (a chain of another n ends at once with end step -1, which the host refuses),
   in runs of at most PL_BLOCK (bit for bit the same for any: the host's runs are longer). x, v
   (chains x n, chain-major) in and out; front_out (chains x n x NOUT) with a record; mass
   (chains x n), all one value with PL_ONE_MASS (engines/gpu.py checks). */
extern "C" __global__ void pl_run_short_chains_gpu(PL_SETUP_PARAMS, double *x, double *v, const double *mass,
                                                   const double *levels, double *front_out, double *work,
                                                   long long *end_step, int *status)
{
  const int c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= chains) return;
  constexpr int N = PL_LOCAL_N, M = PL_ONE_MASS ? 2 : N;    // mass slots (one mass: slot 1)
  if (n != N) {    // a module built for another length (engines/gpu.py refuses the batch)
    end_step[c] = -1;
    return;
  }
  ChainSetup S = make_setup(PL_SETUP_ARGS);
  S.n = N, S.block = PL_BLOCK;    // as constants: the loops over the atoms unroll
  double ml[M], dtfm[M], weight[M], dtm[M], rec[PL_RECORD ? N * front::NCOL : 1];
  /* Each thread's row of shared memory (PL_THREADS: the block's threads, engines/gpu.py's
     block_threads), ROW doubles (odd: a half-warp's 16 threads hit 16 distinct pairs of banks):
     the first PL_SHARED_ARRAYS of the chain's marks (each atom's largest |v|, read and written at
     every step), x, v and f, the rest in registers. In registers, the marks pushed the chain's x,
     v, f out into local memory (ptxas, 21 magnets with friction); with x, v, f in shared memory
     too, what does not fit in registers waits on the SM, not in local memory. */
  constexpr int ROW = (PL_SHARED_ARRAYS * N) | 1;
  __shared__ double rows[PL_THREADS * ROW];
  if (threadIdx.x >= PL_THREADS) {    // launched with more threads than compiled for (never: refused)
    end_step[c] = -1;
    return;
  }
  double *row = rows + threadIdx.x * ROW;
  constexpr bool X_ROW = PL_SHARED_ARRAYS > 1, V_ROW = PL_SHARED_ARRAYS > 2, F_ROW = PL_SHARED_ARRAYS > 3;
  double x_regs[X_ROW ? 1 : N], v_regs[V_ROW ? 1 : N], f_regs[F_ROW ? 1 : N];
  double *mark = row, *xl = X_ROW ? row + N : x_regs, *vl = V_ROW ? row + 2 * N : v_regs,
         *fl = F_ROW ? row + 3 * N : f_regs;
  double scratch[step_scratch(PL_BLOCK)];
  unsigned char phase[N];
  constexpr Slots<N> slots = mass_slots<N>(PL_ONE_MASS);
  const long long at = static_cast<long long>(c) * N;
  PL_UNROLL
  for (int i = 0; i < N; i++) {
    xl[i] = x[at + i], vl[i] = v[at + i];
    mark[i] = quiet_nan(), phase[i] = front::WAITING;
  }
  PL_UNROLL
  for (int i = 0; i < M; i++) ml[i] = mass[at + (PL_ONE_MASS ? 0 : i)];
  if (PL_RECORD)
    for (int k = 0; k < N * front::NCOL; k++) rec[k] = quiet_nan();
  chain_masses(ml, M, dt, g, dtfm, weight, PL_FRICTION ? dtm : nullptr);
  ChainData d{};
  d.x = xl, d.v = vl, d.f = fl, d.dtfm = dtfm, d.mass = ml, d.weight = weight, d.index = slots.slot;
  if (PL_FRICTION) d.dtm = dtm;
  d.scratch = scratch, d.alive[0] = true;
  if (PL_RECORD) {
    d.levels[0] = levels_row(levels + 5 * static_cast<long long>(c));
    d.rec = rec, d.mark = mark, d.phase = phase;    // the start gates as bits (chain.h's BitGates)
  }
  constexpr detail::Sampling SAMPLING = PL_SAMPLING == 2   ? detail::Sampling::masked
                                       : PL_SAMPLING == 1 ? detail::Sampling::listed
                                                          : detail::Sampling::per_atom;
  run_compiled<FixedRuns<N, PL_BLOCK>, SAMPLING>(S, d);
  PL_UNROLL
  for (int i = 0; i < N; i++) x[at + i] = xl[i], v[at + i] = vl[i];
  if (PL_RECORD)
    for (int i = 0; i < N; i++)
      for (int k = 0; k < front::NOUT; k++) front_out[(at + i) * front::NOUT + k] = rec[i * front::NCOL + k];
  work[c] = d.work[0];
  end_step[c] = d.end_step[0];
  status[c] = d.status[0];
}

#else
/* The long chains' team (run_chain's Team, as chain.h's detail::Solo is one thread's): PL_THREADS
   threads a chain, thread t its segment of at most PL_BLOCK free atoms, a chain of its own whose
   end atoms are the chain's ends or ghosts.
   After each step a thread publishes where the next step's drift moves its edge atoms (the
   arithmetic of step.h's drift, as fix lattice/chain's send_edges), in the half of `edges` for
   that step's parity, and reads its ghosts from it before the step: the barrier between is the
   end test's __syncthreads_or, one a step (two halves: a thread writes the next step's half while
   its neighbours may still read this one's). */
struct BlockTeam {
  int t, threads;
  double *edges;    // shared: [parity][thread][left, right edge atom]
  PL_HD bool owns_first() const { return t == 0; }
  PL_HD bool owns_last() const { return t == threads - 1; }
  template <class M> __device__ M either(M m) const { return __syncthreads_or(m); }
  __device__ void ghosts(double *x, int n, long long step) const
  {
    const double *e = edges + 2 * threads * (step & 1);
    if (!owns_first()) x[0] = e[2 * (t - 1) + 1];
    if (!owns_last()) x[n - 1] = e[2 * (t + 1)];
  }
  __device__ void publish(const double *x, const double *v, const double *f, const Masses &ms, double dt, int n,
                          long long next) const
  {
    double *e = edges + 2 * (threads * (next & 1) + t);
    e[0] = x[1] + dt * (v[1] + ms.dtfm[ms.slot[1]] * f[1]);
    e[1] = x[n - 2] + dt * (v[n - 2] + ms.dtfm[ms.slot[n - 2]] * f[n - 2]);
  }
};

/* One block per chain (blockIdx.x), PL_THREADS threads (a longer block is refused: end step -1),
   thread t on free atoms lo .. hi - 1 (segments of PL_BLOCK or fewer; engines/gpu.py sizes both
   for n): its segment's x, v, f, mass terms, marks and start gates in its local memory (CUDA
   interleaves it by thread: coalesced), its record rows and phases in the chain's rows of rec
   (chains x n x NCOL, NaN on entry) and phase (WAITING on entry); index: 0, 1, ..., n - 1. The
   friction work is each thread's, added in thread order (not the host's atom order: its last
   bits may differ). */
extern "C" __global__ void pl_run_long_chains_gpu(PL_SETUP_PARAMS, double *x, double *v, const double *mass,
                                                  const int *index, const double *levels, double *rec,
                                                  unsigned char *phase, double *work, long long *end_step,
                                                  int *status)
{
  constexpr int SEG = PL_BLOCK, M = PL_BLOCK + 2;    // a segment's free atoms, its atoms with the ghosts
  __shared__ double edges[2 * 2 * PL_THREADS], works[PL_THREADS];
  const int c = blockIdx.x, t = threadIdx.x, threads = blockDim.x;
  if (c >= chains) return;
  const int lo = 1 + static_cast<int>(static_cast<long long>(t) * (n - 2) / threads),
            hi = 1 + static_cast<int>(static_cast<long long>(t + 1) * (n - 2) / threads);
  if (threads > PL_THREADS || threads > n - 2 || (n - 2 + threads - 1) / threads > SEG) {    // never: refused
    if (t == 0) end_step[c] = -1;
    return;
  }
  ChainSetup S = make_setup(PL_SETUP_ARGS);
  const int m = hi - lo + 2;    // atoms lo - 1 .. hi, the ends ghosts but in the first and last thread
  S.n = m, S.block = SEG;
  const long long at = static_cast<long long>(c) * n + lo - 1;
  double xs[M], vs[M], fs[M], dtfm[M], weight[M], dtm[M], mark[M], gate[M], scratch[step_scratch(SEG)];
  for (int i = 0; i < m; i++) xs[i] = x[at + i], vs[i] = v[at + i], fs[i] = 0.0, mark[i] = quiet_nan(), gate[i] = 0.0;
  chain_masses(mass + at, m, dt, g, dtfm, weight, PL_FRICTION ? dtm : nullptr);
  ChainData d{};
  d.x = xs, d.v = vs, d.f = fs, d.dtfm = dtfm, d.mass = mass + at, d.weight = weight, d.index = index;
  if (PL_FRICTION) d.dtm = dtm;
  d.scratch = scratch, d.alive[0] = true;
  if (PL_RECORD) {
    d.levels[0] = levels_row(levels + 5 * static_cast<long long>(c));
    d.rec = rec + at * front::NCOL, d.mark = mark, d.gate = gate, d.phase = phase + at;
  }
  const BlockTeam team{t, threads, edges};
  run_compiled<ChainRuns, detail::Sampling::per_run>(S, d, team);
  for (int i = team.owns_first() ? 0 : 1; i < (team.owns_last() ? m : m - 1); i++) x[at + i] = xs[i], v[at + i] = vs[i];
  works[t] = d.work[0];
  __syncthreads();
  if (t == 0) {
    double sum = 0.0;
    for (int k = 0; k < threads; k++) sum += works[k];
    work[c] = sum;
    end_step[c] = d.end_step[0];
    status[c] = d.status[0];
  }
}
#endif
