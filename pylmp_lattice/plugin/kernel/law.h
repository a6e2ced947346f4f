/* Nearest-neighbour force laws of the chain kernel: the one place where a law's F(r) and U(r)
   are computed, for fix lattice/chain, fix lattice/friction's analytic laws, the host engine
   and the GPU engine. Part of pylmp_lattice, GPL-2.0.

   A law gives the repulsive force F(r) > 0 and the potential U(r) (F = -dU/dr) of the
   separation r. To add an analytic law: a value type with its F in laws::, a Kind, its U in
   Law::energy(), one case in Law::dispatch(), and its parameters in the plugin's parser
   (force_law.cpp) and the engines' argument lists. Any other law is its table, interpolated by
   the clamped cubic spline that bond_style table spline uses (fitted by fit_table, fit.h), so
   every engine sees the same function. Tables are plain pointers into their owner's storage. */

#ifndef PYLMP_LATTICE_KERNEL_LAW_H
#define PYLMP_LATTICE_KERNEL_LAW_H

#include "device.h"

namespace pl_kernel {

/* Clamped cubic spline on a uniform grid of n points from x0 with spacing dx: y[i], d2y[i]
   interleaved in yd2 (one cache line per evaluation). */
struct Spline {
  double x0 = 0.0, dx = 1.0, inv_dx = 1.0, c6 = 0.0;
  int n = 0;
  const double *yd2 = nullptr;

  /* the spline of n values and second derivatives yd2 (interleaved) on the grid x0 + i dx */
  PL_HD static Spline on_grid(double x0, double dx, int n, const double *yd2)
  {
    Spline s;
    s.x0 = x0, s.dx = dx, s.inv_dx = 1.0 / dx, s.c6 = dx * dx / 6.0;
    s.n = n, s.yd2 = yd2;
    return s;
  }

  PL_HD double operator()(double x) const
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
   registers and the loop over bonds vectorises. Each takes r as a double or as lanes (device.h:
   Lanes); pow and the table's lookup go lane by lane. */
namespace laws {
  template <int Q> struct PowerInt {    // K / (r + b)^Q by multiplications: several times cheaper than pow
    double K, b;
    template <class R> PL_HD R operator()(R r) const
    {
      const R s = r + b;
      R sq = s;
      for (int m = 1; m < Q; m++) sq *= s;
      return K / sq;
    }
  };
  struct Power {
    double K, b, q;
    template <class R> PL_HD R operator()(R r) const
    {
      return Lanes<R>::each(r, [this](double x) { return K * pow(x + b, -q); });
    }
  };
  struct Linear {
    double k, r_free;
    template <class R> PL_HD R operator()(R r) const { return k * (r_free - r); }
  };
  struct Table {
    Spline spline;
    template <class R> PL_HD R operator()(R r) const
    {
      return Lanes<R>::each(r, [this](double x) { return spline(x); });
    }
  };
}    // namespace laws

struct Law {
  enum Kind { POWER, LINEAR, TABLE };
  Kind kind = POWER;
  double K = 0.0, b = 0.0, q = 0.0;    // power: F = K / (r + b)^q
  int qint = 0;                        // q if it is an integer 1..8
  double k = 0.0, r_free = 0.0;        // linear: F = k (r_free - r)
  Spline tf, tu;                       // table: F and U

  PL_HD static Law power(double K, double b, double q)
  {
    Law law;
    law.kind = POWER;
    law.K = K, law.b = b, law.q = q;
    law.qint = qint_of(q);
    return law;
  }
  /* q if it is an integer 1..8 (laws::PowerInt<q>), else 0 (laws::Power) */
  PL_HD static constexpr int qint_of(double q)
  {
    return (q >= 1.0 && q <= 8.0 && q == static_cast<double>(static_cast<int>(q))) ? static_cast<int>(q) : 0;
  }
  PL_HD static Law linear(double k, double r_free)
  {
    Law law;
    law.kind = LINEAR;
    law.k = k, law.r_free = r_free;
    return law;
  }
  PL_HD static Law table(const Spline &force, const Spline &energy)
  {
    Law law;
    law.kind = TABLE;
    law.tf = force, law.tu = energy;
    return law;
  }
  /* a table law from its fit (fit_table's storage: F's spline, then U's, n points each) */
  PL_HD static Law table(double x0, double dx, int n, const double *storage)
  {
    return table(Spline::on_grid(x0, dx, n, storage), Spline::on_grid(x0, dx, n, storage + 2 * n));
  }

  /* call f(law) with the law as one of the value types above */
  template <class F> PL_HD void dispatch(F &&f) const
  {
    switch (kind) {
      case POWER:
        switch (qint) {
          case 1: return f(laws::PowerInt<1>{K, b});
          case 2: return f(laws::PowerInt<2>{K, b});
          case 3: return f(laws::PowerInt<3>{K, b});
          case 4: return f(laws::PowerInt<4>{K, b});
          case 5: return f(laws::PowerInt<5>{K, b});
          case 6: return f(laws::PowerInt<6>{K, b});
          case 7: return f(laws::PowerInt<7>{K, b});
          case 8: return f(laws::PowerInt<8>{K, b});
          default: return f(laws::Power{K, b, q});
        }
      case LINEAR:
        return f(laws::Linear{k, r_free});
      case TABLE:
        return f(laws::Table{tf});
    }
  }

  PL_HD double force(double r) const
  {
    double value = 0.0;
    dispatch([&](auto law) { value = law(r); });
    return value;
  }

  PL_HD double energy(double r) const
  {
    switch (kind) {
      case POWER:
        return K / ((q - 1.0) * pow(r + b, q - 1.0));
      case LINEAR:
        return 0.5 * k * (r_free - r) * (r_free - r);
      default:
        return tu(r);
    }
  }
};

}    // namespace pl_kernel

#endif
