/* ----------------------------------------------------------------------
   fix lattice/front: front measures of each atom, recorded every step
   Part of pylmp_lattice, GPL-2.0. Compiled as a LAMMPS plugin.

Syntax
   fix ID group-ID lattice/front start S front L drop D pulse_drop R [pulse_floor P] [length n levels FILE]

   S, L, D = velocity levels (velocity units, m/s in units si), 0 < S <= L, D > 0
   R = relative fall that confirms a pulse's maximum, 0 < R < 1
   P = least absolute fall that confirms a pulse's maximum (velocity units), P >= 0, default 0
   (pylmp_lattice sets S, L, D and P against V_I and the chain's noise: measures/levels.py)
   length n levels FILE = per-chain levels for several chains in one run (batched replicas,
     as fix lattice/chain's length): FILE has one row "S L D R P" per chain of n atoms
     (chain c: IDs c n + 1 .. c n + n), used for its atoms instead of the levels above

Example
   fix front all lattice/front start 0.02 front 1.0 drop 0.1 pulse_drop 0.1
   ...
   run 60000
   write_dump all custom front.bin id f_front[*] modify sort id time yes

Description
   Every time step (and once in the setup of the first run) the fix samples each atom's
   velocity v = vx and acceleration a = fx / m after the step is complete, as a dump at
   that step would see them, and keeps seven numbers per atom (a per-atom array, NaN where
   a measure does not exist):
     1 start time: first time v reaches S
     2 arrival time: first time v reaches L (the front)
     3 first peak time
     4 first peak velocity
     5 first peak acceleration
     6 largest |v| so far
     7 pulse arrival: time of the first maximum of v from the start of motion
   They are the array measures of pylmp_lattice/measures.py (arrival_times, first_peaks)
   applied to the record of every step, with the same definitions:
   - a crossing time is interpolated linearly between the last sample below the level and
     the first at or above it (the time of the first sample if that is already there);
   - the first peak is the largest sample from the front on, confirmed once v has fallen
     by D below the running maximum; its time and value are the vertex of the parabola
     through it and its two neighbouring samples (where these are concave);
   - the first peak acceleration is the largest a from the first sample at or above S up
     to the peak's sample, refined by the same parabola when it lies strictly inside;
   - the pulse arrival (measures.arrival_times, method "velocity_peak") is found like the
     first peak, but searched from the first sample at or above S and confirmed by a fall of
     R times the maximum, or P if that is larger.
   Ties go to the earliest sample, as numpy's argmax does. Atoms outside the group keep
   NaN. The records move with their atoms between MPI ranks.

Implementation
   The per-atom rules are the chain kernel's (kernel/front.h), shared with fix lattice/chain
   and the engines. Each step touches,
   per atom, only a hot state (the largest |v| so far, the previous v of a
   waiting atom, a phase byte); a row of the record (NCOL doubles) is touched only for the few
   atoms between their start and both peaks confirmed. The output column 6 (largest |v|) is
   copied from the hot state when something may read the record: at output steps, at the end
   of a run, and at every step if any fix other than lattice/chain and lattice/front runs
   during steps (it might read f_ID at any step). When fix lattice/chain owns the whole time
   step (no other per-step fix; on any number of ranks; see its header) it applies the same rules inside
   its force pass and this fix's end_of_step only refreshes the output.

Restrictions
   Not for rRESPA. The time step must not change during the record.
------------------------------------------------------------------------- */

#include "fix_lattice_front.h"

#include "atom.h"
#include "error.h"
#include "memory.h"
#include "modify.h"
#include "output.h"
#include "update.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <string>

using namespace LAMMPS_NS;
using namespace FixConst;
using namespace FrontRecord;

namespace {
// per-atom doubles moved between ranks: the row, then mark, vprev, phase and shown
constexpr int NPACK = NCOL + 4;

const double NaN = pl_kernel::quiet_nan();

bool same_bits(double a, double b)
{
  return std::memcmp(&a, &b, sizeof(double)) == 0;
}
}    // namespace

