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
  int block;                      // largest run of free atoms (scratch: step_scratch(block))
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
   (ftm2v = 1 in units si) over m, and m g; with dtm (friction), the friction kick's dt / m once
   (ChainDataT::dtm), not a division per atom and step */
template <class R>
PL_HD inline void chain_masses(const R *mass, int n, double dt, double g, R *dtfm, R *weight, R *dtm = nullptr)
{
  const double dtf = 0.5 * dt * 1.0;
  PL_UNROLL
  for (int i = 0; i < n; i++) {
    dtfm[i] = dtf / mass[i];
    weight[i] = mass[i] * g;
    if (dtm) dtm[i] = dt / mass[i];
  }
}

/* front levels from a row "start front drop pulse_drop pulse_floor" */
PL_HD inline front::Levels levels_row(const double *L)
{
  front::Levels levels;
  levels.start = L[0], levels.front = L[1], levels.drop = L[2], levels.pulse_drop = L[3], levels.pulse_floor = L[4];
  return levels;
}

/* W chains' levels as lanes (one chain: its own) */
template <class R> PL_HD inline front::LevelsT<R> lane_levels(const front::Levels *levels)
{
  front::LevelsT<R> lanes;
  for (int l = 0; l < Lanes<R>::W; l++) {
    Lanes<R>::set(lanes.start, l, levels[l].start), Lanes<R>::set(lanes.front, l, levels[l].front);
    Lanes<R>::set(lanes.drop, l, levels[l].drop), Lanes<R>::set(lanes.pulse_drop, l, levels[l].pulse_drop);
    Lanes<R>::set(lanes.pulse_floor, l, levels[l].pulse_floor);
  }
  return lanes;
}

/* one chain's arrays (n each, the record n NCOL) and its outcome; with lanes (R a vector of W
   doubles, device.h) W chains side by side: x[i] holds atom i of every lane's chain, and so does
   the record (rec[i NCOL + k]: column k of atom i's row in every lane), whose phases the gates
   keep (one chain: in phase) */
template <class R> struct ChainDataT {
  static constexpr int W = Lanes<R>::W;
  R *x, *v, *f;                   // x, v in: initial; out: final (lanes: see x_end)
  const R *dtfm, *mass, *weight;  // per mass slot: dt/2m, m, m g
  const R *dtm;                   // per mass slot: dt/m with friction, or null (MassesT)
  const int *index;               // atom i's mass slot: i (each atom its own), or 1 for all (the GPU's
                                  // batches of one mass)
  front::Levels levels[W];
  R *rec;                         // the front record: n rows of NCOL
  R *mark, *gate;                 // marks, start gates
  unsigned char *phase;           // one chain (W = 1): each row's front::Phase
  R *scratch;                     // scratch: step_scratch(block)
  double *x_end, *v_end;          // lanes: each lane's x, v at its end (W rows of n), or null
  bool alive[W];                  // in: the lanes to run (a lane past the last chain: false)
  // outcome, per lane
  double work[W];                 // friction work (as the fix's vector entry of the chain)
  long long end_step[W];          // the last step done
  int status[W];                  // ChainStatus
};
typedef ChainDataT<double> ChainData;

enum ChainStatus { FINISHED = 0, CONTACT = 1, OUT_OF_RANGE = 2, DRIVE_ENDED = 3 };

