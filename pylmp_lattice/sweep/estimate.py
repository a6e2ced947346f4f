"""A sweep's time, command to exit, told before it starts (`_estimate`)."""

from __future__ import annotations

from . import batch
from .spec import Sweep


def _estimate(sweep: Sweep, total: int, workers: int, stats: bool = False) -> str:
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
    seconds = contention() * ((costs.replica_s if stats else costs.sweep_s) + work / workers + serial) + device
    return (f"about {_duration(seconds)} on {workers} worker{'s' if workers > 1 else ''} ({kind}"
            f"{', the replica statistics and figure included' if stats else ''}), if all are like the first")
