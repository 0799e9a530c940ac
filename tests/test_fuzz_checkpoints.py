"""Fuzzing the readers of visviva's own files and of gravity fields: a damaged, edited or
foreign checkpoint (Simulation.load, Ensemble.load, Archive) or ICGEM ``.gfc`` file raises an
InvalidInputError naming the file (and the line, for text), never a bare exception, NaN state,
or arrays whose sizes disagree (the compiled kernels would write past them).

The readers of CCSDS messages, TLEs, OMM catalogues and the command line are fuzzed in
``test_fuzz_readers.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

import visviva as vv

# ---- checkpoints: Simulation.load, Ensemble.load, Archive -----------------------------------

@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    d = tmp_path_factory.mktemp("ckpt")
    sim = vv.Simulation("ias15")
    sim.add(m=1.0)
    sim.add(m=1e-3, a=1.0, e=0.1)
    sim.add(m=1e-5, a=2.0)
    sim.integrate(3.0)
    sim.save(d / "sim.npz")
    vv.Ensemble([sim, sim.copy()]).save(d / "ens.npz")
    with np.load(d / "sim.npz") as z:
        sim_arrays = {k: z[k] for k in z.files}
    with np.load(d / "ens.npz") as z:
        ens_arrays = {k: z[k] for k in z.files}
    return d, sim, sim_arrays, ens_arrays


def _edited(arrays, key, value):
    out = dict(arrays)
    if value is None:
        del out[key]
    else:
        out[key] = value
    return out


@pytest.mark.parametrize("key, value, match", [
    ("x", lambda a: a.copy().reshape(-1), "'x' is float64 of shape"),   # was: kernels wrote
    ("m", lambda a: a[:2].copy(), "'m' is float64 of shape"),           # past the arrays (heap
    ("buf", lambda a: a[:, :2].copy(), "'buf' is float64 of shape"),    # corruption, abort)
    ("v", lambda a: np.where(np.arange(9).reshape(3, 3) == 4, np.nan, a), "NaN or infinite"),
    ("x", lambda a: a.astype(np.float32), "'x' is float32"),
    ("istate", lambda a: np.where(np.arange(32) == 9, 99, a), "impossible values"),
    ("m", lambda a: -a, "negative"),
    ("meta", lambda a: np.array("{"), "not a JSON object"),           # was: JSONDecodeError
    ("meta", lambda a: np.array(str(a).replace('"collision"', '"x"')), "'collision' is missing"),
    ("istate", None, "'istate' is missing"),
    ("format_version", lambda a: np.array("1"), "without a valid format_version"),  # ValueError
])
def test_simulation_file_with_inconsistent_content_is_refused(saved, tmp_path, key, value, match):
    _, _, arrays, _ = saved
    path = tmp_path / "bad.npz"
    np.savez(path, **_edited(arrays, key, value if value is None else value(arrays[key])))
    with pytest.raises(vv.InvalidInputError, match=match) as exc:
        vv.Simulation.load(path)
    assert "bad.npz" in str(exc.value)


def test_simulation_file_with_damaged_bytes_is_refused(saved, tmp_path):
    # was: zipfile.BadZipFile ('Bad CRC-32') raised at first use, after the format check
    d, sim, _, _ = saved
    data = bytearray((d / "sim.npz").read_bytes())
    start = data.index(b"<f8")  # inside the first array's header
    data[start + 40] ^= 0x55
    (tmp_path / "bad.npz").write_bytes(bytes(data))
    with pytest.raises(vv.InvalidInputError, match="bad.npz"):
        vv.Simulation.load(tmp_path / "bad.npz")
    # the untouched file still continues bit for bit
    back = vv.Simulation.load(d / "sim.npz")
    np.testing.assert_array_equal(back.state_arrays()["x"], sim.state_arrays()["x"])


@pytest.mark.parametrize("key, value, match", [
    ("poff", lambda a: a[::-1].copy(), "not a consistent"),            # was: IndexError
    ("meta_index", lambda a: a + 5, "not a consistent"),               # was: IndexError
    ("count", lambda a: np.array("garbage"), "member count"),          # was: ValueError
    ("backend", lambda a: np.array("{"), "'backend' is missing or not JSON"),  # JSONDecodeError
    ("buf", lambda a: np.concatenate([a, a[:3]]), "not a consistent"),  # was: reshape error
    ("fstate", lambda a: a[:1].copy(), "not a consistent"),
])
def test_ensemble_file_with_inconsistent_content_is_refused(saved, tmp_path, key, value, match):
    _, _, _, arrays = saved
    path = tmp_path / "bad.npz"
    np.savez(path, **_edited(arrays, key, value(arrays[key])))
    with pytest.raises(vv.InvalidInputError, match=match):
        vv.Ensemble.load(path)


# ---- ICGEM gravity fields (SphericalHarmonics) --------------------------------------------------

@pytest.mark.parametrize("old, new, match", [
    ("gfc 2 2 ", "gfc 2 5 ", "0 <= m <= n"),                # was: ValueError (lgamma domain)
    ("gfc 2 2 ", "gfc 2 -1 ", "0 <= m <= n"),               # was: read into column -1 silently
    ("gfc 3 1 2.030462010478640e-06", "gfc 3 1 nan", "C is not finite"),  # was: NaN read
    ("gfc 3 1 2.0", "gfc 3 1 x", "C is not a number"),
    ("radius 6378136.3", "radius 63781x36.3", "radius is not a number"),  # was: ValueError
    ("radius 6378136.3", "radius -1", "radius must be positive"),
    ("earth_gravity_constant 3.986004415E+14", "earth_gravity_constant 0", "must be positive"),
    # audit21: a time-variable field (ICGEM 2.0) gives C20 on a 'gfct' line, which was skipped:
    # a field without J2, silently; an unknown data key and a repeated (n, m) were read too
    ("gfc 2 0 ", "gfct 2 0 ", "time-variable field"),
    ("gfc 3 1 ", "trnd 3 1 ", "time-variable field"),
    ("gfc 3 1 ", "gcf 3 1 ", "'gcf' is not a data line"),
    ("gfc 3 1 ", "gfc 3 0 ", "degree 3, order 0 are given again .first on line"),
    # audit42: any norm but 'unnormalized' was read as fully normalised
    ("norm fully_normalized", "norm geodesy_4pi", "norm must be 'fully_normalized' or"),
])
def test_gfc_file_error_names_the_line(tmp_path, old, new, match):
    from test_perturbations import GFC_HEADER, GFC_ROWS
    from visviva.satellites.perturbations import SphericalHarmonics

    text = GFC_HEADER + "\n".join(f"gfc {n} {m} {c:.15e} {s:.15e} 0 0"
                                  for n, m, c, s in GFC_ROWS) + "\n"
    assert old in text
    k = next(i for i, t in enumerate(text.splitlines()) if old in t) + 1
    (tmp_path / "f.gfc").write_text(text.replace(old, new, 1))
    with pytest.raises(vv.InvalidInputError, match=f"f.gfc, line {k}: .*{match}"):
        SphericalHarmonics(tmp_path / "f.gfc")


def test_gfc_secular_rates_are_left_out(tmp_path):
    """'dot' lines (ICGEM 1.0 secular rates) do not change the field (its reference epoch)."""
    from test_perturbations import GFC_HEADER, GFC_ROWS
    from visviva.satellites.perturbations import SphericalHarmonics

    lines = [f"gfc {n} {m} {c:.15e} {s:.15e} 0 0" for n, m, c, s in GFC_ROWS]
    (tmp_path / "a.gfc").write_text(GFC_HEADER + "\n".join(lines) + "\n")
    (tmp_path / "b.gfc").write_text(GFC_HEADER + "\n".join(lines + ["dot 2 0 1.16e-11 0 0 0"]))
    a = SphericalHarmonics(tmp_path / "a.gfc").coefficients
    np.testing.assert_array_equal(a, SphericalHarmonics(tmp_path / "b.gfc").coefficients)
    assert a[0, 2, 0] == pytest.approx(-vv.EARTH.jn(2), rel=1e-5)


def test_gfc_norm_spellings(tmp_path):
    """audit42: 'norm unnormalised' (British spelling) was read as fully normalised, every C_nm
    and S_nm off by the normalisation factor (C20 sqrt(5) = 2.2 times too large, silently)."""
    from test_perturbations import GFC_HEADER, GFC_ROWS
    from visviva.satellites.perturbations import SphericalHarmonics

    lines = "\n".join(f"gfc {n} {m} {c:.15e} {s:.15e} 0 0" for n, m, c, s in GFC_ROWS) + "\n"
    fields = {}
    for word in ("fully_normalized", "fully_normalised", "unnormalized", "unnormalised"):
        (tmp_path / f"{word}.gfc").write_text(
            GFC_HEADER.replace("norm fully_normalized", f"norm {word}") + lines)
        fields[word] = SphericalHarmonics(tmp_path / f"{word}.gfc").coefficients
    np.testing.assert_array_equal(fields["fully_normalised"], fields["fully_normalized"])
    np.testing.assert_array_equal(fields["unnormalised"], fields["unnormalized"])
    assert fields["unnormalized"][0, 2, 0] == GFC_ROWS[1][2]  # read as it is
    assert fields["fully_normalized"][0, 2, 0] == pytest.approx(np.sqrt(5) * GFC_ROWS[1][2])


def test_gfc_above_degree_80_asks_for_a_degree(tmp_path):
    """audit42: a field beyond degree 80 read without degree= said 'got None'."""
    from test_perturbations import GFC_HEADER
    from visviva.satellites.perturbations import SphericalHarmonics

    rows = [f"gfc {n} 0 1e-9 0 0 0" for n in range(2, 91)]
    (tmp_path / "big.gfc").write_text(GFC_HEADER + "\n".join(rows) + "\n")
    with pytest.raises(vv.InvalidInputError, match="goes to degree 90: give degree=N"):
        SphericalHarmonics(tmp_path / "big.gfc")
    assert SphericalHarmonics(tmp_path / "big.gfc", degree=80).degree == 80
