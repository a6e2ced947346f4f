"""How the package's log lines look on stderr, in the command and in a sweep's workers:
"pylmp-lattice: warning: ..." (one line each, the level in lower case)."""

from __future__ import annotations

import logging

FORMAT = "pylmp-lattice: %(levelname)s: %(message)s"


def log_to_stderr(level: int) -> None:
    """Log lines of `level` and above to stderr in FORMAT, unless logging has its handlers
    already (a program that configured it)."""
    for named in (logging.INFO, logging.WARNING):
        logging.addLevelName(named, logging.getLevelName(named).lower())
    logging.basicConfig(level=level, format=FORMAT)
