"""The documentation builds without a warning, and the tutorial notebook runs as written."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parent.parent


def test_the_docs_build_with_warnings_as_errors(tmp_path):
    """`mkdocs build --strict`: every page, link and API reference entry resolves."""
    mkdocs = Path(sys.executable).parent / "mkdocs"
    # not -q: it drops mkdocs's warnings before --strict counts them (pages outside the nav built)
    done = subprocess.run([str(mkdocs), "build", "--strict", "-d", str(tmp_path / "site")],
                          cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0 and "WARNING" not in done.stderr, done.stderr + done.stdout
    assert (tmp_path / "site" / "api" / "index.html").is_file()
    api = (tmp_path / "site" / "api" / "index.html").read_text()
    assert "RunFolder" in api
    # the measures loaded on first use are documented too (griffe reads their TYPE_CHECKING imports)
    from pylmp_lattice import measures

    lazy = [name for names in measures._LAZY.values() for name in names
            if name in measures.__all__ and not name.isupper()]  # constants have no entry
    missing = [name for name in lazy if f'id="pylmp_lattice.measures.{name}"' not in api]
    assert len(lazy) == 21 and not missing, missing
    # the tutorial is a page with its outputs (it was a raw .ipynb link, stored without them)
    page = (tmp_path / "site" / "tutorial" / "index.html").read_text()
    assert "V_P = 3.87" in page and page.count("data:image/png;base64,") >= 1


def test_the_tutorial_is_stored_with_its_outputs_and_leaves_the_backend_alone():
    """Its figure shows in Jupyter (it forced the Agg backend) and in the docs (stored outputs)."""
    import nbformat

    nb = nbformat.read(ROOT / "docs" / "tutorial.ipynb", as_version=4)
    code = [cell for cell in nb.cells if cell.cell_type == "code"]
    assert not any("matplotlib.use" in cell.source for cell in code)
    assert all(cell.outputs for cell in code)
    assert any("image/png" in out.get("data", {}) for cell in code for out in cell.outputs)


def test_the_architecture_figure_draws_the_layers_the_test_keeps(tmp_path):
    """docs/figures/architecture.svg is drawn by docs/figures/architecture.py from the layers of
    tests/test_architecture.py (text kept as text): the committed file names each layer, in
    order, and the script draws it again."""
    import importlib.util
    import re

    from test_architecture import LAYERS

    spec = importlib.util.spec_from_file_location("architecture", ROOT / "docs" / "figures" / "architecture.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    script.draw(tmp_path / "a.svg")
    for svg in (ROOT / "docs" / "figures" / "architecture.svg", tmp_path / "a.svg"):
        names = re.findall(r"<text style=\"font-weight: 700[^>]*>([^<]*)</text>", svg.read_text())  # the bold ones
        assert names == [name for name, _ in LAYERS], (svg, names)


@pytest.mark.lammps
def test_the_tutorial_notebook_runs(tmp_path, monkeypatch):
    """docs/tutorial.ipynb, executed cell by cell in a fresh kernel from docs/, its temporary
    folder (tempfile.mkdtemp, which a reader keeps to look at) in this test's (TMPDIR): each run
    left 4.4 MB in /tmp, 143 of them on this machine."""
    import nbformat
    from nbclient import NotebookClient

    monkeypatch.setenv("TMPDIR", str(tmp_path))
    nb = nbformat.read(ROOT / "docs" / "tutorial.ipynb", as_version=4)
    NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(ROOT / "docs")}}).execute()
    printed = "".join(out.get("text", "") for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs)
    assert "V_P =" in printed and "done [" in printed  # run.status, then the folder's files
    assert len(list(tmp_path.glob("pylmp_tutorial_*/long"))) == 1
