"""The case: a typed, validated description of one simulation, loadable from TOML.

All values are in user units (mm, g, ms, N, m/s); `units` converts them for the engine.
One concept a module:
- `chain`: `Chain`, the magnets and gaps, their ensembles (disorder, defect, thermal velocities);
- `settings`: `RunSettings` [run], `TableSettings` [table], `OutputSettings` [output];
- `model`: the force laws by name, `Friction` [friction], `SecondNeighbour` [second_neighbour];
- `case`: `Case`, the sections together and the checks across them, a long lattice's N;
- `toml`: TOML in and out (`load_case`, `case_from_dict`, `case_to_dict`, `--set` overrides,
  data files, unit warnings);
- `identity`: `case_id` and the hashes of resolved cases;
- `checks`: what the sections share (name rule, LAMMPS's limits, message helpers).
"""

from .case import LONG_LATTICE_MARGIN, Case, long_lattice_particles
from .chain import CHUNK, DISORDER, FAR_ENDS, KEPT_DRAWS, Chain, thermal_velocities
from .checks import MAX_PARTICLES, MAX_STEPS, NAME, NAME_RULE, brief, check_name
from .identity import case_id, identity_hash, normalised, normalised_hash
from .model import FORCE_LAWS, Friction, SecondNeighbour
from .settings import COMPRESSIONS, ENGINES, OUTPUT_FORMATS, OutputSettings, RunSettings, TableSettings
from .toml import (SECTIONS, FieldKindError, apply_override, as_case, case_from_dict, case_to_dict, data_file,
                   load_case, read_toml, unit_warnings)

__all__ = ["CHUNK", "COMPRESSIONS", "DISORDER", "ENGINES", "FAR_ENDS", "FORCE_LAWS", "KEPT_DRAWS",
           "LONG_LATTICE_MARGIN", "MAX_PARTICLES", "MAX_STEPS", "NAME", "NAME_RULE", "OUTPUT_FORMATS", "SECTIONS",
           "Case", "Chain", "FieldKindError", "Friction", "OutputSettings", "RunSettings", "SecondNeighbour", "TableSettings",
           "apply_override", "as_case", "brief", "case_from_dict", "case_id", "case_to_dict", "check_name", "data_file",
           "identity_hash", "load_case", "long_lattice_particles", "normalised", "normalised_hash", "read_toml", "thermal_velocities",
           "unit_warnings"]
