/* The host engine: a batch of independent chains, integrated by the chain kernel (kernel/chain.h)
   with OpenMP over chains; no MPI, no LAMMPS. Loaded by pylmp_lattice/engines/library.py (ctypes);
   engines/cpu.py checks the arguments; each chain gives the bits of the same chain in fix lattice/chain.
   Part of pylmp_lattice, GPL-2.0.

   Each thread runs W chains at a time side by side, one per lane of the kernel's vector type
   (device.h Lanes: W doubles, every per-atom operation one W-wide instruction; short chains do
   not vectorise along the chain): W = 4 with AVX2, else 2 (SSE2), chosen at run time, so the
   library runs on any x86-64. It is built with -ffp-contract=off (no fused multiply-adds), so
   each lane gives the bits of the same chain in LAMMPS on any of them. */

#include "kernel/chain.h"
#include "kernel/fit.h"

#include <cstdint>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace pl_kernel;

namespace {
// The largest run of free atoms stepped as one block, as fix lattice/chain's BLOCK (n >= 3: the
// blocks do not change the bits); the GPU engine takes it from here (pl_engine_block).
constexpr int BLOCK = 256;

/* the batch, as pl_run_chains takes it */
struct Batch {
  ChainSetup S;
  int chains, n;
  double *x, *v;
  const double *mass, *levels;
  double *front_out, *work;
  long long *end_step;
  int *status;
};

/* one thread's storage for W lanes of chains of n atoms: per atom lanes and the record's rows as
   lanes (aligned for any W), and what ends up per lane */
struct LaneStore {
  static constexpr int ARRAYS = 9;    // x v f dtfm mass weight mark gate dtm
  int n, per_array;
  std::vector<double> lanes, rec_lanes, x_end, v_end;
  std::vector<int> index;
  LaneStore(const ChainSetup &S, int W)
      : n(S.n), per_array(S.n * W), lanes((ARRAYS * S.n + step_scratch(S.block)) * W + 8),
        rec_lanes(S.record ? static_cast<size_t>(S.n) * W * front::NCOL + 8 : 0), x_end(S.n * W), v_end(S.n * W),
        index(S.n)
  {
    for (int i = 0; i < n; i++) index[i] = i;
  }
  /* the k-th per-atom array (ARRAYS is the scratch), on a 64-byte boundary */
  double *array(int k) { return aligned(lanes.data()) + static_cast<size_t>(k) * per_array; }
  /* the record: n rows of NCOL lanes, on a 64-byte boundary */
  double *rec() { return aligned(rec_lanes.data()); }
  static double *aligned(double *base)
  {
    return base + (8 - reinterpret_cast<uintptr_t>(base) / sizeof(double) % 8) % 8;
  }
};

/* Chains c0 .. c0 + W - 1 of the batch (those < chains; the other lanes run a copy of chain c0,
   unread) in the lanes of R: their state in, run(S, data) (run_chain), their outcome out. */
template <class R, class Run> inline void run_lanes(const Batch &B, LaneStore &st, int c0, Run &&run)
{
  using L = Lanes<R>;
  constexpr int W = L::W;
  const ChainSetup &S = B.S;
  const int n = S.n;
  R *x = reinterpret_cast<R *>(st.array(0)), *v = reinterpret_cast<R *>(st.array(1));
  R *mass = reinterpret_cast<R *>(st.array(4)), *dtfm = reinterpret_cast<R *>(st.array(3));
  R *weight = reinterpret_cast<R *>(st.array(5)), *mark = reinterpret_cast<R *>(st.array(6));
  ChainDataT<R> d{};
  for (int l = 0; l < W; l++) {
    const int c = c0 + l < B.chains ? c0 + l : c0;
    d.alive[l] = c0 + l < B.chains;
    const size_t at = static_cast<size_t>(c) * n;
    for (int i = 0; i < n; i++) L::set(x[i], l, B.x[at + i]), L::set(v[i], l, B.v[at + i]);
    for (int i = 0; i < n; i++) L::set(mass[i], l, B.mass[at + i]);
    if (S.record) d.levels[l] = levels_row(B.levels + 5 * static_cast<size_t>(c));
  }
  R *dtm = S.friction ? reinterpret_cast<R *>(st.array(8)) : nullptr;    // the friction kick's dt / m
  chain_masses(mass, n, S.dt, S.fr.g, dtfm, weight, dtm);
  d.dtm = dtm;
  d.x = x, d.v = v, d.f = reinterpret_cast<R *>(st.array(2));
  d.dtfm = dtfm, d.mass = mass, d.weight = weight, d.index = st.index.data();
  d.scratch = reinterpret_cast<R *>(st.array(LaneStore::ARRAYS));
  d.x_end = st.x_end.data(), d.v_end = st.v_end.data();
  if (S.record) {
    R *rec = reinterpret_cast<R *>(st.rec());
    for (size_t k = 0; k < static_cast<size_t>(n) * front::NCOL; k++) rec[k] = L::splat(quiet_nan());
    for (int i = 0; i < n; i++) mark[i] = L::splat(quiet_nan());
    d.rec = rec, d.mark = mark, d.gate = reinterpret_cast<R *>(st.array(7));    // the gates keep the phases
  }
  run(S, d);
  for (int l = 0; l < W && c0 + l < B.chains; l++) {
    const int c = c0 + l;
    const size_t at = static_cast<size_t>(c) * n;
    B.work[c] = d.work[l];
    B.end_step[c] = d.end_step[l];
    B.status[c] = d.status[l];
    for (int i = 0; i < n; i++) B.x[at + i] = st.x_end[l * n + i], B.v[at + i] = st.v_end[l * n + i];
    if (S.record)
      for (int i = 0; i < n; i++)
        for (int k = 0; k < front::NOUT; k++)
          B.front_out[(at + i) * front::NOUT + k] = L::get(d.rec[static_cast<size_t>(i) * front::NCOL + k], l);
  }
}

// run_chain's chain for each instruction set, every kernel call inlined into it (flatten) so that
// the lanes' operations are its instructions (one function per law, friction and record: a
// function of them all spills the hot loops' registers). No AVX-512, nor 8 lanes with AVX2:
// GCC 12 computes their masks (a comparison not in a select: && of two, an output) lane by
// lane, 5x slower (21-magnet chains with friction, AMD EPYC).
#if defined(__x86_64__)
template <bool FRICTION, bool FRONT, class LawT>
__attribute__((target("avx2"), flatten)) void chain_avx2(const LawT law, const ChainSetup &S, ChainDataT<Lanes4> &c)
{
  detail::run_chain<FRICTION, FRONT>(law, S, c);
}
#endif
template <bool FRICTION, bool FRONT, class LawT>
__attribute__((flatten)) void chain_sse2(const LawT law, const ChainSetup &S, ChainDataT<Lanes2> &c)
{
  detail::run_chain<FRICTION, FRONT>(law, S, c);
}

#if defined(__x86_64__)
void run_lanes_avx2(const Batch &B, LaneStore &st, int c0)
{
  run_lanes<Lanes4>(B, st, c0, [&](const ChainSetup &S, ChainDataT<Lanes4> &d) {
    dispatch_chain(S, [&](auto law, auto friction, auto record) {
      chain_avx2<decltype(friction)::value, decltype(record)::value>(law, S, d);
    });
  });
}
#endif
void run_lanes_sse2(const Batch &B, LaneStore &st, int c0)
{
  run_lanes<Lanes2>(B, st, c0, [&](const ChainSetup &S, ChainDataT<Lanes2> &d) {
    dispatch_chain(S, [&](auto law, auto friction, auto record) {
      chain_sse2<decltype(friction)::value, decltype(record)::value>(law, S, d);
    });
  });
}
/* the chains a thread runs side by side on this machine, and its run of them: 4 in an AVX2 vector,
   else 2 (SSE2, or the machine's own vectors elsewhere); built with PL_LANES_SSE2, 2 on any
   machine (tests/test_kernel_lanes.py checks the SSE2 lanes on an AVX2 machine) */
int lanes(void (**run)(const Batch &, LaneStore &, int) = nullptr)
{
#if defined(__x86_64__) && !defined(PL_LANES_SSE2)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2")) {
    if (run) *run = run_lanes_avx2;
    return 4;
  }
#endif
  if (run) *run = run_lanes_sse2;
  return 2;
}
}    // namespace

