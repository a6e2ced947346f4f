"""The package's figures, each rendered at low resolution and checked against the figure style
(`plots.style_figure`): panel letters in reading order, every axis labelled with its unit (time
in ms, lengths in mm), symbols in mathtext, a title that says the case and whether the figure
is a quick version, finite axis ranges, and no range set by a flagged measure.

Every study's quick version (run once per session, shared with tests/test_studies.py), and the
run figure of a constant drive, a half-sine pulse, a ramp and a constant drive with friction.
"""

from __future__ import annotations

import io
import re

import numpy as np
import pytest

from pylmp_lattice.plots import panels
from pylmp_lattice.run_folder import RunFolder, simulate
from pylmp_lattice.studies import STUDIES

SYMBOLS = ("V_I", "V_P", "V_0", "u_p", "f_0", "T_s", "T_r", "r_1")  # names that belong in $...$
LETTERS = "abcdefghijkl"


def texts(fig) -> list[str]:
    """Every text a reader sees: the title, panel titles, axis labels and legend entries."""
    out = [fig._suptitle.get_text()] if fig._suptitle else []
    for ax in fig.axes:
        out += [ax.get_title(loc) for loc in ("left", "center", "right")] + [ax.get_xlabel(), ax.get_ylabel()]
        legend = ax.get_legend()
        if legend is not None:
            out += [t.get_text() for t in legend.get_texts()] + [legend.get_title().get_text()]
        out += [t.get_text() for t in ax.texts]
    return [t for t in out if t]


def check_figure(fig, quick: bool | None = None, letters: str | None = None):
    """The figure style; returns the panels in reading order."""
    main = panels(fig)
    found = [ax.get_title(loc="left") for ax in main]
    if len(main) > 1:
        assert all(re.fullmatch(r"\([a-l]\)", t) for t in found), f"panel letters: {found}"
        order = [LETTERS.index(t[1]) for t in found]
        assert order == list(range(order[0], order[0] + len(order))), f"panel letters not in reading order: {found}"
        if letters is not None:
            assert "".join(t[1] for t in found) == letters
    for ax in fig.axes:
        if ax.get_label() == "<colorbar>" or not ax.get_visible():
            continue
        assert ax.get_xlabel() or ax not in main, f"panel {ax.get_title(loc='left')} has no x label"
        assert ax.get_ylabel() or not ax.get_yticks().size, f"panel {ax.get_title(loc='left')} has no y label"
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            assert "(s)" not in label or label.startswith("wall time"), f"time in s, not ms: {label!r}"
            assert "(m)" not in label and "(cm)" not in label, f"length not in mm: {label!r}"
        for lo, hi in (ax.get_xlim(), ax.get_ylim()):
            assert np.isfinite(lo) and np.isfinite(hi) and lo != hi  # (an axis may run downwards)
    for text in texts(fig):
        plain = re.sub(r"\$[^$]*\$", "", text)
        for symbol in SYMBOLS:
            assert symbol not in plain, f"{symbol} outside mathtext in {text!r}"
    title = fig._suptitle.get_text() if fig._suptitle else ""
    assert title, "no figure title"
    if quick is not None:
        assert ("quick" in title) == quick, title
    fig.savefig(io.BytesIO(), format="png", dpi=30)  # renders (mathtext included) at low resolution
    for ax in main:  # a legend wider than its panel covers the panel's axis label
        legend = ax.get_legend()
        if legend is not None and legend.get_visible():
            width, panel = legend.get_window_extent().width, ax.get_window_extent().width
            assert width <= panel, f"panel {ax.get_title(loc='left')}: legend {width:.0f} px, panel {panel:.0f} px"
    return main


# ---------------------------------------------------------------------------------------------
# Every study's figure (quick versions)
# ---------------------------------------------------------------------------------------------

PAPER_LETTERS = {"fig1": "bcd", "s4": "cd", "s7": "bcd", "s8": "bcd"}  # the paper's own panel letters


@pytest.mark.lammps
@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in STUDIES if n != "all"])
def test_study_figure(quick_studies, name):
    result = quick_studies(name)
    check_figure(result.figure, quick=True, letters=PAPER_LETTERS.get(name))
    assert result.to_dict()["quick"] is True


