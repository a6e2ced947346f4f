"""The cases a run folder holds, in user units: case.toml for a run of one case, replicas.toml
for a batch of chains (`deck.render_replicas`: cases equal outside [chain], and in name).

replicas.toml holds replica 0's case whole (`case`) and a row per chain (`replica`): the
[chain] fields where it differs from replica 0's (`chain`), those replica 0 gives and it does
not (`unset`), and its name if another. A batch of a sweep's replicas differs in chain.seed
alone: a few bytes a chain, written in microseconds (the whole case per chain took 0.07 ms).
"""

from __future__ import annotations

from dataclasses import fields
from pathlib import Path
from typing import Sequence

import tomli_w

from ..case import Case, case_from_dict, case_to_dict, load_case, read_toml
from ..errors import ConfigError
from ..formats import layout
from ..formats.files import refuse_links


def case_text(case: Case) -> bytes:
    """case.toml of a run of one case."""
    return tomli_w.dumps(case_to_dict(case)).encode()


def replicas_text(cases: Sequence[Case]) -> bytes:
    """replicas.toml of a batch of chains (see the module's docstring)."""
    first = cases[0]
    names = [f.name for f in fields(first.chain) if f.init]
    rows = []
    for case in cases:
        changed = [(n, getattr(case.chain, n)) for n in names if getattr(case.chain, n) != getattr(first.chain, n)]
        row = {"chain": {n: list(v) if isinstance(v, tuple) else v for n, v in changed if v is not None}}
        unset = [n for n, v in changed if v is None]
        row |= ({"unset": unset} if unset else {}) | ({"name": case.name} if case.name != first.name else {})
        rows.append(row)
    return tomli_w.dumps({"case": case_to_dict(first), "replica": rows}).encode()


def read_cases(folder: Path) -> tuple[Case, ...]:
    """The folder's cases: one from case.toml, or a batch's from replicas.toml; ConfigError
    naming the folder if it holds neither (or one that does not read). Never through a link."""
    refuse_links(folder, (layout.CASE, layout.REPLICAS))
    if (folder / layout.CASE).is_file():
        return (load_case(folder / layout.CASE),)
    if not (folder / layout.REPLICAS).is_file():
        raise ConfigError("folder", f"got {str(folder)!r}; expected a run folder (it has no {layout.CASE})")
    data = read_toml(folder / layout.REPLICAS, "folder")
    try:
        base, rows = data["case"], data["replica"]
        chains = [{k: v for k, v in base["chain"].items() if k not in row.get("unset", ())} | row["chain"]
                  for row in rows]
        return tuple(case_from_dict(base | {"chain": chain, "name": row.get("name", base["name"])}, base_dir=folder)
                     for row, chain in zip(rows, chains))
    except (KeyError, TypeError, AttributeError) as err:
        raise ConfigError("folder", f"{folder / layout.REPLICAS} is not a batch's cases ({type(err).__name__}: "
                                    f"{err})") from None
