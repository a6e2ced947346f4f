"""A kernel engine on the road of every run (`run_folder.execution.Engine`): a batch of chains
run by the host build (`cpu`) or the GPU build (`gpu`) of the chain kernel into a run folder
that looks as LAMMPS leaves it.

`run_folder.execute_batch` writes the folder (deck, replicas.toml, run.json "running"; no data
file and no levels file, which this engine does not read: their text cost 20-40 us a member of
the worker's Python),
this engine runs it and writes what fix lattice/front and fix lattice/chain write at the end
of a batch: front.bin (one frame, a row per atom, `layout.FRONT_COLUMNS`, engine units) and,
with friction, chain_work.txt (each chain's work, %.17g); the log says which engine ran and how
to run the same chains with LAMMPS: `run_folder.write_folder(RunFolder(folder).cases, NEW)`
writes the deck, the data and the levels files of the chains in replicas.toml. A chain that
stops early (a contact, a gap out of the table range, a measured drive's end) fails the batch
as it fails LAMMPS's: ContactError or RunError.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..case import Case
from ..errors import ContactError, RunError
from ..formats import layout
from ..formats.bindump import write_frame
from ..formats.files import atomic_write
from ..formats.front_record import FrontRows, front_rows
from ..units import from_engine
from . import ENGINES
from .arrays import prepare
from .library import Unsupported, library
from .library import layout as kernel_layout

KERNELS = ENGINES[1:]
# the log's word on the files this engine's folder lacks
NO_DATA = ("no data or levels file: the chains are replicas.toml's; pylmp_lattice.run_folder.write_folder("
           "RunFolder(THIS).cases, NEW) writes them into NEW, which `pylmp-lattice lmp -in in.lattice` runs with LAMMPS")


class KernelEngine:
    """The `kind` engine ("cpu" on `threads` cores, default all; "gpu") for these cases (their
    chains from `draws`, their `case_measures.chain_draws`, if drawn), which
    `run_folder.execute_batch` writes into a folder; Unsupported if it cannot run them. After a
    run, `final` holds the chains' last x (mm) and v (m/s), (R, N) each, as LAMMPS's atoms hold
    them at the end of its batch, and `record` the front record it wrote to front.bin, as
    `formats.front_record.read_front_rows` reads it back (None without one)."""

    nprocs = 1
    reads_chain_files = False  # the chains come as arrays: the folder gets no data or levels file
    final: tuple[np.ndarray, np.ndarray] | None = None
    record: FrontRows | None = None
    _launched = None  # the GPU's batch, launched (`start`)

    def __init__(self, kind: str, cases: list[Case], threads: int | None = None, draws=None):
        if kind not in KERNELS:
            raise ValueError(f"kind: got {kind!r}; expected one of {', '.join(KERNELS)}")
        if kind == "gpu":
            from .gpu import available

            why = available()
            if why:
                raise Unsupported(why)
        library()  # the host build (both engines use it): one not built or of another ABI is refused here, noted once
        self.kind, self.threads = kind, threads
        self.arrays = prepare(list(cases), kind, draws)
        if kind == "gpu":
            from .gpu import too_long

            why = too_long(self.arrays.n)
            if why:
                raise Unsupported(why)

    def check(self, path: Path) -> None:
        """Any folder: the engine reads nothing from it."""

    def start(self) -> None:
        """The GPU's first launch begun (`gpu.launch`), before the road writes the folder: the
        device runs it, or queues it behind the other workers' launches, meanwhile."""
        if self.kind == "gpu" and self._launched is None:
            from .gpu import launch

            self._launched = launch(self.arrays)

    def __call__(self, path: Path, on_step: Callable[[int], None] | None = None) -> None:
        from . import cpu

        a = self.arrays
        if self.kind == "cpu":
            x, v, front, work, end_step, status = cpu.run_arrays(a, self.threads)
        else:
            self.start()
            launched, self._launched = self._launched, None  # (a call after a failed one launches anew)
            x, v, front, work, end_step, status = launched.result()
        self.final = from_engine(x, "length"), from_engine(v, "velocity")
        path = Path(path)
        end = int(end_step.max())
        atomic_write(path / layout.LOG, f"pylmp_lattice {self.kind} engine (the chain kernel, no LAMMPS): {a.chains} "
                                        f"chains of {a.n} magnets, {a.steps} steps of {a.dt:.17g} s; last step {end}\n"
                                        f"{NO_DATA}\n")
        if front is not None:
            write_frame(path / layout.FRONT_BIN, end, end * a.dt, layout.FRONT_COLUMNS, front, ids=True)
            self.record = front_rows(front, end * a.dt, a.chains, a.n)  # (the measures need not read it back)
        if a.friction is not None:
            atomic_write(path / layout.CHAIN_WORK, "%.17g\n" * len(work) % tuple(work.tolist()))
        stopped, names = np.flatnonzero(status), kernel_layout().status
        if stopped.size:
            c = int(stopped[np.argmin(end_step[stopped])])  # the first to stop, as LAMMPS stops at it
            at = float(from_engine(end_step[c] * a.dt, "time"))
            if names[status[c]] == "contact":
                gaps = np.diff(x[c])
                i = int(np.argmin(gaps))
                raise ContactError((i + 1, i + 2), at, float(from_engine(gaps[i], "length")), path)
            raise RunError(f"chain {c + 1} of the batch stopped at t = {at:.6g} ms: {names[status[c]].replace('_', ' ')}",
                           path)
        if on_step is not None:
            on_step(end)


def kernel_engine(kind: str, cases: list[Case], threads: int | None = None, draws=None) -> KernelEngine | str:
    """The kernel engine for these cases, or why it cannot run them (one line)."""
    try:
        return KernelEngine(kind, cases, threads, draws)
    except Unsupported as err:
        return str(err)
