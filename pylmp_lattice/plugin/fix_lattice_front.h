/* Front measures of each atom recorded during the run; see fix_lattice_front.cpp. */

#ifndef PYLMP_LATTICE_FIX_LATTICE_FRONT_H
#define PYLMP_LATTICE_FIX_LATTICE_FRONT_H

#include "fix.h"

namespace LAMMPS_NS {

class FixLatticeFront : public Fix {
 public:
  FixLatticeFront(class LAMMPS *, int, char **);
  ~FixLatticeFront() override;
  int setmask() override;
  void setup(int) override;
  void end_of_step() override;

  double memory_usage() override;
  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;

 private:
  double start_level, front_level, drop;    // velocity levels (velocity units)
  double pulse_drop;                         // relative fall that confirms a pulse's maximum
  double **rec;                              // per-atom record: outputs, then running state
  int rows;                                  // rows of rec allocated
  double t_prev;                             // time of the previous sample
  bigint step_prev;                          // its step (-1: no sample yet)

  void sample();
};

}    // namespace LAMMPS_NS

#endif
