"""NVIDIA's NVRTC from its wheel (nvidia-cuda-nvrtc), without CuPy or a device: the GPU engine's
kernel (plugin/kernel/engine_gpu.cu) compiled to PTX, or to machine code with ptxas's report of
each function's registers, stack frame and spills (tests/test_gpu_build.py,
benchmarks/gpu_resources.py). On a GPU machine CuPy compiles the same source with the same options
(engines.gpu.compile_options)."""

from __future__ import annotations

import ctypes
import importlib.util
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

__all__ = ["Compiled", "compile_kernel", "load"]


class Compiled(NamedTuple):
    """What NVRTC made of a source."""

    rc: int  # NVRTC's result code (0: compiled)
    log: str  # its log (with -Xptxas=-v, ptxas's report)
    code: bytes  # PTX (-arch=compute_XX) or a CUBIN (-arch=sm_XX); empty if it failed


@lru_cache
def load() -> ctypes.CDLL | None:
    """NVRTC from the nvidia-cuda-nvrtc wheel (its builtins loaded first: NVRTC opens them by
    name), or None."""
    spec = importlib.util.find_spec("nvidia")
    for root in (spec.submodule_search_locations if spec else []):
        for lib in sorted(Path(root).glob("*/lib/libnvrtc.so.*")):
            for builtins in Path(lib.parent).glob("libnvrtc-builtins.so.*"):
                ctypes.CDLL(str(builtins), mode=ctypes.RTLD_GLOBAL)
            return ctypes.CDLL(str(lib))
    return None


def compile_kernel(source: Path, options: tuple[str, ...]) -> Compiled:
    """`source` compiled by NVRTC with `options`: PTX for -arch=compute_XX, a CUBIN for
    -arch=sm_XX. RuntimeError if NVRTC is not installed."""
    lib = load()
    if lib is None:
        raise RuntimeError("NVIDIA's NVRTC is not installed (pip install nvidia-cuda-nvrtc)")
    prog = ctypes.c_void_p()
    if lib.nvrtcCreateProgram(ctypes.byref(prog), source.read_bytes(), source.name.encode(), 0, None, None) != 0:
        raise RuntimeError(f"NVRTC could not create a program of {source}")
    try:
        opts = [o.encode() for o in options]
        rc = lib.nvrtcCompileProgram(prog, len(opts), (ctypes.c_char_p * len(opts))(*opts))
        size = ctypes.c_size_t()
        lib.nvrtcGetProgramLogSize(prog, ctypes.byref(size))
        log = ctypes.create_string_buffer(size.value)
        lib.nvrtcGetProgramLog(prog, log)
        code = b""
        if rc == 0:
            cubin = any(o.startswith("-arch=sm_") for o in options)
            get_size, get = (lib.nvrtcGetCUBINSize, lib.nvrtcGetCUBIN) if cubin else (lib.nvrtcGetPTXSize, lib.nvrtcGetPTX)
            get_size(prog, ctypes.byref(size))
            buf = ctypes.create_string_buffer(size.value)
            get(prog, buf)
            code = buf.raw if cubin else buf.value
        return Compiled(rc, log.value.decode(errors="replace"), code)
    finally:
        lib.nvrtcDestroyProgram(ctypes.byref(prog))
