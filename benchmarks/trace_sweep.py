"""Where a batched sweep's time goes, worker by worker: `pylmp-lattice sweep` of --members thermal
replicas (bench_sweep.py's sweep: the 21-magnet experiment with friction, 4800 steps) with a
trace in every process, for the GPU machine's one short run as for this one.

Each worker records each task it runs (`sweep.batch._run_task`: wall start and end, its CPU, its
members) and each kernel call in it (`engines.gpu.launch` and the wait for its results, or
`engines.cpu.run_arrays`: wall start and end, which on a shared GPU includes the wait behind the
other workers' launches); the
coordinator (the command itself) runs under cProfile. A sitecustomize.py on the path does both,
so the command runs as a user runs it. Printed: the timeline (when each worker was busy, in its
tasks and in the kernel), the totals, and the coordinator's costliest functions.

    python benchmarks/trace_sweep.py [--members 1000000] [--engine gpu] [--workers N] [--stand-in] [--out DIR]

--stand-in runs bench_gpu_road.py's stand-in for the GPU (the host build on 64 chains, their
results tiled): the road around the kernel on a machine without a device.
"""

from __future__ import annotations

import argparse
import json
import os
import pstats
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_gpu_road import SHIM as STAND_IN  # noqa: E402
from bench_sweep import ROOT, write_sweep  # noqa: E402

THERMAL = 0.02  # m/s RMS, as bench_gpu.py
TRACE = '''import atexit, functools, importlib.abc, importlib.util, json, os, sys, time
_DIR = os.environ["PYLMP_TRACE_DIR"]
if "PYLMP_TRACE_MAIN" not in os.environ:  # the command itself (its children inherit the mark)
    os.environ["PYLMP_TRACE_MAIN"] = str(os.getpid())
    import cProfile
    _profile = cProfile.Profile()
    _profile.enable()
    def _dump():
        _profile.disable()
        _profile.dump_stats(os.path.join(_DIR, "coordinator.prof"))
    atexit.register(_dump)
else:
    def _log(kind, start, end, **more):
        with open(os.path.join(_DIR, f"{os.getpid()}.jsonl"), "a") as out:
            out.write(json.dumps({"kind": kind, "pid": os.getpid(), "start": start, "end": end, **more}) + "\\n")
    def _timed(kind, fn, count):
        @functools.wraps(fn)
        def timed(*args, **kwargs):
            start, cpu = time.time(), time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                _log(kind, start, time.time(), cpu=time.process_time() - cpu, members=count(args))
        return timed
    def _launch_timed(kind, fn, count):  # gpu.launch: the launch and the wait for its results (Launched.result)
        launch = _timed(kind, fn, count)
        @functools.wraps(fn)
        def timed(a):
            got = launch(a)
            got.result = _timed(kind, got.result, lambda _: a.chains)
            return got
        return timed
    _PATCH = {"pylmp_lattice.sweep.batch": ("_run_task", "task", lambda a: len(a[0].each()), _timed),
              "pylmp_lattice.engines.gpu": ("launch", "kernel", lambda a: a[0].chains, _launch_timed),
              "pylmp_lattice.engines.cpu": ("run_arrays", "kernel", lambda a: a[0].chains, _timed)}
    class _Finder(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name not in _PATCH:
                return None
            for finder in sys.meta_path[sys.meta_path.index(self) + 1:]:
                spec = getattr(finder, "find_spec", lambda *a: None)(name, path, target)
                if spec is not None:
                    break
            else:
                return None
            load = spec.loader.exec_module
            def exec_module(module):
                load(module)
                attr, kind, count, wrap = _PATCH[name]
                setattr(module, attr, wrap(kind, getattr(module, attr), count))
            spec.loader.exec_module = exec_module
            return spec
    sys.meta_path.insert(0, _Finder())
'''


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--members", type=int, default=1_000_000)
    p.add_argument("--engine", choices=("gpu", "cpu", "lammps"), default="gpu")
    p.add_argument("--workers", type=int, default=None, help="the sweep's --workers (default: one per core)")
    p.add_argument("--stand-in", action="store_true", help="the GPU stood in for by the host build (no device)")
    p.add_argument("--out", type=Path, default=None, help="keep the trace and the profile here")
    p.add_argument("--top", type=int, default=25, help="the coordinator's functions shown")
    args = p.parse_args()
    with tempfile.TemporaryDirectory(prefix=".trace_sweep.") as tmp:
        tmp = Path(tmp)
        trace = args.out or tmp / "trace"
        trace.mkdir(parents=True, exist_ok=True)
        shim = tmp / "shim"
        shim.mkdir()
        (shim / "sitecustomize.py").write_text((STAND_IN if args.stand_in else "") + TRACE)
        sweep = write_sweep(tmp, args.members, THERMAL, friction=True)
        env = os.environ | {"PYTHONPATH": os.pathsep.join([str(ROOT), str(shim), os.environ.get("PYTHONPATH", "")]),
                            "PYLMP_TRACE_DIR": str(trace), "BENCH_GPU_ROAD_TILE": "64"}
        cmd = [sys.executable, "-m", "pylmp_lattice.cli", "sweep", str(sweep), "-o", str(tmp / "out"), "--engine",
               args.engine, "--yes", *(["--workers", str(args.workers)] if args.workers else [])]
        start = time.time()
        done = subprocess.run(cmd, cwd=tmp, env=env, capture_output=True, text=True)
        wall = time.time() - start
        if done.returncode:
            raise SystemExit(f"sweep failed ({done.returncode}): {done.stderr[-3000:]}")
        said = [line for line in done.stderr.splitlines() if "since the command started" in line]
        events = [json.loads(line) for f in trace.glob("*.jsonl") for line in f.read_text().splitlines()]
        report(args, wall, said, events, pstats.Stats(str(trace / "coordinator.prof")))


