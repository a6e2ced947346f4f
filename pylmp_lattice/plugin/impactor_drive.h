/* The impactor's prescribed motion as fix lattice/chain (each chain's first atom) and fix
   lattice/impactor (one atom) read it from their arguments: the motions themselves are the chain
   kernel's (kernel/drive.h). Its Python twin is pylmp_lattice/impactor.py, which
   tests/test_plugin.py binds it to. Part of pylmp_lattice, GPL-2.0.

   Syntax (at the fix's `impactor` keyword, or as lattice/impactor's arguments):
     constant V | ramp V T | sine V T | rest | measured file PATH column u|v after hold|stop
   constant: u = V t; ramp: v rises linearly to V over T, then constant; sine: v = V sin(pi t / T)
   for t < T, then at rest; rest: held in place; measured: the spline of a series
   (measured_motion.h). t counts from the step at which the fix was defined. */

#ifndef PYLMP_LATTICE_IMPACTOR_DRIVE_H
#define PYLMP_LATTICE_IMPACTOR_DRIVE_H

#include "measured_motion.h"

#include <string>

namespace LAMMPS_NS {

class LAMMPS;

class ImpactorDrive {
 public:
  /* the drive's arguments at arg[iarg]; returns the index after them; errors start with `who` */
  int parse(LAMMPS *lmp, int narg, char **arg, int iarg, const std::string &who);
  /* the measured drive from a file, as fix lattice/impactor's `file PATH column u|v` reads it */
  void load_measured(const std::string &path, bool given_velocity, bool hold_after, LAMMPS *lmp,
                     const std::string &who);
  /* displacement u and velocity ud at time t from the origin; dt: the time step (a measured
     run meant to end on the last sample may overshoot it by round-off) */
  void at(double t, double dt, double &u, double &ud) const;
  /* the kernel's drive (its measured samples are this object's) */
  const pl_kernel::Drive &kernel() const { return drive; }

 private:
  pl_kernel::Drive drive;
  MeasuredMotion measured;
  std::string who;
};

}    // namespace LAMMPS_NS

#endif
