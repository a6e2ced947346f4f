"""Names of a package loaded on first use (PEP 562), so that importing the package stays cheap:
a sweep's command and its workers' fork server import packages before their first member."""

from __future__ import annotations

from importlib import import_module


def lazy_names(package: str, where: dict[str, str]):
    """A package's module `__getattr__` and `__dir__` for `where` (name -> its submodule): a name
    loads its submodule on first use, and so does the submodule's own name (`package.wake`)."""
    submodules = set(where.values())

    def __getattr__(name: str):
        if name in where:
            return getattr(import_module(f".{where[name]}", package), name)
        if name in submodules:
            return import_module(f".{name}", package)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__():
        return sorted({*vars(import_module(package)), *where, *submodules})

    return __getattr__, __dir__