FixLatticeFront::FixLatticeFront(LAMMPS *lmp, int narg, char **arg) :
    Fix(lmp, narg, arg), rec(nullptr), mark(nullptr), vprev(nullptr), phase(nullptr), shown(nullptr), rows(0),
    length(0), refresh_every_step(true), t_prev(0.0), step_prev(-1)
{
  if (narg < 11)
    utils::missing_cmd_args(FLERR, "fix lattice/front start S front L drop D pulse_drop R [pulse_floor P]", error);
  const char *keys[4] = {"start", "front", "drop", "pulse_drop"};
  double *values[4] = {&levels.start, &levels.front, &levels.drop, &levels.pulse_drop};
  for (int k = 0; k < 4; k++) {
    if (strcmp(arg[3 + 2 * k], keys[k]) != 0)
      error->all(FLERR, "Fix lattice/front: expected '{}', got '{}'", keys[k], arg[3 + 2 * k]);
    *values[k] = utils::numeric(FLERR, arg[4 + 2 * k], false, lmp);
  }
  std::string file;
  for (int iarg = 11; iarg < narg; iarg += 2) {
    const std::string key = arg[iarg];
    if (iarg + 1 >= narg) utils::missing_cmd_args(FLERR, "fix lattice/front " + key, error);
    if (key == "pulse_floor") levels.pulse_floor = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    else if (key == "length") length = utils::bnumeric(FLERR, arg[iarg + 1], false, lmp);
    else if (key == "levels") file = arg[iarg + 1];
    else error->all(FLERR, "Fix lattice/front: unknown keyword '{}'; expected pulse_floor, length or levels", key);
  }
  check(levels);
  if (!file.empty()) read_levels(file);
  else if (length) error->all(FLERR, "Fix lattice/front: length needs levels FILE");

  peratom_flag = 1;
  size_peratom_cols = NOUT;
  peratom_freq = 1;
  maxexchange = NPACK;
  grow_arrays(atom->nmax);
  atom->add_callback(Atom::GROW);
}

void FixLatticeFront::check(const Levels &L)
{
  if (!(L.start > 0.0 && L.start <= L.front))
    error->all(FLERR, "Fix lattice/front: need 0 < start <= front, got start {} front {}", L.start, L.front);
  if (!(L.drop > 0.0)) error->all(FLERR, "Fix lattice/front: need drop > 0, got {}", L.drop);
  if (!(L.pulse_floor >= 0.0))
    error->all(FLERR, "Fix lattice/front: need pulse_floor >= 0, got {}", L.pulse_floor);
  if (!(L.pulse_drop > 0.0 && L.pulse_drop < 1.0))
    error->all(FLERR, "Fix lattice/front: need 0 < pulse_drop < 1, got {}", L.pulse_drop);
}

/* per-chain levels: one row "start front drop pulse_drop pulse_floor" per chain of `length`
   atoms (chain c: IDs c length + 1 .. (c + 1) length), '#' comments; every rank reads it */

void FixLatticeFront::read_levels(const std::string &file)
{
  if (length < 1 || atom->natoms % length)
    error->all(FLERR, "Fix lattice/front: levels needs length n dividing the {} atoms", atom->natoms);
  std::ifstream in(file);
  if (!in) error->all(FLERR, "Fix lattice/front: cannot open levels file {}", file);
  std::string line;
  while (std::getline(in, line)) {
    auto row = utils::split_words(utils::trim_comment(line));
    if (row.empty()) continue;
    if (row.size() != 5)
      error->all(FLERR, "Fix lattice/front: {}: expected 'start front drop pulse_drop pulse_floor', got '{}'",
                 file, line);
    Levels L;
    L.start = std::stod(row[0]);
    L.front = std::stod(row[1]);
    L.drop = std::stod(row[2]);
    L.pulse_drop = std::stod(row[3]);
    L.pulse_floor = std::stod(row[4]);
    check(L);
    per_chain.push_back(L);
  }
  if ((bigint) per_chain.size() != atom->natoms / length)
    error->all(FLERR, "Fix lattice/front: {} has {} rows; expected one per chain, {}", file, per_chain.size(),
               atom->natoms / length);
}

FixLatticeFront::~FixLatticeFront()
{
  atom->delete_callback(id, Atom::GROW);
  memory->destroy(rec);
  memory->destroy(mark);
  memory->destroy(vprev);
  memory->destroy(phase);
  memory->destroy(shown);
}

int FixLatticeFront::setmask()
{
  return END_OF_STEP;
}

