/* fix lattice/chain: the front record (fix lattice/front) sampled inside the owned pass, with
   the record's own per-atom routine (FixLatticeFront::sample_row). Part of pylmp_lattice, GPL-2.0. */

#include "fix_lattice_chain.h"

#include "atom.h"
#include "fix_lattice_front.h"

using namespace LAMMPS_NS;
using namespace FrontRecord;

/* block b's atoms that start now or are active, and the block's counts; v_before: their
   velocities of the previous step (the hot part, mark_max, is done in the pass) */

void FixLatticeChain::sample_front_block(int b, const double *v_before)
{
  const Run &run = runs[b];
  BlockFront &bf = block_front[b];
  const int *type = slots();
  const Levels &L = front->chain_levels(run.chain);    // a block lies in one chain
  for (int i = run.first, k = 0; i <= run.last; i++, k++) {
    const unsigned char before = front->sample_row(i, vs[i], fs[i], mass_of[type[i]], v_before[k], L);
    const unsigned char now = front->phase[i];
    bf.waiting -= before == WAITING && now != WAITING;
    bf.active += (now == ACTIVE) - (before == ACTIVE);
  }
}

/* the active and waiting atoms of each block */

void FixLatticeChain::summarise_front()
{
  block_front.assign(runs.size(), BlockFront{0, 0});
  for (size_t b = 0; b < runs.size(); b++)
    for (int i = runs[b].first; i <= runs[b].last; i++) {
      block_front[b].active += front->phase[i] == ACTIVE;
      block_front[b].waiting += front->phase[i] == WAITING;
    }
}

/* the chain ends, hot part included (the impactor's previous velocity was kept in
   initial_integrate; a held end's does not change) */

void FixLatticeChain::sample_front_ends()
{
  const int *type = slots();
  auto sample = [&](const End &e, double v_prev) {
    const int i = e.i;
    front->mark[i] = mark_max(front->mark[i], vs[i]);
    front->sample_row(i, vs[i], fs[i], mass_of[type[i]], v_prev, front->chain_levels(e.chain));
  };
  for (const End &e : impactors) sample(e, impactor_v[e.chain]);
  for (const End &e : held) sample(e, vs[e.i]);
}