def report(args, wall: float, said: list[str], events: list[dict], coordinator: pstats.Stats) -> None:
    t0 = min(e["start"] for e in events)
    tasks = sorted((e for e in events if e["kind"] == "task"), key=lambda e: e["start"])
    kernels = [e for e in events if e["kind"] == "kernel"]
    workers = sorted({e["pid"] for e in tasks})
    print(f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {os.cpu_count()} cores; {args.members} members, engine "
          f"{args.engine}{' (stood in for)' if args.stand_in else ''}, {len(workers)} workers; command to exit "
          f"{wall:.2f} s")
    for line in said:
        print(line.split("info: ", 1)[-1])
    print("\n| worker | task | members | start (s) | task wall (s) | task CPU (s) | kernel call wall (s) | CPU ms a member |")
    print("|---|---|---|---|---|---|---|---|")
    for w, pid in enumerate(workers):
        for k, e in enumerate(t for t in tasks if t["pid"] == pid):
            inside = [q for q in kernels if q["pid"] == pid and e["start"] <= q["start"] <= e["end"]]
            print(f"| {w} | {k} | {e['members']} | {e['start'] - t0:.2f} | {e['end'] - e['start']:.2f} | {e['cpu']:.2f} | "
                  f"{sum(q['end'] - q['start'] for q in inside):.2f} | {1e3 * e['cpu'] / max(e['members'], 1):.3f} |")
    members = sum(e["members"] for e in tasks)
    cpu = sum(e["cpu"] for e in tasks)
    print(f"\ntasks: {len(tasks)}, {members} members; the workers' task CPU {cpu:.1f} s ({1e3 * cpu / members:.3f} ms a "
          f"member); first task started {tasks[0]['start'] - t0:.2f} s, last ended {max(e['end'] for e in tasks) - t0:.2f} s "
          f"after the first trace; kernel calls {len(kernels)}, their wall {sum(q['end'] - q['start'] for q in kernels):.2f} s "
          f"in all, their CPU {sum(q['cpu'] for q in kernels):.2f} s")
    print(f"\nthe coordinator's costliest functions (cProfile, cumulative; {coordinator.total_tt:.2f} s profiled):")
    coordinator.sort_stats("cumulative").print_stats(args.top)


if __name__ == "__main__":
    main()
