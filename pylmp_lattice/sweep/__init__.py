"""Sweeps and ensembles: many runs from one base case, resumable, on a process pool or Dask.

    from pylmp_lattice.sweep import Sweep, load_sweep, run_sweep, load_results, replica_stats

    sweep = Sweep(base="inputs/paper_experiment.toml", grid={"impactor.velocity": [1.0, 2.0]})
    table = run_sweep(sweep, "runs/my_sweep", workers=2)   # a pandas DataFrame, one row per member
    table = load_results("runs/my_sweep")                   # the same table, later

`pylmp-lattice sweep SWEEP.toml -o DIR` does the same from a sweep file (`spec` documents it).
"""

from .execute import run_sweep
from .spec import Member, Sweep, load_sweep, member_id, member_seed
from .table import load_results

_STATS = ("replica_stats", "plot_replica_stats", "write_replica_stats")


def __getattr__(name: str):
    """The statistics load pandas (a second of start-up): imported when first asked for."""
    if name in _STATS:
        from . import stats

        return getattr(stats, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

__all__ = ["Member", "Sweep", "load_sweep", "member_id", "member_seed", "run_sweep", "load_results",
           "replica_stats", "plot_replica_stats", "write_replica_stats"]
