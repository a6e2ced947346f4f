"""Engines for ensembles of independent chains besides LAMMPS: the chain kernel
(pylmp_lattice/plugin/kernel, the physics of fix lattice/chain) on every CPU core (`cpu`) and on
a GPU (`gpu`, CuPy), with the same inputs and results (`arrays`)."""
