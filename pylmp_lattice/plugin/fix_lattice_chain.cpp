/* ----------------------------------------------------------------------
   fix lattice/chain: the whole time step of 1D nearest-neighbour chains
   Part of pylmp_lattice, GPL-2.0. Compiled as a LAMMPS plugin.

Why a fix
   A bond style would still leave LAMMPS's per-bond machinery (bond lists rebuilt at every
   reneighbouring, one bond at a time through its table, energy/virial tallies) and the
   separate passes of fix nve, fix move, fix setforce and the friction fix. A run style would
   replace Verlet, but the wheel ships no integrate.h/verlet.h, so its ABI would have to be
   restated by hand, and every other fix and output would depend on our copy of Verlet. A
   fix under the stock Verlet keeps all of LAMMPS (dumps, thermo, computes, other fixes, MPI
   exchange) and can still do the chain's work in one or two passes over memory per step.

How a step is done
   In general (other fixes that run during the steps), in LAMMPS's arrays:
     initial_integrate: v += dt/2m f, x += dt v for the free atoms; impactors placed;
     post_force: every bond force once from the law, friction, f written, and (when no
       other fix uses the forces after this one) the second half kick in the same pass.
   With no pair style and no bonds LAMMPS builds no neighbour lists; what it still does per
   step is force_clear (a memset of f) and, on several ranks, the ghost positions' forward
   communication. The deck reneighbours only every 100 steps (`neigh_modify every 100
   check no`: exchange and borders, which is all this fix needs) and sets `newton off`
   (no reverse communication of forces).

   Owning the state. When nothing else can look at the atoms between two outputs (no pair or
   kspace style, no sorting, no distance check for reneighbouring, ranks only along x, and no
   other fix that runs during the steps except one fix lattice/front of group all), the fix
   keeps x, v and f along x in its own contiguous arrays (structure of arrays; per-atom
   arrays that move with their atoms between ranks) and does the whole
   step in ONE pass over them: block by block (BLOCK atoms, in L1, in ID order), the first half kick and
   drift of the next block, then the bond forces and second half kick of this one (so both
   neighbours of a block have moved when its forces are due), in the same operations as the
   general path, so both give the same bits. Why: LAMMPS's x, v, f are 3-vectors, so a pass
   over them moves three times the bytes of the chain's own data; at 10^6 atoms they no
   longer fit the last-level cache and the step is memory-bound. The atom arrays are written
   from the fix's arrays exactly when something may read them: at every output step
   (output->next, before the dumps and thermo of that step; f along y and z is LAMMPS's
   cleared zero), x before every reneighbouring (pre_exchange: the box and exchange see the
   positions of the last step, as in the general path's drift-later order), and at the end
   of every run (post_run), so that dumps, thermo, computes and later commands see what
   they see on the general path. The fix's own energy and gap read its arrays. The front
   record (fix lattice/front) is then sampled inside the same pass, with the rules of
   the chain kernel's front rules (kernel/front.h), while the block is in L1: per atom, in a vectorised loop after the block's
   kicks, one read and write of its largest |v| and one comparison with its start gate (its
   chain's start level while it waits, else infinity); the record row only for the atoms that
   start now and the block's active atoms (a span of local indices kept per block, about as
   long as their number: they follow the front), never a scan of the block's other atoms; a
   held end only while its sample can change the record (it keeps its velocity while the fix
   owns the state).

   Owning the state on several ranks. A batch of chains is split by whole chains (`processors
   1 * 1`: the chains are stacked in y), so a rank reads no other rank's atoms. One chain is
   split into slabs: each rank owns the atoms of its slab of x (`processors * 1 1`). The only values it needs from another rank are the positions of the atoms just
   across its slab edges (one per chain and edge), at the current step, before its pass. So at
   every step each rank first computes the new positions of its own edge atoms (the same
   operations as the drift in the pass, so the same bits), sends them to the rank left and
   right in x and receives theirs (two MPI_Sendrecv of a few doubles), then does its pass.
   LAMMPS's own ghost communication of 3-vectors is not read. Which atoms go where is agreed
   at every reneighbouring (by atom ID with both neighbours); a chain whose next atom across
   an edge is not on the neighbouring rank (a slab narrower than a gap: too many ranks for the
   chain) makes the fix work in the atom arrays instead (at setup; an error during a run).

   Clearing the forces. Verlet clears f (a memset of 3 doubles per atom) at every step, which
   is as much memory traffic as the owned step itself. This fix sets every force it needs, so
   pylmp_lattice decks ask LAMMPS to clear only the atoms of an empty group (`group none
   empty`, `atom_modify first none`, `neigh_modify ... include none`, LAMMPS's own option for
   force_clear), and the fix then clears f itself, as force_clear would, at the setup and at
   every step it does not own the state (when other fixes may add forces). Pair and kspace
   styles, which that option would leave without atoms, are refused with it.

Syntax
   fix ID all lattice/chain law args impactor args keyword args ...

   law args = power K b q | linear k r_free | table file keyword
     power: F(r) = K / (r + b)^q, q > 1 (integer q <= 8 by multiplications, else pow)
     (kernel/law.h, read by force_law.h; fix lattice/friction reads its analytic laws with the same code)
     linear: F(r) = k (r_free - r)
     table: section `keyword` of a bond_style table file (N n FP lo hi; rows i r U F on a
       uniform grid), interpolated by its clamped cubic spline, as bond_style table spline
   impactor args = constant V | ramp V T | sine V T | rest |
                   measured file path column u|v after hold|stop
     the motions of impactor_drive.h (shared with fix lattice/impactor):
     constant: u = V t; ramp: v rises linearly to V over T, then constant;
     sine: v = V sin(pi t / T) for t < T, then at rest; rest: held in place;
     measured: the spline of a series (see fix lattice/impactor's header)
   keywords:
     length n = atoms per chain (default: all atoms, one chain)
     range lo hi = separations allowed (distance units); beyond them the run stops with
       an error (default 0 and infinity; pylmp_lattice passes the table's range)
     friction mu p g = Coulomb friction on the free atoms, as fix lattice/friction

Description
   Atom IDs name the chains: chain c (c = 0, 1, ...) holds IDs c n + 1 .. c n + n in order
   along x. Its first atom is the impactor, moved along x by the prescribed motion from
   where it was when the fix was defined (time zero then); its last is held (not moved,
   its force set to zero). The other atoms are free: atom k feels F(r_{k-1}) - F(r_k),
   r_k = x_{k+1} - x_k, and the friction, and is integrated by velocity Verlet, with the
   same operations in the same order as fix nve, so the results equal the stock styles'
   to their table's interpolation error (a table law: to round-off). Separate chains
   (replicas) do not interact; their atoms may sit anywhere in y and z (only x is used).
   At the end of each step x, v, f hold what they hold on the stock path: f of a free
   atom is its total force along x, friction included; of an impactor the chain's push
   on it; of a held atom zero.

   Friction: the limit L = mu (m g + p (F_{k-1} + F_k)) and the exact stick-slip kick of
   fix lattice/friction (kernel/coulomb.h), with the same accounting of the work.

   Contacts: every separation is checked at every step, in the force pass. If one is
   <= 0 the fix prints, on the step it happens,
       CONTACT: magnets I and J gap G m at t = T s
   for the most closed pair (IDs I, J; G the signed gap), and stops the run after that
   step (like fix halt). A separation outside `range` stops the run with an error.

   Parallel: atoms are owned by the rank of their subdomain and the neighbours of the
   ends of a rank's runs are ghosts, which needs comm_modify cutoff at least the longest
   separation (the range check guarantees it when the cutoff exceeds `range` hi). Every
   bond's force is computed from the same two x in the same order on every rank, so 1 and
   several ranks, owning the state or not, give bit-identical trajectories (thermo sums
   differ in their last bits).

Output
   Global scalar: potential energy of all bonds (energy units; with fix_modify energy
   yes it is part of pe and etotal). Global vector: [1] friction work done so far
   (extensive), [2] the smallest separation (intensive), [3 + c] chain c's friction work
   (c = 0 .. chains - 1, extensive; a chain's equals a one-chain run's bit for bit on one rank).

   fix_modify ID write_work FILE
     writes every chain's friction work so far (vector entries 3 + c; energy units, J with
     units si), one line per chain in
     chain order with 17 significant digits (so it reads back to the same double), to FILE
     (replaced), at once: one command after a run of many chains, where a loop over
     f_ID[3 + c] would be one `print` (and one re-reading of the input) per chain.

Restrictions
   Group all, no periodic x, an atom map, per-type or per-atom masses (with per-atom masses,
   rmass, the same bits as types of those masses), units with ftm2v, not rRESPA.
   Other fixes may add forces; the integration of the chain atoms must be this fix's.
------------------------------------------------------------------------- */

