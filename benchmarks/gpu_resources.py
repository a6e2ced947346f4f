"""What each GPU kernel keeps per thread, without a device: NVRTC (the nvidia-cuda-nvrtc wheel)
compiles engine_gpu.cu to sm_90 machine code with the GPU engine's own options
(engines.gpu.compile_options) and ptxas's report (-Xptxas=-v): registers per thread, stack frame
(local memory per thread), spill bytes and shared memory per block. From these, on an H100/H200
(132 SMs, each with 65536 registers and at most 2048 threads and 228 KB of shared memory; the
engine's blocks, gpu.block_threads): the threads resident per SM, and the local memory all
resident threads hold, beside the 50 MB of L2. The stack frame is
split into the front record's rows (N x NCOL doubles, touched only for the few atoms between
their start and both peaks) and the rest (the per-step state that did not fit in registers).
With nvdisasm (the nvidia-cuda-nvdisasm wheel, on PATH, or --nvdisasm PATH) also the local loads
and stores (LDL/STL) in the machine code of the kernel's largest loop, its time step, and the
loops inside it: with none inside, each LDL/STL runs at most once a step.

Cases: the paper's experiment (power law q = 3, friction, front record) for chains of one mass (the
thermal ensembles) and of per-atom masses (disorder), and the same law without friction or record;
chains of --particles magnets (over 64: the long chains' kernel, a block per chain, its blocks of
gpu.long_threads threads, its record rows in global memory). --reference REV adds the same rows
for the short chains' kernel of a git revision (its folder plugin/kernel at REV, its local arrays
32 or 64 long, as ece083f rounded n), compiled with this tree's options: the old and the new
kernel side by side.

    python benchmarks/gpu_resources.py [--particles 21,40,64] [--reference ece083f]
    python benchmarks/gpu_resources.py --particles 21 --blocks 4,8,10,19   # the short chains' block
    python benchmarks/gpu_resources.py --particles 100,1000,10000          # the long chains' kernel
    python benchmarks/gpu_resources.py --particles 21 --row-copy           # gpu.ROW_COPY's variant

Exit 2 with one line where NVRTC is not installed (nvdisasm is optional: '-' without it).
"""

from __future__ import annotations

import argparse
import importlib.util
import io
import math
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pylmp_lattice.engines import gpu, nvrtc  # noqa: E402
from pylmp_lattice.engines.library import layout  # noqa: E402

ARCH = "sm_90"  # H100 and H200
SMS, REGISTERS_PER_SM, THREADS_PER_SM, BLOCKS_PER_SM, L2_MB = 132, 65536, 2048, 32, 50
SHARED_PER_SM, SHARED_RESERVED = 228 * 1024, 1024  # bytes; the driver's reserve per block
# (law kind, q, friction, record) and one mass (the thermal ensembles) or per-atom masses (disorder)
CASES = {"q=3, friction, record, one mass": ((0, 3.0, True, True), True),
         "q=3, friction, record, per-atom masses": ((0, 3.0, True, True), False),
         "q=3, neither, one mass": ((0, 3.0, False, False), True)}


