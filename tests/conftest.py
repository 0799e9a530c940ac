"""Fixtures shared by the tests, and the hypothesis profile (derandomized) every test runs under."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from hypothesis import settings

# Property tests draw the same examples on every run (CI included): a failure found once is
# found again, never by chance on a later landing. A test's own @settings add to this profile.
settings.register_profile("visviva", derandomize=True)
settings.load_profile("visviva")

#: Prepended to a fresh-process script: records the names of the kernels numba compiles in
#: ``compiled`` (a list).
COMPILE_LISTENER = """
from numba.core import event
compiled = []
class _Listener(event.Listener):
    def on_start(self, ev): compiled.append(ev.data["dispatcher"].py_func.__name__)
    def on_end(self, ev): pass
event.register("numba:compile", _Listener())
"""


@pytest.fixture
def force_tier(monkeypatch):
    """``force_tier("interpreted")`` or ``force_tier("compiled")``: the tier every small call
    of the test takes (``budget``: the interpreter's CPU budget, seconds). "interpreted" is as
    on a fresh install: no machine code in memory or in numba's cache."""
    from visviva.core import _jit
    from visviva.core import tier as core_tier
    from visviva.nbody import tier as nbody_tier

    def choose(mode, budget=1e9):
        monkeypatch.setattr(core_tier, "spent", {"cpu_s": 0.0, "off": mode == "compiled"})
        monkeypatch.setattr(core_tier, "BUDGET_S", budget)
        monkeypatch.setattr(nbody_tier, "_per_step", {"s": None})
        monkeypatch.setattr(_jit._Kernel, "load_cached", lambda self, sig: False)
        monkeypatch.setattr(core_tier, "in_memory", lambda kernel: False)
    return choose


@pytest.fixture
def cold_and_warm(tmp_path):
    """``cold_and_warm(script, *args)``: the last stdout line of ``script`` (run after
    :data:`COMPILE_LISTENER`) split on spaces, in a fresh process with an EMPTY numba cache
    (the interpreter tier on), and in one with the test session's own cache and the tier off
    (``VISVIVA_INTERPRET=0``: the machine code, loaded or compiled)."""
    def run(script, *args):
        out = []
        for env in (dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path)),
                    dict(os.environ, VISVIVA_INTERPRET="0")):
            proc = subprocess.run([sys.executable, "-c", COMPILE_LISTENER + script, *args],
                                  capture_output=True, text=True, env=env, timeout=900,
                                  check=True)
            out.append(proc.stdout.strip().splitlines()[-1].split(" "))
        return out
    return run


@pytest.fixture(scope="session")
def visible_times():
    """``f(truth, station, span_s=86400, step_s=20, min_elevation_deg=5)``: the times (every
    ``step_s`` over ``span_s`` from the truth's epoch) when ``station`` sees ``truth`` (two-body)
    above ``min_elevation_deg`` (geometric); at least 40 of them."""
    import numpy as np
    from astropy import units as u

    from visviva.od import simulate_observations

    def visible(truth, station, span_s=86400.0, step_s=20.0, min_elevation_deg=5.0):
        t = truth.epoch + np.arange(0, span_s, step_s) * u.s
        look = simulate_observations(truth, t, "azel", 1e-9, station, seed=False,
                                     light_time=False)
        idx = np.flatnonzero(look.values[:, 1] > np.radians(min_elevation_deg))
        assert idx.size > 40
        return t[idx]

    return visible


@pytest.fixture(scope="session")
def skyfield_ts():
    """A Skyfield timescale with the polar motion of astropy's offline IERS-A file (the one
    the validation checks use)."""
    pytest.importorskip("skyfield")
    from visviva.validation._skyfield import timescale

    return timescale()


@pytest.fixture
def write_catalog_files(tmp_path):
    """A function writing the element sets of satellites as every file kind that
    ``visviva.read_catalog_file`` reads, with the library's own writers; returns {kind: path}.

    Kinds: ``tle`` (three lines), ``json`` (a list of CelesTrak GP records), ``csv``
    (CelesTrak's GP CSV), ``ndm`` (CelesTrak's GP XML: one ``<ndm>`` of ``<omm>``), and for one
    satellite ``kvn`` / ``xml`` (a CCSDS OMM as ``vv.write_omm`` writes it). The files have no
    telling suffix, so the reader must go by content.
    """
    import csv
    import json

    import visviva as vv

    def write(satellites, stem="cat"):
        records = []
        for s in satellites:
            rec = s.to_omm()
            rec["OBJECT_ID"] = rec["OBJECT_ID"] or "UNKNOWN"
            records.append(rec)
        paths = {kind: tmp_path / f"{stem}_{kind}.dat" for kind in ("tle", "json", "csv", "ndm")}
        paths["tle"].write_text("".join(f"{s.name}\n{s.to_tle()[0]}\n{s.to_tle()[1]}\n"
                                        for s in satellites))
        paths["json"].write_text(json.dumps(records, indent=1))
        with open(paths["csv"], "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(records[0]))
            writer.writeheader()
            writer.writerows(records)
        omms = [vv.write_omm(rec, format="xml", originator="TEST").split("?>", 1)[1]
                for rec in records]
        paths["ndm"].write_text('<?xml version="1.0" encoding="UTF-8"?>\n<ndm>'
                                + "".join(omms) + "</ndm>\n")
        if len(records) == 1:
            for kind in ("kvn", "xml"):
                paths[kind] = tmp_path / f"{stem}_{kind}.dat"
                paths[kind].write_text(vv.write_omm(records[0], format=kind, originator="TEST"))
        return paths

    return write


class _FullDisk:
    """A file handle that writes half of what it is given, then fails as a full disk does."""

    def __init__(self, handle):
        self._handle = handle

    def write(self, data):
        self._handle.write(data[: len(data) // 2])
        self._handle.flush()
        import errno

        raise OSError(errno.ENOSPC, "No space left on device (simulated)")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._handle.close()

    def __getattr__(self, name):
        return getattr(self._handle, name)


@pytest.fixture
def full_disk(monkeypatch):
    """``full_disk()``: from then on every file opened for writing (``open``,
    ``Path.write_text``, ``os.fdopen``: the builtin and ``io.open``) takes half of its first
    write and then raises ``OSError(ENOSPC)``, as a disk that fills up mid-write does."""
    import builtins
    import io

    real_open = io.open

    def failing_open(file, mode="r", *args, **kwargs):
        handle = real_open(file, mode, *args, **kwargs)
        return _FullDisk(handle) if any(c in mode for c in "wax+") else handle

    def start():
        monkeypatch.setattr(io, "open", failing_open)
        monkeypatch.setattr(builtins, "open", failing_open)

    return start
