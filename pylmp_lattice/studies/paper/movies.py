"""Movies S1 and S2: animations of the magnets, as MP4 where ffmpeg is available, else GIF.

S1: the 21-magnet experiment (`scaffold.experiment_case`, the run of `fig1`): the magnets on the rod, coloured by
velocity, over the 60 ms of the run. S2: the long lattice at V_I = 2 m/s (the run of `fig3`):
particle velocity against particle number with the front and the settled particles marked, so
the transition zone between them is seen to grow. Quick: 6 frames, and 100 ms of the long lattice.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import numpy as np

from ... import measures
from ...formats.files import replacing
from ...plots import pyplot, style_figure
from ...run_folder import simulate
from ..output import StudyResult
from ..scaffold import EXPERIMENT_STAND_IN, experiment_case, paper_case

NAME = "movies"
log = logging.getLogger(__name__)


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    from matplotlib import animation

    plt = pyplot()
    fmt = "mp4" if animation.writers.is_available("ffmpeg") else "gif"
    frames = 6 if quick else 150
    fps = 15
    out.mkdir(parents=True, exist_ok=True)
    files, stills = {}, []

    case = experiment_case()
    log.info("movies: running %s for Movie S1 (%g ms)", case.name, case.run.duration)
    traj = simulate(case, out / NAME / case.name, overwrite=True, progress=True)
    fig, anim = _movie_s1(plt, traj, _frames(traj.t, frames))
    files["S1"] = _save(anim, out / f"movie_S1.{fmt}", fmt, fps)
    stills.append(fig)

    duration = 100.0 if quick else 600.0
    vi = 2.0
    case = paper_case("movie_long_lattice", {"profile": "constant", "velocity": vi}, duration)
    log.info("movies: running %s for Movie S2 (%d magnets, %g ms)", case.name, case.chain.particles, duration)
    traj = simulate(case, out / NAME / case.name, overwrite=True, progress=True)
    arrival = measures.arrival_times(traj.t, traj.v, vi)
    reached = measures.particles_reached(arrival)
    steady = measures.steady_oscillation(traj.t, traj.v[:, 9], vi, (0.8 * duration, duration))
    onset = measures.steady_onset_times(traj.t, traj.v[:, :reached], vi, (steady.max_velocity, steady.min_velocity))
    fig, anim = _movie_s2(plt, traj, vi, arrival[:reached], onset, _frames(traj.t, frames))
    files["S2"] = _save(anim, out / f"movie_S2.{fmt}", fmt, fps)
    stills.append(fig)

    # the last frame of S2 stands for the movies in NAME.png, its frame's title as the figure's (once)
    ax = stills[1].axes[0]
    what = ax.get_title().replace("Movie S2 (model): ", "Movie S2 (model), last frame: ")
    ax.set_title("")
    still = style_figure(stills[1], what, quick=quick, letters="")
    numbers = {"stand_in_impact_S1": EXPERIMENT_STAND_IN,
               "format": fmt, "frames": frames, "fps": fps, "movie_files": {k: p.name for k, p in files.items()},
               "ffmpeg_available": fmt == "mp4"}
    return StudyResult(NAME, numbers, figure=still, quick=quick)


def _frames(t, count):
    return np.linspace(0, len(t) - 1, count).round().astype(int)


def _save(anim, path: Path, fmt: str, fps: int) -> Path:
    from matplotlib import animation

    writer = animation.FFMpegWriter(fps=fps) if fmt == "mp4" else animation.PillowWriter(fps=fps)
    quiet = logging.getLogger("matplotlib.animation")  # its "Animation.save using <class ...>" info line
    level = quiet.level
    quiet.setLevel(logging.WARNING)
    try:
        with _progress(path.name) as step, replacing(path) as tmp:
            anim.save(tmp, writer=writer, dpi=80, progress_callback=step)
    finally:
        quiet.setLevel(level)
    return path


class _progress:
    """Frames drawn so far: a bar on a terminal (tqdm), else a log line at each quarter, so a
    log file gets plain lines and no carriage returns."""

    def __init__(self, name: str):
        self.name, self.bar, self.said = name, None, 0

    def __enter__(self):
        return self.step

    def step(self, frame: int, total: int) -> None:
        if sys.stderr.isatty():
            if self.bar is None:
                from tqdm import tqdm

                self.bar = tqdm(total=total, desc=f"movie {self.name}", unit="frame", file=sys.stderr, leave=False)
            self.bar.update(frame + 1 - self.bar.n)
        elif 4 * (frame + 1) >= (self.said + 1) * total:
            self.said = 4 * (frame + 1) // total
            log.info("movie %s: %d/%d frames", self.name, frame + 1, total)

    def __exit__(self, *exc):
        if self.bar is not None:
            self.bar.close()


def _movie_s1(plt, traj, frames):
    from matplotlib import animation

    x = traj.x0 + traj.u
    vmax = float(np.max(np.abs(traj.v)))
    fig, ax = plt.subplots(figsize=(10, 2.4), layout="constrained")
    ax.axhline(0, color="0.6", lw=2, zorder=0)  # the rod
    dots = ax.scatter(x[0], np.zeros(x.shape[1]), c=traj.v[0], cmap="coolwarm", vmin=-vmax, vmax=vmax, s=120,
                      marker="s", edgecolors="k")
    fig.colorbar(dots, ax=ax, label="v (m/s)")
    label = ax.set_title("")
    ax.set(xlim=(x.min() - 10, x.max() + 10), ylim=(-1, 1), xlabel="x (mm)", yticks=[])

    def draw(i):
        dots.set_offsets(np.column_stack([x[i], np.zeros(x.shape[1])]))
        dots.set_array(traj.v[i])
        label.set_text(f"Movie S1 (model, stand-in impact): 21 magnets, t = {traj.t[i]:.1f} ms")
        return dots, label

    anim = animation.FuncAnimation(fig, draw, frames=frames, blit=False)
    draw(frames[-1])
    return fig, anim


def _movie_s2(plt, traj, vi, arrival, onset, frames):
    from matplotlib import animation

    n = np.arange(1, traj.v.shape[1] + 1)
    last = len(arrival) + 10
    fig, ax = plt.subplots(figsize=(10, 4), layout="constrained")
    (line,) = ax.plot(n[:last], traj.v[0, :last], lw=0.8)
    front = ax.axvline(0, color="C3", lw=1, label="front")
    settled = ax.axvline(0, color="C2", lw=1, label="settled (steady oscillation)")
    ax.axhline(vi, color="k", ls=":", lw=0.8, label="$V_I$")
    ax.set(xlim=(1, last), ylim=(-0.2, 2.2 * vi), xlabel="magnet n", ylabel="v (m/s)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize="small")  # beside the axes: never on the data
    label = ax.set_title("")

    def draw(i):
        t = traj.t[i]
        line.set_ydata(traj.v[i, :last])
        reached = np.flatnonzero(arrival <= t)
        done = np.flatnonzero(onset <= t)
        front.set_xdata([reached[-1] + 1 if reached.size else 0] * 2)
        settled.set_xdata([done[-1] + 1 if done.size else 0] * 2)
        width = (reached[-1] - done[-1]) if reached.size and done.size else 0
        label.set_text(f"Movie S2 (model): long lattice, $V_I$ = {vi:g} m/s, t = {t:.0f} ms, "
                       f"transition zone {width} magnets")
        return line, front, settled, label

    anim = animation.FuncAnimation(fig, draw, frames=frames, blit=False)
    draw(frames[-1])
    return fig, anim