@dataclass
class Resources:
    registers: int
    stack: int  # bytes per thread (the entry's stack frame)
    spill_stores: int
    spill_loads: int
    step_local: str = "-"  # the time step's LDL/STL (nvdisasm)
    shared: int = 0  # bytes of shared memory per block

    def threads_per_sm(self, threads: int) -> int:
        """Resident threads per SM for blocks of `threads` (registers allocated per warp, in 256s;
        shared memory per block)."""
        per_warp = math.ceil(self.registers * 32 / 256) * 256
        warps = REGISTERS_PER_SM // per_warp
        by_shared = SHARED_PER_SM // (self.shared + SHARED_RESERVED) if self.shared else BLOCKS_PER_SM
        blocks = min(warps // math.ceil(threads / 32), BLOCKS_PER_SM, THREADS_PER_SM // threads, by_shared)
        return blocks * threads


def entry_report(log: str, entry: str) -> tuple[int, int, int, int]:
    """ptxas's registers, stack frame, spill stores and loads of the entry `entry`."""
    m = re.search(rf"Function properties for {entry}\n[^\n]*?(\d+) bytes stack frame, (\d+) bytes spill stores, "
                  rf"(\d+) bytes spill loads\n[^\n]*?Used (\d+) registers", log)
    if not m:
        raise RuntimeError(f"no ptxas report for {entry} in NVRTC's log:\n{log}")
    stack, stores, loads, registers = map(int, m.groups())
    return registers, stack, stores, loads


def step_local(sass: str, entry: str) -> str:
    """LDL/STL instructions (their bytes) in the largest loop of `entry`'s machine code, and how
    many loops it holds."""
    body = sass.split(f".text.{entry}:", 1)[1].split(".section", 1)[0]
    labels, branches, local, pending = {}, [], [], []
    for line in body.splitlines():
        if re.match(r"^\.L_x_\d+:", line):
            pending.append(line[:-1])
            continue
        m = re.match(r"\s*/\*([0-9a-f]{4,})\*/\s+(.*)", line)
        if not m:
            continue
        addr, text = int(m.group(1), 16), m.group(2)
        labels |= dict.fromkeys(pending, addr)
        pending = []
        if b := re.search(r"\bBRA\b.*`\((\.L_x_\d+)\)", text):
            branches.append((addr, b.group(1)))
        if op := re.search(r"\b(?:LDL|STL)(\.\w+)?\b", text):
            local.append((addr, {".U8": 1, ".S8": 1, ".U16": 2, ".S16": 2, ".64": 8, ".128": 16}.get(op.group(1), 4)))
    loops = {(labels[t], addr) for addr, t in branches if t in labels and labels[t] <= addr}
    if not loops:
        return "no loop"
    lo, hi = max(loops, key=lambda span: span[1] - span[0])
    inner = sum(1 for a, b in loops if lo <= a and b <= hi and (a, b) != (lo, hi))
    inside = [size for addr, size in local if lo <= addr <= hi]
    return f"{len(inside)} ({sum(inside)} B); {inner} loops in it"


def find_nvdisasm(given: str | None) -> str | None:
    """nvdisasm: `given`, on PATH, or in the nvidia-cuda-nvdisasm wheel."""
    if given or shutil.which("nvdisasm"):
        return given or shutil.which("nvdisasm")
    spec = importlib.util.find_spec("nvidia")
    for root in (spec.submodule_search_locations if spec else []):
        for path in Path(root).glob("*/bin/nvdisasm"):
            return str(path)
    return None


def measure(kernel: Path, options: tuple[str, ...], entry: str, nvdisasm: str | None = None) -> Resources:
    got = nvrtc.compile_kernel(kernel / "engine_gpu.cu", (*options, f"-arch={ARCH}", "-Xptxas=-v"))
    if got.rc != 0:
        raise RuntimeError(f"NVRTC failed ({got.rc}) with {options}:\n{got.log[-3000:]}")
    registers, stack, stores, loads = entry_report(got.log, entry)
    shared = re.search(rf"Function properties for {entry}\n[^\n]*\n[^\n]*?(\d+) bytes smem", got.log)
    step = "-"
    if nvdisasm:
        with tempfile.NamedTemporaryFile(suffix=".cubin") as f:
            f.write(got.code)
            f.flush()
            step = step_local(subprocess.run([nvdisasm, f.name], capture_output=True, text=True, check=True).stdout,
                              entry)
    return Resources(registers, stack, stores, loads, step, int(shared.group(1)) if shared else 0)


def reference_kernel(rev: str, into: Path) -> Path:
    """plugin/kernel of git revision `rev`, extracted into `into`."""
    folder = "pylmp_lattice/plugin/kernel"
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, folder], capture_output=True, check=True).stdout
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(into, filter="data")
    return into / folder


def with_kernel(options: tuple[str, ...], kernel: Path, local: int) -> tuple[str, ...]:
    """`options` for the kernel folder `kernel` with local arrays `local` long."""
    out = []
    for o in options:
        o = f"-I{kernel}" if o.startswith("-I") else o
        o = f"-DPL_LOCAL_N={local}" if o.startswith("-DPL_LOCAL_N=") else o
        out.append(o)
    return tuple(out)


