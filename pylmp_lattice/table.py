"""The potential table LAMMPS reads (`bond_style table`), sampled from a force law.

The file lists r, U(r), F(r) in engine units (m, J, N) on a uniform grid. Reading it with
`bond_style table spline <points>` on the same grid makes LAMMPS's internal table equal the
file at the nodes and interpolates between them with cubic splines; FP gives the exact end
slopes dF/dr, so the spline is the clamped one. With the default 10000 points the force
LAMMPS uses differs from the law by < 1e-6 relative (see tests/test_table.py).
"""

from __future__ import annotations

import numpy as np

from .units import to_engine

KEYWORD = "FORCE_LAW"


def table_arrays(law, r_min: float, r_max: float, points: int):
    """The table's rows and end slopes in engine units: r (m), U (J), F (N), dF/dr (N/m) at r_min
    and r_max; r_min, r_max in mm. The text of `bond_table` reads back to these doubles."""
    r = np.linspace(r_min, r_max, points)
    # dF/dr in N/m at both ends, for the clamped spline
    fp_lo, fp_hi = -to_engine(law.stiffness(np.array([r_min, r_max])), "stiffness")
    return (to_engine(r, "length"), to_engine(law.energy(r), "energy"), to_engine(law.force(r), "force"),
            float(fp_lo), float(fp_hi))


def bond_table(law, r_min: float, r_max: float, points: int, r_eq: float) -> str:
    """Table text for `bond_coeff 1 <file> FORCE_LAW`; r_min, r_max, r_eq in mm."""
    r_si, u_si, f_si, fp_lo, fp_hi = table_arrays(law, r_min, r_max, points)
    header = (
        f"# {law!r}\n# columns: index, r [m], U [J], F [N]; F = -dU/dr\n\n"
        f"{KEYWORD}\nN {points} FP {fp_lo:.17g} {fp_hi:.17g} EQ {to_engine(r_eq, 'length'):.17g}\n\n"
    )
    rows = np.column_stack([np.arange(1, points + 1), r_si, u_si, f_si])
    body = "\n".join(f"{int(i)} {a:.17g} {e:.17g} {f:.17g}" for i, a, e, f in rows)
    return header + body + "\n"
