"""An independent integrator of the chain equations, for the tests only.

m x_n'' = F(x_n - x_{n-1}) - F(x_{n+1} - x_n) for the free particles, with the impactor's
position prescribed and the last particle fixed, integrated by scipy's DOP853 at tight
tolerances. Units: mm, g, ms, N (so x'' in mm/ms^2 = F/m in N/g).
It shares no code with the package: the force law and the drive are plain callables.
`integrate_chain_friction` / `integrate_rig` add Coulomb stick-slip friction (paper Eq. 1, S3).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp


def power_force(K=413.8, b=3.917, q=3.0):
    return lambda r: K / (r + b) ** q


def integrate_chain(force, mass, r0, n, drive_x, drive_v, t_out, rtol=1e-12, atol=1e-12, force2=None):
    """Velocities (m/s) of all n particles at times t_out (ms).

    force(r) in N for r in mm; drive_x(t), drive_v(t): impactor displacement (mm) and
    velocity (m/s). Particle 0 is driven, particle n-1 fixed. force2(d): optional force (N,
    positive repelling) between particles i and i+2, d = x_{i+2} - x_i in mm.
    """
    x0 = r0 * np.arange(n, dtype=float)
    free = slice(1, n - 1)

    def rhs(t, y):
        x = x0.copy()
        x[0] += drive_x(t)
        x[free] = y[: n - 2]
        f = force(np.diff(x))  # f[i] between particles i and i+1
        a = f[:-1] - f[1:]  # on particles 1 .. n-2
        if force2 is not None:
            f2 = force2(x[2:] - x[:-2])  # f2[i] between particles i and i+2
            a[1:] += f2[:-1]  # pushed by i-2 (particles 2 .. n-2)
            a[:-1] -= f2[1:]  # pushed back by i+2 (particles 1 .. n-3)
        return np.concatenate([y[n - 2 :], a / mass])

    y0 = np.concatenate([x0[free], np.zeros(n - 2)])
    sol = solve_ivp(rhs, (0.0, t_out[-1]), y0, method="DOP853", t_eval=t_out, rtol=rtol, atol=atol)
    assert sol.success, sol.message
    v = np.zeros((len(t_out), n))
    v[:, 0] = drive_v(t_out)
    v[:, free] = sol.y[n - 2 :].T
    return v


# --- Coulomb stick-slip friction -------------------------------------------------------------
#
# m x_n'' = F(r_{n-1}) - F(r_n) - f_n, with |f_n| <= L_n = mu (m g + p (F(r_{n-1}) + F(r_n))).
# Integrated as a hybrid system: each free particle has a mode d in {+1, -1, 0} (sliding right,
# sliding left, stuck). Within a mode the right-hand side is smooth (friction = -d L), so DOP853
# keeps its order; the mode changes at terminal events, located by solve_ivp, and the
# integration restarts from the exact state there.


@dataclass
class FrictionRun:
    """Output of `integrate_chain_friction` at the requested times t (ms).

    x (mm) and v (m/s): positions and velocities of all n particles, shape (len(t), n).
    w_friction, w_drive (mJ = N mm): work dissipated by friction, work done by the driven
    particle 0 on the chain (integral of F(r_0) drive_v), both accumulated from t = 0.
    events: (time, particle, old mode, new mode, position) at each mode change.
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    w_friction: np.ndarray
    w_drive: np.ndarray
    events: list = field(default_factory=list)
    segments: int = 0


