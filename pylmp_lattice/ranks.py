"""Whether more MPI ranks will make a run faster: the warnings behind `--np`.

The chain engine (fix lattice/chain) splits a chain into one slab of magnets per rank and, at
every step, exchanges only the positions across the slab edges and one global flag. A rank's
step then costs about `ATOM_STEP_SECONDS` per magnet it owns plus `EXCHANGE_SECONDS` of
communication, so ranks stop paying once a slab is so short that the exchange costs as much
as the work: below `MIN_MAGNETS_PER_RANK` magnets a rank (benchmarks/bench_mpi.py measures both
costs and docs/performance.md has the numbers). Ranks beyond the cores this process may run on
share cores and only add exchanges.
"""

from __future__ import annotations

import os

# Measured by benchmarks/bench_mpi.py on the project's 2-core machine (docs/performance.md,
# "MPI ranks"): the owned one-pass step with the front record, per magnet and step, and the
# per-step cost of the slab-edge exchange plus the contact flag's allreduce, 2 ranks.
ATOM_STEP_SECONDS = 2.8e-9
EXCHANGE_SECONDS = 6e-6
# A slab shorter than this spends more than a tenth of its step exchanging.
MIN_MAGNETS_PER_RANK = round(10 * EXCHANGE_SECONDS / ATOM_STEP_SECONDS)


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the OS has one, else all)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def rank_warnings(magnets: int, nprocs: int, cores: int | None = None) -> list[str]:
    """One line per reason why `nprocs` ranks will not run `magnets` magnets (per chain, as
    slabs cut every chain of a batched run) faster than fewer ranks; empty if they should."""
    if nprocs <= 1:
        return []
    cores = usable_cores() if cores is None else cores
    warnings = []
    if nprocs > cores:
        warnings.append(f"--np {nprocs} is more than the {cores} cores this run may use: ranks will share "
                        f"cores and run slower than --np {cores}")
    per_rank = magnets // nprocs
    if per_rank < MIN_MAGNETS_PER_RANK:
        best = max(1, magnets // MIN_MAGNETS_PER_RANK)
        warnings.append(f"--np {nprocs}: {magnets} magnets give {per_rank} a rank, fewer than the "
                        f"{MIN_MAGNETS_PER_RANK} a rank needs to gain from the slab-edge exchange; "
                        f"use --np {best} or fewer")
    return warnings
