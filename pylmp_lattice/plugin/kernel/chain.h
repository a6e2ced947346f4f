/* A whole run of one independent chain (impactor, free atoms, held far end), as fix lattice/chain
   does it for a chain it owns alone on one rank: the setup's force pass, then every step with
   step_runs (step.h), the chain ends and the front record; for the host engine (OpenMP over
   chains, engine_cpu.cpp) and the GPU engine (one thread per chain). Every operation is the fix's,
   in its order, so a chain here gives the bits of the same chain in LAMMPS. Part of
   pylmp_lattice, GPL-2.0. */

#ifndef PYLMP_LATTICE_KERNEL_CHAIN_H
#define PYLMP_LATTICE_KERNEL_CHAIN_H

#include "drive.h"
#include "law.h"
#include "step.h"

namespace pl_kernel {

/* what every chain of a batch shares */
struct ChainSetup {
  int n;                          // atoms per chain: 0 the impactor, n - 1 held
  long long steps;
  double dt;
  double range_lo, range_hi;      // allowed separations; r <= 0 is a contact
  bool friction;
  Friction fr;
  Drive drive;
  Law law;
  bool record;                    // the front record
  int block;                      // largest run of free atoms (scratch: 5 block + 1 doubles)
};

/* a batch's setup from the engines' shared arguments (engine_cpu.cpp, engine_gpu.cu): law_kind 0
   power (law_values K b q), 1 linear (k r_free), 2 the fitted `table`; drive_profile a
   Drive::Profile with V, T, or the fitted `measured` */
PL_HD inline ChainSetup chain_setup(int n, long long steps, double dt, int block, int law_kind, const double *law_values,
                                    const Law &table, int drive_profile, double V, double T, const Measured &measured,
                                    bool friction, double mu, double p, double g, double range_lo, double range_hi,
                                    bool record)
{
  ChainSetup S;
  S.n = n;
  S.steps = steps;
  S.dt = dt;
  S.range_lo = range_lo;
  S.range_hi = range_hi;
  S.friction = friction;
  S.fr = Friction{mu, p, g};
  S.record = record;
  S.block = block;
  if (law_kind == 0) S.law = Law::power(law_values[0], law_values[1], law_values[2]);
  else if (law_kind == 1) S.law = Law::linear(law_values[0], law_values[1]);
  else S.law = table;
  S.drive.profile = static_cast<Drive::Profile>(drive_profile);
  S.drive.V = V;
  S.drive.T = T;
  if (S.drive.profile == Drive::MEASURED) S.drive.measured = measured;
  return S;
}

/* a chain's per-atom mass terms, as fix lattice/chain's: dt/2 in force-to-velocity units
   (ftm2v = 1 in units si) over m, and m g */
PL_HD inline void chain_masses(const double *mass, int n, double dt, double g, double *dtfm, double *weight)
{
  const double dtf = 0.5 * dt * 1.0;
  for (int i = 0; i < n; i++) {
    dtfm[i] = dtf / mass[i];
    weight[i] = mass[i] * g;
  }
}

/* front levels from a row "start front drop pulse_drop pulse_floor" */
PL_HD inline front::Levels levels_row(const double *L)
{
  front::Levels levels;
  levels.start = L[0], levels.front = L[1], levels.drop = L[2], levels.pulse_drop = L[3], levels.pulse_floor = L[4];
  return levels;
}

/* one chain's arrays (n each, the record n NCOL) and its outcome */
struct ChainData {
  double *x, *v, *f;              // x, v in: initial; out: final
  const double *dtfm, *mass, *weight;    // per atom: dt/2m, m, m g
  const int *index;               // 0, 1, ..., n - 1 (each atom is its own mass slot)
  front::Levels levels;
  double *rec, *mark, *gate;      // the front record (rec: n rows of NCOL), marks, start gates
  unsigned char *phase;
  Run *runs;                      // scratch: ceil((n - 2) / block) runs
  double *scratch;                // scratch: 5 block + 1 doubles
  // outcome
  double work_done, work_pending; // friction work (as the fix's vector entry of the chain)
  long long end_step;             // the last step done
  int status;                     // ChainStatus
};

enum ChainStatus { FINISHED = 0, CONTACT = 1, OUT_OF_RANGE = 2, DRIVE_ENDED = 3 };

namespace detail {
/* the front record's sampling of a run's rows (FrontPass's hook): the active atoms and those that
   reach the start level now, with the rules of front.h */
struct ChainFront {
  const Run *runs;
  const double *v, *f, *mass;
  double *rec, *gate;
  unsigned char *phase;
  front::Levels levels;
  front::Sample sample;
  int active;                     // atoms of the chain between their start and both peaks

