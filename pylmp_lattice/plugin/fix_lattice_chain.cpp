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
   In general (several ranks, or other fixes that run during the steps), in LAMMPS's arrays:
     initial_integrate: v += dt/2m f, x += dt v for the free atoms; impactors placed;
     post_force: every bond force once from the law, friction, f written, and (when no
       other fix uses the forces after this one) the second half kick in the same pass.
   With no pair style and no bonds LAMMPS builds no neighbour lists; what it still does per
   step is force_clear (a memset of f) and, on several ranks, the ghost positions' forward
   communication. The deck reneighbours only every 100 steps (`neigh_modify every 100
   check no`: exchange and borders, which is all this fix needs) and sets `newton off`
   (no reverse communication of forces).

   Owning the state. When nothing else can look at the atoms between two outputs (one rank,
   no pair or kspace style, no sorting, no distance check for reneighbouring, and no other
   fix that runs during the steps except one fix lattice/front of group all), the fix keeps
   x, v and f along x in its own contiguous arrays (structure of arrays) and does the whole
   step in ONE pass over them: block by block (BLOCK atoms, in L1), the first half kick and
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
   front_rules.h, where v and f are already in registers: per atom one read and write of its
   largest |v|; the record row only for the few atoms at the front (per block counts of the
   atoms that are active or still wait for the start level say where to look).

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
     power: F(r) = K / (r + b)^q (integer q <= 8 by multiplications, else pow)
     linear: F(r) = k (r_free - r)
     table: section `keyword` of a bond_style table file (N n FP lo hi; rows i r U F on a
       uniform grid), interpolated by its clamped cubic spline, as bond_style table spline
   impactor args = constant V | ramp V T | sine V T | rest |
                   measured file path column u|v after hold|stop
     constant: u = V t; ramp: v rises linearly to V over T, then constant;
     sine: v = V sin(pi t / T) for t < T, then at rest; rest: held in place;
     measured: the spline of a series, exactly as fix lattice/piston (see its header)
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
   fix lattice/friction (coulomb.h), with the same accounting of the work.

   Contacts: every separation is checked at every step, in the force pass. If one is
   <= 0 the fix prints, on the step it happens,
       CONTACT: magnets I and J gap G m at t = T s
   for the most closed pair (IDs I, J; G the signed gap), and stops the run after that
   step (like fix halt). A separation outside `range` stops the run with an error.

   Parallel: atoms are owned by the rank of their subdomain and the neighbours of the
   ends of a rank's runs are ghosts, which needs comm_modify cutoff at least the longest
   separation (the range check guarantees it when the cutoff exceeds `range` hi). Every
   bond's force is computed from the same two x in the same order on every rank, so 1 and
   several ranks give bit-identical trajectories (thermo sums differ in their last bits).

Output
   Global scalar: potential energy of all bonds (energy units; with fix_modify energy
   yes it is part of pe and etotal). Global vector: [1] friction work done so far
   (extensive), [2] the smallest separation (intensive).

Restrictions
   Group all, no periodic x, an atom map, per-type masses, units with ftm2v, not rRESPA.
   Other fixes may add forces; the integration of the chain atoms must be this fix's.
------------------------------------------------------------------------- */

#include "fix_lattice_chain.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "fix_lattice_front.h"
#include "force.h"
#include "modify.h"
#include "neighbor.h"
#include "output.h"
#include "timer.h"
#include "update.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {
// runs of at most BLOCK atoms, so that their bond forces (and, owning the state, the velocities
// between the kicks) stay in the L1 cache between the loops that compute and use them
constexpr int BLOCK = 256;
}    // namespace

