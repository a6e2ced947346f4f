/* The per-atom rules of the front record (the sampler the measures read: arrival times, first
   peaks, per-magnet extrema), in one place: fix lattice/front applies them in its own pass after
   each step; fix lattice/chain inside its force pass when it owns the whole step (see both
   fixes' headers); the host and GPU engines in their chain loop (chain.h). Part of
   pylmp_lattice, GPL-2.0. The measures and their definitions are described in
   fix_lattice_front.cpp.

Why a hot and a cold part
   A record row is NCOL doubles (296 bytes), but at any step only the few atoms between their
   start and both peaks confirmed ("active") change it; the others (at rest ahead of the front,
   or behind it with both peaks found) need only their largest |v| so far and, while they wait
   for the start level, their previous velocity. So every step touches, per atom, only
     mark: the largest |v| so far (NaN before the first sample), one max instruction;
     phase: WAITING (no sample at or above the start level yet), ACTIVE or FINISHED (a byte, or
       with lanes the atom's start gate: chain.h);
   and the row only for active atoms (and at its start). The row's V_ABS_MAX column is the
   output copy of |mark|, refreshed whenever something may read the record (see the fix). */

#ifndef PYLMP_LATTICE_KERNEL_FRONT_H
#define PYLMP_LATTICE_KERNEL_FRONT_H

#include "device.h"

