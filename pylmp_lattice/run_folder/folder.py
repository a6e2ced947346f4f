"""`RunFolder`: one run folder, read, measured and summarized through one object.

    folder = RunFolder("runs/x")                 # any run folder, finished or not
    folder.case, folder.status, folder.trajectory(), folder.front(), folder.summarize()

The reader side of a run folder: `run_folder.write` writes one, `run_folder.execution` runs it
(or LAMMPS by hand, `lmp -in in.lattice`), and both sides share `layout` (its files), `marker`
(its state), `cases` (its cases) and `convert` (binary dumps into H5MD). A batch of chains
(`execution.execute_batch`) is a run folder too: its status, cases and deck read as a single
run's; its chains' trajectories are `replicas()`, and what reads one case (`case`, `trajectory`,
the measures and summary) refuses it. What it reads, it caches (a folder that
changes on disk is read again: the cache is keyed by the files' sizes and times). It never
destroys: a folder still being written is read as it stands, and says so.
"""

from __future__ import annotations

import json
import logging
import math
import re
import shlex
from contextlib import suppress
from pathlib import Path

import numpy as np

from .. import measures
from ..formats.bindump import open_dump, read_trajectory
from ..case import Case
from ..formats.dump import Contact, error_line, find_contact, read_dump, read_log, trajectory_from_dump
from ..errors import LatticeError, UsageError, require_bool
from ..case_measures import case_front, read_front_record, set_impactor_acceleration
from ..numbering import number
from ..serialize import dumps, loads_object
from ..trajectory import Trajectory
from ..units import from_engine, to_engine
from ..formats import layout
from ..formats.files import atomic_write, refuse_link, refuse_links, replacing
from . import marker
from .cases import read_cases
from .convert import convert_dumps
from .marker import CONTACT, FAILED, INTERRUPTED, RUNNING, UNLOGGED, WRITTEN
from .write import write_folder

log = logging.getLogger(__name__)


