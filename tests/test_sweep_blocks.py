"""Task sizes (`sweep.blocks._Blocks`): a sweep of several rounds of tasks ends with smaller ones,
so that the workers finish together."""

import heapq
from pathlib import Path

import pytest

from pylmp_lattice.sweep import Sweep
from pylmp_lattice.sweep.blocks import TAIL, _Blocks

ROOT = Path(__file__).resolve().parents[1]


def _sizes(todo: int, slots: int, engine: str = "lammps") -> list[int]:
    sweep = Sweep(base=ROOT / "inputs" / "paper_experiment.toml", set={"chain.thermal_velocity": 0.02},
                  replicas=todo, seed=1, keep="measures")
    first = next(sweep.iter_members())
    blocks, sizes = _Blocks(todo, slots, 1, todo, engine=engine), []
    while sum(sizes) < todo:  # (as `execute._Coordinator._tasks` takes them: the last one is what is left)
        sizes.append(min(blocks.next_size(first), todo - sum(sizes)))
    return sizes


def _finish_gap(sizes: list[int], slots: int, late: float) -> float:
    """Members' worth of time between the first and the last worker's end, each worker taking
    the next task when free, one of them starting `late` members' worth later."""
    free = [0.0] * (slots - 1) + [late]
    heapq.heapify(free)
    for size in sizes:
        heapq.heappush(free, heapq.heappop(free) + size)
    return max(free) - min(free)


@pytest.mark.parametrize("engine", ["lammps", "cpu"])
def test_ten_thousand_members_end_with_smaller_tasks_and_the_workers_finish_together(engine):
    """10^4 members of the 21-magnet experiment on 2 workers: 8 full tasks (834, as many as an
    instance allows over an even share), then smaller ones down to a quarter of that; a worker
    that starts 300 members' time late (its first task's imports) ends at most one last task
    after the other, where 12 equal tasks (834, the last 826) left one idle for 292."""
    sizes = _sizes(10_000, 2, engine)
    assert sum(sizes) == 10_000 and sizes[:8] == [834] * 8
    assert sizes == sorted(sizes, reverse=True) and min(sizes[:-1]) == 834 // TAIL
    assert _finish_gap([834] * 11 + [826], 2, 300) == 292  # (main's tasks)
    assert _finish_gap(sizes, 2, 300) <= 834 // TAIL


@pytest.mark.parametrize(("todo", "engine", "expected"), [(1000, "lammps", [500, 500]), (1000, "cpu", [500, 500]),
                                                           (40_000, "gpu", [20_000, 20_000])])
def test_one_round_of_tasks_and_the_gpu_s_keep_equal_tasks(todo, engine, expected):
    """One task per worker (nothing to balance later) keeps equal shares; so does engine "gpu",
    whose workers share one device that needs large launches."""
    assert _sizes(todo, 2, engine) == expected


@pytest.mark.parametrize(("todo", "expected"), [(1000, [1000]), (10_000, [5000] * 2), (100_000, [6250] * 16),
                                                (10**6, [31250] * 32)])
def test_gpu_tasks_hold_from_5000_members_to_a_wave_of_the_device(todo, expected):
    """Engine "gpu" on 16 workers: a task has at least GPU_MIN_MEMBERS members where the sweep
    has them (each task's process starts a CUDA context, and the processes' launches run one
    after another), so 10^4 members run in 2 tasks, not 16 of 625; from 8e4 members on, one
    task per worker, and at most GPU_TASK_CHAINS (about a wave of the device): 10^6 members in 2
    rounds of 16 tasks, whose launches take turns with the other tasks' Python."""
    from pylmp_lattice.sweep.blocks import GPU_MIN_MEMBERS, GPU_TASK_CHAINS

    assert (GPU_MIN_MEMBERS, GPU_TASK_CHAINS) == (5000, 32768) and _sizes(todo, 16, "gpu") == expected
    assert _sizes(todo, 16, "cpu")[0] <= -(-todo // 16)  # the other engines: every worker from the start
