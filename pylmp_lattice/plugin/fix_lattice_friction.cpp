/* ----------------------------------------------------------------------
   fix lattice/friction: Coulomb friction on a 1D chain of repelling magnets
   Part of pylmp_lattice, GPL-2.0. Compiled as a LAMMPS plugin.

Syntax
   fix ID group-ID lattice/friction mu p g keyword value ...

   mu = Coulomb friction coefficient (unitless)
   p  = share of the neighbour repulsion that presses on the rod (unitless)
   g  = gravitational acceleration (force/mass units, 9.81 in units si)
   zero or more keyword/value pairs may be appended
     bond value = bond type whose force law gives the neighbour forces (default 1)

Examples
   fix fric mobile lattice/friction 0.285 0.012 9.81
   fix fric mobile lattice/friction 0.285 0.012 9.81 bond 1
   fix_modify fric energy yes

Description
   Each atom of the group feels, along x, a Coulomb friction force of magnitude at most
       L_n = mu * (m g + p (F_{n-1} + F_n))
   that opposes its motion (Eq. 1 and Supplement S3 of the paper). F_{n-1} and F_n are
   the repulsive forces from its chain neighbours, the atoms with IDs tag-1 and tag+1,
   at their current separations, computed with the bond style's own single() so the
   friction uses exactly the (tabulated) force law of the bonds. An end atom (ID 1 or
   ID N) has only one neighbour and uses only that force. Atom IDs must run 1..N in
   chain order. The normal force is clipped at zero should the bonds ever attract.

   Stick and slip. Velocity Verlet with fix nve applies the force found at step n as
   one kick of length dt taking the velocity from v(n-1/2) to v(n+1/2) (the setup
   before a run applies a half kick from v(0) to v(1/2)). This fix resolves the
   Coulomb law exactly within that kick, holding the other force F and the limit L
   at their step-n values (the midpoint rule of the leapfrog scheme itself):
     - at rest (v = 0) with |F| <= L: the atom sticks; f and v are set to exactly
       zero, so it stays exactly at rest (no drift, no chatter);
     - at rest with |F| > L: it starts moving with the kinetic friction, f = F - sign(F) L;
     - moving with sign s: f = F - s L, unless that would reverse the velocity within
       the kick. Then the atom stops at the time the linear velocity reaches zero; if
       |F| <= L it stays stuck for the rest of the kick (v and f set to exactly zero,
       so friction never reverses a velocity), otherwise it moves off the other way
       with friction F + s L for the remaining time, and f is the mean force that
       gives that end velocity.
   Order of accuracy: while slipping in one direction the friction is a smooth force
   and the scheme is velocity Verlet, second order. At a stop or reversal the kick is
   exact for F, L constant over the kick, so the local errors are O(dt^2) in velocity
   and position once per event; with finitely many events positions and half-step
   velocities stay second order globally. The one exception is the full-step velocity
   printed at the step where an atom sticks: it is 0 rather than the O(dt) value it
   may have had part way through the kick; it does not feed back into the trajectory.

   Cost: one evaluation of the bond law per moving atom and step (each bond's force is
   cached and shared by its two atoms, and reused while its length is unchanged); an
   atom at rest with exactly zero force is skipped, as it sticks whatever the limit.

   Define this fix after any other fix that changes the forces on its atoms, and use
   it only on atoms integrated by fix nve: it reads the total force f, and for a
   sticking atom it also zeroes v.

Output
   Global scalar: cumulative friction work (energy units, extensive), i.e. the energy
   the friction has dissipated since the fix was defined, counted up to the current
   step: each kick's work is split at the full step, the half after it is counted at
   the next step. With fix_modify energy yes it is added to the potential energy, so
   thermo etotal stays constant up to the integrator's O(dt^2) energy error
   (energy_global_flag = 1, off by default like every fix_modify energy).
   No restart information is written; the count restarts at zero.

Restrictions
   Needs a bond style (bonds between consecutive IDs) and an atom map (atom_style
   bond has one). On several MPI ranks each atom's neighbours must be owned or ghost
   atoms: set comm_modify cutoff longer than the longest bond. Not for rRESPA.
------------------------------------------------------------------------- */