namespace detail {
/* How ChainFront samples the rows due: per_run, a run's rows after its kicks (with lanes, a whole
   run compared at once); per_atom, each atom's right after its kick; listed, the step's due rows
   listed and sampled together after the step, in one loop that a warp's threads (other chains,
   each with its own atoms due) run side by side, where per_atom runs one atom's sampling after
   another for the few threads due at each (bench_gpu.py --variants times both); masked, the
   step's due atoms marked in a bit mask and sampled after the step in a loop over the atoms
   unrolled, each atom's v and f read where they are (a GPU thread's registers), not copied into
   a list (64 x 40 bytes of local memory): a waiting atom's velocity before the step, which its
   start's crossing needs, goes into its row's V_PREV when it is marked (sample_row reads it
   there), which its sampling then overwrites as it would. */
enum class Sampling { per_run, per_atom, listed, masked };

/* A chain's start gates (ChainFront): atom i's is its chain's start level while it waits, -infinity
   while active, NaN when finished. ArrayGates: an array of R (the host engine: per lane). */
template <class R> struct ArrayGates {
  static constexpr Sampling SAMPLING = Sampling::per_run;
  R *g;
  PL_HD R operator[](int i) const { return g[i]; }
  PL_HD void wait(int i, int l, double start) { Lanes<R>::set(g[i], l, start); }
  PL_HD void activate(int i, int l) { Lanes<R>::set(g[i], l, -infinity()); }
  PL_HD void finish(int i, int l) { Lanes<R>::set(g[i], l, quiet_nan()); }
  /* atom i's lanes `started` become active, then those `finished` finished */
  PL_HD void update(int i, MaskOf<R> started, MaskOf<R> finished)
  {
    g[i] = started ? Lanes<R>::splat(-infinity()) : g[i];
    g[i] = finished ? Lanes<R>::splat(quiet_nan()) : g[i];
  }
  PL_HD ArrayGates view() const { return *this; }
};
/* BitGates: one chain of at most 64 atoms (a GPU thread), its gates as two bit masks and the start
   level, 5 registers rather than 2n; sampled per atom or listed, so that no run's velocities are
   held either (benchmarks/gpu_resources.py) */
template <Sampling S> struct BitGates {
  static constexpr Sampling SAMPLING = S;
  static constexpr int ATOMS = 64;    // the most atoms a chain may have
  unsigned long long active = 0, finished = 0;
  double start = 0.0;
  PL_HD double operator[](int i) const
  {
    const unsigned long long bit = 1ull << i;
    return (active & bit) ? -infinity() : (finished & bit) ? quiet_nan() : start;
  }
  PL_HD void wait(int i, int, double level)
  {
    active &= ~(1ull << i), finished &= ~(1ull << i);
    start = level;
  }
  PL_HD void activate(int i, int) { active |= 1ull << i, finished &= ~(1ull << i); }
  PL_HD void finish(int i, int) { finished |= 1ull << i, active &= ~(1ull << i); }
  struct View {    // what the step reads: the hook's gates as they change
    const BitGates *g;
    PL_HD double operator[](int i) const { return (*g)[i]; }
  };
  PL_HD View view() const { return View{this}; }
};

/* the gates run_chain keeps for a sampling: an array of c.gate per run, else bits (one chain) */
template <Sampling S, class R> struct GatesFor {
  using type = BitGates<S>;
  PL_HD static type of(ChainDataT<R> &) { return type{}; }
};
template <class R> struct GatesFor<Sampling::per_run, R> {
  using type = ArrayGates<R>;
  PL_HD static type of(ChainDataT<R> &c) { return type{c.gate}; }
};

/* With PL_ROW_COPY (the GPU's short chains alone, engines/gpu.py's ROW_COPY), sample_cold reads the
   row whole into an array indexed by constants (registers) before it samples, and writes it back
   whole after: front::advance's loads, many behind a branch on an earlier one, then wait on one
   another (local memory, often beyond L1) where the copy issues all of them at once. The same
   arithmetic on the same values: the same bits. */
#ifndef PL_ROW_COPY
#define PL_ROW_COPY 0
#endif

/* front::sample_row, cold: a call keeps the lanes' code small; it takes values, so that the
   caller's arrays of x, v, f (the GPU's, in registers) are not handed to a call */
PL_HD PL_COLD inline void sample_cold(double *r, unsigned char &phase, double v, double f, double m, double v_prev,
                                      const front::Levels L, const front::Sample s)
{
  if constexpr (PL_ROW_COPY != 0) {
    double row[front::NCOL];
    PL_UNROLL
    for (int k = 0; k < front::NCOL; k++) row[k] = r[k];
    front::sample_row(row, phase, v, f, m, v_prev, L, s);
    PL_UNROLL
    for (int k = 0; k < front::NCOL; k++)
      if (k != front::V_ABS_MAX) r[k] = row[k];    // (advance never writes it: the mark's copy, end_lane's)
  } else {
    front::sample_row(r, phase, v, f, m, v_prev, L, s);
  }
}

/* the front record's sampling of a run's rows (FrontPass's hook), per running lane: the active
   atoms and those that reach the start level now, with the rules of front.h. An atom's gate
   says which per lane, in one comparison for all lanes: its chain's start level while it waits
   (due if v >= gate), -infinity while active (always due), NaN when finished (never). */
template <class R, class Runs, class Gates> struct ChainFront {
  using L = Lanes<R>;
  static constexpr int W = L::W;
  static constexpr Sampling SAMPLING = Gates::SAMPLING;
  static constexpr bool PER_ATOM = SAMPLING != Sampling::per_run;    // step.h's hooks: sample_atom
  int n;
  Runs runs;
  const R *v, *f, *mass;
  const int *slot;                // atom i's mass is mass[slot[i]]
  Gates gate;
  ChainDataT<R> *c;
  front::Sample sample;
  front::LevelsT<R> levels;       // the chain's (ChainDataT::levels), with lanes each lane's
  /* listed (one chain, W = 1, a GPU thread): the rows due at this step, sampled by flush() */
  struct Due {
    int i;
    double v, f, m, v_prev;
  };
  Due *due_now;                   // listed: room for n (an array apart, so that the hook's own
  int due_count = 0;              // state, its gates, stays in registers)
  unsigned long long due_mask = 0;    // masked: the atoms due (BitGates' most atoms: 64)

  /* one chain (W = 1): atom i's row, with its v, f and m at this sample and v_prev at the last one */
  PL_HD void row(int i, double vi, double fi, double m, double v_prev)
  {
    unsigned char &phase = c->phase[i];
    const unsigned char was = phase;
    double *r = c->rec + (long long) i * front::NCOL;
    sample_cold(r, phase, vi, fi, m, v_prev, levels, sample);
    if (was == front::WAITING && phase != front::WAITING) gate.activate(i, 0);
    if (was != front::FINISHED && phase == front::FINISHED) gate.finish(i, 0);
  }
  /* the lanes where atom i's row is due (front::due) */
  PL_HD MaskOf<R> due(int i) const { return v[i] >= gate[i] || gate[i] == -infinity(); }
  /* with lanes: the rows of atom i due in the lanes `go` (each lane's row() at once) */
  PL_HD void lanes(int i, MaskOf<R> go, const R &v_prev)
  {
    R alive = R();
    for (int l = 0; l < W; l++) L::set(alive, l, c->alive[l] ? 1.0 : 0.0);
    go = go && alive != 0.0;
    if (!L::any(go)) return;
    R *r = c->rec + (long long) i * front::NCOL;
    const MaskOf<R> starting = go && gate[i] != -infinity();
    const MaskOf<R> finished = front::advance_lanes<R>(r, go, starting, v[i], starting ? v_prev : r[front::V_PREV],
                                                       f[i] / mass[slot[i]], levels, sample);
    if (L::any(starting || finished)) gate.update(i, starting, finished);
  }
  /* atom i's row in every running lane where it is due (listed: at the next flush) */
  PL_HD void rows(int i, const R &v_prev)
  {
    const MaskOf<R> m = due(i);
    if (!L::any(m)) return;
    if constexpr (SAMPLING == Sampling::listed) {
      if (c->alive[0]) due_now[due_count++] = Due{i, v[i], f[i], mass[slot[i]], v_prev};
    } else if constexpr (SAMPLING == Sampling::masked) {
      static_assert(W == 1, "masked sampling: one chain (a GPU thread)");
      if (!c->alive[0]) return;
      due_mask |= 1ull << i;
      if (gate[i] != -infinity()) c->rec[(long long) i * front::NCOL + front::V_PREV] = v_prev;    // it starts now
    } else if constexpr (W > 1) {
      lanes(i, m, v_prev);
    } else {
      if (c->alive[0]) row(i, v[i], f[i], mass[slot[i]], v_prev);
    }
  }
  /* listed, masked: the rows due since the last flush */
  PL_HD void flush()
  {
    if constexpr (SAMPLING == Sampling::listed) {
      for (int k = 0; k < due_count; k++) {
        const Due d = due_now[k];
        row(d.i, d.v, d.f, d.m, d.v_prev);
      }
      due_count = 0;
    } else if constexpr (SAMPLING == Sampling::masked) {
      if (!due_mask) return;
      PL_UNROLL
      for (int i = 0; i < Runs::n; i++)
        if (due_mask >> i & 1)
          row(i, v[i], f[i], mass[slot[i]], c->rec[(long long) i * front::NCOL + front::V_PREV]);
      due_mask = 0;
    }
  }
  /* PER_ATOM: atom i just kicked, its velocity before the step v_before */
  PL_HD void sample_atom(int i, const R &v_before) { rows(i, v_before); }
  /* starting: the lanes where an atom of run b reached its gate at this step, which an active
     atom's gate (-infinity) does at every step (step.h) */
  PL_HD void sample_block(int b, const R *v_before, MaskOf<R> starting)
  {
    if (!L::any(starting)) return;
    const Run run = runs[b];
    PL_UNROLL
    for (int i = run.first; i <= run.last; i++) rows(i, v_before[i - run.first]);
  }
};

/* every bond's separation: the smallest (a contact if <= 0) */
template <class R> PL_HD inline R smallest_gap(const R *x, int n)
{
  R g = Lanes<R>::splat(infinity());
  PL_UNROLL
  for (int i = 0; i + 1 < n; i++) g = x[i + 1] - x[i] < g ? x[i + 1] - x[i] : g;
  return g;
}

/* Who runs a chain: Solo, one thread (or one set of lanes) the whole chain, its atoms 0 .. n - 1
   (the fix for a chain it owns alone, the host engine, the GPU's short chains). The GPU's long
   chains run one block per chain (engine_gpu.cu's BlockTeam): each thread its own segment, a
   chain of its own whose end atoms are the real ends, or ghosts, its neighbours' edge atoms,
   placed at each step where their drift moved them (as fix lattice/chain's slab edges); the
   decisions to end are the whole block's. */
struct Solo {
  PL_HD bool owns_first() const { return true; }     // atom 0 (the impactor) is this thread's
  PL_HD bool owns_last() const { return true; }      // and atom n - 1 (the far end)
  /* the lanes where any thread of the team has `m` (a thread alone: its own) */
  template <class M> PL_HD M either(M m) const { return m; }
  /* this step's ghosts into x (their positions after the drift), from the neighbours' publish */
  template <class R> PL_HD void ghosts(R *, int, long long) const {}
  /* this thread's edge atoms' positions after the drift of step `next`, for its neighbours */
  template <class R> PL_HD void publish(const R *, const R *, const R *, const MassesT<R> &, double, int,
                                        long long) const {}
};

/* lane l's chain ends with `status` after c.end_step: its outcome, its record's largest |v|, and
   with lanes its x, v kept in x_end, v_end (the lane runs on, unread) */
template <bool FRONT, class R, class Team>
PL_HD inline void end_lane(const ChainSetup &S, ChainDataT<R> &c, const R &work_done, long long step, int l,
                           int status, const Team &team)
{
  using L = Lanes<R>;
  const int n = S.n;
  c.alive[l] = false;
  c.status[l] = status;
  c.end_step[l] = step;
  c.work[l] = L::get(work_done, l);
  if (c.x_end)
    PL_UNROLL
    for (int i = 0; i < n; i++) c.x_end[l * n + i] = L::get(c.x[i], l), c.v_end[l * n + i] = L::get(c.v[i], l);
  if (FRONT)
    PL_UNROLL
    for (int i = team.owns_first() ? 0 : 1; i < (team.owns_last() ? n : n - 1); i++)
      L::set(c.rec[(long long) i * front::NCOL + front::V_ABS_MAX], l, L::get(c.mark[i], l));
}

/* the running lanes whose gaps went bad end (a contact or out of range); true if none runs on */
template <bool FRONT, class R, class Team>
PL_HD inline bool end_bad(const ChainSetup &S, ChainDataT<R> &c, const GapsT<R> &gaps, const R &work_done,
                          long long step, const Team &team)
{
  const MaskOf<R> bad = team.either(gaps.bad(S.range_lo, S.range_hi));
  bool running = false;
  if (Lanes<R>::any(bad)) {
    const MaskOf<R> contact = team.either(smallest_gap(c.x, S.n) <= 0.0);
    for (int l = 0; l < Lanes<R>::W; l++)
      if (c.alive[l] && Lanes<R>::on(bad, l))
        end_lane<FRONT>(S, c, work_done, step, l, Lanes<R>::on(contact, l) ? CONTACT : OUT_OF_RANGE, team);
  }
  for (int l = 0; l < Lanes<R>::W; l++) running = running || c.alive[l];
  return !running;
}

/* every running lane ends with `status` */
template <bool FRONT, class R, class Team>
PL_HD inline void end_all(const ChainSetup &S, ChainDataT<R> &c, const R &work_done, long long step, int status,
                          const Team &team)
{
  for (int l = 0; l < Lanes<R>::W; l++)
    if (c.alive[l]) end_lane<FRONT>(S, c, work_done, step, l, status, team);
}

/* SAMPLING: how the front record's rows are sampled (per_atom and listed: one chain, W = 1, its
   start gates as bits; per_run: in c.gate); team: who runs the chain (Solo: this thread alone;
   else c is this thread's segment, S.n its atoms with the ghosts) */
template <bool FRICTION, bool FRONT, class Runs = ChainRuns, Sampling SAMPLING = Sampling::per_run, class LawT, class R,
          class Team = Solo>
PL_HD void run_chain(const LawT law, const ChainSetup &S, ChainDataT<R> &c, const Team team = Team())
{
  using L = Lanes<R>;
  // the runs of free atoms 1 .. n - 2, each at most S.block long (FixedRuns: n and they are constants)
  const Runs runs = Runs::of(S.n, S.block);
  const int n = runs.n, nruns = runs.count();
  R *x = c.x, *v = c.v, *f = c.f;
  const MassesT<R> ms{c.index, c.dtfm, c.mass, c.weight, false, c.dtm};
  const R x0 = x[0];
  double u, ud;
  CoulombWorkT<R> work;
  R work_done = R(), work_pending = R();

  // ---- setup: the impactor's velocity at t = 0, the forces for the first half kick (friction
  // for a kick of dt/2, from v(0)), the ends, the record's first sample
  S.drive.at_step(0, S.dt, u, ud);
  v[0] = L::splat(ud);
  GapsT<R> gaps;
  {
    R left = law(x[1] - x[0]);
    gaps.add(x[1] - x[0]);
    PL_UNROLL
    for (int i = 1; i <= n - 2; i++) {
      const R r = x[i + 1] - x[i];
      gaps.add(r);
      const R right = law(r);
      f[i] = total_force<FRICTION>(left, right, ms.slot[i], ms, S.fr, 0.5 * S.dt, v[i], work);
      left = right;
    }
  }
  if (FRICTION) work.settle(0.5 * S.dt, true, work_done, work_pending), work = CoulombWorkT<R>();
  f[0] = -law(x[1] - x[0]);
  f[n - 1] = L::splat(0.0);
  using Gates = typename GatesFor<SAMPLING, R>::type;
  using Hook = ChainFront<R, Runs, Gates>;
  typename Hook::Due due_now[SAMPLING == Sampling::listed ? 64 : 1];    // BitGates' most atoms
  Hook hook{n, runs, v, f, c.mass, c.index, GatesFor<SAMPLING, R>::of(c), &c, front::Sample{0.0, 0.0, true},
            lane_levels<R>(c.levels), due_now};
  const int own_first = team.owns_first() ? 0 : 1, own_last = team.owns_last() ? n - 1 : n - 2;
  if (FRONT) {
    PL_UNROLL
    for (int i = own_first; i <= own_last; i++) {
      c.mark[i] = front::mark_max(c.mark[i], v[i]);
      for (int l = 0; l < L::W; l++) hook.gate.wait(i, l, c.levels[l].start);
      hook.rows(i, L::splat(quiet_nan()));
    }
    hook.flush();
  }
  team.publish(x, v, f, ms, S.dt, n, 1);
  if (end_bad<FRONT>(S, c, gaps, work_done, 0, team)) return;
  const FrontPass<Hook, R, decltype(hook.gate.view())> pass{c.mark, hook.gate.view(), &hook};
  for (long long step = 1; step <= S.steps; step++) {
    const R v_impactor = v[0];
    // the impactor on the drive's path (the fix's initial_integrate)
    if (!S.drive.at_step(step, S.dt, u, ud)) return end_all<FRONT>(S, c, work_done, step - 1, DRIVE_ENDED, team);
    x[0] = x0 + u;
    v[0] = L::splat(ud);
    team.ghosts(x, n, step);
    hook.sample = front::Sample{0.0 + static_cast<double>(step) * S.dt, hook.sample.t, false};
    GapsT<R> g;
    step_runs<FRICTION, FRONT>(law, runs, nruns, x, v, f, ms, S.fr, S.dt, &work, c.scratch, S.block, pass, g);
    if (FRICTION) work.settle(S.dt, false, work_done, work_pending), work = CoulombWorkT<R>();
    f[0] = -law(x[1] - x[0]);
    f[n - 1] = L::splat(0.0);
    if (FRONT) {
      if (team.owns_first()) {
        c.mark[0] = front::mark_max(c.mark[0], v[0]);
        hook.rows(0, v_impactor);
      }
      if (team.owns_last()) {
        c.mark[n - 1] = front::mark_max(c.mark[n - 1], v[n - 1]);
        hook.rows(n - 1, v[n - 1]);
      }
      hook.flush();
    }
    team.publish(x, v, f, ms, S.dt, n, step + 1);
    if (end_bad<FRONT>(S, c, g, work_done, step, team)) return;
  }
  end_all<FRONT>(S, c, work_done, S.steps, FINISHED, team);
}
}    // namespace detail

