/* ----------------------------------------------------------------------
   fix lattice/front: front measures of each atom, recorded every step
   Part of pylmp_lattice, GPL-2.0. Compiled as a LAMMPS plugin.

Syntax
   fix ID group-ID lattice/front start S front L drop D pulse_drop R

   S, L, D = velocity levels (velocity units, m/s in units si), 0 < S <= L, D > 0
   R = relative fall that confirms a pulse's maximum, 0 < R < 1

Example
   fix front all lattice/front start 0.02 front 1.0 drop 0.1 pulse_drop 0.1
   ...
   run 60000
   write_dump all custom front.bin id f_front[*] modify sort id time yes

Description
   Every time step (and once in the setup of the first run) the fix samples each atom's
   velocity v = vx and acceleration a = fx / m after the step is complete, as a dump at
   that step would see them, and keeps six numbers per atom (a per-atom array, NaN where
   a measure does not exist):
     1 start time: first time v reaches S
     2 arrival time: first time v reaches L (the front)
     3 first peak time
     4 first peak velocity
     5 first peak acceleration
     6 largest |v| so far
     7 pulse arrival: time of the first maximum of v from the start of motion
   They are the array measures of pylmp_lattice/measures.py (arrival_times, first_peaks)
   applied to the record of every step, with the same definitions:
   - a crossing time is interpolated linearly between the last sample below the level and
     the first at or above it (the time of the first sample if that is already there);
   - the first peak is the largest sample from the front on, confirmed once v has fallen
     by D below the running maximum; its time and value are the vertex of the parabola
     through it and its two neighbouring samples (where these are concave);
   - the first peak acceleration is the largest a from the first sample at or above S up
     to the peak's sample, refined by the same parabola when it lies strictly inside;
   - the pulse arrival (measures.arrival_times, method "velocity_peak") is found like the
     first peak, but searched from the first sample at or above S and confirmed by a fall of
     R times the maximum.
   Ties go to the earliest sample, as numpy's argmax does. Atoms outside the group keep
   NaN. The records move with their atoms between MPI ranks.

Restrictions
   Not for rRESPA. The time step must not change during the record.
------------------------------------------------------------------------- */

#include "fix_lattice_front.h"

#include "atom.h"
#include "error.h"
#include "memory.h"
#include "update.h"

#include <cmath>
#include <cstring>
#include <limits>

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {
// Columns of a record. The first NOUT are the fix's output; the rest is running state: the
// previous sample, and blocks that follow a running maximum with its neighbouring samples
// (value, time, value before, its time, value after, its time): the candidate first peak of v
// (BEST_*), the candidate pulse maximum of v (PULSE_*), the running maximum of a since the
// start sample (ARUN_*) and its value when the candidate first peak was set (ASNAP_*, the
// window that ends at the peak).
enum {
  T_START, T_ARRIVAL, T_PEAK, V_PEAK, A_PEAK, V_ABS_MAX, T_PULSE, NOUT,
  V_PREV = NOUT, DONE, PULSE_DONE, A_PREV, TS_START,
  BEST_V, BEST_T, BEST_VM, BEST_TM, BEST_VP, BEST_TP,
  PULSE_V, PULSE_T, PULSE_VM, PULSE_TM, PULSE_VP, PULSE_TP,
  ARUN_A, ARUN_T, ARUN_AM, ARUN_TM, ARUN_AP, ARUN_TP,
  ASNAP_A, ASNAP_T, ASNAP_AM, ASNAP_TM, ASNAP_AP, ASNAP_TP,
  NCOL
};
constexpr int MAXIMUM = 6;    // columns in a maximum block
const double NaN = std::numeric_limits<double>::quiet_NaN();

// A new maximum y at time t, the previous sample (y_prev, t_prev) its left neighbour.
void set_maximum(double *m, double y, double t, double y_prev, double t_prev)
{
  const double row[MAXIMUM] = {y, t, y_prev, t_prev, NaN, NaN};
  std::memcpy(m, row, sizeof(row));
}

// The sample after a maximum is its right neighbour.
void fill_right(double *m, double y, double t, double t_prev)
{
  if (m[1] == t_prev && std::isnan(m[4])) {
    m[4] = y;
    m[5] = t;
  }
}

// First time v reaches level, between samples (t0, v0) below it and (t1, v1).
double crossing(double level, double t0, double v0, double t1, double v1)
{
  return t0 + (level - v0) / (v1 - v0) * (t1 - t0);
}

// Vertex of the parabola through (tm, ym), (t, y), (tp, yp) where it is concave, else (t, y).
void refine(const double *m, double &t_out, double &y_out)
{
  const double y = m[0], t = m[1], ym = m[2], tm = m[3], yp = m[4], tp = m[5];
  t_out = t;
  y_out = y;
  if (std::isnan(ym) || std::isnan(yp)) return;
  const double h1 = t - tm, h2 = tp - t;
  const double c = ((ym - y) / h1 + (yp - y) / h2) / (h1 + h2);
  if (!(c < 0.0)) return;
  const double b = (yp - y) / h2 - c * h2;
  t_out = t - b / (2.0 * c);
  y_out = y - b * b / (4.0 * c);
}
}    // namespace

