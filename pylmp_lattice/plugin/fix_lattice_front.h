/* Front measures of each atom recorded during the run; see fix_lattice_front.cpp. */

#ifndef PYLMP_LATTICE_FIX_LATTICE_FRONT_H
#define PYLMP_LATTICE_FIX_LATTICE_FRONT_H

#include "atom.h"
#include "fix.h"
#include "kernel/front.h"

#include <string>
#include <vector>

namespace LAMMPS_NS {

// the per-atom rules of the record (the chain kernel's)
namespace FrontRecord = pl_kernel::front;

class FixLatticeFront : public Fix {
 public:
  FixLatticeFront(class LAMMPS *, int, char **);
  ~FixLatticeFront() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void end_of_step() override;
  void post_run() override;

  double memory_usage() override;
  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;

  // For fix lattice/chain, which samples the record inside its own pass when it owns the step:
  // the levels and per-atom state (front_rules.h), and the step's sample times; begin_sample
  // returns false if this step was sampled already. After its last sample the owner hands the
  // waiting atoms' previous velocities back with set_previous_velocities.
  FrontRecord::Levels levels;
  // chain c's levels (keywords length and levels; else `levels` for all)
  const FrontRecord::Levels &chain_levels(bigint c) const { return per_chain.empty() ? levels : per_chain[c]; }
  const FrontRecord::Levels &levels_of(int i) const
  {
    return per_chain.empty() ? levels : per_chain[(atom->tag[i] - 1) / length];
  }
  double **rec;                              // rows: outputs, then running state
  double *mark, *vprev;                      // hot state; vprev: waiting atoms' last v
  unsigned char *phase;
  bool begin_sample(FrontRecord::Sample &);
  void end_sample();
  const FrontRecord::Sample &current_sample() const { return current; }
  void set_previous_velocities(const double *v, int stride);

  /* The one per-atom sampling routine past the hot part (mark_max), for this fix's own pass and
     fix lattice/chain's: the row of atom i if it is active or reaches the start level now, with
     its v, f along x and mass at this sample, and v_waiting, its v at the previous sample (used
     only if it was waiting), and L, the levels of its chain (levels_of). */
  void sample_row(int i, double v, double f, double m, double v_waiting, const FrontRecord::Levels &L)
  {
    FrontRecord::sample_row(rec[i], phase[i], v, f, m, v_waiting, L, current);
  }
  // the same, the levels looked up (a division by the chain length: only for an atom not finished)
  void sample_row(int i, double v, double f, double m, double v_waiting)
  {
    if (phase[i] != FrontRecord::FINISHED) sample_row(i, v, f, m, v_waiting, levels_of(i));
  }

 private:
  int rows;                                  // per-atom arrays allocated
  bigint length;                             // atoms per chain, with per-chain levels
  std::vector<FrontRecord::Levels> per_chain;
  double *shown;                             // what the rows' V_ABS_MAX column holds
  bool refresh_every_step;                   // another fix might read the record at any step
  double t_prev;                             // time of the previous sample
  bigint step_prev;                          // its step (-1: no sample yet)
  FrontRecord::Sample current;

  void sample();
  void refresh();
  void check(const FrontRecord::Levels &);
  void read_levels(const std::string &file);
};

}    // namespace LAMMPS_NS

#endif
