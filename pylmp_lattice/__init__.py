"""pylmp_lattice: shock waves in one-dimensional nonlinear lattices, run with LAMMPS.

The Python API, in user units (mm, g, ms, N, m/s):

    import pylmp_lattice as pl
    case = pl.load_case("inputs/paper_experiment.toml", ["run.duration=40"])  # or pl.case_from_dict
    summary = pl.run(case, "runs/example")      # run, measure, summary.json and shock.png
    run = pl.RunFolder("runs/example")          # any run folder: case, status, summary
    traj = run.trajectory()                      # t, x0, u, v, a in user units
    front = run.front()                          # arrival times, V_P per gap, first peaks
    run.figure().savefig("example.png")

`pl.measures` holds every shock measure; `pl.to_atoms`, `pl.write_trajectory` and
`pl.case_from_atoms` connect to ASE.
"""

from importlib import import_module

from .version import __version__

# name -> module; imported on first use, so `import pylmp_lattice` stays light (no LAMMPS, no matplotlib)
_API = {
    "Case": "case", "load_case": "case", "case_from_dict": "case", "case_to_dict": "case",
    "run": "run_folder", "simulate": "run_folder", "execute": "run_folder", "RunFolder": "run_folder",
    "read_run": "run_folder",
    "Trajectory": "trajectory",
    "estimate": "preflight",
    "to_atoms": "ase_io", "write_trajectory": "ase_io", "case_from_atoms": "ase_io",
    "measures": None, "plots": None, "errors": None, "theory": None,
}
# pl.run is run_case; pl.read_run(folder) is RunFolder(folder), kept for earlier scripts
_RENAMED = {"run": "run_case", "read_run": "RunFolder"}
__all__ = [*_API, "__version__"]


def __getattr__(name):
    if name not in _API:
        raise AttributeError(f"module 'pylmp_lattice' has no attribute {name!r}")
    if _API[name] is None:
        return import_module(f".{name}", __name__)
    return getattr(import_module(f".{_API[name]}", __name__), _RENAMED.get(name, name))


def __dir__():
    return sorted(__all__)