#include "fix_lattice_chain.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "fix_lattice_front.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neighbor.h"
#include "output.h"
#include "timer.h"
#include "update.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>

using namespace LAMMPS_NS;
using namespace FixConst;

FixLatticeChain::FixLatticeChain(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), length(0), nchains(0), range_lo(0.0),
    range_hi(std::numeric_limits<double>::infinity()), friction(false), fused(false), own_allowed(false), own(false), clear_forces(false), front(nullptr),
    drive_u(0.0), drive_ud(0.0), xs(nullptr), vs(nullptr), fs(nullptr), nmax_state(0),
    in_order(false), edges_ok(false), energy_step(-1),
    pe_cached(0.0), gap_cached(0.0), contact_step(-1), pass_cpu(0.0), exchange_wall(0.0),
    exchange_min(0.0), owned_steps(0)
{
  if (igroup != 0) error->all(FLERR, "Fix lattice/chain must be defined for group all");
  bool have_law = false, have_impactor = false;
  for (int iarg = 3; iarg < narg;) {
    const std::string key = arg[iarg];
    if (key == "law") {
      iarg = law.parse(lmp, narg, arg, iarg + 1, "Fix lattice/chain");
      have_law = true;
    } else if (key == "impactor") {
      iarg = drive.parse(lmp, narg, arg, iarg + 1, "Fix lattice/chain");
      have_impactor = true;
    } else if (key == "length") {
      if (iarg + 1 >= narg) utils::missing_cmd_args(FLERR, "fix lattice/chain length", error);
      length = utils::bnumeric(FLERR, arg[iarg + 1], false, lmp);
      iarg += 2;
    } else if (key == "range") {
      if (iarg + 2 >= narg) utils::missing_cmd_args(FLERR, "fix lattice/chain range", error);
      range_lo = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      range_hi = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
      if (range_lo < 0.0 || range_hi <= range_lo)
        error->all(FLERR, "Fix lattice/chain: range needs 0 <= lo < hi");
      iarg += 3;
    } else if (key == "friction") {
      if (iarg + 3 >= narg) utils::missing_cmd_args(FLERR, "fix lattice/chain friction", error);
      friction = true;
      fr.mu = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      fr.p = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
      fr.g = utils::numeric(FLERR, arg[iarg + 3], false, lmp);
      if (fr.mu < 0.0 || fr.p < 0.0 || fr.g < 0.0)
        error->all(FLERR, "Fix lattice/chain: friction needs mu, p, g >= 0");
      iarg += 4;
    } else
      error->all(FLERR, "Fix lattice/chain: unknown keyword '{}'", key);
  }
  if (!have_law || !have_impactor)
    error->all(FLERR, "Fix lattice/chain: both 'law' and 'impactor' are required");
  if (length == 0) length = atom->natoms;
  if (length < 3 || atom->natoms % length)
    error->all(FLERR, "Fix lattice/chain: length {} must be >= 3 and divide the {} atoms", length,
               atom->natoms);
  nchains = atom->natoms / length;
  work_done.assign(nchains, 0.0);
  work_pending.assign(nchains, 0.0);
  works.assign(nchains, pl_kernel::CoulombWork());

  // each chain's impactor position now: its owner contributes it, every rank keeps all
  time_origin = update->ntimestep;
  std::vector<double> mine(nchains, 0.0);
  x0.assign(nchains, 0.0);
  for (int i = 0; i < atom->nlocal; i++)
    if ((atom->tag[i] - 1) % length == 0) mine[(atom->tag[i] - 1) / length] = atom->x[i][0];
  MPI_Allreduce(mine.data(), x0.data(), nchains, MPI_DOUBLE, MPI_SUM, world);

  scalar_flag = vector_flag = 1;
  size_vector = 2 + nchains;
  global_freq = 1;
  extscalar = 1;
  extvector = -1;
  extlist = new int[size_vector];
  for (int k = 0; k < size_vector; k++) extlist[k] = k != 1;    // all but the separation extensive
  energy_global_flag = 1;
  time_integrate = 1;
  maxexchange = 3;    // xs, vs, fs
  grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
  live++;    // last: a constructor that stops with an error is not counted (nor destroyed)
}

