/* fix lattice/chain: gaps, contacts and the potential energy. Part of pylmp_lattice, GPL-2.0. */

#include "fix_lattice_chain.h"

#include "atom.h"
#include "comm.h"
#include "error.h"
#include "timer.h"
#include "update.h"

#include <limits>

using namespace LAMMPS_NS;

/* every separation of this rank's bonds (each bond once, by its left atom): the potential
   energy, and the smallest and largest separation with the ID of their left atom */

void FixLatticeChain::bond_scan(double &pe, double &gap_min, tagint &tag_min, double &gap_max,
                                tagint &tag_max)
{
  const Column x = column(atom->x, xs);
  const tagint *tag = atom->tag;
  pe = 0.0;
  gap_min = std::numeric_limits<double>::infinity();
  gap_max = -gap_min;
  tag_min = tag_max = 0;
  auto bond = [&](int i, int j) {
    const double r = x[j] - x[i];
    pe += law.energy(r);
    if (r < gap_min) gap_min = r, tag_min = tag[i];
    if (r > gap_max) gap_max = r, tag_max = tag[i];
  };
  for (const Run &run : runs)
    for (int i = run.first; i <= run.last; i++) bond(i, i < run.last ? i + 1 : run.right);
  for (const End &e : impactors) bond(e.i, e.other);
}

std::atomic<int> FixLatticeChain::stop_asked{0};
std::atomic<int> FixLatticeChain::live{0};

/* Ask this process's runs of fix lattice/chain to stop softly at their next step, as LAMMPS's
   force_timeout does, but on every rank at the same step (see stop_asked). Returns the number of
   such fixes in this process: with none, nothing will take the request. Called from Python
   (pylmp_lattice.runner) through ctypes, from a signal handler's thread. */
int FixLatticeChain::request_stop()
{
  stop_asked.store(1);
  return live.load();
}

extern "C" __attribute__((visibility("default"))) int pylmp_lattice_request_stop()
{
  return FixLatticeChain::request_stop();
}

/* a bad separation seen on any rank: report a contact and stop, or stop with an error; a stop
   asked on any rank: stop (both flags in one reduction) */

void FixLatticeChain::check_gaps(int bad)
{
  enum { BAD_GAP = 1, STOP = 2 };
  const int mine = (bad ? BAD_GAP : 0) | (stop_asked.load(std::memory_order_relaxed) ? STOP : 0);
  int any = mine;
  // one rank: no reduction (an MPI_Allreduce at every step, 0.1 us of a 10^4-magnet step's 15)
  if (comm->nprocs > 1) MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_BOR, world);
  if (any & STOP) {
    stop_asked.store(0);
    if (comm->me == 0)
      utils::logmesg(lmp, "Fix lattice/chain: stopped on request (a signal) after step {}\n", update->ntimestep);
    timer->force_timeout();    // on every rank at this step: the run ends before the next
  }
  if (!(any & BAD_GAP)) return;
  double pe;
  struct {
    double value;
    int tag;
  } lo_in, lo_out, hi_in, hi_out;
  tagint tmin, tmax;
  bond_scan(pe, lo_in.value, tmin, hi_in.value, tmax);
  lo_in.tag = tmin;
  hi_in.tag = tmax;
  MPI_Allreduce(&lo_in, &lo_out, 1, MPI_DOUBLE_INT, MPI_MINLOC, world);
  MPI_Allreduce(&hi_in, &hi_out, 1, MPI_DOUBLE_INT, MPI_MAXLOC, world);
  const double t = update->atime + (update->ntimestep - update->atimestep) * update->dt;
  if (lo_out.value <= 0.0) {
    if (comm->me == 0)
      utils::logmesg(lmp, "CONTACT: magnets {} and {} gap {:.8g} m at t = {:.10g} s\n", lo_out.tag,
                     lo_out.tag + 1, lo_out.value, t);
    contact_step = update->ntimestep;
    timer->force_timeout();
    return;
  }
  const bool low = lo_out.value < range_lo;
  const int i = low ? lo_out.tag : hi_out.tag;
  // worded like bond_style table's error, whose length the runner turns into mm
  error->all(FLERR,
             "Fix lattice/chain: magnets {} and {} outside the table range [{}, {}] m at t = {} s "
             "(extend [table] r_max): type 1 length {}",
             i, i + 1, range_lo, range_hi, t, low ? lo_out.value : hi_out.value);
}

/* potential energy and smallest separation of the current step, computed once */

void FixLatticeChain::energies()
{
  if (energy_step == update->ntimestep) return;
  double pe, gmin, gmax;
  tagint tmin, tmax;
  bond_scan(pe, gmin, tmin, gmax, tmax);
  MPI_Allreduce(&pe, &pe_cached, 1, MPI_DOUBLE, MPI_SUM, world);
  MPI_Allreduce(&gmin, &gap_cached, 1, MPI_DOUBLE, MPI_MIN, world);
  energy_step = update->ntimestep;
}

