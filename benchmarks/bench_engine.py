"""Engine benchmark: atom-steps per second on the paper's chain, as ratios to a plain C loop.

The chain: N magnets, F = K/(r+b)^3 (K = 413.8 N mm^3, b = 3.917 mm), m = 1.084 g, r0 = 12 mm,
magnet 1 pushed at a constant 2 m/s, magnet N held, dt = 0.01 ms. Ways of integrating it:
- "C loop": benchmarks/chain_loop.c, velocity Verlet, compiled here with gcc -O3; it times its
  own loop and writes its final velocities, against which every other row is compared; the
  ratios are to it. Where the CPU has AVX2 a second row builds the same loop with -mavx2
  -mno-fma (the vectors the chain fix's AVX2 copy uses, no fused multiply-add): like for like
  with the plugin on such a machine;
- "LAMMPS default" / "LAMMPS stock": the package's path, case_from_dict ->
  runner.write_run_folder -> runner.run_executable (`lmp`), with `[run] engine` left at its
  default, and with engine = "stock" once the package has that field (detected, not assumed);
  both as the package writes the deck, so with the per-step front record (`[output] front`,
  on by default); one more row shows the default path without the record.
  The time is LAMMPS's own Loop time minus its Output section (from log.lammps): start-up,
  reading the data file, the one dump frame at the end and the thermo lines are excluded;
  the output interval is the run's duration, so that frame is the only one;
- "numpy": the same velocity Verlet, vectorised (whole-array operations, no Python loop over
  magnets);
- "scipy DOP853": solve_ivp on the same equations, at the loosest tolerance (rtol = atol, a
  power of 10, in mm and m/s) whose final-velocity error is no larger than velocity Verlet's at
  dt = 0.01 ms, both measured against DOP853 at 1e-13 on the same run (chosen for every size
  before timing it; both errors are printed). It runs only up to --scipy-max-n magnets and
  --scipy-max-steps steps' worth of time (marked in the table); its atom-steps are N times the
  number of dt = 0.01 ms steps in the time it integrated.
Each size runs each way --repeat times, interleaved (these machines are shared and noisy); the
table shows the best. The run time at size N is --atom-steps / N steps, at least --min-steps
(a package deck prints thermo 20 times a run and the default path then writes its state back
to LAMMPS's arrays, so a run of 100 steps would measure mostly that), but never so long that
the front (bounded by V0 + 2 V_I) reaches the held end; max |v - v_C| is over all magnets at
the end. Then: the accuracy check of issue 7 (default path against the C loop, N = 10^4 after
10^4 steps; required <= 1e-9 m/s) and a small ensemble of 21-magnet replicas, one LAMMPS instance each (write_run_folder +
run_embedded, wall time with start-up, extrapolated per replica), against batched replicas
when the package has them. MPI ranks: benchmarks/bench_mpi.py.

    python benchmarks/bench_engine.py            # the full table (about 10 minutes)
    python benchmarks/bench_engine.py --quick    # sizes up to 10^4, about a minute
"""

from __future__ import annotations

import argparse
import math
import os
import re
import subprocess
import tempfile
import time
from dataclasses import dataclass, fields
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from pylmp_lattice import run_folder as simulation, runner
from pylmp_lattice.case import RunSettings, case_from_dict
from pylmp_lattice.forcelaw import PowerLaw
from pylmp_lattice.measures import linear_wave_speed
from pylmp_lattice.units import to_engine

# The paper's chain, user units (mm, g, ms, N, m/s)
K, B, Q, MASS, R0, V_I, DT = 413.8, 3.917, 3.0, 1.084, 12.0, 2.0, 0.01
C_SOURCE = Path(__file__).with_name("chain_loop.c")
CHECK_TOLERANCE = 1e-9  # m/s, issue 7: default path against the C loop


# ----------------------------------------------------------------------------- the chain