FixLatticeChain::~FixLatticeChain()
{
  if (--live == 0) stop_asked.store(0);    // a stop not taken before the last run ended stops no later one
  atom->delete_callback(id, Atom::GROW);
  memory->destroy(xs);
  memory->destroy(vs);
  memory->destroy(fs);
  delete[] extlist;
}

int FixLatticeChain::setmask()
{
  return INITIAL_INTEGRATE | PRE_FORCE | POST_FORCE | FINAL_INTEGRATE | PRE_EXCHANGE | PRE_NEIGHBOR | POST_RUN;
}

void FixLatticeChain::init()
{
  if (utils::strmatch(update->integrate_style, "^respa"))
    error->all(FLERR, "Fix lattice/chain does not support run_style respa");
  if (atom->map_style == Atom::MAP_NONE)
    error->all(FLERR, "Fix lattice/chain needs an atom map (atom_modify map array)");
  if (!atom->rmass && !atom->mass) error->all(FLERR, "Fix lattice/chain needs masses");
  if (domain->xperiodic) error->all(FLERR, "Fix lattice/chain needs a non-periodic x boundary");

  // per-type masses here; per-atom masses (atom->rmass) at every reneighbouring (build_lists)
  dtf = 0.5 * update->dt * force->ftm2v;
  one_type = !atom->rmass && atom->ntypes == 1;
  if (!atom->rmass) {
    const int ntypes = atom->ntypes;
    dtfm.assign(ntypes + 1, 0.0);
    mass_of.assign(ntypes + 1, 0.0);
    weight.assign(ntypes + 1, 0.0);
    for (int t = 1; t <= ntypes; t++) {
      mass_of[t] = atom->mass[t];
      dtfm[t] = dtf / atom->mass[t];
      weight[t] = atom->mass[t] * fr.g;
    }
  }

  // the second half kick may join the force pass only if no other fix reads or changes
  // the forces after this one or integrates; the fix may own the state (see the header) only
  // if no other fix runs during the steps, except one fix lattice/front of group all
  constexpr int DURING_STEPS = INITIAL_INTEGRATE | POST_INTEGRATE | PRE_EXCHANGE | PRE_NEIGHBOR |
      POST_NEIGHBOR | PRE_FORCE | PRE_REVERSE | POST_FORCE | FINAL_INTEGRATE | END_OF_STEP;
  fused = true;
  bool alone = true;
  front = nullptr;
  for (int j = 0, me = -1; j < modify->nfix; j++) {
    if (modify->fix[j] == this) {
      me = j;
      continue;
    }
    if (modify->fmask[j] & FINAL_INTEGRATE) fused = false;
    if ((modify->fmask[j] & POST_FORCE) && me >= 0) fused = false;
    if (!(modify->fmask[j] & DURING_STEPS)) continue;
    auto *record = dynamic_cast<FixLatticeFront *>(modify->fix[j]);
    if (record && record->igroup == 0 && !front) front = record;
    else alone = false;
  }
  const bool other_forces = force->pair || force->kspace || force->bond || force->angle ||
      force->dihedral || force->improper;
  own_allowed = fused && alone && split_by_slabs_or_chains() && !other_forces && atom->sortfreq == 0 &&
      neighbor->dist_check == 0;
  // LAMMPS clears the forces of `neigh_modify include` group atoms only (see the header)
  clear_forces = neighbor->includegroup != 0;
  if (clear_forces && (force->pair || force->kspace))
    error->all(FLERR, "Fix lattice/chain: neigh_modify include (set by the deck so that the fix clears "
                      "the forces itself) leaves pair and kspace styles without atoms; remove it to use one");
}

