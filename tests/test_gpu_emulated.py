"""The GPU engine (engines.gpu) on the road of every batch with its CUDA kernels emulated on the
host: engine_gpu.cu compiled by g++ (tests/cuda_host.h defines CUDA's qualifiers, thread indices
and barriers) and run a block after another, each of a block's threads a host thread, which meet
at its barriers (the long chains' kernel, a block per chain), behind a NumPy stand-in for CuPy that passes each kernel argument as CuPy passes it
and refuses what CuPy would pass otherwise (a Python int or float, a host array, an argument
that is not the kernel's parameter in kind or count). So everything but the device runs here:
the arguments, their order and types, the launches and their chunks, the local and global-row
paths, the copies back. Against the host engine (engines.cpu) on the same batch: x, v, the front
record, work, end step and status, for every law, drive, friction on and off, thermal and
disorder members, both far ends, chains on both local sizes and a block per chain (long ones), and batches in
several launches. Still only a device can check local memory's limits, launch limits, NVRTC's
code (tests/test_gpu_build.py compiles it) and CuPy's own conversions (the gpu-marked tests)."""

from __future__ import annotations

import ctypes
import re
import shutil
import subprocess
import sys
import threading
import types
from pathlib import Path

import numpy as np
import pytest

from pylmp_lattice.case import Case
from pylmp_lattice.engines import cpu, gpu
from pylmp_lattice.engines.arrays import prepare
from pylmp_lattice.engines.library import Unsupported, layout, library, ptr
from pylmp_lattice.engines.road import KernelEngine
from pylmp_lattice.errors import ContactError
from pylmp_lattice.formats.layout import CHAIN_WORK, FRONT_BIN
from pylmp_lattice.run_folder import execute_batch
from pylmp_lattice.sweep.store import Outcomes

from conftest import OTHER_LAWS, make_case
from test_kernel_cpu import DRIVES, FRICTION  # its cases, which its gpu-marked tests run on a device

SHIM = Path(__file__).resolve().parent / "cuda_host.h"
SOURCE = gpu.KERNEL / "engine_gpu.cu"
NVRTC_ONLY = ("-default-device", "-fmad=false")  # options g++ has no use for (the shim's __device__ is nothing;
# g++ contracts nothing on x86-64 without -mfma)
# a kernel parameter's C type -> the NumPy type CuPy passes as it (scalars) or the array's dtype (pointers)
C_TYPES = {"int": np.int32, "long long": np.int64, "double": np.float64, "unsigned char": np.uint8}
GUARD = 4096  # bytes either side of each array argument, checked after a launch
CTYPES = {np.int32: ctypes.c_int, np.int64: ctypes.c_longlong, np.float64: ctypes.c_double}
COMPILE_OPTIONS = gpu.compile_options  # what CuPy's stand-in checks a module's options against


def kernel_signatures(text: str) -> dict[str, list[tuple[str, bool]]]:
    """Each extern "C" __global__ kernel's parameters as (C type, pointer, const), PL_SETUP_PARAMS expanded."""
    text = re.sub(r"/\*.*?\*/|//[^\n]*", "", text, flags=re.S).replace("\\\n", " ")
    macros = dict(re.findall(r"#define\s+(PL_\w+_PARAMS)\s+([^\n]*)", text))
    out = {}
    for name, params in re.findall(r'extern\s+"C"\s+__global__\s+void\s+(\w+)\s*\(([^)]*)\)', text):
        for macro, body in macros.items():
            params = re.sub(rf"\b{macro}\b", body, params)
        sig = []
        for param in params.split(","):
            words = param.replace("*", " * ").split()
            pointer = "*" in words
            base = " ".join(w for w in words[:-1] if w not in ("const", "*", "__restrict__"))
            assert base in C_TYPES, f"{name}: parameter {param.strip()!r} of a type the emulator does not know"
            sig.append((base, pointer, "const" in words))
        out[name] = sig
    return out


class DeviceArray(np.ndarray):
    """A "device" array: a NumPy array with CuPy's .get() (a host copy)."""

    def get(self) -> np.ndarray:
        return np.array(self)


def _device(a) -> DeviceArray:
    return np.array(a, copy=True).view(DeviceArray)  # CuPy's asarray copies host arrays to the device


