"""What the studies share: the paper's chain as a case, its linear constants, sweeps of runs."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import measures
from ..case import Case, case_from_dict
from ..run_folder import RunFolder
from ..sweep import Member, Sweep, run_sweep
from ..sweep.store import member_folder

# The paper's lattice (main text): m, r0 and the magnet law F = K/(r+b)^q.
MASS, R0 = 1.084, 12.0  # g, mm
PAPER_FORCE = {"law": "power", "K": 413.8, "b": 3.917, "q": 3.0}
MAGNET_LENGTH = 6.35  # mm, one magnet particle (two ring magnets), paper Sec. 1


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


def linear_constants(case: Case) -> tuple[float, float]:
    """(V0 in m/s, f0 in Hz) of the case's nearest-neighbour law at its initial spacing."""
    r0 = float(np.mean(case.chain.gaps()))
    k = float(case.force.stiffness(r0))
    m = float(np.mean(case.chain.masses()))
    return measures.linear_wave_speed(k, m, r0), measures.linear_frequency(k, m)


def particles_reached(arrival) -> int:
    """How many particles the front reached (arrival finite)."""
    return int(np.sum(np.isfinite(arrival)))


def pick(candidates, limit: int) -> list[int]:
    """The 0-based particle indices among `candidates` below `limit`."""
    return [n for n in candidates if n < limit]


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
        return self.status == "done"

    def row(self, label: str, key: str) -> dict:
        """The start of the member's row in a study: its swept value `key` as `label`, its
        status and error."""
        return {label: self.member.params[key], "status": self.status, "error": self.error}

    def trajectory(self):
        """The member's trajectory (`RunFolder.trajectory`)."""
        return RunFolder(self.folder).trajectory()


def sweep_runs(base: dict, root: Path, workers: int | None = None, **spec) -> list[SweepRun]:
    """Run a sweep of `base` (a case dict, `paper_dict`; spec: set / grid / zip as in `sweep.Sweep`) in `root` through the
    sweep layer (parallel, resumable: members already done are not run again); its members in
    sweep order."""
    sweep = Sweep(base=base, **spec)
    table = run_sweep(sweep, root, workers=workers, progress=False).set_index("id")
    runs = []
    for m in sweep.members():
        row = table.loc[m.id]
        folder = member_folder(root, m.id)
        summary = RunFolder(folder).summary if row["status"] == "done" else None
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
