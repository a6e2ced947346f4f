/* The chain kernel's portability layer: the same headers compile with g++ (the LAMMPS plugin and
   the host engine) and with NVRTC (the GPU engine). NVRTC has no host standard headers: the
   kernel headers use no std::vector, std::string or exceptions, only the math below.
   Part of pylmp_lattice, GPL-2.0. */

#ifndef PYLMP_LATTICE_KERNEL_DEVICE_H
#define PYLMP_LATTICE_KERNEL_DEVICE_H

#if defined(__CUDACC__) || defined(__CUDACC_RTC__)
#define PL_HD __host__ __device__
#define PL_SIMD_REDUCE
#define PL_SIMD_STEP
#define PL_RESTRICT __restrict__
#define PL_COLD __noinline__
#define PL_UNROLL _Pragma("unroll")
#else
#define PL_HD
#define PL_SIMD_REDUCE _Pragma("omp simd reduction(min : r_min) reduction(max : r_max) reduction(+ : r_sum)")
#define PL_SIMD_STEP \
  _Pragma("omp simd reduction(min : r_min) reduction(max : r_max) reduction(+ : r_sum) reduction(+ : starting)")
#define PL_RESTRICT __restrict
#define PL_COLD __attribute__((noinline))
#define PL_UNROLL
#endif

#ifndef __CUDACC_RTC__
#include <cmath>
#include <limits>
#endif

namespace pl_kernel {

#ifndef __CUDACC_RTC__
// unqualified calls in the kernel find these on the host (and with nvcc on the device too);
// NVRTC declares CUDA's own
using std::copysign;
using std::cos;
using std::fabs;
using std::fmax;
using std::isnan;
using std::pow;
using std::sin;
#endif
#if defined(__CUDACC__) || defined(__CUDACC_RTC__)
__device__ inline double infinity() { return __longlong_as_double(0x7ff0000000000000LL); }
__device__ inline double quiet_nan() { return __longlong_as_double(0x7ff8000000000000LL); }
#else
inline double infinity() { return std::numeric_limits<double>::infinity(); }
inline double quiet_nan() { return std::numeric_limits<double>::quiet_NaN(); }
#endif

constexpr double PI = 3.14159265358979323846;

/* The per-atom code's value type R: double (one chain: fix lattice/chain, the GPU engine) or, in
   the host engine, a GCC vector of W doubles, one chain per lane (engine_cpu.cpp): every per-atom
   operation is then one W-wide instruction with the same IEEE result in each lane as the double
   code's, so a lane has the bits of its chain run alone. Branches on values become selects
   (`m ? a : b` takes a mask of lanes in GNU C++); a comparison gives MaskOf<R> (bool for double). */
template <class R> using MaskOf = decltype(R() < R());

template <class R> struct Lanes {    // a vector: W lanes
  static constexpr int W = sizeof(R) / sizeof(double);
  static R splat(double a) { return a - R{}; }    // a in every lane (a - 0 is a, -0.0 included)
  static double get(const R &r, int l) { return r[l]; }
  static void set(R &r, int l, double a) { r[l] = a; }
  static bool on(const MaskOf<R> &m, int l) { return m[l] != 0; }
  static bool any(const MaskOf<R> &m)    // an OR of the lanes, without a branch per lane
  {
    long long acc = 0;
    for (int l = 0; l < W; l++) acc |= m[l];
    return acc != 0;
  }
  /* f(lane value) in each lane: laws with pow or a table */
  template <class F> static R each(const R &r, F &&f)
  {
    R out;
    for (int l = 0; l < W; l++) out[l] = f(r[l]);
    return out;
  }
};
template <> struct Lanes<double> {
  static constexpr int W = 1;
  PL_HD static double splat(double a) { return a; }
  PL_HD static double get(double r, int) { return r; }
  PL_HD static void set(double &r, int, double a) { r = a; }
  PL_HD static bool on(bool m, int) { return m; }
  PL_HD static bool any(bool m) { return m; }
  template <class F> PL_HD static double each(double r, F &&f) { return f(r); }
};

#if !defined(__CUDACC__) && !defined(__CUDACC_RTC__)
/* the host engine's lane types and their fabs, copysign, isnan and fmax, bit for bit std's per lane (fmax:
   in value; the sign of a zero it returns may differ, which no comparison sees) */
typedef double Lanes2 __attribute__((vector_size(16)));
typedef double Lanes4 __attribute__((vector_size(32)));

#if defined(__x86_64__)
/* any lane set: one movmskpd (Lanes4: only in code built for AVX, as the host engine's); other
   machines OR the lanes (the template above) */
template <> inline bool Lanes<Lanes2>::any(const MaskOf<Lanes2> &m)
{
  return __builtin_ia32_movmskpd((Lanes2) m) != 0;
}
template <> __attribute__((target("avx"))) inline bool Lanes<Lanes4>::any(const MaskOf<Lanes4> &m)
{
  return __builtin_ia32_movmskpd256((Lanes4) m) != 0;
}
#endif

template <class R> struct LaneBits;
template <> struct LaneBits<Lanes2> {
  typedef long long I __attribute__((vector_size(16)));
};
template <> struct LaneBits<Lanes4> {
  typedef long long I __attribute__((vector_size(32)));
};
template <class R, class I = typename LaneBits<R>::I> inline I sign_bits()
{
  return (I) (-0.0 - R{});
}
template <class R, class I = typename LaneBits<R>::I> inline R fabs(R a)
{
  return (R) ((I) a & ~sign_bits<R>());
}
template <class R, class I = typename LaneBits<R>::I> inline R copysign(R a, R b)
{
  return (R) (((I) a & ~sign_bits<R>()) | ((I) b & sign_bits<R>()));
}
template <class R, class I = typename LaneBits<R>::I> inline I isnan(R a)
{
  return a != a;
}
/* std::fmax per lane: the other value where one is a NaN */
template <class R, class I = typename LaneBits<R>::I> inline R fmax(R a, R b)
{
  return isnan(a) ? b : isnan(b) ? a : a > b ? a : b;
}
#endif

}    // namespace pl_kernel

#endif
