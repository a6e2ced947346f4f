"""Studies: the paper's figures and the literature's tests, each one module with
`run(out, quick) -> StudyResult`.

Layout: `paper/` (one module per figure of the paper: fig1-4, s3-s9, movies), `literature/`
(harmonic, toda, hugoniot, dsw), `ensembles/` (replicas of random chains: thermal), on one
scaffold: `scaffold` (the paper's constants, the chains as cases, runs of many cases),
`long_lattice` (Fig. 3's measures and panels, shared by fig3 and s5), `output` (the one writer).
Studies call measures (`pylmp_lattice.measures`) and the scaffold, never each other.

`pylmp-lattice study NAME [-o DIR] [--quick]` runs a study and writes, through the one writer
`write_study`: DIR/NAME.json (its numbers, units in the keys, strict JSON), DIR/NAME_<table>.csv
for each table, DIR/NAME.png and DIR/NAME.pdf. A study's own run folders go under DIR/NAME/;
running the study again redoes them (`simulate(..., overwrite=True)`), as it rewrites its files.
`--quick` runs a small version (fewer or shorter runs) for tests and a first look.

To add a study: write `studies/<origin>/<name>.py` with `run(out: Path, quick: bool) ->
StudyResult` and add its name, origin and one-line title to STUDIES.
"""

from __future__ import annotations

import importlib
import logging
import os
from pathlib import Path
from typing import TYPE_CHECKING

from ..formats.layout import as_path

if TYPE_CHECKING:
    from .output import StudyResult

__all__ = ["STUDIES", "StudyResult", "run_study", "write_study"]

log = logging.getLogger(__name__)

# name -> title; the module pylmp_lattice.studies.<ORIGIN[name]>.<name> runs it.
STUDIES: dict[str, str] = {
    "fig1": "Fig. 1(b, c): the 21-magnet experiment with a smooth synthetic impact; rise times",
    "fig2": "Fig. 2: force and stiffness against separation, the power-law fit, magnets 2 and 8",
    "fig3": "Fig. 3(a-e): the long lattice at V_I = 2 m/s without friction, and the transition zone",
    "fig4": "Fig. 4(a-d): V_P, f/f0, eta against V_I; V*, V*/V0 and V* against q (sweeps)",
    "s3": "Fig. S3 / Sec. S2: second-neighbour interaction (attractive, 5 %) and its effect on V_P and first peaks",
    "s4": "Fig. S4: the friction calibration rig (one magnet between two fixed magnets)",
    "s5": "Fig. S5: the linear lattice (V_P -> V0, the oscillation decays completely)",
    "s6": "Fig. S6: friction, V_P along the chain for several mu (sweep)",
    "s7": "Fig. S7: a ramp to V_I, sweep over the ramp time T_r",
    "s8": "Fig. S8: a half-sine pulse, sweep over T_s from well below to well above T0",
    "s9": "Fig. S9: phase portraits of magnet 10 for V_I = 0.01, 0.1, 1, 2 m/s",
    "movies": "Movies S1 and S2: the experiment's magnets, and the long lattice's growing transition zone",
    "harmonic": "The harmonic chain driven by a piston, against its exact (Bessel) solution",
    "toda": "The Toda lattice: soliton speed, and the piston problem's wake, period two and lead soliton",
    "hugoniot": "Hugoniots of the magnet, Toda, Lennard-Jones and Morse chains; jump conditions; wake energy",
    "dsw": "Dispersive-shock theory against simulation: V_P, wake frequency and gap, eta and V*, first peaks",
    "thermal": "Thermal motion and mass disorder: V_P, first peak and eta of the long lattice (ensembles)",
    "all": "every study above, into one folder",
}
LITERATURE = ("harmonic", "toda", "hugoniot", "dsw")
ENSEMBLES = ("thermal",)
# name -> the subpackage that holds it ("" for `all`, which lives beside the scaffold)
ORIGIN = {name: "literature" if name in LITERATURE else "ensembles" if name in ENSEMBLES else "" if name == "all"
          else "paper" for name in STUDIES}


def study_module(name: str) -> str:
    """The module that runs study `name`."""
    return ".".join(filter(None, (__name__, ORIGIN[name], name)))


def run_study(name: str, out: str | Path = Path("runs/studies"), quick: bool = False) -> StudyResult:
    """Run study `name`, write its files into `out`, and return its results."""
    from ..errors import require_bool

    require_bool(quick=quick)  # "no" would run the small version
    if name not in STUDIES:
        raise ValueError(f"study: got {name!r}; choose one of {', '.join(STUDIES)}")
    out = as_path(out, "out", "the folder for the study's files")
    check_output(out)
    for each in STUDIES if name == "all" else (name,):  # before any run: none of its writes may follow a link
        refuse_planted_links(out, each)
    log.info("study %s: %s -> %s", name, STUDIES[name], out)
    from .output import write_study

    result = importlib.import_module(study_module(name)).run(out, quick)
    write_study(result, out)
    return result


def check_output(out: Path) -> None:
    """UsageError naming `output` unless `out` may take a study's files: a folder that is no
    symbolic link (its writes would land wherever it points), not the working directory, a
    parent of it or runs/ (`layout.check_place`), no run folder of this package (the study's
    files would sit among the run's), and one this user can write in."""
    from ..errors import UsageError
    from ..formats.layout import check_place
    from ..preflight import check_writable
    from ..run_folder import marker

    check_place(out, "study")
    if marker.is_run(out):
        raise UsageError("output", f"{out} holds a run of this package; choose a new folder for the study (-o)")
    check_writable(out, "output")


def refuse_planted_links(out: Path, name: str) -> None:
    """LinkError for a symbolic link where study `name` writes in `out`: its files
    (`output.study_files`), its runs' folder NAME/ or anything in it (the runs are redone
    there; a link inside would take their writes elsewhere). (The movies are written by a
    rename, which replaces a link, never follows it.)"""
    from ..formats.files import refuse_link, refuse_links
    from .output import study_files

    for path in study_files(out, name):
        refuse_link(path)
    runs = out / name
    refuse_link(runs)
    for folder, dirs, files in os.walk(runs):  # (never follows a link: each is refused as found)
        refuse_links(folder, dirs + files)


def __getattr__(name):
    # StudyResult and write_study from `output` (numpy) on first use: the command line reads
    # STUDIES for its choices of every command
    if name in ("StudyResult", "write_study"):
        return getattr(importlib.import_module(".output", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
