"""Case description: validation messages, TOML round trip, overrides, long-lattice size."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from pylmp_lattice.case import case_from_dict, case_to_dict, load_case
from pylmp_lattice.errors import ConfigError, UsageError
from pylmp_lattice.forcelaw import PowerLaw

from conftest import OTHER_LAWS, make_case, make_law_case

INPUTS = Path(__file__).parent.parent / "inputs"


@pytest.mark.parametrize(
    "section, values, field, expected",
    [
        ("chain", {"mass": -1.0}, "chain.mass", "expected > 0"),
        ("chain", {"r0": 0.0}, "chain.r0", "expected > 0"),
        ("chain", {"r0": [12.0, 12.0]}, "chain.r0", "expected 1 or 29"),
        ("chain", {"colour": "red"}, "chain.colour", "unknown key"),
        ("chain", {"far_end": "open"}, "chain.far_end", "choose one of fixed, long"),
        ("force", {"q": 0.5}, "force.q", "expected > 1"),
        ("force", {"law": "buckingham"}, "force.law", "choose one of"),
        ("force", {"law": "lj", "epsilon": 1.0, "sigma": 10.0}, "table.r_min", "not finite there"),
        ("table", {"r_min": 13.0}, "table.r_min", "expected in [0.0, 12.0] mm"),
        ("table", {"r_min": -1.0}, "table.r_min", "expected >= 0"),
        ("impactor", {"velocity": -2.0}, "impactor.velocity", "got -2.0 m/s; expected > 0"),
        ("impactor", {"velocity": "fast"}, "impactor.velocity", "expected a number"),
        ("run", {"dt": 0.5, "output_interval": 1.0}, "run.dt", "stability limit"),
        ("run", {"output_interval": 0.015}, "run.output_interval", "whole multiple of run.dt"),
        # checked before LAMMPS runs, in mm (LAMMPS would stop with "Bond length > table outer cutoff" in m)
        ("table", {"r_max": 10.0}, "table.r_max", "got 10 mm; expected > 12 mm, the widest initial gap"),
        # a table that ends at the widest gap: the first stretch of that gap leaves it
        ("table", {"r_max": 12.0}, "table.r_max", "got 12 mm; expected > 12 mm, the widest initial gap"),
        ("table", {"points": 99}, "table.points", "expected an integer in [100, 1e7]"),
        ("chain", {"magnet_length": 2e6}, "chain.magnet_length", "expected a number in [0, 1e6]"),
        ("chain", {"velocity": [0.0] * 29 + [0.1]}, "chain.velocity", "for the held last magnet; expected 0"),
        ("output", {"fine": [2, 2]}, "output.fine", "expected distinct magnet numbers"),
        ("output", {"fine": [31]}, "output.fine", "expected magnet numbers in [1, 30]"),
        ("output", {"fine": [2], "fine_interval": 0.0}, "output.fine_interval", "expected > 0"),
        ("friction", {"mu": -0.1}, "friction.mu", "expected >= 0"),
        ("friction", {"p": -0.012}, "friction.p", "expected >= 0"),
        ("second_neighbour", {"law": "power", "sign": 0}, "second_neighbour.sign", "expected -1 (attractive) or 1"),
    ],
)
def test_bad_input_names_the_field(section, values, field, expected):
    with pytest.raises(ConfigError) as info:
        make_case(**{section: values})
    assert info.value.field == field
    assert expected in str(info.value)


def test_stability_limit_of_the_paper_law():
    # dt < sqrt(m / k_max), k_max = q K / b^(q+1) at contact: sqrt(1.084 / 5.2718) ms
    k_max = 3 * 413.8 / 3.917**4
    assert make_case().stability_limit() == pytest.approx(math.sqrt(1.084 / k_max), rel=1e-9)
    assert make_case().stability_limit() == pytest.approx(0.4534, abs=1e-4)


def test_bounds_that_are_allowed_at_their_ends():
    """The closed ends of the documented ranges: magnet N (the held one) may be output finely;
    the table may start at the smallest gap ([law's start, smallest gap]); friction may be
    off term by term (mu = p = g = 0: a sweep over mu starts at 0); a table of 100 points;
    a magnet length of 1e6 mm."""
    case = make_case(output={"fine": [1, 30]}, table={"r_min": 12.0, "points": 100}, chain={"magnet_length": 1e6},
                     friction={"mu": 0.0, "p": 0.0, "g": 0.0})
    assert case.output.fine == (1, 30) and case.table_range()[0] == 12.0
    assert (case.friction.mu, case.friction.p, case.friction.g) == (0.0, 0.0, 0.0)


def test_the_table_defaults_to_the_law_s_start_and_three_times_the_widest_gap():
    """[r_min, r_max] = [0, 3 x 12 mm] for the paper's law and gaps; [first sample, 3 x the
    widest gap] for a sampled law; gaps up to 15 mm: r_max 45 mm."""
    assert make_case().table_range() == (0.0, 36.0)
    r = np.linspace(2.0, 60.0, 59)
    sampled = make_case(force={"law": "sampled", "r": list(r), "F": list(PowerLaw().force(r))},
                        chain={"r0": [12.0] * 28 + [15.0]})
    assert sampled.table_range() == (2.0, 45.0)


def test_a_table_that_starts_before_a_sampled_law_does_is_refused():
    """A law known from 2 mm on: a table from 1 mm would extrapolate the spline below its
    samples, refused naming table.r_min with the law's range."""
    r = np.linspace(2.0, 60.0, 59)
    with pytest.raises(ConfigError, match=r"^table\.r_min: got 1\.0 mm; expected in \[2\.0, 12\.0\] mm"):
        make_case(force={"law": "sampled", "r": list(r), "F": list(PowerLaw().force(r))}, table={"r_min": 1.0})


def test_a_time_step_at_the_stability_limit_is_refused():
    """Velocity Verlet is stable for omega_max dt < 2 only: at omega_max dt = 2 the stiffest mode
    grows linearly. Springs k = 1 N/mm and masses 1 g have dt_max = sqrt(m/k) = 1 ms exactly
    (sqrt(g / (N/mm)) = 1 ms): dt = 1 ms is refused, 0.5 ms taken."""
    spring = {"law": "linear", "k": 1.0, "r_free": 30.0}
    ok = make_case(force=spring, chain={"mass": 1.0}, dt=0.5, interval=1.0, duration=10.0)
    assert ok.stability_limit() == 1.0
    with pytest.raises(ConfigError, match=r"^run\.dt: got 1\.0 ms; expected < 1 ms \(stability limit"):
        make_case(force=spring, chain={"mass": 1.0}, dt=1.0, interval=1.0, duration=10.0)


def test_the_stability_limit_counts_the_second_neighbours_stiffness():
    """Gershgorin: omega^2 <= 4 (k_max + k2_max) / m, so dt < sqrt(m / (k_max + k2_max)). The
    paper's law at contact, k_max = 3 K / b^4, and the second neighbours of Sec. S2 (K2 = 206.2
    N mm^3, b2 = 10.267 mm, attractive) at the smallest second separation, twice the table's
    start (0 mm): k2_max = 3 K2 / b2^4."""
    second = {"law": "power", "K": 206.2, "b": 10.267, "q": 3.0, "sign": -1}
    case = make_case(second_neighbour=second, run={"engine": "stock"})
    k_max, k2_max = 3 * 413.8 / 3.917**4, 3 * 206.2 / 10.267**4
    assert case.stability_limit() == pytest.approx(math.sqrt(1.084 / (k_max + k2_max)), rel=1e-12)
    assert case.stability_limit() < make_case().stability_limit() * (1 - 1e-3)


def test_a_run_of_exactly_the_largest_step_count_is_taken():
    """LAMMPS takes `run N` up to 2^31 - 1 steps: that many is a run, one more is not."""
    from pylmp_lattice.case import RunSettings

    top = 2**31 - 1
    assert RunSettings(duration=float(top), dt=1.0, output_interval=1.0).steps() == top
    with pytest.raises(ConfigError, match=r"^run\.duration: got 2147483648\.0 ms; expected at most 2147483647 steps"):
        RunSettings(duration=float(top + 1), dt=1.0, output_interval=1.0)


def test_toml_round_trip_and_override(tmp_path):
    import tomli_w

    case = make_case(chain={"mass": [1.0] * 29 + [2.0]})
    path = tmp_path / "c.toml"
    path.write_bytes(tomli_w.dumps(case_to_dict(case)).encode())
    assert load_case(path) == case
    faster = load_case(path, ["impactor.velocity=1.5", "run.duration=20"])
    assert faster.impactor.velocity == 1.5 and faster.run.duration == 20



@pytest.mark.parametrize("law", OTHER_LAWS)
def test_other_laws_round_trip_through_toml(tmp_path, law):
    import tomli_w

    case = make_law_case(law)
    path = tmp_path / "c.toml"
    path.write_bytes(tomli_w.dumps(case_to_dict(case)).encode())
    assert f'law = "{law}"' in path.read_text()
    assert load_case(path) == case


def test_long_lattice_is_sized_from_the_front_speed_bound():
    case = load_case(INPUTS / "paper_long_lattice.toml")
    v0 = 12.0 * math.sqrt(3 * 413.8 / 15.917**4 / 1.084)
    expected = math.ceil((v0 + 2 * 2.0) * case.run.duration / 12.0) + 20
    assert case.chain.particles == expected


def test_missing_file_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="file not found"):
        load_case(tmp_path / "nope.toml")


