/* Coulomb friction on a 1D chain of magnets; see fix_lattice_friction.cpp for the syntax. */

#ifndef PYLMP_LATTICE_FIX_LATTICE_FRICTION_H
#define PYLMP_LATTICE_FIX_LATTICE_FRICTION_H

#include "fix.h"

namespace LAMMPS_NS {

class FixLatticeFriction : public Fix {
 public:
  FixLatticeFriction(class LAMMPS *, int, char **);
  ~FixLatticeFriction() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void post_force(int) override;
  double compute_scalar() override;

 private:
  double mu, p, g;
  int btype;               // bond type whose force law gives the neighbour forces
  double work_done;        // this rank's friction work up to the current step (J)
  double work_pending;     // work of the current kick's second half, due at the next step
  double *fright;          // per atom slot: repulsive force from the right neighbour
  double *rsq_right;       // per atom slot: squared separation fright was computed at
  int nmax;
  bool periodic;           // any periodic dimension: pick the closest image of neighbours

  void apply_friction(double kick, bool setup_kick);
  int neighbour(int, tagint);
  [[noreturn]] void missing_neighbour(int, tagint);
  double bond_force(int, int);
};

}    // namespace LAMMPS_NS

#endif
