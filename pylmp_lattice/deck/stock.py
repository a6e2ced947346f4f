"""Sections 1-4 of the stock engine's deck: bonds with a force table, fix nve, the impactor's
fix move (or fix lattice/impactor), the held end, Coulomb friction (fix lattice/friction) and
the contact guard of stock LAMMPS commands."""

from __future__ import annotations

from ..case import Case
from ..formats.layout import CONTACT_MARK, IMPACTOR, SECOND_TABLE, TABLE, in_deck
from ..impactor import Constant, Measured, Ramp, Rest, SinePulse
from ..table import KEYWORD
from ..units import to_engine
from .data import _SYSTEM, _read_data
from .engine_args import _law_args, _num


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
