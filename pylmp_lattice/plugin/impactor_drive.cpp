/* The impactor's prescribed motion (see impactor_drive.h). Part of pylmp_lattice, GPL-2.0. */

#include "impactor_drive.h"

#include "error.h"
#include "lammps.h"
#include "utils.h"


using namespace LAMMPS_NS;

int ImpactorDrive::parse(LAMMPS *lmp, int narg, char **arg, int iarg, const std::string &name)
{
  Error *error = lmp->error;
  who = name;
  if (iarg >= narg) utils::missing_cmd_args(FLERR, who + " impactor", error);
  const std::string kind = arg[iarg];
  const int nargs = kind == "constant" ? 1 : (kind == "ramp" || kind == "sine") ? 2 : kind == "measured" ? 6 : 0;
  if (iarg + nargs >= narg) utils::missing_cmd_args(FLERR, who + " impactor " + kind, error);
  if (kind == "constant" || kind == "ramp" || kind == "sine") {
    drive.profile = kind == "constant" ? pl_kernel::Drive::CONSTANT
        : kind == "ramp"               ? pl_kernel::Drive::RAMP
                                       : pl_kernel::Drive::SINE;
    drive.V = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    if (nargs == 2) drive.T = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
    if (nargs == 2 && !(drive.T > 0.0)) error->all(FLERR, "{}: impactor {} needs a time > 0", who, kind);
  } else if (kind == "rest") {
    drive.profile = pl_kernel::Drive::REST;
  } else if (kind == "measured") {
    // measured file PATH column u|v after hold|stop
    const std::string column = arg[iarg + 4], after = arg[iarg + 6];
    if (std::string(arg[iarg + 1]) != "file" || std::string(arg[iarg + 3]) != "column" ||
        std::string(arg[iarg + 5]) != "after" || (column != "u" && column != "v") ||
        (after != "hold" && after != "stop"))
      error->all(FLERR, "{}: expected impactor measured file PATH column u|v after hold|stop", who);
    load_measured(arg[iarg + 2], column == "v", after == "hold", lmp, who);
  } else
    error->all(FLERR, "{}: unknown impactor '{}'; expected constant, ramp, sine, rest or measured", who, kind);
  return iarg + 1 + nargs;
}

void ImpactorDrive::load_measured(const std::string &path, bool given_velocity, bool hold_after,
                                  LAMMPS *lmp, const std::string &name)
{
  who = name;
  measured.load(path, given_velocity, hold_after, lmp->error, who.c_str());
  drive.profile = pl_kernel::Drive::MEASURED;
  drive.measured = measured.spline();
}

void ImpactorDrive::at(double t, double dt, double &u, double &ud) const
{
  if (!drive.at(t, dt, u, ud)) measured.past_end(t);
}
