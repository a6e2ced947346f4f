"""deck.render: a pure function from a case to file texts (the deck, the data file, the tables).

Its sections, in order, for both engines; every field of a case reaches the files (or is listed
with the place it acts instead); floats written so that they read back to the same double, in
the text and through LAMMPS itself; and no string field of a case takes a value that could
start a LAMMPS command (that the deck's commands are its own: `test_injection`).
"""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest

from pylmp_lattice import deck
from pylmp_lattice.case import case_from_dict, case_to_dict
from pylmp_lattice.errors import ConfigError
from pylmp_lattice.formats.layout import DATA, DECK, IMPACTOR, SECOND_TABLE, TABLE
from pylmp_lattice.units import to_engine

from conftest import make_case
from test_injection import ATTACKS

FRICTION = {"mu": 0.285, "p": 0.012}


def base(**sections) -> dict:
    """A small case with friction and fine output, as a dict to change field by field."""
    sections["output"] = {"fine": [2, 3]} | sections.get("output", {})
    return case_to_dict(make_case(particles=12, duration=2.0, friction=FRICTION, **sections))


def render(data: dict) -> dict[str, str]:
    """deck.render of the case `data` describes; the texts of one case are rendered once (the
    field-by-field test renders the same base some 30 times: a force table each time)."""
    key = json.dumps(data, sort_keys=True)
    if key not in _RENDERED:
        _RENDERED[key] = deck.render(case_from_dict(data))
    return _RENDERED[key]


_RENDERED: dict[str, dict[str, str]] = {}


# ---------------------------------------------------------------- sections

SECTIONS = {
    "chain": ["# ---- 1. The chain: 12 magnets", "# ---- 2-4. Force law", "# ---- 5. Output", "# ---- 6. Run 2 ms"],
    "stock": ["# ---- 1. The chain: 12 magnets", "# ---- 2. Force law", "# ---- 3. Boundary conditions",
              "# ---- 4. Guard", "# ---- 5. Output", "# ---- 6. Run 2 ms"],
}


@pytest.mark.parametrize("engine", sorted(SECTIONS))
def test_the_deck_has_its_sections_in_order_and_its_files(engine):
    files = render(base(run={"engine": engine}))
    assert sorted(files) == sorted([DECK, DATA, TABLE])
    text = files[DECK]
    where = [text.find(header) for header in SECTIONS[engine]]
    assert -1 not in where and where == sorted(where), where
    assert text.startswith("# pylmp_lattice deck for case 'test'\n")
    assert "variable        dir index .\n" in text and f"read_data       ${{dir}}/{DATA}" in text
    assert text.count("\nrun ") == 1 and "\nrun             200\n" in text  # 2 ms of 0.01 ms steps
    # the engine's fixes: one fix does the whole step, or the stock path's fixes and guard
    has = {name: f"fix             {name} " in text for name in ("chain", "integrate", "friction", "contact", "drive")}
    assert has == ({"chain": True, "integrate": False, "friction": False, "contact": False, "drive": False}
                   if engine == "chain" else
                   {"chain": False, "integrate": True, "friction": True, "contact": True, "drive": True})


def test_a_measured_drive_and_second_neighbours_add_their_files():
    t = list(np.linspace(0.0, 3.0, 7))
    measured = render(base(impactor={"profile": "measured", "t": t, "values": [0.5 * x for x in t], "column": "u"}))
    assert IMPACTOR in measured and f"file ${{dir}}/{IMPACTOR} column u after hold" in measured[DECK]
    rows = [line.split() for line in measured[IMPACTOR].splitlines()[1:]]
    # t from the first sample, s; u, m: 0.5 mm per ms of the samples, in SI
    assert np.array_equal(np.array(rows, float), np.column_stack([to_engine(np.array(t), "time"),
                                                                   to_engine(0.5 * np.array(t), "length")]))
    second = render(base(second_neighbour={"law": "power", "K": 20.0, "b": 10.0, "q": 3.0}))
    assert SECOND_TABLE in second and f"bond_coeff      2 ${{dir}}/{SECOND_TABLE}" in second[DECK]
    assert "bond_style      table spline" in second[DECK]  # second neighbours take the stock path


def test_render_is_pure():
    """The same case gives the same texts, twice, and the case is not changed."""
    case = case_from_dict(base(chain={"thermal_velocity": 0.01, "seed": 4}))
    before = case_to_dict(case)
    assert deck.render(case) == deck.render(case) and case_to_dict(case) == before


# ---------------------------------------------------------------- every field reaches the files

