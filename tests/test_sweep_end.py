"""The end of a sweep: what the coordinator loads for it while the members run (`execute._preload`)."""

import subprocess
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from pylmp_lattice.sweep import load_sweep, run_sweep
from pylmp_lattice.sweep.execute import PRELOAD_THREAD

EXPERIMENT = Path(__file__).resolve().parents[1] / "inputs" / "paper_experiment.toml"


@pytest.mark.parametrize("figure", [False, True])
def test_the_figure_is_loaded_and_drawn_once_only_for_a_caller_that_draws_it(figure):
    """pandas and the parquet writer always; matplotlib, a panel drawn (`stats.warm_up`), only
    where the replica figure follows (the CLI's sweep), not for run_sweep's table alone."""
    code = ("import sys\n"
            "from pylmp_lattice.sweep.execute import _preload\n"
            f"_preload({figure}, lambda: False)\n"
            "print(*(m in sys.modules for m in ('pandas', 'pyarrow.parquet', 'matplotlib', 'matplotlib.mathtext')))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["True", "True", str(figure), str(figure)]


def test_a_sweep_returns_only_after_its_figure_s_warm_up(tmp_path):
    """matplotlib is not thread-safe: the caller draws the figure once the coordinator's thread
    that warmed it up has ended."""
    pytest.importorskip("pylmp_lattice.engines.cpu")
    path = tmp_path / "sweep.toml"
    path.write_text(f'base = "{EXPERIMENT}"\nreplicas = 4\nseed = 3\nkeep = "measures"\n[set]\n'
                    '"chain.thermal_velocity" = 0.02\n"run.duration" = 5.0\n')
    with ThreadPoolExecutor(1) as pool:
        table = run_sweep(load_sweep(path), tmp_path / "out", executor=pool, slots=1, progress=False, engine="cpu",
                          stats=True)
    assert list(table["status"]) == ["done"] * 4
    assert not [t for t in threading.enumerate() if t.name == PRELOAD_THREAD]