class Kernel:
    """A kernel of the emulated module: called as CuPy's RawKernel, (grid, block, args)."""

    def __init__(self, lib: ctypes.CDLL, name: str, signature: list[tuple[str, bool, bool]], launches: list):
        self.fn, self.name, self.signature, self.launches = getattr(lib, name), name, signature, launches
        self.set_thread = lib.pl_emu_set_thread
        self.set_thread.argtypes = [ctypes.c_uint] * 3
        self.begin_block = lib.pl_emu_begin_block
        self.begin_block.argtypes = [ctypes.c_uint]
        self.broken = lib.pl_emu_broken

    def marshal(self, args) -> list:
        """The arguments as CuPy passes them (NumPy scalars by their type, arrays as their data
        pointer); TypeError for anything the kernel's parameter is not."""
        if len(args) != len(self.signature):
            raise TypeError(f"{self.name}: {len(args)} arguments for {len(self.signature)} parameters")
        out = []
        for k, (arg, (base, pointer, _)) in enumerate(zip(args, self.signature)):
            want = C_TYPES[base]
            if pointer:
                if not isinstance(arg, DeviceArray) or arg.dtype != want or not arg.flags.c_contiguous:
                    raise TypeError(f"{self.name}: argument {k} is {type(arg).__name__} "
                                    f"{getattr(arg, 'dtype', '')}, not a contiguous device array of {base}")
                out.append(arg)
            else:
                if type(arg) is not want:  # a Python int or float: CuPy passes it as another type
                    raise TypeError(f"{self.name}: argument {k} is {type(arg).__name__}, not {want.__name__} ({base})")
                out.append(CTYPES[want](arg.item()))
        return out

    def __call__(self, grid, block, args):
        """Every block of the launch, one after another, its threads host threads (ctypes lets go
        of the GIL in a call), on guarded copies of the arrays (a write outside an argument's
        array, or into a const one, fails the test)."""
        assert len(grid) == 1 and len(block) == 1, "the engine's launches are 1-D"
        args = self.marshal(args)
        arrays = [a for a in args if isinstance(a, DeviceArray)]
        for i, a in enumerate(arrays):  # distinct arrays (the kernels' pointers are __restrict__)
            assert not any(np.shares_memory(a, b) for b in arrays[i + 1:]), f"{self.name}: arguments share memory"
        guarded = {id(a): np.full(a.nbytes + 2 * GUARD, 0xA5, np.uint8) for a in arrays}
        for a in arrays:
            guarded[id(a)][GUARD:GUARD + a.nbytes] = a.view(np.uint8).reshape(-1)
        c_args = [ctypes.c_void_p(guarded[id(a)].ctypes.data + GUARD) if isinstance(a, DeviceArray) else a for a in args]
        self.launches.append((self.name, grid[0], block[0]))
        errors = []

        def thread(b: int, t: int) -> None:
            try:
                self.set_thread(b, block[0], t)
                self.fn(*c_args)
            except BaseException as err:  # pragma: no cover - reported below
                errors.append(err)

        for b in range(grid[0]):
            self.begin_block(block[0])
            threads = [threading.Thread(target=thread, args=(b, t)) for t in range(block[0])]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
        assert not errors, errors
        assert not self.broken(), f"{self.name}: a barrier that not every thread of its block reached (a device hangs)"
        for k, (a, (_, pointer, const)) in enumerate(zip(args, self.signature)):
            if pointer:
                g, data = guarded[id(a)], a.view(np.uint8).reshape(-1)
                assert (g[:GUARD] == 0xA5).all() and (g[GUARD + a.nbytes:] == 0xA5).all(), \
                    f"{self.name}: argument {k} written outside its array"
                assert not const or np.array_equal(g[GUARD:GUARD + a.nbytes], data), f"{self.name}: const argument {k} written"
                data[:] = g[GUARD:GUARD + a.nbytes]


class FakeCupy(types.ModuleType):
    """The part of CuPy that engines.gpu uses, on NumPy and the emulated kernels."""

    int32, int64, uint8, float64 = np.int32, np.int64, np.uint8, np.float64

    def __init__(self, build):
        super().__init__("cupy")
        self.build, self.launches, self.modules = build, [], []
        class Event:  # CuPy's signature; the emulated launches have finished when they return
            def __init__(self, block=False, disable_timing=False, interprocess=False):
                pass

            def record(self, stream=None):
                pass

            def synchronize(self):
                pass

        self.cuda = types.SimpleNamespace(Event=Event, runtime=types.SimpleNamespace(getDeviceCount=lambda: 1))
        fake = self

        class RawModule:
            def __init__(self, code: str, options: tuple[str, ...]):
                assert code == SOURCE.read_text()
                d = dict(o[2:].split("=", 1) for o in options if o.startswith("-D"))
                case = int(d["PL_LAW_KIND"]), float(d["PL_LAW_Q"]), d["PL_FRICTION"] == "1", d["PL_RECORD"] == "1"
                assert options == COMPILE_OPTIONS(int(d["PL_LOCAL_N"]), case, block=int(d["PL_BLOCK"]),
                                                  one_mass=d["PL_ONE_MASS"] == "1"), options
                fake.modules.append(options)
                self.lib = fake.build(options)
                self.signatures = kernel_signatures(code)

            def get_function(self, name: str) -> Kernel:
                return Kernel(self.lib, name, self.signatures[name], fake.launches)

        self.RawModule = RawModule

    @staticmethod
    def asarray(a):
        return _device(a)

    @staticmethod
    def zeros(n, dtype=np.float64):
        return np.zeros(n, dtype).view(DeviceArray)

    @staticmethod
    def empty(n, dtype=np.float64):
        return np.empty(n, dtype).view(DeviceArray)

    @staticmethod
    def full(n, value, dtype=np.float64):
        return np.full(n, value, dtype).view(DeviceArray)

    @staticmethod
    def arange(n, dtype=None):
        return np.arange(n, dtype=dtype).view(DeviceArray)


