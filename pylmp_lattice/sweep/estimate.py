"""A sweep's time, command to exit, told before it starts (`_estimate`)."""

from __future__ import annotations

from . import batch
from .spec import Sweep

# A batched member beyond its atom-steps, for the estimate: its share of the worker's Python
# (0.23 ms, docs/performance.md "Worker Python per batched member"); a member run alone costs
# this machine's `overhead.Overheads.member_s`.
BATCHED_SECONDS = 2.3e-4


def _estimate(sweep: Sweep, total: int, workers: int, stats: bool = False) -> str:
    """The sweep's time, command to exit, from the first member's case, preflight's model and
    this machine's overheads (`overhead`, measured once, at the contention now): its start-up
    and end (with the replica statistics and figure if `stats`: the CLI draws them), then in
    its workers each task's overhead (a member run alone, or a point's batch of replicas) and,
    per member, a batched one's atom-steps (the instance's cost per step is the task's) and
    BATCHED_SECONDS, one run alone its engine and output."""
    from ..overhead import overheads
    from ..preflight.estimate import (SECONDS_PER_ATOM_FRAME, SECONDS_PER_ATOM_STEP, SECONDS_PER_STEP, _duration,
                                      atom_frames, engine_seconds)

    first = next(sweep.iter_members(), None)
    if first is None or first.case is None:
        return "no estimate"
    case, costs = first.case, overheads(measure=True)
    n, steps = case.chain.particles, case.run.steps()
    if sweep.replicas > 1 and batch.batchable(case):  # a task holds one point's members
        each, kind = SECONDS_PER_ATOM_STEP * n * steps + BATCHED_SECONDS, "batched"
        tasks = -(-total // sweep.replicas) * (costs.member_s + SECONDS_PER_STEP * steps)
    else:
        each = engine_seconds(n, steps) + SECONDS_PER_ATOM_FRAME[case.output.format] * atom_frames(case)
        tasks, kind = total * costs.member_s, "each run alone"
    stats = stats and sweep.replicas > 1
    seconds = (costs.replica_s if stats else costs.sweep_s) + (each * total + tasks) / workers
    return (f"about {_duration(seconds)} on {workers} worker{'s' if workers > 1 else ''} ({kind}"
            f"{', the replica statistics and figure included' if stats else ''}), if all are like the first")
