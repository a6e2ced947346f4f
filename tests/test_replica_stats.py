"""Replica statistics: outcomes only, converged plateaus only, counts, labelled plots."""

from __future__ import annotations

import logging
from pathlib import Path

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


def test_every_statistic_states_its_coverage_and_marks_it_below_90_percent(tmp_path, caplog):
    """Of the members run (done or failed: 5 at V_I = 1.5, 4 at 2.0), 3 converged plateaus:
    coverage 0.6 and 0.75, marked in the table, hollow in the figure, and one warning line; the
    first peak (4 of 5: the failed member has none) is marked at 1.5 only."""
    stats = replica_stats(_table())
    assert stats["n"].tolist() == [4, 4] and stats["failed"].tolist() == [1, 0]
    np.testing.assert_allclose(stats[f"{VP}.mean.coverage"], [0.6, 0.75], rtol=1e-12)
    np.testing.assert_allclose(stats[f"{PEAK}.mean.coverage"], [0.8, 1.0], rtol=1e-12)
    assert stats[f"{VP}.mean.low_coverage"].tolist() == [True, True]
    assert stats[f"{PEAK}.mean.low_coverage"].tolist() == [True, False]
    with caplog.at_level("WARNING"):
        written = write_replica_stats(tmp_path, _table())
    lines = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert lines == [f"{name}: below 90% coverage at {k} of 2 points (lowest {low} of the members run, failed ones "
                     "counted): a mean over the members with a value only (converged, not failed)"
                     for name, k, low in ((f"{VP}.mean", 2, "60%"), (f"{PEAK}.mean", 1, "80%"),
                                          ("shock_velocity_max_m_per_s.value", 1, "80%"))]
    assert pd.read_csv(tmp_path / "replica_stats.csv")[f"{VP}.mean.low_coverage"].tolist() == [True, True]
    assert written[f"{VP}.mean.count"].tolist() == [3, 3]
    ax = plot_replica_stats(stats, "impactor.velocity", f"{VP}.mean")
    hollow = [line for line in ax.lines if line.get_markerfacecolor() == "white"]
    assert len(hollow) == 1 and hollow[0].get_xdata().tolist() == [1.5, 2.0]
    assert "hollow: under 90% of members" in ax.get_title()
    full = plot_replica_stats(replica_stats(_table().query("status == 'done'")), "impactor.velocity", f"{PEAK}.mean")
    assert not [line for line in full.lines if line.get_markerfacecolor() == "white"]
    assert "hollow" not in full.get_title()


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
    assert ax.get_title() == "3 of 4 replicas (coverage 75%, below 90%)\nmean 3.01 ± 0.0058 m/s (± standard error)"
    assert ax.patches[0].get_data().values.sum() == 3  # the histogram (one step patch) holds the 3 values
    stats = write_replica_stats(tmp_path, one.drop(columns=["impactor.velocity"]))
    assert len(stats) == 1 and (tmp_path / "replica_stats.png").stat().st_size > 0


def _two_field_table():
    """A grid of V_I x friction (a section swept as a whole: mu and p vary together, g does
    not) x pulse duration, 3 replicas per point; V_P = 2 V_I - mu + T_s / 100 + 0.01 r."""
    rows = []
    for vi in (1.0, 2.0):
        for mu, p in ((0.285, 0.012), (0.0, 0.0)):
            for ts in (30.0, 47.8):
                for r in range(3):
                    rows.append({"id": f"{vi}-{mu}-{ts}-{r}", "impactor.velocity": vi, "friction.mu": mu, "friction.p": p,
                                 "friction.g": 9.81, "impactor.duration": ts, "replica": r, "chain.seed": r,
                                 "status": "done", "error": None, "folder": "x", "wall_time_s": 0.1,
                                 f"{VP}.mean": 2 * vi - mu + ts / 100 + 0.01 * r, f"{VP}.converged": True})
    return pd.DataFrame(rows)


