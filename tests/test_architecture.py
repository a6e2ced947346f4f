"""The package's layers, as a test: every import (module level or inside a function) goes to the
same layer or one below, and no modules import each other in a cycle.

The order, lowest first (docs/architecture.md draws it):

    base          errors, units, numbering, serialize, trajectory, file locks, version, exact results
    formats       the run folder's file names and every reader and writer; the array measures
    models        force laws, impactor profiles, force tables, MPI rank layout, theory
    case          the case: chain, settings, model sections, TOML, identity
    bridge        a case's measures (front levels, front record), summary, figures, progress, ASE
    deck          deck text from a case
    engine        LAMMPS: plugin, engine, runner, programs, preflight, overheads; the kernel engines (engines)
    run folder    write, run, record, convert, read
    sweeps        parameter sweeps and ensembles
    studies       the paper's figures and the literature
    interface     the command line and the `pl` API
"""

from __future__ import annotations

import ast
import functools
import shutil
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "pylmp_lattice"

# (layer, the modules in it: a name covers its submodules), lowest first
LAYERS = [
    ("base", ["errors", "log_lines", "lazy", "units", "numbering", "serialize", "columnar", "trajectory", "file_lock",
              "version", "exact", "mdanalysis"]),
    ("formats", ["formats", "measures"]),
    ("models", ["forcelaw", "impactor", "table", "ranks", "theory"]),
    ("case", ["case"]),
    ("bridge", ["case_measures", "summary", "plots", "progress", "ase_io"]),
    ("deck", ["deck"]),
    ("engine", ["plugin", "engine", "engines", "runner", "tools", "preflight", "overhead"]),
    ("run folder", ["run_folder"]),
    ("sweeps", ["sweep"]),
    ("studies", ["studies"]),
    ("interface", ["cli", "__main__", ""]),  # "": the package's own __init__, the `pl` API; __main__: python -m
]


def module_name(path: Path, package: Path) -> str:
    """'formats.layout' for package/formats/layout.py, 'sweep' for package/sweep/__init__.py."""
    parts = list(path.relative_to(package).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer_of(module: str) -> int:
    """The index in LAYERS of the layer holding `module`; KeyError for a module no layer names."""
    for index, (_, names) in enumerate(LAYERS):
        if any(module == name or (name and module.startswith(name + ".")) for name in names):
            return index
    raise KeyError(module)


@functools.lru_cache(maxsize=None)
def import_nodes(text: str) -> tuple[ast.stmt, ...]:
    """The import statements of a module's source, at any depth: parsed once per text (the tests
    here read the package four times, and its planted copy differs in three files only)."""
    return tuple(node for node in ast.walk(ast.parse(text)) if isinstance(node, (ast.Import, ast.ImportFrom)))


def imports(package: Path) -> dict[str, set[str]]:
    """{module: the package's modules it imports}, every import statement of each file."""
    modules = {module_name(p, package): p for p in package.rglob("*.py")}
    out: dict[str, set[str]] = {}
    for module, path in modules.items():
        here = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
        for node in import_nodes(path.read_text()):
            targets = []
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = here[: len(here) - node.level + 1] if node.level > 1 else here
                    target = ".".join([*base, *([node.module] if node.module else [])])
                elif (node.module or "").startswith(package.name):
                    target = node.module.removeprefix(package.name).lstrip(".")
                else:
                    continue
                for alias in node.names:
                    full = f"{target}.{alias.name}".lstrip(".")
                    targets.append(full if full in modules else target)
            elif isinstance(node, ast.Import):
                targets = [a.name.removeprefix(package.name).lstrip(".") for a in node.names
                           if a.name.split(".")[0] == package.name]
            for target in targets:
                while target not in modules and "." in target:
                    target = target.rsplit(".", 1)[0]
                if target != module and target in modules:
                    out.setdefault(module, set()).add(target)
    return out


def upward_imports(package: Path) -> list[str]:
    """'a -> b' for each import of a module in a higher layer, and each module no layer names."""
    graph = imports(package)
    bad = []
    for module in sorted({module_name(p, package) for p in package.rglob("*.py")}):
        try:
            layer_of(module)
        except KeyError:
            bad.append(f"{module}: in no layer (add it to LAYERS)")
    for module, targets in sorted(graph.items()):
        for target in sorted(targets):
            try:
                if layer_of(target) > layer_of(module):
                    bad.append(f"{module} ({LAYERS[layer_of(module)][0]}) -> {target} ({LAYERS[layer_of(target)][0]})")
            except KeyError:
                pass  # reported above
    return bad


def cycles(package: Path) -> list[list[str]]:
    """Each cycle of module imports, as the modules on it. A module's import of a package above
    it (its own, or the root's `__version__`) is not followed: a package's `__init__` names its
    submodules, which is not a cycle in the layers."""
    graph = {m: {t for t in targets if not (t == "" or m.startswith(t + "."))} for m, targets in imports(package).items()}
    found, state = [], {}

    def visit(module, path):
        state[module] = "open"
        for target in sorted(graph.get(module, ())):
            if state.get(target) == "open":
                found.append(path[path.index(target):] + [target])
            elif target not in state:
                visit(target, path + [target])
        state[module] = "closed"

    for module in sorted(graph):
        if module not in state:
            visit(module, [module])
    return found


def test_every_import_goes_to_the_same_layer_or_below():
    assert upward_imports(PACKAGE) == []


def test_no_import_cycles():
    assert cycles(PACKAGE) == []


def test_a_planted_upward_import_and_a_cycle_are_found(tmp_path):
    copy = tmp_path / "pylmp_lattice"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "*.so"))
    # a reader that calls up into the run folder (inside a function: imported at first use)
    layout = copy / "formats" / "layout.py"
    layout.write_text(layout.read_text() + "\n\ndef planted():\n    from ..run_folder import folder\n")
    assert upward_imports(copy) == ["formats.layout (formats) -> run_folder.folder (run folder)"]
    # two base modules that import each other
    (copy / "units.py").write_text((copy / "units.py").read_text() + "\nfrom . import numbering\n")
    (copy / "numbering.py").write_text((copy / "numbering.py").read_text() + "\nfrom . import units\n")
    assert {"numbering", "units"} in [set(cycle) for cycle in cycles(copy)]
