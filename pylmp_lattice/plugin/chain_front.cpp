/* fix lattice/chain: the front record (fix lattice/front) sampled inside the owned pass, with
   the record's own per-atom routine (FixLatticeFront::sample_row). Part of pylmp_lattice, GPL-2.0. */

#include "fix_lattice_chain.h"

#include "atom.h"
#include "fix_lattice_front.h"

#include <algorithm>
#include <cmath>

using namespace LAMMPS_NS;
using namespace FrontRecord;

/* block b's active atoms and, if `starting`, those that start now; v_before: the block's
   velocities of the previous step (the hot part, mark_max, is done in the pass) */

void FixLatticeChain::sample_front_block(int b, const double *v_before, bool starting)
{
  const Run &run = runs[b];
  BlockFront &bf = block_front[b];
  const int *type = slots();
  const Levels &L = front->chain_levels(run.chain);    // a block lies in one chain
  const unsigned char *phase = front->phase;
  auto sample = [&](int i) {
    front->sample_row(i, vs[i], fs[i], mass_of[type[i]], v_before[i - run.first], L);
  };
  if (bf.active) {
    for (int i = bf.lo; i <= bf.hi; i++)
      if (phase[i] == ACTIVE) sample(i);
  }
  if (starting) {    // rare: each atom starts once
    for (int i = run.first; i <= run.last; i++)
      if (vs[i] >= start_gate[i]) {
        sample(i);
        start_gate[i] = INFINITY;
        bf.lo = bf.active ? std::min(bf.lo, i) : i;
        bf.hi = bf.active ? std::max(bf.hi, i) : i;
        bf.active++;    // counted for the span; recounted below
      }
  }
  // the span shrinks to the atoms still active
  int active = 0;
  for (int i = bf.lo; i <= bf.hi && bf.active; i++) active += phase[i] == ACTIVE;
  bf.active = active;
  if (!active) return;
  while (phase[bf.lo] != ACTIVE) bf.lo++;
  while (phase[bf.hi] != ACTIVE) bf.hi--;
}

/* the active atoms of each block, every atom's start gate, and the held ends whose samples may
   still change the record: while the fix owns the state a held end keeps its velocity, so one
   that waits below the start level (or has finished) with its largest |v| already at least |v|
   gives the same record at every step */

void FixLatticeChain::summarise_front()
{
  held_moving.clear();
  for (const End &e : held) {
    const int i = e.i;
    const unsigned char phase = front->phase[i];
    const double mark = front->mark[i];
    const bool quiet = mark_max(mark, vs[i]) == mark &&
        (phase == FINISHED || (phase == WAITING && !(vs[i] >= front->chain_levels(e.chain).start)));
    if (!quiet) held_moving.push_back(e);
  }
  block_front.assign(runs.size(), BlockFront{0, 0, -1});
  start_gate.assign(atom->nlocal, INFINITY);
  for (size_t b = 0; b < runs.size(); b++) {
    BlockFront &bf = block_front[b];
    const double start = front->chain_levels(runs[b].chain).start;
    for (int i = runs[b].first; i <= runs[b].last; i++) {
      if (front->phase[i] == WAITING) start_gate[i] = start;
      if (front->phase[i] != ACTIVE) continue;
      if (!bf.active++) bf.lo = i;
      bf.hi = i;
    }
  }
  front_summarised = true;
}

/* the chain ends, hot part included (the impactor's previous velocity was kept in
   initial_integrate; a held end's does not change, and so only those in held_moving can change
   the record) */

void FixLatticeChain::sample_front_ends()
{
  const int *type = slots();
  auto sample = [&](const End &e, double v_prev) {
    const int i = e.i;
    front->mark[i] = mark_max(front->mark[i], vs[i]);
    front->sample_row(i, vs[i], fs[i], mass_of[type[i]], v_prev, front->chain_levels(e.chain));
  };
  for (const End &e : impactors) sample(e, impactor_v[e.chain]);
  for (const End &e : held_moving) sample(e, vs[e.i]);
}
