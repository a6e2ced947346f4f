/* The nearest-neighbour force laws as the pylmp_lattice fixes (lattice/chain, and
   lattice/friction's analytic laws) read them from their arguments: the laws themselves are the
   chain kernel's (kernel/law.h); this adds the parsing, the checks of their parameters and the
   storage of a table's spline. Part of pylmp_lattice, GPL-2.0.

   Syntax at the fix's law keyword: power K b q | linear k r_free | table FILE KEYWORD (the file
   pylmp_lattice writes for bond_style table, interpolated by the clamped cubic spline that
   bond_style table spline uses, so both engines see the same function). */

#ifndef PYLMP_LATTICE_CHAIN_LAW_H
#define PYLMP_LATTICE_CHAIN_LAW_H

#include "kernel/law.h"

#include <string>
#include <vector>

namespace LAMMPS_NS {

struct ForceLaw : pl_kernel::Law {
  ForceLaw() = default;
  ForceLaw(const ForceLaw &) = delete;    // the table's spline points into `storage`
  ForceLaw &operator=(const ForceLaw &) = delete;

  /* parse "power K b q" | "linear k r_free" | "table FILE KEYWORD" at arg[iarg]; returns
     the index after the law's arguments; errors start with `who` (e.g. "Fix lattice/chain") */
  int parse(class LAMMPS *lmp, int narg, char **arg, int iarg, const std::string &who);

 private:
  std::vector<double> storage;    // a table's splines of F and U
  void read_table(class LAMMPS *lmp, const std::string &file, const std::string &keyword,
                  const std::string &who);
};

}    // namespace LAMMPS_NS

#endif
