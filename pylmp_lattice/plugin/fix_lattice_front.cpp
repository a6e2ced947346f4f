/* ----------------------------------------------------------------------
   fix lattice/front: front measures of each atom, recorded every step
   Part of pylmp_lattice, GPL-2.0. Compiled as a LAMMPS plugin.

Syntax
   fix ID group-ID lattice/front start S front L drop D

   S, L, D = velocity levels (velocity units, m/s in units si), 0 < S <= L, D > 0

Example
   fix front all lattice/front start 0.02 front 1.0 drop 0.1
   ...
   run 60000
   write_dump all custom front.bin id f_front[1] f_front[2] f_front[3] f_front[4] f_front[5] f_front[6] modify sort id

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
   They are the array measures of pylmp_lattice/measures.py (arrival_times, first_peaks)
   applied to the record of every step, with the same definitions:
   - a crossing time is interpolated linearly between the last sample below the level and
     the first at or above it (the time of the first sample if that is already there);
   - the first peak is the largest sample from the front on, confirmed once v has fallen
     by D below the running maximum; its time and value are the vertex of the parabola
     through it and its two neighbouring samples (where these are concave);
   - the first peak acceleration is the largest a from the first sample at or above S up
     to the peak's sample, refined by the same parabola when it lies strictly inside.
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
// Columns of a record. The first NOUT are the fix's output; the rest is running state:
// the previous sample, the candidate peak of v with its neighbours (M: before, P: after),
// the running maximum of a since the start sample (ARUN_*) and its value when the current
// candidate peak was set (ASNAP_*, the window that ends at the peak).
enum {
  T_START, T_ARRIVAL, T_PEAK, V_PEAK, A_PEAK, V_ABS_MAX, NOUT,
  V_PREV = NOUT, A_PREV, TS_START, DONE,
  BEST_V, BEST_T, BEST_VM, BEST_TM, BEST_VP, BEST_TP,
  ARUN_A, ARUN_T, ARUN_AM, ARUN_TM, ARUN_AP, ARUN_TP,
  ASNAP_A, ASNAP_T, ASNAP_AM, ASNAP_TM, ASNAP_AP, ASNAP_TP,
  NCOL
};
constexpr int MAXIMUM = 6;    // columns in a (value, time, before, time, after, time) block
const double NaN = std::numeric_limits<double>::quiet_NaN();

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
  if (narg != 9) utils::missing_cmd_args(FLERR, "fix lattice/front start S front L drop D", error);
  const char *keys[3] = {"start", "front", "drop"};
  double *values[3] = {&start_level, &front_level, &drop};
  for (int k = 0; k < 3; k++) {
    if (strcmp(arg[3 + 2 * k], keys[k]) != 0)
      error->all(FLERR, "Fix lattice/front: expected '{}', got '{}'", keys[k], arg[3 + 2 * k]);
    *values[k] = utils::numeric(FLERR, arg[4 + 2 * k], false, lmp);
  }
  if (!(start_level > 0.0 && start_level <= front_level))
    error->all(FLERR, "Fix lattice/front: need 0 < start <= front, got start {} front {}", start_level,
               front_level);
  if (!(drop > 0.0)) error->all(FLERR, "Fix lattice/front: need drop > 0, got {}", drop);

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
    const double ai = f[i][0] / (rmass ? rmass[i] : mass[type[i]]);
    if (!(std::fabs(vi) <= r[V_ABS_MAX])) r[V_ABS_MAX] = std::fabs(vi);    // NaN at first

    // the sample after a maximum is its right neighbour
    if (r[DONE] != 1.0 && r[BEST_T] == t_prev && std::isnan(r[BEST_VP])) {
      r[BEST_VP] = vi;
      r[BEST_TP] = t;
    }
    if (r[ARUN_T] == t_prev && std::isnan(r[ARUN_AP])) {
      r[ARUN_AP] = ai;
      r[ARUN_TP] = t;
    }

    if (std::isnan(r[T_START]) && vi >= start_level) {
      r[T_START] = first ? t : crossing(start_level, t_prev, r[V_PREV], t, vi);
      r[TS_START] = t;
    }
    bool arrived_now = false;
    if (std::isnan(r[T_ARRIVAL]) && vi >= front_level) {
      r[T_ARRIVAL] = first ? t : crossing(front_level, t_prev, r[V_PREV], t, vi);
      arrived_now = true;
    }

    if (r[DONE] != 1.0 && !std::isnan(r[TS_START]) && (std::isnan(r[ARUN_A]) || ai > r[ARUN_A])) {
      const double row[MAXIMUM] = {ai, t, t == r[TS_START] ? NaN : r[A_PREV], t_prev, NaN, NaN};
      std::memcpy(&r[ARUN_A], row, sizeof(row));
    }

    if (r[DONE] != 1.0 && !std::isnan(r[T_ARRIVAL])) {
      if (arrived_now || vi > r[BEST_V]) {
        const double row[MAXIMUM] = {vi, t, first ? NaN : r[V_PREV], t_prev, NaN, NaN};
        std::memcpy(&r[BEST_V], row, sizeof(row));
        std::memcpy(&r[ASNAP_A], &r[ARUN_A], sizeof(row));
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
