"""Every public function, class and method of the package has a docstring.

Public: a name without a leading underscore, defined in a module whose dotted name has none;
a method may inherit its docstring from a protocol it implements (`forcelaw.Law`,
`impactor.Profile`), as `inspect.getdoc` and the API reference read it.
"""

from __future__ import annotations

import importlib
import inspect
import importlib.util
import pkgutil

import pylmp_lattice


def undocumented() -> list[str]:
    missing = []
    for info in pkgutil.walk_packages(pylmp_lattice.__path__, "pylmp_lattice."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        spec = importlib.util.find_spec(info.name)
        if not info.ispkg and not spec.origin.endswith(".py"):  # the plugin's libraries: C++, not Python
            continue
        module = importlib.import_module(info.name)
        if not inspect.getdoc(module):
            missing.append(f"{info.name} (module)")
        for name, obj in vars(module).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
                continue
            if inspect.isfunction(obj) and not inspect.getdoc(obj):
                missing.append(f"{info.name}.{name}")
            elif inspect.isclass(obj):
                if not (obj.__doc__ or "").strip() or obj.__doc__.startswith(f"{obj.__name__}("):  # dataclass's own
                    missing.append(f"{info.name}.{name} (class)")
                for attr, member in vars(obj).items():
                    function = member.fget if isinstance(member, property) else getattr(member, "__func__", member)
                    if not attr.startswith("_") and inspect.isfunction(function) and not inspect.getdoc(getattr(obj, attr)):
                        missing.append(f"{info.name}.{name}.{attr}")
    return missing


def test_every_public_function_class_and_method_has_a_docstring():
    assert undocumented() == []


def test_the_walk_finds_a_missing_docstring(monkeypatch):
    """A function without one is reported (the test above can fail)."""
    from pylmp_lattice import deck

    monkeypatch.setattr(deck.render, "__doc__", None)
    assert undocumented() == ["pylmp_lattice.deck.render"]
