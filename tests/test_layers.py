"""House rules the linters do not check: foreign private accesses and module sizes (issue 12).

Run as a script (``python tests/test_layers.py``) to list every foreign private access.

**Foreign private access.** ``x._name`` (read, write or call) where ``x`` is not ``self``,
``cls``, ``type(...)`` or an imported module, and no class of the same module defines
``_name`` (a method, a class attribute, a ``__slots__`` entry or a ``self._name = ...``
assignment): one module reaching into another object's private state. The few accesses
the design allows are the *documented friends*, a table in docs/design.md ("Documented
friends") that this test parses: an access is a friend when its attribute and module match
a row. The test fails when the number of the others rises above ``CEILING``.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "visviva"
DESIGN = ROOT / "docs" / "design.md"

# Issue 12 started at 86 (the crude count). Lower it when an access is removed, never raise it.
# Down to 0 at the end of issue 12 (session 2): keep it there.
CEILING = 0
# ``from module import _name`` across modules (a module's private helper used elsewhere):
# measured at the end of issue 12's second session; lower it as helpers become public.
PRIVATE_IMPORT_CEILING = 0
MAX_LINES = 700


def _imported_modules(tree: ast.Module, path: Path) -> set[str]:
    """Names bound to modules by the imports of one file.

    ``import a.b as c`` binds a module; ``from visviva.x import y`` binds one when
    ``visviva/x/y.py`` or ``visviva/x/y/`` exists; ``from pkg import name`` of another
    package binds a module unless ``name`` is capitalised (a class, by PEP 8).
    """
    names = set()
    inside = path.is_relative_to(SRC.parent)
    package = path.relative_to(SRC.parent).with_suffix("").parts[:-1] if inside else ()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                names.add(alias.asname or alias.name.split(".")[0])
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(package[: len(package) - node.level + 1])
                base += (node.module or "").split(".") if node.module else []
            else:
                base = (node.module or "").split(".")
            for alias in node.names:
                if base and base[0] == "visviva":
                    target = SRC.parent.joinpath(*base, alias.name)
                    is_module = target.is_dir() or target.with_suffix(".py").exists()
                else:
                    is_module = not alias.name[:1].isupper()
                if is_module:
                    names.add(alias.asname or alias.name)
    return names


def _own_attributes(tree: ast.Module) -> set[str]:
    """Private attribute names that the classes of one module define."""
    own = set()
    for cls in (n for n in ast.walk(tree) if isinstance(n, ast.ClassDef)):
        for node in ast.walk(cls):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                own.add(node.name)
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                for target in targets:
                    if isinstance(target, ast.Name):
                        own.add(target.id)
                        if target.id == "__slots__" and node.value is not None:
                            own.update(c.value for c in ast.walk(node.value)
                                       if isinstance(c, ast.Constant)
                                       and isinstance(c.value, str))
                    elif (isinstance(target, ast.Attribute)
                          and isinstance(target.value, ast.Name)
                          and target.value.id in ("self", "cls", "obj")):
                        own.add(target.attr)
    return {name for name in own if name.startswith("_")}


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_accesses(root: Path = SRC) -> list[tuple[str, int, str]]:
    """Every foreign private access under ``root``: (path relative to src/, line, source)."""
    hits = []
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        modules = _imported_modules(tree, path)
        own = _own_attributes(tree)
        rel = path.relative_to(root.parent).as_posix()
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Attribute) and _is_private(node.attr)):
                continue
            if node.attr in own:
                continue
            value = node.value
            if isinstance(value, ast.Name) and value.id in {"self", "cls"} | modules:
                continue
            if (isinstance(value, ast.Call) and isinstance(value.func, ast.Name)
                    and value.func.id in ("type", "super")):
                continue
            hits.append((rel, node.lineno, ast.unparse(node)))
    return hits


def private_imports(root: Path = SRC) -> list[tuple[str, int, str]]:
    """``from visviva.m import _name`` in another module: (path, line, "m._name").

    Private *modules* (``_units``, ``_containers``, ``central_force._inputs``, ``core._jit``) are
    the package's shared toolboxes: importing them or their names is not counted. The private
    names of any other module are.
    """
    hits = []
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        modules = _imported_modules(tree, path)
        rel = path.relative_to(root.parent).as_posix()
        for node in ast.walk(tree):
            if not isinstance(node, ast.ImportFrom):
                continue
            internal = node.level > 0 or (node.module or "").split(".")[0] == "visviva"
            if node.module and node.module.split(".")[-1].startswith("_"):
                continue  # a private module (_units, _containers, core._jit) is the toolbox
            for alias in node.names:
                if (internal and _is_private(alias.name)
                        and (alias.asname or alias.name) not in modules):
                    hits.append((rel, node.lineno, f"{node.module or '.'}.{alias.name}"))
    return hits


def documented_friends(design: Path = DESIGN) -> list[tuple[str, list[str]]]:
    """The rows of the "Documented friends" table: (attribute, module globs or ["*"])."""
    text = design.read_text()
    match = re.search(r"^#+ Documented friends\n(.*?)(?=^#)", text, re.M | re.S)
    assert match, "docs/design.md has no 'Documented friends' section"
    rows = []
    for line in match.group(1).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 4 or not cells[0].startswith("`"):
            continue
        attribute = cells[0].strip("`")
        where = re.findall(r"`([^`]+)`", cells[2]) or ["*"]
        rows.append((attribute, where))
    return rows


def _is_friend(hit, friends) -> bool:
    path, _, source = hit
    attribute = source.rsplit(".", 1)[-1]
    for name, where in friends:
        if name == attribute and any(w == "*" or path.endswith(w) for w in where):
            return True
    return False


def foreign_accesses() -> list[tuple[str, int, str]]:
    friends = documented_friends()
    return [hit for hit in private_accesses() if not _is_friend(hit, friends)]


def test_foreign_private_accesses_stay_below_the_ceiling():
    hits = foreign_accesses()
    listing = "\n".join(f"  {path}:{line}: {source}" for path, line, source in hits)
    assert len(hits) <= CEILING, (
        f"{len(hits)} foreign private accesses (ceiling {CEILING}):\n{listing}\n"
        "Use a public method, or document a friend in docs/design.md ('Documented friends')."
    )


def test_private_imports_across_modules_stay_below_the_ceiling():
    hits = private_imports()
    listing = "\n".join(f"  {path}:{line}: {name}" for path, line, name in hits)
    assert len(hits) <= PRIVATE_IMPORT_CEILING, (
        f"{len(hits)} imports of other modules' private names (ceiling "
        f"{PRIVATE_IMPORT_CEILING}):\n{listing}\nMake the helper public (in its module's "
        "__all__) or move it where both users can own it."
    )


def test_every_documented_friend_is_used():
    """A friend row that matches no access is stale: the table must shrink with the code."""
    hits = private_accesses()
    for attribute, where in documented_friends():
        used = [h for h in hits if _is_friend(h, [(attribute, where)])]
        assert used, f"documented friend {attribute} ({where}) is no longer used; remove its row"


def test_the_checker_sees_what_it_should(tmp_path):
    """Same-module classes are trusted, other objects' privates and imported classes are not."""
    (tmp_path / "probe").mkdir()
    (tmp_path / "probe" / "probe.py").write_text(
        "from visviva.states import StateVectors\n"
        "from visviva import _units\n"
        "class A:\n"
        "    __slots__ = ('_x',)\n"
        "    def __eq__(self, other):\n"
        "        return self._x == other._x\n"
        "def f(a, client):\n"
        "    _units.to_km(a)\n"
        "    StateVectors._from_canonical(a)\n"
        "    return client._secret\n"
    )
    found = [source for _, _, source in private_accesses(tmp_path / "probe")]
    assert sorted(found) == ["StateVectors._from_canonical", "client._secret"]


def test_every_module_is_under_700_lines():
    long = {p.relative_to(SRC.parent).as_posix(): n for p in SRC.rglob("*.py")
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines (split them by concept): {long}"


if __name__ == "__main__":
    found = foreign_accesses()
    for path, line, source in found:
        print(f"{path}:{line}: {source}")
    print(f"{len(found)} foreign private accesses (ceiling {CEILING})", file=sys.stderr)
    imports = private_imports()
    for path, line, name in imports:
        print(f"{path}:{line}: import {name}")
    print(f"{len(imports)} private imports across modules (ceiling {PRIVATE_IMPORT_CEILING})",
          file=sys.stderr)
