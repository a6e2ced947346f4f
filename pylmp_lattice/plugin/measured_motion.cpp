/* Measured impactor motion (see measured_motion.h). Part of pylmp_lattice, GPL-2.0. */

#include "measured_motion.h"

#include "kernel/fit.h"

#include "error.h"
#include "utils.h"

#include <algorithm>
#include <fstream>

using namespace LAMMPS_NS;

void MeasuredMotion::load(const std::string &file, bool velocity, bool hold, Error *err,
                          const char *name)
{
  path = file;
  error = err;
  who = name;
  t.clear();
  y.clear();
  read_file();
  storage.assign(2 * t.size(), 0.0);
  fitted = pl_kernel::fit_measured(t.data(), y.data(), t.size(), velocity, hold, storage.data());
}

/* Every rank reads the (small) file itself, so every rank reaches the same error. */

void MeasuredMotion::read_file()
{
  std::ifstream in(path);
  if (!in) error->all(FLERR, who + ": cannot open file {}", path);

  std::string line;
  for (int lineno = 1; std::getline(in, line); lineno++) {
    std::replace(line.begin(), line.end(), ',', ' ');
    auto words = utils::split_words(utils::trim_comment(line));
    if (words.empty()) continue;
    if (words.size() != 2 || !utils::is_double(words[0]) || !utils::is_double(words[1]))
      error->all(FLERR, who + ": {} line {}: expected two numbers 't value', got '{}'",
                 path, lineno, utils::trim(line));
    const double ti = std::stod(words[0]);
    if (!t.empty() && ti <= t.back())
      error->all(FLERR,
                 who + ": {} line {}: time {} does not increase (previous {}); "
                 "times must increase strictly",
                 path, lineno, ti, t.back());
    t.push_back(ti);
    y.push_back(std::stod(words[1]));
  }
  if (t.size() < 4)
    error->all(FLERR, who + ": {} has {} samples; need at least 4", path, t.size());
}

void MeasuredMotion::past_end(double tau) const
{
  error->all(FLERR,
             who + ": time {} s is past the end of the data in {} "
             "(last sample {} s); shorten the run or use 'after hold'",
             t[0] + tau, path, t.back());
}
