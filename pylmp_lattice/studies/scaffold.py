"""What every study stands on: the paper's constants, the chains as cases, runs of many cases.

The paper's constants have their one home here (K, b, q: the defaults of `forcelaw.PowerLaw`,
which are the paper's law): MASS, R0, PAPER_FORCE, MAGNET_LENGTH, the calibrated friction
FRICTION, and (from `case_measures`) the linear constants V0 and f0 of any case (`linear_constants`).

Every chain is in user units (mm, g, ms, N, m/s). The Toda, Lennard-Jones and Morse chains of
the literature studies are the dimensionless lattices (m = A = B = 1; m = epsilon = sigma = 1),
since mm, g, ms, mJ are a consistent set: time is then in ms and velocity in m/s. The Morse
chain has alpha r_e = 6, the value with the Lennard-Jones curvature at the minimum
(2 alpha^2 D = 72 epsilon / r_m^2).

Runs of many cases go through the sweep layer (`sweep_runs`, `run_cases`): resumable, in
parallel, one member folder per case under the study's folder.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

from ..case import Case, case_from_dict, case_to_dict
from ..case_measures import linear_constants  # noqa: F401  (the studies' V0 and f0, from the bridge)
from ..errors import LatticeError
from ..forcelaw import PowerLaw
from ..run_folder import RunFolder
from ..sweep import Member, Sweep, member_id, run_sweep
from ..sweep.store import DONE, Outcomes, member_folder
from ..trajectory import Trajectory

# The paper's lattice (main text): m, r0 and the magnet law F = K/(r+b)^q.
MASS, R0 = 1.084, 12.0  # g, mm
PAPER_LAW = PowerLaw()  # K = 413.8 N mm^3, b = 3.917 mm, q = 3
PAPER_FORCE = {"law": "power"} | asdict(PAPER_LAW)
MAGNET_LENGTH = 6.35  # mm, one magnet particle (two ring magnets), paper Sec. 1
FRICTION = {"mu": 0.285, "p": 0.012, "g": 9.81}  # the calibrated friction (Sec. S3), g in m/s^2
# The paper's linear lattice (Fig. S5): the magnets' stiffness at r0, N/mm.
MAGNET_STIFFNESS = float(PAPER_LAW.stiffness(R0))
LJ_R0 = 2 ** (1 / 6)  # mm, the Lennard-Jones minimum for sigma = 1 mm

# The chains of the literature studies: name -> (force, spacing r0 in mm, mass in g, table settings)
CHAINS = {
    "magnet": (PAPER_FORCE, R0, MASS, {}),
    "toda": ({"law": "toda", "A": 1.0, "B": 1.0, "a": 10.0}, 10.0, 1.0, {"r_min": 2.0}),
    "lj": ({"law": "lj", "epsilon": 1.0, "sigma": 1.0}, LJ_R0, 1.0, {"r_min": 0.75}),
    "morse": ({"law": "morse", "D": 1.0, "alpha": 6.0 / LJ_R0, "r_e": LJ_R0}, LJ_R0, 1.0, {"r_min": 0.5}),
    "harmonic": ({"law": "linear", "k": MAGNET_STIFFNESS, "r_free": 24.0}, R0, MASS, {}),
}
SECTIONS = ("chain", "force", "impactor", "run", "table", "friction")

# The 21-magnet experiment (Fig. 1): its impact u1(t) is not published, so a half-sine velocity
# pulse stands in for it (peak 2.81 m/s, rising in 23.9 ms, the paper's magnet-1 rise time).
EXPERIMENT_PEAK, EXPERIMENT_RISE = 2.81, 23.9  # m/s, ms
EXPERIMENT_STAND_IN = f"half-sine pulse, peak {EXPERIMENT_PEAK:g} m/s, rise {EXPERIMENT_RISE:g} ms"


def paper_case(name: str, impactor: dict, duration: float, **options) -> Case:
    """The paper's chain (m = 1.084 g, r0 = 12 mm, the magnet law) with an impactor profile and
    run length (ms); options as for `paper_dict`."""
    return case_from_dict(paper_dict(name, impactor, duration, **options))


def paper_dict(name: str, impactor: dict, duration: float, far_end: str = "long", particles: int | None = None,
               dt: float = 0.01, output_interval: float = 0.1, **sections) -> dict:
    """`paper_case` as a case dict. As a sweep's base it leaves a long lattice's N unresolved, so
    each member gets the N its own V_I, law and run length need; `sections` add or replace case
    sections (force, friction, ...); a `run` section adds to the run settings."""
    data = {
        "name": name,
        "chain": {"mass": MASS, "r0": R0, "far_end": far_end} | ({"particles": particles} if particles else {}),
        "force": dict(PAPER_FORCE),
        "impactor": dict(impactor),
        "run": {"duration": duration, "dt": dt, "output_interval": output_interval},
    }
    data["run"] |= sections.pop("run", {})  # extra run settings join the run length and step
    data.update(sections)
    return data


def experiment_case() -> Case:
    """The paper's 21-magnet experiment with the stand-in pulse, the calibrated friction and
    magnet 21 fixed (= inputs/paper_experiment.toml)."""
    return paper_case("paper_experiment", {"profile": "sine", "velocity": EXPERIMENT_PEAK,
                                           "duration": 2 * EXPERIMENT_RISE}, 60.0,
                      far_end="fixed", particles=21, dt=0.0125, output_interval=0.125, friction=dict(FRICTION))


def chain_case(chain: str, name: str, impactor: dict, duration: float, particles: int | None = None,
               dt: float = 0.01, output: float = 0.1, r0=None) -> Case:
    """A case of one of CHAINS: a long lattice unless `particles` is given (then a held far end).

    r0: per-gap initial separations (mm) instead of the chain's uniform spacing."""
    force, spacing, mass, table = CHAINS[chain]
    chain_d = {"mass": mass, "r0": spacing if r0 is None else list(r0)}
    chain_d |= {"far_end": "long"} if particles is None else {"particles": particles, "far_end": "fixed"}
    return case_from_dict({
        "name": name, "chain": chain_d, "force": dict(force), "impactor": impactor,
        "run": {"duration": duration, "dt": dt, "output_interval": output}, "table": dict(table),
    })