def integrate_chain_friction(
    force, mass, r0, n, drive_x, drive_v, t_out, mu, p, g=9.81e-3, x_init=None,
    rtol=1e-12, atol=1e-12, t_breaks=(), max_events=100_000,
):
    """The chain with Coulomb stick-slip friction on the free particles 1 .. n-2.

    Same conventions as `integrate_chain` (particle 0 driven, n-1 fixed, all start at rest);
    x_init (mm, n values) replaces the equispaced start r0 * arange(n). g in mm/ms^2.
    t_breaks: times (ms) where the drive is not smooth (e.g. the end of a pulse); the
    integration restarts there so that no step straddles them.
    The friction law assumes F >= 0 (repulsion) when p > 0. Returns a `FrictionRun`.
    """
    t_out = np.asarray(t_out, dtype=float)
    x_ref = r0 * np.arange(n, dtype=float) if x_init is None else np.array(x_init, dtype=float)
    nf = n - 2  # free particles; state y = [x_free, v_free, w_friction, w_drive]

    def forces(t, y):
        x = x_ref.copy()
        x[0] += float(drive_x(t))
        x[1:-1] = y[:nf]
        f = force(np.diff(x))
        return f, f[:-1] - f[1:], mu * (mass * g + p * (f[:-1] + f[1:]))

    def rhs(t, y, d):
        f, net, limit = forces(t, y)
        v = y[nf : 2 * nf]
        a = np.where(d != 0, (net - d * limit) / mass, 0.0)  # stuck: v = 0 and stays 0
        return np.concatenate([v, a, [limit @ np.abs(v), f[0] * float(drive_v(t))]])

    def switching(t, y, d):
        """Per particle, a function crossing zero at the next mode change.

        Sliding: d v (decreases through 0 when it stops). Stuck: |net| - L (rises through 0
        when it slips). An exact 0 is nudged to the side of the current mode, because
        solve_ivp counts 0 -> 0 as a crossing: a just-released particle (v = 0) or one
        whose forces balance exactly (mu = 0, net = 0 ahead of the wave) would fire at once.
        """
        _, net, limit = forces(t, y)
        s = np.where(d != 0, d * y[nf : 2 * nf], np.abs(net) - limit)
        return np.where(s != 0.0, s, np.where(d != 0, 1e-300, -1e-300))

    def direction_after(sol, t, i):
        """Sign of the net force on particle i just after t, from the segment's last step.

        Needed when L = 0: the root is then where net leaves exactly 0, which it does only
        once the positions change by an ulp, so at the root itself net can still be 0."""
        for k in range(64):
            s = t + 4 * np.finfo(float).eps * max(1.0, t) * 2.0**k
            net = forces(s, sol.sol(s))[1][i]
            if net != 0.0:
                return int(np.sign(net))
        return 0

    def rest_mode(net, limit):
        return 0 if abs(net) <= limit else int(np.sign(net))

    y = np.concatenate([x_ref[1:-1], np.zeros(nf), [0.0, 0.0]])
    _, net, limit = forces(0.0, y)
    d = np.array([rest_mode(net[i], limit[i]) for i in range(nf)])
    out = np.zeros((len(t_out), len(y)))
    events, t, segments, stalled = [], 0.0, 0, 0
    while True:
        # All switching functions share one force evaluation per (t, y).
        cache = {}

        def s_all(t, y, d):
            key = (t, y.tobytes())
            if cache.get("key") != key:
                cache["key"], cache["s"] = key, switching(t, y, d)
            return cache["s"]

        def event(i, direction):
            e = lambda t, y, d: s_all(t, y, d)[i]  # noqa: E731
            e.terminal, e.direction = True, direction
            return e

        evs = [event(i, +1.0 if d[i] == 0 else -1.0) for i in range(nf)]
        t_stop = min([b for b in t_breaks if b > t] + [t_out[-1]])
        sol = solve_ivp(
            rhs, (t, t_stop), y, method="DOP853", args=(d,), events=evs,
            dense_output=True, rtol=rtol, atol=atol,
        )
        assert sol.success, sol.message
        segments += 1
        now = (t_out >= t) & (t_out <= sol.t[-1])  # an output at an event gets the later segment
        if now.any():
            out[now] = sol.sol(t_out[now]).T
        if sol.status == 0 and t_stop == t_out[-1]:
            break
        stalled = stalled + 1 if sol.t[-1] - t <= 1e-12 * max(1.0, t) else 0
        if stalled > 100 or len(events) > max_events:
            raise RuntimeError(f"no progress past t = {t} ms (Zeno?) or too many events")
        t, y = sol.t[-1], sol.y[:, -1].copy()
        if sol.status == 0:  # at a break: same modes
            continue
        _, net, limit = forces(t, y)
        fired = {i for i in range(nf) if sol.t_events[i].size}
        new = d.copy()
        # solve_ivp reports only the first of simultaneous roots, so each particle is also
        # checked against its mode (a slider past v = 0, a stuck one past the limit).
        for i in range(nf):
            if d[i] != 0 and (i in fired or d[i] * y[nf + i] < 0):
                y[nf + i] = 0.0  # exactly at rest: then stick, or slide back
                new[i] = rest_mode(net[i], limit[i])
            elif d[i] == 0 and (i in fired or abs(net[i]) > limit[i]):
                # It fired on |net| rising through L: slip even if rounding leaves |net| <= L,
                # otherwise the same root is found again at once.
                new[i] = int(np.sign(net[i])) or direction_after(sol, t, i)
            if new[i] != d[i]:
                events.append((t, i + 1, int(d[i]), int(new[i]), y[i]))
        d = new

    x = np.tile(x_ref, (len(t_out), 1))
    x[:, 0] += drive_x(t_out)
    x[:, 1:-1] = out[:, :nf]
    v = np.zeros((len(t_out), n))
    v[:, 0] = drive_v(t_out)
    v[:, 1:-1] = out[:, nf : 2 * nf]
    return FrictionRun(t_out, x, v, out[:, -2], out[:, -1], events, segments)


def integrate_rig(force, mass, gap, start, t_out, mu, p, g=9.81e-3, **options):
    """The calibration rig of Fig. S4: one magnet between two fixed ones, `gap` (mm) apart,
    released from rest at `start` (mm) from the left one. Returns a `FrictionRun` (n = 3)."""
    zero = lambda t: np.zeros_like(np.asarray(t, dtype=float))  # noqa: E731
    return integrate_chain_friction(
        force, mass, 0.0, 3, zero, zero, t_out, mu, p, g, x_init=[0.0, start, gap], **options
    )