def _lines_and_bands(ax):
    """Per line drawn: its x and y, the lengths of its error bars and its band's y extent."""
    from matplotlib.collections import PolyCollection

    bands = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert len(bands) == len(ax.containers)
    return [(bars.lines[0].get_xdata(), bars.lines[0].get_ydata(),
             [s[1, 1] - s[0, 1] for s in bars.lines[2][0].get_segments()],
             (band.get_paths()[0].vertices[:, 1].min(), band.get_paths()[0].vertices[:, 1].max()))
            for bars, band in zip(ax.containers, bands)]


def test_a_grid_over_several_fields_draws_one_line_per_combination_of_the_others():
    """Points that differ in friction or T_s are never joined (they were, zig-zag at the same
    V_I): one line (bars and band) per combination, against V_I, each named in the legend by
    the fields that vary (friction.g does not: left out), with its own points' means, standard
    errors (0.01 / sqrt(3)) and replica std (0.01)."""
    from matplotlib.figure import Figure

    stats = replica_stats(_two_field_table())
    ax = plot_replica_stats(stats, "impactor.velocity", f"{VP}.mean", ax=Figure().add_subplot())
    names = [text.get_text() for text in ax.get_legend().get_texts()]
    assert names == [r"friction $\mu$ 0.285, $p$ 0.012; pulse duration $T_s$ 30 ms",
                     r"friction $\mu$ 0.285, $p$ 0.012; pulse duration $T_s$ 47.8 ms",
                     r"friction $\mu$ 0, $p$ 0; pulse duration $T_s$ 30 ms",
                     r"friction $\mu$ 0, $p$ 0; pulse duration $T_s$ 47.8 ms"]
    drawn = _lines_and_bands(ax)
    assert len(drawn) == 4
    for (x, y, bars, band), (mu, ts) in zip(drawn, [(0.285, 30.0), (0.285, 47.8), (0.0, 30.0), (0.0, 47.8)]):
        mean = [2 * vi - mu + ts / 100 + 0.01 for vi in (1.0, 2.0)]
        np.testing.assert_array_equal(x, [1.0, 2.0])
        np.testing.assert_allclose(y, mean, rtol=1e-12)
        np.testing.assert_allclose(bars, [2 * 0.01 / np.sqrt(3)] * 2, rtol=1e-9)
        np.testing.assert_allclose(band, (mean[0] - 0.01, mean[1] + 0.01), rtol=1e-9)
    assert ax.get_title().endswith("3 values per point")


def test_a_field_zipped_with_x_goes_with_it_one_line():
    """The guide's [zip] of pulse duration and run length, against T_s: the run length changes
    with T_s only, so the points are one line (not one line per run length, of one point each)."""
    from matplotlib.figure import Figure

    rows = [{"id": f"{ts}-{r}", "impactor.duration": ts, "run.duration": ts + 30.0, "replica": r, "chain.seed": r,
             "status": "done", "error": None, "folder": "x", "wall_time_s": 0.1, f"{VP}.mean": ts / 10 + 0.01 * r,
             f"{VP}.converged": True} for ts in (30.0, 40.0, 50.0) for r in range(3)]
    stats = replica_stats(pd.DataFrame(rows))
    ax = plot_replica_stats(stats, "impactor.duration", f"{VP}.mean", ax=Figure().add_subplot())
    (x, y, _, _), = _lines_and_bands(ax)
    np.testing.assert_array_equal(x, [30.0, 40.0, 50.0])
    np.testing.assert_allclose(y, [3.01, 4.01, 5.01], rtol=1e-12)
    assert ax.get_legend() is None


def test_more_combinations_than_lines_draws_the_first_and_says_so():
    from matplotlib.figure import Figure

    stats = replica_stats(_two_field_table())
    ax = plot_replica_stats(stats, "impactor.velocity", f"{VP}.mean", ax=Figure().add_subplot(), lines=3)
    assert len(ax.containers) == 3 and ax.get_title().endswith("3 values per point; first 3 of 4 lines")
    assert len(ax.get_legend().get_texts()) == 3


