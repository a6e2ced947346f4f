"""Statistics over replicas: mean and standard error of each measure per parameter point.

Only outcomes are averaged (`MEASURES`: V_P, the first peak, ...), never the inputs a member's
summary repeats (V_I, V0, f0, N). A plateau counts only from the members where it converged
(its `.converged` column), so every statistic states its coverage, the values used of the
members run (done or failed: a member that failed, e.g. a chain whose draw brought two magnets
into contact, is an outcome of its draw too): a mean over the members that converged, or that
did not fail, is biased whenever that depends on the draw (under 10 % mass disorder 2 of 8
long-lattice plateaus converged; under 30 % mass disorder 11 of 20 experiments touched). Below
COVERAGE_LIMIT the table marks the statistic (`.low_coverage`), the figure draws it hollow and
a warning names it. The headline speed, `front_speed_m_per_s.value` (`summary.front_window`:
a fixed window of gaps, no plateau criterion), is defined for every member whose front crossed
that window.
"""

from __future__ import annotations

import io
import logging
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import UsageError
from .store import atomic_write
from .table import STATS_CSV, STATS_PNG

log = logging.getLogger(__name__)


# Columns that label a member rather than its parameter point.
REPLICA_COLUMNS = ("replica", "chain.seed")
# The table columns averaged by default: column -> (name, unit).
MEASURES = {
    "front_speed_m_per_s.value": ("front speed, fixed gap window", "m/s"),
    "shock_velocity_plateau_m_per_s.mean": ("shock velocity plateau $V_P$", "m/s"),
    "first_peak_velocity_plateau_m_per_s.mean": ("first peak velocity, plateau", "m/s"),
    "shock_velocity_max_m_per_s.value": ("largest $V_P$", "m/s"),
    "particles_reached_by_front": ("magnets reached by the front", None),
    "friction_dissipated_energy_mJ": ("energy taken by friction", "mJ"),
}
# A statistic over fewer than this fraction of the members run (done or failed) is marked (table, figure, warning).
COVERAGE_LIMIT = 0.9
# Names and units of the fields a sweep commonly varies (any other is shown by its key).
FIELDS = {
    "impactor.velocity": ("impactor velocity $V_I$", "m/s"),
    "impactor.duration": ("pulse duration $T_s$", "ms"),
    "chain.thermal_velocity": ("thermal RMS velocity", "m/s"),
    "chain.mass_disorder": ("mass disorder (relative std)", None),
    "chain.r0_disorder": ("gap disorder (relative std)", None),
    "chain.particles": ("magnets N", None),
    "friction.mu": (r"friction $\mu$", None),
    "friction.p": ("friction $p$", None),
    "friction.g": ("friction $g$", "m/s^2"),
    "force.q": ("force law power q", None),
    "run.duration": ("run length", "ms"),
}


def label(column: str) -> str:
    """An axis label for a table column: its name and unit, e.g. "impactor velocity $V_I$ (m/s)"."""
    name, unit = MEASURES.get(column) or FIELDS.get(column) or (column, None)
    return f"{name} ({unit})" if unit else name


def replica_stats(table: pd.DataFrame, measures: list[str] | None = None) -> pd.DataFrame:
    """Per parameter point (the swept columns without replica and seed), over its members run:
    `n` (done members), `failed` (failed members), and for each measure `<measure>.mean`,
    `<measure>.sem` (standard error of the mean, std with ddof=1 over sqrt(count); NaN for a
    single value) and `<measure>.count`, the number of values used: finite, and, for a plateau (a
    measure `X.mean` beside a column `X.converged`), from members where it converged;
    `<measure>.coverage`, count / (n + failed), and `<measure>.low_coverage`, True below
    COVERAGE_LIMIT (a mean over some members only). A point with no member run has n = 0,
    counts 0, NaN means and coverage: nothing to average.

    measures: columns to summarise (default: those of `MEASURES` in the table).
    """
    if not hasattr(table, "columns") or "status" not in table.columns:
        raise UsageError("table", f"got {type(table).__name__}; expected a sweep's table (`load_results`, `run_sweep`)")
    start = list(table.columns).index("status")
    point = [c for c in table.columns[1:start] if c not in REPLICA_COLUMNS]
    if measures is None:
        measures = [c for c in MEASURES if c in table.columns]
    groups = table.groupby(point, sort=False, dropna=False) if point else [((), table)]
    rows = []
    for key, members in groups:
        status = members["status"].to_numpy()
        group = members[status == "done"]
        row = dict(zip(point, key if isinstance(key, tuple) else (key,)))
        row["n"], row["failed"] = len(group), int((status == "failed").sum())
        run = row["n"] + row["failed"]
        for name in measures:
            values = used_values(group, name)
            row[f"{name}.mean"] = values.mean() if len(values) else np.nan
            row[f"{name}.sem"] = standard_error(values)
            row[f"{name}.count"] = len(values)
            row[f"{name}.coverage"] = len(values) / run if run else np.nan
            row[f"{name}.low_coverage"] = _low_coverage(len(values), run)
        rows.append(row)
    columns = point + ["n", "failed"] + [f"{name}.{s}" for name in measures for s in STATISTICS]
    return pd.DataFrame(rows, columns=columns)


