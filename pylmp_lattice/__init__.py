"""pylmp_lattice: shock waves in one-dimensional nonlinear lattices, run with LAMMPS."""

__version__ = "0.1.0"
