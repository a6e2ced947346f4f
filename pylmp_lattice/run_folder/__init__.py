"""Run folders: the one home of a run's files (`layout`), the `RunFolder` that writes, reads and
summarizes one (`folder`), and `execute`/`run_case`/`simulate` (`execution`), the one way a case
becomes a run.

Names are imported on first use: the deck writer and the readers import `run_folder.layout` alone,
without the layers above them.
"""

from importlib import import_module

_API = {"RunFolder": "folder", "execute": "execution", "run_case": "execution", "simulate": "execution",
        "simulate_replicas": "execution", "split_replicas": "execution", "write_replicas_folder": "execution",
        "RUNNERS": "execution"}
__all__ = list(_API)


def __getattr__(name):
    if name not in _API:
        raise AttributeError(f"module 'pylmp_lattice.run_folder' has no attribute {name!r}")
    return getattr(import_module(f".{_API[name]}", __name__), name)


def __dir__():
    return sorted(__all__)