@pytest.fixture(scope="session")
def emulated_build(tmp_path_factory):
    """options -> the g++ build of engine_gpu.cu with them (cached for the session)."""
    gxx = shutil.which("g++")
    if gxx is None:
        pytest.skip("no g++ to build the emulated kernels")
    folder, built = tmp_path_factory.mktemp("gpu_emulated"), {}

    def build(options: tuple[str, ...]) -> ctypes.CDLL:
        if options not in built:
            flags = [o for o in options if o not in NVRTC_ONLY]
            assert all(o.startswith(("-std=", "-I", "-D")) for o in flags), flags
            lib = folder / f"engine_gpu_{len(built)}.so"
            subprocess.run([gxx, "-O0", "-shared", "-fPIC", *flags, "-include", str(SHIM), "-x", "c++", str(SOURCE),
                            "-o", str(lib)], check=True)
            built[options] = ctypes.CDLL(str(lib))
        return built[options]

    return build


@pytest.fixture
def emulated_gpu(monkeypatch, emulated_build) -> FakeCupy:
    """engines.gpu on the emulated kernels (its module cache emptied: they are not CuPy's)."""
    fake = FakeCupy(emulated_build)
    monkeypatch.setitem(sys.modules, "cupy", fake)
    monkeypatch.setattr(gpu, "available", lambda: None)
    monkeypatch.setattr(gpu, "_MODULES", {})
    return fake


def run_both(cases: list[Case], tmp_path: Path, monkeypatch) -> dict:
    """The batch on the road with --engine cpu and --engine gpu: each engine's run_arrays
    outputs (x, v, front, work, end_step, status; the GPU's launched before the road writes the
    folder, `gpu.launch`) and the files each left, or its error."""
    got = {}
    for kind, owner, name in (("cpu", cpu, "run_arrays"), ("gpu", gpu.Launched, "result")):
        original = getattr(owner, name)

        def capture(*args, _run=original, _kind=kind, **kw):
            got[_kind] = {"out": _run(*args, **kw)}
            return got[_kind]["out"]

        monkeypatch.setattr(owner, name, capture)
        folder = tmp_path / kind
        try:
            execute_batch(cases, folder, KernelEngine(kind, cases))
        except ContactError as err:
            got[kind]["error"] = (err.pair, err.time_ms, err.gap_mm)
        got[kind]["files"] = {name: (folder / name).read_bytes() for name in (FRONT_BIN, CHAIN_WORK)
                              if (folder / name).exists()}
    return got


def assert_same_outputs(got: dict) -> bool:
    """The GPU engine's outputs within 1e-12 relative of the host's, the same end steps, statuses,
    errors and files; True if every bit is the same."""
    names = ("x", "v", "front", "work", "end_step", "status")
    host, dev = got["cpu"]["out"], got["gpu"]["out"]
    for name, a, b in zip(names, host, dev):
        if a is None or b is None:
            assert a is None and b is None, name
            continue
        assert a.shape == b.shape and a.dtype == b.dtype, name
        if a.dtype.kind == "f":
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=0, equal_nan=True, err_msg=name)
        else:
            assert np.array_equal(a, b), name
    assert got["cpu"].get("error") == got["gpu"].get("error")
    assert got["cpu"]["files"].keys() == got["gpu"]["files"].keys()
    same_bits = all(a is None or np.array_equal(a, b, equal_nan=a.dtype.kind == "f") for a, b in zip(host, dev))
    return same_bits and got["cpu"]["files"] == got["gpu"]["files"]


