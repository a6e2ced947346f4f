"""A sweep's disk: what its members will write, summed and checked against the free space
before any member runs (`check`), with or without --yes.

A member's files are `preflight.file_bytes` of its case: run alone, its whole run folder (the
force table is most of it when no trajectory is kept); batched (replicas of a point the chain
engine holds together, `batch.batchable`), its chain's data and front record, and its share
of the batch's table and small files, one batch per point and worker at most (a kernel engine's
batch, engine cpu or gpu, has no data file and no force table: `engines.road`; on a Dask
scheduler, whose workers are not counted before it is reached, from one batch per point to one
per replica, and the check refuses only what the least cannot fit); and its share
of the sweep's records (RECORD_BYTES). The bytes of a member are the mean over up to SAMPLES
parameter points spread over the grid, built without enumerating the members: a grid over N or
the duration is seen at both ends.
"""

from __future__ import annotations

import math
from pathlib import Path

from ..errors import ConfigError, UsageError
from .seeds import member_seed
from .spec import Sweep, _is_random

SAMPLES = 8
# A member's share of the sweep's own records, beyond its run folder: its rows of results.csv and
# .parquet and, batched, its entries in members.json and members.arrow and its lines of the
# batch's replicas.toml and chain_work.txt (1175 bytes for a thermal replica of the 21-magnet
# experiment in a 600-member sweep, 1480 in one of 10^5, engine cpu and gpu alike, 2026-11-27 16:20
# UTC; 2000 before overestimated a 10^6-member GPU sweep's disk by 1.7x with the data file below)
RECORD_BYTES = 1500.0


def member_bytes(sweep: Sweep, slots: int | None) -> float | None:
    """Mean bytes on disk of a member (see the module) on `slots` workers (None: as many batches
    of a point as it has replicas, the most there can be); None if no sampled point is a valid
    case."""
    from ..case import case_from_dict
    from ..engines import ENGINES
    from ..formats.layout import DATA, FRONT_BIN, TABLE
    from ..preflight import file_bytes
    from .batch import batchable

    axes = [[{k: v} for v in values] for k, values in sweep.grid.items()]
    if sweep.zip:
        axes.append([dict(zip(sweep.zip, row)) for row in zip(*sweep.zip.values())])
    points = math.prod(len(a) for a in axes)
    sizes = []
    samples = min(points, SAMPLES)  # the first and last point among them
    for k in sorted({round(i * (points - 1) / max(1, samples - 1)) for i in range(samples)}):
        point = {}
        for axis in reversed(axes):  # itertools.product's order: the last axis varies fastest
            k, j = divmod(k, len(axis))
            point |= axis[j]
        data = sweep._data(point)
        if _is_random(data):
            data.setdefault("chain", {}).setdefault("seed", member_seed(sweep.seed, 0))
        try:
            case = case_from_dict(data, base_dir=sweep.base_dir)
        except ConfigError:  # an invalid member writes (almost) nothing
            continue
        files = file_bytes(case)
        if sweep.replicas > 1 and batchable(case):
            own = files[DATA] + files.get(FRONT_BIN, 0.0)
            shared = sum(files.values()) - own
            if sweep.engine in ENGINES[1:]:  # the kernel's: chains as arrays, no data file, no force table
                own, shared = own - files[DATA], shared - files.get(TABLE, 0.0)
            batches = sweep.replicas if slots is None else min(sweep.replicas, slots)  # of a point, at most
            sizes.append(own + shared * batches / sweep.replicas + RECORD_BYTES)
        else:
            sizes.append(sum(files.values()) + RECORD_BYTES)
    return sum(sizes) / len(sizes) if sizes else None


def check(sweep: Sweep, root: str | Path, todo: int, slots: int | None) -> str:
    """UsageError unless `todo` members' files fit the free space where `root` is (or will be);
    returns the need as text ("about 12 MB on disk"). slots: the pool's workers
    (`pool.pool_slots`); None on a Dask scheduler, whose workers are not counted here: its
    batched members need from their size at one batch per point (what is checked: "at least")
    to that at one per replica, and the text says both ("about 2.6 to 10 MB on disk, ...")."""
    from ..preflight import _size, free_disk

    each = member_bytes(sweep, slots or 1)
    if each is None:
        return "no disk estimate"
    most = each if slots is not None else member_bytes(sweep, None)
    need, free = each * todo, free_disk(root)
    if need > free:
        raise UsageError("-o", f"the sweep needs {'' if most == each else 'at least '}about {_size(need)} on disk "
                          f"({todo} members to run, about {_size(each)} each) and {root} has {_size(free)} free; free "
                          "space or sweep fewer members"
                          + ('' if sweep.keep == "measures" else ', or set keep = "measures" (no trajectories)'))
    if most == each:
        return f"about {_size(need)} on disk"
    return (f"about {_size(need)} to {_size(most * todo)} on disk, as the Dask scheduler's workers run a point's "
            f"{sweep.replicas} replicas in 1 to {sweep.replicas} batches" + (f" ({root} has {_size(free)} free)"
                                                                              if most * todo > free else ""))
