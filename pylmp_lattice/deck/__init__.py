"""The LAMMPS input deck of a case (moved into a package; split into one concept a file next)."""

from .stock import *  # noqa: F401,F403
from .stock import _FRONT_FIX, DATA, DECK  # noqa: F401
