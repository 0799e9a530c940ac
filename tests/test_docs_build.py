"""The documentation site: every page joins the toctree, the API page covers the public surface,
and (slow) the whole Sphinx build passes with warnings as errors (also ``make docs``)."""

from __future__ import annotations

import importlib.util
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import visviva

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"


def _conf():
    spec = importlib.util.spec_from_file_location("_vv_docs_conf", DOCS / "conf.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_index_uses_a_glob_toctree():
    text = (DOCS / "index.md").read_text()
    assert re.search(r"```\{toctree\}[^`]*:glob:[^`]*\n\*\n```", text), "index.md: glob toctree"


@pytest.mark.parametrize("page", sorted(p.name for p in DOCS.glob("*.md")))
def test_every_page_has_a_title(page):
    """A page without a top-level heading breaks the toctree (a Sphinx warning, so the build)."""
    lines = (DOCS / page).read_text(encoding="utf-8").splitlines()
    first = next((ln for ln in lines if ln.strip() and not ln.startswith(("(", "%", "---"))), "")
    assert first.startswith("# "), f"docs/{page} must start with a '# Title' line, got {first!r}"


def test_api_page_covers_every_public_name():
    conf = _conf()
    text = "\n".join(conf._api_markdown())
    for name in visviva._PUBLIC:
        assert f"visviva.{name}" in text, name


def test_validation_page_includes_a_committed_report():
    assert "{include} validation_report/report.md" in (DOCS / "validation.md").read_text()
    assert (DOCS / "validation_report" / "report.md").is_file()


@pytest.mark.slow
def test_sphinx_build_has_no_warnings(tmp_path):
    if shutil.which("sphinx-build") is None and importlib.util.find_spec("sphinx") is None:
        pytest.skip("sphinx is not installed (dev extra)")
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(DOCS),
         str(tmp_path / "html")], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert (tmp_path / "html" / "api.html").is_file()
