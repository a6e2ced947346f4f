/* Impactor moved by a prescribed motion (impactor_drive.h); see fix_lattice_impactor.cpp for the syntax. */

#ifndef PYLMP_LATTICE_FIX_LATTICE_IMPACTOR_H
#define PYLMP_LATTICE_FIX_LATTICE_IMPACTOR_H

#include "fix.h"
#include "impactor_drive.h"

namespace LAMMPS_NS {

class FixLatticeImpactor : public Fix {
 public:
  FixLatticeImpactor(class LAMMPS *, int, char **);
  int setmask() override;
  void init() override;
  void setup(int) override;
  void initial_integrate(int) override;
  void final_integrate() override;

 private:
  ImpactorDrive drive;
  bigint time_origin;    // step at which the fix was defined: the drive's t = 0
  double x0[3];          // the atom's position then

  void place(bool set_x);
};

}    // namespace LAMMPS_NS

#endif