def front_limited_steps(n: int) -> int:
    """Steps before the front, at most V0 + 2 V_I fast (case.long_lattice_particles), reaches magnet N."""
    v0 = linear_wave_speed(float(PowerLaw(K, B, Q).stiffness(R0)), MASS, R0)
    return int((n - 1) * R0 / (v0 + 2 * V_I) / DT)


def has_engine_field() -> bool:
    return "engine" in {f.name for f in fields(RunSettings)}


def paper_case(n: int, steps: int, variant: dict | None = None):
    """The benchmark chain as a package case, everything else at the package's defaults (so the
    per-step front record is on); `variant` adds sections' fields."""
    duration = round(steps * DT, 10)
    data = {
        "name": f"bench_{n}",
        "chain": {"mass": MASS, "r0": R0, "particles": n, "far_end": "fixed"},
        "force": {"law": "power", "K": K, "b": B, "q": Q},
        "impactor": {"profile": "constant", "velocity": V_I},
        "run": {"duration": duration, "dt": DT, "output_interval": duration},
    }
    for section, values in (variant or {}).items():
        data[section] = data.get(section, {}) | values
    return case_from_dict(data)


# ----------------------------------------------------------------------------- the ways

@dataclass
class Took:
    """One timed run. On this shared machine a process waits for a core for much of its wall
    time, so CPU time is the steadier measure of the work; both are kept."""

    wall: float  # s
    cpu: float  # s
    result: object  # final velocities (m/s); for LAMMPS the Output share of the Loop time


class Stopwatch:
    def __init__(self):
        self.wall, self.cpu = time.perf_counter(), time.process_time()

    def took(self, result) -> Took:
        return Took(time.perf_counter() - self.wall, time.process_time() - self.cpu, result)


def lammps_times(folder: Path) -> tuple[float, float, float]:
    """(Loop time s, its Output section s, CPU use fraction), from the folder's log.lammps
    (averages over ranks)."""
    text = (folder / "log.lammps").read_text()
    loop = re.search(r"^Loop time of (\S+) on", text, re.MULTILINE)
    cpu = re.search(r"^(\S+)% CPU use with", text, re.MULTILINE)
    output = re.search(r"^Output\s*\|[^|]*\|\s*(\S+)\s*\|", text, re.MULTILINE)
    if not (loop and cpu and output):
        raise RuntimeError(f"{folder}/log.lammps: no Loop time or timing breakdown")
    return float(loop.group(1)), float(output.group(1)), float(cpu.group(1)) / 100


# LAMMPS's CPU share comes from getrusage, which counts in scheduler ticks (4 ms here)
MIN_LOOP_FOR_CPU = 0.2  # s


def run_lammps(folder: Path, nprocs: int = 1) -> Took:
    """Run the folder's deck with `lmp`: the engine's time (Loop - Output; its CPU time as the
    Loop's CPU share of it, NaN for loops too short to tell) and the Output share of the Loop."""
    runner.run_executable(folder, nprocs=nprocs)
    loop, output, cpu_share = lammps_times(folder)
    cpu = (loop - output) * cpu_share if loop >= MIN_LOOP_FOR_CPU else math.nan
    return Took(loop - output, cpu, output / loop)


def build_c_loop(folder: Path, flags: tuple[str, ...] = ()) -> Path:
    exe = folder / ("chain_loop" + "".join(flags).replace("-", "_"))
    subprocess.run(["gcc", "-O3", *flags, "-o", str(exe), str(C_SOURCE)], check=True)
    return exe


def has_avx2() -> bool:
    """Whether this CPU has AVX2 (Linux's /proc/cpuinfo; False elsewhere)."""
    try:
        return " avx2" in Path("/proc/cpuinfo").read_text()
    except OSError:
        return False


def run_c_loop(exe: Path, n: int, steps: int) -> Took:
    """The C loop's own timing of its loop, and its final velocities (m/s); SI units like the deck."""
    out = exe.with_name(f"v_{n}.bin")
    args = [n, steps, to_engine(DT, "time"), K * to_engine(1.0, "length") ** 3, to_engine(B, "length"),
            to_engine(MASS, "mass"), to_engine(R0, "length"), V_I, out]
    done = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True, check=True)
    wall, cpu = map(float, done.stdout.split())
    return Took(wall, cpu, np.fromfile(out))


