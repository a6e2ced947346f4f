/* CUDA's kernel qualifiers and thread indices on the host, so that g++ compiles engine_gpu.cu
   into a library whose kernels tests/test_gpu_emulated.py runs thread after thread (exact: the
   kernels have one thread per chain and no barriers; a __shared__ array is one static array, in
   which each thread uses only its own row). Passed with -include. */

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
