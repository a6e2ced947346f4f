/* Measured impactor motion (see measured_motion.h). Part of pylmp_lattice, GPL-2.0. */

#include "measured_motion.h"

#include "error.h"
#include "utils.h"

#include <algorithm>
#include <fstream>

using namespace LAMMPS_NS;

void MeasuredMotion::load(const std::string &file, bool velocity, bool hold, Error *err,
                          const char *name)
{
  path = file;
  given_velocity = velocity;
  hold_after = hold;
  error = err;
  who = name;
  t.clear();
  y.clear();
  read_file();
  fit_spline();
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

/* Not-a-knot cubic spline: the third derivative is continuous at t[1] and t[n-2].
   Eliminating d2y[0] and d2y[n-1] with these conditions leaves a tridiagonal
   system for d2y[1..n-2], solved by the Thomas algorithm. */

void MeasuredMotion::fit_spline()
{
  const int n = t.size();
  std::vector<double> h(n - 1), lo(n), di(n), up(n), rhs(n);
  for (int i = 0; i < n - 1; i++) h[i] = t[i + 1] - t[i];
  for (int i = 1; i < n - 1; i++) {
    lo[i] = h[i - 1];
    di[i] = 2.0 * (h[i - 1] + h[i]);
    up[i] = h[i];
    rhs[i] = 6.0 * ((y[i + 1] - y[i]) / h[i] - (y[i] - y[i - 1]) / h[i - 1]);
  }
  // d2y[0] = ((h0 + h1) d2y[1] - h0 d2y[2]) / h1, and its mirror image at the right end
  di[1] += h[0] * (h[0] + h[1]) / h[1];
  up[1] -= h[0] * h[0] / h[1];
  const double a = h[n - 3], b = h[n - 2];
  di[n - 2] += b * (a + b) / a;
  lo[n - 2] -= b * b / a;

  for (int i = 2; i < n - 1; i++) {
    const double w = lo[i] / di[i - 1];
    di[i] -= w * up[i - 1];
    rhs[i] -= w * rhs[i - 1];
  }
  d2y.assign(n, 0.0);
  d2y[n - 2] = rhs[n - 2] / di[n - 2];
  for (int i = n - 3; i >= 1; i--) d2y[i] = (rhs[i] - up[i] * d2y[i + 1]) / di[i];
  d2y[0] = ((h[0] + h[1]) * d2y[1] - h[0] * d2y[2]) / h[1];
  d2y[n - 1] = ((a + b) * d2y[n - 2] - b * d2y[n - 3]) / a;

  yint.assign(n, 0.0);
  for (int i = 0; i < n - 1; i++)
    yint[i + 1] = yint[i] + 0.5 * h[i] * (y[i] + y[i + 1]) -
        h[i] * h[i] * h[i] * (d2y[i] + d2y[i + 1]) / 24.0;
}

void MeasuredMotion::at(double tau, double slack, double &u, double &ud) const
{
  const int n = t.size();
  double time = t[0] + tau;
  // a run meant to end on the last sample may overshoot it by round-off
  const bool past_end = time > t[n - 1] + slack;
  if (past_end && !hold_after)
    error->all(FLERR,
               who + ": time {} s is past the end of the data in {} "
               "(last sample {} s); shorten the run or use 'after hold'",
               time, path, t[n - 1]);
  time = std::min(time, t[n - 1]);

  const int k = std::min<int>(std::upper_bound(t.begin(), t.end(), time) - t.begin() - 1, n - 2);
  const double h = t[k + 1] - t[k];
  const double A = (t[k + 1] - time) / h, B = 1.0 - A;
  const double c = h * h / 6.0;
  const double value = A * y[k] + B * y[k + 1] + c * ((A * A * A - A) * d2y[k] + (B * B * B - B) * d2y[k + 1]);
  const double slope = (y[k + 1] - y[k]) / h +
      h / 6.0 * (-(3.0 * A * A - 1.0) * d2y[k] + (3.0 * B * B - 1.0) * d2y[k + 1]);

  if (given_velocity) {
    const double integral = yint[k] + h * (0.5 * (1.0 - A * A) * y[k] + 0.5 * B * B * y[k + 1]) +
        h * c * ((0.25 * (1.0 - A * A * A * A) - 0.5 * (1.0 - A * A)) * d2y[k] +
                 (0.25 * B * B * B * B - 0.5 * B * B) * d2y[k + 1]);
    u = integral;
    ud = value;
  } else {
    u = value - y[0];
    ud = slope;
  }
  if (past_end) ud = 0.0;    // holding the last position
}
