"""CCSDS OEM reading and writing, 10^5 states (10^4 quick), timed against plain-table I/O.

No maintained MIT/BSD Python package reads and writes the OEM, so the references are the floors
of the same work without the CCSDS grammar (ratio = visviva time / reference time):

* ``read_oem KVN``: ``vv.read_oem(text)`` (lexer, metadata, units, epochs checked, times parsed
  by astropy, increasing-time and span checks) against ``numpy.loadtxt`` of the state lines
  plus ``astropy.time.Time`` of their epochs. Target: ratio <= 3.
* ``write_oem KVN``: ``vv.write_oem(e)`` (shortest round-trip floats) against
  ``numpy.savetxt`` with ``%.17g`` of the same numbers (epochs already text). Target: <= 3.
* ``read_oem XML``: against ``xml.etree.ElementTree.fromstring`` of the same document (the C
  parser alone, no conversion). Target: <= 3.
* ``write_oem XML``: against building the same element tree with ElementTree and serialising
  it. Target: <= 1.5.

* ``read_tdm KVN``: ``vv.read_tdm(text)`` of two-way ranges (lexer, metadata, keywords, numbers
  and epochs checked, times parsed) against splitting the data lines and converting their
  epochs with ``astropy.time.Time`` and their values with numpy. Target: ratio <= 6 (half of
  the time is the KVN lexer shared by every message, which checks each line's form).
* ``write_tdm KVN``: ``vv.write_tdm(tdm)`` against joining ``f"RANGE = {epoch} {value!r}"``
  lines. Target: <= 3.

The notes give the file sizes and states per second. Run: ``python -m benchmarks --only ccsds``.
"""

from __future__ import annotations

import io

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import quick_from_env, result, time_call
except ImportError:  # pragma: no cover
    from common import quick_from_env, result, time_call


def _ephemeris(n: int):
    from astropy import units as u
    from astropy.time import Time

    from visviva.ccsds.oem import Ephemeris, OEMSegment

    rng = np.random.default_rng(502)
    t = Time("2024-01-01T00:00:00", scale="utc") + np.arange(n) * 10.0 * u.s
    r = rng.normal(size=(n, 3)) * 7000.0
    v = rng.normal(size=(n, 3)) * 7.0
    seg = OEMSegment.from_states(t, r, v, object_name="BENCH", object_id="2024-001A")
    return Ephemeris([seg], {"CCSDS_OEM_VERS": "3.0", "CREATION_DATE": "2024-01-01T00:00:00",
                             "ORIGINATOR": "VISVIVA BENCH"})


def _et_write(eph) -> str:
    import xml.etree.ElementTree as ET

    seg = eph.segments[0]
    root = ET.Element("oem")
    data = ET.SubElement(ET.SubElement(ET.SubElement(root, "body"), "segment"), "data")
    rows = np.hstack([seg.r_km, seg.v_km_s]).tolist()
    keys = ("X", "Y", "Z", "X_DOT", "Y_DOT", "Z_DOT")
    for epoch, row in zip(seg.epochs, rows, strict=True):
        sv = ET.SubElement(data, "stateVector")
        ET.SubElement(sv, "EPOCH").text = epoch
        for key, value in zip(keys, row, strict=True):
            ET.SubElement(sv, key, {"units": "km"}).text = repr(value)
    return ET.tostring(root, encoding="unicode")


