"""Nothing in an input reaches a deck as code, a shell, or a path outside its folder.

The attacks of issue 19 (a case name that ends the deck's comment line and starts `shell`
commands; a name that is a path) from a case file, `--name`, `--set` and a sweep's [grid] and
[set]: each is refused with one line and exit 2 before anything runs, sentinel files in the
working directory and in `runs/other` stay, and no INJECTED file appears. Then the decks of
valid cases are read the way LAMMPS reads them (continuation lines joined, comments stripped):
every command is one the deck writer means to write, and the case's strings sit in comments.
"""

from __future__ import annotations

import logging
import re

import pytest
import tomli_w

from pylmp_lattice import deck
from pylmp_lattice.case import case_from_dict, case_to_dict
from pylmp_lattice.cli import main
from pylmp_lattice.errors import ConfigError

from conftest import make_case, make_law_case

# Each name is refused; before the fix the first ran `shell touch INJECTED` in LAMMPS, the
# others wrote or deleted outside runs/.
ATTACKS = [
    "x\nshell touch INJECTED\nprint y",
    "x &\nshell touch INJECTED",
    "x\r\nshell touch INJECTED",
    "${shell}",
    "$(v_x)",
    "x # y",
    "'x'",
    "\"x\"",
    "../../x",
    "..",
    ".",
    "",
    "/tmp/x",
    "runs/other",
    "n" * 101,
]
CASE = case_to_dict(make_case(particles=10, velocity=1.0, duration=0.2)) | {"name": "ok"}


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    work = tmp_path / "work"
    (work / "runs" / "other").mkdir(parents=True)
    sentinels = {work / "sentinel.txt": "keep\n", work / "runs" / "other" / "sentinel.txt": "keep too\n"}
    for path, text in sentinels.items():
        path.write_text(text)
    with open(work / "case.toml", "wb") as f:
        tomli_w.dump(CASE, f)
    monkeypatch.chdir(work)
    root = logging.getLogger()  # cli.main sets up logging once per process: to this test's stderr
    saved, root.handlers[:] = root.handlers[:], []
    yield work
    root.handlers[:] = saved
    for path, text in sentinels.items():
        assert path.read_text() == text
    assert not list(tmp_path.rglob("INJECTED")) and not (tmp_path.parent / "INJECTED").exists()
    assert sorted(p.name for p in (work / "runs").iterdir()) == ["other"], "a refused input wrote a run folder"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["work"]


def refused(argv, capsys) -> str:
    code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("name", ATTACKS)
def test_name_from_a_case_file(workdir, capsys, name):
    with open("bad.toml", "wb") as f:
        tomli_w.dump(CASE | {"name": name}, f)
    assert "error: name: got " in refused(["run", "bad.toml"], capsys)
    (workdir / "bad.toml").unlink()


@pytest.mark.parametrize("name", ATTACKS)
def test_name_from_the_command_line(workdir, capsys, name):
    assert "error: name: got " in refused(["run", "case.toml", "--name", name], capsys)
    # --set parses the value as TOML: a quoted string carries the control characters as escapes
    value = '"' + name.encode("unicode_escape").decode().replace('"', '\\"') + '"'
    assert "error: name: got " in refused(["run", "case.toml", "--set", f"name={value}"], capsys)


@pytest.mark.parametrize("table", ["grid", "set"])
def test_name_from_a_sweep(workdir, capsys, table):
    values = {"name": ATTACKS[:3] + ["fine"]} if table == "grid" else {"name": ATTACKS[0]}
    with open("sweep.toml", "wb") as f:
        tomli_w.dump({"base": "case.toml", table: values}, f)
    assert f"error: {table}.name: got " in refused(["sweep", "sweep.toml", "-o", "runs/sweep", "--workers", "1",
                                                   "--quiet"], capsys)
    (workdir / "sweep.toml").unlink()


# Commands the deck writer writes; anything else in a deck was put there by its input.
COMMANDS = {
    "units", "dimension", "boundary", "atom_style", "atom_modify", "processors", "newton", "read_data",
    "comm_modify", "delete_bonds", "group", "neigh_modify", "fix", "fix_modify", "variable", "timestep",
    "thermo_style", "thermo_modify", "thermo", "dump", "dump_modify", "run", "write_dump", "bond_style",
    "bond_coeff", "compute", "velocity", "if",
}


def commands(text: str) -> list[str]:
    """The deck's commands as LAMMPS reads them: '&' joins lines, '#' starts a comment
    outside quotes (LAMMPS strips comments before it expands variables)."""
    joined = re.sub(r"&[ \t]*\n", " ", text)
    out = []
    for line in joined.splitlines():
        code = re.sub(r"""("[^"]*"|'[^']*')|#.*""", lambda m: m.group(1) or "", line).strip()
        if code:
            out.append(code)
    return out


@pytest.mark.parametrize("case", [
    make_case(),
    make_case(friction={"mu": 0.285}, run={"engine": "stock"}, output={"format": "text", "fine": [1, 2]}),
    make_case(impactor={"profile": "sine", "velocity": 1.0, "duration": 5.0}, run={"engine": "stock"}),
    make_case(second_neighbour={"law": "power", "K": 20.0, "b": 10.0, "q": 3.0}),
    make_law_case("toda"),
    make_case(chain={"mass_disorder": 0.01, "seed": 3}, output={"format": "none"}),
], ids=["paper", "stock-friction-text", "sine", "second-neighbour", "toda", "disorder"])
def test_deck_holds_only_its_own_commands_and_the_name_only_in_comments(case):
    case = case_from_dict(case_to_dict(case) | {"name": "my-case_1.0"})
    files = deck.render(case)
    for command in commands(files[deck.DECK]):
        assert command.split()[0] in COMMANDS, command
        assert "my-case_1.0" not in command and "shell" not in command
    assert files[deck.DATA].splitlines()[0].startswith("# my-case_1.0:")


def test_deck_checks_the_name_itself():
    """A case changed behind its validation (frozen dataclass forced) still writes no unsafe deck."""
    case = make_case()
    object.__setattr__(case, "name", ATTACKS[0])
    for render in (deck.deck_text, deck.data_text):
        with pytest.raises(ConfigError, match=re.escape("name: got 'x\\nshell touch")):
            render(case)
