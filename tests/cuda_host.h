/* CUDA's kernel qualifiers, thread indices and barriers on the host, so that g++ compiles
   engine_gpu.cu into a library whose kernels tests/test_gpu_emulated.py runs: the short chains'
   (one thread per chain, no barrier) thread after thread, the long chains' (a block per chain)
   with a host thread for each of a block's threads, one block after another, which meet at the
   barriers (pl_emu_begin_block sets their count). A __shared__ array is one static array: the
   block's, as on a device, since blocks run one at a time. Passed with -include. */
#include <pthread.h>

#define __global__
#define __shared__ static
#define __device__
#define __host__
#define __restrict__ __restrict

struct pl_emu_dim3 {
  unsigned int x, y, z;
};

// unsigned, as CUDA's, so blockIdx.x * blockDim.x + threadIdx.x is computed as on a device
static thread_local pl_emu_dim3 blockIdx{0, 0, 0}, blockDim{1, 1, 1}, threadIdx{0, 0, 0};

/* the thread the next kernel call runs as (1-D grids and blocks) */
extern "C" void pl_emu_set_thread(unsigned int block, unsigned int threads, unsigned int thread)
{
  blockIdx = {block, 0, 0};
  blockDim = {threads, 1, 1};
  threadIdx = {thread, 0, 0};
}

static pthread_barrier_t pl_emu_barrier;
static int pl_emu_or[3];

/* a block of `threads` host threads is about to run (each calls pl_emu_set_thread, then the kernel) */
extern "C" void pl_emu_begin_block(unsigned int threads)
{
  static bool made = false;
  if (made) pthread_barrier_destroy(&pl_emu_barrier);
  pthread_barrier_init(&pl_emu_barrier, nullptr, threads);
  made = true;
  pl_emu_or[0] = pl_emu_or[1] = pl_emu_or[2] = 0;
}

static void __syncthreads() { pthread_barrier_wait(&pl_emu_barrier); }

/* each call's OR in its own of three slots, cleared two calls later (after a barrier all have passed) */
static int __syncthreads_or(int p)
{
  static thread_local int call = 0;
  const int k = call++ % 3;
  if (p) __atomic_store_n(&pl_emu_or[k], 1, __ATOMIC_SEQ_CST);
  __atomic_store_n(&pl_emu_or[(k + 1) % 3], 0, __ATOMIC_SEQ_CST);
  __syncthreads();
  return __atomic_load_n(&pl_emu_or[k], __ATOMIC_SEQ_CST);
}
