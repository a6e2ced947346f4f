"""The chains of the literature studies (harmonic, toda, hugoniot) and their run loop.

Every chain is in user units (mm, g, ms, N, m/s). The Toda, Lennard-Jones and Morse chains are
the dimensionless lattices (m = A = B = 1; m = epsilon = sigma = 1), since mm, g, ms, mJ are a
consistent set: time is then in ms and velocity in m/s. The Morse chain has alpha r_e = 6, the
value with the Lennard-Jones curvature at the minimum (2 alpha^2 D = 72 epsilon / r_m^2).

Multi-run studies run through the sweep layer (`run_cases`): resumable, in parallel, one
member folder per case under the study's folder.
"""

from __future__ import annotations

from pathlib import Path

from ..case import Case, case_from_dict, case_to_dict
from ..errors import LatticeError
from ..run_folder import RunFolder
from ..sweep import Sweep, member_id, run_sweep
from ..sweep.store import DONE, member_folder
from ..trajectory import Trajectory

SECTIONS = ("chain", "force", "impactor", "run", "table", "friction")

MAGNET = {"law": "power", "K": 413.8, "b": 3.917, "q": 3.0}
MAGNET_MASS, MAGNET_R0 = 1.084, 12.0  # g, mm
# The paper's linear lattice (Fig. S5): the magnets' stiffness at r0, 3 K / (r0 + b)^4 N/mm.
MAGNET_STIFFNESS = 3 * 413.8 / (12.0 + 3.917) ** 4
LJ_R0 = 2 ** (1 / 6)  # mm, the Lennard-Jones minimum for sigma = 1 mm

# name -> (force, spacing r0 in mm, mass in g, table settings)
CHAINS = {
    "magnet": (MAGNET, MAGNET_R0, MAGNET_MASS, {}),
    "toda": ({"law": "toda", "A": 1.0, "B": 1.0, "a": 10.0}, 10.0, 1.0, {"r_min": 2.0}),
    "lj": ({"law": "lj", "epsilon": 1.0, "sigma": 1.0}, LJ_R0, 1.0, {"r_min": 0.75}),
    "morse": ({"law": "morse", "D": 1.0, "alpha": 6.0 / LJ_R0, "r_e": LJ_R0}, LJ_R0, 1.0, {"r_min": 0.5}),
    "harmonic": ({"law": "linear", "k": MAGNET_STIFFNESS, "r_free": 24.0}, MAGNET_R0, MAGNET_MASS, {}),
}


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


def run_cases(cases: list[Case], root: Path, workers: int | None = None) -> list[tuple[dict, Trajectory]]:
    """Run `cases` as one sweep in `root` (resumable: done members are not run again); each
    case's summary and trajectory, in order. The cases differ in whole sections, which the
    sweep zips; a failed member stops the study with its one-line error."""
    dicts = [case_to_dict(c) for c in cases]
    sections = [s for s in SECTIONS if any(s in d for d in dicts)]
    sweep = Sweep(base=dicts[0], zip={s: [d[s] for d in dicts] for s in sections} if len(cases) > 1 else {})
    table = run_sweep(sweep, root, workers=workers, progress=False)
    failed = table[table["status"] != DONE]
    if len(failed):
        raise LatticeError(f"study run failed: {failed['error'].iloc[0]} (in {Path(root) / failed['folder'].iloc[0]})")
    out = []
    for case in cases:
        folder = member_folder(root, member_id(case))
        run = RunFolder(folder)
        out.append((run.summary, run.trajectory()))
    return out