def _drawn_figure(monkeypatch, tmp_path, table):
    """write_replica_stats's figure, kept as it is saved."""
    import matplotlib.figure

    figures, save = [], matplotlib.figure.Figure.savefig
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", lambda fig, *a, **k: (figures.append(fig), save(fig, *a, **k)))
    write_replica_stats(tmp_path, table)
    assert (tmp_path / "replica_stats.png").stat().st_size > 0
    (fig,) = figures
    return fig


def test_the_sweep_figure_has_one_legend_under_its_panels(monkeypatch, tmp_path):
    """Each panel draws the 4 lines without a legend of its own; one figure legend under the
    panels names them, and the panels keep their size in inches."""
    from pylmp_lattice.sweep.stats import MARGINS, PANEL

    table = _two_field_table()
    table["friction_dissipated_energy_mJ"] = table["friction.mu"] * (1 + 0.1 * table["replica"])  # a second panel
    fig = _drawn_figure(monkeypatch, tmp_path, table)
    assert len(fig.axes) == 2 and all(ax.get_legend() is None and len(ax.containers) == 4 for ax in fig.axes)
    (legend,) = fig.legends
    assert legend.get_texts()[3].get_text() == r"friction $\mu$ 0, $p$ 0; pulse duration $T_s$ 47.8 ms"
    width, height = fig.get_size_inches()
    assert width == 2 * PANEL[0] and height > PANEL[1]
    for ax in fig.axes:
        assert ax.get_position().height * height == pytest.approx(PANEL[1] - MARGINS[2] - MARGINS[3], rel=1e-9)
    np.testing.assert_allclose(_lines_and_bands(fig.axes[0])[2][1], [2 - 0 + 0.3 + 0.01, 4 + 0.3 + 0.01], rtol=1e-12)


@pytest.mark.parametrize("panels", [1, 2])
def test_the_legend_fits_in_the_figure_under_the_axes(monkeypatch, tmp_path, panels):
    """Long entries (three fields vary besides V_I; one panel is 4.5 inches wide): the legend,
    one line per field where an entry would be wider than the figure, lies inside the figure
    and below every axes with its labels (a fixed layout: the sizes are estimated, not measured)."""
    table = _two_field_table()
    table.insert(6, "run.duration", table["impactor.duration"] + 20)  # zipped with T_s, a swept column
    if panels == 2:
        table["friction_dissipated_energy_mJ"] = table["friction.mu"] * (1 + 0.1 * table["replica"])
    fig = _drawn_figure(monkeypatch, tmp_path, table)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    (legend,) = fig.legends
    box = legend.get_window_extent(renderer)
    assert len(fig.axes) == panels and ("\n" in legend.get_texts()[0].get_text()) == (panels == 1)
    assert 0 <= box.x0 and box.x1 <= fig.bbox.x1 and 0 <= box.y0
    assert all(box.y1 <= ax.get_tightbbox(renderer).y0 for ax in fig.axes)


def test_the_sweep_figure_s_axis_is_a_swept_number_that_varies(monkeypatch, tmp_path):
    """A force section swept whole (force.K, force.b the same in both, force.q not): the figure
    is drawn against force.q, one line per V_I (it was drawn against force.K, every point at
    413.8, one line per point)."""
    rows = [{"id": f"{q}-{vi}-{r}", "force.law": "power", "force.K": 413.8, "force.b": 3.917, "force.q": q,
             "impactor.velocity": vi, "replica": r, "chain.seed": r, "status": "done", "error": None, "folder": "x",
             "wall_time_s": 0.1, f"{VP}.mean": q + vi + 0.01 * r, f"{VP}.converged": True}
            for q in (3.0, 2.5) for vi in (1.5, 2.5) for r in range(3)]
    fig = _drawn_figure(monkeypatch, tmp_path, pd.DataFrame(rows))
    (ax,) = fig.axes
    assert ax.get_xlabel() == label("force.q")
    drawn = _lines_and_bands(ax)
    assert len(drawn) == 2
    for (x, y, _, _), vi in zip(drawn, (1.5, 2.5)):
        np.testing.assert_array_equal(x, [2.5, 3.0])
        np.testing.assert_allclose(y, [2.5 + vi + 0.01, 3.0 + vi + 0.01], rtol=1e-12)


