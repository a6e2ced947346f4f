"""Figures: the panels show the measures' numbers (synthetic front, no engine)."""

from __future__ import annotations

import numpy as np
import pytest

from pylmp_lattice import measures
from pylmp_lattice.plots import shock_figure
from pylmp_lattice.trajectory import Trajectory


def test_shock_figure_plots_the_measured_propagation_velocity():
    t = np.linspace(0, 100, 2001)
    n = np.arange(40)
    c = 3.0  # m/s = mm/ms, gap 12 mm
    behind = t[:, None] - n * 12.0 / c  # time since the front passed particle n
    v = 2.0 * (1 + np.tanh(behind / 0.5)) / 2 * (1 + 0.3 * np.sin(behind))
    traj = Trajectory(t=t, x0=12.0 * n, u=np.zeros_like(v), v=v, a=np.gradient(v, t, axis=0) * 1e3)
    fig = shock_figure(traj, list(n + 1), 2.0, measures.front(t, v, traj.a, 2.0, 12.0), v0=1.6)
    assert len(fig.axes) == 5  # four panels and the acceleration axis
    line = fig.axes[1].lines[0]
    expected = measures.propagation_velocity(measures.arrival_times(t, v, 2.0), 12.0)
    np.testing.assert_allclose(line.get_ydata(), expected)
    assert np.nanmedian(line.get_ydata()) == pytest.approx(c, rel=1e-3)


def test_shock_figure_is_labelled():
    """Title, panel letters, gap axis, panel (c) legend with the 2 V_I line (given for a steady
    drive; absent otherwise), marker key, integer ticks."""
    t = np.linspace(0, 100, 2001)
    n = np.arange(40)
    behind = t[:, None] - n * 12.0 / 3.0
    v = 2.0 * (1 + np.tanh(behind / 0.5)) / 2 * (1 + 0.3 * np.sin(behind))
    traj = Trajectory(t=t, x0=12.0 * n, u=np.zeros_like(v), v=v, a=np.gradient(v, t, axis=0) * 1e3)
    front = measures.front(t, v, traj.a, 2.0, 12.0)
    fig = shock_figure(traj, list(n + 1), 2.0, front, v0=1.6, title="demo: V_I = 2 m/s, N = 40", saturation=4.0)
    a, b, c, d = fig.axes[:4]
    assert fig._suptitle.get_text() == "demo: V_I = 2 m/s, N = 40"
    assert [ax.get_title(loc="left") for ax in (a, b, c, d)] == ["(a)", "(b)", "(c)", "(d)"]
    assert b.get_xlabel().startswith("gap n")
    labels = [text.get_text() for text in c.get_legend().get_texts()]
    assert "2 $V_I$ = 4 m/s" in labels and any("acceleration" in label for label in labels)
    assert any(line.get_label().startswith("2 $V_I$") and line.get_ydata()[0] == 4.0 for line in c.lines)
    assert {"maxima", "minima"} <= {text.get_text() for text in d.get_legend().get_texts()}
    for ax in (b, c):
        ticks = ax.xaxis.get_major_locator()()
        assert np.all(ticks == np.round(ticks))
    pulse = shock_figure(traj, list(n + 1), 2.0, front, v0=1.6, title="pulse")
    assert not any(str(line.get_label()).startswith("2 $V_I$") for line in pulse.axes[2].lines)


@pytest.mark.parametrize("setting, expected", [
    ("MPLBACKEND=pdf", "pdf"),  # the environment names one (Jupyter's kernel sets MPLBACKEND to its inline backend)
    ("switch", "svg"),  # the script chose one through pyplot before
    ("", "agg"),  # none chosen: Agg, which needs no screen
])
def test_a_panel_drawn_without_axes_keeps_the_callers_backend(setting, expected, tmp_path):
    """plots.velocity_profiles(t, v, magnets) with no `ax` draws through pyplot: it forced the
    Agg backend every time, so in a notebook (or a script that had chosen its backend) no figure
    showed after it. A backend already chosen is kept; Agg only where none was. A matplotlibrc
    naming the ps backend stands in for matplotlib's own choice, which is Agg by itself on a
    machine without a screen: "agg" can come only from `plots.pyplot`, and each other backend
    only from the caller's choice."""
    import os
    import subprocess
    import sys

    (tmp_path / "matplotlibrc").write_text("backend: ps\n")
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"} | {"MATPLOTLIBRC": str(tmp_path / "matplotlibrc")}
    if setting.startswith("MPLBACKEND="):
        env["MPLBACKEND"] = setting.split("=", 1)[1]
    code = ("import numpy as np, matplotlib\n"
            + ("import matplotlib.pyplot as plt; plt.switch_backend('svg')\n" if setting == "switch" else "")
            + "from pylmp_lattice.plots import velocity_profiles\n"
            "velocity_profiles(np.arange(3.0), np.ones((3, 1)), [2])\n"
            "print(matplotlib.get_backend().lower())\n")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == expected
