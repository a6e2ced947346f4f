"""A case's law, drive and front levels in SI as the plugin's fixes (fix lattice/chain, fix
lattice/friction, fix lattice/front) and the kernel engines take them: `law_params`,
`impactor_params`, `impactor_samples`, `front_levels_rows`; their text as fix arguments; and
the one way every number is written into a deck (`_num`: it reads back to the same double)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..case import Case
from ..forcelaw import LinearSpring, PowerLaw
from ..formats.layout import IMPACTOR, in_deck
from ..impactor import Constant, Measured, Ramp, Rest, SinePulse
from ..units import to_engine


def _num(x) -> str:
    """A float as the shortest text that reads back to the same double."""
    return repr(float(x))


def law_params(law) -> tuple[str, tuple[float, ...]] | None:
    """The law in the plugin's analytic form (fix lattice/chain, fix lattice/friction, the engines):
    ("power", (K, b, q)) or ("linear", (k, r_free)), SI; None for a law it only knows as a table.
    New analytic laws of the plugin go here."""
    if isinstance(law, PowerLaw):
        K = law.K * to_engine(1.0, "length") ** law.q  # N mm^q -> N m^q
        return "power", (float(K), float(to_engine(law.b, "length")), float(law.q))
    if isinstance(law, LinearSpring):
        return "linear", (float(to_engine(law.k, "stiffness")), float(to_engine(law.r_free, "length")))
    return None


def _law_args(law) -> str | None:
    """`law_params` as fix arguments; worked out once per law object (a sweep's batch asks for
    each member's, and its members share their point's law: by identity, so that laws equal
    but not alike, K = 0.0 and -0.0, keep their own text)."""
    kept = _LAW_ARGS.get(id(law))
    if kept is None or kept[0] is not law:
        params = law_params(law)
        if len(_LAW_ARGS) >= 64:
            _LAW_ARGS.clear()
        kept = _LAW_ARGS[id(law)] = (law, None if params is None else " ".join([params[0], *map(_num, params[1])]))
    return kept[1]


_LAW_ARGS: dict[int, tuple] = {}  # id(law) -> (law, its arguments): the law is held, so its id is not reused


def impactor_params(imp) -> tuple[str, tuple[float, ...]]:
    """The impactor's motion for fix lattice/chain and the engines (SI): ("constant", (V,)),
    ("ramp", (V, T)), ("sine", (V, T)), ("rest", ()) or ("measured", ()) (`impactor_samples`)."""
    if isinstance(imp, Rest):
        return "rest", ()
    if isinstance(imp, Measured):
        return "measured", ()
    v = float(to_engine(imp.velocity, "velocity"))
    if isinstance(imp, Constant):
        return "constant", (v,)
    if isinstance(imp, Ramp):
        return "ramp", (v, float(to_engine(imp.ramp_time, "time")))
    if isinstance(imp, SinePulse):
        return "sine", (v, float(to_engine(imp.duration, "time")))
    raise TypeError(f"no deck for impactor {imp!r}")


def _impactor_args(imp) -> str:
    """`impactor_params` as fix arguments."""
    kind, values = impactor_params(imp)
    if kind == "measured":
        return f"measured file {in_deck(IMPACTOR)} column {imp.column} after {imp.after}"
    return " ".join([kind, *map(_num, values)])


def impactor_samples(imp: Measured) -> tuple[np.ndarray, np.ndarray]:
    """The measured drive's samples in engine units: t [s] from the first sample, u [m] or v [m/s]."""
    t = to_engine(np.asarray(imp.t, float) - imp.t[0], "time")
    return t, to_engine(np.asarray(imp.values, float), "length" if imp.column == "u" else "velocity")


def front_levels_rows(cases: Sequence[Case], draws=None) -> np.ndarray:
    """Each chain's front levels as fix lattice/front takes them (SI): (R, 5), a row "start front
    drop pulse_drop pulse_floor" per chain (`case_measures.chain_front_levels`; draws: the
    cases' `case_measures.chain_draws`, if drawn)."""
    from ..case_measures import chain_front_levels  # (as in data.chains_data_text)

    lv = chain_front_levels(cases, draws)
    speeds = [to_engine(x, "velocity") for x in (lv.start, lv.front, lv.drop)]
    return np.stack([*speeds, np.full(len(cases), lv.pulse_drop), to_engine(lv.pulse_floor, "velocity")], axis=1)
