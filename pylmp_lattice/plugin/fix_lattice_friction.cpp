/* ----------------------------------------------------------------------
   fix lattice/friction: Coulomb friction on a 1D chain of repelling magnets
   Part of pylmp_lattice, GPL-2.0. Compiled as a LAMMPS plugin.

Syntax
   fix ID group-ID lattice/friction mu p g keyword args ...

   mu = Coulomb friction coefficient (unitless)
   p  = share of the neighbour repulsion that presses on the rod (unitless)
   g  = gravitational acceleration (force/mass units, 9.81 in units si)
   zero or more keyword/args pairs may be appended
     law args = bond [btype] or power K b q or linear k r_free or table file keyword
       bond [btype] = the force law of bond type btype (default 1), through the bond style
       power K b q = F(r) = K / (r + b)^q, K > 0, b >= 0, q > 1
         K = force*distance^q units, b = distance units, q = exponent (unitless)
       linear k r_free = F(r) = k (r_free - r), k > 0, r_free > 0
         k = force/distance units, r_free = distance units
       table file keyword = a bond_style table file's section, by its clamped spline
       (power, linear, table: the laws of fix lattice/chain, from the same code, force_law.h,
       so both fixes accept and refuse the same parameters)
     bond value = btype: the same as law bond btype (the syntax before law existed)

Examples
   fix fric mobile lattice/friction 0.285 0.012 9.81
   fix fric mobile lattice/friction 0.285 0.012 9.81 law bond 2
   fix fric mobile lattice/friction 0.285 0.012 9.81 law power 4.138e-7 3.917e-3 3
   fix fric mobile lattice/friction 0.285 0.0 9.81 law linear 1000.0 0.012
   fix_modify fric energy yes

Description
   Each atom of the group feels, along x, a Coulomb friction force of magnitude at most
       L_n = mu * (m g + p (F_{n-1} + F_n))
   that opposes its motion (Eq. 1 and Supplement S3 of the paper). F_{n-1} and F_n are
   the repulsive forces from its chain neighbours, the atoms with IDs tag-1 and tag+1,
   at their current separations r. An end atom (ID 1 or ID N) has only one neighbour
   and uses only that force. Atom IDs must run 1..N in chain order. The normal force is
   clipped at zero should the bonds ever attract.

   The law keyword says how F(r) is evaluated. With law bond (the default) it is the
   bond style's own single() for bond type btype, so the friction sees exactly the
   forces of the bonds; this is the choice for a law known only as samples. With law
   power or law linear the fix evaluates the analytic law itself, which is several
   times cheaper than a table lookup; the bonds keep their own representation of it.
   If the bonds are a bond_style table spline of the same law (as pylmp_lattice writes
   them), the two differ by the table's interpolation error, < 1e-6 relative with
   10000 points, which changes L_n by less than that. A power law with an integer
   q <= 8 is computed with multiplications, any other q with pow().

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

   Cost: one evaluation of F per step for each atom that moves or is loaded. Skipped:
   an atom at rest with exactly zero force, which sticks whatever the limit, and with
   law power (F > 0) an atom at rest with |f| <= mu m g, which sticks whatever F adds.
   A bond's force is shared by its two atoms when they come one after the other in
   memory, as in a chain read in ID order and sorted along x. Measured with N = 10^4
   (benchmarks/bench_friction.py), relative to the frictionless run: all atoms moving,
   1.4x with law power and 2.0x with law bond on a bond_style table spline; an impact
   into a chain at rest, 1.1x with law power and 1.3x with law bond (at rest ahead of
   the wave, round-off leaves nonzero net forces).

   Define this fix after any other fix that changes the forces on its atoms, and use
   it only on atoms integrated by fix nve: it reads the total force f, and for a
   sticking atom it also zeroes v.

   Without periodic boundaries the results do not depend on the number of MPI ranks:
   every rank computes the force of a bond from the same two positions in the same
   order, so 1 and several ranks give the same trajectory bit for bit; only the global
   scalar is summed in another order. (Across a periodic boundary a ghost's shifted
   coordinates can change the last bit of a separation.)

Output
   Global scalar: cumulative friction work (energy units, extensive), i.e. the energy
   the friction has dissipated since the fix was defined, counted up to the current
   step: each kick's work is split at the full step, the half after it is counted at
   the next step. With fix_modify energy yes it is added to the potential energy, so
   thermo etotal stays constant up to the integrator's O(dt^2) energy error
   (energy_global_flag = 1, off by default like every fix_modify energy).
   No restart information is written; the count restarts at zero.

Restrictions
   Needs bonds between consecutive IDs, a bond style for law bond, and an atom map
   (atom_style bond has one). On several MPI ranks each atom's neighbours must be owned
   or ghost atoms: set comm_modify cutoff longer than the longest bond. Not for rRESPA.
------------------------------------------------------------------------- */

#include "fix_lattice_friction.h"

#include "atom.h"
#include "bond.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "update.h"

#include <cmath>
#include <cstring>

using namespace LAMMPS_NS;
using namespace FixConst;