def run(quick: bool = False) -> list[dict]:
    quick = quick or quick_from_env()
    import xml.etree.ElementTree as ET

    from astropy.time import Time

    import visviva as vv
    n = 10_000 if quick else 100_000
    repeat = 3 if quick else 5
    size = f"{n:.0e}".replace("+0", "")
    eph = _ephemeris(n)
    kvn = vv.write_oem(eph)
    xml = vv.write_oem(eph, format="xml")
    seg = eph.segments[0]
    body = "\n".join(kvn.splitlines()[16:])
    assert body.startswith("2024-01-01T00:00:00"), body[:40]
    table = np.hstack([seg.r_km, seg.v_km_s])

    def ref_read():
        numbers = np.loadtxt(io.StringIO(body), usecols=range(1, 7))
        epochs = np.loadtxt(io.StringIO(body), usecols=0, dtype=str)
        return numbers, Time(list(epochs), format="isot", scale="utc")

    def ref_write():
        out = io.StringIO()
        np.savetxt(out, table, fmt="%.17g")
        return out.getvalue()

    back = vv.read_oem(kvn).segments[0]
    exact = np.array_equal(back.r_km, seg.r_km) and np.array_equal(back.v_km_s, seg.v_km_s)
    rows = []
    for name, ours, ref_name, ref, target, mb in (
        ("read_oem KVN", lambda: vv.read_oem(kvn), "numpy.loadtxt + astropy Time", ref_read,
         3.0, len(kvn)),
        ("write_oem KVN", lambda: vv.write_oem(eph), "numpy.savetxt %.17g", ref_write, 3.0,
         len(kvn)),
        ("read_oem XML", lambda: vv.read_oem(xml), "xml.etree.ElementTree.fromstring (C)",
         lambda: ET.fromstring(xml), 3.0, len(xml)),
        ("write_oem XML", lambda: vv.write_oem(eph, format="xml"),
         "ElementTree build + tostring", lambda: _et_write(eph), 1.5, len(xml)),
    ):
        t_vv = time_call(ours, repeat=repeat, number=1)
        t_ref = time_call(ref, repeat=repeat, number=1)
        rows.append(result(f"{name}, {size} states", t_vv, ref_name, t_ref, target=target,
                           notes=f"{mb / 1e6:.1f} MB; {n / t_vv.median / 1e3:.0f} k states/s; "
                                 f"read back bit for bit: {exact}"))
    rows += _tdm_rows(vv, Time, n, repeat, size)
    return rows


def _tdm_text(n: int) -> tuple[str, list, list]:
    from astropy import units as u
    from astropy.time import Time

    t = Time("2024-01-01T00:00:00", scale="utc") + np.arange(n) * u.s
    epochs = list(t.isot)
    values = (1000.0 + np.random.default_rng(503).normal(size=n)).tolist()
    head = ("CCSDS_TDM_VERS = 2.0\nCREATION_DATE = 2024-01-01T00:00:00\nORIGINATOR = BENCH\n"
            "META_START\nTIME_SYSTEM = UTC\nPARTICIPANT_1 = STATION\nPARTICIPANT_2 = SAT\n"
            "MODE = SEQUENTIAL\nPATH = 1,2,1\nRANGE_UNITS = km\nMETA_STOP\nDATA_START\n")
    body = "\n".join(f"RANGE = {e} {v!r}" for e, v in zip(epochs, values, strict=True))
    return head + body + "\nDATA_STOP\n", epochs, values


def _tdm_rows(vv, Time, n, repeat, size) -> list[dict]:
    text, epochs, values = _tdm_text(n)
    tdm = vv.read_tdm(text)
    exact = tdm.segments[0].values.tolist() == values

    def ref_read():
        parts = [line.split() for line in text.splitlines()[12:-1]]
        return (Time([p[2] for p in parts], format="isot", scale="utc"),
                np.array([p[3] for p in parts], dtype=float))

    def ref_write():
        return "\n".join(f"RANGE = {e} {v!r}" for e, v in zip(epochs, values, strict=True))

    rows = []
    for name, ours, ref_name, ref, target in (
        ("read_tdm KVN", lambda: vv.read_tdm(text), "str.split + astropy Time + numpy",
         ref_read, 6.0),
        ("write_tdm KVN", lambda: vv.write_tdm(tdm), "f-string lines joined", ref_write, 3.0),
    ):
        t_vv = time_call(ours, repeat=repeat, number=1)
        t_ref = time_call(ref, repeat=repeat, number=1)
        rows.append(result(f"{name}, {size} ranges", t_vv, ref_name, t_ref, target=target,
                           notes=f"{len(text) / 1e6:.1f} MB; {n / t_vv.median / 1e3:.0f} k lines/s; "
                                 f"read back bit for bit: {exact}"))
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run():
        print(row)