STATISTICS = ("mean", "sem", "count", "coverage", "low_coverage")  # the columns of each measure


def _low_coverage(count: int, members: int | None) -> bool:
    """Whether `count` values of `members` run fall below COVERAGE_LIMIT (never with no members)."""
    return bool(members) and count < COVERAGE_LIMIT * members


def low_coverage_warnings(stats: pd.DataFrame) -> list[str]:
    """One line per measure whose statistic is marked low_coverage at some point: how many
    points, the lowest coverage, and at how many points no member has a value (no mean)."""
    lines = []
    for column in [c for c in stats.columns if c.endswith(".low_coverage")]:
        low = stats[column].to_numpy(bool)
        if low.any():
            name = column.removesuffix(".low_coverage")
            worst = stats.loc[low, f"{name}.coverage"].min()
            none = int((stats.loc[low, f"{name}.count"] == 0).sum())
            lines.append(f"{name}: below {COVERAGE_LIMIT:.0%} coverage at {int(low.sum())} of {len(stats)} points "
                         f"(lowest {worst:.0%} of the members run, failed ones counted): a mean over the members "
                         "with a value only (converged, not failed)"
                         + (f"; no member has one at {none} point{'s' if none > 1 else ''} (no mean)" if none else ""))
    return lines


def standard_error(values: np.ndarray) -> float:
    """The standard error of the mean: std with ddof=1 over sqrt(count); NaN for fewer than two values."""
    return values.std(ddof=1) / np.sqrt(len(values)) if len(values) > 1 else np.nan


def used_values(members: pd.DataFrame, name: str) -> np.ndarray:
    """The values of column `name` that a mean uses: finite, and for a plateau (`X.mean` beside
    `X.converged`) only where it converged. `members`: done members."""
    values = members[name].to_numpy(float)
    keep = np.isfinite(values)
    converged = name.removesuffix(".mean") + ".converged"
    if name.endswith(".mean") and converged in members.columns:
        keep &= members[converged].to_numpy() == True  # noqa: E712 (a column of True, False or NaN)
    return values[keep]


def _counted(used: np.ndarray) -> str:
    low, high = int(np.min(used)), int(np.max(used))
    return f"{low} values" if low == high else f"{low}-{high} values"


