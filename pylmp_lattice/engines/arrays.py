"""A batch of ensemble members as the kernel engines take it (engine units, `units`): shared by
`engines.cpu` and `engines.gpu`.

The members are those a sweep batches in one LAMMPS instance (`deck.render_replicas`): equal N,
everything but [chain] equal, output.format = "none". Every number is the one the LAMMPS deck
passes (`deck.law_params`, `impactor_params`, `impactor_samples`, `front_levels_rows`,
`table.table_arrays`), so an engine that runs the kernel gets LAMMPS's bits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..case import Case
from ..errors import ConfigError
from .library import Unsupported

LAWS = {"power": 0, "linear": 1, "table": 2}
DRIVES = {"constant": 0, "ramp": 1, "sine": 2, "rest": 3, "measured": 4}


@dataclass
class Arrays:
    """The batch in engine units (SI). law: LAWS key and its values (power K b q, linear k r_free);
    table: r, U, F rows and the end slopes of F (a table law); drive: DRIVES key, V, T, and a
    measured drive's samples t, y (u or v), given_velocity, hold; friction: mu, p, g or None;
    range: allowed separations; x, v, mass (R, N); levels (R, 5) with a front record."""

    batch: Case
    chains: int
    n: int
    steps: int
    dt: float
    law: str
    law_values: np.ndarray
    table: tuple
    drive: str
    V: float
    T: float
    samples: tuple
    given_velocity: bool
    hold: bool
    friction: tuple | None
    range: tuple[float, float]
    x: np.ndarray
    v: np.ndarray
    mass: np.ndarray
    record: bool
    levels: np.ndarray


def prepare(cases: list[Case], engine: str, draws=None) -> Arrays:
    """The members' arrays (their chains from `draws`, the cases' `case_measures.chain_draws`,
    if drawn); Unsupported if `engine` cannot run them."""
    from ..case_measures import chain_draws
    from ..deck import front_levels_rows, impactor_params, law_params, impactor_samples, records_front, replica_batch
    from ..table import table_arrays
    from ..units import to_engine

    if not cases:
        raise Unsupported("no members to run")
    try:
        batch = replica_batch(cases)
    except ConfigError as err:
        raise Unsupported(f"these members cannot share a batch: {err}") from None
    if batch.output.format != "none":
        raise Unsupported(f"output.format = {batch.output.format!r}: the {engine} engine keeps no frames; "
                          "it needs output.format = 'none'")

    draws = draws or chain_draws(cases)

    def engine_units(values: np.ndarray, quantity: str) -> np.ndarray:
        return np.ascontiguousarray(to_engine(values, quantity), float)

    lo, hi = batch.table_range()
    params = law_params(batch.force)
    if params is None:  # the table the deck writes, as its doubles
        (law, values), table = ("table", ()), table_arrays(batch.force, lo, hi, batch.table.points)
    else:
        (law, values), table = params, ()
    drive, dv = impactor_params(batch.impactor)
    measured = drive == "measured"
    fr = batch.friction
    record = records_front(batch)
    return Arrays(
        batch, len(cases), batch.chain.particles, batch.run.steps(), float(to_engine(batch.run.dt, "time")),
        law, np.array(values + (0.0,) * (3 - len(values)), float), table, drive, *(tuple(dv) + (0.0, 0.0))[:2],
        impactor_samples(batch.impactor) if measured else (), measured and batch.impactor.column == "v",
        measured and batch.impactor.after == "hold",
        (float(fr.mu), float(fr.p), float(to_engine(fr.g, "acceleration"))) if fr else None,
        (float(to_engine(lo, "length")), float(to_engine(hi, "length"))),
        engine_units(draws.positions, "length"), engine_units(draws.velocities, "velocity"),
        engine_units(draws.masses, "mass"), record,
        np.ascontiguousarray(front_levels_rows(cases, draws), float) if record else np.zeros((len(cases), 5)))
