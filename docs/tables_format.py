"""Formatting and reading for docs/tables.py: numbers as the docs show them, a Markdown table,
and the stored study outputs under docs/ (docs/reproduction/, docs/literature/)."""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

DATA = Path(__file__).resolve().parent  # docs/: the stored outputs lie in its reproduction/ and literature/
COMPARE = ["quantity", "paper", "ours", "difference", "why"]  # the paper-against-ours tables


def fixed(x, decimals: int) -> str:
    """x with `decimals` decimals; "-" where there is no number."""
    return "-" if x is None or not math.isfinite(float(x)) else f"{float(x):.{decimals}f}"


def sig(x, figures: int) -> str:
    """x to `figures` significant figures, trailing zeros kept (1.101, 0.2202, 3.8884)."""
    if x is None or not math.isfinite(float(x)):
        return "-"
    x = float(x)
    if x == 0:
        return "0"
    return fixed(x, max(0, figures - 1 - math.floor(math.log10(abs(x)))))


def sci(x, decimals: int = 1) -> str:
    """x in exponent form without the exponent's leading zero, "5.7e-7"; "-" where there is none."""
    if x is None or not math.isfinite(float(x)):
        return "-"
    return re.sub(r"e([+-])0(\d)", r"e\1\2", f"{float(x):.{decimals}e}")


def percent(x, decimals: int = 2) -> str:
    """A relative number as a signed percentage, "+0.09 %"."""
    return "-" if x is None or not math.isfinite(float(x)) else f"{100 * float(x):+.{decimals}f} %"


def table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["|" + "|".join(f" {cell} " if cell else " " for cell in row) + "|" for row in rows]) + "\n"


def read_json(path: str) -> dict:
    return json.loads((DATA / path).read_text())


def read_csv(path: str) -> list[dict]:
    with open(DATA / path, newline="") as f:
        return list(csv.DictReader(f))


def num(text: str) -> float:
    return float(text) if text not in ("", "nan", "None") else math.nan

def exp_form(x) -> str:
    """A small relative number in exponent form, "-9.3e-10"; "-" where there is none."""
    return "-" if x is None or not math.isfinite(float(x)) else f"{float(x):.1e}"
