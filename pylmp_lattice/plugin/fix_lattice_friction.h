/* Coulomb friction on a 1D chain of magnets; see fix_lattice_friction.cpp for the syntax. */

#ifndef PYLMP_LATTICE_FIX_LATTICE_FRICTION_H
#define PYLMP_LATTICE_FIX_LATTICE_FRICTION_H

#include "force_law.h"
#include "fix.h"
#include "kernel/coulomb.h"

namespace LAMMPS_NS {

class FixLatticeFriction : public Fix {
 public:
  FixLatticeFriction(class LAMMPS *, int, char **);
  int setmask() override;
  void init() override;
  void setup(int) override;
  void post_force(int) override;
  double compute_scalar() override;

 private:
  pl_kernel::Friction fr;              // mu, p, g
  bool from_bond;                      // F from the bond style (law bond), else from `law`
  int btype;                           // law bond: bond type whose single() gives F
  ForceLaw law;                        // an analytic or tabulated law (force_law.h)
  double work_done;                    // this rank's friction work up to the current step (J)
  double work_pending;                 // work of the current kick's second half, due at the next step
  bool periodic;                       // any periodic dimension: pick the closest image of neighbours

  void apply_friction(double kick, bool setup_kick);
  int neighbour(int, tagint);
  [[noreturn]] void missing_neighbour(int, tagint);
  double bond_force(int, int);
  double bond_style_force(int, int, double);
};

}    // namespace LAMMPS_NS

#endif