# (field, its new value, the other fields of the base that it needs (None: left out))
CHANGES = [
    ("name", "other", {}),
    ("chain.mass", 1.2, {}),
    ("chain.r0", 11.0, {}),
    ("chain.particles", 13, {}),
    ("chain.far_end", "long", {}),  # N from the duration instead of 12
    ("chain.thermal_velocity", 0.01, {"chain": {"seed": 1}}),
    ("chain.mass_disorder", 0.01, {"chain": {"seed": 1}}),
    ("chain.r0_disorder", 0.01, {"chain": {"seed": 1}}),
    ("chain.disorder", "uniform", {"chain": {"seed": 1, "r0_disorder": 0.01}}),
    ("chain.defect_index", 6, {"chain": {"defect_index": 5, "defect_mass": 2.0}}),
    ("chain.defect_mass", 3.0, {"chain": {"defect_index": 5, "defect_mass": 2.0}}),
    ("chain.defect_r0", 10.0, {"chain": {"defect_index": 5, "defect_mass": 2.0}}),
    ("chain.seed", 2, {"chain": {"seed": 1, "r0_disorder": 0.01}}),
    ("chain.velocity", [0.0] * 5 + [0.01] + [0.0] * 6, {}),
    ("force.K", 400.0, {}),
    ("force.b", 4.0, {}),
    ("force.q", 3.5, {}),
    ("impactor.velocity", 1.5, {}),
    ("run.duration", 3.0, {}),
    ("run.dt", 0.005, {}),
    ("run.output_interval", 0.2, {}),
    ("run.check_interval", 0.2, {"run": {"engine": "stock"}}),
    ("run.engine", "stock", {}),
    ("table.points", 5000, {}),
    ("table.r_max", 30.0, {}),
    ("table.r_min", 1.0, {}),
    ("friction.mu", 0.3, {}),
    ("friction.p", 0.02, {}),
    ("friction.g", 9.8, {}),
    ("output.format", "text", {}),
    ("output.fine", [2, 4], {}),
    ("output.fine_interval", 0.05, {}),
    ("output.front", False, {}),
    ("second_neighbour", {"law": "power", "K": 20.0, "b": 10.0, "q": 3.0}, {"run": {"engine": "stock"}}),
]
# Fields that act elsewhere than in the deck's files
ELSEWHERE = {
    "chain.magnet_length": "the lab frame's pitch r0 + L, for the summary's lab-frame front speed (summary.py)",
    "output.compression": "the H5MD file's compression: applied when run_folder.convert writes traj.h5md",
}


def _set(data: dict, dotted: str, value) -> dict:
    data = {k: dict(v) if isinstance(v, dict) else v for k, v in data.items()}
    *section, key = dotted.split(".")
    target = data.setdefault(section[0], {}) if section else data
    if value is None:
        target.pop(key, None)
    else:
        target[key] = value
    return data


def _fields() -> set[str]:
    case = make_case(friction=FRICTION)
    out = {"second_neighbour"}
    for f in dataclasses.fields(case):
        value = getattr(case, f.name)
        if dataclasses.is_dataclass(value):
            out |= {f"{f.name}.{g.name}" for g in dataclasses.fields(value)}
        elif f.name != "second_neighbour":
            out.add(f.name)
    return out


def test_every_field_of_a_case_is_listed_here():
    """A new field fails this test until it is added to CHANGES (it reaches the deck) or to
    ELSEWHERE (where it acts instead)."""
    listed = {field for field, _, _ in CHANGES} | set(ELSEWHERE)
    assert _fields() == listed, (_fields() - listed, listed - _fields())


@pytest.mark.parametrize("field, value, needs", CHANGES, ids=[c[0] for c in CHANGES])
def test_each_field_of_a_case_reaches_the_files(field, value, needs):
    data = base()
    for dotted, section in needs.items():
        for key, v in section.items():
            data = _set(data, f"{dotted}.{key}", v)
    changed = _set(data, field, value)
    if field == "second_neighbour":
        changed[field] = value
    if field == "chain.far_end":
        del changed["chain"]["particles"]
    before, after = render(data), render(changed)
    assert after != before, f"{field} = {value!r} changes none of the files"


# ---------------------------------------------------------------- full precision

DT = 0.0012345678901234567  # ms: 17 significant digits


def _numbers(text: str) -> set[float]:
    return {float(x) for x in re.findall(r"(?<![\w.$])-?\d+\.\d*(?:e[-+]?\d+)?", text)}


def test_floats_are_written_to_the_last_bit():
    """Values with 17 significant digits reach the files as the same doubles (SI)."""
    v, dt, mass, r0 = 1.2345678901234567, DT, 1.0840000000000001, 12.000000000000002
    files = render(base(impactor={"profile": "constant", "velocity": v}, run={"dt": dt, "duration": 400 * dt, "output_interval": 40 * dt},
                        chain={"mass": mass, "r0": r0}))
    numbers = _numbers(files[DECK])
    assert v in numbers and to_engine(dt, "time") in numbers
    assert to_engine(FRICTION["mu"], "velocity") in numbers  # mu is dimensionless: as given
    data = _numbers(files[DATA])
    assert to_engine(mass, "mass") in data
    case = case_from_dict(base(chain={"mass": mass, "r0": r0}))
    x = to_engine(case.chain.positions(), "length")
    assert all(xi in data for xi in x[1:])