def same_but_work(got: dict) -> bool:
    """assert_same_outputs' checks passed (within 1e-12), and every bit the same but the friction
    work's and the file that holds it, which differ (if at all) by rounding alone (1e-14 relative)."""
    host, dev = got["cpu"]["out"], got["gpu"]["out"]
    np.testing.assert_allclose(dev[3], host[3], rtol=1e-14, atol=0)
    same = all(a is None or np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
               for k, (a, b) in enumerate(zip(host, dev)) if k != 3)
    files = {k: v for k, v in got["cpu"]["files"].items() if k != CHAIN_WORK}
    return same and files == {k: v for k, v in got["gpu"]["files"].items() if k != CHAIN_WORK}


LAWS = {
    "power_q3": {},  # the paper's, q an integer (the kernel's integer-power road)
    "power_q2.7": {"force": {"law": "power", "K": 413.8, "b": 3.917, "q": 2.7}},
    "linear": {"force": {"law": "linear", "k": 0.1, "r_free": 20.0}, "velocity": 0.5},
    "table_morse": "morse",
}


def members(count: int = 6, particles: int | None = 21, duration: float = 10.0, chain: dict | None = None,
            law: str = "power_q3", **kw) -> list[Case]:
    """`count` thermal members of one point (the front record on), `particles` magnets."""
    base = {"particles": particles, "duration": duration, "output": {"format": "none"}}
    spec = LAWS[law]
    if isinstance(spec, str):  # a law the kernel runs as a table
        force, r0, table = OTHER_LAWS[spec]
        base |= {"force": force, "table": table, "velocity": 0.5}
        chain = {"mass": 1.0, "r0": r0} | (chain or {})
    else:
        base |= spec
    chain = {"thermal_velocity": 0.02} | (chain or {})
    return [make_case(**(base | kw), chain=chain | {"seed": s}) for s in range(count)]


