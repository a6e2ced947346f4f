/* The chain-specialised engine of pylmp_lattice; see fix_lattice_chain.cpp for the syntax.
   The class is spread over one file per concept:
     fix_lattice_chain.cpp   syntax, arguments, the fix's hooks and outputs
     chain_layout.cpp        where the atoms are: blocks, chain ends, slab edges between ranks,
                             the fix's own per-atom state
     chain_step.cpp          the two step paths (LAMMPS's arrays; the owned one pass, the chain
                             kernel's step_runs for this rank's slab)
     chain_front.cpp         the front record sampled inside the owned pass
     chain_checks.cpp        gaps, contacts, energy
   The physics is the chain kernel's (kernel/*.h: laws, drives, friction, front rules, the step),
   read from the arguments by force_law.h and impactor_drive.h. */

#ifndef PYLMP_LATTICE_FIX_LATTICE_CHAIN_H
#define PYLMP_LATTICE_FIX_LATTICE_CHAIN_H

#include "force_law.h"
#include "fix.h"
#include "impactor_drive.h"
#include "kernel/coulomb.h"
#include "kernel/step.h"

#include <atomic>
#include <vector>

namespace LAMMPS_NS {

class FixLatticeChain : public Fix {
 public:
  static int request_stop();    // a soft stop of this process's runs at their next step: see stop_asked
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
  int modify_param(int, char **) override;

  double memory_usage() override;
  void grow_arrays(int) override;
  void copy_arrays(int, int, int) override;
  int pack_exchange(int, double *) override;
  int unpack_exchange(int, double *) override;

 private:
  // blocks of at most BLOCK atoms, so that their bond forces (and, owning the state, the
  // velocities between the kicks) stay in the L1 cache between the loops that compute and use them.
  // 129: a block's 128 inner bonds fill whole vectors (2 or 4 doubles) in the owned pass's loop.
  // 10^4 magnets, CPU time against the C loop (best of 7, interleaved, load 3): 1.05x with the
  // front record and 1.40x without, where 128 gave 0.76x and 1.09x and 256 0.86x and 1.14x
  static constexpr int BLOCK = 129;

  // ---- the arguments (fix_lattice_chain.cpp)
  ForceLaw law;
  ImpactorDrive drive;
  bigint length;                 // atoms per chain: chain c holds IDs c*length+1 .. (c+1)*length
  bigint nchains;
  double range_lo, range_hi;     // allowed separations; r <= 0 is a contact
  bool friction;
  pl_kernel::Friction fr;        // mu, p, g
  bigint time_origin;            // step at which the fix was defined: the drive's t = 0
  std::vector<double> x0;        // each chain's impactor position then

  // per mass slot: half-kick dt/(2m), m, m g; a slot is the atom's type (set in init()) or,
  // with per-atom masses (atom->rmass), its local index (set in build_lists())
  std::vector<double> dtfm, mass_of, weight;
  std::vector<int> local_index;    // per-atom masses: 0, 1, ..., nlocal - 1
  bool one_type;                   // one mass for all atoms, slot 1
  double dtf;                      // dt/2 in force-to-velocity units
  bool fused;                    // the second half kick is done in post_force (no other fix needs f first)
  bool own_allowed;              // see init()
  bool own;                      // this run: the fix owns the state (see the header)
  bool clear_forces;             // LAMMPS does not clear the forces (neigh_modify include)
  class FixLatticeFront *front;  // the front record this fix samples while it owns the state
  double drive_u, drive_ud;      // the drive's displacement and velocity at the current step

  // ---- the state while the fix owns it: each atom's x, v, f along x (per-atom arrays that
  // move with their atoms between ranks; the atom arrays are written from them only when
  // something may read them). Ghost entries of xs: the slab-edge neighbours (below).
  double *xs, *vs, *fs;
  int nmax_state;
  std::vector<double> impactor_v;    // each chain's impactor velocity of the previous step

