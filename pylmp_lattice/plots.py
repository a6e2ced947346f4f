"""Figures of a run, in the layout of the paper's Fig. 3: functions of arrays, Axes returned.

matplotlib is imported lazily and with the non-interactive Agg backend where no backend was
chosen (`pyplot`), so plotting works on machines without a screen and shows in notebooks. `shock_figure` builds its Figure without pyplot (a third less to
import, and nothing for pyplot to keep): save it, or show it in a notebook as it is.
"""

from __future__ import annotations

import numpy as np

from . import measures


def pyplot():
    """matplotlib's pyplot, imported on first use (it costs a command 0.4 s), with the Agg
    backend (no screen needed) unless one was chosen already: through pyplot, or by the
    environment (MPLBACKEND, which Jupyter's kernel sets to its inline backend). Forcing Agg
    always, a panel drawn in a notebook left it showing no figure."""
    import os
    import sys

    import matplotlib

    if "matplotlib.pyplot" not in sys.modules and not os.environ.get("MPLBACKEND"):
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def style_figure(fig, what: str, quick: bool = False, stand_in: str | None = None, letters: str = "abcdefghijkl"):
    """The package's figure style: panel letters in reading order, and a title saying the case
    (`what`), whether it is a quick (small) version, and whether its impact is a stand-in.

    Panels are the figure's main axes (not twins or colour bars), ordered by row, then column;
    each gets "(letter)" at the left of its title, from `letters` (e.g. "bc" for a figure that
    reproduces the paper's panels (b) and (c)). Returns the figure."""
    for letter, ax in zip(letters, panels(fig)):
        ax.set_title(f"({letter})", loc="left", fontweight="bold")
    notes = (["quick version"] if quick else []) + ([f"stand-in impact: {stand_in}"] if stand_in else [])
    fig.suptitle(what + (f"\n[{'; '.join(notes)}]" if notes else ""))
    return fig


def panels(fig) -> list:
    """The figure's main axes in reading order: no twin axes (they share a panel), no colour bars."""
    main = []
    for ax in fig.axes:
        if ax.get_label() == "<colorbar>" or any(t in main for t in ax._twinned_axes.get_siblings(ax)):
            continue
        main.append(ax)
    # rows from the top (panels whose tops agree to 5 % of the figure), then left to right
    return sorted(main, key=lambda ax: (-round(ax.get_position().y1 * 20), ax.get_position().x0))


def twin_axis(ax, label: str, color: str = "C3"):
    """A right-hand axis for a second quantity, its label and ticks in `color`."""
    right = ax.twinx()
    right.set_ylabel(label, color=color)
    right.tick_params(axis="y", colors=color)
    return right


def separate(left, right, left_values, right_values, overlap: float = -0.2):
    """Twin-axis data kept readable: the left axis's data in the upper part of the panel, the
    right axis's in the lower part (overlapping by `overlap` of the height), each range set by
    its own finite values, and ticked over that part alone; a negative overlap leaves a gap for
    a legend."""
    for ax, values, (lo, hi) in ((left, left_values, (0.5 - overlap / 2, 0.97)),
                                 (right, right_values, (0.03, 0.5 + overlap / 2))):
        log = ax.get_yscale() == "log"
        v = np.asarray(values, float)
        v = v[np.isfinite(v) & (v > 0)] if log else v[np.isfinite(v)]
        if v.size == 0:
            continue
        v = np.log10(v) if log else v
        vmin, vmax = float(v.min()), float(v.max())
        span = (vmax - vmin) or abs(vmax) or 1.0
        scale = span / (hi - lo)
        limits = np.array([vmin - lo * scale, vmax + (1 - hi) * scale])
        ax.set_ylim(*(10**limits if log else limits))
        # ticks over its own part only: the experiment's first peak velocity axis read down to
        # -1.8 m/s, and Fig. 2(a)'s force axis down to 1e-7 N (its stiffness one up to 1e7 N/mm)
        inside = slice(vmin - 0.05 * span, vmax + 0.05 * span)
        if log:
            from matplotlib.ticker import FixedLocator

            decades = np.arange(np.floor(inside.start), np.ceil(inside.stop) + 1)
            minor = np.log10(np.outer(10**decades, np.arange(2, 10)).ravel())
            ax.yaxis.set_major_locator(FixedLocator(10**decades[(decades >= inside.start) & (decades <= inside.stop)]))
            ax.yaxis.set_minor_locator(FixedLocator(10**minor[(minor >= inside.start) & (minor <= inside.stop)]))
        else:
            from matplotlib.ticker import MaxNLocator

            ticks = MaxNLocator(nbins=5).tick_values(vmin, vmax)
            ax.set_yticks(ticks[(ticks >= inside.start) & (ticks <= inside.stop)])


