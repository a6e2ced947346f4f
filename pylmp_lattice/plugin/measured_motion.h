/* A measured impactor motion u(t) or v(t) read from a file: the reading and its checks; the
   spline is the chain kernel's (kernel/drive.h, fitted by kernel/fit.h). Shared by fix
   lattice/impactor and fix lattice/chain. Part of pylmp_lattice, GPL-2.0. */

#ifndef PYLMP_LATTICE_MEASURED_MOTION_H
#define PYLMP_LATTICE_MEASURED_MOTION_H

#include "kernel/drive.h"

#include <string>
#include <vector>

namespace LAMMPS_NS {

class Error;

class MeasuredMotion {
 public:
  MeasuredMotion() = default;
  MeasuredMotion(const MeasuredMotion &) = delete;    // the spline points into the vectors
  MeasuredMotion &operator=(const MeasuredMotion &) = delete;
  /* read `path` (two columns t, value; blanks or commas; '#' comments; >= 4 samples,
     t strictly increasing) and fit the spline; errors go through `error` with `who` */
  void load(const std::string &path, bool given_velocity, bool hold_after, Error *error,
            const char *who);
  /* the kernel's spline of the samples */
  const pl_kernel::Measured &spline() const { return fitted; }
  /* the error of a run past the data at time tau after t[0] (kernel's Measured::at said so) */
  [[noreturn]] void past_end(double tau) const;

 private:
  std::string path, who;
  Error *error = nullptr;
  std::vector<double> t, y, storage;    // knots, values; the fit's d2y and integral
  pl_kernel::Measured fitted;

  void read_file();
};

}    // namespace LAMMPS_NS

#endif
