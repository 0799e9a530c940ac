"""Sphinx configuration of the visviva documentation (Markdown pages via MyST).

Build: ``make docs`` (``sphinx-build -W --keep-going -b html docs docs/_build/html``). Warnings
fail the build, with the deliberate exceptions listed in ``suppress_warnings`` below, and
docstring markup problems of the API page, which are reported (not fatal) unless
``VISVIVA_DOCS_STRICT=1``: capability engineers add modules and pages continuously, and a stray
asterisk in a docstring should not stop the whole documentation.

Every ``*.md`` page in this folder joins the site automatically (a glob toctree in index.md).
"""

from __future__ import annotations

import importlib
import inspect
import logging
import os
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "src"))

import visviva  # noqa: E402

project = "visviva"
author = "visviva developers"
copyright = "2026, visviva developers"
release = visviva.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "validation_report/**", "README.md"]

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
myst_dmath_double_inline = True

# numpydoc-style docstrings (Parameters / Returns / Notes / References)
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_use_param = False  # types such as "ndarray, shape (..., 3)" stay text, not xrefs
napoleon_use_keyword = False
napoleon_use_ivar = True  # "Attributes" sections do not duplicate the documented members
autodoc_typehints = "none"  # types live in the numpydoc sections (with units)
autodoc_member_order = "bysource"
autodoc_default_options = {"members": True, "show-inheritance": False}

suppress_warnings = [
    # pages written by different people may skip a heading level (# then ###)
    "myst.header",
    # a doctest output block that pygments cannot lex is still shown verbatim
    "misc.highlighting_failure",
    # links to files outside docs/ (../examples/x.py, ../README.md) are fine on GitHub
    "myst.xref_missing",
    # "more than one target found": type words such as "shape" in numpydoc Attributes sections
    "ref.python",
]
# Also not fatal (dropped by _DocstringWarnings below, since Sphinx gives them no type): index.md
# orders the pages with one-name glob patterns, and pages not written yet match nothing.

html_theme = "alabaster"
html_title = f"visviva {release}"
html_static_path: list[str] = []
html_theme_options = {"description": "Orbital mechanics you can trust", "fixed_sidebar": True}

# --------------------------------------------------------------------------------------------
# The public API page: ``{visviva-public-api}`` expands to autodoc directives for every public
# name that imports today (names still in progress are listed, not documented).


def _public_objects():
    """(qualified name, object, kind) for the top-level surface, grouped in _PUBLIC order."""
    out, missing = [], []
    for name, module in visviva._PUBLIC.items():
        try:
            obj = getattr(visviva, name)
        except Exception as exc:  # noqa: BLE001 - a capability in progress
            missing.append((name, module, f"{type(exc).__name__}: {exc}"))
            continue
        out.append((f"visviva.{name}", obj, module))
    return out, missing


def _kind(obj) -> str:
    if inspect.isclass(obj):
        return "autoexception" if issubclass(obj, BaseException) else "autoclass"
    if callable(obj):
        return "autofunction"
    return "data"


def _module_extras(modules: list[str], documented: set[int]):
    """Names in each module's ``__all__`` that the top level does not export."""
    out = []
    for modname in modules:
        try:
            mod = importlib.import_module(modname)
        except Exception:  # noqa: BLE001
            continue
        names = [n for n in getattr(mod, "__all__", []) if not n.startswith("_")]
        items = []
        for n in names:
            try:
                obj = getattr(mod, n)
            except Exception:  # noqa: BLE001
                continue
            if id(obj) in documented or inspect.ismodule(obj):
                continue
            if not (inspect.isclass(obj) or callable(obj)):
                continue
            items.append((f"{modname}.{n}", obj))
        if items:
            out.append((modname, items))
    return out


EXTRA_MODULES = [
    "visviva.central_force",
    "visviva.anomalies",
    "visviva.elements",
    "visviva.states",
    "visviva.nbody",
    "visviva.satellites",
    "visviva.mechanics",
    "visviva.validation",
]


def _rst_block(rst_lines: list[str]) -> list[str]:
    """An ``eval-rst`` block: autodoc output is reStructuredText, the page is Markdown."""
    return ["```{eval-rst}", *rst_lines, "```", ""]


def _inherited_option(obj) -> list[str]:
    """Document the members a class takes from a shared visviva base (``_containers``)."""
    bases = getattr(obj, "__mro__", ())[1:]
    if any(getattr(b, "__module__", "").startswith("visviva._") for b in bases):
        return ["   :inherited-members: object"]
    return []