def velocity_profiles(t, v, magnets, ax=None):
    """Fig. 3(a): v_n(t) of the chosen magnets (column k of v is magnet number magnets[k],
    1 .. N), m/s against ms."""
    ax = ax or pyplot().gca()
    for k, n in enumerate(magnets):
        ax.plot(t, v[:, k], lw=0.8, label=f"n = {n}")
    ax.set(xlabel="t (ms)", ylabel="v (m/s)")
    legend_above_data(ax, ncol=len(magnets))
    return ax


def propagation_velocity(vp, v0=None, ax=None, flagged: int = 0, drive_gap: bool = False):
    """Fig. 3(b): shock propagation velocity V_P over each gap (gap n: magnets n and n+1), in the
    gap frame (the gap's length r0 over its crossing time, as the paper's model counts it); NaN
    gaps are left out; `flagged`: how many were left out as flagged (`Front.accepted_velocity`:
    crossed out of order, or slower than any linear wave), and `drive_gap`: whether gap 1 was
    left out as the drive's (`Front.drive_gap`), said in the legend."""
    ax = ax or pyplot().gca()
    n = np.arange(1, len(vp) + 1)
    ax.plot(n, vp, ".", ms=3, label="$V_P$ over gap n")
    # short entries: a legend wider than the axes covers their label
    if flagged:
        ax.plot([], [], " ", label=f"{flagged} flagged gap{'s' if flagged > 1 else ''}, not drawn")
    if drive_gap:  # velocity or acceleration peak: either way magnet 1's is the drive's
        ax.plot([], [], " ", label="gap 1: the drive's, not drawn")
    if v0 is not None:
        ax.axhline(v0, color="k", ls=":", lw=1, label=f"$V_0$ = {v0:.3f} m/s")
    ax.set(xlabel="gap n (between magnets n and n+1)", ylabel="$V_P$, gap frame (m/s)")
    _integer_ticks(ax)
    ax.legend(fontsize="small")
    return ax


def first_peaks(peaks: measures.FirstPeaks, ax=None, saturation: float | None = None):
    """Fig. 3(c): first peak velocity (left axis, upper part) and acceleration (right axis,
    lower part) against n, with the level the first peaks saturate at (m/s; 2 V_I under a
    constant drive without friction) drawn when given."""
    ax = ax or pyplot().gca()
    n = np.arange(1, len(peaks.peak_velocity) + 1)
    handles = ax.plot(n, peaks.peak_velocity, "o", ms=2.5, color="C0", label="first peak velocity (left)")
    velocities = peaks.peak_velocity
    if saturation is not None:
        handles.append(ax.axhline(saturation, color="k", ls=":", lw=1, label=f"2 $V_I$ = {saturation:g} m/s"))
        velocities = np.append(velocities, saturation)
    ax.set(xlabel="magnet n", ylabel="first peak velocity (m/s)")
    _integer_ticks(ax)
    right = twin_axis(ax, "first peak acceleration (m/s$^2$)")
    handles += right.plot(n, peaks.peak_acceleration, "s", ms=2, mfc="none", color="C3",
                          label="first peak acceleration (right)")
    separate(ax, right, velocities, peaks.peak_acceleration)
    ax.legend(handles=handles, fontsize="small", loc="center right")
    return ax


