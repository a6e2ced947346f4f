"""Every study, one after the other into the same folder; all.json lists each one's wall time.

A line on stderr (the log) as each study finishes: its number, name, wall time and the total."""

from __future__ import annotations

import logging
import time
from pathlib import Path

from ..plots import pyplot, style_figure
from .output import StudyResult

NAME = "all"
log = logging.getLogger(__name__)


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    from . import STUDIES, run_study

    wall = {}
    names = [name for name in STUDIES if name != NAME]
    for k, name in enumerate(names, 1):
        start = time.perf_counter()
        run_study(name, out, quick)
        wall[name] = round(time.perf_counter() - start, 1)
        log.info("study all: [%d/%d] %s done in %.1f s (%.1f s so far)", k, len(names), name, wall[name],
                 sum(wall.values()))
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 3.5), layout="constrained")
    ax.barh(list(wall), list(wall.values()))
    ax.set(xlabel="wall time (s)", ylabel="study")
    style_figure(fig, "pylmp-lattice study all: wall time per study", quick=quick, letters="")
    numbers = {"wall_time_s": wall, "total_wall_time_s": round(sum(wall.values()), 1),
               "studies": {name: f"{name}.json" for name in wall}}
    return StudyResult(NAME, numbers, figure=fig, quick=quick)
