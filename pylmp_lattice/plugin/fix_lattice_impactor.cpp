/* ----------------------------------------------------------------------
   fix lattice/impactor: impactor moved along x by a prescribed motion
   Part of pylmp_lattice, GPL-2.0. Compiled as a LAMMPS plugin.

Syntax
   fix ID group-ID lattice/impactor constant V | ramp V T | sine V T | rest |
                                  measured file path column u|v after hold|stop
   fix ID group-ID lattice/impactor file path column u|v keyword value ...

   group-ID must contain exactly one atom (the impactor)
   constant, ramp, sine, rest, measured: the motions of fix lattice/chain's impactor keyword,
     from the same code (impactor_drive.h); V velocity units, T time units
   the second form is `measured` with its defaults:
   path = text file with two columns, time and value, one sample a line
   u = the value is the displacement (distance units, m in units si)
   v = the value is the velocity (velocity units, m/s in units si)
   zero or more keyword/value pairs may be appended
     after value = hold or stop (default stop)
       hold = after the last sample keep the last position with zero velocity
       stop = stop the run with an error if it goes past the last sample

Examples
   fix drive impactor lattice/impactor ramp 2.0 7.3e-3
   fix drive impactor lattice/impactor file impactor_u.txt column u after hold
   fix drive impactor lattice/impactor file impactor_v.csv column v

Description
   constant: u = V t; ramp: v = V t / T up to T, then V; sine: v = V sin(pi t / T) up to T,
   then at rest; rest: held where it is. t counts from the step at which the fix is defined.

   Measured: columns may be separated by blanks or commas; '#' starts a comment. At least 4
   samples are needed and times must increase strictly. The first sample's time is
   the moment the fix is defined, and the displacement is counted from the first
   sample, so the atom starts where it is: x(t) = x0 + u(t0 + t) - u(t0), where x0
   is its position when the fix is defined; y and z stay at x0's.

   The column is interpolated with a not-a-knot cubic spline (exact for cubics,
   fourth order in the sample interval for smooth data, including near the ends).
   Given u, the velocity is the spline's derivative. Given v, the displacement is the
   exact integral of the spline of v, so position and velocity stay consistent.

   Like fix move, the fix sets x(t+dt) and v(t+dt) in initial_integrate (in place of
   the integrator) and sets v(t+dt) again in final_integrate, so the atom's output
   velocity is the prescribed one whatever other fixes did to it; the setup before a
   run sets v(t). Forces on the atom are ignored.

Restrictions
   Not for rRESPA. Do not integrate the atom with another fix (e.g. fix nve).
------------------------------------------------------------------------- */

#include "fix_lattice_impactor.h"

#include "atom.h"
#include "error.h"
#include "group.h"
#include "update.h"

#include <cstring>
#include <string>

using namespace LAMMPS_NS;
using namespace FixConst;

FixLatticeImpactor::FixLatticeImpactor(LAMMPS *lmp, int narg, char **arg) : Fix(lmp, narg, arg)
{
  if (narg < 4) utils::missing_cmd_args(FLERR, "fix lattice/impactor", error);
  if (strcmp(arg[3], "file") != 0) {
    if (drive.parse(lmp, narg, arg, 3, "Fix lattice/impactor") != narg)
      error->all(FLERR, "Fix lattice/impactor: unexpected arguments after the motion");
  } else {    // file PATH column u|v [after hold|stop]
    if (narg < 7) utils::missing_cmd_args(FLERR, "fix lattice/impactor file", error);
    if (strcmp(arg[5], "column") != 0)
      error->all(FLERR, "Fix lattice/impactor: expected 'column u|v', got '{}'", arg[5]);
    const std::string column = arg[6];
    if (column != "u" && column != "v")
      error->all(FLERR, "Fix lattice/impactor: column '{}' unknown; choose one of 'u', 'v'", column);
    bool hold_after = false;
    for (int iarg = 7; iarg < narg; iarg += 2) {
      if (strcmp(arg[iarg], "after") != 0)
        error->all(FLERR, "Fix lattice/impactor: unknown keyword '{}'; expected 'after'", arg[iarg]);
      if (iarg + 1 >= narg) utils::missing_cmd_args(FLERR, "fix lattice/impactor after", error);
      if (strcmp(arg[iarg + 1], "hold") == 0) hold_after = true;
      else if (strcmp(arg[iarg + 1], "stop") == 0) hold_after = false;
      else
        error->all(FLERR, "Fix lattice/impactor: after '{}' unknown; choose one of 'hold', 'stop'",
                   arg[iarg + 1]);
    }
    drive.load_measured(arg[4], column == "v", hold_after, lmp, "Fix lattice/impactor");
  }

  if (group->count(igroup) != 1)
    error->all(FLERR, "Fix lattice/impactor: group {} has {} atoms; expected exactly 1",
               group->names[igroup], group->count(igroup));

  time_integrate = 1;
  time_origin = update->ntimestep;

  // the owner of the single atom contributes its position, every rank keeps a copy
  double mine[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < atom->nlocal; i++)
    if (atom->mask[i] & groupbit)
      for (int d = 0; d < 3; d++) mine[d] = atom->x[i][d];
  MPI_Allreduce(mine, x0, 3, MPI_DOUBLE, MPI_SUM, world);
}

int FixLatticeImpactor::setmask()
{
  return INITIAL_INTEGRATE | FINAL_INTEGRATE;
}

void FixLatticeImpactor::init()
{
  if (utils::strmatch(update->integrate_style, "^respa"))
    error->all(FLERR, "Fix lattice/impactor does not support run_style respa");
}

/* put the atom on its prescribed path at the current step's time */

void FixLatticeImpactor::place(bool set_x)
{
  double u, ud;
  drive.at((update->ntimestep - time_origin) * update->dt, update->dt, u, ud);
  double **x = atom->x;
  double **v = atom->v;
  for (int i = 0; i < atom->nlocal; i++) {
    if (!(atom->mask[i] & groupbit)) continue;
    if (set_x) {
      x[i][0] = x0[0] + u;
      x[i][1] = x0[1];
      x[i][2] = x0[2];
    }
    v[i][0] = ud;
    v[i][1] = v[i][2] = 0.0;
  }
}

void FixLatticeImpactor::setup(int /*vflag*/)
{
  place(false);
}

void FixLatticeImpactor::initial_integrate(int /*vflag*/)
{
  place(true);
}

void FixLatticeImpactor::final_integrate()
{
  place(false);
}
