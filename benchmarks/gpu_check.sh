#!/usr/bin/env bash
# The one prepared script a session with a GPU machine runs (issue 28, "Checks on a GPU machine"),
# in under 5 minutes: a venv on the image's Python (its numpy and CuPy) with the carried wheels,
# then `bench_gpu.py --check`, then the benchmark. Prepare on the dev machine first:
#   bash benchmarks/gpu_wheels.sh          # wheels/ (ignored by git)
#   cmake -S . -B /tmp/b -DPython_EXECUTABLE=$(which python) && cmake --build /tmp/b -j2 \
#     && cmake --install /tmp/b --prefix /tmp/b/inst   # then copy latticeengine.so into pylmp_lattice/plugin/
# and run it with the device tool: command "bash benchmarks/gpu_check.sh", carry ["wheels",
# "pylmp_lattice/plugin/latticeengine.so"], timeout_s 330. Output also in $OUT/gpu_check.txt.
set -uo pipefail
cd "$(dirname "$0")/.."
log="${OUT:-/tmp}/gpu_check.txt"
exec > >(tee "$log") 2>&1
started=$SECONDS
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader || true
venv=/tmp/pylmp-gpu-venv
python3 -m venv --system-site-packages "$venv" && py="$venv/bin/python" || py=python3
"$py" -m pip install -q --no-index --find-links wheels tomli-w tqdm || echo "gpu_check: could not install tomli-w, tqdm from wheels/"
"$py" -c "import numpy, cupy, sys; print('python', sys.version.split()[0], 'numpy', numpy.__version__, 'cupy', cupy.__version__)"
export PYTHONPATH="$PWD"
echo "== bench_gpu.py --check"
timeout 150 "$py" benchmarks/bench_gpu.py --check
check=$?
echo "check exit $check after $((SECONDS - started)) s"
echo "== bench_gpu.py"
left=$((280 - (SECONDS - started))); timeout $((left > 30 ? left : 30)) "$py" benchmarks/bench_gpu.py --sizes 10000,100000,1000000 --long 10000 --sweep 10000
echo "benchmark exit $? after $((SECONDS - started)) s"
exit $check
