"""Draw docs/figures/architecture.svg: the package's layers and the imports between them.

The layers and the import graph are the ones tests/test_architecture.py checks, read from the
source, so the picture is of the code as it stands. Run from the repository root:

    python docs/figures/architecture.py
"""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
from test_architecture import LAYERS, PACKAGE, imports, layer_of, module_name  # noqa: E402

OUT = Path(__file__).with_name("architecture.svg")


def layer_imports() -> tuple[Counter, Counter]:
    """(imports between two layers, keyed (from, to); imports within each layer)."""
    between, within = Counter(), Counter()
    for module, targets in imports(PACKAGE).items():
        for target in targets:
            a, b = layer_of(module), layer_of(target)
            if a == b:
                within[a] += 1
            else:
                between[a, b] += 1
    return between, within


def draw(path: Path = OUT) -> None:
    between, within = layer_imports()
    modules = Counter(layer_of(m) for m in {module_name(p, PACKAGE) for p in PACKAGE.rglob("*.py")})
    n = len(LAYERS)
    fig, ax = plt.subplots(figsize=(9.5, 0.62 * n + 1.4))
    for i, (name, members) in enumerate(LAYERS):
        y = i
        ax.add_patch(plt.Rectangle((0.0, y - 0.36), 6.2, 0.72, facecolor=plt.cm.Blues(0.12 + 0.05 * (i % 2)),
                                   edgecolor="0.4", lw=0.8))
        ax.text(0.12, y + 0.12, name, fontsize=10, fontweight="bold", va="center")
        shown = ", ".join(m or "pl (the package's __init__)" for m in members)
        ax.text(0.12, y - 0.16, shown, fontsize=7.5, va="center", color="0.2")
        ax.text(6.1, y + 0.12, f"{modules[i]} module{'s' * (modules[i] != 1)}, {within[i]} import{'s' * (within[i] != 1)} inside",
                fontsize=7, va="center", ha="right", color="0.35")
    # the imports from each layer (row) to each layer below it (column): a cell each, shaded by
    # the count; the cells above the diagonal (upward imports) stay empty, as the test demands
    x0, w = 6.5, 0.26
    top = max(between.values())
    for (a, b), count in sorted(between.items()):
        ax.add_patch(plt.Rectangle((x0 + b * w, a - w / 2), w, w, facecolor=plt.cm.Oranges(0.15 + 0.7 * count / top),
                                   edgecolor="white", lw=0.5))
        ax.text(x0 + (b + 0.5) * w, a, str(count), fontsize=6, ha="center", va="center")
    for i in range(n):
        ax.add_patch(plt.Rectangle((x0 + i * w, i - w / 2), w, w, facecolor="0.85", edgecolor="white", lw=0.5))
        ax.text(x0 + (i + 0.5) * w, -0.5, LAYERS[i][0], fontsize=6, rotation=90, ha="center", va="top")
    ax.text(x0, n - 0.05, "imports from the row's layer\nto the column's (grey: within)", fontsize=7, va="top",
            color="0.3")
    ax.set(xlim=(-0.1, x0 + n * w + 0.1), ylim=(-2.0, n + 0.2))
    ax.axis("off")
    ax.set_title(f"pylmp_lattice: {n} layers, lowest first; {sum(between.values())} imports between layers, "
                 "none upward (tests/test_architecture.py)", fontsize=9)
    plt.rcParams.update({"svg.hashsalt": "pylmp_lattice", "svg.fonttype": "none"})  # the same file every run; text as text
    fig.savefig(path, metadata={"Date": None}, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    draw()
    print(f"wrote {OUT}")
