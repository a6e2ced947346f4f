/* The chain-specialised engine of pylmp_lattice; see fix_lattice_chain.cpp for the syntax. */

#ifndef PYLMP_LATTICE_FIX_LATTICE_CHAIN_H
#define PYLMP_LATTICE_FIX_LATTICE_CHAIN_H

#include "chain_law.h"
#include "fix.h"
#include "measured_motion.h"

#include <vector>

namespace LAMMPS_NS {

class FixLatticeChain : public Fix {
 public:
  FixLatticeChain(class LAMMPS *, int, char **);
  ~FixLatticeChain() override;
  int setmask() override;
  void init() override;
  void setup_pre_neighbor() override;
  void pre_neighbor() override;
  void setup(int) override;
  void initial_integrate(int) override;
  void post_force(int) override;
  void final_integrate() override;
  void post_run() override;
  double compute_scalar() override;
  double compute_vector(int) override;

 private:
  ChainLaw law;
  bigint length;                 // atoms per chain: chain c holds IDs c*length+1 .. (c+1)*length
  bigint nchains;
  double range_lo, range_hi;     // allowed separations; r <= 0 is a contact
  bool friction;
  double mu, p, g;
  enum { CONSTANT, RAMP, SINE, REST, MEASURED } profile;
  double drive_v, drive_t;       // peak velocity and ramp time or pulse length
  MeasuredMotion measured;
  bigint time_origin;            // step at which the fix was defined: the drive's t = 0
  std::vector<double> x0;        // each chain's impactor position then

  // per-type constants, set in init(): half-kick dt/(2m), m, m g
  std::vector<double> dtfm, mass_of, weight;
  bool fused;                    // the second half kick is done in post_force (no other fix needs f first)
  bool lazy_allowed, in_order;   // one rank, nothing between the passes, blocks in chain order
  bool lazy;                     // this run: the drift waits for post_force (see init())
  std::vector<double> f_last;    // lazy: each atom's force of the last step, by local index

  // local layout, rebuilt at every reneighbouring: runs of up to 512 free atoms that follow
  // each other in memory with consecutive IDs, with the local/ghost index of the atom left
  // of the first and right of the last; the chain ends held apart
  struct Run {
    int first, last, left, right;
  };
  std::vector<Run> runs;
  struct End {
    int i, other, chain;    // impactor: its right neighbour; held end: its left neighbour
  };
  std::vector<End> impactors, held;
  std::vector<double> bond_force;    // scratch: the forces of one run's bonds
  std::vector<double> positions;     // scratch: two runs' positions (see run_forces)
  double drive_u, drive_ud;      // the drive's displacement and velocity at the current step

  double work_done, work_pending;    // friction work (see coulomb.h)
  bigint energy_step;                // step at which pe_cached and gap_cached were computed
  double pe_cached, gap_cached;
  bigint contact_step;               // step of a contact found, or -1

  void build_lists();
  void drive(bigint step);
  void place_impactors(bool set_x);
  void forces(double kick, bool setup_kick, bool kick_v);
  // the force pass: NO_KICK (setup, or the kick left to final_integrate), KICK (the second
  // half kick too), LAZY (also the first half kick and drift, one block ahead)
  enum { NO_KICK, KICK, LAZY };
  template <bool FRICTION, int MODE, class Law> void run_forces(const Law law, double kick, bool setup_kick, int &bad);
  void check_gaps(int bad);
  void bond_scan(double &pe, double &gap_min, tagint &tag_min, double &gap_max, tagint &tag_max);
  void energies();
};

}    // namespace LAMMPS_NS

#endif