def pick(candidates, reached: int) -> list[int]:
    """The magnet numbers among `candidates` that the front reached (magnets 1 .. reached,
    `measures.particles_reached`)."""
    return [n for n in candidates if n <= reached]


@dataclass(frozen=True)
class SweepRun:
    """One member of a study's sweep: its case and parameters, status ("done" or "failed"), the
    one-line error of a failed run, its folder, and the run summary (None if failed)."""

    member: Member
    status: str
    error: str | None
    folder: Path
    summary: dict | None

    @property
    def done(self) -> bool:
        """Whether the member's run ended normally (status "done")."""
        return self.status == DONE

    def row(self, label: str, key: str) -> dict:
        """The start of the member's row in a study: its swept value `key` as `label`, its
        status and error."""
        return {label: self.member.params[key], "status": self.status, "error": self.error}

    def trajectory(self) -> Trajectory:
        """The member's trajectory (`RunFolder.trajectory`)."""
        return RunFolder(self.folder).trajectory()


def sweep_runs(base: dict, root: Path, workers: int | None = None, **spec) -> list[SweepRun]:
    """Run a sweep of `base` (a case dict, `paper_dict`; spec: set / grid / zip as in
    `sweep.Sweep`) in `root` through the sweep layer (parallel, resumable: members already done
    are not run again); its members in sweep order."""
    sweep = Sweep(base=base, **spec)
    # overwrite: a study run again with other values (quick, full) makes `root` this sweep's
    table = run_sweep(sweep, root, workers=workers, progress=False, overwrite=True).set_index("id")
    runs, disk = [], Outcomes(root)
    for m in sweep.members():
        row = table.loc[m.id]
        folder = Path(root) / row["folder"]  # a batched member's: its batch's
        summary = disk.get(m.id)["summary"] if row["status"] == DONE else None
        error = row["error"] if isinstance(row["error"], str) else None
        runs.append(SweepRun(m, row["status"], error, folder, summary))
    return runs


def done_runs(runs: list[SweepRun], rows: list, label: str, key: str):
    """Append every member's row (`SweepRun.row`) to `rows`; yield (run, row) of those done, for
    the study to add its measures to the row."""
    for r in runs:
        rows.append(row := r.row(label, key))
        if r.done:
            yield r, row


def run_cases(cases: list[Case], root: Path, workers: int | None = None) -> list[tuple[dict, Trajectory]]:
    """Run `cases` as one sweep in `root` (resumable: done members are not run again); each
    case's summary and trajectory, in order. The cases differ in whole sections, which the
    sweep zips; a failed member stops the study with its one-line error."""
    dicts = [case_to_dict(c) for c in cases]
    sections = [s for s in SECTIONS if any(s in d for d in dicts)]
    sweep = Sweep(base=dicts[0], zip={s: [d[s] for d in dicts] for s in sections} if len(cases) > 1 else {})
    table = run_sweep(sweep, root, workers=workers, progress=False, overwrite=True)  # as in sweep_runs
    failed = table[table["status"] != DONE]
    if len(failed):
        raise LatticeError(f"study run failed: {failed['error'].iloc[0]} (in {Path(root) / failed['folder'].iloc[0]})")
    out = []
    for case in cases:
        folder = member_folder(root, member_id(case))
        run = RunFolder(folder)
        out.append((run.summary, run.trajectory()))
    return out
