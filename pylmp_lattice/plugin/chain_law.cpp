/* Force laws of fix lattice/chain (see chain_law.h). Part of pylmp_lattice, GPL-2.0. */

#include "chain_law.h"

#include "error.h"
#include "lammps.h"
#include "utils.h"

#include <cstring>
#include <fstream>

using namespace LAMMPS_NS;

/* Clamped spline: first derivatives given at both ends; tridiagonal solve for d2y. */

void UniformSpline::fit(double first, double step, const std::vector<double> &y, double slope_lo,
                        double slope_hi)
{
  n = y.size();
  x0 = first;
  dx = step;
  inv_dx = 1.0 / step;
  c6 = step * step / 6.0;
  std::vector<double> d2(n), w(n);
  d2[0] = -0.5;
  w[0] = 3.0 / dx * ((y[1] - y[0]) / dx - slope_lo);
  for (int i = 1; i < n - 1; i++) {
    const double p = 0.5 * d2[i - 1] + 2.0;
    d2[i] = -0.5 / p;
    w[i] = (3.0 * (y[i + 1] - 2.0 * y[i] + y[i - 1]) / (dx * dx) - 0.5 * w[i - 1]) / p;
  }
  const double wn = 3.0 / dx * (slope_hi - (y[n - 1] - y[n - 2]) / dx);
  d2[n - 1] = (wn - 0.5 * w[n - 2]) / (0.5 * d2[n - 2] + 1.0);
  for (int i = n - 2; i >= 0; i--) d2[i] = d2[i] * d2[i + 1] + w[i];
  yd2.resize(2 * n);
  for (int i = 0; i < n; i++) {
    yd2[2 * i] = y[i];
    yd2[2 * i + 1] = d2[i];
  }
}

int ChainLaw::parse(LAMMPS *lmp, int narg, char **arg, int iarg, const std::string &who)
{
  Error *error = lmp->error;
  if (iarg >= narg) utils::missing_cmd_args(FLERR, who + " law", error);
  const std::string style = arg[iarg];
  auto need = [&](int count) {
    if (iarg + count >= narg) utils::missing_cmd_args(FLERR, who + " law " + style, error);
  };
  if (style == "power") {
    need(3);
    K = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    b = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
    q = utils::numeric(FLERR, arg[iarg + 3], false, lmp);
    if (K <= 0.0 || b < 0.0 || q <= 1.0)
      error->all(FLERR, "{}: law power needs K > 0, b >= 0, q > 1", who);
    qint = (q == std::floor(q) && q <= 8.0) ? static_cast<int>(q) : 0;
    kind = POWER;
    return iarg + 4;
  }
  if (style == "linear") {
    need(2);
    kind = LINEAR;
    k = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    r_free = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
    if (k <= 0.0 || r_free <= 0.0)
      error->all(FLERR, "{}: law linear needs k > 0, r_free > 0", who);
    return iarg + 3;
  }
  if (style == "table") {
    need(2);
    kind = TABLE;
    read_table(lmp, arg[iarg + 1], arg[iarg + 2], who);
    return iarg + 3;
  }
  error->all(FLERR, "{}: unknown law '{}'; expected power, linear or table", who, style);
  return narg;
}

/* The section KEYWORD of a bond_style table file: "N n FP lo hi ..." then n lines
   "index r U F" on a uniform grid (as pylmp_lattice writes it). Every rank reads it. */

void ChainLaw::read_table(LAMMPS *lmp, const std::string &file, const std::string &keyword,
                          const std::string &who)
{
  Error *error = lmp->error;
  std::ifstream in(file);
  if (!in) error->all(FLERR, "{}: cannot open table file {}", who, file);
  std::string line;
  while (std::getline(in, line) && utils::trim(utils::trim_comment(line)) != keyword) {}
  if (!in) error->all(FLERR, "{}: no section {} in {}", who, keyword, file);
  std::getline(in, line);
  auto words = utils::split_words(line);
  int n = 0;
  double fp_lo = 0.0, fp_hi = 0.0;
  bool have_fp = false;
  for (size_t i = 0; i + 1 < words.size(); i++) {
    if (words[i] == "N") n = std::stoi(words[i + 1]);
    if (words[i] == "FP" && i + 2 < words.size()) {
      fp_lo = std::stod(words[i + 1]);
      fp_hi = std::stod(words[i + 2]);
      have_fp = true;
    }
  }
  if (n < 4 || !have_fp)
    error->all(FLERR, "{}: {} section {} needs 'N n' (n >= 4) and 'FP lo hi'", who, file,
               keyword);
  std::vector<double> r, u, f;
  while ((int) r.size() < n && std::getline(in, line)) {
    auto row = utils::split_words(utils::trim_comment(line));
    if (row.empty()) continue;
    if (row.size() != 4)
      error->all(FLERR, "{}: {}: expected 'index r U F', got '{}'", who, file, line);
    r.push_back(std::stod(row[1]));
    u.push_back(std::stod(row[2]));
    f.push_back(std::stod(row[3]));
  }
  if ((int) r.size() != n)
    error->all(FLERR, "{}: {} section {} has {} rows; expected {}", who, file, keyword,
               r.size(), n);
  const double step = (r[n - 1] - r[0]) / (n - 1);
  for (int i = 1; i < n; i++)
    if (std::fabs(r[i] - (r[0] + i * step)) > 1.0e-9 * std::fabs(r[n - 1]))
      error->all(FLERR, "{}: {} must sample r on a uniform grid", who, file);
  tf.fit(r[0], step, f, fp_lo, fp_hi);
  tu.fit(r[0], step, u, -f[0], -f[n - 1]);
}
