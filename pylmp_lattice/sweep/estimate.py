"""A sweep's time, command to exit, told before it starts (`_estimate`)."""

from __future__ import annotations

from . import batch
from .spec import Sweep


def _estimate(sweep: Sweep, total: int, workers: int | None, stats: bool = False) -> str:
    """The sweep's time, command to exit, from the first member's case, preflight's model and
    this machine's overheads (`overhead`, measured once, at the contention now): its start-up
    and end (with the replica statistics and figure if `stats`: the CLI draws them), then in
    its workers each task's overhead (a member run alone, or a point's batch of replicas) and,
    per member, a batched one's atom-steps (the instance's cost per step is the task's) and
    worker Python (`overhead.batched_seconds`: a kernel engine's has no instance, and less
    Python), and the coordinator's share (COORDINATOR_SECONDS, one member after another), one
    run alone its engine and output; all times the contention now. With engine "gpu" a batched
    member's atom-steps run on the one device, not in the workers (`overhead.gpu_seconds`). The
    overheads are measured (LAMMPS commands in child processes) only for engine "lammps": a
    kernel engine's sweep runs none, and a machine without LAMMPS (a GPU machine's image) failed
    the measurement, uncached, on every sweep (1-3 s).
    workers None: a Dask scheduler's, whose number is not known here; the time its workers
    share is then said apart from the rest.
    """
    from ..overhead import COORDINATOR_SECONDS, batched_seconds, contention, engine_seconds, gpu_seconds, overheads
    from ..preflight.estimate import SECONDS_PER_ATOM_FRAME, _duration, atom_frames

    first = next(sweep.iter_members(), None)
    if first is None or first.case is None:
        return "no estimate"
    case, costs = first.case, overheads(measure=sweep.engine == "lammps")
    n, steps = case.chain.particles, case.run.steps()
    device = serial = 0.0  # the GPU's seconds (its kernels do not run in parallel over the workers), the coordinator's
    if sweep.replicas > 1 and batch.batchable(case):  # a task holds one point's members
        tasks = -(-total // sweep.replicas)
        work = batched_seconds(tasks, total, n, steps, costs.member_s, sweep.engine)
        device = gpu_seconds(total * n * steps) if sweep.engine == "gpu" else 0.0
        serial = total * COORDINATOR_SECONDS
        kind = "batched"
    else:
        each = engine_seconds(n, steps) + SECONDS_PER_ATOM_FRAME[case.output.format] * atom_frames(case)
        work, kind = total * (each + costs.member_s), "each run alone"
    stats = stats and sweep.replicas > 1
    load = contention()
    fixed = load * ((costs.replica_s if stats else costs.sweep_s) + serial) + device
    if workers is None:
        said = f"{_duration(fixed)} plus {_duration(load * work)} shared by the Dask scheduler's workers"
    else:
        said = f"{_duration(fixed + load * work / workers)} on {workers} worker{'s' if workers > 1 else ''}"
    return (f"about {said} ({kind}{', the replica statistics and figure included' if stats else ''}), "
            "if all are like the first")
