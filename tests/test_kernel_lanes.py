"""The host engine's lanes (engine_cpu.cpp): chains side by side in the lanes of a vector, 4 with
AVX2 and 2 with SSE2 alone, each lane with the bits of its chain run alone. The installed library
takes AVX2 where the CPU has it, so the SSE2 lanes are checked here in a build of their own
(PL_LANES_SSE2). The rule both run (kernel/front.h's advance_lanes, also fix lattice/chain's and
the GPU's) is checked against the measures of every step's arrays in test_output.py and
test_noise_measures.py."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from pylmp_lattice.engines import cpu, library
from pylmp_lattice.engines.arrays import prepare
from pylmp_lattice.engines.library import layout

from conftest import make_case
from test_kernel_cpu import FRICTION


@pytest.mark.slow  # compiles the library (about 10-20 s)
def test_the_sse2_lanes_give_the_avx2_lanes_bits(tmp_path, monkeypatch):
    """The library built with PL_LANES_SSE2 (2 chains a thread side by side, as on a CPU without
    AVX2) against the installed one (4): x, v, the front record, work, end step and status, byte
    for byte, for 23 thermal members with friction under mass disorder (lanes past the last chain
    in both) and 11 whose chains meet in a contact at different steps (lanes that end while the
    others run on)."""
    if layout().lanes != 4:
        pytest.skip("the installed library runs 2 lanes here: nothing to compare the SSE2 build with")
    compiler = shutil.which("g++")
    if compiler is None:
        pytest.skip("no g++ to build the SSE2 lanes")
    source = Path(cpu.__file__).resolve().parent.parent / "plugin"  # (an installed package ships them too)
    built = tmp_path / "engine_sse2.so"
    done = subprocess.run([compiler, "-O1", "-std=c++17", "-fPIC", "-shared", "-fopenmp", "-ffp-contract=off",
                           "-Wno-psabi", "-DPL_LANES_SSE2", "-I", str(source), str(source / "engine_cpu.cpp"), "-o",
                           str(built)], capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"g++ could not build the SSE2 lanes: {done.stderr.strip()[-300:]}")
    batches = {
        "disorder": [make_case(particles=21, duration=30.0, output={"format": "none"}, friction=FRICTION,
                               chain={"thermal_velocity": 0.02, "seed": s, "mass_disorder": 0.02 * (s % 2),
                                      "disorder": "uniform"}) for s in range(23)],
        "contact": [make_case(particles=21, duration=80.0, output={"format": "none"},
                              chain={"thermal_velocity": 0.3, "seed": s}) for s in range(11)],
    }
    arrays = {name: prepare(cases, "cpu") for name, cases in batches.items()}
    want = {name: cpu.run_arrays(a, 2) for name, a in arrays.items()}
    monkeypatch.setattr(library, "_LOADED", [library._load(built)])
    assert layout().lanes == 2
    statuses = set(layout().status[k] for k in want["contact"][5])
    assert "contact" in statuses and len(set(want["contact"][4])) > 1, (statuses, want["contact"][4])
    assert np.isfinite(want["disorder"][2][:, 1]).any()  # arrivals recorded
    for name, a in arrays.items():
        got = cpu.run_arrays(a, 2)
        for field, mine, avx2 in zip(("x", "v", "front", "work", "end_step", "status"), got, want[name]):
            assert mine.tobytes() == avx2.tobytes(), (name, field)


def test_a_chain_that_ends_keeps_its_record_while_its_lanes_run_on():
    """Chains that meet in a contact at different steps, side by side in lanes with chains that
    run on to the end: each one's x, v, record, work, end step and status are those of the same
    chain run alone (its own call, its lanes copies of it, which end with it), byte for byte: an
    ended lane's rows are not touched by its neighbours' later steps (a mutation that sampled
    ended lanes survived the other tests)."""
    # every other chain with a gap of 0.3 mm at magnet 8: a contact at 27-36 ms of the 60
    cases = [make_case(particles=21, duration=60.0, output={"format": "none"},
                       chain={"thermal_velocity": 0.02, "seed": s, **({"defect_index": 8, "defect_r0": 0.3} if s % 2 else {})})
             for s in range(8)]
    together = cpu.run_arrays(prepare(cases, "cpu"), 1)
    statuses = [layout().status[k] for k in together[5]]
    assert statuses == ["done", "contact"] * 4 and max(together[4][1::2]) < 4000, (statuses, together[4])
    n = cases[0].chain.particles
    for k, case in enumerate(cases):
        alone = cpu.run_arrays(prepare([case], "cpu"), 1)
        for name, got, want in zip(("x", "v", "front", "work", "end_step", "status"), together, alone):
            mine = got[k * n:(k + 1) * n] if name == "front" else got[k]  # (front: a row per atom)
            assert mine.tobytes() == (want if name == "front" else want[0]).tobytes(), (k, name)