FixLatticeFront::FixLatticeFront(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), rec(nullptr), rows(0), t_prev(0.0), step_prev(-1)
{
  if (narg != 11) utils::missing_cmd_args(FLERR, "fix lattice/front start S front L drop D pulse_drop R", error);
  const char *keys[4] = {"start", "front", "drop", "pulse_drop"};
  double *values[4] = {&start_level, &front_level, &drop, &pulse_drop};
  for (int k = 0; k < 4; k++) {
    if (strcmp(arg[3 + 2 * k], keys[k]) != 0)
      error->all(FLERR, "Fix lattice/front: expected '{}', got '{}'", keys[k], arg[3 + 2 * k]);
    *values[k] = utils::numeric(FLERR, arg[4 + 2 * k], false, lmp);
  }
  if (!(start_level > 0.0 && start_level <= front_level))
    error->all(FLERR, "Fix lattice/front: need 0 < start <= front, got start {} front {}", start_level,
               front_level);
  if (!(drop > 0.0)) error->all(FLERR, "Fix lattice/front: need drop > 0, got {}", drop);
  if (!(pulse_drop > 0.0 && pulse_drop < 1.0))
    error->all(FLERR, "Fix lattice/front: need 0 < pulse_drop < 1, got {}", pulse_drop);

  peratom_flag = 1;
  size_peratom_cols = NOUT;
  peratom_freq = 1;
  grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
}

FixLatticeFront::~FixLatticeFront()
{
  atom->delete_callback(id, Atom::GROW);
  memory->destroy(rec);
}

int FixLatticeFront::setmask()
{
  return END_OF_STEP;
}

void FixLatticeFront::setup(int)
{
  sample();    // the state before the first step, as a dump's first frame
}

void FixLatticeFront::end_of_step()
{
  sample();
}

void FixLatticeFront::sample()
{
  const bigint step = update->ntimestep;
  if (step == step_prev) return;    // a later run's setup repeats the last step
  const double t = update->atime + (step - update->atimestep) * update->dt;
  const bool first = step_prev < 0;

  double **v = atom->v, **f = atom->f;
  const double *rmass = atom->rmass, *mass = atom->mass;
  const int *type = atom->type, *mask = atom->mask;
  for (int i = 0; i < atom->nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    double *r = rec[i];
    const double vi = v[i][0];
    if (!(std::fabs(vi) <= r[V_ABS_MAX])) r[V_ABS_MAX] = std::fabs(vi);    // NaN at first
    // Most magnets are at rest ahead of the front or have both peaks behind them: for those
    // the record reads only the first columns (one or two cache lines) and moves on.
    if (std::isnan(r[T_START]) && vi < start_level) {
      r[V_PREV] = vi;
      continue;
    }
    if (r[DONE] == 1.0 && r[PULSE_DONE] == 1.0) continue;
    const double ai = f[i][0] / (rmass ? rmass[i] : mass[type[i]]);

    fill_right(&r[BEST_V], vi, t, t_prev);
    fill_right(&r[PULSE_V], vi, t, t_prev);
    fill_right(&r[ARUN_A], ai, t, t_prev);

    if (std::isnan(r[T_START]) && vi >= start_level) {
      r[T_START] = first ? t : crossing(start_level, t_prev, r[V_PREV], t, vi);
      r[TS_START] = t;
    }
    bool arrived_now = false;
    if (std::isnan(r[T_ARRIVAL]) && vi >= front_level) {
      r[T_ARRIVAL] = first ? t : crossing(front_level, t_prev, r[V_PREV], t, vi);
      arrived_now = true;
    }

    const bool started_now = t == r[TS_START];
    const double v_before = first ? NaN : r[V_PREV];
    if (r[DONE] != 1.0 && !std::isnan(r[TS_START]) && (started_now || ai > r[ARUN_A]))
      set_maximum(&r[ARUN_A], ai, t, started_now ? NaN : r[A_PREV], t_prev);

    if (r[PULSE_DONE] != 1.0 && !std::isnan(r[TS_START])) {
      if (started_now || vi > r[PULSE_V]) {
        set_maximum(&r[PULSE_V], vi, t, v_before, t_prev);
      } else if (vi <= r[PULSE_V] - pulse_drop * std::fabs(r[PULSE_V])) {
        r[PULSE_DONE] = 1.0;
        double v_max;
        refine(&r[PULSE_V], r[T_PULSE], v_max);
      }
    }

    if (r[DONE] != 1.0 && !std::isnan(r[T_ARRIVAL])) {
      if (arrived_now || vi > r[BEST_V]) {
        set_maximum(&r[BEST_V], vi, t, v_before, t_prev);
        std::memcpy(&r[ASNAP_A], &r[ARUN_A], MAXIMUM * sizeof(double));
      } else if (vi <= r[BEST_V] - drop) {
        r[DONE] = 1.0;
        refine(&r[BEST_V], r[T_PEAK], r[V_PEAK]);
        const bool inside = r[ASNAP_T] > r[TS_START] && r[ASNAP_T] < r[BEST_T];
        double t_acc;
        if (inside) refine(&r[ASNAP_A], t_acc, r[A_PEAK]);
        else r[A_PEAK] = r[ASNAP_A];
      }
    }
    r[V_PREV] = vi;
    r[A_PREV] = ai;
  }
  t_prev = t;
  step_prev = step;
}

double FixLatticeFront::memory_usage()
{
  return static_cast<double>(atom->nmax) * NCOL * sizeof(double);
}

void FixLatticeFront::grow_arrays(int nmax)
{
  memory->grow(rec, nmax, NCOL, "lattice/front:rec");
  for (int i = rows; i < nmax; i++)    // nothing recorded yet
    for (int c = 0; c < NCOL; c++) rec[i][c] = NaN;
  rows = nmax;
  array_atom = rec;
}

void FixLatticeFront::copy_arrays(int i, int j, int)
{
  std::memcpy(rec[j], rec[i], NCOL * sizeof(double));
}

int FixLatticeFront::pack_exchange(int i, double *buf)
{
  std::memcpy(buf, rec[i], NCOL * sizeof(double));
  return NCOL;
}

int FixLatticeFront::unpack_exchange(int nlocal, double *buf)
{
  std::memcpy(rec[nlocal], buf, NCOL * sizeof(double));
  return NCOL;
}
