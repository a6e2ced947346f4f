"""An independent integrator of the chain equations, for the tests only.

m x_n'' = F(x_n - x_{n-1}) - F(x_{n+1} - x_n) for the free particles, with the impactor's
position prescribed and the last particle fixed, integrated by scipy's DOP853 at tight
tolerances. Units: mm, g, ms, N (so x'' in mm/ms^2 = F/m in N/g).
It shares no code with the package: the force law and the drive are plain callables.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def power_force(K=413.8, b=3.917, q=3.0):
    return lambda r: K / (r + b) ** q


def integrate_chain(force, mass, r0, n, drive_x, drive_v, t_out, rtol=1e-12, atol=1e-12):
    """Velocities (m/s) of all n particles at times t_out (ms).

    force(r) in N for r in mm; drive_x(t), drive_v(t): impactor displacement (mm) and
    velocity (m/s). Particle 0 is driven, particle n-1 fixed.
    """
    x0 = r0 * np.arange(n, dtype=float)
    free = slice(1, n - 1)

    def rhs(t, y):
        x = x0.copy()
        x[0] += drive_x(t)
        x[free] = y[: n - 2]
        f = force(np.diff(x))  # f[i] between particles i and i+1
        return np.concatenate([y[n - 2 :], (f[:-1] - f[1:]) / mass])

    y0 = np.concatenate([x0[free], np.zeros(n - 2)])
    sol = solve_ivp(rhs, (0.0, t_out[-1]), y0, method="DOP853", t_eval=t_out, rtol=rtol, atol=atol)
    assert sol.success, sol.message
    v = np.zeros((len(t_out), n))
    v[:, 0] = drive_v(t_out)
    v[:, free] = sol.y[n - 2 :].T
    return v
