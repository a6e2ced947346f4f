"""Replica statistics: outcomes only, converged plateaus only, counts, labelled plots."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from pylmp_lattice.sweep import plot_replica_stats, replica_stats, write_replica_stats
from pylmp_lattice.sweep.stats import label

VP = "shock_velocity_plateau_m_per_s"
PEAK = "first_peak_velocity_plateau_m_per_s"


def _table():
    """Two points x 4 replicas; replica 3 of each has a V_P plateau that did not converge (a
    wild value that must not enter the mean), and one member failed."""
    rows = []
    for vi in (1.5, 2.0):
        for r in range(4):
            rows.append({"id": f"{vi}-{r}", "impactor.velocity": vi, "replica": r, "chain.seed": r, "status": "done",
                         "error": None, "folder": "x", "wall_time_s": 0.1, "particles": 21,
                         "impactor_peak_velocity_m_per_s": vi, "linear_wave_speed_V0_m_per_s": 1.6 + 0.001 * r,
                         "linear_frequency_f0_Hz": 42.4 + 0.01 * r,
                         f"{VP}.mean": 2 * vi + 0.01 * r if r < 3 else -0.08, f"{VP}.converged": r < 3,
                         f"{PEAK}.mean": 1.7 * vi + 0.01 * r, f"{PEAK}.converged": True,
                         "shock_velocity_max_m_per_s.value": 2 * vi + 0.1})
    rows.append(rows[0] | {"id": "f", "status": "failed", f"{VP}.mean": 1e9})
    return pd.DataFrame(rows)


def test_only_converged_plateaus_of_done_members_count_and_inputs_are_left_out():
    stats = replica_stats(_table())
    assert stats["n"].tolist() == [4, 4]
    assert stats[f"{VP}.mean.count"].tolist() == [3, 3] and stats[f"{PEAK}.mean.count"].tolist() == [4, 4]
    np.testing.assert_allclose(stats[f"{VP}.mean.mean"], [3.01, 4.01], rtol=1e-12)
    np.testing.assert_allclose(stats[f"{VP}.mean.sem"], [0.01 / np.sqrt(3)] * 2, rtol=1e-9)
    np.testing.assert_allclose(stats[f"{PEAK}.mean.mean"], [1.7 * 1.5 + 0.015, 1.7 * 2 + 0.015], rtol=1e-12)
    for inp in ("particles", "impactor_peak_velocity_m_per_s", "linear_wave_speed_V0_m_per_s", "linear_frequency_f0_Hz"):
        assert not any(c.startswith(inp) for c in stats.columns)


def test_a_sweep_where_no_member_is_done_has_nothing_to_average(tmp_path):
    """Every member failed (a bad grid value, say): each point is reported with n = 0, counts 0
    and no mean, and writing the statistics does not fail (it raised ValueError: 'n' is not
    in list)."""
    table = _table().assign(status="failed")
    stats = replica_stats(table)
    assert stats["impactor.velocity"].tolist() == [1.5, 2.0] and stats["n"].tolist() == [0, 0]
    assert stats[f"{VP}.mean.count"].tolist() == [0, 0] and stats[f"{VP}.mean.mean"].isna().all()
    written = write_replica_stats(tmp_path, table)
    assert written["n"].tolist() == [0, 0] and not (tmp_path / "replica_stats.png").exists()
    assert pd.read_csv(tmp_path / "replica_stats.csv")["n"].tolist() == [0, 0]
    empty = replica_stats(table.iloc[:0])
    assert len(empty) == 0 and "n" in empty.columns and f"{VP}.mean.count" in empty.columns


def test_a_table_read_back_from_csv_gives_the_same_statistics(tmp_path):
    """From results.csv a converged column holds True/False (and NaN for a failed member)."""
    _table().to_csv(tmp_path / "t.csv", index=False)
    pd.testing.assert_frame_equal(replica_stats(pd.read_csv(tmp_path / "t.csv")), replica_stats(_table()))


def test_plots_are_labelled_with_names_and_units():
    import matplotlib.pyplot as plt

    stats = replica_stats(_table())
    ax = plot_replica_stats(stats, "impactor.velocity", f"{PEAK}.mean")
    assert ax.get_xlabel() == "impactor velocity $V_I$ (m/s)"
    assert ax.get_ylabel() == "first peak velocity, plateau (m/s)"
    assert "4 values per point" in ax.get_title()
    assert not ax.yaxis.get_major_formatter().get_useOffset()  # no "+4.634" above the axis
    plt.close(ax.figure)
    assert label("chain.thermal_velocity") == "thermal RMS velocity (m/s)" and label("some.field") == "some.field"


@pytest.mark.parametrize("column", ["linear_wave_speed_V0_m_per_s", "impactor_peak_velocity_m_per_s"])
def test_inputs_can_still_be_asked_for_by_name(column):
    stats = replica_stats(_table(), [column])
    assert stats[f"{column}.count"].tolist() == [4, 4]


def test_one_point_s_figure_shows_the_spread_over_the_replicas(tmp_path):
    """A pure ensemble (one parameter point): each panel is the histogram of the values a mean
    uses, its title the count of the done replicas and the mean with its standard error."""
    from matplotlib.figure import Figure

    from pylmp_lattice.sweep.stats import plot_replica_spread, used_values

    table = _table()
    one = table[table["impactor.velocity"] == 1.5]
    done = one[one["status"] == "done"]
    values = used_values(done, f"{VP}.mean")
    np.testing.assert_allclose(np.sort(values), [3.0, 3.01, 3.02], rtol=1e-12)  # the unconverged replica is out
    ax = plot_replica_spread(values, f"{VP}.mean", ax=Figure().add_subplot(), members=len(done))
    assert ax.get_xlabel() == "shock velocity plateau $V_P$ (m/s)" and ax.get_ylabel() == "replicas"
    assert ax.get_title() == "3 of 4 replicas\nmean 3.01 ± 0.0058 m/s (± standard error)"
    assert sum(bar.get_height() for bar in ax.containers[0]) == 3  # the histogram holds the 3 values
    stats = write_replica_stats(tmp_path, one.drop(columns=["impactor.velocity"]))
    assert len(stats) == 1 and (tmp_path / "replica_stats.png").stat().st_size > 0