def plot_replica_stats(stats: pd.DataFrame, x: str, measure: str, ax=None, by: list[str] | None = None,
                       lines: int = 8, legend: bool = True, **kwargs):
    """`measure` mean against column `x` with standard-error bars and the replicas' ± std as a
    band (as the paper's Fig. 4), one line per combination of the columns `by`, both axes
    labelled with name and unit; returns the Axes.

    by: default, the other swept columns (those before `n`) that vary at some value of `x`,
    when `x` is one of them (a column zipped with `x` goes with it); points differing in one of
    these are never joined. Only the first `lines` combinations (in
    the table's order) are drawn, the title says so. legend: name each line's values (when
    there are several lines).
    """
    means = [c.removesuffix(".mean") for c in stats.columns if c.endswith(".mean") and c[:-5] + ".sem" in stats.columns]
    if measure not in means:
        raise ValueError(f"measure {measure!r}: not in the statistics; available: {', '.join(means) or 'none'}")
    if x not in stats.columns:
        raise ValueError(f"x {x!r}: not a column of the statistics; available: {', '.join(stats.columns)}")
    if ax is None:
        import matplotlib.pyplot as plt

        ax = plt.figure().add_subplot()
    if by is None:  # the swept columns that vary at some x (one zipped with x does not: it goes with x)
        swept = list(stats.columns[:list(stats.columns).index("n")]) if "n" in stats.columns else []
        by = [c for c in swept if c != x and stats.groupby(x, dropna=False)[c].nunique(dropna=False).max() > 1]
        by = by if x in swept else []
    groups = list(stats.groupby(by, sort=False, dropna=False)) if by else [((), stats)]
    fmt, capsize, name = kwargs.pop("fmt", "o-"), kwargs.pop("capsize", 3), kwargs.pop("label", None)
    names = _legend_names(by)
    counts, lows, empty = [], 0, []
    for key, data in groups[:lines]:
        data = data.sort_values(x)
        mean, sem, count = (data[f"{measure}.{s}"].to_numpy(float) for s in ("mean", "sem", "count"))
        std = sem * np.sqrt(count)  # the replicas' own scatter
        values = dict(zip(by, key if isinstance(key, tuple) else (key,)))
        line = ax.errorbar(data[x].to_numpy(), mean, yerr=sem, fmt=fmt, capsize=capsize,
                           label=names(values) if by else name, **kwargs)
        color = line[0].get_color()
        ax.fill_between(data[x].to_numpy(), mean - std, mean + std, color=color, alpha=0.15, lw=0)
        low = _low(data, measure)
        if low.any():  # a mean over some members only: hollow (in the line's colour: the cycle moves on once a line)
            ax.plot(data[x].to_numpy()[low], mean[low], "o", color=color, mfc="white", mec=color, zorder=3)
            lows += int(low.sum())
        for at in data[x].to_numpy()[count == 0]:  # no member has a value there: said where the point would be
            ax.axvline(at, color=color, ls=":", lw=0.8)
            empty.append(at)
        counts.append(count)
    ax.set_xlabel(label(x))
    ax.set_ylabel(label(measure))
    _no_offset(ax.yaxis)
    shown = f"; first {lines} of {len(groups)} lines" if len(groups) > lines else ""
    hollow = f"; hollow: under {COVERAGE_LIMIT:.0%} of members" if lows else ""
    # (a line of its own: the panel's title is as wide as the panel)
    none = f"\ndotted: no value at {', '.join(map(_shown, sorted(set(empty), key=str)))}" if empty else ""
    ax.set_title(f"mean ± standard error (bars), ± std of the replicas (band)\n"
                 f"{_counted(np.concatenate(counts))} per point{shown}{hollow}{none}", fontsize="small")
    if legend and len(groups) > 1:
        ax.legend(fontsize="x-small")
    return ax


def _shown(value) -> str:
    """A swept value as a title gives it: a number shortest (%g), anything else as text."""
    return f"{value:g}" if isinstance(value, (int, float, np.number)) and not isinstance(value, bool) else str(value)


def _low(stats: pd.DataFrame, measure: str) -> np.ndarray:
    """Where `measure`'s statistic is marked low_coverage (False where the column is missing:
    statistics from before coverage was recorded)."""
    column = f"{measure}.low_coverage"
    return stats[column].to_numpy(bool) if column in stats.columns else np.zeros(len(stats), bool)


def _legend_names(columns: list[str]):
    """A function giving a line's legend entry from its values of `columns`: each field's name,
    value and unit, e.g. "pulse duration $T_s$ 30 ms"; the columns of a section swept as a
    whole under its name once, "friction $\\mu$ 0.285, $p$ 0.012"."""
    sections: dict[str, list[str]] = {}
    for column in columns:
        sections.setdefault(column.split(".")[0], []).append(column)

    def entry(column: str, values: dict, section: str | None = None) -> str:
        name, unit = FIELDS.get(column) or (column.split(".", 1)[-1] if section else column, None)
        if section and name.startswith(section + " "):
            name = name[len(section) + 1:]
        return f"{name} {_shown(values[column])}" + (f" {unit}" if unit else "")

    def names(values: dict) -> str:
        return "; ".join(entry(group[0], values) if len(group) == 1 else
                         f"{section} " + ", ".join(entry(c, values, section) for c in group)
                         for section, group in sections.items())
    return names


