"""The package's version: one home, below every layer (run.json and a sweep's provenance name it)."""

__version__ = "0.1.0"