def test_one_point_s_sweep_figure_is_still_the_histograms(monkeypatch, tmp_path):
    """A pure ensemble: a histogram per panel (as before), no legend, panels of PANEL inches."""
    from matplotlib.patches import StepPatch

    from pylmp_lattice.sweep.stats import PANEL

    one = _table()
    one = one[one["impactor.velocity"] == 1.5].drop(columns=["impactor.velocity"])
    fig = _drawn_figure(monkeypatch, tmp_path, one)
    assert tuple(fig.get_size_inches()) == (2 * PANEL[0], PANEL[1]) and not fig.legends
    ax = fig.axes[0]
    assert isinstance(ax.patches[0], StepPatch) and ax.patches[0].get_data().values.sum() == 3
    # (of the 5 run: the failed one counts)
    assert ax.get_title() == "3 of 5 replicas (coverage 60%, below 90%)\nmean 3.01 ± 0.0058 m/s (± standard error)"


def test_a_measure_not_in_the_statistics_is_named_with_the_available_ones():
    stats = replica_stats(_table())
    with pytest.raises(ValueError, match=r"^measure 'shock_velocity_plateau': not in the statistics; available: "
                                         rf"{VP}\.mean, {PEAK}\.mean, shock_velocity_max_m_per_s\.value$"):
        plot_replica_stats(stats, "impactor.velocity", "shock_velocity_plateau")


@pytest.mark.lammps
def test_a_disordered_ensemble_reports_coverage_and_its_headline_speed_uses_every_member(tmp_path, caplog):
    """8 members of the long lattice under 10 % mass disorder (300 ms): every statistic states its
    coverage; the front speed over the case's fixed gap window is defined for all 8 (the same
    gaps for each), and its mean is the plain mean of the 8 members' values; the plateaus that
    converged in fewer than 90 % of the members are marked and warned about (600 ms: 2 of 8
    V_P plateaus, 4 of 8 first peaks)."""
    from pylmp_lattice.sweep import Sweep, run_sweep

    base = Path(__file__).parent.parent / "inputs" / "paper_long_lattice.toml"
    sweep = Sweep(base=base, base_dir=base.parent, replicas=8, seed=2026, keep="measures",
                  set={"chain.mass_disorder": 0.1, "run.duration": 300.0})
    table = run_sweep(sweep, tmp_path / "sweep", workers=2, progress=False)
    assert (table["status"] == "done").sum() == 8
    with caplog.at_level("WARNING"):
        stats = write_replica_stats(tmp_path / "sweep", table)
    measures = [c.removesuffix(".count") for c in stats.columns if c.endswith(".count")]
    assert len(measures) >= 5
    for m in measures:
        assert np.isfinite(stats[f"{m}.coverage"].iloc[0]) and f"{m}.low_coverage" in stats.columns
    head = "front_speed_m_per_s.value"
    assert stats[f"{head}.count"].iloc[0] == 8 and stats[f"{head}.coverage"].iloc[0] == 1.0
    assert table["front_speed_m_per_s.first_gap"].nunique() == 1 and table["front_speed_m_per_s.last_gap"].nunique() == 1
    assert stats[f"{head}.mean"].iloc[0] == pytest.approx(float(np.mean(table[head].to_numpy(float))), rel=1e-12)
    low = [m for m in measures if stats[f"{m}.low_coverage"].iloc[0]]
    assert all(stats[f"{m}.count"].iloc[0] < 0.9 * 8 for m in low)
    warned = [r.getMessage().split(":")[0] for r in caplog.records if r.levelno == logging.WARNING]
    assert sorted(warned) == sorted(low)


