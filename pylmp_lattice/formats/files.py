"""Files the package writes: made without following links, whole or not at all.

Every file is written beside its name, in a temporary file that `tempfile.mkstemp` creates
with O_EXCL (a link there fails the creation, never is followed), then renamed over the name
(`os.replace` replaces a link, never writes through it): readers see the old file or the new
one, never a part, and an interrupted write leaves the old one. A link at the name itself is
refused (`LinkError`, one line naming it): a folder that is untrusted input must not turn a
write into one outside it. A full disk is `DiskFull`, naming the file.

`atomic_write` writes bytes or text; `replacing` lends a writer that needs a path (h5py,
matplotlib, ASE) the temporary file; `remove_tree` removes a file, link or folder without
following links. LAMMPS writes its own files (log, dumps, front record) by name: a run is
refused while any of its file names is a link (`refuse_links`, before LAMMPS starts).
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
from pathlib import Path

from ..errors import ConfigError, LatticeError

# The process's umask (read once, at import: reading it means setting it).
UMASK = os.umask(0o022)
os.umask(UMASK)
_FULL = (errno.ENOSPC, errno.EDQUOT)


class LinkError(ConfigError):
    """A symbolic link stands where the package writes a file (or LAMMPS does): refused."""

    def __init__(self, path: str | Path):
        self.path = str(path)
        try:
            target = f" (to {os.readlink(path)})"
        except OSError:
            target = ""
        super().__init__(self.path, f"is a symbolic link{target} where a file is written; links are never written "
                                    "through: remove it, or choose another folder")

    def __reduce__(self):  # pickled from a sweep's worker with its path, not its message
        return LinkError, (self.path,)


class DiskFull(LatticeError):
    """No space (or quota) left on the device while writing `path`; what was written before
    stays. then: what became of the work, for the message."""

    def __init__(self, path: str | Path, then: str = ""):
        self.path, self.then = str(path), then
        super().__init__(f"no space left on the device for {self.path}" + (f"; {then}" if then else ""))

    def __reduce__(self):
        return DiskFull, (self.path, self.then)


def disk_full(err: BaseException) -> bool:
    """Whether an error is a full disk or quota (an OSError's errno, or the text HDF5 reports)."""
    text = str(err)
    return isinstance(err, DiskFull) or (isinstance(err, OSError) and err.errno in _FULL) \
        or "No space left on device" in text or "Disk quota exceeded" in text


def as_disk_full(err: BaseException, where: str | Path) -> DiskFull:
    """A full-disk error (`disk_full`) as DiskFull, naming its file, else `where`."""
    return err if isinstance(err, DiskFull) else DiskFull(getattr(err, "filename", None) or where)


def free_bytes(path: str | Path) -> int:
    """Free bytes (for this user) on the file system that holds `path` (existing)."""
    return shutil.disk_usage(path).free


def refuse_link(path: str | Path) -> None:
    """LinkError if `path` is a symbolic link (dangling or not: lstat)."""
    if os.path.islink(path):
        raise LinkError(path)


def refuse_links(folder: str | Path, names) -> None:
    """LinkError for the first of `names` in `folder` that is a symbolic link."""
    for name in names:
        refuse_link(Path(folder) / name)


def atomic_write(path: str | Path, data: bytes | str | list, sync: bool = False) -> None:
    """Write `data` into `path` through a temporary file renamed over it (see the module); a
    list's texts or bytes one after the other (no copy of them all joined).

    sync: flush it to the disk before it replaces the old one (survives a power cut, not only
    a killed process; about a millisecond per file)."""
    with replacing(path) as tmp, open(tmp, "r+b") as f:  # the file mkstemp made: no link
        for chunk in data if isinstance(data, list) else [data]:
            f.write(chunk.encode() if isinstance(chunk, str) else chunk)
        if sync:
            f.flush()
            os.fsync(f.fileno())


@contextlib.contextmanager
def replacing(path: str | Path, part: str | Path | None = None):
    """Yield a new empty file beside `path` for a writer to fill; when the block ends, it
    replaces `path` (LinkError if `path` is a link); on an error it is removed, and a full disk
    is `DiskFull`. part: the temporary file's name (a leftover of that name, or a link there,
    is removed first); default a fresh name from mkstemp (".NAME.<random>.tmp<suffix>", so that
    writers that read the format from the suffix still can)."""
    path = Path(path)
    refuse_link(path)  # before the work, not only at the end
    try:
        tmp = _create(path, part)
    except OSError as err:
        raise DiskFull(path) if disk_full(err) else err from err
    try:
        yield tmp
        refuse_link(path)
        os.replace(tmp, path)
    except BaseException as err:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if disk_full(err) and not isinstance(err, DiskFull):
            raise DiskFull(path) from err
        raise


def _create(path: Path, part: str | Path | None) -> Path:
    if part is None:
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}")
        tmp = Path(name)
    else:
        tmp = Path(part)
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)  # a leftover, or a link: removed, never followed
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
    try:
        os.fchmod(fd, 0o666 & ~UMASK)  # as open() would make it (mkstemp's are the owner's alone)
    finally:
        os.close(fd)
    return tmp


def remove_tree(path: str | Path) -> None:
    """Remove a file, a link (never what it names) or a folder and what it holds (shutil.rmtree
    removes links inside, never follows them); nothing if missing."""
    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path)
    else:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(path)
