"""Engines for ensembles of independent chains besides LAMMPS: the chain kernel
(pylmp_lattice/plugin/kernel, the physics of fix lattice/chain) on every CPU core (`cpu`) and on
a GPU (`gpu`, CuPy), with the same inputs and results (`arrays`)."""

# The engines a sweep's batches take (here, not in `road`: a sweep file is checked without numpy's
# arrays and the kernel's modules, which only the workers load)
ENGINES = ("lammps", "cpu", "gpu")
