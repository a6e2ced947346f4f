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
     phase: WAITING (no sample at or above the start level yet), ACTIVE or FINISHED (a byte);
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

struct Levels {
  double start, front, drop, pulse_drop;    // velocity levels; relative fall of a pulse
  double pulse_floor = 0.0;                 // least absolute fall of a pulse (the chain's noise)
};
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

// A new maximum y at time t, the previous sample (y_prev, t_prev) its left neighbour.
PL_HD inline void set_maximum(double *m, double y, double t, double y_prev, double t_prev)
{
  m[0] = y, m[1] = t, m[2] = y_prev, m[3] = t_prev, m[4] = m[5] = quiet_nan();
}

// The sample after a maximum is its right neighbour.
PL_HD inline void fill_right(double *m, double y, double t, double t_prev)
{
  if (m[1] == t_prev && isnan(m[4])) {
    m[4] = y;
    m[5] = t;
  }
}

// First time v reaches level, between samples (t0, v0) below it and (t1, v1).
PL_HD inline double crossing(double level, double t0, double v0, double t1, double v1)
{
  return t0 + (level - v0) / (v1 - v0) * (t1 - t0);
}

// Vertex of the parabola through (tm, ym), (t, y), (tp, yp) where it is concave, else (t, y).
PL_HD inline void refine(const double *m, double &t_out, double &y_out)
{
  const double y = m[0], t = m[1], ym = m[2], tm = m[3], yp = m[4], tp = m[5];
  t_out = t;
  y_out = y;
  if (isnan(ym) || isnan(yp)) return;
  const double h1 = t - tm, h2 = tp - t;
  const double c = ((ym - y) / h1 + (yp - y) / h2) / (h1 + h2);
  if (!(c < 0.0)) return;
  const double b = (yp - y) / h2 - c * h2;
  t_out = t - b / (2.0 * c);
  y_out = y - b * b / (4.0 * c);
}
}    // namespace detail

/* cold part: the row r of an atom that starts now or is active, with its velocity v and
   acceleration a at this sample and its velocity v_prev at the previous one (the row keeps it
   for active atoms; a waiting atom's comes from the hot state of whoever samples). Moves the
   atom from WAITING to ACTIVE and from ACTIVE to FINISHED. */
PL_HD inline void advance(double *r, unsigned char &phase, double v, double v_prev, double a, const Levels &L,
                    const Sample &s)
{
  using namespace detail;
  const double t = s.t, t_prev = s.t_prev;
  if (phase == WAITING) {
    r[T_START] = s.first ? t : crossing(L.start, t_prev, v_prev, t, v);
    r[TS_START] = t;
    phase = ACTIVE;
  }
  bool arrived_now = false;
  if (isnan(r[T_ARRIVAL]) && v >= L.front) {
    r[T_ARRIVAL] = s.first ? t : crossing(L.front, t_prev, v_prev, t, v);
    arrived_now = true;
  }

  // which maxima move to this sample; the others get it as their right neighbour if their
  // maximum was the previous sample (a moved maximum's block is rewritten whole)
  const bool started_now = t == r[TS_START];
  const bool arun_open = r[DONE] != 1.0, pulse_open = r[PULSE_DONE] != 1.0;
  const bool best_open = arun_open && !isnan(r[T_ARRIVAL]);
  const bool arun_new = arun_open && (started_now || a > r[ARUN_A]);
  const bool pulse_new = pulse_open && (started_now || v > r[PULSE_V]);
  const bool best_new = best_open && (arrived_now || v > r[BEST_V]);
  if (!best_new) fill_right(&r[BEST_V], v, t, t_prev);
  if (!pulse_new) fill_right(&r[PULSE_V], v, t, t_prev);
  if (!arun_new) fill_right(&r[ARUN_A], a, t, t_prev);

  const double v_before = s.first ? quiet_nan() : v_prev;
  if (arun_new) set_maximum(&r[ARUN_A], a, t, started_now ? quiet_nan() : r[A_PREV], t_prev);

  if (pulse_new) {
    set_maximum(&r[PULSE_V], v, t, v_before, t_prev);
  } else if (pulse_open && v <= r[PULSE_V] - fmax(L.pulse_drop * fabs(r[PULSE_V]), L.pulse_floor)) {
    r[PULSE_DONE] = 1.0;
    double v_max;
    refine(&r[PULSE_V], r[T_PULSE], v_max);
  }

  if (best_new) {
    set_maximum(&r[BEST_V], v, t, v_before, t_prev);
    for (int k = 0; k < MAXIMUM; k++) r[ASNAP_A + k] = r[ARUN_A + k];
  } else if (best_open && v <= r[BEST_V] - L.drop) {
    r[DONE] = 1.0;
    refine(&r[BEST_V], r[T_PEAK], r[V_PEAK]);
    const bool inside = r[ASNAP_T] > r[TS_START] && r[ASNAP_T] < r[BEST_T];
    double t_acc;
    if (inside) refine(&r[ASNAP_A], t_acc, r[A_PEAK]);
    else r[A_PEAK] = r[ASNAP_A];
  }
  r[V_PREV] = v;
  r[A_PREV] = a;
  if (r[DONE] == 1.0 && r[PULSE_DONE] == 1.0) phase = FINISHED;
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