namespace pl_kernel {
namespace front {

// Columns of a row. The first NOUT are the fix's output; the rest is running state: the previous
// sample (of an active atom), and blocks that follow a running maximum with its neighbouring
// samples (value, time, value before, its time, value after, its time): the candidate first
// peak of v (BEST_*), the candidate pulse maximum of v (PULSE_*), the running maximum of a since
// the start sample (ARUN_*) and its value when the candidate first peak was set (ASNAP_*, the
// window that ends at the peak).
enum Column {
  T_START, T_ARRIVAL, T_PEAK, V_PEAK, A_PEAK, V_ABS_MAX, T_PULSE, NOUT,
  V_PREV = NOUT, DONE, PULSE_DONE, A_PREV, TS_START,
  BEST_V, BEST_T, BEST_VM, BEST_TM, BEST_VP, BEST_TP,
  PULSE_V, PULSE_T, PULSE_VM, PULSE_TM, PULSE_VP, PULSE_TP,
  ARUN_A, ARUN_T, ARUN_AM, ARUN_TM, ARUN_AP, ARUN_TP,
  ASNAP_A, ASNAP_T, ASNAP_AM, ASNAP_TM, ASNAP_AP, ASNAP_TP,
  NCOL
};
enum Phase : unsigned char { WAITING, ACTIVE, FINISHED };

/* per chain, or with lanes (R: device.h) per lane */
template <class R> struct LevelsT {
  R start, front, drop, pulse_drop;    // velocity levels; relative fall of a pulse
  R pulse_floor = R();                 // least absolute fall of a pulse (the chain's noise)
};
typedef LevelsT<double> Levels;
struct Sample {
  double t, t_prev;    // this sample's time and the previous one's
  bool first;          // no earlier sample
};

/* hot part, every atom at every sample: the largest |v| (NaN compares false, so the first
   sample replaces the NaN of an atom not sampled yet, and a NaN v is kept; written so that
   x86 does it in one maxpd; per lane with lanes, device.h) */
template <class R> PL_HD inline R mark_max(R mark, R v)
{
  const R a = fabs(v);
  return mark > a ? mark : a;
}
/* an atom that waits and reaches the start level now: its row must be updated */
PL_HD inline bool starts(unsigned char phase, double v, const Levels &L)
{
  return phase == WAITING && v >= L.start;
}
/* an atom whose row this sample updates: active, or it starts now */
PL_HD inline bool due(unsigned char phase, double v, const Levels &L)
{
  return phase == ACTIVE || starts(phase, v, L);
}

namespace detail {
constexpr int MAXIMUM = 6;    // columns in a maximum block

/* Each rule below works on the lanes in a mask `go` (a bool for one chain, device.h's MaskOf
   with lanes: W chains side by side, each lane's row a lane of R). A lane's operations are the
   same as one chain's, a branch being a select, so each lane has the bits of its chain alone;
   a block of selects runs only where some lane takes it (with one chain: where it does), but
   refine computes its vertex in every lane it is given and keeps it only where it exists. */
template <class R> PL_HD inline R pick(MaskOf<R> m, R a, R b)
{
  return m ? a : b;
}

// A new maximum y at time t, the previous sample (y_prev, t_prev) its left neighbour.
template <class R> PL_HD inline void set_maximum(R *m, MaskOf<R> go, R y, R t, R y_prev, R t_prev)
{
  const R nan = Lanes<R>::splat(quiet_nan());
  m[0] = pick(go, y, m[0]), m[1] = pick(go, t, m[1]), m[2] = pick(go, y_prev, m[2]);
  m[3] = pick(go, t_prev, m[3]), m[4] = pick(go, nan, m[4]), m[5] = pick(go, nan, m[5]);
}

// The sample after a maximum is its right neighbour.
template <class R> PL_HD inline void fill_right(R *m, MaskOf<R> go, R y, R t, R t_prev)
{
  const MaskOf<R> right = go && m[1] == t_prev && isnan(m[4]);
  if (Lanes<R>::any(right)) m[4] = pick(right, y, m[4]), m[5] = pick(right, t, m[5]);
}

// First time v reaches level, between samples (t0, v0) below it and (t1, v1).
template <class R> PL_HD inline R crossing(R level, R t0, R v0, R t1, R v1)
{
  return t0 + (level - v0) / (v1 - v0) * (t1 - t0);
}

// Vertex of the parabola through (tm, ym), (t, y), (tp, yp) where it is concave, else (t, y).
template <class R> PL_HD inline void refine(const R *m, MaskOf<R> go, R &t_out, R &y_out)
{
  const R y = m[0], t = m[1], ym = m[2], tm = m[3], yp = m[4], tp = m[5];
  const R h1 = t - tm, h2 = tp - t;
  const R c = ((ym - y) / h1 + (yp - y) / h2) / (h1 + h2);
  const MaskOf<R> vertex = !(isnan(ym) || isnan(yp)) && c < 0.0;
  const R b = (yp - y) / h2 - c * h2;
  t_out = pick(go, pick(vertex, t - b / (2.0 * c), t), t_out);
  y_out = pick(go, pick(vertex, y - b * b / (4.0 * c), y), y_out);
}
}    // namespace detail

/* cold part: the rows r of atoms that start now (`starting`) or are active (the other lanes of
   `go`), with their velocity v and acceleration a at this sample and their velocity v_prev at
   the previous one (the row keeps it for active atoms; a waiting atom's comes from the hot
   state of whoever samples); the lanes outside `go` are left as they are. Returns the lanes
   whose atom has both peaks now: they move from ACTIVE to FINISHED (those starting, from
   WAITING to ACTIVE). */
template <class R>
PL_HD inline MaskOf<R> advance_lanes(R *r, MaskOf<R> go, MaskOf<R> starting, R v, R v_prev, R a,
                                     const LevelsT<R> &L, const Sample &s)
{
  using namespace detail;
  using Ln = Lanes<R>;
  const R t = Ln::splat(s.t), t_prev = Ln::splat(s.t_prev), one = Ln::splat(1.0);
  if (Ln::any(starting)) {
    r[T_START] = pick(starting, s.first ? t : crossing(L.start, t_prev, v_prev, t, v), r[T_START]);
    r[TS_START] = pick(starting, t, r[TS_START]);
  }
  const MaskOf<R> arrived_now = go && isnan(r[T_ARRIVAL]) && v >= L.front;
  if (Ln::any(arrived_now))
    r[T_ARRIVAL] = pick(arrived_now, s.first ? t : crossing(L.front, t_prev, v_prev, t, v), r[T_ARRIVAL]);

  // which maxima move to this sample; the others get it as their right neighbour if their
  // maximum was the previous sample (a moved maximum's block is rewritten whole)
  const MaskOf<R> started_now = t == r[TS_START];
  const MaskOf<R> arun_open = r[DONE] != 1.0, pulse_open = r[PULSE_DONE] != 1.0;
  const MaskOf<R> best_open = arun_open && !isnan(r[T_ARRIVAL]);
  const MaskOf<R> arun_new = go && arun_open && (started_now || a > r[ARUN_A]);
  const MaskOf<R> pulse_new = go && pulse_open && (started_now || v > r[PULSE_V]);
  const MaskOf<R> best_new = go && best_open && (arrived_now || v > r[BEST_V]);
  fill_right(&r[BEST_V], go && !best_new, v, t, t_prev);
  fill_right(&r[PULSE_V], go && !pulse_new, v, t, t_prev);
  fill_right(&r[ARUN_A], go && !arun_new, a, t, t_prev);

  const R v_before = s.first ? Ln::splat(quiet_nan()) : v_prev;
  if (Ln::any(arun_new))
    set_maximum(&r[ARUN_A], arun_new, a, t, pick(started_now, Ln::splat(quiet_nan()), r[A_PREV]), t_prev);

  const MaskOf<R> pulse_ends =
      go && !pulse_new && pulse_open && v <= r[PULSE_V] - fmax(L.pulse_drop * fabs(r[PULSE_V]), L.pulse_floor);
  if (Ln::any(pulse_new)) set_maximum(&r[PULSE_V], pulse_new, v, t, v_before, t_prev);
  if (Ln::any(pulse_ends)) {
    r[PULSE_DONE] = pick(pulse_ends, one, r[PULSE_DONE]);
    R v_max = R();
    refine(&r[PULSE_V], pulse_ends, r[T_PULSE], v_max);
  }

  const MaskOf<R> best_ends = go && !best_new && best_open && v <= r[BEST_V] - L.drop;
  if (Ln::any(best_new)) {
    set_maximum(&r[BEST_V], best_new, v, t, v_before, t_prev);
    for (int k = 0; k < MAXIMUM; k++) r[ASNAP_A + k] = pick(best_new, r[ARUN_A + k], r[ASNAP_A + k]);
  }
  if (Ln::any(best_ends)) {
    r[DONE] = pick(best_ends, one, r[DONE]);
    refine(&r[BEST_V], best_ends, r[T_PEAK], r[V_PEAK]);
    const MaskOf<R> inside = r[ASNAP_T] > r[TS_START] && r[ASNAP_T] < r[BEST_T];
    R t_acc = R();
    refine(&r[ASNAP_A], best_ends && inside, t_acc, r[A_PEAK]);
    r[A_PEAK] = pick(best_ends && !inside, r[ASNAP_A], r[A_PEAK]);
  }
  r[V_PREV] = pick(go, v, r[V_PREV]);
  r[A_PREV] = pick(go, a, r[A_PREV]);
  return go && r[DONE] == 1.0 && r[PULSE_DONE] == 1.0;
}

/* advance_lanes for one chain's atom that is due (front::due), its phase moved on */
PL_HD inline void advance(double *r, unsigned char &phase, double v, double v_prev, double a, const Levels &L,
                          const Sample &s)
{
  const bool starting = phase == WAITING;
  if (starting) phase = ACTIVE;
  if (advance_lanes<double>(r, true, starting, v, v_prev, a, L, s)) phase = FINISHED;
}

/* The one per-atom sampling routine past the hot part (mark_max): the row r of an atom that is
   active or reaches the start level now, with its v, force f and mass m at this sample and
   v_waiting, its v at the previous sample (used only if it was waiting). */
PL_HD inline void sample_row(double *r, unsigned char &phase, double v, double f, double m, double v_waiting,
                             const Levels &L, const Sample &s)
{
  const unsigned char before = phase;
  if (due(before, v, L))
    advance(r, phase, v, before == WAITING ? v_waiting : r[V_PREV], f / m, L, s);
}

}    // namespace front
}    // namespace pl_kernel

#endif
