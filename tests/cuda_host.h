/* CUDA's kernel qualifiers, thread indices and barriers on the host, so that g++ compiles
   engine_gpu.cu into a library whose kernels tests/test_gpu_emulated.py runs one block after
   another, a host thread for each of a block's threads, which meet at the barriers (the long
   chains' kernel, a block per chain; pl_emu_begin_block sets their count). A __shared__ array is one static array: the
   block's, as on a device, since blocks run one at a time. Passed with -include. */
#include <pthread.h>
#include <time.h>

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

/* A block's barrier: a generation count under a mutex. A thread that waits over 10 s (a block
   whose threads do not all reach the barrier, which hangs a device) breaks it for good: every
   wait then returns at once, and pl_emu_broken tells the launch, which fails the test. After
   it, the odd threads wait 20 us: the even ones run ahead into the next step, so that a read
   of shared memory a neighbour may overwrite before the next barrier (one half of `edges` for
   both steps) reads the new value, not by the chance of the host's scheduling. */
static pthread_mutex_t pl_emu_mutex = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t pl_emu_cond = PTHREAD_COND_INITIALIZER;
static unsigned int pl_emu_threads = 1, pl_emu_waiting = 0;
static unsigned long pl_emu_generation = 0;
static int pl_emu_or[3], pl_emu_broken_flag = 0;

/* a block of `threads` host threads is about to run (each calls pl_emu_set_thread, then the kernel) */
extern "C" void pl_emu_begin_block(unsigned int threads)
{
  pl_emu_threads = threads, pl_emu_waiting = 0;
  pl_emu_or[0] = pl_emu_or[1] = pl_emu_or[2] = 0;
}

/* 1 if a barrier broke since the last call (which mends it) */
extern "C" int pl_emu_broken()
{
  const int broken = pl_emu_broken_flag;
  pl_emu_broken_flag = 0;
  return broken;
}

static void __syncthreads()
{
  pthread_mutex_lock(&pl_emu_mutex);
  const unsigned long generation = pl_emu_generation;
  if (++pl_emu_waiting == pl_emu_threads) {
    pl_emu_waiting = 0, pl_emu_generation++;
    pthread_cond_broadcast(&pl_emu_cond);
  } else {
    timespec until;
    clock_gettime(CLOCK_REALTIME, &until);
    until.tv_sec += 10;
    while (generation == pl_emu_generation && !pl_emu_broken_flag)
      if (pthread_cond_timedwait(&pl_emu_cond, &pl_emu_mutex, &until) != 0) {
        pl_emu_broken_flag = 1;
        pthread_cond_broadcast(&pl_emu_cond);
      }
  }
  pthread_mutex_unlock(&pl_emu_mutex);
  if (threadIdx.x % 2) {
    const timespec late{0, 20000};
    nanosleep(&late, nullptr);
  }
}

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
