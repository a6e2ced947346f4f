/* Nearest-neighbour force laws of the pylmp_lattice fixes (lattice/chain, and lattice/friction's
   analytic laws): the one place where laws are defined and their parameters checked.
   Part of pylmp_lattice, GPL-2.0.

   A law gives the repulsive force F(r) > 0 and the potential U(r) (F = -dU/dr) of the
   separation r. To add an analytic law: a value type with its F in ChainLaws, a Kind, its
   parameters in parse(), its U in energy(), and one case in dispatch(). Any other law reaches the
   fix as its table (law table FILE KEYWORD, the file pylmp_lattice writes for bond_style
   table), interpolated by the clamped cubic spline that bond_style table spline uses, so
   both engines see the same function. */

#ifndef PYLMP_LATTICE_CHAIN_LAW_H
#define PYLMP_LATTICE_CHAIN_LAW_H

#include "pointers.h"

#include <cmath>
#include <string>
#include <type_traits>
#include <vector>

namespace LAMMPS_NS {

/* Clamped cubic spline on a uniform grid of n points from x0 with spacing dx. */
struct UniformSpline {
  double x0 = 0.0, dx = 1.0, inv_dx = 1.0, c6 = 0.0;
  int n = 0;
  std::vector<double> yd2;    // y[i], d2y[i] interleaved: one cache line per evaluation

  void fit(double first, double step, const std::vector<double> &y, double slope_lo,
           double slope_hi);
  double operator()(double x) const
  {
    double u = (x - x0) * inv_dx;
    int i = static_cast<int>(u);
    i = i < 0 ? 0 : (i > n - 2 ? n - 2 : i);
    const double B = u - i, A = 1.0 - B;
    const double *p = &yd2[2 * i];
    return A * p[0] + B * p[2] + ((A * A * A - A) * p[1] + (B * B * B - B) * p[3]) * c6;
  }
};

/* The laws as small value types: the force loop gets a copy, so its coefficients live in
   registers and the loop over bonds vectorises. */
namespace ChainLaws {
  template <int Q> struct PowerInt {    // K / (r + b)^Q by multiplications: several times cheaper than pow
    double K, b;
    double operator()(double r) const
    {
      const double s = r + b;
      double sq = s;
      for (int m = 1; m < Q; m++) sq *= s;
      return K / sq;
    }
  };
  struct Power {
    double K, b, q;
    double operator()(double r) const { return K * std::pow(r + b, -q); }
  };
  struct Linear {
    double k, r_free;
    double operator()(double r) const { return k * (r_free - r); }
  };
  struct Table {
    const UniformSpline *spline;
    double operator()(double r) const { return (*spline)(r); }
  };
}    // namespace ChainLaws

struct ChainLaw {
  enum Kind { POWER, LINEAR, TABLE };
  Kind kind = POWER;
  double K = 0.0, b = 0.0, q = 0.0;    // power: F = K / (r + b)^q
  int qint = 0;                        // q if it is an integer 1..8
  double k = 0.0, r_free = 0.0;        // linear: F = k (r_free - r)
  UniformSpline tf, tu;                // table: F and U

  /* parse "power K b q" | "linear k r_free" | "table FILE KEYWORD" at arg[iarg]; returns
     the index after the law's arguments; errors start with `who` (e.g. "Fix lattice/chain") */
  int parse(class LAMMPS *lmp, int narg, char **arg, int iarg, const std::string &who);

  /* call f(law) with the law as one of the value types above */
  template <class F> void dispatch(F &&f) const
  {
    using namespace ChainLaws;
    switch (kind) {
      case POWER:
        switch (qint) {
          case 1: return f(PowerInt<1>{K, b});
          case 2: return f(PowerInt<2>{K, b});
          case 3: return f(PowerInt<3>{K, b});
          case 4: return f(PowerInt<4>{K, b});
          case 5: return f(PowerInt<5>{K, b});
          case 6: return f(PowerInt<6>{K, b});
          case 7: return f(PowerInt<7>{K, b});
          case 8: return f(PowerInt<8>{K, b});
          default: return f(Power{K, b, q});
        }
      case LINEAR:
        return f(Linear{k, r_free});
      case TABLE:
        return f(Table{&tf});
    }
  }

  double force(double r) const
  {
    double value = 0.0;
    dispatch([&](auto law) { value = law(r); });
    return value;
  }

  double energy(double r) const
  {
    switch (kind) {
      case POWER:
        return K / ((q - 1.0) * std::pow(r + b, q - 1.0));
      case LINEAR:
        return 0.5 * k * (r_free - r) * (r_free - r);
      default:
        return tu(r);
    }
  }

 private:
  void read_table(class LAMMPS *lmp, const std::string &file, const std::string &keyword,
                  const std::string &who);
};

}    // namespace LAMMPS_NS

#endif