@pytest.mark.lammps
@pytest.mark.slow
def test_stand_in_impact_is_said(quick_studies):
    for name in ("fig1", "fig2"):
        result = quick_studies(name)
        assert "stand-in impact" in result.figure._suptitle.get_text()
        assert "half-sine" in result.numbers["stand_in_impact"]


@pytest.mark.lammps
@pytest.mark.slow
def test_quick_figures_say_what_they_cannot_show(quick_studies):
    """A quick study keeps the full study's trends or says which panel it cannot show."""
    assert "eta_by_time_ms" in quick_studies("s9").numbers["quick_cannot_show"]
    assert "quick_cannot_show" in quick_studies("fig4").numbers


@pytest.mark.lammps
def test_all_figure(all_study):
    _, result, _ = all_study  # `all` over fig2 (conftest.all_study)
    check_figure(result.figure, quick=True)


# ---------------------------------------------------------------------------------------------
# The run figure (Fig. 3(a-d) of one run)
# ---------------------------------------------------------------------------------------------

DRIVES = {
    "constant": ({"profile": "constant", "velocity": 2.0}, {}),
    # 40 ms: the impactor peaks (t = 20 ms) after magnet 2 (14.8 ms), so gap 1 is crossed out of
    # order and its "V_P" is -2.3 m/s
    "pulse": ({"profile": "sine", "velocity": 2.0, "duration": 40.0}, {}),
    "ramp": ({"profile": "ramp", "velocity": 2.0, "ramp_time": 20.0}, {}),
    "friction": ({"profile": "constant", "velocity": 2.0}, {"friction": {"mu": 0.285, "p": 0.012}}),
}


@pytest.mark.lammps
@pytest.mark.parametrize("drive", list(DRIVES))
def test_run_figure(tmp_path, case_factory, drive):
    impactor, sections = DRIVES[drive]
    case = case_factory(particles=30, duration=60.0, impactor=impactor, **sections)
    simulate(case, tmp_path)
    run = RunFolder(tmp_path)
    fig = run.figure()
    a, b, c, d = check_figure(fig, letters="abcd")
    assert case.name in fig._suptitle.get_text()
    # (b): no gap crossed out of order is drawn, nor sets the range
    vp = run.front().propagation_velocity
    drawn = np.concatenate([line.get_ydata() for line in b.get_lines() if len(line.get_ydata()) == len(vp)])
    assert np.all(drawn[np.isfinite(drawn)] > 0)
    assert b.get_ylim()[0] > 0
    if drive == "pulse":
        assert vp[0] < 0  # magnet 2 peaks before the drive: gap 1, the drive's, is left out and said so
        assert "gap 1: the drive's, not drawn" in [t.get_text() for t in b.get_legend().get_texts()]
    # (c): the 2 V_I line only where the first peaks saturate there: a steady drive, no friction
    saturation = [line for line in c.get_lines() if "2 $V_I$" in str(line.get_label())]
    assert bool(saturation) == (drive in ("constant", "ramp"))
    # (c): twin axes kept apart: the velocity in the upper part of the panel, the acceleration below
    right = next(ax for ax in fig.axes if ax is not c and ax.bbox.bounds == c.bbox.bounds)
    v_top = c.transData.transform((0, np.nanmin(run.front().peaks.peak_velocity)))[1]
    a_top = right.transData.transform((0, np.nanmax(run.front().peaks.peak_acceleration)))[1]
    assert a_top < v_top


@pytest.mark.lammps
def test_run_figure_without_a_trajectory_labels_its_empty_panels(tmp_path, case_factory):
    """output.format = "none": panels (a) and (d) say that no trajectory was written, under their
    axis labels and without ticks (trial: bare 0-1 axes, no label: numbers of nothing)."""
    from pylmp_lattice.run_folder import execute

    case = case_factory(particles=30, duration=60.0, impactor=DRIVES["constant"][0], output={"format": "none"})
    execute(case, tmp_path)
    a, b, c, d = check_figure(RunFolder(tmp_path).figure(), letters="abcd")
    for ax, ylabel in ((a, "v (m/s)"), (d, "peak velocity (m/s)")):
        assert (ax.get_xlabel(), ax.get_ylabel()) == ("t (ms)", ylabel)
        assert len(ax.get_xticks()) == 0 and len(ax.get_yticks()) == 0
        assert [t.get_text() for t in ax.texts] == ["no trajectory written\n(output.format = 'none')"]