/* with neigh_modify include, what Verlet's force_clear would do, unless the fix owns the state
   (then nothing else writes f, whose y and z stay the zero of the setup) */

void FixLatticeChain::setup_pre_force(int /*vflag*/)
{
  if (clear_forces) clear();
}

void FixLatticeChain::pre_force(int /*vflag*/)
{
  if (clear_forces && !own) clear();
}

void FixLatticeChain::clear()
{
  const size_t n = atom->nlocal + (force->newton ? atom->nghost : 0);
  if (n) memset(&atom->f[0][0], 0, 3 * n * sizeof(double));
}

/* the layout of this rank's atoms; neighbours must be owned or ghosts */

void FixLatticeChain::setup_pre_neighbor()
{
  build_lists();
}

/* owning the state: exchange and the box see the positions (of the last step, see the header);
   v and f move with their atoms in the fix's per-atom arrays */

void FixLatticeChain::pre_exchange()
{
  if (!own) return;
  double **x = atom->x;
  for (int i = 0; i < atom->nlocal; i++) x[i][0] = xs[i];
}

void FixLatticeChain::pre_neighbor()
{
  // one rank with no ghosts, every atom where it was: the layout stands (the rebuild and the
  // front record's summary cost about 2% of a 10^4-magnet run at every 100th step)
  if (comm->nprocs == 1 && atom->nghost == 0 && layout_tags.size() == static_cast<size_t>(atom->nlocal) &&
      std::equal(layout_tags.begin(), layout_tags.end(), atom->tag))
    return;
  build_lists();
  if (!own) return;
  front_summarised = false;    // the blocks changed: summarised again at the next sample
  if (!in_order || !edges_ok)    // in_order is this rank's: error->one
    error->one(FLERR, "Fix lattice/chain: an atom's chain neighbour is no longer on this rank or the "
                      "next in x (a slab narrower than a gap, or a chain across a rank); run on fewer ranks");
}

