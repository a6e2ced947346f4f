"""A sweep's progress line on stderr (`_Progress`)."""

from __future__ import annotations

import sys

from .store import FAILED, INTERRUPTED


class _Progress:
    """A progress bar on stderr (terminals only): members finished of all, failed, running."""

    def __init__(self, total: int, enabled: bool):
        self.failed = self.running = 0
        self.bar = None
        if enabled and sys.stderr.isatty():  # else no tqdm (its import is on the way to the first member)
            from tqdm import tqdm

            self.bar = tqdm(total=total, file=sys.stderr, unit="member", dynamic_ncols=True, mininterval=0.5)

    def show(self, running: int) -> None:
        self.running = running
        if self.bar is not None:
            self.bar.set_postfix_str(f"failed {self.failed}, tasks running {running}", refresh=False)

    def advance(self, status: str, count: int = 1) -> None:
        """`count` members finished with this status."""
        self.failed += count * (status == FAILED)
        if status != INTERRUPTED and self.bar is not None:
            self.bar.update(count)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