def plot_replica_spread(values: np.ndarray, measure: str, ax=None, members: int | None = None):
    """One parameter point: the histogram of a measure over its replicas (`used_values`, of
    `members` run, done or failed), the mean and its standard error marked, the axis labelled
    with name and unit; returns the Axes."""
    if ax is None:
        import matplotlib.pyplot as plt

        ax = plt.figure().add_subplot()
    mean = values.mean()
    error = standard_error(values)
    # ax.hist's bins as one step patch, not a rectangle a bin: 0.09 s less CPU of the 10^4-member
    # sweep's figure (0.43 -> 0.34 s)
    counts, edges = np.histogram(values, bins=min(30, max(5, len(values) // 10)))
    ax.stairs(counts, edges, fill=True, color="0.7")
    ax.axvline(mean, color="C0")
    if np.isfinite(error):
        ax.axvspan(mean - error, mean + error, color="C0", alpha=0.3, lw=0)
    _no_offset(ax.xaxis)
    ax.set_xlabel(label(measure))
    ax.set_ylabel("replicas")
    used = f"{len(values)} of {members} replicas" if members is not None else f"{len(values)} values"
    if _low_coverage(len(values), members):
        used += f" (coverage {len(values) / members:.0%}, below {COVERAGE_LIMIT:.0%})"
    unit = MEASURES.get(measure, (None, None))[1]
    spread = f" ± {error:.2g}" if np.isfinite(error) else ""
    ax.set_title(f"{used}\nmean {mean:.5g}{spread}{' ' + unit if unit else ''} (± standard error)", fontsize="small")
    return ax


def _no_offset(axis) -> None:
    """Tick labels as the values are, not "1e-4 + 4.634" (a linear axis; others have no offset)."""
    from matplotlib.ticker import ScalarFormatter

    formatter = axis.get_major_formatter()
    if isinstance(formatter, ScalarFormatter):
        formatter.set_useOffset(False)


# A panel of the replica statistics figure, inches, and the margins of its axes in it (left,
# right, bottom, top: tick labels, axis labels, title). A fixed layout: matplotlib's constrained
# layout measures every text and would double the figure's cost (0.2-0.4 s).
PANEL = (4.5, 3.2)
MARGINS = (0.85, 0.15, 0.55, 0.5)
# The legend below the panels (one for all: their lines are the same combinations), inches at
# fontsize "small": a line of text, the space between entries, a character, the handle and the
# margin under the legend (estimates from the font size, not measured: a fixed layout).
LEGEND_LINE, LEGEND_GAP, LEGEND_CHAR, LEGEND_HANDLE, LEGEND_MARGIN = 0.15, 0.06, 0.065, 0.7, 0.2


def _panel(row: int, col: int, cols: int, rows: int, below: float = 0.0) -> list[float]:
    """The axes rectangle of panel (row, col), as fractions of the figure; `below`: inches kept
    free under the panels."""
    (w, h), (left, right, bottom, top) = PANEL, MARGINS
    height = rows * h + below
    return [(col * w + left) / (cols * w), 1 - ((row + 1) * h - bottom) / height,
            (w - left - right) / (cols * w), (h - bottom - top) / height]


def _legend_below(fig, axes: list, cols: int, rows: int) -> None:
    """One legend for all panels under them, in as many columns as the entries' estimated width
    allows (an entry wider than the figure on one line per field); the figure grows by its
    height and the panels keep their size."""
    handles, labels = axes[0].get_legend_handles_labels()
    if len(labels) < 2:
        return
    width, lines = PANEL[0] * cols, 1
    if _entry_width(labels) > width:
        labels = [text.replace("; ", "\n") for text in labels]
        lines = max(text.count("\n") + 1 for text in labels)
    ncols = int(max(1, min(len(labels), width // _entry_width(labels))))
    below = (LEGEND_LINE * lines + LEGEND_GAP) * -(-len(labels) // ncols) + LEGEND_MARGIN
    height = PANEL[1] * rows + below
    fig.set_size_inches(width, height)
    for k, ax in enumerate(axes):
        ax.set_position(_panel(k // cols, k % cols, cols, rows, below))
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, below / height), ncols=ncols,
               fontsize="small", frameon=False)


def _entry_width(labels: list[str]) -> float:
    """Inches of the widest legend entry, estimated from its characters (mathtext's $, \\ and
    braces left out)."""
    chars = max(len(re.sub(r"[$\\{}_^]", "", line)) for text in labels for line in text.split("\n"))
    return LEGEND_HANDLE + LEGEND_CHAR * chars


def warm_up() -> None:
    """A panel of the replica figure drawn with made-up values and dropped: matplotlib's first
    drawing finds and loads the fonts and builds the mathtext parser, some 0.05-0.1 s of the
    figure that a sweep's command draws after its last member, which its coordinator spends
    while the workers run instead (`execute._preload`)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=PANEL)
    ax = fig.add_axes(_panel(0, 0, 1, 1))
    plot_replica_spread(np.linspace(4.0, 4.1, 50), "shock_velocity_plateau_m_per_s.mean", ax=ax, members=50)
    FigureCanvasAgg(fig).draw()


@dataclass(frozen=True)
class Drawn:
    """The replica statistics made and drawn, not yet written (`draw_replica_stats`): the
    statistics `write_replica_stats` returns, replica_stats.csv's text, the low-coverage
    warnings and replica_stats.png's bytes (None: no measure scatters)."""

    stats: pd.DataFrame
    csv: str
    warnings: list[str]
    png: bytes | None


def draw_replica_stats(table: pd.DataFrame, measures: list[str] | None = None, panels: int = 6) -> Drawn:
    """What `write_replica_stats` writes, made without writing it (no I/O: a sweep's command
    draws it while the table's files are written, `execute.ReplicaDrawing`)."""
    from matplotlib.figure import Figure

    stats = replica_stats(table, measures)
    csv, warnings = stats.to_csv(index=False), low_coverage_warnings(stats)
    point = list(stats.columns[:list(stats.columns).index("n")])
    # the first numeric swept column whose values differ between points (a section swept whole
    # has columns that stay put, e.g. force.K when only force.q changes: no axis)
    numeric = [c for c in point if pd.api.types.is_numeric_dtype(stats[c]) and stats[c].nunique(dropna=False) > 1]
    x = numeric[0] if numeric else "point"
    if not numeric:
        stats = stats.assign(point=np.arange(len(stats)))
    scatter = [c[:-4] for c in stats.columns if c.endswith(".sem") and np.nanmax(stats[c].to_numpy(float), initial=0) > 0]
    shown = scatter[:panels]
    if not shown:
        return Drawn(stats, csv, warnings, None)
    cols, rows = min(len(shown), 3), -(-len(shown) // 3)
    fig = Figure(figsize=(PANEL[0] * cols, PANEL[1] * rows))
    done = table[table["status"] == "done"]
    axes = [fig.add_axes(_panel(k // cols, k % cols, cols, rows)) for k in range(len(shown))]
    for ax, measure in zip(axes, shown):
        if len(stats) == 1:
            plot_replica_spread(used_values(done, measure), measure, ax=ax, members=int(stats["n"][0] + stats["failed"][0]))
        else:
            plot_replica_stats(stats, x, measure, ax=ax, legend=False)
    _legend_below(fig, axes, cols, rows)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100)
    return Drawn(stats, csv, warnings, buffer.getvalue())


def write_replica_stats(root: str | Path, table: pd.DataFrame, measures: list[str] | None = None,
                        panels: int = 6, drawn: Drawn | None = None) -> pd.DataFrame:
    """DIR/replica_stats.csv, and DIR/replica_stats.png: the first `panels` measures that scatter
    between replicas, against the first numeric swept field that varies (or the point number), with
    standard-error bars, one line per combination of the other swept fields that vary (the
    first 8; one legend under the panels names them); with one parameter point, each one's
    histogram over the replicas. Returns the statistics. drawn: `draw_replica_stats` of these
    arguments, if already made."""
    root = Path(root)
    drawn = drawn or draw_replica_stats(table, measures, panels)
    atomic_write(root / STATS_CSV, drawn.csv, sync=True)
    for line in drawn.warnings:
        log.warning("%s", line)
    if drawn.png is not None:
        atomic_write(root / STATS_PNG, drawn.png, sync=True)
    else:  # an earlier figure would no longer show this table
        (root / STATS_PNG).unlink(missing_ok=True)
    return drawn.stats
