/* ----------------------------------------------------------------------
   fix lattice/piston: impactor moved along x by a measured time series
   Part of pylmp_lattice, GPL-2.0. Compiled as a LAMMPS plugin.

Syntax
   fix ID group-ID lattice/piston file path column u|v keyword value ...

   group-ID must contain exactly one atom (the impactor)
   path = text file with two columns, time and value, one sample a line
   u = the value is the displacement (distance units, m in units si)
   v = the value is the velocity (velocity units, m/s in units si)
   zero or more keyword/value pairs may be appended
     after value = hold or stop (default stop)
       hold = after the last sample keep the last position with zero velocity
       stop = stop the run with an error if it goes past the last sample

Examples
   fix drive impactor lattice/piston file impactor_u.txt column u after hold
   fix drive impactor lattice/piston file impactor_v.csv column v

Description
   Columns may be separated by blanks or commas; '#' starts a comment. At least 4
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

#include "fix_lattice_piston.h"

#include "atom.h"
#include "error.h"
#include "group.h"
#include "update.h"

#include <algorithm>
#include <cstring>
#include <fstream>

using namespace LAMMPS_NS;
using namespace FixConst;

FixLatticePiston::FixLatticePiston(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), given_velocity(false), hold_after(false)
{
  if (narg < 7) utils::missing_cmd_args(FLERR, "fix lattice/piston", error);
  if (strcmp(arg[3], "file") != 0)
    error->all(FLERR, "Fix lattice/piston: expected 'file <path>', got '{}'", arg[3]);
  path = arg[4];
  if (strcmp(arg[5], "column") != 0)
    error->all(FLERR, "Fix lattice/piston: expected 'column u|v', got '{}'", arg[5]);
  if (strcmp(arg[6], "v") == 0) given_velocity = true;
  else if (strcmp(arg[6], "u") != 0)
    error->all(FLERR, "Fix lattice/piston: column '{}' unknown; choose one of 'u', 'v'", arg[6]);

  for (int iarg = 7; iarg < narg; iarg += 2) {
    if (strcmp(arg[iarg], "after") != 0)
      error->all(FLERR, "Fix lattice/piston: unknown keyword '{}'; expected 'after'", arg[iarg]);
    if (iarg + 1 >= narg) utils::missing_cmd_args(FLERR, "fix lattice/piston after", error);
    if (strcmp(arg[iarg + 1], "hold") == 0) hold_after = true;
    else if (strcmp(arg[iarg + 1], "stop") == 0) hold_after = false;
    else
      error->all(FLERR, "Fix lattice/piston: after '{}' unknown; choose one of 'hold', 'stop'",
                 arg[iarg + 1]);
  }

  if (group->count(igroup) != 1)
    error->all(FLERR, "Fix lattice/piston: group {} has {} atoms; expected exactly 1",
               group->names[igroup], group->count(igroup));

  time_integrate = 1;
  time_origin = update->ntimestep;

  // the owner of the single atom contributes its position, every rank keeps a copy
  double mine[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < atom->nlocal; i++)
    if (atom->mask[i] & groupbit)
      for (int d = 0; d < 3; d++) mine[d] = atom->x[i][d];
  MPI_Allreduce(mine, x0, 3, MPI_DOUBLE, MPI_SUM, world);

  read_file();
  fit_spline();
}

int FixLatticePiston::setmask()
{
  return INITIAL_INTEGRATE | FINAL_INTEGRATE;
}

void FixLatticePiston::init()
{
  if (utils::strmatch(update->integrate_style, "^respa"))
    error->all(FLERR, "Fix lattice/piston does not support run_style respa");
}

/* Every rank reads the (small) file itself, so every rank reaches the same error. */

void FixLatticePiston::read_file()
{
  std::ifstream in(path);
  if (!in) error->all(FLERR, "Fix lattice/piston: cannot open file {}", path);

  std::string line;
  for (int lineno = 1; std::getline(in, line); lineno++) {
    std::replace(line.begin(), line.end(), ',', ' ');
    auto words = utils::split_words(utils::trim_comment(line));
    if (words.empty()) continue;
    if (words.size() != 2 || !utils::is_double(words[0]) || !utils::is_double(words[1]))
      error->all(FLERR, "Fix lattice/piston: {} line {}: expected two numbers 't value', got '{}'",
                 path, lineno, utils::trim(line));
    const double ti = std::stod(words[0]);
    if (!t.empty() && ti <= t.back())
      error->all(FLERR,
                 "Fix lattice/piston: {} line {}: time {} does not increase (previous {}); "
                 "times must increase strictly",
                 path, lineno, ti, t.back());
    t.push_back(ti);
    y.push_back(std::stod(words[1]));
  }
  if (t.size() < 4)
    error->all(FLERR, "Fix lattice/piston: {} has {} samples; need at least 4", path, t.size());
}

