"""How magnets and gaps are numbered wherever a user sees a number: as the paper counts.

- Magnet n = 1 .. N, in chain order; magnet 1 is the impactor (the driven magnet), magnet N
  the far end.
- Gap n = 1 .. N-1 lies between magnets n and n+1 (the paper's "gap between the 10th and 11th
  magnets" is gap 10); V_P over gap n is r0_n / (t_(n+1) - t_n).
- A range is inclusive: "gaps 145-193" is gap 145 through gap 193 (49 gaps). Fields that hold
  a number say what they number and which end: `magnet`, `first_gap`, `last_gap`,
  `first_magnet`, `last_magnet`.

This holds in results objects (`measures`), summary.json, the studies' JSON and CSV files and
their figures, the sweep's tables (built from summaries), the case (`output.fine`,
`chain.defect_index`) and the CLI. Arrays stay numpy's, 0-based: column i of a (n_frames, N)
history, or entry i of a per-magnet array (N,), is magnet i + 1; entry i of a per-gap array
(N-1,) is gap i + 1. Results objects convert at their boundary, with these helpers.
"""

from __future__ import annotations


def number(index: int) -> int:
    """The magnet (or gap) number of 0-based array entry `index`."""
    return int(index) + 1


def entries(first: int, last: int) -> slice:
    """The array entries of magnets (or gaps) first .. last, inclusive."""
    return slice(int(first) - 1, int(last))