@pytest.mark.lammps
@pytest.mark.slow
def test_quick_figures_name_only_what_they_draw(quick_studies):
    """s5 (d, e) and fig3 (d, e): a magnet's entry only with its extrema or frequencies drawn
    (the quick s5 had "n = 25" with none); dsw (d): a knee's entry only with a knee drawn (the
    quick dsw has no knee); fig3 (f): the widths at other tolerances each in a colour and a
    marker of their own; s8 (b): V0 and the constant drive's V_P off the spines."""
    for name in ("s5", "fig3"):
        for ax in panels(quick_studies(name).figure)[3:5]:
            drawn = {line.get_label() for line in ax.get_lines() if len(line.get_xdata())}
            named = {t.get_text() for t in ax.get_legend().get_texts() if t.get_text().startswith("n = ")}
            assert named and named <= drawn, (name, named - drawn)
    d = panels(quick_studies("dsw").figure)[3]
    knees = {line.get_marker() for line in d.get_lines() if len(line.get_xdata()) and line.get_linestyle() == "None"
             and line.get_marker() in ("v", "^")}
    entries = {t.get_text() for t in d.get_legend().get_texts()} if d.get_legend() else set()
    assert ("two-line knee" in entries) == ("v" in knees) and ("kneedle knee" in entries) == ("^" in knees)
    f = panels(quick_studies("fig3").figure)[5]
    widths = [line for line in f.get_lines() if "within 0.2" in line.get_label() or "within 0.0" in line.get_label()]
    assert len(widths) == 3 and len({(line.get_color(), line.get_marker()) for line in widths}) == 3
    assert len({line.get_marker() for line in widths}) == 3
    b = panels(quick_studies("s8").figure)[0]
    numbers = quick_studies("s8").numbers
    lo, hi = b.get_ylim()
    for level in (numbers["V0_m_per_s"], numbers["V_P_constant_drive_m_per_s"]):
        assert lo + 0.02 * (hi - lo) < level < hi - 0.02 * (hi - lo)


def covered(ax) -> int:
    """Points of the axes' lines that its legend's box covers (display coordinates)."""
    ax.figure.draw_without_rendering()  # places a "best" legend (a bare Figure's canvas.draw does nothing)
    box = ax.get_legend().get_window_extent()
    count = 0
    for line in ax.lines:
        xy = line.get_transform().transform(np.asarray(line.get_xydata(), float))
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        count += int(np.sum((xy[:, 0] >= box.x0) & (xy[:, 0] <= box.x1) & (xy[:, 1] >= box.y0) & (xy[:, 1] <= box.y1)))
    return count


def test_legends_of_a_long_run_cover_no_trace():
    """A long run's traces fill panels (a) and (d) from edge to edge: their legends covered
    traces wherever matplotlib put them (issue 27 item 13); they sit in headroom above the data."""
    from matplotlib.figure import Figure

    from pylmp_lattice.plots import oscillation_peaks, velocity_profiles

    t = np.linspace(0, 1000, 20001)
    magnets = [2, 50, 100, 150]
    v = np.stack([2 + 1.9 * np.sin(2 * np.pi * t / (9 + k)) * (t > 150 * k) for k in range(4)], axis=1)
    for draw, args in ((velocity_profiles, (t, v, magnets)), (oscillation_peaks, (t, v, magnets, 2.0))):
        ax = Figure(figsize=(5.5, 4)).subplots()
        draw(*args, ax=ax)
        assert covered(ax) == 0, draw.__name__


@pytest.mark.lammps
@pytest.mark.slow
def test_friction_rig_legends_cover_no_trace(quick_studies):
    """Fig. S4's rig traces (`analysis/friction_calibration.py`, study s4) run from edge to edge:
    a legend in the upper right hid the last turning points of every panel (trial: 707 points
    under the quick version's first panel's legend); it sits in headroom above the data."""
    for ax in panels(quick_studies("s4").figure):
        assert covered(ax) == 0, ax.get_title()


