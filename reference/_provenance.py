"""Provenance headers for the reference data written by the ``generate_*.py`` scripts.

Every file in ``reference/data/`` is JSON with two top-level keys: ``provenance`` (what made it:
the generating script, the library versions, the settings, the date) and ``cases`` (the data).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import platform
from importlib import metadata
from pathlib import Path

HERE = Path(__file__).resolve().parent
DATA = HERE / "data"
REPO = HERE.parent

#: keys every provenance header must have (checked by tests/test_validation_data.py)
REQUIRED = ("generator", "generated_utc", "libraries", "settings", "description", "units")


def versions(*names: str) -> dict[str, str]:
    """Installed versions of ``names`` plus Python and numpy."""
    out = {"python": platform.python_version()}
    for name in ("numpy", *names):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def header(script: str, libraries: tuple[str, ...], settings: dict, description: str,
           units: dict) -> dict:
    """The provenance header of one data file."""
    return {
        "generator": f"reference/{Path(script).name}",
        "command": f"python reference/{Path(script).name}",
        "generated_utc": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "libraries": versions(*libraries),
        "settings": settings,
        "description": description,
        "units": units,
    }


def document(script: str, libraries: tuple[str, ...], settings: dict, description: str,
             units: dict, cases: list) -> dict:
    """One data file's content: ``{"provenance": header(...), "cases": cases}``."""
    return {"provenance": header(script, libraries, settings, description, units),
            "cases": cases}


def main(name: str, generate) -> None:
    """Command-line entry of a generator: write ``reference/data/<name>`` from ``generate()``."""
    path = write(name, generate())
    print(f"wrote {path}")


def _clean(value):
    if hasattr(value, "tolist") and not isinstance(value, list | tuple | dict):
        value = value.tolist()  # numpy scalars and arrays to Python floats and lists
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


def write(name: str, payload: dict) -> Path:
    """Write ``reference/data/<name>`` (full float precision, strict JSON)."""
    DATA.mkdir(parents=True, exist_ok=True)
    path = DATA / name
    path.write_text(json.dumps(_clean(payload), indent=1, allow_nan=False) + "\n",
                    encoding="utf-8")
    return path


def read(name: str) -> dict:
    """Read ``reference/data/<name>``."""
    return json.loads((DATA / name).read_text(encoding="utf-8"))