@pytest.mark.lammps
def test_lammps_reads_the_data_file_and_timestep_back_bit_for_bit(tmp_path):
    """The deck and data file read by LAMMPS (run 0: setup only): positions, masses, velocities
    and dt are the case's, converted to SI, to the last bit; every atom on the x axis."""
    from pylmp_lattice.engine import instance

    case = case_from_dict(base(chain={"r0_disorder": 0.01, "mass_disorder": 0.01, "thermal_velocity": 0.05, "seed": 7},
                               run={"dt": DT, "duration": 400 * DT, "output_interval": 40 * DT}))
    for name, text in deck.render(case).items():
        (tmp_path / name).write_text(text)
    text = re.sub(r"^run +\d+$", "run 0", (tmp_path / DECK).read_text(), flags=re.MULTILINE)
    with instance(["-screen", "none", "-log", "none", "-var", "dir", str(tmp_path)]) as lmp:
        for line in re.sub(r"&[ \t]*\n", " ", text).splitlines():
            if line.strip() and not line.startswith(("dump", "write_dump")):  # nothing written
                lmp.command(line)
        n = case.chain.particles
        assert lmp.get_natoms() == n
        assert lmp.extract_global("dt") == to_engine(case.run.dt, "time")
        x = np.array(lmp.gather_atoms("x", 1, 3)).reshape(n, 3)
        v = np.array(lmp.gather_atoms("v", 1, 3)).reshape(n, 3)
        m = np.array(lmp.gather_atoms("rmass", 1, 1))
    np.testing.assert_array_equal(x[:, 0], to_engine(case.chain.positions(), "length"))
    np.testing.assert_array_equal(v[1:-1, 0], to_engine(case.chain.velocities(), "velocity")[1:-1])
    np.testing.assert_array_equal(m, to_engine(case.chain.masses(), "mass"))
    assert not np.any(x[:, 1:]) and not np.any(v[:, 1:])


# ---------------------------------------------------------------- a batch of chains

def test_a_batch_s_levels_file_gives_each_chain_its_own_deck_s_levels():
    """Three thermal chains under a half-sine pulse, each its own noise: the batch's levels file
    has, row by row and column by column (start front drop pulse_drop pulse_floor), the numbers
    each chain's own deck passes fix lattice/front; pulse_drop is the fraction 0.1 and the
    floor 3 sigma > 0, not to be swapped."""
    from pylmp_lattice.formats.layout import FRONT_LEVELS

    cases = [make_case(particles=21, duration=30.0, impactor={"profile": "sine", "velocity": 2.0, "duration": 10.0},
                       chain={"thermal_velocity": 0.02 * (1 + s), "seed": s}, output={"format": "none"})
             for s in range(3)]
    files = deck.render_replicas(cases, front=True)
    rows = np.loadtxt(files[FRONT_LEVELS].splitlines(), comments="#")
    assert rows.shape == (3, 5) and len(set(rows[:, 4])) == 3  # each chain its own floor
    for r, case in enumerate(cases):
        own = deck._FRONT_FIX.search(deck.render(case)[DECK]).groups()
        assert own[4] is not None  # a noisy chain's deck has a floor
        np.testing.assert_array_equal(rows[r], [float(x) for x in own])
    np.testing.assert_array_equal(rows[:, 3], 0.1)
    assert np.all(rows[:, 4] > 0) and np.all(rows[:, 4] < rows[:, 1])


def test_a_batch_guards_its_chains_with_the_narrowest_table_range():
    """Chains with gaps of 12 mm and one with a 13 mm gap: their own tables end at 3 x the
    widest gap, 36 and 39 mm. In one batch (the exact law: no table file) the chain fix guards
    every chain with the narrowest, 0.036 m, in either order: no chain runs past its own range."""
    plain = make_case(particles=21)
    wide = make_case(particles=21, chain={"r0": [12.0] * 19 + [13.0]})
    assert (plain.table_range(), wide.table_range()) == ((0.0, 36.0), (0.0, 39.0))
    for cases in ([plain, wide], [wide, plain]):
        text = deck.render_replicas(cases)[DECK]
        lo, hi = re.search(r"range (\S+) (\S+) length 21", text).groups()
        assert (float(lo), float(hi)) == (0.0, pytest.approx(0.036, rel=1e-15))


# ---------------------------------------------------------------- no string becomes a command

def _strings() -> list[str]:
    """The string fields of a case: each either a choice or the name."""
    data = base(chain={"disorder": "normal", "r0_disorder": 0.01, "seed": 1})
    return ["name"] + [f"{s}.{k}" for s, section in data.items() if isinstance(section, dict)
                       for k, value in section.items() if isinstance(value, str)]


@pytest.mark.parametrize("attack", ATTACKS[:4])
@pytest.mark.parametrize("field", _strings())
def test_a_hostile_string_in_any_field_is_refused(field, attack):
    """Each string field is the name (an identifier) or a choice from a list: a string that
    would start a LAMMPS command is refused with the field's name, before any deck exists."""
    data = _set(base(chain={"disorder": "normal", "r0_disorder": 0.01, "seed": 1}), field, attack)
    with pytest.raises(ConfigError, match=rf"^{re.escape(field)}: got "):
        case_from_dict(data)