def _api_markdown() -> list[str]:
    objs, missing = _public_objects()
    lines = ["## The top-level surface", ""]
    documented: set[int] = set()
    rst: list[str] = []
    for qualname, obj, _module in objs:
        kind = _kind(obj)
        if kind == "data":
            text = repr(obj).replace("\n", " ").replace("`", "'")
            rst += [f".. py:data:: {qualname}", "", f"   ``{text[:150]}``", ""]
            continue
        documented.add(id(obj))
        rst += [f".. {kind}:: {qualname}", *_inherited_option(obj), ""]
    lines += _rst_block(rst)
    for modname, items in _module_extras(EXTRA_MODULES, documented):
        lines += [f"## More in `{modname}`", ""]
        rst = []
        for qualname, obj in items:
            documented.add(id(obj))
            rst += [f".. {_kind(obj)}:: {qualname}", ""]
        lines += _rst_block(rst)
    if missing:
        lines += ["## Not available in this build", "",
                  "These public names are declared but their module does not provide them yet:",
                  ""]
        lines += [f"- `visviva.{name}` (`{module}`)" for name, module, _ in missing]
        lines.append("")
    return lines


def _setup_api_directive(app):
    from docutils import nodes
    from docutils.statemachine import StringList
    from sphinx.util.docutils import SphinxDirective
    from sphinx.util.nodes import nested_parse_with_titles

    class PublicAPI(SphinxDirective):
        """Expands to autodoc directives for every public name that imports today."""

        has_content = False

        def run(self):
            container = nodes.section()
            source = self.get_source_info()[0]
            content = StringList()
            for i, line in enumerate(_api_markdown()):
                content.append(line, source, i)
            nested_parse_with_titles(self.state, content, container)
            return container.children

    app.add_directive("visviva-public-api", PublicAPI)


# --------------------------------------------------------------------------------------------
# Docstring markup problems: reported, not fatal (unless VISVIVA_DOCS_STRICT=1).


class _DocstringWarnings(logging.Filter):
    """Turn warnings located in docstrings into info messages and remember them."""

    def __init__(self):
        super().__init__()
        self.seen: list[str] = []

    def filter(self, record: logging.LogRecord) -> bool:
        if getattr(record, "subtype", None) == "empty_glob":
            return False
        location = str(getattr(record, "location", "") or "")
        if record.levelno >= logging.WARNING and "docstring of" in location:
            try:
                message = record.getMessage()
            except Exception:  # noqa: BLE001
                message = str(record.msg)
            self.seen.append(f"{location}: {message}")
            return False
        return True


def _setup_docstring_filter(app):
    from sphinx.util.logging import WarningStreamHandler

    flt = _DocstringWarnings()
    if os.environ.get("VISVIVA_DOCS_STRICT") == "1":
        flt.filter = lambda record: getattr(record, "subtype", None) != "empty_glob"
    for handler in logging.getLogger("sphinx").handlers:
        if isinstance(handler, WarningStreamHandler):
            handler.filters.insert(0, flt)

    def report(app, exception):
        if flt.seen:
            out = Path(app.outdir) / "docstring-warnings.txt"
            out.write_text("\n".join(flt.seen) + "\n", encoding="utf-8")
            print(f"docs: {len(flt.seen)} docstring markup problem(s), not fatal; see {out}",
                  file=sys.stderr)

    app.connect("build-finished", report)


# --------------------------------------------------------------------------------------------
# Docstrings write norms as |r| and |v2 - v1|: in reStructuredText that is a substitution
# reference (an error). Escape such bars outside code, math and tables so they print as written.

_SPANS = re.compile(r"(``.+?``|:[a-z:]+:`[^`]*`|`[^`]*`)")


def _escape_bars(line: str) -> str:
    stripped = line.strip()
    if "|" not in line or stripped.startswith((">>>", "...", "+-", "+=")):
        return line
    if stripped.startswith("|") and stripped.endswith("|") and " | " in stripped:
        return line  # a grid-table row
    parts = _SPANS.split(line)
    for i in range(0, len(parts), 2):  # even parts are outside backtick spans
        parts[i] = re.sub(r"(?<!\\)\|", r"\\|", parts[i])
    return "".join(parts)


def _escape_docstring_bars(app, what, name, obj, options, lines):
    literal_indent = None
    for i, line in enumerate(lines):
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None:
            if line.strip() and indent <= literal_indent:
                literal_indent = None
            else:
                continue
        if line.rstrip().endswith("::") or line.strip().startswith(".. math::"):
            literal_indent = indent
            lines[i] = _escape_bars(line)
            continue
        lines[i] = _escape_bars(line)


def setup(app):
    _setup_api_directive(app)
    _setup_docstring_filter(app)
    app.connect("autodoc-process-docstring", _escape_docstring_bars, priority=600)
    return {"parallel_read_safe": True}
