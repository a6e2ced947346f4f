"""The GPU engine's kernel (plugin/kernel/engine_gpu.cu and the shared headers) compiles with
NVRTC, as CuPy compiles it on a GPU machine (`engines.gpu.compile_options`), on any machine with
NVIDIA's NVRTC wheel (nvidia-cuda-nvrtc, in the test extras): no GPU is needed to compile.

The kernel had never been compiled by NVRTC before this test: without -default-device its
lambdas are host code to NVRTC's JIT mode, and the GPU engine failed on its first launch."""

from __future__ import annotations

import re
import shutil

import pytest

from pylmp_lattice.engines import nvrtc
from pylmp_lattice.engines.gpu import KERNEL, _sources_digest, compile_options, local_size

ARCH = "-arch=compute_90"  # the H100/H200 of issue 28; PTX, so no device is asked


def compile_ptx(options: tuple[str, ...]) -> tuple[int, str, bytes]:
    """NVRTC's result code, log and PTX for engine_gpu.cu with `options`."""
    if nvrtc.load() is None:
        pytest.skip("NVIDIA's NVRTC is not installed (pip install nvidia-cuda-nvrtc)")
    return tuple(nvrtc.compile_kernel(KERNEL / "engine_gpu.cu", options))


CASES = [  # (law kind, q, friction, record): engines.gpu.batch_case's, each law type of Law::dispatch
    (0, 3.0, True, True), (0, 3.0, False, False), (0, 1.0, True, False), (0, 8.0, False, True), (0, 2.5, True, True),
    (1, 0.0, True, True), (2, 0.0, False, True)]


@pytest.mark.parametrize(("case", "n"), [*((case, n) for case in CASES for n in (21, 1000)), (CASES[0], 64)])
def test_nvrtc_compiles_the_kernel_for_each_case_of_a_batch(n, case):
    """One entry point (the short chains' kernel for chains of n magnets, or over 64 the long
    chains', a block per chain) and one copy of the run per module: under 2 s of NVRTC each (64
    magnets, unrolled: 4-8 s, so one case only). With every case in one module (44 copies of
    the run, twice), NVRTC took 25-45 s to PTX here and 3 minutes to sm_90 code on the GPU
    machine, which stalled its first check."""
    rc, log, ptx = compile_ptx((*compile_options(n, case), ARCH))
    assert rc == 0, log
    entries = [line.split()[-1] for line in ptx.decode().splitlines() if ".entry" in line]
    assert entries == ["pl_run_short_chains_gpu(" if local_size(n) else "pl_run_long_chains_gpu("], entries
    assert len(ptx) < 1_500_000, len(ptx)  # one copy of the run: 90-570 kB (unrolled for 64 magnets; all 44: 4.5 MB)


def test_the_options_change_with_any_header_of_the_kernel(tmp_path):
    """CuPy's disk cache keys a module by its source and options, not the headers it includes:
    the options carry a digest of every kernel source, which an edit to a header changes."""
    same, edited = shutil.copytree(KERNEL, tmp_path / "same"), shutil.copytree(KERNEL, tmp_path / "edited")
    (edited / "step.h").write_text((edited / "step.h").read_text() + "\n")
    digest = _sources_digest(KERNEL)
    assert f"-DPL_KERNEL_SOURCES={digest}" in compile_options(21, CASES[0])
    assert _sources_digest(same) == digest != _sources_digest(edited)


def test_the_paper_s_chains_hold_a_fraction_of_the_local_memory_they_held(monkeypatch):
    """The short chains' kernel is compiled for the batch's length (gpu.local_size) and runs, so
    its loops unroll and less of a chain stays in local memory (ptxas's report, sm_90; the numbers
    of benchmarks/gpu_resources.py). At ece083f (local arrays of 32, loops over a run-time n) the
    stack frame was 11472 bytes a thread without friction and record, 12592 with both (9216 of
    them the record's rows), all in local memory, which 50688 resident threads on an H200 held
    at 638 MB, 13x its L2. Now, for chains of one mass (the thermal ensembles): under 1.5 kB
    without, nothing spilled. With both, the engine's choice (the marks alone in shared memory,
    the due rows listed: the fastest on an H200, bench_gpu.py --variants) holds the record's rows,
    the list of due rows (64 x 40 bytes) and under 1 kB more, some of it spilled; with the
    marks, x, v, f in shared memory (gpu.SHARED_ARRAYS = 4) nothing is spilled. The bounds
    leave room for another NVRTC's choices."""
    from pylmp_lattice.engines import gpu
    from pylmp_lattice.engines.library import layout

    if nvrtc.load() is None:
        pytest.skip("NVIDIA's NVRTC is not installed (pip install nvidia-cuda-nvrtc)")
    n = 21
    rows = n * layout().ncol * 8
    assert local_size(n) == n and local_size(64) == 64 and local_size(65) == 0
    neither, both = (0, 3.0, False, False), (0, 3.0, True, True)
    for case, shared, sampling, bound, spill in ((neither, gpu.SHARED_ARRAYS, gpu.SAMPLING, 1500, 0),
                                                 (both, gpu.SHARED_ARRAYS, gpu.SAMPLING, rows + 2560 + 1000, 2048),
                                                 (both, 4, "per_atom", rows + 500, 64)):
        monkeypatch.setattr(gpu, "SHARED_ARRAYS", shared)
        monkeypatch.setattr(gpu, "SAMPLING", sampling)
        got = nvrtc.compile_kernel(KERNEL / "engine_gpu.cu", (*compile_options(n, case, one_mass=True), "-arch=sm_90",
                                                                   "-Xptxas=-v"))
        assert got.rc == 0, got.log
        m = re.search(r"Function properties for pl_run_short_chains_gpu\n[^\n]*?(\d+) bytes stack frame, (\d+) bytes "
                      r"spill stores, (\d+) bytes spill loads", got.log)
        stack, stores, loads = map(int, m.groups())
        assert stack < min(bound, 12592) and stores <= spill and loads <= spill, (case, shared, sampling, got.log)


def test_row_copy_changes_the_short_chains_code_only(monkeypatch):
    """gpu.ROW_COPY compiles chain.h's sample_cold with each due row copied into registers (the
    emulated tests show its bits are the host's): the short chains' PTX differs from the default's,
    while the long chains' kernel is compiled as without it (the copy's registers would cost it a
    third of its resident threads)."""
    from pylmp_lattice.engines import gpu

    def ptx(n, row_copy):
        monkeypatch.setattr(gpu, "ROW_COPY", row_copy)
        options = compile_options(n, CASES[0])
        rc, log, code = compile_ptx((*options, ARCH))
        assert rc == 0, log
        return options, code

    assert ptx(21, False)[1] != ptx(21, True)[1]
    assert ptx(1000, False)[0] == ptx(1000, True)[0]