void FixLatticeFront::init()
{
  // a fix that runs during the steps might read the record (f_ID) at any step
  constexpr int DURING_STEPS = INITIAL_INTEGRATE | POST_INTEGRATE | PRE_EXCHANGE | PRE_NEIGHBOR |
      POST_NEIGHBOR | PRE_FORCE | PRE_REVERSE | POST_FORCE | FINAL_INTEGRATE | END_OF_STEP;
  refresh_every_step = false;
  for (int j = 0; j < modify->nfix; j++) {
    Fix *other = modify->fix[j];
    if (other == this || !(modify->fmask[j] & DURING_STEPS)) continue;
    if (!utils::strmatch(other->style, "^lattice/chain$")) refresh_every_step = true;
  }
}

void FixLatticeFront::setup(int)
{
  sample();    // the state before the first step, as a dump's first frame
  refresh();
}

void FixLatticeFront::end_of_step()
{
  sample();    // nothing if fix lattice/chain sampled this step
  if (refresh_every_step || update->ntimestep == output->next) refresh();
}

void FixLatticeFront::post_run()
{
  refresh();    // for write_dump after the run
}

bool FixLatticeFront::begin_sample(Sample &s)
{
  const bigint step = update->ntimestep;
  if (step == step_prev) return false;    // a later run's setup repeats the last step
  s.t = update->atime + (step - update->atimestep) * update->dt;
  s.t_prev = t_prev;
  s.first = step_prev < 0;
  current = s;
  return true;
}

void FixLatticeFront::end_sample()
{
  t_prev = current.t;
  step_prev = update->ntimestep;
}

void FixLatticeFront::set_previous_velocities(const double *v, int stride)
{
  for (int i = 0; i < atom->nlocal; i++)
    if (phase[i] == WAITING) vprev[i] = v[stride * i];
}

void FixLatticeFront::sample()
{
  Sample s;
  if (!begin_sample(s)) return;
  double **v = atom->v, **f = atom->f;
  const double *rmass = atom->rmass, *mass = atom->mass;
  const int *type = atom->type, *mask = atom->mask;
  for (int i = 0; i < atom->nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    const double vi = v[i][0];
    mark[i] = mark_max(mark[i], vi);
    if (phase[i] == FINISHED) continue;
    sample_row(i, vi, f[i][0], rmass ? rmass[i] : mass[type[i]], vprev[i]);
    if (phase[i] == WAITING) vprev[i] = vi;
  }
  end_sample();
}

/* the output copy of the largest |v| (NaN before an atom's first sample); `shown` keeps what
   the rows hold, so that only the rows of changed atoms are touched */

void FixLatticeFront::refresh()
{
  for (int i = 0; i < atom->nlocal; i++)
    if (!same_bits(mark[i], shown[i])) rec[i][V_ABS_MAX] = shown[i] = mark[i];
}

double FixLatticeFront::memory_usage()
{
  return static_cast<double>(rows) * ((NCOL + 3) * sizeof(double) + 1);
}

void FixLatticeFront::grow_arrays(int nmax)
{
  memory->grow(rec, nmax, NCOL, "lattice/front:rec");
  memory->grow(mark, nmax, "lattice/front:mark");
  memory->grow(vprev, nmax, "lattice/front:vprev");
  memory->grow(phase, nmax, "lattice/front:phase");
  memory->grow(shown, nmax, "lattice/front:shown");
  for (int i = rows; i < nmax; i++) {    // nothing recorded yet
    for (int c = 0; c < NCOL; c++) rec[i][c] = NaN;
    mark[i] = NaN;
    vprev[i] = NaN;
    phase[i] = WAITING;
    shown[i] = NaN;
  }
  rows = nmax;
  array_atom = rec;
}

void FixLatticeFront::copy_arrays(int i, int j, int)
{
  std::memcpy(rec[j], rec[i], NCOL * sizeof(double));
  mark[j] = mark[i];
  vprev[j] = vprev[i];
  phase[j] = phase[i];
  shown[j] = shown[i];
}

int FixLatticeFront::pack_exchange(int i, double *buf)
{
  std::memcpy(buf, rec[i], NCOL * sizeof(double));
  buf[NCOL] = mark[i];
  buf[NCOL + 1] = vprev[i];
  buf[NCOL + 2] = phase[i];
  buf[NCOL + 3] = shown[i];
  return NPACK;
}

int FixLatticeFront::unpack_exchange(int nlocal, double *buf)
{
  std::memcpy(rec[nlocal], buf, NCOL * sizeof(double));
  mark[nlocal] = buf[NCOL];
  vprev[nlocal] = buf[NCOL + 1];
  phase[nlocal] = static_cast<unsigned char>(buf[NCOL + 2]);
  shown[nlocal] = buf[NCOL + 3];
  return NPACK;
}