/* f(law, friction, record): the batch's law as its value type (Law::dispatch), whether it has
   friction and a front record as detail::Bool */
template <class F> PL_HD inline void dispatch_chain(const ChainSetup &S, F &&f)
{
  S.law.dispatch([&](auto law) {
    if (S.friction) {
      if (S.record) f(law, detail::Bool<true>(), detail::Bool<true>());
      else f(law, detail::Bool<true>(), detail::Bool<false>());
    } else {
      if (S.record) f(law, detail::Bool<false>(), detail::Bool<true>());
      else f(law, detail::Bool<false>(), detail::Bool<false>());
    }
  });
}

/* Run one chain, or with lanes W chains (the running lanes: c.alive): c.x, c.v hold the initial
   state (c.x[0] the impactor's position at t = 0), the record its NaN rows and marks (one chain:
   its WAITING phases; lanes keep theirs in the start gates, which run_chain sets); on return each lane's final state (with lanes in x_end, v_end), record (the rows'
   largest |v| refreshed), friction work, last step and status. */
template <class R> PL_HD inline void run_chain(const ChainSetup &S, ChainDataT<R> &c)
{
  dispatch_chain(S, [&](auto law, auto friction, auto record) {
    detail::run_chain<decltype(friction)::value, decltype(record)::value>(law, S, c);
  });
}

}    // namespace pl_kernel

#endif