class RunFolder:
    """A run folder on disk (see `layout` for its files). Open any folder with `RunFolder(path)`."""

    def __init__(self, path: str | Path):
        self.path = layout.as_path(path, "folder", "the path of a run folder")
        self._cache: dict = {}

    def _folder(self) -> Path:
        """The folder's path; UsageError if nothing is there, or a file (its state, case and files
        are read from a folder that exists)."""
        if not self.path.is_dir():
            why = "it is not a folder" if self.path.exists() else "no such folder"
            raise UsageError("folder", f"got {str(self.path)!r}; expected a run folder ({why})")
        return self.path

    def __repr__(self) -> str:
        return f"RunFolder({str(self.path)!r})"

    @classmethod
    def create(cls, case: Case | list[Case], path: str | Path, overwrite: bool = False) -> RunFolder:
        """Write `case` (or a batch: a list of cases) into `path` (`write.write_folder`) and open the folder."""
        return cls(write_folder(case, path, overwrite))

    def record(self, state: str, **details) -> None:
        """Write run.json (`marker.record`): a runner other than `execution` says how a run ended."""
        marker.record(self.path, state, **details)

    # ---- what the folder is

    @property
    def cases(self) -> tuple[Case, ...]:
        """The folder's cases: its one case, or a batch's chains in order (`cases.read_cases`)."""
        if "cases" not in self._cache:
            self._cache["cases"] = read_cases(self._folder())
        return self._cache["cases"]

    @property
    def case(self) -> Case:
        """The run's case; UsageError for a batch of chains (see `cases`)."""
        cases = self.cases
        if len(cases) != 1:
            raise UsageError("folder", f"{self.path} holds a batch of {len(cases)} chains, not one case; "
                                        "read RunFolder.cases and RunFolder.replicas()")
        return cases[0]

    @property
    def status(self) -> str:
        """How the run stands: "running", "done", "interrupted", "contact", "failed",
        "unlogged" or "written" (see `marker.status`)."""
        folder = self._folder()
        if not any((folder / name).exists() for name in (layout.CASE, layout.REPLICAS, layout.MARKER)):
            raise UsageError("folder", f"got {str(folder)!r}; expected a run folder (it has no {layout.CASE})")
        return marker.status(folder)

    def contact(self) -> Contact | None:
        """Where two magnets touched, if the run stopped so."""
        text = marker.log_text(self.path)
        return find_contact(text) if text else None

    def friction_work(self) -> float:
        """Energy the friction has dissipated by the end of the run, mJ (the fix's scalar in the log)."""
        if self.case.friction is None:
            raise UsageError(str(self.path), "its case has no [friction] section: no friction work to read")
        return float(from_engine(read_log(self.path / layout.LOG).runs[-1]["f_friction"][-1], "energy"))

    @property
    def summary(self) -> dict | None:
        """summary.json, or None if the folder has none, or one that is not a strict JSON object
        (as `summarize` writes it: no NaN)."""
        try:
            return loads_object((self._folder() / layout.SUMMARY).read_bytes())
        except OSError:
            return None

    # ---- trajectories

    def convert(self) -> bool:
        """Turn the binary dumps into traj.h5md when safe (`convert.convert_dumps`); whether it did."""
        done = convert_dumps(self.path, self.case)
        if done:
            self._cache.clear()
        return done

    def trajectory(self, group: str = "chain", *, magnets=None) -> Trajectory:
        """The trajectory in user units: group "chain" (every magnet) or "fine" (the output.fine
        magnets at output.fine_interval); `magnets`: only these magnets of the group, by number
        (1 .. N, as the paper counts), increasing. Column k holds magnets[k].

        From traj.h5md, the binary dumps (converted first when safe, else read as they stand)
        or the text dump. The impactor's acceleration comes from its profile
        (`case_measures.set_impactor_acceleration`)."""
        from ..formats import h5md

        if group not in layout.BINARY_GROUPS:
            raise UsageError("group", f"got {group!r}; choose one of {', '.join(layout.BINARY_GROUPS)}")
        case = self.case
        if group == "fine" and not case.output.fine:
            raise UsageError("group", f"got 'fine'; output.fine was not set for the run in {self.path}: "
                                      "it holds the group chain alone")
        columns = self._columns(group, magnets)
        key = ("trajectory", group, columns, self._stamp())
        if key in self._cache:
            return self._cache[key]
        binary, text = self.path / layout.BINARY_GROUPS[group], self.path / layout.TEXT_GROUPS[group]
        if binary.is_file() and not self.convert() and binary.is_file():
            if self.status == RUNNING:
                log.warning("%s is still being written: read the %d frames it has so far", self.path,
                            open_dump(binary).frames)
            traj = read_trajectory(binary, self._masses(group), columns)
        elif (self.path / layout.H5MD).is_file():
            traj = h5md.read_group(self.path / layout.H5MD, group, columns)
        elif text.is_file():
            traj = _select(trajectory_from_dump(read_dump(text, dt=to_engine(case.run.dt, "time"))), columns)
        else:
            raise UsageError(str(self.path), f"holds no {group} trajectory (status {self.status}, "
                                              f"output.format = {case.output.format!r})")
        numbers = self._numbers(group)
        numbers = numbers if columns is None else numbers[list(columns)]
        set_impactor_acceleration(case, traj, numbers == 0)
        self._cache[key] = traj
        return traj

    def replicas(self) -> list[Trajectory]:
        """A batch's chains' trajectories in user units, from its text dump of all chains: chain
        r holds atoms r N + 1 .. r N + N, each the trajectory its own run gives (`deck.render_replicas`)."""
        cases = self.cases
        dump = self.path / layout.DUMP
        if not dump.is_file():
            raise UsageError(str(self.path), f"holds no text dump of its chains (status {self.status})")
        batched = trajectory_from_dump(read_dump(dump, dt=to_engine(cases[0].run.dt, "time")))
        n, out = cases[0].chain.particles, []
        for r, case in enumerate(cases):
            part = slice(r * n, (r + 1) * n)
            out.append(Trajectory(batched.t, batched.x0[part], batched.u[:, part], batched.v[:, part], batched.a[:, part].copy()))
            set_impactor_acceleration(case, out[-1], [0])  # imposed (see `trajectory`)
        return out

    def _numbers(self, group: str) -> np.ndarray:
        """0-based magnet numbers of a group's columns (in id order)."""
        case = self.case
        return np.arange(case.chain.particles) if group == "chain" else np.sort(case.output.fine) - 1

    def _columns(self, group: str, magnets) -> tuple[int, ...] | None:
        """The 0-based columns of a group that hold `magnets` (numbers 1 .. N), or None for all."""
        if magnets is None:
            return None
        held = [int(m) for m in self._numbers(group) + 1]
        where = f"1 .. {held[-1]}" if group == "chain" else f"the output.fine magnets {held}"
        wanted = list(magnets) if isinstance(magnets, (list, tuple, np.ndarray)) else None
        if wanted is None or not all(isinstance(m, (int, np.integer)) and not isinstance(m, bool) for m in wanted) \
                or any(m not in held for m in wanted) or wanted != sorted(set(wanted)):
            raise UsageError("magnets", f"got {magnets!r}; expected a list of increasing integer magnet numbers in {where}")
        return tuple(held.index(m) for m in wanted)

    def _masses(self, group: str) -> np.ndarray:
        return to_engine(self.case.chain.masses()[self._numbers(group)], "mass")

    def _stamp(self) -> tuple:
        """Sizes and times of the files a read depends on: a changed folder is read again."""
        out, folder = [], self._folder()
        for name in (layout.H5MD, layout.TRAJ_BIN, layout.FINE_BIN, layout.DUMP, layout.FINE_DUMP, layout.FRONT_BIN):
            with suppress(FileNotFoundError):
                st = (folder / name).stat()
                out.append((name, st.st_size, st.st_mtime_ns))
        return tuple(out)

    # ---- measures

    def arrival_method(self) -> str:
        """A pulse's arrival is its first velocity peak (far from the impactor it may never reach
        V_I/2); any other drive's is the crossing of V_I/2."""
        return measures.default_arrival_method(pulse=self.case.impactor.is_pulse())

    def measures(self) -> tuple[measures.Front | None, np.ndarray | None]:
        """The front measures and each magnet's largest |v| (m/s): from the engine's record when
        the run wrote one, else from the whole trajectory. (None, None) without a drive, or
        without either source."""
        key = ("measures", self._stamp())
        if key not in self._cache:
            self._cache[key] = self._measure()
        return self._cache[key]

    def _measure(self):
        case = self.case
        vi = case.impactor.peak_velocity()
        if vi <= 0:
            return None, None
        if (self.path / layout.FRONT_BIN).is_file():
            record = read_front_record(case, self.path / layout.FRONT_BIN, self.arrival_method())
            return record.front, record.max_speed
        try:
            traj = self.trajectory()
        except LatticeError:
            return None, None
        if len(traj.t) < 2:
            raise UsageError(str(self.path), f"holds {len(traj.t)} frame(s) of its trajectory (status {self.status}); "
                                              "a front needs at least 2, nothing to measure")
        front = case_front(case, traj.t, traj.v, traj.a, self.arrival_method())
        return front, np.max(np.abs(traj.v), axis=0)

    def front(self) -> measures.Front | None:
        """The front measures (arrival times, V_P per gap, first peaks); see `measures`."""
        return self.measures()[0]

    # ---- summary and figure

    def summarize(self, figure: bool = True, wall_time: float | None = None) -> dict:
        """Write summary.json (strict JSON: an undefined measure is null), then the figure; return
        the summary. Works for any run folder LAMMPS no longer writes: finished, run by hand,
        stopped by a contact, failed or interrupted (measured up to where it stopped; `stopped`
        says where), or unlogged (its end not known: `stopped` says its last frame). A folder still being written is refused (UsageError): its numbers would be
        partial. A deck edited since it was written is said so (`deck_changes`). What an earlier
        summary of the same run holds and this one does not redo stays: its wall time, and its
        figure when not drawn again. A figure that fails is a warning: the summary is already
        written."""
        from ..summary import summary_of

        require_bool(figure=figure)  # before anything is read or written: "no" would draw it
        refuse_links(self.path, layout.RUN_FILES)  # what it reads and writes: never through a link
        case, status = self.case, self.status
        if status == RUNNING:
            wait = marker.quiet_wait(self.path)  # a writer /proc cannot see may go on: how long it counts as one
            raise UsageError(str(self.path), "still being written by LAMMPS; " + (
                f"its {wait[0]} changed {max(0, int(wait[1]))} s ago; if no LAMMPS writes it any more, summarize "
                f"again in {math.ceil(wait[2])} s" if wait else "summarize it when the run ends"))
        ran = [name for name in (layout.LOG, *layout.OUTPUTS) if (self.path / name).is_file()]
        if status == WRITTEN:  # no log and no output: nothing to measure (it read as a run with no front)
            raise UsageError(str(self.path), f"holds no {layout.LOG} and no output: a deck never run, or run with its "
                                              f"log elsewhere or none; run it with: (cd {shlex.quote(str(self.path))} "
                                              f"&& pylmp-lattice lmp -in {layout.DECK})")
        if layout.LOG not in ran:
            log.warning("%s: no %s (LAMMPS writes it where it runs: `lmp -in` from another folder without -log left it "
                        "there): the run's end and its friction work are not known; move that %s into %s and "
                        "summarize again", self.path, layout.LOG, layout.LOG, self.path)
        earlier = self.summary if self._current(layout.SUMMARY) else None
        if any(name in ran for name in layout.BINARY_GROUPS.values()):
            self.convert()  # a hand-run's dumps become traj.h5md first, so the summary names the file that stays
        front, max_speed = self.measures()
        summary = summary_of(case, front, max_speed)
        summary["status"] = status
        stopped = self._stopped(status)
        if stopped:
            summary["stopped"] = stopped
            if "error" in stopped:
                log.warning("%s: the run failed: %s", self.path, stopped["error"])
        summary.update(self.deck_changes())
        if case.friction is not None and layout.LOG in ran:
            with suppress(KeyError, IndexError, LatticeError):
                summary["friction_dissipated_energy_mJ"] = round(self.friction_work(), 6) + 0.0  # (as a batch's)
        files = {"folder": str(self.path)}
        if layout.LOG in ran:  # a deck run from elsewhere logs where it ran
            files["log"] = layout.LOG
        for name in (layout.H5MD, layout.TRAJ_BIN, layout.DUMP):
            if (self.path / name).exists():
                files["trajectory"] = name
        if self._current(layout.FIGURE):  # drawn again below, or the earlier one of this run
            files["figure"] = layout.FIGURE
        summary["files"] = files
        if wall_time is None and earlier is not None and "wall_time_s" in earlier:
            wall_time = earlier["wall_time_s"]
        if wall_time is not None:
            summary["wall_time_s"] = round(wall_time, 2)
        atomic_write(self.path / layout.SUMMARY, dumps(summary) + "\n")
        if figure and front is not None:
            try:
                log.info("%s: drawing %s", self.path, layout.FIGURE)
                with replacing(self.path / layout.FIGURE) as png:
                    self.figure().savefig(png, dpi=120, format="png")
            except Exception as err:  # the summary stands without its figure
                log.warning("%s: no figure (%s: %s); summary.json is written", self.path, type(err).__name__, err)
                files.pop("figure", None)
            else:
                files["figure"] = layout.FIGURE
            atomic_write(self.path / layout.SUMMARY, dumps(summary) + "\n")
        return json.loads(dumps(summary))  # as summary.json holds it: null for NaN, 15 digits

    def _current(self, name: str) -> bool:
        """Whether a file a summary wrote still describes the run: it exists, and the log has not
        changed since (a deck run again by hand writes a new one)."""
        try:
            made = (self.path / name).stat().st_mtime_ns
        except FileNotFoundError:
            return False
        try:
            return made >= (self.path / layout.LOG).stat().st_mtime_ns
        except FileNotFoundError:
            return True

    def deck_changes(self) -> dict:
        """How the deck that ran differs from case.toml, as far as can be told without reading
        arbitrary edits (each a warning too): "deck_edited": true if in.lattice is not the deck
        written (its hash in run.json), and "run_steps" {"case", "log"} if the log's `run N`
        commands add up to another number of steps than the case's. Empty if neither."""
        changes = {}
        written = (marker.read(self.path) or {}).get(marker.DECK_HASH)
        with suppress(OSError):
            if written and marker.deck_hash((self.path / layout.DECK).read_text()) != written:
                changes["deck_edited"] = True
                log.warning("%s: %s was edited after it was written; the summary's case values (V_I, run length, "
                            "...) are case.toml's and may not be the deck's", self.path, layout.DECK)
        text = marker.log_text(self.path) or ""
        ran = [int(n) for n in re.findall(r"^run\s+(\d+)\s*$", text, re.MULTILINE)]
        cases = self.cases
        run, where = cases[0].run, layout.CASE if len(cases) == 1 else layout.REPLICAS  # a batch's chains share it
        if ran and sum(ran) != run.steps():
            changes["run_steps"] = {"case": run.steps(), "log": sum(ran)}
            log.warning("%s: the log ran %d steps (%g ms), %s has %d (%g ms)", self.path, sum(ran),
                        sum(ran) * run.dt, where, run.steps(), run.duration)
        return changes

    def _stopped(self, status: str) -> dict | None:
        """Where a run that did not finish, or whose end is not known, stopped: a contact (pair,
        time, gap) or the last time it wrote (an interrupt; an error, with its message from
        run.json or the log's ERROR line; a run "unlogged", whose log would say whether it ended
        there)."""
        if status == CONTACT:
            c = self.contact()
            return {"reason": "contact", "magnets": list(c.magnets), "time_ms": c.time_ms, "gap_mm": c.gap_mm}
        if status in (INTERRUPTED, FAILED, UNLOGGED):
            record = marker.read(self.path) or {}
            error = record.get("error") or (error_line(marker.log_text(self.path) or "")
                                            if status == FAILED else None)
            return {"reason": status, "time_ms": record.get("time_ms", self._last_time()),
                    **({"error": error} if error else {})}
        return None

    def _last_time(self) -> float | None:
        """The last time (ms) the folder holds a frame of, or the front record's end."""
        with suppress(LatticeError, OSError, IndexError, ValueError):
            return float(self.trajectory().t[-1])
        return None

    def figure(self):
        """Fig. 3(a-d) of the run, titled with the case, V_I, N and where a run that did not
        finish, or whose end is not known, stopped (`_stopped`): profiles from the fine output if any, else a few magnets the front
        reached; panels (a, d) empty without a trajectory."""
        from ..plots import shock_figure
        from ..case_measures import linear_constants

        case, front = self.case, self.front()
        if front is None:  # (`measures`) no drive to measure a front against, or no record and no trajectory
            raise UsageError(str(self.path), f"has no front to draw (status {self.status}): " + (
                f"impactor.profile = {case.impactor.profile!r} drives nothing" if case.impactor.peak_velocity() <= 0
                else "no front record and no trajectory; run it first"))
        vi, v0 = case.impactor.peak_velocity(), linear_constants(case)[0]
        title = f"{case.name}: $V_I$ = {vi:g} m/s, N = {case.chain.particles}"
        stopped = self._stopped(self.status) or {}
        if stopped.get("time_ms") is not None:  # a run that ended early (or may have) says so: its panels end there
            title += f"; stopped at {stopped['time_ms']:.5g} of {case.run.duration:g} ms ({stopped['reason']})"
        # the first peaks saturate at 2 V_I under a steady drive without friction only
        steady = case.impactor.profile in ("constant", "ramp") and case.friction is None
        saturation = 2 * vi if steady else None
        if case.output.format == "none":
            return shock_figure(None, [], vi, front, v0, title=title, saturation=saturation)
        if case.output.fine:
            chosen = sorted(case.output.fine)
            profiles = self.trajectory("fine")
        else:  # magnet 2 and three the front reached, the last of them just behind it
            reached = np.flatnonzero(np.isfinite(front.arrival))
            last = number(reached[-1]) if reached.size else 1
            chosen = sorted({2, max(2, (last - 1) // 4 + 1), max(2, (last - 1) // 2 + 1), max(2, last - 1)})
            profiles = self.trajectory("chain", magnets=chosen)
        if len(profiles.t) < 2:  # one frame (a run shorter than its interval, or one that stopped first)
            interval, field = ((case.fine_interval(), "output.fine_interval") if case.output.fine
                               else (case.run.output_interval, "run.output_interval"))
            why = (f"\n(run.duration {case.run.duration:g} ms < {field} {interval:g} ms)"
                   if case.run.duration < interval else f"\n(the run stopped before {interval:g} ms)")
            return shock_figure(None, [], vi, front, v0, title=title, saturation=saturation,
                                missing="one frame written: no profile to draw" + why)
        return shock_figure(profiles, chosen, vi, front, v0, title=title, saturation=saturation)


def summarize_folder(path: str | Path, figure: bool = True, wall_time: float | None = None) -> dict:
    """`RunFolder(path).summarize(...)` in one call (one entry into this module): the writer's
    hand-over of a run it ended."""
    return RunFolder(path).summarize(figure=figure, wall_time=wall_time)


def _select(traj: Trajectory, columns) -> Trajectory:
    if columns is None:
        return traj
    cols = list(columns)
    return Trajectory(traj.t, traj.x0[cols], traj.u[:, cols], traj.v[:, cols], traj.a[:, cols])
