#!/usr/bin/env bash
# Where `sweep --engine gpu` spends its time on a GPU machine (benchmarks/trace_sweep.py): the
# module cache warmed by a small sweep, then 10^6 members on 16 workers and on 8. Run with the
# device tool as gpu_check.sh (carry wheels and latticeengine.so); output also in $OUT/gpu_trace.txt.
set -uo pipefail
cd "$(dirname "$0")/.."
out="${OUT:-/tmp}"
exec > >(tee "$out/gpu_trace.txt") 2>&1
export PYTHONUNBUFFERED=1
py=python3
site=/tmp/pylmp-gpu-site
"$py" -m pip install -q --no-index --no-deps --target "$site" wheels/tomli_w-*.whl
export PYTHONPATH="$site:$PWD"
"$py" -c "import cupy; e = cupy.cuda.Event(block=True, disable_timing=True); e.record(); e.synchronize(); print('blocking event: ok')"
started=$SECONDS
stage() { echo "== $* (at $((SECONDS - started)) s)"; }
stage "20000 members (NVRTC's module compiled and cached)"
timeout 90 "$py" benchmarks/trace_sweep.py --members 20000 --top 0 | grep -v "^| [0-9]"
for workers in 16 8 16; do
  stage "10^6 members, $workers workers"
  timeout 100 "$py" benchmarks/trace_sweep.py --members 1000000 --workers "$workers" --top 45 --out "$out/trace-$workers-$SECONDS"
done
stage "done"