/* Not-a-knot cubic spline: the third derivative is continuous at t[1] and t[n-2].
   Eliminating d2y[0] and d2y[n-1] with these conditions leaves a tridiagonal
   system for d2y[1..n-2], solved by the Thomas algorithm. */

void FixLatticePiston::fit_spline()
{
  const int n = t.size();
  std::vector<double> h(n - 1), lo(n), di(n), up(n), rhs(n);
  for (int i = 0; i < n - 1; i++) h[i] = t[i + 1] - t[i];
  for (int i = 1; i < n - 1; i++) {
    lo[i] = h[i - 1];
    di[i] = 2.0 * (h[i - 1] + h[i]);
    up[i] = h[i];
    rhs[i] = 6.0 * ((y[i + 1] - y[i]) / h[i] - (y[i] - y[i - 1]) / h[i - 1]);
  }
  // d2y[0] = ((h0 + h1) d2y[1] - h0 d2y[2]) / h1, and its mirror image at the right end
  di[1] += h[0] * (h[0] + h[1]) / h[1];
  up[1] -= h[0] * h[0] / h[1];
  const double a = h[n - 3], b = h[n - 2];
  di[n - 2] += b * (a + b) / a;
  lo[n - 2] -= b * b / a;

  for (int i = 2; i < n - 1; i++) {
    const double w = lo[i] / di[i - 1];
    di[i] -= w * up[i - 1];
    rhs[i] -= w * rhs[i - 1];
  }
  d2y.assign(n, 0.0);
  d2y[n - 2] = rhs[n - 2] / di[n - 2];
  for (int i = n - 3; i >= 1; i--) d2y[i] = (rhs[i] - up[i] * d2y[i + 1]) / di[i];
  d2y[0] = ((h[0] + h[1]) * d2y[1] - h[0] * d2y[2]) / h[1];
  d2y[n - 1] = ((a + b) * d2y[n - 2] - b * d2y[n - 3]) / a;

  yint.assign(n, 0.0);
  for (int i = 0; i < n - 1; i++)
    yint[i + 1] = yint[i] + 0.5 * h[i] * (y[i] + y[i + 1]) -
        h[i] * h[i] * h[i] * (d2y[i] + d2y[i + 1]) / 24.0;
}

/* displacement u and velocity ud at time tau after the fix was defined */

void FixLatticePiston::motion(double tau, double &u, double &ud) const
{
  const int n = t.size();
  double time = t[0] + tau;
  // a run meant to end on the last sample may overshoot it by round-off
  const bool past_end = time > t[n - 1] + 1.0e-6 * update->dt;
  if (past_end && !hold_after)
    error->all(FLERR,
               "Fix lattice/piston: time {} s is past the end of the data in {} "
               "(last sample {} s); shorten the run or use 'after hold'",
               time, path, t[n - 1]);
  time = std::min(time, t[n - 1]);

  const int k = std::min<int>(std::upper_bound(t.begin(), t.end(), time) - t.begin() - 1, n - 2);
  const double h = t[k + 1] - t[k];
  const double A = (t[k + 1] - time) / h, B = 1.0 - A;
  const double c = h * h / 6.0;
  const double value = A * y[k] + B * y[k + 1] + c * ((A * A * A - A) * d2y[k] + (B * B * B - B) * d2y[k + 1]);
  const double slope = (y[k + 1] - y[k]) / h +
      h / 6.0 * (-(3.0 * A * A - 1.0) * d2y[k] + (3.0 * B * B - 1.0) * d2y[k + 1]);

  if (given_velocity) {
    const double integral = yint[k] + h * (0.5 * (1.0 - A * A) * y[k] + 0.5 * B * B * y[k + 1]) +
        h * c * ((0.25 * (1.0 - A * A * A * A) - 0.5 * (1.0 - A * A)) * d2y[k] +
                 (0.25 * B * B * B * B - 0.5 * B * B) * d2y[k + 1]);
    u = integral;
    ud = value;
  } else {
    u = value - y[0];
    ud = slope;
  }
  if (past_end) ud = 0.0;    // holding the last position
}

/* put the atom on its prescribed path at the current step's time */

void FixLatticePiston::place(bool set_x)
{
  double u, ud;
  motion((update->ntimestep - time_origin) * update->dt, u, ud);
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

void FixLatticePiston::setup(int /*vflag*/)
{
  place(false);
}

void FixLatticePiston::initial_integrate(int /*vflag*/)
{
  place(true);
}

void FixLatticePiston::final_integrate()
{
  place(false);
}
