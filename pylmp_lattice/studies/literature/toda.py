"""The Toda lattice (m = A = B = 1: g, N, 1/mm, so time in ms): one soliton and the piston.

Soliton: an exact soliton enters a chain through magnet 1, which follows the
exact solution (a measured impactor), and crosses gaps 11-41; its speed, from the time
centroids of exp(-r_n) - 1 (for the exact soliton exactly kappa (n - n0) / sinh kappa), against
sinh(kappa)/kappa for kappa = 0.25 ... 2.5 (dt = 0.005 ms from kappa = 2).
Piston (x_0 = u_p t, 200 time units): the mean state next to the piston against the uniform
wake exp(-r) = (1 + u_p/2)^2 below the critical speed 2; the period-two (staggered) amplitude
|r_(n+1) - r_n| at t = 100 and 200 on both sides of it; the front speed and height against the
lead soliton, cosh(kappa) = 1 + u_p. Quick: three kappa, three u_p, 100 time units.
Magnets and gaps are numbered from 1 (`numbering`); the exact solutions' site index n is the
magnet number minus 1.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...exact import toda_lead_soliton, toda_piston_wake, toda_soliton, toda_soliton_speed
from ...measures import centroid_speed, lead_pulse, staggered_amplitude
from ...plots import pyplot, style_figure
from ..output import StudyResult
from ..scaffold import CHAINS, chain_case, run_cases

NAME = "toda"
KAPPAS = (0.25, 0.5, 1.0, 1.5, 2.0, 2.5)
PISTON_SPEEDS = (0.25, 0.5, 1.0, 1.5, 1.8, 1.9, 2.1, 2.2, 2.5, 3.0, 4.0)
A_GAP = CHAINS["toda"][0]["a"]  # mm, where F = 0: r = gap - a
SOLITON_GAPS = (11, 41)  # the gaps where the soliton's speed is measured (inclusive)
STAGGER_GAPS = 6  # the gaps next to the piston where period two is looked for
QUICK = ((0.5, 1.0, 2.0), (1.0, 1.9, 2.1), 100.0)  # kappas, piston speeds, piston run length


def soliton_case(kappa: float, dt: float = 0.01, output: float = 0.05):
    """An exact soliton entering the chain through magnet 1 (its centre 10/kappa sites behind
    it at t = 0, so the chain starts at rest to ~1e-8); the run ends once the pulse has passed
    gap SOLITON_GAPS[1] (15 / sinh(kappa) later, when its centre is 15/kappa sites beyond), and
    the held end is far enough that its reflection stays 15/kappa sites away from that gap."""
    n0, beta = -10.0 / kappa, np.sinh(kappa)
    site = SOLITON_GAPS[1] - 1  # the exact solution's index of the last gap
    particles = int(site + 30.0 / kappa) + 10
    duration = np.ceil((kappa * (site - n0) + 15) / beta / output) * output
    t = np.arange(0.0, duration + dt / 2, dt)
    x, _, _ = toda_soliton([0], t, kappa, n0)
    _, _, r0 = toda_soliton(np.arange(particles - 1), [0.0], kappa, n0)
    impactor = {"profile": "measured", "t": list(t), "values": list(x[:, 0] - x[0, 0]), "column": "u"}
    return chain_case("toda", f"soliton_k{kappa:g}", impactor, float(duration), particles=particles, dt=dt,
                      output=output, r0=A_GAP + r0[0])


def soliton_speed(t, gaps) -> float:
    """The soliton's speed (sites per ms) from the time centroids of exp(-r) - 1 at
    SOLITON_GAPS (`measures.centroid_speed`); gaps (frames, N-1) in mm."""
    return centroid_speed(t, np.expm1(-(np.asarray(gaps) - A_GAP)), SOLITON_GAPS)


def piston_case(u_p: float, duration: float, particles: int | None = None):
    """The Toda piston problem: a held far end beyond the front's reach unless `particles`."""
    particles = particles or int(toda_lead_soliton(u_p)[1] * duration) + 30
    return chain_case("toda", f"piston_up{u_p:g}", {"velocity": u_p}, duration, particles=particles)