def test_sampled_law_from_csv(tmp_path):
    csv = tmp_path / "force.csv"
    csv.write_text("# r [mm], F [N]\n" + "\n".join(f"{r},{413.8 / (r + 3.917) ** 3}" for r in range(0, 40)))
    case = case_from_dict({
        "chain": {"particles": 5, "mass": 1.084, "r0": 12.0},
        "force": {"law": "sampled", "file": "force.csv"},
        "impactor": {"velocity": 1.0},
        "run": {"duration": 1.0},
        "table": {"r_max": 39.0},
    }, base_dir=tmp_path)
    assert case.force.force(12.0) == pytest.approx(413.8 / 15.917**3, rel=1e-4)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--set", "chain.mass=-1"], "chain.mass: got -1 g; expected > 0"),
        (["--set", "run.dt=0.5", "--set", "run.output_interval=1.0"], "run.dt: got 0.5 ms; expected < 0.4534 ms"),
        (["--set", "chain.nonsense=1"], "chain.nonsense: unknown key"),
    ],
)
def test_cli_bad_input_is_one_line_exit_2(tmp_path, args, message):
    done = subprocess.run(
        [sys.executable, "-m", "pylmp_lattice.cli", "deck", str(INPUTS / "paper_experiment.toml"), "-o", str(tmp_path), *args],
        capture_output=True, text=True, cwd=tmp_path,
    )
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and message in done.stderr
    assert "Traceback" not in done.stderr


