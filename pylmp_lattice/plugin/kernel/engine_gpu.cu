/* The GPU engine's kernel: one thread per chain, each running the chain kernel's run_chain
   (chain.h) on its own slices of the batch's arrays (chain-major). Compiled at run time by NVRTC
   through CuPy (pylmp_lattice/engines/gpu.py, with -I this folder). Part of pylmp_lattice, GPL-2.0. */

#include "chain.h"

using namespace pl_kernel;

extern "C" __global__ void pl_run_chains_gpu(
    int chains, int n, long long steps, double dt, int block, int law_kind, const double *law_values, int table_n,
    double table_x0, double table_dx, const double *table_yd2, int drive_profile, double V, double T, int measured_n,
    const double *measured_t, const double *measured_y, const double *measured_fit, int given_velocity, int hold_after,
    int friction, double mu, double p, double g, double range_lo, double range_hi, double *x, double *v,
    const double *mass, double *f, double *dtfm, double *weight, const int *index, int record, const double *levels,
    double *rec, double *mark, double *gate, unsigned char *phase, int *runs, double *scratch, double *work,
    long long *end_step, int *status)
{
  const int c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= chains) return;
  ChainSetup S = chain_setup(n, steps, dt, range_lo, range_hi, friction != 0, mu, p, g, record != 0, block);
  if (law_kind == 0) S.law = Law::power(law_values[0], law_values[1], law_values[2]);
  else if (law_kind == 1) S.law = Law::linear(law_values[0], law_values[1]);
  else {
    // the host's fit (fit.h), its step and 1 / step as fit_spline computes them
    Spline tf;
    tf.x0 = table_x0, tf.dx = table_dx, tf.inv_dx = 1.0 / table_dx, tf.c6 = table_dx * table_dx / 6.0;
    tf.n = table_n, tf.yd2 = table_yd2;
    Spline tu = tf;
    tu.yd2 = table_yd2 + 2 * table_n;
    S.law = Law::table(tf, tu);
  }
  S.drive.profile = static_cast<Drive::Profile>(drive_profile);
  S.drive.V = V;
  S.drive.T = T;
  if (S.drive.profile == Drive::MEASURED) {
    S.drive.measured.n = measured_n;
    S.drive.measured.t = measured_t;
    S.drive.measured.y = measured_y;
    S.drive.measured.d2y = measured_fit;
    S.drive.measured.yint = measured_fit + measured_n;
    S.drive.measured.given_velocity = given_velocity != 0;
    S.drive.measured.hold_after = hold_after != 0;
  }
  const long long at = static_cast<long long>(c) * n;
  chain_masses(mass + at, n, dt, g, dtfm + at, weight + at);
  const int nruns = (n - 2 + block - 1) / block;
  ChainData d{};
  d.x = x + at;
  d.v = v + at;
  d.f = f + at;
  d.dtfm = dtfm + at;
  d.mass = mass + at;
  d.weight = weight + at;
  d.index = index;
  d.runs = reinterpret_cast<Run *>(runs) + static_cast<long long>(c) * nruns;
  d.scratch = scratch + static_cast<long long>(c) * (5 * block + 1);
  if (S.record) {
    d.levels = levels_row(levels + 5 * static_cast<long long>(c));
    d.rec = rec + at * front::NCOL;
    d.mark = mark + at;
    d.gate = gate + at;
    d.phase = phase + at;
  }
  run_chain(S, d);
  work[c] = d.work_done;
  end_step[c] = d.end_step;
  status[c] = d.status;
}