#include "fix_lattice_friction.h"

#include "atom.h"
#include "bond.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "update.h"

#include <cmath>
#include <cstring>

using namespace LAMMPS_NS;
using namespace FixConst;

FixLatticeFriction::FixLatticeFriction(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), work_done(0.0), work_pending(0.0), fright(nullptr), rsq_right(nullptr),
    nmax(0), periodic(false)
{
  if (narg < 6) utils::missing_cmd_args(FLERR, "fix lattice/friction", error);
  mu = utils::numeric(FLERR, arg[3], false, lmp);
  p = utils::numeric(FLERR, arg[4], false, lmp);
  g = utils::numeric(FLERR, arg[5], false, lmp);
  if (mu < 0.0) error->all(FLERR, "Fix lattice/friction: mu = {} must be >= 0", mu);
  if (p < 0.0) error->all(FLERR, "Fix lattice/friction: p = {} must be >= 0", p);
  if (g < 0.0) error->all(FLERR, "Fix lattice/friction: g = {} must be >= 0", g);

  btype = 1;
  for (int iarg = 6; iarg < narg; iarg += 2) {
    if (strcmp(arg[iarg], "bond") == 0) {
      if (iarg + 1 >= narg) utils::missing_cmd_args(FLERR, "fix lattice/friction bond", error);
      btype = utils::inumeric(FLERR, arg[iarg + 1], false, lmp);
    } else
      error->all(FLERR, "Fix lattice/friction: unknown keyword '{}'; expected 'bond'", arg[iarg]);
  }

  scalar_flag = 1;
  global_freq = 1;
  extscalar = 1;
  energy_global_flag = 1;
}

FixLatticeFriction::~FixLatticeFriction()
{
  memory->destroy(fright);
  memory->destroy(rsq_right);
}

int FixLatticeFriction::setmask()
{
  return POST_FORCE;
}

void FixLatticeFriction::init()
{
  if (!force->bond) error->all(FLERR, "Fix lattice/friction needs a bond style");
  if (btype < 1 || btype > atom->nbondtypes)
    error->all(FLERR, "Fix lattice/friction: bond type {} out of range 1..{}", btype,
               atom->nbondtypes);
  if (atom->map_style == Atom::MAP_NONE)
    error->all(FLERR, "Fix lattice/friction needs an atom map (atom_modify map array)");
  if (utils::strmatch(update->integrate_style, "^respa"))
    error->all(FLERR, "Fix lattice/friction does not support run_style respa");
  // bond coefficients may have changed since the last run
  for (int i = 0; i < nmax; i++) rsq_right[i] = -1.0;
}

void FixLatticeFriction::setup(int /*vflag*/)
{
  apply_friction(0.5 * update->dt, true);
}

void FixLatticeFriction::post_force(int /*vflag*/)
{
  apply_friction(update->dt, false);
}

double FixLatticeFriction::compute_scalar()
{
  double all;
  MPI_Allreduce(&work_done, &all, 1, MPI_DOUBLE, MPI_SUM, world);
  return all;
}

/* local index of the atom with ID tag nearest to atom i; it must be owned or a ghost */

inline int FixLatticeFriction::neighbour(int i, tagint tag)
{
  const int j = atom->map(tag);
  if (j < 0) missing_neighbour(i, tag);
  // without periodic images the map's atom is the only copy
  return periodic ? domain->closest_image(i, j) : j;
}

void FixLatticeFriction::missing_neighbour(int i, tagint tag)
{
  error->one(FLERR,
             "Fix lattice/friction: atom {} (neighbour of atom {}) is not on this rank; "
             "set comm_modify cutoff longer than the longest bond",
             tag, atom->tag[i]);
}

