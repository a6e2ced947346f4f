"""Sweeps and ensembles: many runs from one base case, resumable, on a process pool or Dask.

    from pylmp_lattice.sweep import Sweep, load_sweep, run_sweep, load_results, replica_stats

    if __name__ == "__main__":   # the workers' fork server imports this script again, as "spawn" does
        sweep = Sweep(base="inputs/paper_experiment.toml", grid={"impactor.velocity": [1.0, 2.0]})
        table = run_sweep(sweep, "runs/my_sweep", workers=2)   # a pandas DataFrame, one row per member
        table = load_results("runs/my_sweep")                   # the same table, later

`pylmp-lattice sweep SWEEP.toml -o DIR` does the same from a sweep file (`spec` documents it).
"""

# Loaded on first use (PEP 562): `pylmp_lattice.sweep.pool` can start the workers' fork server
# before numpy, pandas and the engine are loaded here.
from ..lazy import lazy_names

_WHERE = {"run_sweep": "execute", "Member": "spec", "Sweep": "spec", "load_sweep": "spec", "member_id": "spec",
          "member_seed": "seeds", "load_results": "table", "replica_stats": "stats", "plot_replica_stats": "stats",
          "write_replica_stats": "stats", "plot_replica_spread": "stats"}
__all__ = list(_WHERE)
__getattr__, __dir__ = lazy_names(__name__, _WHERE)