  PL_HD void row(int i, double v_prev)
  {
    const unsigned char was = phase[i];
    front::sample_row(rec + (long long) i * front::NCOL, phase[i], v[i], f[i], mass[i], v_prev, levels, sample);
    if (was == front::WAITING && phase[i] != front::WAITING) gate[i] = infinity(), active++;
    if (was != front::FINISHED && phase[i] == front::FINISHED) active--;
  }
  PL_HD void sample_block(int b, const double *v_before, bool starting)
  {
    if (!starting && active == 0) return;
    const Run &run = runs[b];
    for (int i = run.first; i <= run.last; i++)
      if (phase[i] == front::ACTIVE || (starting && v[i] >= gate[i])) row(i, v_before[i - run.first]);
  }
};

/* every bond's separation: the smallest (a contact if <= 0) */
PL_HD inline double smallest_gap(const double *x, int n)
{
  double g = infinity();
  for (int i = 0; i + 1 < n; i++) g = x[i + 1] - x[i] < g ? x[i + 1] - x[i] : g;
  return g;
}

template <bool FRICTION, bool FRONT, class LawT>
PL_HD void run_chain(const LawT law, const ChainSetup &S, ChainData &c)
{
  const int n = S.n;
  double *x = c.x, *v = c.v, *f = c.f;
  const Masses ms{c.index, c.dtfm, c.mass, c.weight, false};
  // the runs of free atoms 1 .. n - 2, each at most S.block long
  int nruns = 0;
  for (int first = 1; first <= n - 2; first += S.block) {
    const int last = first + S.block - 1 < n - 2 ? first + S.block - 1 : n - 2;
    c.runs[nruns++] = Run{first, last, first - 1, last + 1, 0};
  }
  const double x0 = x[0];
  double u, ud;
  CoulombWork work;
  c.work_done = c.work_pending = 0.0;
  c.status = FINISHED;
  c.end_step = 0;

  // ---- setup: the impactor's velocity at t = 0, the forces for the first half kick (friction
  // for a kick of dt/2, from v(0)), the ends, the record's first sample
  S.drive.at(0.0, S.dt, u, ud);
  v[0] = ud;
  Gaps gaps;
  {
    double left = law(x[1] - x[0]);
    gaps.add(x[1] - x[0]);
    for (int i = 1; i <= n - 2; i++) {
      const double r = x[i + 1] - x[i];
      gaps.add(r);
      const double right = law(r);
      f[i] = total_force<FRICTION>(left, right, i, ms, S.fr, 0.5 * S.dt, v[i], work);
      left = right;
    }
  }
  if (FRICTION) work.settle(0.5 * S.dt, true, c.work_done, c.work_pending), work = CoulombWork();
  f[0] = -law(x[1] - x[0]);
  f[n - 1] = 0.0;
  ChainFront hook{c.runs, v, f, c.mass, c.rec, c.gate, c.phase, c.levels, front::Sample{0.0, 0.0, true}, 0};
  if (FRONT) {
    for (int i = 0; i < n; i++) {
      c.mark[i] = front::mark_max(c.mark[i], v[i]);
      c.gate[i] = c.levels.start;
      hook.row(i, quiet_nan());
    }
  }
  if (gaps.bad(S.range_lo, S.range_hi)) {
    c.status = smallest_gap(x, n) <= 0.0 ? CONTACT : OUT_OF_RANGE;
    return;
  }
  const FrontPass<ChainFront> pass{c.mark, c.gate, &hook};
  for (long long step = 1; step <= S.steps; step++) {
    const double v_impactor = v[0];
    // the impactor on the drive's path (the fix's initial_integrate)
    if (!S.drive.at(static_cast<double>(step) * S.dt, S.dt, u, ud)) {
      c.status = DRIVE_ENDED;
      return;
    }
    x[0] = x0 + u;
    v[0] = ud;
    hook.sample = front::Sample{0.0 + static_cast<double>(step) * S.dt, hook.sample.t, false};
    Gaps g;
    step_runs<FRICTION, FRONT>(law, c.runs, nruns, x, v, f, ms, S.fr, S.dt, &work, c.scratch, S.block, pass, g);
    if (FRICTION) work.settle(S.dt, false, c.work_done, c.work_pending), work = CoulombWork();
    f[0] = -law(x[1] - x[0]);
    f[n - 1] = 0.0;
    if (FRONT) {
      c.mark[0] = front::mark_max(c.mark[0], v[0]);
      hook.row(0, v_impactor);
      c.mark[n - 1] = front::mark_max(c.mark[n - 1], v[n - 1]);
      hook.row(n - 1, v[n - 1]);
    }
    c.end_step = step;
    if (g.bad(S.range_lo, S.range_hi)) {
      c.status = smallest_gap(x, n) <= 0.0 ? CONTACT : OUT_OF_RANGE;
      return;
    }
  }
}
}    // namespace detail

/* Run one chain: c.x, c.v hold its initial state (c.x[0] the impactor's position at t = 0), the
   record its NaN rows, marks and WAITING phases; on return its final state, record (the rows'
   largest |v| refreshed), friction work and status. */
PL_HD inline void run_chain(const ChainSetup &S, ChainData &c)
{
  S.law.dispatch([&](auto law) {
    if (S.friction) {
      if (S.record) detail::run_chain<true, true>(law, S, c);
      else detail::run_chain<true, false>(law, S, c);
    } else {
      if (S.record) detail::run_chain<false, true>(law, S, c);
      else detail::run_chain<false, false>(law, S, c);
    }
  });
  if (S.record)
    for (int i = 0; i < S.n; i++) c.rec[(long long) i * front::NCOL + front::V_ABS_MAX] = c.mark[i];
}

}    // namespace pl_kernel

#endif