/* repulsive (positive) force of the bond from atom a to its right neighbour b.
   Slot a of fright caches it with the squared separation it was computed at, and is
   reused while that separation is unchanged to the bit: atoms at rest next to atoms at
   rest cost no evaluation. Slots change owner when atoms migrate or ghosts are rebuilt;
   a reused value is still exact because single() depends only on the bond type and rsq. */

inline double FixLatticeFriction::bond_force(int a, int b)
{
  double **x = atom->x;
  const double dx = x[a][0] - x[b][0];
  const double dy = x[a][1] - x[b][1];
  const double dz = x[a][2] - x[b][2];
  const double rsq = dx * dx + dy * dy + dz * dz;
  if (rsq != rsq_right[a]) {
    double fbond;    // force / r
    force->bond->single(btype, rsq, a, b, fbond);
    rsq_right[a] = rsq;
    fright[a] = fbond * sqrt(rsq);
  }
  return fright[a];
}

/* friction for a velocity kick of length `kick`, starting from the current v */

void FixLatticeFriction::apply_friction(double kick, bool setup_kick)
{
  double **v = atom->v;
  double **f = atom->f;
  double *rmass = atom->rmass;
  double *mass = atom->mass;
  int *type = atom->type;
  int *mask = atom->mask;
  tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  const bigint natoms = atom->natoms;

  if (atom->nmax > nmax) {
    memory->grow(fright, atom->nmax, "lattice/friction:fright");
    memory->grow(rsq_right, atom->nmax, "lattice/friction:rsq_right");
    for (int i = nmax; i < atom->nmax; i++) rsq_right[i] = -1.0;
    nmax = atom->nmax;
  }
  periodic = domain->xperiodic || domain->yperiodic || domain->zperiodic;

  double work_now = 0.0, work_next = 0.0;
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    const double fx = f[i][0];
    const double v0 = v[i][0];
    if (v0 == 0.0 && fx == 0.0) continue;    // stays at rest whatever the limit: no work

    const double fleft = (tag[i] > 1) ? bond_force(neighbour(i, tag[i] - 1), i) : 0.0;
    const double fright_i = (tag[i] < natoms) ? bond_force(i, neighbour(i, tag[i] + 1)) : 0.0;
    const double m = rmass ? rmass[i] : mass[type[i]];
    const double normal = m * g + p * (fleft + fright_i);
    const double limit = normal > 0.0 ? mu * normal : 0.0;
    const double k = kick / m;

    // ftot: the constant force over the kick that reproduces the exact Coulomb solution
    double ftot = 0.0;
    bool stuck = false;
    if (v0 == 0.0) {
      if (fabs(fx) <= limit) stuck = true;
      else ftot = fx - copysign(limit, fx);
    } else {
      const double s = copysign(1.0, v0);
      ftot = fx - s * limit;
      const double v1 = v0 + k * ftot;
      if (s * v1 <= 0.0) {    // the velocity reaches zero within the kick
        if (fabs(fx) <= limit) stuck = true;
        // moves off the other way for the rest of the kick, a time m v1 / ftot
        else ftot = (v1 * (fx + s * limit) / ftot - v0) / k;
      }
    }

    if (stuck) {
      // v is zeroed now, so all of this kick's loss is settled at this step
      work_now += 0.5 * v0 * (m * v0 + kick * fx);    // -(ffric) kick (v0 + 0) / 2
      v[i][0] = 0.0;
      f[i][0] = 0.0;
      continue;
    }
    // friction work over the kick, split at the full step where v = (v0 + v1) / 2
    const double ffric = ftot - fx;
    const double v1 = v0 + k * ftot;
    const double vmid = 0.5 * (v0 + v1);
    if (setup_kick) work_next -= ffric * kick * vmid;
    else {
      work_now -= ffric * 0.25 * kick * (v0 + vmid);
      work_next -= ffric * 0.25 * kick * (vmid + v1);
    }
    f[i][0] = ftot;
  }

  // the setup kick replaces the second half-kick planned at the end of the last run
  if (!setup_kick) work_done += work_pending;
  work_done += work_now;
  work_pending = work_next;
}
