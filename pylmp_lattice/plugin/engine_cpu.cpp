/* The host engine: a batch of independent chains, integrated by the chain kernel (kernel/chain.h)
   with OpenMP over chains; no MPI, no LAMMPS. Loaded by pylmp_lattice/engines/library.py (ctypes);
   engines/cpu.py checks the arguments; each chain gives the bits of the same chain in fix lattice/chain.
   Part of pylmp_lattice, GPL-2.0. */

#include "kernel/chain.h"
#include "kernel/fit.h"

#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace pl_kernel;

namespace {
// The largest run of free atoms stepped as one block, as fix lattice/chain's BLOCK (n >= 3: the
// blocks do not change the bits); the GPU engine takes it from here (pl_engine_block).
constexpr int BLOCK = 256;
}

extern "C" {

/* The version of this ABI: engines/library.py refuses a library of another. */
int pl_engine_abi() { return 2; }

/* The engines' layout, read by engines/library.py so that Python never restates it: the block,
   a front record row's output columns (front::NOUT, those of fix lattice/front) and all of its
   columns (front::NCOL), and each ChainStatus's name (NULL past the last). */
int pl_engine_block() { return BLOCK; }
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
  const int nruns = n > 2 ? (n - 2 + S.block - 1) / S.block : 0;
#ifdef _OPENMP
  if (threads > 0) omp_set_num_threads(threads);
#else
  (void) threads;
#endif
#pragma omp parallel
  {
    std::vector<double> f(n), dtfm(n), weight(n), rec, mark, gate, scratch(5 * S.block + 1);
    std::vector<unsigned char> phase;
    std::vector<int> index(n);
    std::vector<Run> runs(nruns > 0 ? nruns : 1);
    for (int i = 0; i < n; i++) index[i] = i;
    if (S.record) rec.resize(static_cast<size_t>(n) * front::NCOL), mark.resize(n), gate.resize(n), phase.resize(n);
#pragma omp for schedule(dynamic, 16)
    for (int c = 0; c < chains; c++) {
      const size_t at = static_cast<size_t>(c) * n;
      const double *m = mass + at;
      chain_masses(m, n, dt, g, dtfm.data(), weight.data());
      ChainData d{};
      d.x = x + at;
      d.v = v + at;
      d.f = f.data();
      d.dtfm = dtfm.data();
      d.mass = m;
      d.weight = weight.data();
      d.index = index.data();
      d.runs = runs.data();
      d.scratch = scratch.data();
      if (S.record) {
        d.levels = levels_row(levels + 5 * static_cast<size_t>(c));
        for (double &r : rec) r = quiet_nan();
        for (int i = 0; i < n; i++) mark[i] = quiet_nan(), phase[i] = front::WAITING;
        d.rec = rec.data();
        d.mark = mark.data();
        d.gate = gate.data();
        d.phase = phase.data();
      }
      run_chain(S, d);
      work[c] = d.work_done;
      end_step[c] = d.end_step;
      status[c] = d.status;
      if (S.record)
        for (int i = 0; i < n; i++)
          for (int k = 0; k < front::NOUT; k++)
            front_out[(at + i) * front::NOUT + k] = rec[static_cast<size_t>(i) * front::NCOL + k];
    }
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

}    // extern "C"