extern "C" {

/* The version of this ABI: engines/library.py refuses a library of another. */
int pl_engine_abi() { return 6; }

/* The engines' layout, read by engines/library.py so that Python never restates it: the block,
   the chains a thread runs side by side (a call gives each thread a multiple of them, or its
   other lanes run copies), a front record row's output columns (front::NOUT, those of fix
   lattice/front) and all of its columns (front::NCOL), and each ChainStatus's name (NULL past
   the last). */
int pl_engine_block() { return BLOCK; }
int pl_engine_lanes() { return lanes(); }
int pl_engine_nout() { return front::NOUT; }
int pl_engine_ncol() { return front::NCOL; }
const char *pl_engine_status(int status)
{
  switch (status) {
    case FINISHED: return "done";
    case CONTACT: return "contact";
    case OUT_OF_RANGE: return "out_of_range";
    case DRIVE_ENDED: return "drive_ended";
    default: return nullptr;
  }
}

/* Run `chains` chains of n atoms for `steps` steps of dt (SI units throughout).
   law_kind 0 power (law_params K b q), 1 linear (k r_free), 2 table (table_n rows r, U, F and
   the end slopes of F, fp_lo fp_hi); drive_profile 0 constant, 1 ramp, 2 sine, 3 rest,
   4 measured (measured_n samples t from 0, y = u or v); friction mu p g if `friction`;
   range: allowed separations. Per chain (row-major, chains x n): x, v in and out, mass; with
   `record` levels (chains x 5: start front drop pulse_drop pulse_floor) and front_out (chains x
   n x 7: the fix lattice/front columns); work (chains): friction work; end_step and status
   (kernel/chain.h ChainStatus, named by pl_engine_status) per chain. threads <= 0: OpenMP's default. Returns 0. */
int pl_run_chains(int chains, int n, long long steps, double dt, int law_kind, const double *law_params,
                  int table_n, const double *table_r, const double *table_u, const double *table_f, double fp_lo,
                  double fp_hi, int drive_profile, double V, double T, int measured_n, const double *measured_t,
                  const double *measured_y, int given_velocity, int hold_after, int friction, double mu, double p,
                  double g, double range_lo, double range_hi, double *x, double *v, const double *mass, int record,
                  const double *levels, double *front_out, double *work, long long *end_step, int *status,
                  int threads)
{
  std::vector<double> table_storage(law_kind == 2 ? 4 * table_n : 0), measured_storage;
  const Law table = law_kind == 2 ? fit_table(table_r, table_u, table_f, table_n, fp_lo, fp_hi, table_storage.data())
                                  : Law();
  Measured measured;
  if (drive_profile == Drive::MEASURED) {
    measured_storage.assign(2 * measured_n, 0.0);
    measured = fit_measured(measured_t, measured_y, measured_n, given_velocity != 0, hold_after != 0,
                            measured_storage.data());
  }
  const ChainSetup S = chain_setup(n, steps, dt, n - 2 < BLOCK ? n - 2 : BLOCK, law_kind, law_params, table,
                                   drive_profile, V, T, measured, friction != 0, mu, p, g, range_lo, range_hi,
                                   record != 0);
  const Batch B{S, chains, n, x, v, mass, levels, front_out, work, end_step, status};
  void (*run)(const Batch &, LaneStore &, int);
  const int W = lanes(&run);
#ifdef _OPENMP
  if (threads > 0) omp_set_num_threads(threads);
#else
  (void) threads;
#endif
#pragma omp parallel
  {
    LaneStore st(S, W);
#pragma omp for schedule(dynamic, 1)    // one lane batch a grab: with 2, a call of one batch a thread ran on one
    for (int c0 = 0; c0 < chains; c0 += W) run(B, st, c0);
  }
  return 0;
}

/* The splines of the GPU engine (engines/gpu.py), fitted here as the plugin fits them: a table law
   (out: 4 n doubles, F's spline then U's, as kernel::Spline's yd2; x0_dx: its first r and spacing)
   and a measured drive (out: 2 n doubles, d2y then the integral). */
void pl_fit_table(const double *r, const double *u, const double *f, int n, double fp_lo, double fp_hi, double *out,
                  double *x0_dx)
{
  const Law law = fit_table(r, u, f, n, fp_lo, fp_hi, out);
  x0_dx[0] = law.tf.x0;
  x0_dx[1] = law.tf.dx;
}

void pl_fit_measured(const double *t, const double *y, int n, double *out)
{
  fit_measured(t, y, n, false, false, out);
}

/* The GPU engine's drive path (Drive::path): u, ud of steps 0 .. steps - 1 of dt (out: 2 steps
   doubles, pairs) for drive_profile 0-3 with V, T, as the host's chains see them. Returns 0, or -1
   for a measured drive (its path needs the fit, and has no sin or cos to replace). */
int pl_drive_path(int drive_profile, double V, double T, double dt, long long steps, double *out)
{
  if (drive_profile < Drive::CONSTANT || drive_profile >= Drive::MEASURED) return -1;
  Drive drive;
  drive.profile = static_cast<Drive::Profile>(drive_profile);
  drive.V = V, drive.T = T;
  for (long long k = 0; k < steps; k++) drive.at_step(k, dt, out[2 * k], out[2 * k + 1]);
  return 0;
}

}    // extern "C"
