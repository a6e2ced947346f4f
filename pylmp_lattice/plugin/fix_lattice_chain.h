/* The chain-specialised engine of pylmp_lattice; see fix_lattice_chain.cpp for the syntax. */

#ifndef PYLMP_LATTICE_FIX_LATTICE_CHAIN_H
#define PYLMP_LATTICE_FIX_LATTICE_CHAIN_H

#include "chain_law.h"
#include "coulomb.h"
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
  void pre_exchange() override;
  void pre_neighbor() override;
  void setup(int) override;
  void setup_pre_force(int) override;
  void pre_force(int) override;
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
  bool own_allowed, in_order;    // see init() and build_lists()
  bool own;                      // this run: the fix owns the state (shadow arrays, see the header)
  bool clear_forces;             // LAMMPS does not clear the forces (neigh_modify include)
  class FixLatticeFront *front;  // the front record this fix samples while it owns the state

  // own: each local atom's x, v, f along x (index = local index); the atom arrays are written
  // from them only when something may read them
  std::vector<double> xs, vs, fs;
  std::vector<double> impactor_v;    // own: each chain's impactor velocity of the previous step
  // own, with a front record: each block's (runs[b]) active and waiting atoms
  struct BlockFront {
    int active, waiting;
  };
  std::vector<BlockFront> block_front;

  // local layout, rebuilt at every reneighbouring: runs of up to BLOCK free atoms that follow
  // each other in memory with consecutive IDs, with the local/ghost index of the atom left
  // of the first and right of the last; the chain ends held apart
  struct Run {
    int first, last, left, right;
    bool operator==(const Run &o) const
    {
      return first == o.first && last == o.last && left == o.left && right == o.right;
    }
  };
  std::vector<Run> runs;
  struct End {
    int i, other, chain;    // impactor: its right neighbour; held end: its left neighbour
    bool operator==(const End &o) const { return i == o.i && other == o.other && chain == o.chain; }
  };
  std::vector<End> impactors, held;
  std::vector<double> bond_force;    // scratch: the forces of one run's bonds
  std::vector<double> scratch;       // scratch: positions of two runs (AoS), velocities (own)
  double drive_u, drive_ud;      // the drive's displacement and velocity at the current step

  double work_done, work_pending;    // friction work (see coulomb.h)
  bigint energy_step;                // step at which pe_cached and gap_cached were computed
  double pe_cached, gap_cached;
  bigint contact_step;               // step of a contact found, or -1

  // x, v or f along x: the shadow arrays while the fix owns the state, else the atom arrays
  struct Column {
    double *p;
    int stride;
    double &operator[](int i) const { return p[stride * i]; }
  };
  Column column(double **a, std::vector<double> &s) const { return own ? Column{s.data(), 1} : Column{a[0], 3}; }

  void build_lists();
  void drive(bigint step);
  void place_impactors(bool set_x);
  void forces(double kick, bool setup_kick, bool kick_v);
  void end_forces();
  template <bool FRICTION>
  double total_force(double left, double right, int t, double kick, double &v, CoulombWork &work) const;
  template <bool FRICTION, bool KICK, class Law> void run_forces(const Law law, double kick, bool setup_kick, int &bad);
  template <bool FRICTION, bool FRONT, class Law> void own_step(const Law law, int &bad);
  void sample_front_block(int b, const double *v_before);
  void summarise_front();
  void sample_front_ends();
  void gather();
  void clear();
  void scatter();
  void check_gaps(int bad);
  void bond_scan(double &pe, double &gap_min, tagint &tag_min, double &gap_max, tagint &tag_max);
  void energies();
};

}    // namespace LAMMPS_NS

#endif