FixLatticeChain::FixLatticeChain(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), length(0), nchains(0), range_lo(0.0),
    range_hi(std::numeric_limits<double>::infinity()), friction(false), mu(0.0), p(0.0),
    g(0.0), profile(REST), drive_v(0.0), drive_t(0.0), fused(false), own_allowed(false), in_order(false), own(false),
    clear_forces(false), front(nullptr), drive_u(0.0),
    drive_ud(0.0), work_done(0.0), work_pending(0.0), energy_step(-1), pe_cached(0.0),
    gap_cached(0.0), contact_step(-1)
{
  if (igroup != 0) error->all(FLERR, "Fix lattice/chain must be defined for group all");
  bool have_law = false, have_impactor = false;
  for (int iarg = 3; iarg < narg;) {
    const std::string key = arg[iarg];
    if (key == "law") {
      iarg = law.parse(lmp, narg, arg, iarg + 1);
      have_law = true;
    } else if (key == "impactor") {
      if (iarg + 1 >= narg) utils::missing_cmd_args(FLERR, "fix lattice/chain impactor", error);
      const std::string kind = arg[iarg + 1];
      const int nargs = kind == "constant" ? 1 : (kind == "ramp" || kind == "sine") ? 2 : kind == "measured" ? 6 : 0;
      if (iarg + 1 + nargs >= narg)
        utils::missing_cmd_args(FLERR, "fix lattice/chain impactor " + kind, error);
      if (kind == "constant" || kind == "ramp" || kind == "sine") {
        profile = kind == "constant" ? CONSTANT : kind == "ramp" ? RAMP : SINE;
        drive_v = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
        if (nargs == 2) drive_t = utils::numeric(FLERR, arg[iarg + 3], false, lmp);
        if (nargs == 2 && drive_t <= 0.0)
          error->all(FLERR, "Fix lattice/chain: impactor {} needs a time > 0", kind);
      } else if (kind == "rest") {
        profile = REST;
      } else if (kind == "measured") {
        if (strcmp(arg[iarg + 2], "file") || strcmp(arg[iarg + 4], "column") || strcmp(arg[iarg + 6], "after"))
          error->all(FLERR, "Fix lattice/chain: expected impactor measured file PATH column u|v after hold|stop");
        const std::string column = arg[iarg + 5], after = arg[iarg + 7];
        if ((column != "u" && column != "v") || (after != "hold" && after != "stop"))
          error->all(FLERR, "Fix lattice/chain: impactor measured column u|v after hold|stop");
        profile = MEASURED;
        measured.load(arg[iarg + 3], column == "v", after == "hold", error, "Fix lattice/chain");
      } else
        error->all(FLERR, "Fix lattice/chain: unknown impactor '{}'; expected constant, ramp, sine, rest or measured", kind);
      iarg += 2 + nargs;
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
      mu = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      p = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
      g = utils::numeric(FLERR, arg[iarg + 3], false, lmp);
      if (mu < 0.0 || p < 0.0 || g < 0.0)
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

  // each chain's impactor position now: its owner contributes it, every rank keeps all
  time_origin = update->ntimestep;
  std::vector<double> mine(nchains, 0.0);
  x0.assign(nchains, 0.0);
  for (int i = 0; i < atom->nlocal; i++)
    if ((atom->tag[i] - 1) % length == 0) mine[(atom->tag[i] - 1) / length] = atom->x[i][0];
  MPI_Allreduce(mine.data(), x0.data(), nchains, MPI_DOUBLE, MPI_SUM, world);

  scalar_flag = vector_flag = 1;
  size_vector = 2;
  global_freq = 1;
  extscalar = 1;
  extvector = -1;
  extlist = new int[2]{1, 0};
  energy_global_flag = 1;
  time_integrate = 1;
}

FixLatticeChain::~FixLatticeChain()
{
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
  if (atom->rmass || !atom->mass) error->all(FLERR, "Fix lattice/chain needs per-type masses");
  if (domain->xperiodic) error->all(FLERR, "Fix lattice/chain needs a non-periodic x boundary");

  const int ntypes = atom->ntypes;
  dtfm.assign(ntypes + 1, 0.0);
  mass_of.assign(ntypes + 1, 0.0);
  weight.assign(ntypes + 1, 0.0);
  const double dtf = 0.5 * update->dt * force->ftm2v;
  for (int t = 1; t <= ntypes; t++) {
    mass_of[t] = atom->mass[t];
    dtfm[t] = dtf / atom->mass[t];
    weight[t] = atom->mass[t] * g;
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
  own_allowed = fused && alone && comm->nprocs == 1 && !other_forces && atom->sortfreq == 0 &&
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
      runs.push_back({i, i, -1, -1});
    }
  }
  // blocks of at most BLOCK atoms (one bond per block boundary is computed twice, from the
  // same two positions)
  std::vector<Run> blocks;
  for (const Run &run : runs) {
    const int left = neighbour(run.first, tag[run.first] - 1);
    const int right = neighbour(run.last, tag[run.last] + 1);
    for (int first = run.first; first <= run.last; first += BLOCK) {
      const int last = std::min(first + BLOCK - 1, run.last);
      blocks.push_back({first, last, first == run.first ? left : first - 1, last == run.last ? right : last + 1});
    }
  }
  runs.swap(blocks);
  bond_force.resize(BLOCK + 1);
  scratch.resize(4 * (BLOCK + 2));

  // owning the state, the drift moves block k + 1 before the forces of block k: a free
  // neighbour of a block must be the end of the block before or the start of the block after it
  auto is_free = [&](int j) {
    const bigint k = (tag[j] - 1) % length;
    return k != 0 && k != length - 1;
  };
  in_order = true;
  for (size_t k = 0; k < runs.size(); k++) {
    if (is_free(runs[k].left) && (k == 0 || runs[k].left != runs[k - 1].last)) in_order = false;
    if (is_free(runs[k].right) && (k + 1 == runs.size() || runs[k].right != runs[k + 1].first)) in_order = false;
  }
}

void FixLatticeChain::setup_pre_neighbor()
{
  build_lists();
}

/* owning the state: exchange and the box see the positions (of the last step, see the header) */

void FixLatticeChain::pre_exchange()
{
  if (!own) return;
  double **x = atom->x;
  for (int i = 0; i < atom->nlocal; i++) x[i][0] = xs[i];
}

void FixLatticeChain::pre_neighbor()
{
  if (!own) {
    build_lists();
    return;
  }
  // owning the state on one rank, the atoms keep their places (no sorting, none leaves the
  // shrink-wrapped box); the arrays are indexed by them, so check it
  const auto old_runs = runs;
  const auto old_impactors = impactors, old_held = held;
  build_lists();
  if (!(runs == old_runs && impactors == old_impactors && held == old_held && in_order))
    error->one(FLERR, "Fix lattice/chain: the atoms moved in memory during a run on one rank");
}

/* the prescribed displacement and velocity at `step` */

void FixLatticeChain::drive(bigint step)
{
  const double t = (step - time_origin) * update->dt;
  const double V = drive_v, T = drive_t;
  switch (profile) {
    case CONSTANT:
      drive_u = V * t;
      drive_ud = V;
      break;
    case RAMP:
      drive_u = t < T ? V * t * t / (2.0 * T) : V * (t - 0.5 * T);
      drive_ud = t < T ? V * t / T : V;
      break;
    case SINE:
      drive_u = t < T ? V * T / M_PI * (1.0 - cos(M_PI * t / T)) : 2.0 * V * T / M_PI;
      drive_ud = t < T ? V * sin(M_PI * t / T) : 0.0;
      break;
    case REST:
      drive_u = drive_ud = 0.0;
      break;
    case MEASURED:
      // a run meant to end on the last sample may overshoot it by round-off
      measured.at(t, 1.0e-6 * update->dt, drive_u, drive_ud);
      break;
  }
}

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
  drive(update->ntimestep);
  place_impactors(false);
  forces(0.5 * update->dt, true, false);
  // decided once per run: the atoms keep their order between reneighbourings on one rank
  own = own_allowed && in_order;
  block_front.clear();    // summarised at the first owned sample, after the record's own setup sample
  if (own) gather();
  if (comm->me == 0)
    utils::logmesg(lmp, "Fix lattice/chain: {}\n",
                   own ? std::string("owns the state (one pass per step") + (front ? ", front record inside)" : ")")
                       : std::string("works in the atom arrays"));
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
    const int *__restrict type = atom->type;
    const double *__restrict dtfm_of = dtfm.data();
    const double dtv = update->dt;
    if (atom->ntypes == 1) {
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
  drive(update->ntimestep);
  place_impactors(true);
}

void FixLatticeChain::post_force(int /*vflag*/)
{
  if (!own) {
    forces(update->dt, false, fused);
    return;
  }
  FrontRecord::Sample sample;
  const bool record = front && front->begin_sample(sample);
  if (record && block_front.size() != runs.size()) summarise_front();
  int bad = 0;
  law.dispatch([&](auto F) {
    if (friction) {
      if (record) own_step<true, true>(F, bad);
      else own_step<true, false>(F, bad);
    } else {
      if (record) own_step<false, true>(F, bad);
      else own_step<false, false>(F, bad);
    }
  });
  end_forces();
  if (record) {
    sample_front_ends();
    front->end_sample();
  }
  check_gaps(bad);
  if (update->ntimestep == output->next) scatter();
}

void FixLatticeChain::final_integrate()
{
  if (!fused) {
    double *__restrict v = atom->v[0];
    const double *__restrict f = atom->f[0];
    const int *__restrict type = atom->type;
    for (const Run &run : runs)
      for (int i = run.first; i <= run.last; i++) v[3 * i] += dtfm[type[i]] * f[3 * i];
  }
  place_impactors(false);    // the prescribed velocity, whatever other fixes did
}

void FixLatticeChain::post_run()
{
  if (own) {
    scatter();
    if (front) front->set_previous_velocities(vs.data(), 1);
    own = false;
  }
  if (contact_step >= 0) timer->reset_timeout();
}

/* owning the state: the fix's arrays from the atom arrays and back */

void FixLatticeChain::gather()
{
  const int n = atom->nlocal;
  xs.resize(n);
  vs.resize(n);
  fs.resize(n);
  impactor_v.assign(nchains, 0.0);
  double **x = atom->x, **v = atom->v, **f = atom->f;
  for (int i = 0; i < n; i++) {
    xs[i] = x[i][0];
    vs[i] = v[i][0];
    fs[i] = f[i][0];
  }
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

/* all forces of the step in the atom arrays; `kick` is the length of the velocity kick they
   will make (for the friction), kick_v applies its second half here */

void FixLatticeChain::forces(double kick, bool setup_kick, bool kick_v)
{
  int bad = 0;
  law.dispatch([&](auto F) {
    if (friction) {
      if (kick_v) run_forces<true, true>(F, kick, setup_kick, bad);
      else run_forces<true, false>(F, kick, setup_kick, bad);
    } else {
      if (kick_v) run_forces<false, true>(F, kick, setup_kick, bad);
      else run_forces<false, false>(F, kick, setup_kick, bad);
    }
  });
  end_forces();
  check_gaps(bad);
}

/* the impactors' push and the held ends' zero force */

void FixLatticeChain::end_forces()
{
  const Column x = column(atom->x, xs), f = column(atom->f, fs);
  for (const End &e : impactors) f[e.i] = -law.force(x[e.other] - x[e.i]);
  for (const End &e : held) f[e.i] = 0.0;
}

/* one free atom's total force from its bonds' forces left and right, with friction the exact
   stick-slip kick: v (after the first half kick) becomes 0 if the atom sticks */

template <bool FRICTION>
inline double FixLatticeChain::total_force(double left, double right, int t, double kick, double &v,
                                           CoulombWork &work) const
{
  const double fx = left - right;
  if constexpr (!FRICTION) {
    return fx;
  } else {
    const double m = mass_of[t];
    const double normal = weight[t] + p * (left + right);
    const double limit = normal > 0.0 ? mu * normal : 0.0;
    const double dvdf = kick / m;
    const double v0 = v;
    bool stuck;
    const double ftot = coulomb_kick(v0, fx, limit, dvdf, stuck);
    if (stuck) work.stuck(v0, m, kick, fx), v = 0.0;
    else work.slip(v0, fx, ftot, dvdf);
    return ftot;
  }
}

/* the force pass in the atom arrays (KICK: with the second half kick) */

template <bool FRICTION, bool KICK, class Law>
void FixLatticeChain::run_forces(const Law law, double kick, bool setup_kick, int &bad)
{
  // restrict: stores to v, f and the bond forces cannot change the law's coefficients
  double *__restrict x = atom->x[0];
  double *__restrict v = atom->v[0];
  double *__restrict f = atom->f[0];
  double *__restrict F = bond_force.data();
  const int *__restrict type = atom->type;
  const double *__restrict dtfm_of = dtfm.data();
  const double half_kick = dtfm_of[1];
  const bool one_type = atom->ntypes == 1;
  // the block's positions, contiguous: X[0] left neighbour, X[1..len] the block, X[len+1]
  // right neighbour
  double *__restrict X = scratch.data();
  // the smallest and largest separation and a NaN probe, as vectorised reductions
  double r_min = std::numeric_limits<double>::infinity(), r_max = -r_min, r_sum = 0.0;
  CoulombWork work;
  for (const Run &run : runs) {
    const int first = run.first, len = run.last - first + 1;
    for (int k = 0; k < len; k++) X[1 + k] = x[3 * (first + k)];
    X[0] = x[3 * run.left];
    X[len + 1] = x[3 * run.right];
    // the bond forces, F[k] left of atom first + k
#pragma omp simd reduction(min : r_min) reduction(max : r_max) reduction(+ : r_sum)
    for (int k = 0; k <= len; k++) {
      const double r = X[k + 1] - X[k];
      r_min = r < r_min ? r : r_min;
      r_max = r > r_max ? r : r_max;
      r_sum += r;
      F[k] = law(r);
    }
    double *__restrict fr = f + 3 * first;
    double *__restrict vr = v + 3 * first;
    for (int k = 0; k < len; k++) {
      const int t = FRICTION || !one_type ? type[first + k] : 1;
      const double ftot = total_force<FRICTION>(F[k], F[k + 1], t, kick, vr[3 * k], work);
      fr[3 * k] = ftot;
      if (KICK) vr[3 * k] += (one_type ? half_kick : dtfm_of[t]) * ftot;
    }
  }
  if (FRICTION) work.settle(kick, setup_kick, work_done, work_pending);
  // r <= 0 is a contact
  if (!(r_min > 0.0 && r_min >= range_lo && r_max <= range_hi) || std::isnan(r_sum)) bad = 1;
}

/* Owning the state, the whole step in one pass over the fix's arrays (see the header): the
   same operations as initial_integrate, run_forces<KICK> and the front record's sample. */

template <bool FRICTION, bool FRONT, class Law>
void FixLatticeChain::own_step(const Law law, int &bad)
{
  double *__restrict x = xs.data();
  double *__restrict v = vs.data();
  double *__restrict f = fs.data();
  double *__restrict F = bond_force.data();
  double *__restrict mark = FRONT ? front->mark : nullptr;
  const int *__restrict type = atom->type;
  const double *__restrict dtfm_of = dtfm.data();
  const double half_kick = dtfm_of[1];
  const bool one_type = atom->ntypes == 1;
  const double dtv = update->dt, kick = update->dt;
  const FrontRecord::Levels levels = FRONT ? front->levels : FrontRecord::Levels{};
  // per block in flight (two): the velocities after the first half kick, and before it
  double *__restrict half[2] = {scratch.data(), scratch.data() + BLOCK};
  double *__restrict before[2] = {scratch.data() + 2 * BLOCK, scratch.data() + 3 * BLOCK};
  // velocity Verlet's first half kick and drift, with last step's forces
  auto drift = [&](const Run &run, double *__restrict vh, double *__restrict v0) {
    for (int i = run.first, k = 0; i <= run.last; i++, k++) {
      v0[k] = v[i];
      vh[k] = v[i] + (one_type ? half_kick : dtfm_of[type[i]]) * f[i];
      x[i] += dtv * vh[k];
    }
  };
  double r_min = std::numeric_limits<double>::infinity(), r_max = -r_min, r_sum = 0.0;
  CoulombWork work;
  if (!runs.empty()) drift(runs[0], half[0], before[0]);
  for (size_t b = 0; b < runs.size(); b++) {
    const Run &run = runs[b];
    const int first = run.first, last = run.last, len = last - first + 1;
    if (b + 1 < runs.size()) drift(runs[b + 1], half[(b + 1) % 2], before[(b + 1) % 2]);
    double *__restrict vh = half[b % 2];
    // the bond forces, F[k] left of atom first + k: the two end bonds, then the inner ones
    // from consecutive positions
    auto bond = [&](double r) {
      r_min = r < r_min ? r : r_min;
      r_max = r > r_max ? r : r_max;
      r_sum += r;
      return law(r);
    };
    F[0] = bond(x[first] - x[run.left]);
    F[len] = bond(x[run.right] - x[last]);
    const double *__restrict xb = x + first;
#pragma omp simd reduction(min : r_min) reduction(max : r_max) reduction(+ : r_sum)
    for (int k = 1; k < len; k++) {
      const double r = xb[k] - xb[k - 1];
      r_min = r < r_min ? r : r_min;
      r_max = r > r_max ? r : r_max;
      r_sum += r;
      F[k] = law(r);
    }
    // the forces and the second half kick
    double *__restrict fb = f + first;
    double *__restrict vb = v + first;
    // the front record's largest |v| of every atom (it may change at every step: atoms ahead
    // of the front feel round-off forces from unequal gaps), and how many atoms are at or
    // above the start level (a count as a double: an int would keep the loop from vectorising)
    double *__restrict mb = FRONT ? mark + first : nullptr;
    double at_start = 0.0;
    // one loop for one atom type and one for several (a test inside would keep the loop from
    // vectorising)
    auto kick_loop = [&](auto one_type_) {
      constexpr bool ONE_TYPE = decltype(one_type_)::value;
      for (int k = 0; k < len; k++) {
        const int t = FRICTION || !ONE_TYPE ? type[first + k] : 1;
        const double ftot = total_force<FRICTION>(F[k], F[k + 1], t, kick, vh[k], work);
        const double vn = vh[k] + (ONE_TYPE ? half_kick : dtfm_of[t]) * ftot;
        fb[k] = ftot;
        vb[k] = vn;
        if constexpr (FRONT) {
          mb[k] = FrontRecord::mark_max(mb[k], vn);
          at_start += vn >= levels.start ? 1.0 : 0.0;
        }
      }
    };
    if (one_type) kick_loop(std::true_type{});
    else kick_loop(std::false_type{});
    // the rows only of blocks where an atom is active or may reach the start level now
    if (FRONT && (block_front[b].active > 0 || (block_front[b].waiting > 0 && at_start > 0.0)))
      sample_front_block(b, before[b % 2]);
  }
  if (FRICTION) work.settle(kick, false, work_done, work_pending);
  if (!(r_min > 0.0 && r_min >= range_lo && r_max <= range_hi) || std::isnan(r_sum)) bad = 1;
}

/* owning the state: the front record of block b's atoms that start now or are active, and
   the block's counts; v_before: their velocities of the previous step */

void FixLatticeChain::sample_front_block(int b, const double *v_before)
{
  using namespace FrontRecord;
  const Sample &s = front->current_sample();
  const Run &run = runs[b];
  BlockFront &bf = block_front[b];
  for (int i = run.first, k = 0; i <= run.last; i++, k++) {
    unsigned char &phase = front->phase[i];
    const unsigned char before = phase;
    if (!(before == ACTIVE || starts(before, vs[i], front->levels))) continue;
    const double v_prev = before == WAITING ? v_before[k] : front->rec[i][V_PREV];
    advance(front->rec[i], phase, vs[i], v_prev, fs[i] / mass_of[atom->type[i]], front->levels, s);
    bf.waiting -= before == WAITING;
    bf.active += (phase == ACTIVE) - (before == ACTIVE);
  }
}

/* owning the state: the active and waiting atoms of each block */

void FixLatticeChain::summarise_front()
{
  using namespace FrontRecord;
  block_front.assign(runs.size(), BlockFront{0, 0});
  for (size_t b = 0; b < runs.size(); b++)
    for (int i = runs[b].first; i <= runs[b].last; i++) {
      block_front[b].active += front->phase[i] == ACTIVE;
      block_front[b].waiting += front->phase[i] == WAITING;
    }
}

/* owning the state: the front record of the chain ends (the impactor's previous velocity was
   kept in initial_integrate; a held end's does not change) */

void FixLatticeChain::sample_front_ends()
{
  using namespace FrontRecord;
  const Sample &s = front->current_sample();
  auto sample = [&](int i, double v_prev) {
    front->mark[i] = mark_max(front->mark[i], vs[i]);
    unsigned char &phase = front->phase[i];
    if (!(phase == ACTIVE || starts(phase, vs[i], front->levels))) return;
    advance(front->rec[i], phase, vs[i], phase == WAITING ? v_prev : front->rec[i][V_PREV],
            fs[i] / mass_of[atom->type[i]], front->levels, s);
  };
  for (const End &e : impactors) sample(e.i, impactor_v[e.chain]);
  for (const End &e : held) sample(e.i, vs[e.i]);
}

/* every separation of this rank's bonds (each bond once, by its left atom): the potential
   energy, and the smallest and largest separation with the ID of their left atom */

void FixLatticeChain::bond_scan(double &pe, double &gap_min, tagint &tag_min, double &gap_max,
                                tagint &tag_max)
{
  const Column x = column(atom->x, xs);
  const tagint *tag = atom->tag;
  pe = 0.0;
  gap_min = std::numeric_limits<double>::infinity();
  gap_max = -gap_min;
  tag_min = tag_max = 0;
  auto bond = [&](int i, int j) {
    const double r = x[j] - x[i];
    pe += law.energy(r);
    if (r < gap_min) gap_min = r, tag_min = tag[i];
    if (r > gap_max) gap_max = r, tag_max = tag[i];
  };
  for (const Run &run : runs)
    for (int i = run.first; i <= run.last; i++) bond(i, i < run.last ? i + 1 : run.right);
  for (const End &e : impactors) bond(e.i, e.other);
}

/* a bad separation seen on any rank: report a contact and stop, or stop with an error */

void FixLatticeChain::check_gaps(int bad)
{
  int any = 0;
  MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, world);
  if (!any) return;
  double pe;
  struct {
    double value;
    int tag;
  } lo_in, lo_out, hi_in, hi_out;
  tagint tmin, tmax;
  bond_scan(pe, lo_in.value, tmin, hi_in.value, tmax);
  lo_in.tag = tmin;
  hi_in.tag = tmax;
  MPI_Allreduce(&lo_in, &lo_out, 1, MPI_DOUBLE_INT, MPI_MINLOC, world);
  MPI_Allreduce(&hi_in, &hi_out, 1, MPI_DOUBLE_INT, MPI_MAXLOC, world);
  const double t = update->atime + (update->ntimestep - update->atimestep) * update->dt;
  if (lo_out.value <= 0.0) {
    if (comm->me == 0)
      utils::logmesg(lmp, "CONTACT: magnets {} and {} gap {:.8g} m at t = {:.10g} s\n", lo_out.tag,
                     lo_out.tag + 1, lo_out.value, t);
    contact_step = update->ntimestep;
    timer->force_timeout();
    return;
  }
  const bool low = lo_out.value < range_lo;
  const int i = low ? lo_out.tag : hi_out.tag;
  // worded like bond_style table's error, whose length the runner turns into mm
  error->all(FLERR,
             "Fix lattice/chain: magnets {} and {} outside the table range [{}, {}] m at t = {} s "
             "(extend [table] r_max): type 1 length {}",
             i, i + 1, range_lo, range_hi, t, low ? lo_out.value : hi_out.value);
}

/* potential energy and smallest separation of the current step, computed once */

void FixLatticeChain::energies()
{
  if (energy_step == update->ntimestep) return;
  double pe, gmin, gmax;
  tagint tmin, tmax;
  bond_scan(pe, gmin, tmin, gmax, tmax);
  MPI_Allreduce(&pe, &pe_cached, 1, MPI_DOUBLE, MPI_SUM, world);
  MPI_Allreduce(&gmin, &gap_cached, 1, MPI_DOUBLE, MPI_MIN, world);
  energy_step = update->ntimestep;
}

double FixLatticeChain::compute_scalar()
{
  energies();
  return pe_cached;
}

double FixLatticeChain::compute_vector(int n)
{
  if (n == 0) {
    double all;
    MPI_Allreduce(&work_done, &all, 1, MPI_DOUBLE, MPI_SUM, world);
    return all;
  }
  energies();
  return gap_cached;
}