def run_numpy(n: int, steps: int) -> Took:
    """Velocity Verlet with whole-array numpy operations, user units (mm, ms, g, N; v in m/s).

    N/g is mm/ms^2, so a = F/m needs no factor. The same operations in the same order as
    the C loop, so the two agree to rounding.
    """
    x = R0 * np.arange(n, dtype=float)
    v = np.zeros(n)
    v[0] = V_I
    s, F, tmp = np.empty(n - 1), np.empty(n - 1), np.empty(n - 2)
    x_free, v_free = x[1:-1], v[1:-1]
    half = 0.5 * DT / MASS

    def gap_forces():  # F = F(r_i) on every gap
        np.subtract(x[1:], x[:-1], out=s)
        np.add(s, B, out=s)
        np.multiply(s, s, out=F)
        np.multiply(F, s, out=F)
        np.divide(K, F, out=F)

    def kick():  # v += dt/2m (F(r_(i-1)) - F(r_i)) on the free magnets
        np.subtract(F[:-1], F[1:], out=tmp)
        np.multiply(tmp, half, out=tmp)
        np.add(v_free, tmp, out=v_free)

    gap_forces()
    clock = Stopwatch()
    for step in range(1, steps + 1):
        kick()
        np.multiply(v_free, DT, out=tmp)
        np.add(x_free, tmp, out=x_free)
        x[0] = V_I * (step * DT)
        gap_forces()
        kick()
    return clock.took(v)


def run_dop853(n: int, steps: int, tol: float) -> Took:
    """solve_ivp DOP853 over steps * dt, rtol = atol = tol; its final velocities (m/s)."""
    held = (n - 1) * R0
    x = np.empty(n)
    x[-1] = held

    def rhs(t, y):
        x[0], x[1:-1] = V_I * t, y[: n - 2]
        F = K / (np.diff(x) + B) ** 3
        return np.concatenate([y[n - 2 :], (F[:-1] - F[1:]) / MASS])

    y0 = np.concatenate([R0 * np.arange(1, n - 1), np.zeros(n - 2)])
    clock = Stopwatch()
    sol = solve_ivp(rhs, (0.0, steps * DT), y0, method="DOP853", rtol=tol, atol=tol)
    took = clock.took(np.concatenate([[V_I], sol.y[n - 2 :, -1], [0.0]]))
    if not sol.success:
        raise RuntimeError(f"solve_ivp failed: {sol.message}")
    return took


def choose_dop853_tolerance(exe: Path, n: int, steps: int) -> tuple[float, float, float]:
    """The loosest rtol = atol = 10^-k whose final velocities are as accurate as velocity Verlet's.

    Both against DOP853 at 1e-13 over the same run (n magnets, steps * dt). The error depends
    on the run's length (a tolerance that matches Verlet over 43 ms is 40x worse over 100 ms),
    so every size is calibrated on its own run. Returns (tol, its error, Verlet's error), m/s.
    """
    reference = run_dop853(n, steps, 1e-13).result
    verlet_error = float(np.max(np.abs(run_c_loop(exe, n, steps).result - reference)))
    for k in range(3, 13):
        error = float(np.max(np.abs(run_dop853(n, steps, 10.0**-k).result - reference)))
        if error <= verlet_error:
            return 10.0**-k, error, verlet_error
    raise RuntimeError("no DOP853 tolerance down to 1e-12 is as accurate as velocity Verlet")


# ----------------------------------------------------------------------------- the table

@dataclass
class Row:
    """One way at one size: the best times of the repeats and the final velocities."""

    way: str
    steps: int  # dt steps integrated; 0: not run
    wall: float = math.inf  # s, best of the repeats
    cpu: float = math.inf  # s, best of the repeats
    v: np.ndarray | None = None  # m/s, final velocities
    dv: float | None = None  # m/s, max |v - v_C| over the magnets (C loop over the same time)
    note: str = ""


