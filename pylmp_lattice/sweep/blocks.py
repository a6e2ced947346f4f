"""A sweep's tasks, sized: consecutive members of one parameter point, as many as one instance
allows, shared evenly by the workers, smaller toward the end (`_Blocks`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from . import batch
from .spec import Member

# A task's members: at most this many atoms, atom-steps (about 0.7 s of engine time: a batch of
# the 21-magnet experiment with friction and the front record runs 5e7 atom-steps in 0.33 s,
# docs/performance.md) and atom types (LAMMPS keeps some per-type-pair tables; with masses per
# magnet each chain may add one, `deck.chains_data_text`, else the chains share theirs) in one
# instance. Each instance costs about 0.05 s to set up, so tasks are as large as these allow,
# shared evenly by the workers.
# A sweep of several rounds of tasks (more than one task per worker) ends with tasks that shrink
# (each at most the members left over 2 x the workers, at least the full size over TAIL), so that
# the workers finish together: with equal tasks, the noise of a shared machine and the
# coordinator's work left one of 2 workers idle for 0.1-0.3 s at the end of 10^4 members (each
# task 0.4-0.5 s with engine "cpu").
TAIL = 4
MAX_ATOMS = 200_000
MAX_ATOM_STEPS = 1e8
MAX_TYPES = 1024
# A task's atoms with engine = "gpu" (no LAMMPS instance: a batch as large as the host's arrays
# and the device allow; 4e6 atoms are about 0.4 GB on the device, 2e5 members of 21 magnets)
GPU_MAX_ATOMS = 4_000_000
# ... and at most GPU_TASK_CHAINS members, about one wave of the device (an H200's 132 SMs hold
# 34k of the kernel's threads at 254 registers, docs/performance.md; more at fewer): the
# processes' launches run one after another (no MPS) while each task's Python, about 0.1 ms a
# member (0.9 s for 10^4 in one task on this 2-core VM), 20 % of it before its launch, runs in
# parallel, so 10^6 members in 32 tasks of 31250 (2 rounds) keep the device and the cores busy
# together, where 16 of 62500 (2 waves each: the same device time) had every worker wait for the
# queue of launches, then work alone.
GPU_TASK_CHAINS = 32768
# ... and at least GPU_MIN_MEMBERS where the sweep has them: each GPU task's process starts CuPy
# and a CUDA context, and each launch takes at least one chain's run: 10^4 members run as 2 tasks,
# not 16 of 625 (16 starts and 16 launches one after another); 10^5 as one task per worker.
GPU_MIN_MEMBERS = 5000


@dataclass
class _Blocks:
    """Task sizes: the members in as few tasks as one instance allows (MAX_*), their number a
    multiple of the workers, so that every worker gets an equal share; a task holds one point's
    members, so the few points of a sweep are split in equal parts (3 points on 2 workers: 6
    tasks, not 3 of which one worker would run 2). With several rounds of tasks (not with engine
    "gpu": the workers share one device, which needs large launches), the last ones shrink (TAIL).
    With engine "gpu" a sweep of fewer than GPU_MIN_MEMBERS a worker has fewer tasks than workers."""

    todo: int  # members to run (at least)
    slots: int
    points: int = 1  # parameter points
    replicas: int = 1  # members per point
    limits: dict = field(default_factory=dict)
    engine: str = "lammps"
    left: int | None = None  # members not yet in a task (default: todo)

    def next_size(self, m: Member) -> int:
        """The size of the task that starts with member `m`."""
        tasks = self.slots * math.ceil(self.todo / (self.slots * self._cap(m)))
        if self.engine == "gpu":
            tasks = min(tasks, max(math.ceil(self.todo / GPU_MIN_MEMBERS), math.ceil(self.todo / self._cap(m))))
        ways = min(tasks, self.slots)  # the workers that share the members
        # parts per point: until the tasks fill those workers evenly, or are too many to matter
        parts = next(k for k in range(1, ways + 1)
                     if (self.points * k) % ways == 0 or self.points * k >= 4 * ways)
        size = max(1, min(math.ceil(self.todo / tasks), math.ceil(self.replicas / parts)))
        left = self.todo if self.left is None else self.left
        if tasks > self.slots and self.engine != "gpu":
            size = min(size, max(size // TAIL, math.ceil(left / (2 * self.slots)), 1))
        self.left = max(0, left - size)
        return size

    def _cap(self, m: Member) -> int:
        """Members of this point one instance may hold (1 if they cannot be batched)."""
        point = m.point
        if point not in self.limits:
            case = m.case
            if case is None or not batch.batchable(case):
                self.limits[point] = 1
            else:
                from ..deck import per_atom_masses

                n = case.chain.particles
                caps = [MAX_ATOMS // n, int(MAX_ATOM_STEPS // (n * case.run.steps()))]
                if self.engine == "gpu":
                    caps = [GPU_MAX_ATOMS // n, GPU_TASK_CHAINS]
                elif per_atom_masses(case):  # each chain may add an atom type; else the chains share theirs
                    caps.append(MAX_TYPES)
                self.limits[point] = max(1, min(caps))
        return self.limits[point]
