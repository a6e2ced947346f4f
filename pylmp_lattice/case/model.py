"""The model sections besides the chain: the force law's choices, [friction] and [second_neighbour]."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ConfigError
from ..forcelaw import FPUT, ForceLaw, LennardJones, LinearSpring, Morse, PowerLaw, SampledLaw, Toda

FORCE_LAWS = {cls.law: cls for cls in (PowerLaw, LinearSpring, SampledLaw, Toda, LennardJones, Morse, FPUT)}


@dataclass(frozen=True)
class Friction:
    """Coulomb friction of the magnets on the rod (paper Eq. S1, Sec. S3).

    Limit on magnet n: f_n = mu (m g + p (F_(n-1) + F_n)), opposing its motion; a magnet at
    rest sticks while its net force is below f_n. Applied by `fix lattice/friction` (plugin).
    """

    mu: float = 0.285
    p: float = 0.012
    g: float = 9.81  # m/s^2

    def __post_init__(self):
        for name, unit in (("mu", ""), ("p", ""), ("g", " m/s^2")):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"friction.{name}", f"got {value!r}{unit}; expected >= 0")


@dataclass(frozen=True)
class SecondNeighbour:
    """Interaction between magnets n and n+2 (paper Sec. S2: about 5 % of the nearest one, and
    attractive, since the magnets alternate in polarity): F2(d) = sign * law.force(d), with d =
    x_(n+2) - x_n the separation of the pair in mm (the sum of the two gaps between them),
    positive F2 repelling. law: any nearest-neighbour law form (`[second_neighbour] law = ...`
    with its parameters); sign: -1 attractive, +1 repulsive.
    """

    law: ForceLaw
    sign: float = -1.0

    def __post_init__(self):
        if self.sign not in (-1, 1):
            raise ConfigError("second_neighbour.sign", f"got {self.sign!r}; expected -1 (attractive) or 1 (repulsive)")

    def force(self, d):
        """F2(d), N (positive repels)."""
        return self.sign * self.law.force(d)

    def energy(self, d):
        """U2(d), mJ, with F2 = -dU2/dd."""
        return self.sign * self.law.energy(d)

    def stiffness(self, d):
        """-dF2/dd, N/mm (negative for an attraction that weakens with distance)."""
        return self.sign * self.law.stiffness(d)

    def __repr__(self):
        return f"SecondNeighbour({'attractive' if self.sign < 0 else 'repulsive'} {self.law!r})"
