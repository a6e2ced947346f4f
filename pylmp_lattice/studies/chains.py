"""The chains of the literature studies (harmonic, toda, hugoniot) and their run loop.

Every chain is in user units (mm, g, ms, N, m/s). The Toda, Lennard-Jones and Morse chains are
the dimensionless lattices (m = A = B = 1; m = epsilon = sigma = 1), since mm, g, ms, mJ are a
consistent set: time is then in ms and velocity in m/s. The Morse chain has alpha r_e = 6, the
value with the Lennard-Jones curvature at the minimum (2 alpha^2 D = 72 epsilon / r_m^2).

The sweep layer (issue 8) had not landed on main when these studies were written, so
multi-run studies are a plain loop over `simulation.run_case`, one folder per run.
"""

from __future__ import annotations

from pathlib import Path

from ..case import Case, case_from_dict
from ..simulation import load_trajectory, run_case
from ..trajectory import Trajectory

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


def run_chain(case: Case, out: Path) -> tuple[dict, Trajectory]:
    """Run `case` in out/<case.name> (`run_case`: summary.json beside the run); its summary and trajectory."""
    folder = Path(out) / case.name
    return run_case(case, folder, figure=False), load_trajectory(case, folder)