def oscillation_peaks(t, v, magnets, drive_velocity, ax=None):
    """Fig. 3(d): velocity maxima (up triangles) and minima (down triangles) behind the front
    against time (columns of v as in `velocity_profiles`)."""
    ax = ax or pyplot().gca()
    for k, n in enumerate(magnets):
        osc = measures.oscillations(t, v[:, k], drive_velocity)
        ax.plot(osc.max_time, osc.max_velocity, "^", ms=3, color=f"C{k}", label=f"n = {n}")
        ax.plot(osc.min_time, osc.min_velocity, "v", ms=3, color=f"C{k}")
    # marker key: grey stand-ins for the two marker shapes
    ax.plot([], [], "^", ms=4, color="0.4", label="maxima")
    ax.plot([], [], "v", ms=4, color="0.4", label="minima")
    ax.set(xlabel="t (ms)", ylabel="peak velocity (m/s)")
    legend_above_data(ax, ncol=3)
    return ax


def legend_above_data(ax, ncol: int, row: float = 0.075):
    """The legend in `ncol` columns at the top of the axes, in headroom made for it: the y range
    grows so that the data keep below its rows (`row`: a row's share of the axes height, small
    font). A long run's traces fill the whole panel, and a legend anywhere inside covered them."""
    handles, labels = ax.get_legend_handles_labels()
    rows = -(-len(labels) // ncol)
    low, high = ax.get_ylim()
    share = 1 - rows * row - 0.03  # what the data keep of the height
    ax.set_ylim(low, low + (high - low) / share)
    ax.legend(handles, labels, loc="upper left", ncol=ncol, fontsize="small", columnspacing=1.0, handlelength=1.5)


def shock_figure(profiles, magnets, drive_velocity: float, front: measures.Front, v0: float | None = None,
                 title: str | None = None, saturation: float | None = None,
                 missing: str = "no trajectory written\n(output.format = 'none')"):
    """The four panels of Fig. 3(a-d), lettered, under `title`; returns the Figure.

    profiles: a Trajectory of the chosen magnets (their numbers, 1 .. N, in `magnets`) for
    panels (a) and (d), or None for a run without one (those panels then say `missing`);
    front: the run's front measures for panels (b) and (c), flagged gaps and the drive's gap
    left out (`Front.accepted_velocity`); saturation: the first peaks' limit (2 V_I for a
    constant drive without friction; None: no such line, e.g. for a pulse)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 8))
    # fixed margins: a constrained layout would cost more than drawing the panels
    axes = fig.subplots(2, 2, gridspec_kw={"left": 0.07, "right": 0.93, "bottom": 0.07, "top": 0.92,
                                           "wspace": 0.4, "hspace": 0.3})
    if profiles is None:  # the panels' axes as they would be, no ticks: they would number nothing
        for ax, ylabel in ((axes[0, 0], "v (m/s)"), (axes[1, 1], "peak velocity (m/s)")):
            ax.text(0.5, 0.5, missing, ha="center", va="center",
                    transform=ax.transAxes)
            ax.set(xlabel="t (ms)", ylabel=ylabel, xticks=[], yticks=[])
    else:
        velocity_profiles(profiles.t, profiles.v, magnets, axes[0, 0])
        oscillation_peaks(profiles.t, profiles.v, magnets, drive_velocity, axes[1, 1])
    flagged = int(np.sum(front.out_of_order | front.below_linear_speed))
    propagation_velocity(front.accepted_velocity, v0, axes[0, 1], flagged, bool(front.drive_gap[0]))
    first_peaks(front.peaks, axes[1, 0], saturation=saturation)
    for letter, ax in zip("abcd", axes.flat):
        ax.set_title(f"({letter})", loc="left", fontweight="bold", y=1.01)  # a fixed y: no search for the tick labels
    if title:
        fig.suptitle(title)
    return fig


def _integer_ticks(ax):
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
