"""Run folders: the one home of a run's files.

- `claim`: every check of a folder before a run writes it, once, and its lock;
- `write`: a case, or a batch of chains, into a claimed folder (deck, input files, its cases,
  run.json);
- `execution`: `execute`/`execute_batch`/`run_case`/`simulate`, the one road from cases to a run
  (claim, preflight, write, run an engine, record how it ended, convert, summarize);
- `marker`: the folder's state (run.json, the runner's lock, how the run stands);
- `cases`: the folder's cases (case.toml, or a batch's replicas.toml);
- `convert`: binary dumps into traj.h5md, by the writer after a run or by the reader later;
- `folder`: `RunFolder`, which reads, caches, measures and summarizes any run folder.

The names of its files and their readers are the floor below, `formats` (`formats.layout` names
every file). Names here are imported on first use.
"""

from importlib import import_module

_API = {"RunFolder": "folder", "write_folder": "write", "execute": "execution", "execute_batch": "execution",
        "run_case": "execution", "simulate": "execution", "Lammps": "execution", "RUNNERS": "execution"}
__all__ = list(_API)


def __getattr__(name):
    if name not in _API:
        raise AttributeError(f"module 'pylmp_lattice.run_folder' has no attribute {name!r}")
    return getattr(import_module(f".{_API[name]}", __name__), name)


def __dir__():
    return sorted(__all__)
