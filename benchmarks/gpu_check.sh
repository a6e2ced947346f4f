#!/usr/bin/env bash
# The one prepared script a session with a GPU machine runs (issue 28, "Checks on a GPU machine"),
# in under 5 minutes: the image's Python (its numpy, CuPy, pandas, pyarrow, matplotlib) with the
# carried wheels, the gpu-marked tests, `bench_gpu.py --check`, then the benchmark, the
# 10^6-member sweep from command to exit included, and one kernel launch under Nsight Compute. Prepare on the dev machine first:
#   bash benchmarks/gpu_wheels.sh          # wheels/ (ignored by git)
#   cmake -S . -B /tmp/b -DPython_EXECUTABLE=$(which python) && cmake --build /tmp/b -j2 \
#     && cmake --install /tmp/b --prefix /tmp/b/inst   # then copy latticeengine.so into pylmp_lattice/plugin/
#   mkdir -p wheels/kernel-ece083f && git archive ece083f pylmp_lattice/plugin/kernel \
#     | tar -x -C wheels/kernel-ece083f --strip-components=3   # the old kernel, timed beside the new
# and run it with the device tool: command "bash benchmarks/gpu_check.sh", carry ["wheels",
# "pylmp_lattice/plugin/latticeengine.so"], timeout_s 500: correctness first, then the kernel's
# variants, the benchmark with the sweeps, Nsight Compute, the long chains last (each stage with
# its own timeout; the run of 2026-11-28 01:17 UTC took 147 s). Output also in $OUT/gpu_check.txt.
set -uo pipefail
cd "$(dirname "$0")/.."
out="${OUT:-/tmp}"
exec > >(tee "$out/gpu_check.txt") 2>&1
export PYTHONUNBUFFERED=1
started=$SECONDS
stage() { echo "== $* (at $((SECONDS - started)) s)"; }
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader || true
nproc; lscpu | grep -m1 "Model name" || true
py=python3
site=/tmp/pylmp-gpu-site
"$py" -m pip install -q --no-index --no-deps --target "$site" wheels/tomli_w-*.whl \
  || echo "gpu_check: could not install tomli-w from wheels/"
export PYTHONPATH="$site:$PWD"
# byte-compiled as pip installs it: a tree without .pyc files compiles each module in every process
"$py" -m compileall -q pylmp_lattice benchmarks >/dev/null || echo "gpu_check: could not byte-compile the package"
"$py" -c "import numpy, cupy, pandas, pyarrow, matplotlib, sys; print('python', sys.version.split()[0], 'numpy', \
numpy.__version__, 'cupy', cupy.__version__, 'cuda runtime', cupy.cuda.runtime.runtimeGetVersion())"
stage "gpu-marked tests: the GPU engine against the host build"
timeout 60 "$py" -m pytest -q -x -m gpu -p no:cacheprovider tests/test_kernel_cpu.py 2>&1 | tail -25
stage "bench_gpu.py --check"
timeout 60 "$py" benchmarks/bench_gpu.py --check
check=$?
stage "check exit $check"
stage "bench_gpu.py --variants: the kernel with parts left out, the engine's choices one at a time, the old kernel"
reference=()
[ -f wheels/kernel-ece083f/engine_gpu.cu ] && reference=(--reference-kernel wheels/kernel-ece083f)
timeout 150 "$py" benchmarks/bench_gpu.py --sizes "" --long 0 --sweep "" --variants 100000 "${reference[@]}"
stage "variants exit $?"
stage "bench_gpu.py: 21 magnets, kernel and command to exit"
timeout 220 "$py" benchmarks/bench_gpu.py --sizes 10000,100000,1000000 --long 0 --sweep 10000,1000000 --log "$out" \
  --loop-limit 2e10
stage "benchmark exit $?"
# ensembles under disorder (the thermal example's 1 % mass and 0.5 % gap scatter): a worker's
# Python per replica went from 0.38 to 0.10 ms on the dev VM on 2026-11-27 (10^6 of them: 19.7 s on
# 2026-11-28 00:59 UTC, 13.6 s at 01:18 with the later changes; a fresh machine's first compiles
# the per-atom-mass module in every worker, about 6 s more)
# where the 10^6-member sweep's time goes: each worker's tasks and kernel calls, the coordinator's profile
stage "trace_sweep.py: 10^6 members, 16 workers"
timeout 60 "$py" benchmarks/trace_sweep.py --members 1000000 --top 30
stage "trace exit $?"
stage "bench_gpu.py: 10^5 and 10^6 members under disorder, command to exit"
timeout 90 "$py" benchmarks/bench_gpu.py --sizes "" --long 0 --sweep 100000,1000000 --disorder --log "$out" \
  --loop-limit 0
stage "disorder sweeps exit $?"
# What bounds the kernel now (memory, FP64, the stalls of its warps)? Nsight Compute's sections
# for one launch of 20000 chains (the warm-up's skipped); the whole report in $OUT/ncu.txt. Its
# SourceCounters (not yet run): are the front record's rows, which each chain reads at its own
# atoms, local-memory accesses that a warp's threads do not share (uncoalesced, excessive sectors)?
stage "ncu: one launch of 20000 chains"
command -v ncu >/dev/null && timeout 90 ncu --section SpeedOfLight --section MemoryWorkloadAnalysis --section Occupancy \
  --section WarpStateStats --section ComputeWorkloadAnalysis --section LaunchStats --section InstructionStats \
  --section SourceCounters \
  -k pl_run_short_chains_gpu --launch-skip 1 --launch-count 1 "$py" benchmarks/bench_gpu.py --sizes 20000 --long 0 \
  --sweep "" --loop-limit 0 >"$out/ncu.txt" 2>&1
stage "ncu exit $?"
grep -E "Duration|Throughput|Registers Per|Occupancy|Stall|Issue Slots|Executed Ipc|Pipe|Shared Memory|Local|Uncoalesced|Excessive|Branch|Divergen" \
  "$out/ncu.txt" | head -50
# members of 1000 magnets, a block a chain (0: these stages left out): 1000 (the one thread a chain
# it replaced took 11.6 s on an H200), then 10^4 (issue 28's row) while time is left
for long in ${GPU_CHECK_LONG:-1000 10000}; do
  left=$((450 - (SECONDS - started)))
  [ "$long" = 0 ] || [ "$left" -lt 30 ] && continue
  stage "bench_gpu.py: $long members of 1000 magnets, a block per chain (for at most ${left} s)"
  timeout "$left" "$py" benchmarks/bench_gpu.py --sizes "" --long "$long" --sweep "" --loop-limit 5e9
  stage "benchmark exit $?"
done
exit $check
