"""MPI ranks: whether more of them will make a run faster (the warnings behind `--np`), and this
process's rank and its job's size where an MPI launcher started it (`launched`).

The chain engine (fix lattice/chain) splits one chain into a slab of magnets per rank and, at
every step, exchanges only the positions across the slab edges and one global flag. A rank's
step then costs about `ATOM_STEP_SECONDS` per magnet it owns plus `EXCHANGE_SECONDS` of
communication, so ranks stop paying once a slab is so short that the exchange costs as much
as the work: below `MIN_MAGNETS_PER_RANK` magnets a rank (benchmarks/bench_mpi.py measures both
costs and docs/performance.md has the numbers). Ranks beyond the cores this process may run on
share cores and only add exchanges.
"""

from __future__ import annotations

import os

from .errors import UsageError

# Measured on the project's 2-core machine (docs/performance.md, "Chain engine on several MPI
# ranks", 2026-11-24): the owned one-pass step with the front record, CPU time per magnet and
# step at 10^4 magnets (benchmarks/bench_engine.py: 0.2636 s for 10^8 magnet-steps), and the
# exchanges of a step on 2 ranks (slab edges and the contact flag) at their fastest step, when
# both ranks had a core (benchmarks/bench_mpi.py: 3.37 and 3.52 us in two runs).
ATOM_STEP_SECONDS = 2.6e-9
EXCHANGE_SECONDS = 3.5e-6
# A slab shorter than this spends more than a tenth of its step exchanging (about 13 000).
MIN_MAGNETS_PER_RANK = round(10 * EXCHANGE_SECONDS / ATOM_STEP_SECONDS)


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS has one, else all)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def rank_warnings(magnets: int, nprocs: int, cores: int | None = None) -> list[str]:
    """One line per reason why `nprocs` ranks will not run one chain of `magnets` magnets
    faster than fewer ranks; empty if they should. (A batch of chains is split by whole chains
    instead, with no exchanges: it gains from every rank up to one chain a rank.)"""
    if nprocs <= 1:
        return []
    cores = usable_cores() if cores is None else cores
    warnings = []
    if nprocs > cores:
        warnings.append(f"--np {nprocs} is more than the {cores} cores this run may use: ranks will share "
                        f"cores and wait for each other at every step, many times slower than --np {cores}")
    per_rank = magnets // nprocs
    if per_rank < MIN_MAGNETS_PER_RANK:
        best = max(1, magnets // MIN_MAGNETS_PER_RANK)
        warnings.append(f"--np {nprocs}: {magnets} magnets give {per_rank} a rank, fewer than the "
                        f"{MIN_MAGNETS_PER_RANK} below which the slab-edge exchange costs over a tenth of a "
                        f"step and more ranks gain little; use --np {best}{'' if best == 1 else ' or fewer'}")
    return warnings


# What MPI launchers set in each rank's environment, its rank and its job's size: MPICH's hydra
# and Intel MPI, Open MPI, MVAPICH (the first pair found counts). Not srun's SLURM_PROCID and
# SLURM_NTASKS: srun without PMI starts processes MPI never joins (and an allocation's every
# process, a sweep's Dask workers among them, sees SLURM_NTASKS).
LAUNCHER_VARIABLES = (("PMI_RANK", "PMI_SIZE"), ("OMPI_COMM_WORLD_RANK", "OMPI_COMM_WORLD_SIZE"),
                      ("MV2_COMM_WORLD_RANK", "MV2_COMM_WORLD_SIZE"))


def launched() -> tuple[int, int]:
    """(rank, size) of the MPI job a launcher (`mpiexec`) started this process in, from the
    variables launchers set, before MPI itself starts; (0, 1) outside such a job."""
    for rank, size in LAUNCHER_VARIABLES:
        r, n = os.environ.get(rank, ""), os.environ.get(size, "")
        if r.isdigit() and n.isdigit() and int(n) >= 1:
            return int(r), int(n)
    return 0, 1


def refuse_launched(command: str) -> None:
    """UsageError where this process is one of several ranks an MPI launcher started: `command`
    runs in one process, and its copies would each run all of it and race for its folder (one
    refused, the other waiting for it in MPI for ever). Only a hand run (`lmp`) runs on ranks."""
    n = launched()[1]
    if n > 1:
        raise UsageError("mpiexec", f"got {n} ranks; {command} runs in one process (its copies would each run "
                                    f"all of it): to run a case on {n} ranks use `pylmp-lattice run CASE --runner lmp "
                                    f"--np {n}`, or in a run folder `mpiexec -n {n} pylmp-lattice lmp -in in.lattice`")