FixLatticeFriction::FixLatticeFriction(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), from_bond(true), btype(1), work_done(0.0), work_pending(0.0),
    periodic(false)
{
  if (narg < 6) utils::missing_cmd_args(FLERR, "fix lattice/friction", error);
  const double mu = utils::numeric(FLERR, arg[3], false, lmp);
  const double p = utils::numeric(FLERR, arg[4], false, lmp);
  const double g = utils::numeric(FLERR, arg[5], false, lmp);
  if (mu < 0.0) error->all(FLERR, "Fix lattice/friction: mu = {} must be >= 0", mu);
  if (p < 0.0) error->all(FLERR, "Fix lattice/friction: p = {} must be >= 0", p);
  if (g < 0.0) error->all(FLERR, "Fix lattice/friction: g = {} must be >= 0", g);
  fr = pl_kernel::Friction{mu, p, g};

  for (int iarg = 6; iarg < narg;) {
    if (strcmp(arg[iarg], "bond") == 0) {    // the syntax from before the law keyword
      if (iarg + 1 >= narg) utils::missing_cmd_args(FLERR, "fix lattice/friction bond", error);
      from_bond = true;
      btype = utils::inumeric(FLERR, arg[iarg + 1], false, lmp);
      iarg += 2;
      continue;
    }
    if (strcmp(arg[iarg], "law") != 0)
      error->all(FLERR, "Fix lattice/friction: unknown keyword '{}'; expected 'law'", arg[iarg]);
    if (iarg + 1 >= narg) utils::missing_cmd_args(FLERR, "fix lattice/friction law", error);
    if (strcmp(arg[iarg + 1], "bond") == 0) {
      from_bond = true;
      btype = 1;
      iarg += 2;
      if (iarg < narg && utils::is_integer(arg[iarg]))
        btype = utils::inumeric(FLERR, arg[iarg++], false, lmp);
    } else {
      const char *style = arg[iarg + 1];
      if (strcmp(style, "power") && strcmp(style, "linear") && strcmp(style, "table"))
        error->all(FLERR, "Fix lattice/friction: unknown law '{}'; expected bond, power, linear or table",
                   style);
      from_bond = false;
      iarg = law.parse(lmp, narg, arg, iarg + 1, "Fix lattice/friction");
    }
  }

  scalar_flag = 1;
  global_freq = 1;
  extscalar = 1;
  energy_global_flag = 1;
}

int FixLatticeFriction::setmask()
{
  return POST_FORCE;
}

void FixLatticeFriction::init()
{
  if (from_bond) {
    if (!force->bond) error->all(FLERR, "Fix lattice/friction law bond needs a bond style");
    if (btype < 1 || btype > atom->nbondtypes)
      error->all(FLERR, "Fix lattice/friction: bond type {} out of range 1..{}", btype,
                 atom->nbondtypes);
  }
  if (atom->map_style == Atom::MAP_NONE)
    error->all(FLERR, "Fix lattice/friction needs an atom map (atom_modify map array)");
  if (utils::strmatch(update->integrate_style, "^respa"))
    error->all(FLERR, "Fix lattice/friction does not support run_style respa");
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

/* repulsive (positive) force between atom i and its right neighbour j. It depends on
   x[i] - x[j] alone, in this order, so every rank gets the same bits for the same bond. */

inline double FixLatticeFriction::bond_force(int i, int j)
{
  double **x = atom->x;
  const double dx = x[i][0] - x[j][0];
  const double dy = x[i][1] - x[j][1];
  const double dz = x[i][2] - x[j][2];
  const double rsq = dx * dx + dy * dy + dz * dz;
  if (from_bond) return bond_style_force(i, j, rsq);
  // on the chain's axis r = |dx| (the same bits as sqrt(rsq)), saving the sqrt
  return law.force((dy == 0.0 && dz == 0.0) ? fabs(dx) : sqrt(rsq));
}

/* law bond, kept out of bond_force: with the single() call in it, GCC did not inline
   bond_force, and the analytic laws paid a function call per atom (~10% of the fix). */

double FixLatticeFriction::bond_style_force(int i, int j, double rsq)
{
  double fbond;    // force / r
  force->bond->single(btype, rsq, i, j, fbond);
  return fbond * sqrt(rsq);
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
  const int nall = nlocal + atom->nghost;
  const bigint natoms = atom->natoms;
  periodic = domain->xperiodic || domain->yperiodic || domain->zperiodic;

  // atoms are mostly stored in chain order: the right neighbour is then the next atom in
  // memory (no map lookup), and the force right of the previous atom is the force left of
  // this one (each bond evaluated once)
  tagint prev_tag = -1;
  double prev_fright = 0.0;

  pl_kernel::CoulombWork work;
  for (int i = 0; i < nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    const double fx = f[i][0];
    const double v0 = v[i][0];
    if (v0 == 0.0 && fx == 0.0) continue;    // stays at rest whatever the limit: no work

    // law power (F > 0): at rest and held by its weight alone, it sticks whatever the
    // neighbour forces add to the limit (also in rounding), so they are not needed; this
    // is the stuck branch below. m is not kept for later: that slowed law bond by 4%.
    if (v0 == 0.0 && !from_bond && law.kind == ForceLaw::POWER) {
      const double weight = (rmass ? rmass[i] : mass[type[i]]) * fr.g;
      if (fabs(fx) <= fr.limit(weight, 0.0, 0.0)) {
        v[i][0] = 0.0;
        f[i][0] = 0.0;
        continue;
      }
    }

    const tagint t = tag[i];
    double fleft = 0.0, fright = 0.0;
    if (t == prev_tag + 1) fleft = prev_fright;
    else if (t > 1) fleft = bond_force(neighbour(i, t - 1), i);
    if (t < natoms) {
      const int j = (!periodic && i + 1 < nall && tag[i + 1] == t + 1) ? i + 1 : neighbour(i, t + 1);
      fright = bond_force(i, j);
    }
    prev_tag = t;
    prev_fright = fright;

    const double m = rmass ? rmass[i] : mass[type[i]];
    double vi = v0;
    f[i][0] = fr.kick_force(m, m * fr.g, fleft, fright, fx, kick, vi, work);
    v[i][0] = vi;
  }
  work.settle(kick, setup_kick, work_done, work_pending);
}
