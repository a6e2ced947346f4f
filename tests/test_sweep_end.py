"""The end of a sweep: what the coordinator loads for it while the members run (`execute._preload`), and the
replica figure drawn while the table's files are written (`execute.ReplicaDrawing`)."""

import subprocess
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from pylmp_lattice.sweep import load_sweep, run_sweep
from pylmp_lattice.sweep import write_replica_stats
from pylmp_lattice.sweep.execute import PRELOAD_THREAD, ReplicaDrawing

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


def test_the_replica_statistics_drawn_beside_the_table_s_write_are_those_drawn_after_it(tmp_path):
    """`run_sweep(stats=ReplicaDrawing())` draws them in the table's last write (not after a
    stop), and what the caller writes from them is byte for byte what write_replica_stats of
    the returned table writes on its own."""
    pytest.importorskip("pylmp_lattice.engines.cpu")
    path = tmp_path / "sweep.toml"
    path.write_text(f'base = "{EXPERIMENT}"\nreplicas = 6\nseed = 5\nkeep = "measures"\n[set]\n'
                    '"chain.thermal_velocity" = 0.02\n"run.duration" = 5.0\n')
    drawing = ReplicaDrawing()
    with ThreadPoolExecutor(1) as pool:
        table = run_sweep(load_sweep(path), tmp_path / "out", executor=pool, slots=1, progress=False, engine="cpu",
                          stats=drawing)
    assert drawing.made is not None and drawing.made[0] is table  # drawn beside the write, of this table
    beside, after = tmp_path / "beside", tmp_path / "after"
    beside.mkdir(), after.mkdir()
    stats = write_replica_stats(beside, table, drawn=drawing.drawn(table))
    assert stats.equals(write_replica_stats(after, table))
    for name in ("replica_stats.csv", "replica_stats.png"):
        assert (beside / name).read_bytes() == (after / name).read_bytes()
    assert (beside / "replica_stats.png").stat().st_size > 1000  # a figure: the replicas' measures scatter


def test_a_replica_drawing_that_failed_raises_where_the_caller_writes_it():
    """A figure that cannot be drawn does not fail the table's write: its error is raised by
    `drawn`, where the caller would have drawn it; a table not drawn is drawn there."""
    import pandas as pd

    drawing = ReplicaDrawing()
    table = pd.DataFrame({"id": ["a"]})  # no status column: replica_stats cannot read it
    drawing(table)
    assert isinstance(drawing.made[1], Exception)
    with pytest.raises(type(drawing.made[1])):
        drawing.drawn(table)
    other = pd.DataFrame({"id": ["b"]})
    with pytest.raises(type(drawing.made[1])):  # drawn again, for this table
        drawing.drawn(other)
