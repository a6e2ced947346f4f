"""Statistics over replicas: mean and standard error of each measure per parameter point."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pandas as pd

from .store import atomic_write


# Columns that label a member rather than its parameter point.
REPLICA_COLUMNS = ("replica", "chain.seed")
STATS_CSV, STATS_PNG = "replica_stats.csv", "replica_stats.png"


def replica_stats(table: pd.DataFrame, measures: list[str] | None = None) -> pd.DataFrame:
    """Per parameter point (the swept columns without replica and seed), over its done members:
    `n`, and for each measure `<measure>.mean`, `<measure>.sem` (standard error of the mean,
    std with ddof=1 over sqrt(count); NaN for a single value) and `<measure>.count`, the number
    of finite values used (a measure can be missing or infinite in some members, e.g. V_P
    where two arrivals coincide).

    measures: numeric columns to summarise (default: every numeric measure column).
    """
    done = table[table["status"] == "done"]
    start = list(table.columns).index("status")
    point = [c for c in table.columns[1:start] if c not in REPLICA_COLUMNS]
    if measures is None:
        after = list(table.columns)[list(table.columns).index("wall_time_s") + 1:]
        measures = [c for c in after if pd.api.types.is_numeric_dtype(table[c]) and not pd.api.types.is_bool_dtype(table[c])]
    groups = done.groupby(point, sort=False, dropna=False) if point else [((), done)]
    rows = []
    for key, group in groups:
        row = dict(zip(point, key if isinstance(key, tuple) else (key,)))
        row["n"] = len(group)
        for name in measures:
            values = group[name].to_numpy(float)
            values = values[np.isfinite(values)]
            row[f"{name}.mean"] = values.mean() if len(values) else np.nan
            row[f"{name}.sem"] = values.std(ddof=1) / np.sqrt(len(values)) if len(values) > 1 else np.nan
            row[f"{name}.count"] = len(values)
        rows.append(row)
    return pd.DataFrame(rows)


def plot_replica_stats(stats: pd.DataFrame, x: str, measure: str, ax=None, **kwargs):
    """`measure` mean against column `x` with standard-error bars (as the paper's Fig. 4); returns the Axes."""
    if ax is None:
        import matplotlib.pyplot as plt

        ax = plt.figure().add_subplot()
    data = stats.sort_values(x)
    mean, sem = (data[f"{measure}.{s}"].to_numpy(float) for s in ("mean", "sem"))
    ax.errorbar(data[x].to_numpy(), mean, yerr=sem, fmt=kwargs.pop("fmt", "o-"),
                capsize=kwargs.pop("capsize", 3), **kwargs)
    ax.set_xlabel(x)
    ax.set_ylabel(measure)
    return ax


def write_replica_stats(root: str | Path, table: pd.DataFrame, panels: int = 6) -> pd.DataFrame:
    """DIR/replica_stats.csv, and DIR/replica_stats.png: the first `panels` measures that scatter
    between replicas, against the first numeric swept field (or the point number), with
    standard-error bars. Returns the statistics."""
    from matplotlib.figure import Figure

    root = Path(root)
    stats = replica_stats(table)
    atomic_write(root / STATS_CSV, stats.to_csv(index=False))
    point = list(stats.columns[:list(stats.columns).index("n")])
    numeric = [c for c in point if pd.api.types.is_numeric_dtype(stats[c])]
    x = numeric[0] if numeric else "point"
    if not numeric:
        stats = stats.assign(point=np.arange(len(stats)))
    scatter = [c[:-4] for c in stats.columns if c.endswith(".sem") and np.nanmax(stats[c].to_numpy(float), initial=0) > 0]
    shown = scatter[:panels]
    if shown:
        fig = Figure(figsize=(4.5 * min(len(shown), 3), 3.2 * -(-len(shown) // 3)), layout="constrained")
        axes = fig.subplots(-(-len(shown) // 3), min(len(shown), 3), squeeze=False).ravel()
        for ax, measure in zip(axes, shown):
            plot_replica_stats(stats, x, measure, ax=ax)
        for ax in axes[len(shown):]:
            ax.set_visible(False)
        buffer = io.BytesIO()
        fig.savefig(buffer, format="png", dpi=100)
        atomic_write(root / STATS_PNG, buffer.getvalue())
    return stats
