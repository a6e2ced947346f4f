"""The cases a run folder holds, in user units: case.toml for a run of one case, replicas.toml
for a batch of chains (`deck.render_replicas`: cases equal outside [chain], and in name).

replicas.toml holds replica 0's case whole (`case`), the number of chains (`count`), and a
column per [chain] field in which the chains differ (`chains`, one value per chain; `unset`:
the chains that leave a field out, whose place in its column holds a stand-in), and their names
if they differ (`names`). A batch of a sweep's replicas differs in chain.seed alone: one column
of integers, written in 0.1 ms for 300 chains (a table per chain took 1.9 ms, the whole case
per chain 20 ms).
"""

from __future__ import annotations

from dataclasses import fields
from operator import attrgetter
from pathlib import Path
from typing import Sequence

import tomli_w

from ..case import Case, case_from_dict, case_to_dict, load_case, read_toml
from ..errors import UsageError
from ..formats import layout
from ..formats.files import refuse_links


def case_text(case: Case) -> bytes:
    """case.toml of a run of one case."""
    return tomli_w.dumps(case_to_dict(case)).encode()


def replicas_text(cases: Sequence[Case]) -> bytes:
    """replicas.toml of a batch of chains (see the module's docstring)."""
    first = cases[0]
    chains = [case.chain for case in cases]
    columns, unset = {}, {}
    for f in (f for f in fields(first.chain) if f.init):
        values = list(map(attrgetter(f.name), chains))
        if values.count(values[0]) == len(values):  # all equal (a list's count, at C speed; no field is NaN)
            continue
        given = next(v for v in values if v is not None)
        columns[f.name] = [list(v) if isinstance(v, tuple) else v for v in (given if v is None else v for v in values)]
        if None in values:
            unset[f.name] = [r for r, v in enumerate(values) if v is None]
    names = [case.name for case in cases]
    data = {"count": len(cases), "case": case_to_dict(first), "chains": columns, "unset": unset,
            **({"names": names} if len(set(names)) > 1 else {})}
    return tomli_w.dumps(data).encode()


def read_cases(folder: Path) -> tuple[Case, ...]:
    """The folder's cases: one from case.toml, or a batch's from replicas.toml; UsageError
    naming the folder if it holds neither (or one that does not read). Never through a link."""
    refuse_links(folder, (layout.CASE, layout.REPLICAS))
    if (folder / layout.CASE).is_file():
        return (load_case(folder / layout.CASE),)
    if not (folder / layout.REPLICAS).is_file():
        raise UsageError("folder", f"got {str(folder)!r}; expected a run folder (it has no {layout.CASE})")
    data = read_toml(folder / layout.REPLICAS, "folder")
    try:
        base, count, columns, unset = data["case"], data["count"], data["chains"], data["unset"]
        names = data.get("names", [base["name"]] * count)
        cases = []
        for r in range(count):
            chain = base["chain"] | {k: column[r] for k, column in columns.items()}
            chain = {k: v for k, v in chain.items() if r not in unset.get(k, ())}
            cases.append(case_from_dict(base | {"chain": chain, "name": names[r]}, base_dir=folder))
        return tuple(cases)
    except (KeyError, IndexError, TypeError, AttributeError) as err:
        raise UsageError("folder", f"{folder / layout.REPLICAS} is not a batch's cases ({type(err).__name__}: "
                                    f"{err})") from None
