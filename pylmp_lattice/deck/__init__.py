"""The LAMMPS input deck of a case: pure functions from a `Case` to file texts.

`render(case)` returns {file name: text}: the deck `in.lattice`, the data file `chain.data`
and the potential table `force.table`. Written into one folder, `lmp -in in.lattice` runs it.
`render_replicas(cases)` puts several chains of equal length into one deck (chain engine);
`render_folder(cases)` is either, as a run folder holds it.
Engine units are LAMMPS `units si`; every user value passes through `units.to_engine` here.
One concept a module:
- `script`: the deck `in.lattice` (`deck_text`): header, output, run;
- `chain_engine`, `stock`: its sections 1-4 for each engine;
- `data`: the data file of one chain or a batch (`data_text`, `chains_data_text`);
- `tables`: the other files a deck reads (force tables, the measured drive's samples);
- `replicas`: a batch of chains in one deck (`render_replicas`, `replica_batch`);
- `kind`: which deck a case gets (`uses_chain_engine`, `per_atom_masses`, `atom_types`, `records_front`);
- `engine_args`: the law, drive and front levels in SI as the plugin's fixes and the kernel
  engines take them (`law_params`, `impactor_params`, `impactor_samples`, `front_levels_rows`).
"""

from __future__ import annotations

from collections.abc import Sequence

from ..case import Case
from ..formats.layout import DATA, DECK
from .data import chains_data_text, data_text
from .engine_args import front_levels_rows, impactor_params, impactor_samples, law_params
from .kind import atom_types, per_atom_masses, records_front, uses_chain_engine
from .replicas import _FRONT_FIX, render_replicas, replica_batch, replica_range  # _FRONT_FIX: tests/test_sweep.py
from .script import deck_text
from .tables import _tables

__all__ = ["DATA", "DECK", "atom_types", "chains_data_text", "data_text", "deck_text", "front_levels_rows",
           "impactor_params", "impactor_samples", "law_params", "per_atom_masses", "records_front", "render", "render_folder",
           "render_replicas", "replica_batch", "replica_range", "uses_chain_engine"]


def render(case: Case) -> dict[str, str]:
    """The LAMMPS input of `case`: {file name: text}, the deck (`in.lattice`), the data file
    (`chain.data`), the force table(s) and, for a measured drive, its samples (`impactor.txt`).

    A pure function: no file is read or written, and the same case gives the same texts. Every
    value is converted to LAMMPS `units si` here (`units.to_engine`) and written so that it reads
    back to the same double; the case's name appears only in comments. Written into one folder,
    `lmp -in in.lattice` runs it (`run_folder.write` does that, with case.toml and run.json)."""
    return {DECK: deck_text(case), DATA: data_text(case), **_tables(case)}


# render_folder calls render_replicas through this module, so that replacing
# deck.render_replicas (tests/test_sweep.py) reaches every run folder's deck.
def render_folder(cases: Sequence[Case], draws=None, chain_files: bool = True) -> dict[str, str]:
    """The deck files of a run folder of one case (`render`) or of a batch of chains
    (`render_replicas`; draws: their `case_measures.chain_draws`, if drawn; without
    `chain_files`, no data and levels files): a batch whose cases write no per-frame output
    (output.format = "none") records every chain's front; else it writes one text dump of all
    chains."""
    if len(cases) == 1:
        return render(cases[0])
    return render_replicas(cases, front=cases[0].output.format == "none", draws=draws, chain_files=chain_files)
