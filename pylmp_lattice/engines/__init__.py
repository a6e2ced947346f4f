"""Engines for ensembles of independent chains besides LAMMPS: the chain kernel
(pylmp_lattice/plugin/kernel, the physics of fix lattice/chain) on every CPU core (`cpu`)."""
