"""The `--np` warnings (more ranks than cores, and slabs too short to gain from more ranks), and
the rank an MPI launcher gave this process."""

from __future__ import annotations

import os

from pylmp_lattice import ranks


def test_one_rank_and_a_long_chain_on_few_ranks_are_not_warned():
    assert ranks.rank_warnings(301, 1, cores=2) == []
    assert ranks.rank_warnings(1_000_000, 2, cores=2) == []


def test_more_ranks_than_cores_is_warned():
    (line,) = ranks.rank_warnings(1_000_000, 4, cores=2)
    assert line.startswith("--np 4 is more than the 2 cores")


def test_a_chain_too_short_for_its_ranks_is_warned_with_the_ranks_that_help():
    n = 3 * ranks.MIN_MAGNETS_PER_RANK
    (line,) = ranks.rank_warnings(n, 4, cores=8)
    assert f"{n} magnets give {n // 4} a rank" in line and line.endswith("use --np 3 or fewer")
    assert ranks.rank_warnings(n, 3, cores=8) == []
    (line,) = ranks.rank_warnings(301, 2, cores=8)
    assert line.endswith("use --np 1")


def test_usable_cores_counts_this_process_affinity():
    assert 1 <= ranks.usable_cores() <= (os.cpu_count() or 1)


def test_launched_reads_a_launcher_s_rank_and_size_together(monkeypatch):
    """(rank, size) where mpiexec started the process (MPICH's PMI_RANK and PMI_SIZE, Open MPI's
    OMPI_COMM_WORLD_RANK and _SIZE, ...), the first whole pair counting; (0, 1) outside one, and
    for srun's SLURM_PROCID alone (srun without PMI starts processes MPI never joins)."""
    for pair in ranks.LAUNCHER_VARIABLES:
        for name in pair:
            monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("SLURM_PROCID", "3")
    assert ranks.launched() == (0, 1)
    monkeypatch.setenv("OMPI_COMM_WORLD_RANK", "1")
    assert ranks.launched() == (0, 1)  # no size: not a pair
    monkeypatch.setenv("OMPI_COMM_WORLD_SIZE", "4")
    assert ranks.launched() == (1, 4)
    monkeypatch.setenv("PMI_RANK", "0")
    monkeypatch.setenv("PMI_SIZE", "2")
    assert ranks.launched() == (0, 2)
    monkeypatch.setenv("PMI_SIZE", "")  # set but empty: the next pair
    assert ranks.launched() == (1, 4)