/* the impactors on the drive's path at the current step */

void FixLatticeChain::place_impactors(bool set_x)
{
  const Column x = column(atom->x, xs), v = column(atom->v, vs);
  for (const End &e : impactors) {
    if (set_x) x[e.i] = x0[e.chain] + drive_u;
    v[e.i] = drive_ud;
  }
}

void FixLatticeChain::setup(int /*vflag*/)
{
  energy_step = -1;
  own = false;
  drive.at((update->ntimestep - time_origin) * update->dt, update->dt, drive_u, drive_ud);
  place_impactors(false);
  forces(0.5 * update->dt, true, false);
  // decided once per run
  own = own_allowed && in_order && edges_ok;
  front_summarised = false;    // summarised at the first owned sample, after the record's own setup sample
  if (own) gather();
  pass_cpu = exchange_wall = 0.0;
  exchange_min = std::numeric_limits<double>::infinity();
  owned_steps = 0;
  if (comm->me == 0) {
    const std::string ranks = fmt::format(" on {} rank{}", comm->nprocs, comm->nprocs > 1 ? "s" : "");
    const std::string edges = comm->nprocs == 1 ? ""
        : comm->procgrid[0] == 1 ? ", whole chains on each rank"
                                 : ", slab edges exchanged every step";
    utils::logmesg(lmp, "Fix lattice/chain: {}\n",
                   own ? std::string("owns the state (one pass per step") +
                           (front ? ", front record inside)" : ")") + ranks + edges
                       : std::string("works in the atom arrays") + ranks +
                           (own_allowed ? " (a chain's neighbour across a slab edge is not on the next rank)" : ""));
  }
}

void FixLatticeChain::initial_integrate(int /*vflag*/)
{
  if (own) {
    // the free atoms move in post_force; the impactors' velocities of the last step are the
    // front record's previous samples
    for (const End &e : impactors) impactor_v[e.chain] = vs[e.i];
  } else {
    // restrict: stores to x and v cannot change the fix's members, so nothing is reloaded
    double *__restrict x = atom->x[0];
    double *__restrict v = atom->v[0];
    const double *__restrict f = atom->f[0];
    const int *__restrict type = slots();
    const double *__restrict dtfm_of = dtfm.data();
    const double dtv = update->dt;
    if (one_type) {
      const double h = dtfm_of[1];
      for (const Run &run : runs)
        for (int i = run.first; i <= run.last; i++) {
          v[3 * i] += h * f[3 * i];
          x[3 * i] += dtv * v[3 * i];
        }
    } else {
      for (const Run &run : runs)
        for (int i = run.first; i <= run.last; i++) {
          v[3 * i] += dtfm_of[type[i]] * f[3 * i];
          x[3 * i] += dtv * v[3 * i];
        }
    }
  }
  drive.at((update->ntimestep - time_origin) * update->dt, update->dt, drive_u, drive_ud);
  place_impactors(true);
}

