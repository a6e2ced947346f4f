"""The GPU engine's kernel (plugin/kernel/engine_gpu.cu and the shared headers) compiles with
NVRTC, as CuPy compiles it on a GPU machine (`engines.gpu.compile_options`), on any machine with
NVIDIA's NVRTC wheel (nvidia-cuda-nvrtc, in the test extras): no GPU is needed to compile.

The kernel had never been compiled by NVRTC before this test: without -default-device its
lambdas are host code to NVRTC's JIT mode, and the GPU engine failed on its first launch."""

from __future__ import annotations

import ctypes
import importlib.util
import shutil
from pathlib import Path

import pytest

from pylmp_lattice.engines.gpu import KERNEL, LOCAL_SIZES, _sources_digest, compile_options

ARCH = "-arch=compute_90"  # the H100/H200 of issue 28; PTX, so no device is asked


def _nvrtc():
    """NVRTC from the nvidia-cuda-nvrtc wheel (its builtins loaded first: NVRTC opens them by
    name), or None."""
    spec = importlib.util.find_spec("nvidia")
    for root in (spec.submodule_search_locations if spec else []):
        for lib in sorted(Path(root).glob("*/lib/libnvrtc.so.*")):
            for builtins in Path(lib.parent).glob("libnvrtc-builtins.so.*"):
                ctypes.CDLL(str(builtins), mode=ctypes.RTLD_GLOBAL)
            return ctypes.CDLL(str(lib))
    return None


def compile_ptx(options: tuple[str, ...]) -> tuple[int, str, bytes]:
    """NVRTC's result code, log and PTX for engine_gpu.cu with `options`."""
    lib = _nvrtc()
    if lib is None:
        pytest.skip("NVIDIA's NVRTC is not installed (pip install nvidia-cuda-nvrtc)")
    prog = ctypes.c_void_p()
    source = (KERNEL / "engine_gpu.cu").read_bytes()
    assert lib.nvrtcCreateProgram(ctypes.byref(prog), source, b"engine_gpu.cu", 0, None, None) == 0
    try:
        opts = [o.encode() for o in options]
        rc = lib.nvrtcCompileProgram(prog, len(opts), (ctypes.c_char_p * len(opts))(*opts))
        size = ctypes.c_size_t()
        lib.nvrtcGetProgramLogSize(prog, ctypes.byref(size))
        log = ctypes.create_string_buffer(size.value)
        lib.nvrtcGetProgramLog(prog, log)
        lib.nvrtcGetPTXSize(prog, ctypes.byref(size))
        ptx = ctypes.create_string_buffer(size.value)
        if rc == 0:
            lib.nvrtcGetPTX(prog, ptx)
        return rc, log.value.decode(errors="replace"), ptx.value
    finally:
        lib.nvrtcDestroyProgram(ctypes.byref(prog))


CASES = [  # (law kind, q, friction, record): engines.gpu.batch_case's, each law type of Law::dispatch
    (0, 3.0, True, True), (0, 3.0, False, False), (0, 1.0, True, False), (0, 8.0, False, True), (0, 2.5, True, True),
    (1, 0.0, True, True), (2, 0.0, False, True)]


@pytest.mark.parametrize("local", [*LOCAL_SIZES, 0])
@pytest.mark.parametrize("case", CASES)
def test_nvrtc_compiles_the_kernel_for_each_case_of_a_batch(local, case):
    """One entry point (the local arrays' kernel, or the global rows' with local 0) and one copy
    of the run per module: under 2 s of NVRTC each. With every case in one module (44 copies of
    the run, twice), NVRTC took 25-45 s to PTX here and 3 minutes to sm_90 code on the GPU
    machine, which stalled its first check."""
    rc, log, ptx = compile_ptx((*compile_options(local, case), ARCH))
    assert rc == 0, log
    entries = [line.split()[-1] for line in ptx.decode().splitlines() if ".entry" in line]
    assert entries == ["pl_run_short_chains_gpu(" if local else "pl_run_chains_gpu("], entries
    assert len(ptx) < 400_000, len(ptx)  # one copy of the run: 90-130 kB (all 44 were 4.5 MB)


def test_the_options_change_with_any_header_of_the_kernel(tmp_path):
    """CuPy's disk cache keys a module by its source and options, not the headers it includes:
    the options carry a digest of every kernel source, which an edit to a header changes."""
    same, edited = shutil.copytree(KERNEL, tmp_path / "same"), shutil.copytree(KERNEL, tmp_path / "edited")
    (edited / "step.h").write_text((edited / "step.h").read_text() + "\n")
    digest = _sources_digest(KERNEL)
    assert f"-DPL_KERNEL_SOURCES={digest}" in compile_options(LOCAL_SIZES[0], CASES[0])
    assert _sources_digest(same) == digest != _sources_digest(edited)
