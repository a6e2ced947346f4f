"""The floor: the file layout of a run folder and every reader and writer of LAMMPS's files and
ours. Nothing here imports a layer above (the case, the deck, the runner, the run folder): a
format reads and writes arrays in user units.

- `layout`: the names of a run's files and columns (the only module that names them);
- `dump`: LAMMPS's text dumps and log;
- `bindump`: LAMMPS's binary dumps (`dump custom ... binary`);
- `h5md`: the run's trajectory as H5MD, with `psf` its topology for MDAnalysis and VMD;
- `front_record`: fix lattice/front's record (front.bin) as arrays.
"""
