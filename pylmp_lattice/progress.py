"""A progress bar on stderr for a running engine: simulated time in ms, steps, time left.

It draws only when stderr is a terminal (tqdm's `disable=None`), so logs and pipes stay clean.
"""

from __future__ import annotations

import contextlib
import sys

from .case import Case


@contextlib.contextmanager
def progress_bar(case: Case, enabled: bool = True):
    """Yield `on_step(step)` for a runner; a no-op when not `enabled` or stderr is not a terminal."""
    if not enabled:
        yield None
        return
    from tqdm import tqdm  # here: a sweep's members draw no bar

    total = case.run.steps()

    def label(step: int) -> str:
        return f"{case.name}: t = {step * case.run.dt:.6g}/{case.run.duration:g} ms"

    with tqdm(total=total, desc=label(0), unit="step", file=sys.stderr, disable=None, leave=False,
              bar_format="{desc} |{bar}| {n_fmt}/{total_fmt} steps [{elapsed}<{remaining}]") as bar:

        def on_step(step: int) -> None:
            step = min(int(step), total)
            bar.set_description_str(label(step), refresh=False)
            bar.update(step - bar.n)

        yield on_step