  // ---- the layout (chain_layout.cpp), rebuilt at every reneighbouring. Blocks: runs of up to
  // BLOCK free atoms that follow each other in memory with consecutive IDs, in ID order, with
  // the local/ghost index of the atom left of the first and right of the last
  using Run = pl_kernel::Run;
  std::vector<Run> runs;
  struct End {
    int i, other, chain;    // impactor: its right neighbour; held end: its left neighbour
  };
  std::vector<End> impactors, held;
  bool in_order;                 // every free local neighbour of a block is in the block next to it
  std::vector<tagint> layout_tags;    // the local atoms' IDs, in order, when the layout was built
  // slab edges: the ghosts, neighbours of this rank's atoms, whose x the rank left (0) or right (1)
  // in x sends at every owned step, and the local atoms whose x this rank sends it
  struct Edge {
    int rank;                    // the neighbouring rank, or MPI_PROC_NULL
    std::vector<int> send, recv;
    std::vector<double> out, in;
  } edges[2];
  bool edges_ok;                 // every such ghost is owned by the rank next in x (on all ranks)
  std::vector<double> bond_force;    // scratch: the forces of one block's bonds
  std::vector<double> scratch;       // scratch: positions of a block (AoS); the owned step's

  // ---- the front record inside the owned pass (chain_front.cpp): each block's active atoms
  // (how many, and the span of local indices lo..hi that holds them; they follow the front, so
  // the span is about as long as their number), and per local atom its start gate: its chain's
  // start level while it waits, else infinity (so the pass finds the atoms that start now with
  // one vectorised comparison)
  struct BlockFront {
    int active, lo, hi;
  };
  std::vector<BlockFront> block_front;
  std::vector<double> start_gate;
  std::vector<End> held_moving;    // the held ends that are sampled (chain_front.cpp)
  bool front_summarised = false;   // the three above are up to date (false after a reneighbouring)

  // ---- checks and energy (chain_checks.cpp)
  // friction work of each chain on this rank (see kernel/coulomb.h): done, due at the next step, and
  // this step's sums (each chain's runs add to it in ID order, as a one-chain run does)
  std::vector<double> work_done, work_pending;
  std::vector<pl_kernel::CoulombWork> works;
  bigint energy_step;                // step at which pe_cached and gap_cached were computed
  double pe_cached, gap_cached;
  bigint contact_step;               // step of a contact found, or -1
  // A soft stop asked of this process (pylmp_lattice_request_stop, chain_checks.cpp: a signal to
  // an MPI hand run) is taken at the next step by every rank at once: it rides on the gap
  // check's reduction, where LAMMPS's force_timeout, called by each rank as its signal comes,
  // stops each at its own step and leaves the others waiting in an exchange for ever.
  static std::atomic<int> stop_asked;     // asked, not yet taken
  static std::atomic<int> live;           // instances of this fix in this process

  // owning the state on several ranks, this run: this rank's CPU time in its passes and wall
  // time in the exchanges (slab edges, contact flag), reported at the end (benchmarks/bench_mpi.py)
  double pass_cpu, exchange_wall, exchange_min;    // exchange_min: the fastest step's
  bigint owned_steps;

  // x, v or f along x: the fix's arrays while it owns the state, else the atom arrays
  struct Column {
    double *p;
    int stride;
    double &operator[](int i) const { return p[stride * i]; }
  };
  Column column(double **a, double *s) const { return own ? Column{s, 1} : Column{a[0], 3}; }

  // chain_layout.cpp
  void build_lists();
  void find_edges();
  bool split_by_slabs_or_chains() const;
  void send_edges();
  bool is_free(int i) const;
  const int *slots() const;
  // fix_lattice_chain.cpp
  void place_impactors(bool set_x);
  void gather();
  void scatter();
  void clear();
  // chain_step.cpp
  void forces(double kick, bool setup_kick, bool kick_v);
  void own_pass();
  void own_steps(bool record, int &bad);
  void end_forces();
  void settle_work(double kick, bool setup_kick);
  pl_kernel::Masses masses() const;
  // the owned step's hook into the front record (kernel/step.h's FrontPass)
  struct FrontHook {
    static constexpr bool PER_ATOM = false;    // a block's rows after its kicks
    FixLatticeChain *fix;
    void sample_block(int b, const double *v_before, bool starting)
    {
      if (fix->block_front[b].active > 0 || starting) fix->sample_front_block(b, v_before, starting);
    }
  };
  template <bool FRICTION, bool KICK, class Law> void run_forces(const Law law, double kick, bool setup_kick, int &bad);
  template <bool FRICTION, bool FRONT, class Law> void own_step(const Law law, int &bad);
  // chain_front.cpp
  void sample_front_block(int b, const double *v_before, bool starting);
  void sample_front_ends();
  void summarise_front();
  // chain_checks.cpp
  void check_gaps(int bad);
  void bond_scan(double &pe, double &gap_min, tagint &tag_min, double &gap_max, tagint &tag_max);
  void energies();
};

}    // namespace LAMMPS_NS

#endif
