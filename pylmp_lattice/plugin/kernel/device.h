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
#else
#define PL_HD
#define PL_SIMD_REDUCE _Pragma("omp simd reduction(min : r_min) reduction(max : r_max) reduction(+ : r_sum)")
#define PL_SIMD_STEP \
  _Pragma("omp simd reduction(min : r_min) reduction(max : r_max) reduction(+ : r_sum) reduction(+ : starting)")
#define PL_RESTRICT __restrict
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

}    // namespace pl_kernel

#endif
