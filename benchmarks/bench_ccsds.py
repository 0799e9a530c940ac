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

The notes give the file sizes and states per second. Run: ``python -m benchmarks --only ccsds``.
"""

from __future__ import annotations

import io

import numpy as np

try:  # as part of the package (python -m benchmarks) or as a script
    from .common import quick_from_env, result, skipped, time_call
except ImportError:  # pragma: no cover
    from common import quick_from_env, result, skipped, time_call


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
    try:
        import xml.etree.ElementTree as ET

        from astropy.time import Time

        import visviva as vv
    except Exception as exc:  # pragma: no cover
        return [skipped("read_oem", f"visviva not importable: {exc}")]
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
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run():
        print(row)
