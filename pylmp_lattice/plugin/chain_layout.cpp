/* fix lattice/chain: where the atoms are (see fix_lattice_chain.h). Part of pylmp_lattice, GPL-2.0.

   Rebuilt at every reneighbouring, on every rank: the blocks of free atoms in ID order, the
   chain ends, and the slab edges, i.e. which of this rank's atoms are read by the ranks left
   and right of it in x and which of their atoms it reads, agreed by atom ID with both. Also
   the fix's own per-atom state (x, v, f along x), which moves with its atoms. */

#include "fix_lattice_chain.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "memory.h"
#include "update.h"

#include <algorithm>

using namespace LAMMPS_NS;

/* each atom's mass slot (see the header) */

const int *FixLatticeChain::slots() const
{
  return atom->rmass ? local_index.data() : atom->type;
}

bool FixLatticeChain::is_free(int i) const
{
  const bigint k = (atom->tag[i] - 1) % length;
  return k != 0 && k != length - 1;
}

/* the layout of this rank's atoms; neighbours must be owned or ghosts */

void FixLatticeChain::build_lists()
{
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  auto neighbour = [&](int i, tagint t) {
    const int j = atom->map(t);
    if (j < 0)
      error->one(FLERR,
                 "Fix lattice/chain: atom {} (neighbour of atom {}) is not on this rank; set "
                 "comm_modify cutoff longer than the longest separation",
                 t, tag[i]);
    return j;
  };
  if (atom->rmass) {    // per-atom masses: the slot tables of this rank's atoms, as init() does per type
    local_index.resize(nlocal);
    dtfm.resize(nlocal);
    mass_of.resize(nlocal);
    weight.resize(nlocal);
    for (int i = 0; i < nlocal; i++) {
      local_index[i] = i;
      mass_of[i] = atom->rmass[i];
      dtfm[i] = dtf / atom->rmass[i];
      weight[i] = atom->rmass[i] * fr.g;
    }
  }
  runs.clear();
  impactors.clear();
  held.clear();
  for (int i = 0; i < nlocal; i++) {
    const tagint t = tag[i];
    const bigint k = (t - 1) % length;
    const int c = (t - 1) / length;
    if (k == 0) {
      impactors.push_back({i, neighbour(i, t + 1), c});
    } else if (k == length - 1) {
      held.push_back({i, neighbour(i, t - 1), c});
    } else if (!runs.empty() && runs.back().last == i - 1 && tag[i - 1] == t - 1) {
      runs.back().last = i;
    } else {
      runs.push_back({i, i, -1, -1, c});
    }
  }
  // blocks of at most BLOCK atoms (one bond per block boundary is computed twice, from the
  // same two positions), in ID order: atoms that arrived from another rank sit at the end of
  // the arrays
  std::vector<Run> blocks;
  for (const Run &run : runs) {
    const int left = neighbour(run.first, tag[run.first] - 1);
    const int right = neighbour(run.last, tag[run.last] + 1);
    for (int first = run.first; first <= run.last; first += BLOCK) {
      const int last = std::min(first + BLOCK - 1, run.last);
      blocks.push_back({first, last, first == run.first ? left : first - 1, last == run.last ? right : last + 1,
                        run.chain});
    }
  }
  std::sort(blocks.begin(), blocks.end(), [&](const Run &a, const Run &b) { return tag[a.first] < tag[b.first]; });
  runs.swap(blocks);
  bond_force.resize(BLOCK + 1);
  scratch.resize(5 * BLOCK + 8);    // the owned step's (kernel/step.h), and a block's positions

  // owning the state, the drift moves block k + 1 before the forces of block k: a free local
  // neighbour of a block must be the end of the block before or the start of the block after
  // it (true in ID order; checked, as the pass depends on it)
  in_order = true;
  for (size_t k = 0; k < runs.size(); k++) {
    const int left = runs[k].left, right = runs[k].right;
    if (left < nlocal && is_free(left) && (k == 0 || left != runs[k - 1].last)) in_order = false;
    if (right < nlocal && is_free(right) && (k + 1 == runs.size() || right != runs[k + 1].first))
      in_order = false;
  }
  find_edges();
  layout_tags.assign(tag, tag + nlocal);
}

/* Several ranks own the state only in a brick of slabs along x (each slab edge has one
   neighbouring rank) or of whole chains stacked along y (no chain crosses a rank). */

bool FixLatticeChain::split_by_slabs_or_chains() const
{
  return comm->nprocs == 1 || (comm->style == Comm::BRICK && comm->procgrid[2] == 1 &&
                               (comm->procgrid[1] == 1 || comm->procgrid[0] == 1));
}

/* The slab edges: each ghost that this rank reads (a neighbour of a block or a chain end) is
   asked for, by ID, from the rank next in x on its side; that rank must own it. With whole
   chains on each rank there is none. */