@pytest.mark.lammps
@pytest.mark.slow
def test_hugoniot_labels_the_model_chains_reduced_units(quick_studies):
    """The Toda chain (m = A = B = 1) is in reduced units: its panels said m/s and mJ (issue 27
    item 13); the magnets' stay in m/s."""
    fig = quick_studies("hugoniot").figure
    by_title = {ax.get_title(): ax for ax in fig.axes}
    toda = [ax for title, ax in by_title.items() if title.startswith("toda (m = A = B = 1)")]
    magnet = [ax for title, ax in by_title.items() if title.startswith("magnet\n")]
    assert len(toda) == 2 and len(magnet) == 2
    for ax in toda:
        assert "m/s" not in ax.get_xlabel() + ax.get_ylabel() and "reduced units" in ax.get_xlabel()
    assert all(ax.get_xlabel() == "$u_p$ (m/s)" for ax in magnet)


def test_twin_axes_tick_only_their_own_data():
    """Panel (c) of the experiment: the first peak velocities (2.4-5.1 m/s) are drawn in the upper
    part, so the left axis extends below them; it was ticked down to -1.8 m/s, a velocity no
    first peak has. Each axis is now ticked over its own values only."""
    from matplotlib.figure import Figure

    from pylmp_lattice.plots import separate

    ax = Figure().subplots()
    right = ax.twinx()
    velocity, acceleration = np.linspace(2.4, 5.1, 18), np.linspace(200, 3900, 18)
    ax.plot(velocity)
    right.plot(acceleration)
    separate(ax, right, velocity, acceleration)
    assert ax.get_ylim()[0] < 0  # the room below, for the other axis's data
    assert 2.0 <= min(ax.get_yticks()) and max(ax.get_yticks()) <= 5.5, ax.get_yticks()
    assert 0 <= min(right.get_yticks()) and max(right.get_yticks()) <= 4000, right.get_yticks()


def test_twin_log_axes_tick_only_their_own_decades():
    """Fig. 2(a): force 5e-3-8 N on the left, stiffness 3e-4-6 N/mm on the right, each in its
    part of the panel; the left axis was ticked down to 1e-7 N and the right up to 1e7 N/mm. Each
    is now ticked (decades, and 2-9 between) over its own values' decades only."""
    from matplotlib.figure import Figure

    from pylmp_lattice.plots import separate

    ax = Figure().subplots()
    right = ax.twinx()
    force, stiffness = np.geomspace(5e-3, 8.0, 40), np.geomspace(3e-4, 6.0, 40)
    ax.semilogy(force)
    right.semilogy(stiffness)
    separate(ax, right, force, stiffness)
    assert ax.get_ylim()[0] < 1e-4 and right.get_ylim()[1] > 1e3  # room for the other axis's data
    assert list(ax.yaxis.get_majorticklocs()) == [1e-2, 1e-1, 1.0, 10.0]
    assert list(right.yaxis.get_majorticklocs()) == [1e-3, 1e-2, 1e-1, 1.0]
    minor = ax.yaxis.get_minorticklocs()
    assert minor.min() == pytest.approx(4e-3) and minor.max() == pytest.approx(9.0)


@pytest.mark.lammps
@pytest.mark.slow
def test_fig1_draws_the_front_speed_line_on_the_trajectories(quick_studies):
    """Fig. 1(b) had no front-speed line where the paper draws its red arrow (issue 27 item 13):
    the gap-frame fit over magnets 2-12, its speed in the legend, as in the lab-frame panel."""
    result = quick_studies("fig1")
    left = panels(result.figure)[0]
    speed = result.numbers["V_P_fit_by_arrival_definition_and_magnets"]["velocity_peak"]["n=2..12"]
    (label,) = [t.get_text() for t in left.get_legend().get_texts()]
    assert label == f"front, magnets 2-12: {speed.velocity:.2f} m/s (gap frame)"
    xs, ts = left.lines[-1].get_data()
    assert np.allclose(np.diff(xs) / np.diff(ts), speed.velocity)  # mm/ms = m/s
