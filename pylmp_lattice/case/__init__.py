"""The case: a typed, validated description of one simulation, loadable from TOML (see `case.case`)."""

from .case import (CHUNK, COMPRESSIONS, DISORDER, ENGINES, FAR_ENDS, FORCE_LAWS, KEPT_DRAWS, LONG_LATTICE_MARGIN,
                   MAX_PARTICLES, MAX_STEPS, NAME, NAME_RULE, OUTPUT_FORMATS, SECTIONS, Case, Chain, Friction,
                   OutputSettings, RunSettings, SecondNeighbour, TableSettings, apply_override, brief, case_from_dict,
                   case_id, case_to_dict, check_name, data_file, identity_hash, load_case, long_lattice_particles,
                   normalised, normalised_hash, read_toml, unit_warnings)