void FixLatticeChain::find_edges()
{
  for (Edge &e : edges) {
    e.send.clear();
    e.recv.clear();
    e.rank = MPI_PROC_NULL;
  }
  edges_ok = true;
  if (comm->nprocs == 1) return;
  int ok = split_by_slabs_or_chains();
  if (ok) {
    if (comm->myloc[0] > 0) edges[0].rank = comm->procneigh[0][0];
    if (comm->myloc[0] < comm->procgrid[0] - 1) edges[1].rank = comm->procneigh[0][1];
    const int nlocal = atom->nlocal;
    double **x = atom->x;
    auto need = [&](int j) {
      if (j >= nlocal) edges[x[j][0] < domain->sublo[0] ? 0 : 1].recv.push_back(j);
    };
    for (const Run &run : runs) {
      need(run.left);
      need(run.right);
    }
    for (const End &e : impactors) need(e.other);
    for (const End &e : held) need(e.other);
    for (Edge &e : edges) {
      if (!e.recv.empty() && e.rank == MPI_PROC_NULL) ok = 0;    // a neighbour no rank next in x owns
      std::sort(e.recv.begin(), e.recv.end());
      e.recv.erase(std::unique(e.recv.begin(), e.recv.end()), e.recv.end());
    }
    // to the rank on side d the IDs wanted from it; from the rank on the other side the IDs
    // it wants from this rank, which are what this rank sends it
    for (int d = 0; d < 2; d++) {
      Edge &to = edges[d], &from = edges[1 - d];
      std::vector<tagint> want;
      for (int j : to.recv) want.push_back(atom->tag[j]);
      int nwant = want.size(), ngive = 0;
      MPI_Sendrecv(&nwant, 1, MPI_INT, to.rank, 0, &ngive, 1, MPI_INT, from.rank, 0, world, MPI_STATUS_IGNORE);
      std::vector<tagint> give(ngive);
      MPI_Sendrecv(want.data(), nwant, MPI_LMP_TAGINT, to.rank, 0, give.data(), ngive, MPI_LMP_TAGINT,
                   from.rank, 0, world, MPI_STATUS_IGNORE);
      for (tagint t : give) {
        const int j = atom->map(t);
        if (j < 0 || j >= nlocal) ok = 0;
        from.send.push_back(j);
      }
    }
  }
  int all = 0;
  MPI_Allreduce(&ok, &all, 1, MPI_INT, MPI_MIN, world);
  edges_ok = all;
  for (Edge &e : edges) {
    e.out.resize(e.send.size());
    e.in.resize(e.recv.size());
  }
}

/* Owning the state on several ranks, before the pass: this step's positions of the atoms other
   ranks read (a free atom's drift as the pass will do it, bit for bit; an end is placed
   already), sent; the neighbours' received into the ghost entries of xs. */

void FixLatticeChain::send_edges()
{
  const double dtv = update->dt;
  const int *type = slots();
  for (Edge &e : edges)
    for (size_t k = 0; k < e.send.size(); k++) {
      const int j = e.send[k];
      e.out[k] = is_free(j) ? xs[j] + dtv * (vs[j] + dtfm[type[j]] * fs[j]) : xs[j];
    }
  for (int d = 0; d < 2; d++) {
    Edge &to = edges[d], &from = edges[1 - d];
    MPI_Sendrecv(to.out.data(), to.out.size(), MPI_DOUBLE, to.rank, 1, from.in.data(), from.in.size(),
                 MPI_DOUBLE, from.rank, 1, world, MPI_STATUS_IGNORE);
  }
  for (Edge &e : edges)
    for (size_t k = 0; k < e.recv.size(); k++) xs[e.recv[k]] = e.in[k];
}

/* the fix's per-atom state, moved with its atoms */

double FixLatticeChain::memory_usage()
{
  return 3.0 * nmax_state * sizeof(double);
}

void FixLatticeChain::grow_arrays(int nmax)
{
  memory->grow(xs, nmax, "lattice/chain:xs");
  memory->grow(vs, nmax, "lattice/chain:vs");
  memory->grow(fs, nmax, "lattice/chain:fs");
  nmax_state = nmax;
}

void FixLatticeChain::copy_arrays(int i, int j, int)
{
  xs[j] = xs[i];
  vs[j] = vs[i];
  fs[j] = fs[i];
}

int FixLatticeChain::pack_exchange(int i, double *buf)
{
  buf[0] = xs[i];
  buf[1] = vs[i];
  buf[2] = fs[i];
  return 3;
}

int FixLatticeChain::unpack_exchange(int nlocal, double *buf)
{
  xs[nlocal] = buf[0];
  vs[nlocal] = buf[1];
  fs[nlocal] = buf[2];
  return 3;
}