def test_members_that_failed_count_against_the_coverage_and_a_point_without_values_is_said(caplog):
    """Strong disorder: 11 of 20 replicas of a point touched (failed), the other 9 converged. The
    mean is over 9 of 20 (coverage 45 %, marked, warned), not '9 of 9' (a trial found the
    survivors' mean unmarked); a point where no member has a value keeps its place in the
    figure (a dotted line) and the warning says it has no mean."""
    rows = []
    for disorder, failed in ((0.0, 0), (0.3, 11), (0.6, 20)):
        for r in range(20):
            rows.append({"id": f"{disorder}-{r}", "chain.mass_disorder": disorder, "replica": r, "chain.seed": r,
                         "status": "failed" if r < failed else "done", "error": None, "folder": "x",
                         "wall_time_s": 0.1, f"{VP}.mean": np.nan if r < failed else 4.0 + 0.01 * r,
                         f"{VP}.converged": r >= failed})
    stats = replica_stats(pd.DataFrame(rows), [f"{VP}.mean"])
    assert stats["n"].tolist() == [20, 9, 0] and stats["failed"].tolist() == [0, 11, 20]
    np.testing.assert_allclose(stats[f"{VP}.mean.coverage"], [1.0, 0.45, 0.0], rtol=1e-12)
    assert stats[f"{VP}.mean.low_coverage"].tolist() == [False, True, True]
    from pylmp_lattice.sweep.stats import low_coverage_warnings

    line, = low_coverage_warnings(stats)
    assert "at 2 of 3 points (lowest 0% of the members run" in line and line.endswith("no member has one at 1 point (no mean)")
    ax = plot_replica_stats(stats, "chain.mass_disorder", f"{VP}.mean")
    dotted = [line for line in ax.lines if line.get_linestyle() == ":"]
    assert [line.get_xdata()[0] for line in dotted] == [0.6] and ax.get_title().endswith("\ndotted: no value at 0.6")
    hollow, = [line for line in ax.lines if line.get_markerfacecolor() == "white"]
    assert hollow.get_color() == ax.containers[0].lines[0].get_color()  # the line's own colour, not the next


def test_a_point_without_values_on_an_axis_of_text_is_named_as_text():
    """x a swept choice (the force law): its dotted point is named by its text (a number format
    raised ValueError on it)."""
    rows = [{"id": f"{law}-{r}", "force.law": law, "replica": r, "chain.seed": r, "status": "done", "error": None,
             "folder": "x", "wall_time_s": 0.1, f"{VP}.mean": 4.0 + 0.01 * r, f"{VP}.converged": law != "toda"}
            for law in ("power", "toda", "lj") for r in range(3)]
    stats = replica_stats(pd.DataFrame(rows), [f"{VP}.mean"])
    ax = plot_replica_stats(stats, "force.law", f"{VP}.mean")
    assert ax.get_title().endswith("\ndotted: no value at toda")


def _members(values, converged=None, status=None, **point):
    """Rows of one parameter point (`point`: its swept columns), one per value of V_P."""
    status = status or ["done"] * len(values)
    converged = [True] * len(values) if converged is None else converged
    return [{"id": f"{point}-{r}", **point, "replica": r, "chain.seed": r, "status": s, "error": None, "folder": "x",
             "wall_time_s": 0.1, f"{VP}.mean": v, f"{VP}.converged": c, "front_speed_m_per_s.value": v}
            for r, (v, c, s) in enumerate(zip(values, converged, status))]