def run(out: Path, quick: bool = False) -> StudyResult:
    """Run this study into `out` (`quick`: its small version) and return its results; what it
    runs and measures is the module's docstring."""
    kappas, speeds, duration = QUICK if quick else (KAPPAS, PISTON_SPEEDS, 200.0)
    folder = out / NAME
    solitons = []
    cases = [soliton_case(kappa, dt=0.005 if kappa >= 2 else 0.01) for kappa in kappas]
    for kappa, case, (_, traj) in zip(kappas, cases, run_cases(cases, folder / "solitons")):
        measured = soliton_speed(traj.t, traj.gaps())
        solitons.append({"kappa": kappa, "dt_ms": case.run.dt, "speed_sites_per_ms": measured,
                         "exact_sinh_k_over_k": float(toda_soliton_speed(kappa)),
                         "relative_error": measured / float(toda_soliton_speed(kappa)) - 1})
    pistons = []
    for u_p, (_, traj) in zip(speeds, run_cases([piston_case(u_p, duration) for u_p in speeds], folder / "pistons")):
        t, r = traj.t, traj.gaps() - A_GAP
        late = t > duration - 10
        kappa, lead = toda_lead_soliton(u_p)
        speed, height = lead_pulse(t, np.expm1(-r))
        uniform = float(toda_piston_wake(u_p))
        mean_r = float(np.mean(r[late, :10]))
        pistons.append({
            "u_p": u_p, "mean_r_gaps_1_10": mean_r, "uniform_wake_r": uniform,
            "relative_error_exp_minus_r": float(np.exp(-mean_r) / np.exp(-uniform) - 1) if u_p < 2 else None,
            "mean_v_magnets_2_11": float(np.mean(traj.v[late, 1:11])),
            "staggered_t_half": staggered_amplitude(t, r, duration / 2, STAGGER_GAPS),
            "staggered_t_end": staggered_amplitude(t, r, duration, STAGGER_GAPS),
            "front_speed_sites_per_ms": speed, "lead_soliton_speed": float(lead),
            "front_height": height, "lead_soliton_height_sinh2k": float(np.sinh(kappa) ** 2),
        })
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5), layout="constrained")
    k_line = np.linspace(0.1, max(kappas) * 1.05, 200)
    axes[0, 0].plot(k_line, toda_soliton_speed(k_line), "k-", lw=0.8, label=r"$\sinh(\kappa)/\kappa$")
    axes[0, 0].plot([s["kappa"] for s in solitons], [s["speed_sites_per_ms"] for s in solitons], "o", label="LAMMPS")
    axes[0, 0].set(xlabel=r"$\kappa$", ylabel="soliton speed (sites/ms)", title="one soliton")
    axes[0, 0].legend(fontsize="small")
    u = np.array([p["u_p"] for p in pistons])
    u_line = np.linspace(0.0, max(u) * 1.05, 200)
    axes[0, 1].plot(u_line, np.where(u_line < 2, (1 + u_line / 2) ** 2, np.nan), "k-", lw=0.8, label="$(1 + u_p/2)^2$")
    axes[0, 1].plot(u, [np.exp(-p["mean_r_gaps_1_10"]) for p in pistons], "o", label="LAMMPS, gaps 1-10, last 10 units")
    axes[0, 1].axvline(2.0, color="k", ls=":", lw=0.8, label="critical speed 2")
    axes[0, 1].set(xlabel="piston speed $u_p$ (m/s)", ylabel="mean $\\exp(-r)$ next to the piston", title="the wake")
    axes[0, 1].legend(fontsize="small")
    axes[1, 0].semilogy(u, [p["staggered_t_half"] for p in pistons], "s", label=f"t = {duration / 2:g} ms")
    axes[1, 0].semilogy(u, [p["staggered_t_end"] for p in pistons], "o", label=f"t = {duration:g} ms")
    axes[1, 0].axvline(2.0, color="k", ls=":", lw=0.8, label="critical speed 2")
    axes[1, 0].set(xlabel="piston speed $u_p$ (m/s)", ylabel="max $|r_{n+1} - r_n|$, gaps 1-6 (mm)",
                   title="period two: relaxes below 2, persists above")
    axes[1, 0].legend(fontsize="small")
    axes[1, 1].plot(u_line[1:], toda_lead_soliton(u_line[1:])[1], "k-", lw=0.8,
                    label=r"lead soliton $\sinh(\kappa)/\kappa$, $\cosh\kappa = 1 + u_p$")
    axes[1, 1].plot(u, [p["front_speed_sites_per_ms"] for p in pistons], "o", label="LAMMPS front")
    axes[1, 1].set(xlabel="piston speed $u_p$ (m/s)", ylabel="front speed (sites/ms)", title="the front")
    style_figure(fig, f"Toda lattice (m = A = B = 1, a = {A_GAP:g} mm): a soliton, and the piston problem over "
                 f"{duration:g} ms", quick=quick)
    axes[1, 1].legend(fontsize="small")
    numbers = {
        "units": "m = A = B = 1 (g, N, 1/mm): time in ms, velocity in m/s, r = gap - a in mm",
        "solitons": solitons,
        "max_soliton_speed_relative_error": max(abs(s["relative_error"]) for s in solitons),
        "pistons": pistons, "piston_duration": duration,
    }
    tables = {"solitons": {k: [s[k] for s in solitons] for k in solitons[0]},
              "pistons": {k: [p[k] for p in pistons] for k in pistons[0]}}
    return StudyResult(NAME, numbers, tables=tables, figure=fig, quick=quick)