void FixLatticeChain::post_force(int /*vflag*/)
{
  if (own) own_pass();
  else forces(update->dt, false, fused);
}

void FixLatticeChain::final_integrate()
{
  if (!fused) {
    double *__restrict v = atom->v[0];
    const double *__restrict f = atom->f[0];
    const int *__restrict type = slots();
    for (const Run &run : runs)
      for (int i = run.first; i <= run.last; i++) v[3 * i] += dtfm[type[i]] * f[3 * i];
  }
  place_impactors(false);    // the prescribed velocity, whatever other fixes did
}

void FixLatticeChain::post_run()
{
  if (own) {
    scatter();
    if (front) front->set_previous_velocities(vs, 1);
    own = false;
    if (comm->nprocs > 1 && owned_steps > 0) {
      const double mine[3] = {pass_cpu, exchange_wall, exchange_min};
      double most[3];
      MPI_Allreduce(mine, most, 3, MPI_DOUBLE, MPI_MAX, world);
      if (comm->me == 0)
        utils::logmesg(lmp, "Fix lattice/chain: {} owned steps: pass {:.4g} us CPU a step, exchanges {:.4g} us "
                       "wall a step, {:.4g} us at the fastest step (slowest rank each)\n", owned_steps,
                       1e6 * most[0] / owned_steps, 1e6 * most[1] / owned_steps, 1e6 * most[2]);
    }
  }
  if (contact_step >= 0) timer->reset_timeout();
}

/* owning the state: the fix's arrays from the atom arrays and back */

void FixLatticeChain::gather()
{
  impactor_v.assign(nchains, 0.0);
  double **x = atom->x, **v = atom->v, **f = atom->f;
  for (int i = 0; i < atom->nlocal; i++) {
    xs[i] = x[i][0];
    vs[i] = v[i][0];
    fs[i] = f[i][0];
  }
  // the slab-edge neighbours until the first step sends them (thermo at the setup reads them)
  for (int i = atom->nlocal; i < atom->nlocal + atom->nghost; i++) xs[i] = x[i][0];
}

void FixLatticeChain::scatter()
{
  double **x = atom->x, **v = atom->v, **f = atom->f;
  for (int i = 0; i < atom->nlocal; i++) {
    x[i][0] = xs[i];
    v[i][0] = vs[i];
    f[i][0] = fs[i];
  }
}

double FixLatticeChain::compute_scalar()
{
  energies();
  return pe_cached;
}

/* fix_modify ID write_work FILE: each chain's friction work, a line each (see the header) */

int FixLatticeChain::modify_param(int narg, char **arg)
{
  if (strcmp(arg[0], "write_work") != 0) return 0;
  if (narg < 2) utils::missing_cmd_args(FLERR, "fix_modify lattice/chain write_work", error);
  std::vector<double> all(nchains);
  MPI_Allreduce(work_done.data(), all.data(), nchains, MPI_DOUBLE, MPI_SUM, world);
  if (comm->me == 0) {
    FILE *fp = fopen(arg[1], "w");
    if (!fp) error->one(FLERR, "Fix lattice/chain: cannot open {} for write_work: {}", arg[1], utils::getsyserror());
    for (double w : all) fprintf(fp, "%.17g\n", w);
    fclose(fp);
  }
  return 2;
}

double FixLatticeChain::compute_vector(int n)
{
  if (n == 1) {
    energies();
    return gap_cached;
  }
  double mine = 0.0, all;
  if (n == 0)
    for (double w : work_done) mine += w;
  else
    mine = work_done[n - 2];
  MPI_Allreduce(&mine, &all, 1, MPI_DOUBLE, MPI_SUM, world);
  return all;
}
