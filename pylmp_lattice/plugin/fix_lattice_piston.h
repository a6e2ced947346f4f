/* Impactor driven by a measured time series; see fix_lattice_piston.cpp for the syntax. */

#ifndef PYLMP_LATTICE_FIX_LATTICE_PISTON_H
#define PYLMP_LATTICE_FIX_LATTICE_PISTON_H

#include "fix.h"
#include "measured_motion.h"

#include <string>

namespace LAMMPS_NS {

class FixLatticePiston : public Fix {
 public:
  FixLatticePiston(class LAMMPS *, int, char **);
  int setmask() override;
  void init() override;
  void setup(int) override;
  void initial_integrate(int) override;
  void final_integrate() override;

 private:
  std::string path;
  bool given_velocity;    // the file's column is v (else u)
  bool hold_after;        // past the data: hold the last position (else stop the run)
  bigint time_origin;     // step at which the fix was defined: file time t[0]
  double x0[3];           // the atom's position then

  MeasuredMotion spline;    // the file's motion

  void place(bool set_x);
};

}    // namespace LAMMPS_NS

#endif