def test_mean_and_standard_error_are_numpy_s_of_the_values_used():
    """Skewed values (the median, 4.1, is 0.44 below the mean, 4.54): mean, ddof = 1 standard
    error and count as numpy gives them for the values the rules keep; a done member without
    a value (its front never crossed the window: NaN, and its plateau not converged) is not a
    value, and counts against the coverage as one run."""
    values = np.array([3.9, 4.0, 4.1, 4.2, 6.5])
    rows = _members([*values, np.nan], converged=[True] * 5 + [False], **{"impactor.velocity": 2.0})
    stats = replica_stats(pd.DataFrame(rows))
    for measure in (f"{VP}.mean", "front_speed_m_per_s.value"):
        assert stats[f"{measure}.count"].tolist() == [5], measure
        assert stats[f"{measure}.mean"][0] == pytest.approx(np.mean(values), rel=1e-14)
        assert stats[f"{measure}.sem"][0] == pytest.approx(np.std(values, ddof=1) / np.sqrt(5), rel=1e-12)
        assert stats[f"{measure}.coverage"][0] == pytest.approx(5 / 6, rel=1e-14)
    assert np.mean(values) - np.median(values) == pytest.approx(0.44, abs=1e-12)


def test_interrupted_members_are_not_members_run():
    """A sweep stopped by a signal leaves members "interrupted" (unstarted, redone on resume):
    they are neither done (n) nor failed, and the coverage counts the members run only: 3
    done (2 converged) and 1 failed of 6 is 2 of 4, not 2 of 6, nor 2 of 5 ("interrupted" is
    not "done", nor "failed")."""
    rows = _members([4.0, 4.1, 9.9, np.nan, np.nan, np.nan], converged=[True, True, False, False, False, False],
                    status=["done", "done", "done", "failed", "interrupted", "interrupted"], **{"impactor.velocity": 2.0})
    stats = replica_stats(pd.DataFrame(rows), [f"{VP}.mean"])
    assert stats["n"].tolist() == [3] and stats["failed"].tolist() == [1]
    assert stats[f"{VP}.mean.count"].tolist() == [2]
    assert stats[f"{VP}.mean.coverage"][0] == pytest.approx(0.5, rel=1e-14)
    assert stats[f"{VP}.mean.mean"][0] == pytest.approx(4.05, rel=1e-14)


@pytest.mark.parametrize("used, run, low", [(9, 10, False), (18, 20, False), (8, 10, True), (17, 20, True)])
def test_a_coverage_of_exactly_90_percent_is_not_marked(used, run, low):
    """COVERAGE_LIMIT: marked are statistics over *fewer* than 90 % of the members run; 9 of 10
    and 18 of 20 are at the limit and stand, 8 of 10 and 17 of 20 are below it."""
    rows = _members([4.0 + 0.01 * r for r in range(run)], converged=[r < used for r in range(run)],
                    **{"impactor.velocity": 2.0})
    stats = replica_stats(pd.DataFrame(rows), [f"{VP}.mean"])
    assert stats[f"{VP}.mean.count"][0] == used
    assert stats[f"{VP}.mean.low_coverage"].tolist() == [low]


def test_points_of_sections_swept_whole_keep_their_empty_fields():
    """A sweep over the force law as a whole section: the power law's points have no force.A
    and the Toda law's no force.K (NaN in the table). Each point is still a point of its own,
    with its own members' mean (they were dropped, as pandas groupby drops keys with NaN)."""
    rows = []
    for law, K, A, vp in (("power", 413.8, np.nan, 4.0), ("toda", np.nan, 1.0, 2.0)):
        for vi in (1.0, 2.0):
            rows += _members([vp * vi + 0.01 * r for r in range(3)],
                             **{"force.law": law, "force.K": K, "force.A": A, "impactor.velocity": vi})
    stats = replica_stats(pd.DataFrame(rows), [f"{VP}.mean"])
    assert stats["force.law"].tolist() == ["power", "power", "toda", "toda"]
    assert stats["n"].tolist() == [3, 3, 3, 3]
    np.testing.assert_allclose(stats[f"{VP}.mean.mean"], [4.01, 8.01, 2.01, 4.01], rtol=1e-14)
