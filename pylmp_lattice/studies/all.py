"""Every study, one after the other into the same folder; all.json lists each one's wall time."""

from __future__ import annotations

import time
from pathlib import Path

from ..plots import pyplot
from .output import StudyResult

NAME = "all"


def run(out: Path, quick: bool = False) -> StudyResult:
    from . import STUDIES, run_study

    wall = {}
    for name in STUDIES:
        if name == NAME:
            continue
        start = time.perf_counter()
        run_study(name, out, quick)
        wall[name] = round(time.perf_counter() - start, 1)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 3.5), layout="constrained")
    ax.barh(list(wall), list(wall.values()))
    ax.set(xlabel="wall time (s)", title=f"pylmp-lattice study all{' --quick' if quick else ''}")
    numbers = {"wall_time_s": wall, "total_wall_time_s": round(sum(wall.values()), 1),
               "studies": {name: f"{name}.json" for name in wall}}
    return StudyResult(NAME, numbers, figure=fig, quick=quick)