def row(label: str, n: int, local: int, block: int | str, record: bool, r: Resources, threads: int) -> str:
    per_sm = r.threads_per_sm(threads)
    resident = per_sm * SMS
    rows = local * layout().ncol * 8 if record else 0  # the record's rows (engine_gpu.cu's rec)
    rest = r.stack - rows
    mb = lambda b: f"{resident * b / 1e6:.0f} MB ({resident * b / 1e6 / L2_MB:.1f}x L2)"  # noqa: E731
    full = SMS * THREADS_PER_SM * r.stack / 1e9
    return (f"| {label} | {n} | {local} | {block} | {r.registers} | {r.stack} | {rows} | {rest} | "
            f"{r.spill_stores} / {r.spill_loads} | {r.step_local} | {r.shared} B x {threads} | {per_sm} | {resident} | "
            f"{mb(r.stack)} | {mb(rest)} | {full:.2f} GB |")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--particles", default="21", help="chain lengths, comma separated (3-64: the short chains' kernel; "
                                                     "longer: the long chains')")
    p.add_argument("--blocks", default="", help="PL_BLOCK values to try (default: the engine's, gpu.short_block "
                                                "or gpu.long_segment)")
    p.add_argument("--nvdisasm", help="nvdisasm's path (else PATH, then the nvidia-cuda-nvdisasm wheel)")
    p.add_argument("--reference", help="a git revision whose kernel gets the same rows (e.g. ece083f)")
    p.add_argument("--row-copy", action="store_true", help="with gpu.ROW_COPY: each due row of the record copied "
                                                           "whole into registers for its sampling")
    args = p.parse_args()
    gpu.ROW_COPY = args.row_copy or gpu.ROW_COPY
    if nvrtc.load() is None:
        print("gpu_resources: NVIDIA's NVRTC is not installed (pip install nvidia-cuda-nvrtc)", file=sys.stderr)
        raise SystemExit(2)
    try:
        sizes = [int(n) for n in args.particles.split(",") if n]
        blocks = [int(b) for b in args.blocks.split(",") if b]
    except ValueError:
        print(f"gpu_resources: --particles and --blocks take integers, not {args.particles!r}, {args.blocks!r}",
              file=sys.stderr)
        raise SystemExit(2) from None
    if not sizes or any(n < 3 for n in sizes) or any(b < 1 for b in blocks):
        print("gpu_resources: --particles >= 3, --blocks >= 1", file=sys.stderr)
        raise SystemExit(2)
    nvdisasm = find_nvdisasm(args.nvdisasm)
    if args.nvdisasm and not Path(args.nvdisasm).is_file():
        print(f"gpu_resources: --nvdisasm {args.nvdisasm} is not a file", file=sys.stderr)
        raise SystemExit(2)
    with tempfile.TemporaryDirectory() as tmp:
        try:
            ref = reference_kernel(args.reference, Path(tmp)) if args.reference else None
        except subprocess.CalledProcessError as err:
            why = err.stderr.decode(errors="replace").strip().splitlines()
            print(f"gpu_resources: --reference {args.reference}: git archive failed: {why[-1] if why else err}",
                  file=sys.stderr)
            raise SystemExit(2) from None
        print(f"NVRTC {ARCH}, ptxas -v; {SMS} SMs x {REGISTERS_PER_SM} registers, blocks of {gpu.THREADS} threads"
              f"{'; the short-chain kernel with its due rows copied whole (ROW_COPY; not --reference)' if gpu.ROW_COPY else ''}")
        print("| kernel, case | magnets | PL_LOCAL_N | block | registers | stack frame (B/thread) | of it record rows | "
              "the rest | spill stores / loads (B) | the step's LDL/STL (static) | shared memory per block | threads/SM | "
              "resident threads | their stack | their rest | stack at 2048 threads/SM |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for name, (case, one_mass) in CASES.items():
            for n in sizes:
                local = gpu.local_size(n)
                entry = "pl_run_short_chains_gpu" if local else "pl_run_long_chains_gpu"
                if ref is not None and local:
                    old_local = 32 if n <= 32 else 64
                    options = with_kernel(gpu.compile_options(local, case, one_mass=one_mass), ref, old_local)
                    print(row(f"{args.reference}, {name}", n, old_local, "at run time", case[3],
                              measure(ref, options, entry, nvdisasm), gpu.THREADS), flush=True)
                for block in blocks or [gpu.short_block(local) if local else gpu.long_segment(n)]:
                    r = measure(gpu.KERNEL, gpu.compile_options(n, case, block, one_mass), entry, nvdisasm)
                    threads = gpu.block_threads(local) if local else gpu.long_threads(n)
                    print(row(f"this tree, {name}", n, local, block, case[3], r, threads), flush=True)
    print("threads/SM: by registers and shared memory (blocks of gpu.block_threads); their stack: resident threads x stack frame, the local memory "
          f"they hold at once, against the {L2_MB} MB of L2 (H100: 50 MB, H200: 60 MB); their rest: the same without "
          "the record's rows; at 2048 threads/SM: the stack if registers did not limit the threads resident; the "
          "step's LDL/STL: in the machine code of the kernel's largest loop (nvdisasm; '-' without it), run at most "
          "once a step where no loop is in it.")


if __name__ == "__main__":
    main()