SCENARIOS = {
    **{f"{law}-{'friction' if fr else 'frictionless'}": (lambda law=law, fr=fr: members(law=law, **({"friction": FRICTION} if fr else {})))
       for law in LAWS for fr in (False, True)},
    **{f"drive-{d}": (lambda d=d: members(impactor=DRIVES[d], friction=FRICTION)) for d in DRIVES},
    "disorder": lambda: members(friction=FRICTION, chain={"thermal_velocity": None, "mass_disorder": 0.05, "r0_disorder": 0.05}),
    "long-far-end": lambda: members(particles=None, duration=5.0, chain={"far_end": "long"}),
    "40-magnets-short": lambda: members(particles=40, friction=FRICTION),
    "64-magnets-short": lambda: members(particles=64, impactor=DRIVES["measured"]),
    "120-magnets-long": lambda: members(particles=120, friction=FRICTION),
    "120-magnets-table-long": lambda: members(particles=120, law="table_morse", impactor=DRIVES["sine"]),
    "300-magnets-two-host-runs-long": lambda: members(count=3, particles=300, duration=2.0, friction=FRICTION),  # n - 2 > block
    "120-magnets-rest-long": lambda: members(particles=120, impactor=DRIVES["rest"]),  # no record
    "67-magnets-disorder-long": lambda: members(count=3, particles=67, friction=FRICTION, chain={
        "thermal_velocity": None, "mass_disorder": 0.05, "r0_disorder": 0.05}),  # segments of 7 and 8
    "contact": lambda: members(count=4, duration=80.0),  # 21 magnets driven into the held end: a contact at about 68.6 ms
    "contact-long": lambda: members(count=3, particles=70, duration=80.0, velocity=4.0),
}


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_the_emulated_gpu_engine_gives_the_host_engine_s_results(tmp_path, monkeypatch, emulated_gpu, scenario):
    cases = SCENARIOS[scenario]()
    got = run_both(cases, tmp_path, monkeypatch)
    n = cases[0].chain.particles
    local = gpu.local_size(n)
    # bit for bit (one kernel, one compiler, no FMA contraction on x86-64), but for a long chain's
    # friction work: its threads' sums added in thread order, not in the host's atom order
    assert assert_same_outputs(got) or (not local and same_but_work(got))
    a = prepare(cases, "gpu")
    assert emulated_gpu.modules == [gpu.compile_options(n, gpu.batch_case(a), one_mass=gpu.one_mass(a))]
    assert (got["gpu"]["out"][2] is None) == scenario.endswith(("rest", "rest-long"))  # a drive at rest: no record
    if scenario.startswith("contact"):
        assert got["gpu"]["error"] is not None and got["gpu"]["out"][5].any()
    else:
        assert not got["gpu"]["out"][5].any() and "error" not in got["gpu"]
    if not local:  # a block a chain, a thread a segment of at most LONG_SEGMENT atoms
        assert emulated_gpu.launches == [("pl_run_long_chains_gpu", len(cases), -(-(n - 2) // gpu.LONG_SEGMENT))]
        assert {"-DPL_LOCAL_N=0", f"-DPL_BLOCK={gpu.LONG_SEGMENT}", f"-DPL_THREADS={gpu.LONG_THREADS}"} <= set(
            emulated_gpu.modules[0])
        return
    threads = gpu.block_threads(local)  # blocks whose rows of shared memory fit 48 KB
    assert emulated_gpu.launches == [("pl_run_short_chains_gpu", 1, threads)]
    row = gpu.shared_row(local)
    # x, v, f in shared memory: blocks of SHARED_THREADS; else THREADS, halved until the marks fit
    first = gpu.SHARED_THREADS if gpu.shared_arrays(local) > 1 else gpu.THREADS
    assert threads * row * 8 <= gpu.SHARED_LIMIT and (threads == first or 2 * threads * row * 8 > gpu.SHARED_LIMIT), \
        (threads, row)
    # the marks, x, v, f in the row where 32 threads fit, else the marks alone
    fits = 32 * ((gpu.SHARED_ARRAYS * local) | 1) * 8 <= gpu.SHARED_LIMIT
    assert gpu.shared_arrays(local) == (gpu.SHARED_ARRAYS if fits else 1) and row % 2 == 1
    # a module with one of each mass term for chains of one mass; n of them with mass disorder
    assert ("-DPL_ONE_MASS=1" in emulated_gpu.modules[0]) == (scenario != "disorder")


def test_a_chain_that_ends_early_keeps_its_end_state_while_the_others_run_on(tmp_path, monkeypatch, emulated_gpu):
    """The host engine runs chains side by side in the lanes of a vector (engine_cpu.cpp): 11
    members (a batch of lanes and a part-full one) driven into a contact at different steps, each
    lane's end state, record, work and end step against the GPU kernel's one chain per thread."""
    cases = members(count=11, duration=80.0, chain={"thermal_velocity": 0.3})
    got = run_both(cases, tmp_path, monkeypatch)
    assert assert_same_outputs(got)
    end_step, status = got["cpu"]["out"][4:]
    assert status.any() and len(set(end_step[status != 0])) > 1 and end_step.max() > end_step.min()


@pytest.mark.parametrize("particles", [21, 100])
def test_batches_in_several_launches(tmp_path, monkeypatch, emulated_gpu, particles):
    """40 chains in launches of 16 (CHUNK_ATOM_STEPS and THREADS small): 21 magnets, grids of 2,
    2 and 1 blocks of 8 threads, the last block part-full; 100 magnets, grids of 16, 16 and 8
    chains, a block of 13 threads each; each chain its own levels (thermal draws)."""
    cases = members(count=40, particles=particles, friction=FRICTION)
    monkeypatch.setattr(gpu, "THREADS", 8)
    monkeypatch.setattr(gpu, "SHARED_THREADS", 8)
    monkeypatch.setattr(gpu, "CHUNK_ATOM_STEPS", 16 * particles * cases[0].run.steps() + 1)
    got = run_both(cases, tmp_path, monkeypatch)
    if particles == 21:
        assert assert_same_outputs(got)
        assert [launch[1:] for launch in emulated_gpu.launches] == [(2, 8), (2, 8), (1, 8)]
    else:
        assert same_but_work(got)
        assert [launch[1:] for launch in emulated_gpu.launches] == [(16, 13), (16, 13), (8, 13)]


@pytest.mark.parametrize("particles", [21, 70])
def test_a_module_built_for_another_batch_runs_no_chain_and_is_refused(tmp_path, monkeypatch, emulated_gpu, particles):
    """A module holds one case of the law, friction and record (engine_gpu.cu's run_compiled):
    given a batch of another case, its chains are not run (a thread a chain, or a block), and
    the engine says so."""
    a = prepare(members(count=3, particles=particles, friction=FRICTION), "gpu")
    batch_case = gpu.batch_case
    assert gpu.batch_case(a) == (0, 3.0, True, True)
    for other in ((0, 2.0, True, True), (0, 3.5, True, True), (1, 0.0, True, True), (0, 3.0, False, True),
                  (0, 3.0, True, False)):
        monkeypatch.setattr(gpu, "batch_case", lambda _a, _other=other: _other)
        with pytest.raises(RuntimeError, match="did not run this batch's chains"):
            gpu.run_arrays(a)
    monkeypatch.setattr(gpu, "batch_case", batch_case)
    if particles != 21:
        return
    # a module for chains of 22 magnets
    monkeypatch.setattr(gpu, "compile_options", lambda n, *args, **kw: COMPILE_OPTIONS(n + 1, *args, **kw))
    with pytest.raises(RuntimeError, match="did not run this batch's chains"):
        gpu.run_arrays(a)


@pytest.mark.parametrize("block,shared,sampling,row_copy", [
    (1, 4, "per_atom", False), (4, 1, "listed", False), (19, 4, "listed", False), (19, 3, "per_atom", False),
    (19, 2, "listed", False), (19, 1, "masked", False), (19, 2, "masked", False), (4, 4, "masked", False),
    (19, 1, "listed", True), (4, 2, "masked", True), (19, 4, "per_atom", True)])
def test_the_short_chains_runs_change_no_bit(tmp_path, monkeypatch, emulated_gpu, block, shared, sampling, row_copy):
    """The short chains' kernel steps the free atoms in runs of at most gpu.SHORT_BLOCK (a
    compile-time constant, chosen by the registers it leaves, benchmarks/gpu_resources.py): one
    atom, a few runs, or one run of all 19; x, v, f in shared memory or registers (the first
    `shared` of marks, x, v, f in shared memory); the record's rows sampled per atom, or listed
    or marked in a bit mask and sampled after the step, each row sampled in place or copied
    whole (gpu.ROW_COPY): bit for bit the host engine's (runs of its BLOCK, sampled per run)."""
    monkeypatch.setattr(gpu, "SHORT_BLOCK", block)
    monkeypatch.setattr(gpu, "SHARED_ARRAYS", shared)
    monkeypatch.setattr(gpu, "SAMPLING", sampling)
    monkeypatch.setattr(gpu, "ROW_COPY", row_copy)
    cases = members(friction=FRICTION)
    assert assert_same_outputs(run_both(cases, tmp_path, monkeypatch))
    a = prepare(cases, "gpu")
    assert emulated_gpu.modules[0] == gpu.compile_options(21, gpu.batch_case(a), one_mass=True)
    assert {f"-DPL_BLOCK={block}", f"-DPL_SHARED_ARRAYS={shared}", f"-DPL_SAMPLING={gpu.SAMPLINGS[sampling]}",
            f"-DPL_ROW_COPY={int(row_copy)}"} <= set(emulated_gpu.modules[0])


@pytest.mark.parametrize("segment,threads", [(1, 256), (3, 256), (8, 4)])
def test_the_long_chains_segments_change_no_bit_of_x_v_and_the_record(tmp_path, monkeypatch, emulated_gpu, segment,
                                                                       threads):
    """A block per chain of 70 magnets in segments of 1 free atom (68 threads: each thread's two
    ghosts the neighbours of one atom), of 3 (23 threads, the last segments shorter), and at most
    4 threads a block (segments of up to 24: LONG_SEGMENT's multiple that 4 threads need; 3
    threads of 22 and 23), with friction and a thermal
    velocity of 3 m/s, which brings magnets 4 and 5, 47 and 48, 62 and 63 into contact (one in
    each chain, at steps 148, 115 and 110, found by whichever thread holds the pair): x, v, the
    record, end steps and statuses bit for bit the host's, the work within 1e-14; every thread of
    a chain ends at its contact's step."""
    monkeypatch.setattr(gpu, "LONG_SEGMENT", segment)
    monkeypatch.setattr(gpu, "LONG_THREADS", threads)
    cases = members(count=3, particles=70, friction=FRICTION, duration=10.0, velocity=0.5,
                    chain={"thermal_velocity": 3.0})
    got = run_both(cases, tmp_path, monkeypatch)
    assert assert_same_outputs(got) or same_but_work(got)
    want = {1: 68, 3: 23, 8: 3}[segment]
    assert emulated_gpu.launches == [("pl_run_long_chains_gpu", 3, want)] and gpu.long_threads(70) == want
    x, end_step, status = got["gpu"]["out"][0], *got["gpu"]["out"][4:]
    assert list(end_step) == [148, 115, 110] and status.all()
    assert list(np.argmin(np.diff(x, axis=1), axis=1)) == [4, 47, 62]


@pytest.mark.parametrize("segment", [1, 2, 4])
def test_the_paper_s_chains_through_the_long_chains_kernel_change_no_bit(tmp_path, monkeypatch, emulated_gpu, segment):
    """bench_gpu.py --variants' "a block per chain" rows: the 21-magnet thermal replicas with
    friction, a block each (19, 10 and 5 threads), give the host's x, v, record, end steps and
    statuses bit for bit, the work within 1e-14 (summed by thread), so that the rows time the
    same members' same numbers."""
    monkeypatch.setattr(gpu, "local_size", lambda _n: 0)
    monkeypatch.setattr(gpu, "LONG_SEGMENT", segment)
    cases = members(count=4, friction=FRICTION)
    got = run_both(cases, tmp_path, monkeypatch)
    assert assert_same_outputs(got) or same_but_work(got)
    assert emulated_gpu.launches == [("pl_run_long_chains_gpu", 4, {1: 19, 2: 10, 4: 5}[segment])]
    assert got["gpu"]["out"][2] is not None and not got["gpu"]["out"][5].any()


def test_a_long_chain_whose_drive_ends_ends_in_every_thread_at_the_host_s_step(emulated_gpu):
    """The measured drive stops where its data end (8 ms, impactor.after = "stop"): a batch run
    50 steps past it (the road refuses such a case; the kernel's end without a barrier) ends
    with status drive ended at step 800 in the block per chain as in the host build, x, v, the
    record bit for bit, the work within 1e-14."""
    import dataclasses

    cases = members(count=2, particles=70, duration=8.0, impactor=dict(DRIVES["measured"], after="stop"),
                    friction=FRICTION)
    a = prepare(cases, "gpu")
    a = dataclasses.replace(a, steps=a.steps + 50)
    host, dev = cpu.run_arrays(a, 1), gpu.run_arrays(a)
    assert emulated_gpu.launches[-1][0] == "pl_run_long_chains_gpu"
    assert list(host[4]) == [800, 800] and [layout().status[k] for k in host[5]] == ["drive_ended"] * 2
    for k in (0, 1, 4, 5):
        assert np.array_equal(dev[k], host[k]), k
    assert np.array_equal(dev[2], host[2], equal_nan=True)
    np.testing.assert_allclose(dev[3], host[3], rtol=1e-14, atol=0)


def test_chains_too_long_for_a_block_are_refused_with_a_reason(emulated_gpu, monkeypatch):
    """Over 2 + LONG_THREADS x LONG_SEGMENT_MAX magnets (65538) a thread's segment would not fit
    its local memory: the engine refuses the batch (the sweep runs it on LAMMPS, with a note)."""
    assert gpu.too_long(65538) is None and "chains of 65539 magnets" in gpu.too_long(65539)
    assert gpu.long_segment(65538) == gpu.LONG_SEGMENT_MAX and gpu.long_threads(65538) == gpu.LONG_THREADS
    assert gpu.long_segment(2051) == 16  # a multiple of LONG_SEGMENT: 2051 to 4098 magnets share a module
    monkeypatch.setattr(gpu, "LONG_SEGMENT_MAX", 4)
    monkeypatch.setattr(gpu, "LONG_THREADS", 16)
    with pytest.raises(Unsupported, match="chains of 70 magnets: the GPU engine runs at most 66 "):
        KernelEngine("gpu", members(count=2, particles=70))
    assert KernelEngine("gpu", members(count=2, particles=66)).arrays.n == 66


def test_the_emulator_refuses_what_cupy_would_pass_otherwise(emulated_build):
    """A Python int or float, a host array, a wrong dtype, a wrong count: each a TypeError, not a crash."""
    sig = kernel_signatures(SOURCE.read_text())
    long = sig["pl_run_long_chains_gpu"]
    assert len(sig["pl_run_short_chains_gpu"]) == 29 + 8 and len(long) == 29 + 10
    assert long[29 + 6] == ("unsigned char", True, False)  # phase
    assert long[29 + 2] == ("double", True, True) and long[29 + 3] == ("int", True, True)  # mass, index
    assert long[27:29] == [("double", True, True), ("long long", False, False)]  # drive path
    lib = emulated_build(gpu.compile_options(21, (0, 3.0, True, True)))
    k = Kernel(lib, "pl_run_short_chains_gpu", sig["pl_run_short_chains_gpu"], [])
    good = [np.int32(1) if b == "int" else np.int64(1) if b == "long long" else np.float64(1.0) for b, p, _ in k.signature]
    good = [FakeCupy.zeros(4, C_TYPES[b]) if p else g for g, (b, p, _) in zip(good, k.signature)]
    assert len(k.marshal(good)) == len(good)
    for k_arg, bad in ((1, 21), (3, 1e-5), (6, np.zeros(3)), (6, FakeCupy.zeros(3, np.int32)), (6, FakeCupy.zeros(6)[::2])):
        with pytest.raises(TypeError, match=f"argument {k_arg} "):
            k.marshal(good[:k_arg] + [bad] + good[k_arg + 1:])
    with pytest.raises(TypeError, match="arguments for"):
        k.marshal(good[:-1])


def test_an_emulated_gpu_sweep_gives_the_cpu_engine_s_results_table(tmp_path, emulated_gpu):
    """test_sweep_engines's gpu sweep (6 replicas of the 21-magnet experiment, friction on the
    rod) on the emulated kernels: the same table as --engine cpu, bit for bit."""
    from test_sweep_engines import ENSEMBLES, assert_same_table, sweep_in_process, write_sweep

    path = write_sweep(tmp_path, 6, ENSEMBLES["thermal with friction"])
    cpu_table = sweep_in_process(path, tmp_path / "cpu", "cpu")
    gpu_table = sweep_in_process(path, tmp_path / "gpu", "gpu")
    assert set(gpu_table["status"]) == {"done"} and emulated_gpu.launches
    disk = Outcomes(tmp_path / "gpu")
    assert {disk.get(i)["record"]["engine"] for i in gpu_table["id"]} == {"gpu"}
    assert_same_table(cpu_table, gpu_table, rtol=0)


def test_the_sine_drive_runs_on_the_host_s_path(tmp_path, monkeypatch, emulated_gpu):
    """The GPU's sin and cos are not glibc's to the last bit, so the sine drive's u, ud reach the
    kernel as the host build computed them (gpu.drive_path, Drive::path) for every step with t < T
    (T = 2.3 ms of a 10 ms run): they are the half-sine's to 1e-15, and the kernel reads
    them: a path of u 1e-9 off moves magnets 1 and 2 of every chain."""
    cases = members(impactor=DRIVES["sine"], friction=FRICTION)
    a = prepare(cases, "gpu")
    path = gpu.drive_path(a).reshape(-1, 2)
    t = np.arange(len(path)) * a.dt
    assert t[-1] > a.T and t[-2] <= a.T + a.dt and len(path) < a.steps  # every step before T, and no more
    inside = t < a.T
    np.testing.assert_allclose(path[inside, 1], a.V * np.sin(np.pi * t[inside] / a.T), rtol=0, atol=1e-15 * a.V)
    np.testing.assert_allclose(path[inside, 0], a.V * a.T / np.pi * (1 - np.cos(np.pi * t[inside] / a.T)), rtol=0,
                               atol=1e-15 * a.V * a.T)
    assert np.all(path[~inside] == [2 * a.V * a.T / np.pi, 0.0])
    assert gpu.drive_path(prepare(members(), "gpu")).size == 0  # a constant drive: no path
    assert library().pl_drive_path(4, 1.0, 1.0, 1e-3, 10, ptr(np.zeros(20))) == -1  # measured: refused
    (tmp_path / "true").mkdir(), (tmp_path / "off").mkdir()
    assert assert_same_outputs(run_both(cases, tmp_path / "true", monkeypatch))
    off = gpu.drive_path(a) * np.tile([1.0 + 1e-9, 1.0], len(path))
    monkeypatch.setattr(gpu, "drive_path", lambda _a: off)
    got = run_both(cases, tmp_path / "off", monkeypatch)
    assert (got["gpu"]["out"][0][:, 1:3] != got["cpu"]["out"][0][:, 1:3]).all()  # magnets 1 and 2 (the rest stuck)


def test_a_sweep_worker_s_warm_up_runs_one_chain_for_one_step_in_the_batch_s_module(emulated_gpu):
    """gpu.warm_up(gpu.warm_batch(case)), as a GPU sweep's worker runs it as it starts: one launch of
    the short chains' kernel, one chain, in the module that the batch of such members then uses."""
    cases = members(friction=FRICTION)
    gpu.warm_up(gpu.warm_batch(cases[0]))
    assert [(name, grid) for name, grid, _ in emulated_gpu.launches] == [("pl_run_short_chains_gpu", 1)]
    gpu.run_arrays(prepare(cases, "gpu"))
    assert len(emulated_gpu.modules) == 1  # the batch found its module loaded


def test_a_gpu_engine_called_again_after_a_failed_run_runs_its_batch_anew(tmp_path, monkeypatch, emulated_gpu):
    """The road's engine launches in start() and collects in its call: after a run that raised, the
    next call launches again (it got no results before), and a failed batch's results are refused."""
    cases = members(count=2)
    real, calls = gpu._run, []

    def fails_once(a):
        calls.append(a)
        if len(calls) == 1:
            yield
            raise RuntimeError("cudaErrorLaunchFailure")
        return (yield from real(a))

    monkeypatch.setattr(gpu, "_run", fails_once)
    engine = KernelEngine("gpu", cases)
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
    with pytest.raises(RuntimeError, match="cudaErrorLaunchFailure"):
        engine(tmp_path / "a")
    engine(tmp_path / "b")
    assert len(calls) == 2 and engine.final[0].shape == (2, 21) and np.isfinite(engine.final[0]).all()
    calls.clear()
    broken = gpu.launch(engine.arrays)  # a batch whose run raises: its results are refused after
    with pytest.raises(RuntimeError, match="cudaErrorLaunchFailure"):
        broken.result()
    with pytest.raises(RuntimeError, match="collected, or its run failed"):
        broken.result()
