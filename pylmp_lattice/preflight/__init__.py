"""Before a run starts: what it will need, and whether this machine can give it.
One concept a module:
- `estimate`: its output size, memory and time (`estimate`, `Estimate`, `file_bytes`, `frames`;
  the engine's time is `overhead.engine_seconds`), linear models calibrated on this project's machine;
- `checks`: the refusals and warnings before a run (`check`, `coarse_dt_warning`), and what
  this machine has (`free_disk`, `available_memory`, `check_writable`).
"""

from .checks import available_memory, check, check_writable, coarse_dt_warning, disk_size, fits, free_disk
from .estimate import (H5MD_BYTES, H5MD_OVERHEAD, SAMPLE, SECONDS_PER_ATOM_FRAME,
                       TEXT_MOVING_EXTRA, TEXT_UNEVEN_EXTRA, Estimate, atom_frames, estimate,
                       file_bytes, frames, output_bytes)
# the sweep's messages and disk check, benchmarks/calibrate_preflight.py
from .estimate import _ChainSample, _duration, _fine_frames, _h5md_group_bytes, _size

__all__ = ["H5MD_BYTES", "H5MD_OVERHEAD", "SAMPLE", "SECONDS_PER_ATOM_FRAME",
           "TEXT_MOVING_EXTRA", "TEXT_UNEVEN_EXTRA", "Estimate", "atom_frames", "available_memory", "check",
           "check_writable", "coarse_dt_warning", "disk_size", "estimate", "file_bytes", "fits", "free_disk", "frames",
           "output_bytes"]
