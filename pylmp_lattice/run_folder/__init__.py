"""Run folders: the one home of a run's files.

- `write`: a case into a folder (deck, input files, case.toml, run.json);
- `execution`: `execute`/`run_case`/`simulate`, the one way a case becomes a run (preflight,
  write, run LAMMPS, record how it ended, convert, summarize);
- `marker`: the folder's state (run.json, the runner's lock, how the run stands);
- `convert`: binary dumps into traj.h5md, by the writer after a run or by the reader later;
- `folder`: `RunFolder`, which reads, caches, measures and summarizes any run folder.

The names of its files and their readers are the floor below, `formats` (`formats.layout` names
every file). Names here are imported on first use.
"""

from importlib import import_module

_API = {"RunFolder": "folder", "write_folder": "write", "execute": "execution", "run_case": "execution", "simulate": "execution",
        "simulate_replicas": "execution", "split_replicas": "execution", "write_replicas_folder": "execution",
        "RUNNERS": "execution"}
__all__ = list(_API)


def __getattr__(name):
    if name not in _API:
        raise AttributeError(f"module 'pylmp_lattice.run_folder' has no attribute {name!r}")
    return getattr(import_module(f".{_API[name]}", __name__), name)


def __dir__():
    return sorted(__all__)