def test_cli_missing_case_file(tmp_path):
    done = subprocess.run([sys.executable, "-m", "pylmp_lattice.cli", "deck", str(tmp_path / "x.toml")],
                          capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 2 and "file not found" in done.stderr and "Traceback" not in done.stderr


@pytest.mark.parametrize("profile, law", [("measured", "power"), ("constant", "sampled")])
def test_mistyped_key_lists_file_among_the_valid_keys(profile, law):
    data = case_to_dict(make_case())
    section = "impactor" if profile == "measured" else "force"
    data["impactor"] = {"profile": profile, "fiel": "u1.csv"} if profile == "measured" else data["impactor"]
    if law == "sampled":
        data["force"] = {"law": "sampled", "fiel": "force.csv"}
    with pytest.raises(ConfigError, match=rf"^{section}\.fiel: unknown key; expected one of file, ") as info:
        case_from_dict(data)
    assert info.value.field == f"{section}.fiel"


def test_second_neighbour_section_round_trips_and_validates():
    data = case_to_dict(make_case(second_neighbour={"law": "power", "K": 206.2, "b": 10.267, "q": 3.0, "sign": -1}))
    case = case_from_dict(data)
    assert case.second_neighbour.sign == -1 and case.second_neighbour.law.K == 206.2
    assert case_to_dict(case) == data
    assert case.second_neighbour.force(24.0) < 0  # attractive
    data["second_neighbour"]["sign"] = 0.5
    with pytest.raises(ConfigError, match="second_neighbour.sign: got 0.5"):
        case_from_dict(data)
    data["second_neighbour"] |= {"sign": -1, "law": "sampled"}
    with pytest.raises(ConfigError, match="second_neighbour.law"):
        case_from_dict(data)
    long = make_case(chain={"particles": None, "far_end": "long"}, second_neighbour={"law": "power", "sign": 1})
    assert long.held() == [long.chain.particles - 2, long.chain.particles - 1]


def test_second_neighbours_need_the_stock_engine():
    """The chain engine's fix handles nearest neighbours only: a case with second neighbours
    runs on the stock deck path by default, and asking for the chain engine is refused."""
    second = {"law": "power", "K": 206.2, "b": 10.267, "q": 3.0, "sign": -1}
    assert make_case(second_neighbour=second).run.engine == "stock"
    assert make_case().run.engine == "chain"
    with pytest.raises(ConfigError, match="run.engine: got 'chain'; second neighbours need run.engine = 'stock'"):
        make_case(second_neighbour=second, run={"engine": "chain"})


MEASURED = "# t [ms], u [mm]\n" + "".join(f"{t},{0.5 * t}\n" for t in range(6))


@pytest.mark.parametrize("name", ["a", "paper_experiment", "run-1.5", "A" * 100, "..x", "x.."])
def test_valid_names(name):
    assert dataclasses.replace(make_case(), name=name).name == name  # built again, so checked


@pytest.mark.parametrize("name", ["", ".", "..", "a/b", "/abs", "a b", "x\nshell touch X", "é", "n" * 101, 5, None])
def test_name_is_an_identifier(name):
    with pytest.raises(ConfigError) as info:
        case_from_dict(case_to_dict(make_case()) | {"name": name})
    assert info.value.field == "name"
    assert str(info.value).endswith("expected 1-100 characters of letters, digits, '-', '_', '.' (not '.' or '..')")


def test_long_name_gives_one_short_line():
    with pytest.raises(ConfigError) as info:
        case_from_dict(case_to_dict(make_case()) | {"name": "n" * 300})
    assert str(info.value).startswith("name: got 'nnnnnnnnn") and len(str(info.value)) < 160


def _measured_case(folder: Path, file: str):
    data = case_to_dict(make_case(particles=6, duration=4.0)) | {"impactor": {"profile": "measured", "file": file}}
    (folder / "case.toml").write_bytes(tomli_w.dumps(data).encode())
    return load_case(folder / "case.toml")


def test_data_file_is_read_from_the_case_folder_only(tmp_path, monkeypatch):
    """impactor.file (like force.file) names a file inside the case file's folder, whatever the
    working directory: absolute paths, '..' and links leading out are refused."""
    case_dir, outside = tmp_path / "cases", tmp_path / "elsewhere"
    (case_dir / "data").mkdir(parents=True)
    outside.mkdir()
    (case_dir / "data" / "u1.csv").write_text(MEASURED)
    (outside / "u1.csv").write_text(MEASURED)
    (case_dir / "link.csv").symlink_to(outside / "u1.csv")
    (case_dir / "inside-link.csv").symlink_to(case_dir / "data" / "u1.csv")
    monkeypatch.chdir(outside)  # a relative path is not read from the working directory
    assert _measured_case(case_dir, "data/u1.csv").impactor.t == (0, 1, 2, 3, 4, 5)
    assert _measured_case(case_dir, "inside-link.csv").impactor.t == (0, 1, 2, 3, 4, 5)
    for bad in (str(outside / "u1.csv"), "../elsewhere/u1.csv", "data/../../elsewhere/u1.csv", "link.csv"):
        with pytest.raises(ConfigError, match=r"^impactor\.file: got .*; expected a file inside the folder"):
            _measured_case(case_dir, bad)


def test_non_csv_data_file_is_not_echoed(tmp_path):
    (tmp_path / "notes.txt").write_text("password = hunter2\n0,1\n")
    with pytest.raises(ConfigError) as info:
        _measured_case(tmp_path, "notes.txt")
    assert "hunter2" not in str(info.value) and "password" not in str(info.value)
    assert str(info.value).startswith("impactor.file: notes.txt: expected two numeric columns")
    assert "; not a number in data row 1, column 1 (a header line must start with '#')" in str(info.value)


def test_data_file_header_must_be_a_comment(tmp_path):
    """A header row of text is refused with the rule (never guessed to be a header); as a '#'
    line it is a comment; a bad later row is counted without the comment lines."""
    rows = "".join(f"{t},{0.5 * t}\n" for t in range(6))
    (tmp_path / "plain.csv").write_text("t_ms,u_mm\n" + rows)
    (tmp_path / "commented.csv").write_text("# t_ms,u_mm\n" + rows)
    (tmp_path / "bad.csv").write_text("# t_ms,u_mm\n" + rows.replace("2,1.0", "2,x"))
    with pytest.raises(ConfigError, match=r"^impactor\.file: plain\.csv: expected two numeric columns .*; not a "
                                          r"number in data row 1, column 1 \(a header line must start with '#'\)$"):
        _measured_case(tmp_path, "plain.csv")
    assert _measured_case(tmp_path, "commented.csv").impactor.values == (0, 0.5, 1, 1.5, 2, 2.5)
    with pytest.raises(ConfigError, match=r"data row 3, column 2 \('#' comment lines not counted\)$"):
        _measured_case(tmp_path, "bad.csv")


@pytest.mark.parametrize("r0, law, expected", [
    # the paper's law: k = 3 K / (r0 + b)^4 is 0 in doubles once (r0 + b)^4 overflows, r0 > 1.158e77 mm
    (1e100, {}, r"got 1e\+100 mm, where the power law's stiffness -dF/dr is 0 N/mm; .*: up to 1\.158e\+77 mm"),
    (1e78, {}, r"up to 1\.158e\+77 mm for this law$"),
    # Lennard-Jones beyond its inflection point (26/7)^(1/6) sigma = 6.222 mm: k < 0, an unstable chain
    (12.0, {"law": "lj", "epsilon": 1.0, "sigma": 5.0}, r"stiffness -dF/dr is -0\.005986\d* N/mm; .* to 6\.222 mm"),
    # Morse beyond r_e + ln 2 / alpha = 5.693 mm
    (12.0, {"law": "morse", "D": 1.0, "alpha": 1.0, "r_e": 5.0}, r"up to 5\.69\d mm for this law$"),
    (1e-320, {}, r"got 9\.99989e-321 mm; expected >= 2\.225e-308 mm \(the smallest normal double"),
])
def test_gap_where_the_chain_carries_no_waves_is_refused(r0, law, expected):
    """Issue of the trial (item 3): a gap where the law's stiffness at rest is 0 in doubles made
    exact.weak_shock divide by zero (a traceback). Refused by name with the law's range."""
    sections = {"force": law} if law else {}
    for far_end in ("fixed", "long"):  # a long lattice takes V0 first, to size itself
        with pytest.raises(ConfigError, match=expected) as info:
            make_case(chain={"r0": r0, "far_end": far_end}, **sections)
        assert info.value.field == "chain.r0"


def test_stiffness_that_underflows_everywhere_names_no_range():
    with pytest.raises(ConfigError, match=r"^chain\.r0: got 12 mm, .* is 0 N/mm; .*; no gap has it for this law's "
                                          r"parameters$"):
        make_case(force={"law": "power", "K": 1e-320, "b": 3.917, "q": 3.0})


@pytest.mark.parametrize("run, field, expected", [
    ({"dt": 1e-300}, "run.dt", r"got 1e-300 ms; expected >= 2\.328e-08 ms \(run\.duration = 50\.0 ms in at most "
                               r"2147483647 steps"),
    ({"dt": 10.0}, "run.dt", r"got 10\.0 ms; expected <= run\.output_interval = 0\.1 ms"),
    ({"duration": 1e12}, "run.duration", r"expected at most 2147483647 steps of run\.dt = 0\.01 ms"),
    ({"dt": 0.03}, "run.duration", r"expected a whole multiple of run\.dt = 0\.03 ms"),
])
def test_time_step_errors_name_the_value_at_fault(run, field, expected):
    """A time step beyond the bounds of every interval is named (trial item 7: run.dt = 1e-300
    named run.duration, run.dt = 10 named run.output_interval)."""
    with pytest.raises(ConfigError, match=expected) as info:
        make_case(run=run)
    assert info.value.field == field


def test_another_impactor_profile_starts_its_section_afresh(tmp_path):
    """As --set force.law=..., --set impactor.profile=... drops the file's [impactor] keys, and
    an error about its keys says so (trial item 7: "impactor.velocity: unknown key")."""
    path = tmp_path / "c.toml"
    path.write_bytes(tomli_w.dumps(case_to_dict(make_case(impactor={"profile": "sine", "velocity": 2.0,
                                                                       "duration": 40.0}))).encode())
    with pytest.raises(ConfigError, match=r"^impactor\.t: missing; or give impactor\.file \(--set "
                                          r"impactor\.profile=measured starts \[impactor\] afresh"):
        load_case(path, ["impactor.profile=measured"])
    with pytest.raises(ConfigError, match=r"^impactor\.velocity: missing \(--set impactor\.profile=constant starts"):
        load_case(path, ["impactor.profile=constant"])
    assert load_case(path, ["impactor.profile=constant", "impactor.velocity=1.5"]).impactor.velocity == 1.5
    assert load_case(path, ["impactor.profile=sine", "impactor.velocity=1.5"]).impactor.duration == 40.0


@pytest.mark.parametrize("chain", [
    {}, {"defect_index": 3, "defect_mass": 0.5}, {"defect_index": 3, "defect_r0": 20.0},
    {"mass": [1.0 + 0.1 * k for k in range(12)]}, {"mass_disorder": 0.1, "seed": 1, "defect_index": 2, "defect_mass": 9.0},
    {"r0_disorder": 0.1, "disorder": "uniform", "seed": 2},
])
def test_extremes_of_masses_and_gaps_are_those_of_the_arrays(chain):
    c = make_case(particles=12, chain=chain).chain
    assert c.mass_range == (c.masses().min(), c.masses().max())
    assert c.gap_range == (c.gaps().min(), c.gaps().max())


def test_numpy_numbers_are_taken_as_numbers():
    """From Python, a numpy integer or float is a number as in TOML (trial: np.int64 particles
    gave "chain.particles: got np.int64(21); expected a number"); bool stays no number."""
    import numpy as np

    case = make_case(particles=np.int64(12), velocity=np.float32(2.0), chain={"r0": np.int32(12), "seed": np.uint32(3)},
                     output={"fine": [np.int64(2), 5]})
    assert case == make_case(particles=12, chain={"seed": 3}, output={"fine": [2, 5]})
    assert type(case.chain.particles) is int and type(case.impactor.velocity) is float
    case_from_dict(case_to_dict(case))  # plain TOML values: written back as they came
    for value in (True, np.bool_(True)):
        with pytest.raises(ConfigError, match=r"^chain.particles: got True; expected a number$"):
            make_case(particles=value)
    with pytest.raises(ConfigError, match=r"^chain.particles: got 2; expected an integer in \[3, "):
        make_case(particles=np.int64(2))


def test_numpy_arrays_are_taken_as_lists():
    """A 1-D numpy array is a list of values as in TOML (trial: per-magnet masses as an array gave
    "expected a number or a list"); its kind, length and range stay checked."""
    import numpy as np

    masses = [1.0 + 0.1 * k for k in range(12)]
    case = make_case(particles=12, chain={"mass": np.array(masses), "r0": np.full(11, 12.0)},
                     output={"fine": np.array([2, 5])})
    assert case == make_case(particles=12, chain={"mass": masses, "r0": [12.0] * 11}, output={"fine": [2, 5]})
    assert type(case.chain.mass) is tuple and type(case.chain.mass[0]) is float
    for chain, head, tail in (({"mass": -np.ones(12)}, "chain.mass: got -1.0..-1.0 (min..max) g", "; expected > 0"),
                              ({"mass": np.ones(11)}, "chain.mass: got 11 values", "; expected 1 or 12"),
                              ({"mass": np.array([1.0] * 11 + [np.nan])}, "chain.mass: got [1.0, ",
                               "; expected a number or a list of finite numbers"),
                              ({"mass": np.ones((2, 12))}, "chain.mass: got [[1.0, 1.0,",
                               "; expected a number or a list of finite numbers")):
        with pytest.raises(ConfigError) as info:
            make_case(particles=12, chain=chain)
        assert str(info.value).startswith(head) and str(info.value).endswith(tail)


@pytest.mark.parametrize("data", [[1, 2], "case.toml", None])
def test_case_from_dict_refuses_what_is_not_a_dict_in_one_line(data):
    with pytest.raises(UsageError, match=r"^data: got .*; expected a dict of the case's sections, "
                                         r"\{section: \{key: value\}\} as in its TOML file$"):
        case_from_dict(data)


def test_one_override_may_be_given_alone_and_others_are_refused(tmp_path):
    """load_case(path, "run.duration=40") reads one override (trial: it read each character, "--set: got 'r'")."""
    path = tmp_path / "c.toml"
    path.write_bytes(tomli_w.dumps(case_to_dict(make_case())).encode())
    assert load_case(path, "run.duration=20") == load_case(path, ["run.duration=20"]) == make_case(duration=20.0)
    for bad in (20, ["run.duration=20", 3], {"run.duration": 20}):
        with pytest.raises(UsageError, match=r"^overrides: got .*; expected a list of 'section.key=value' strings"):
            load_case(path, bad)
