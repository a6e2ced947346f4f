"""Statistics over replicas: mean and standard error of each measure per parameter point."""

from __future__ import annotations

import numpy as np
import pandas as pd


# Columns that label a member rather than its parameter point.
REPLICA_COLUMNS = ("replica", "chain.seed")


def replica_stats(table: pd.DataFrame, measures: list[str] | None = None) -> pd.DataFrame:
    """Per parameter point (the swept columns without replica and seed), over its done members:
    `n`, and for each measure `<measure>.mean` and `<measure>.sem` (standard error of the mean,
    std with ddof=1 over sqrt(n); NaN for a single replica).

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
            values = group[name].astype(float).dropna()
            row[f"{name}.mean"] = values.mean() if len(values) else np.nan
            row[f"{name}.sem"] = values.std(ddof=1) / np.sqrt(len(values)) if len(values) > 1 else np.nan
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
