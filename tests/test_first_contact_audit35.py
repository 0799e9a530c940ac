"""First-contact audit 35: what a Skyfield/Orekit/STK user meets in the first five minutes.

Each test fails on the code before its fix (named in the test's comment)."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

import visviva as vv

SRC = Path(vv.__file__).parent


def _resolves(dotted: str) -> bool:
    """True when ``vv.a.b`` (``dotted`` without the ``vv``) names an attribute or module."""
    obj = vv
    parts = dotted.split(".")
    for i, part in enumerate(parts):
        if hasattr(obj, part):
            obj = getattr(obj, part)
            continue
        try:
            obj = importlib.import_module("visviva." + ".".join(parts[: i + 1]))
        except ImportError:
            return False
    return True


def test_every_vv_name_in_messages_and_docstrings_exists():
    # was: the TLE checksum error advised 'vv.parse_tle_text ... with verify_checksum=False',
    # which is not importable from visviva (AttributeError for whoever followed the advice)
    missing = []
    for path in SRC.rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        for m in re.finditer(r"(?<![\w.])vv((?:\.[A-Za-z_]\w*)+)", text):
            dotted = m.group(1)[1:]
            if dotted.split(".")[0] in {"copy"}:  # a local array named vv (conjunctions)
                continue
            if not _resolves(dotted):
                line = text[: m.start()].count("\n") + 1
                missing.append(f"{path.relative_to(SRC)}:{line}: vv.{dotted}")
    assert not missing, missing


def test_checksum_error_names_a_reader_that_exists():
    line1 = "1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9000"
    line2 = "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350 12340"
    with pytest.raises(vv.TLEFormatError, match="checksum") as info:
        vv.Satellite.from_tle(line1, line2)
    named = re.findall(r"visviva\.satellites\.catalog\.(\w+)", str(info.value))
    assert named == ["parse_tle_text"]
    from visviva.satellites import catalog

    sat = getattr(catalog, named[0])(line1 + "\n" + line2, verify_checksum=False).satellites[0]
    assert sat.satnum == 25544