class Bench:
    def __init__(self, args, tmp: Path):
        self.args, self.tmp = args, tmp
        self.exe = build_c_loop(tmp)
        self.exe_avx2 = build_c_loop(tmp, ("-mavx2", "-mno-fma")) if has_avx2() else None
        # the deck as the package writes it (`[run] engine` and `[output] front` at their
        # defaults); the default without the per-step front record; the stock path where the
        # package has one
        self.variants = {"default": {}, "no_front": {"output": {"front": False}}}
        self.variants |= {"stock": {"run": {"engine": "stock"}}} if has_engine_field() else {}
        self.default_engine = getattr(paper_case(21, 1).run, "engine", None)
        self.checked: dict[tuple[int, int], float] = {}  # (N, steps) -> max |v_default - v_C|

    def steps_for(self, n: int) -> int:
        steps = max(int(self.args.atom_steps // n), self.args.min_steps)
        return max(1, min(steps, self.args.max_steps, front_limited_steps(n)))

    def label(self, name: str) -> str:
        if name == "stock":
            return "LAMMPS stock (engine = stock)"
        if name == "no_front":
            return "LAMMPS default without front record"
        if self.default_engine is None:
            return "LAMMPS default (stock; no [run] engine yet)"
        return f"LAMMPS default ({self.default_engine} engine, front record)"

    def size(self, n: int) -> list[Row]:
        """Every way at chain size n, interleaved over the repeats."""
        steps = self.steps_for(n)
        rows = {"C": Row("C loop (gcc -O3)", steps), "numpy": Row("numpy velocity Verlet", steps)}
        ways = {"C": lambda: run_c_loop(self.exe, n, steps), "numpy": lambda: run_numpy(n, steps)}
        if self.exe_avx2 is not None:
            rows["C_avx2"] = Row("C loop (gcc -O3 -mavx2 -mno-fma)", steps)
            ways["C_avx2"] = lambda: run_c_loop(self.exe_avx2, n, steps)
        folders = {}
        for name, variant in self.variants.items():
            folders[name] = simulation.RunFolder.create(paper_case(n, steps, variant), self.tmp / f"{name}_{n}").path
            rows[name] = Row(self.label(name), steps)
            ways[name] = lambda folder=folders[name]: run_lammps(folder)
        scipy = Row("scipy DOP853", min(steps, self.args.scipy_max_steps))
        if n > self.args.scipy_max_n:
            scipy.steps, scipy.note = 0, f"not run: N > {self.args.scipy_max_n}"
        else:
            tol, error, verlet_error = choose_dop853_tolerance(self.exe, n, scipy.steps)
            scipy.way += f" (tol {tol:.0e})"
            scipy.note = f"error {error:.1e}, Verlet's {verlet_error:.1e} m/s"
            if scipy.steps < steps:
                scipy.note += f"; capped at {scipy.steps} steps' time (|v-v_C| over that time)"
            rows["scipy"] = scipy
            ways["scipy"] = lambda: run_dop853(n, scipy.steps, tol)
        for _ in range(self.args.repeat):
            for key, way in ways.items():
                took, row = way(), rows[key]
                if took.wall < row.wall and key in folders:  # result: the Output share of the Loop
                    row.note = f"output {took.result:.0%} of Loop excluded"
                row.wall = min(row.wall, took.wall)
                row.cpu = row.cpu if math.isnan(took.cpu) else min(row.cpu, took.cpu)
                if key not in folders:
                    row.v = took.result
        for name, folder in folders.items():
            rows[name].v = simulation.RunFolder(folder).trajectory().v[-1]
        c = rows.pop("C")
        for row in rows.values():
            # a capped DOP853 run is compared with the C loop over the same time
            ref = c.v if row.steps == steps else run_c_loop(self.exe, n, row.steps).result
            row.dv = float(np.max(np.abs(row.v - ref)))
        self.checked[n, steps] = rows["default"].dv
        return [c, *rows.values()] + ([] if scipy.steps else [scipy])

    def check(self, n: int, steps: int) -> float:
        """max |v_default - v_C| after `steps` steps at size n, m/s (from the table if it ran this)."""
        if (n, steps) not in self.checked:
            case = paper_case(n, steps)
            folder = runner.run_executable(simulation.RunFolder.create(case, self.tmp / "check").path)
            v = simulation.RunFolder(folder).trajectory().v[-1]
            self.checked[n, steps] = float(np.max(np.abs(v - run_c_loop(self.exe, n, steps).result)))
        return self.checked[n, steps]


HEADER = (f"{'N':>8} {'way':<44} {'steps':>6} {'wall [s]':>9} {'atom-st/s':>10} {'x C':>6} "
          f"{'CPU [s]':>9} {'x C':>6} {'|v-v_C|':>8}  note")


def print_size(n: int, rows: list[Row]) -> None:
    """Throughput from wall and from CPU time, each as a ratio to the C loop's."""
    c = rows[0]
    for row in rows:
        if not row.steps:
            print(f"{n:>8} {row.way:<44} {'-':>6} {'-':>9} {'-':>10} {'-':>6} {'-':>9} {'-':>6} {'-':>8}  {row.note}")
            continue
        rate = n * row.steps / row.wall
        x_wall = (c.wall / c.steps) / (row.wall / row.steps)
        cpu, x_cpu = "-", "-"
        if row.cpu < math.inf:
            cpu, x_cpu = f"{row.cpu:.4g}", f"{(c.cpu / c.steps) / (row.cpu / row.steps):.3f}"
        dv = "-" if row.dv is None else f"{row.dv:.1e}"
        print(f"{n:>8} {row.way:<44} {row.steps:>6} {row.wall:>9.4g} {rate:>10.3g} {x_wall:>6.3f} "
              f"{cpu:>9} {x_cpu:>6} {dv:>8}  {row.note}")


def replica_rows(bench: Bench) -> None:
    """21-magnet replicas: one LAMMPS instance each (simulation.simulate; a sample, extrapolated)
    against all of them in one instance (simulation.execute_batch, when the package has it).

    Both timed whole: writing the folder, start-up, the run and reading the trajectories back."""
    n, count, sample = 21, bench.args.replicas, bench.args.replica_sample
    steps = front_limited_steps(n)
    case = paper_case(n, steps)
    execute_batch = getattr(simulation, "execute_batch", None)
    final = {}  # final velocities of the last repeat: (replicas, N)

    def one_by_one(repeat):  # fresh folders, as an ensemble's members have
        final["one"] = np.array([simulation.simulate(case, bench.tmp / f"replica_{repeat}_{i}").v[-1]
                                 for i in range(sample)])
        return sample

    def batched(repeat):
        trajectories = execute_batch([case] * count, bench.tmp / f"replicas_{repeat}").replicas()
        final["batched"] = np.array([t.v[-1] for t in trajectories])
        return count

    ways = {"one": one_by_one} | ({"batched": batched} if execute_batch else {})
    wall, cpu = dict.fromkeys(ways, math.inf), dict.fromkeys(ways, math.inf)
    for repeat in range(bench.args.repeat):
        for key, way in ways.items():
            clock = Stopwatch()
            took = clock.took(way(repeat))  # result: the members run
            wall[key] = min(wall[key], took.wall / took.result)
            cpu[key] = min(cpu[key], took.cpu / took.result)
    print(f"\nReplicas: {count} chains of {n} magnets, {steps} steps each; writing, start-up and reading back included")
    print(f"{'way':<52} {'wall/replica':>12} {f'wall, {count}':>11} {'speed-up':>9} {'CPU/replica':>12} {'speed-up':>9}")
    labels = {"one": f"one LAMMPS instance each (simulate; {sample} timed)",
              "batched": f"batched: {count} in one instance (execute_batch)"}
    for key in ways:
        print(f"{labels[key]:<52} {wall[key]:>12.4g} {wall[key] * count:>11.4g} {wall['one'] / wall[key]:>9.1f} "
              f"{cpu[key]:>12.4g} {cpu['one'] / cpu[key]:>9.1f}")
    if execute_batch:
        diff = np.max(np.abs(final["batched"] - final["one"][0]))
        print(f"max |v(batched replica) - v(one instance)| = {diff:.1e} m/s over all replicas "
              "(the batched run is read from a text dump of 12 significant digits)")
    else:
        print(f"{labels['batched']:<52} {'-':>12} {'-':>11} {'-':>9} {'-':>12} {'-':>9}  "
              "not yet available: the package has no batched-replica path")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="sizes up to 10^4, 1e7 atom-steps, 2 repeats, MPI at 10^5")
    parser.add_argument("--sizes", type=int, nargs="+", help="chain sizes N (default 21 1000 10000 100000 1000000)")
    parser.add_argument("--atom-steps", type=float, help="work per run, N x steps (default 1e8)")
    parser.add_argument("--min-steps", type=int, default=1000, help="at least this many steps per run (default 1000)")
    parser.add_argument("--max-steps", type=int, default=100_000, help="at most this many steps per run")
    parser.add_argument("--repeat", type=int, help="runs of each way per size, best kept (default 3)")
    parser.add_argument("--scipy-max-n", type=int, default=1000, help="largest N for solve_ivp")
    parser.add_argument("--scipy-max-steps", type=int, default=10_000, help="solve_ivp integrates at most this many dt")
    parser.add_argument("--replicas", type=int, default=1000, help="replicas of the 21-magnet chain")
    parser.add_argument("--replica-sample", type=int, help="replicas timed one instance each (default 20)")
    parser.add_argument("--check-n", type=int, default=10_000, help="accuracy check: N (issue 7: 10^4)")
    parser.add_argument("--check-steps", type=int, default=10_000, help="accuracy check: steps (issue 7: 10^4)")
    args = parser.parse_args()
    quick = {"sizes": [21, 1000, 10_000], "atom_steps": 1e7, "repeat": 2, "replica_sample": 5}
    full = {"sizes": [21, 1000, 10_000, 100_000, 1_000_000], "atom_steps": 1e8, "repeat": 3, "replica_sample": 20}
    for key, value in (quick if args.quick else full).items():
        if getattr(args, key) is None:
            setattr(args, key, value)

    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    print(f"Engine benchmark, {stamp}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at start")
    print(f"paper chain: F = K/(r+b)^3, K = {K} N mm^3, b = {B} mm, m = {MASS} g, r0 = {R0} mm, "
          f"impactor {V_I} m/s, far end held, dt = {DT} ms; best of {args.repeat}, interleaved")
    with tempfile.TemporaryDirectory(prefix="bench_engine_") as tmp:
        bench = Bench(args, Path(tmp))
        print(f"CPU [s]: the process's CPU time (LAMMPS: Loop - Output times its CPU share, shown for loops "
              f">= {MIN_LOOP_FOR_CPU} s);\n  the steadier ratio on a shared machine, where a process waits for a core")
        print("scipy DOP853: rtol = atol = the loosest 10^-k as accurate as velocity Verlet at dt = "
              f"{DT} ms on the same run (final velocities against DOP853 at 1e-13; both errors in the note)")
        if bench.default_engine is None:
            print("chain engine: not yet available ([run] engine is not a case field on main); default = stock")
        print("\n" + HEADER)
        for n in args.sizes:
            print_size(n, bench.size(n))
        if args.check_steps:
            dv = bench.check(args.check_n, args.check_steps)
            verdict = "meets" if dv <= CHECK_TOLERANCE else "FAILS"
            print(f"\nAccuracy: {bench.label('default')}, N = {args.check_n}, {args.check_steps} steps: "
                  f"max |v - v_C| = {dv:.1e} m/s ({verdict} issue 7's <= {CHECK_TOLERANCE:g} m/s)")
        if args.replica_sample:
            replica_rows(bench)
    print(f"\nload average {os.getloadavg()[0]:.2f} at the end ({os.cpu_count()} cores, shared machine)")


if __name__ == "__main__":
    main()
