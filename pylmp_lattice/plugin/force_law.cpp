/* Force laws of fix lattice/chain (see force_law.h). Part of pylmp_lattice, GPL-2.0. */

#include "force_law.h"

#include "kernel/fit.h"

#include "error.h"
#include "lammps.h"
#include "utils.h"

#include <cstring>
#include <fstream>

using namespace LAMMPS_NS;

int ForceLaw::parse(LAMMPS *lmp, int narg, char **arg, int iarg, const std::string &who)
{
  Error *error = lmp->error;
  if (iarg >= narg) utils::missing_cmd_args(FLERR, who + " law", error);
  const std::string style = arg[iarg];
  auto need = [&](int count) {
    if (iarg + count >= narg) utils::missing_cmd_args(FLERR, who + " law " + style, error);
  };
  if (style == "power") {
    need(3);
    const double K = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    const double b = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
    const double q = utils::numeric(FLERR, arg[iarg + 3], false, lmp);
    if (K <= 0.0 || b < 0.0 || q <= 1.0)
      error->all(FLERR, "{}: law power needs K > 0, b >= 0, q > 1", who);
    static_cast<Law &>(*this) = Law::power(K, b, q);
    return iarg + 4;
  }
  if (style == "linear") {
    need(2);
    const double k = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
    const double r_free = utils::numeric(FLERR, arg[iarg + 2], false, lmp);
    if (k <= 0.0 || r_free <= 0.0)
      error->all(FLERR, "{}: law linear needs k > 0, r_free > 0", who);
    static_cast<Law &>(*this) = Law::linear(k, r_free);
    return iarg + 3;
  }
  if (style == "table") {
    need(2);
    read_table(lmp, arg[iarg + 1], arg[iarg + 2], who);
    return iarg + 3;
  }
  error->all(FLERR, "{}: unknown law '{}'; expected power, linear or table", who, style);
  return narg;
}

/* The section KEYWORD of a bond_style table file: "N n FP lo hi ..." then n lines
   "index r U F" on a uniform grid (as pylmp_lattice writes it). Every rank reads it. */

void ForceLaw::read_table(LAMMPS *lmp, const std::string &file, const std::string &keyword,
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
  storage.assign(4 * n, 0.0);
  static_cast<Law &>(*this) = pl_kernel::fit_table(r.data(), u.data(), f.data(), n, fp_lo, fp_hi, storage.data());
}
