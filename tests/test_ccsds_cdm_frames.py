"""A CDM whose two objects name different REF_FRAMEs (CCSDS 508.0-B-1 lets each segment name
its own): ``msg.states()`` / ``msg.probability()`` put both on GCRF before combining them.
Before, only a warning was given and ``o1.r - o2.r`` mixed GCRF with ITRF."""

import warnings
from pathlib import Path

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time

import visviva as vv
from visviva.conjunctions import rtn_to_inertial
from visviva.satellites.frames import gcrs_to_itrs

TCA = Time("2024-05-01T12:00:00", scale="utc")
SAMPLE = Path(__file__).parent / "data" / "sample_cdm.kvn"
KM, KMS = u.km, u.km / u.s


def _gcrf_message():
    """Two crossing LEO objects at TCA (relative position normal to the relative velocity,
    miss 104 m), each with an RTN covariance; all in GCRF."""
    r1, v1 = np.array([7000.0, 0.0, 0.0]), np.array([0.0, 7.5, 0.0])
    r2, v2 = r1 + np.array([0.1, 0.02, 0.02]), np.array([0.0, 0.0, 7.5])
    rtn = np.diag([30.0, 200.0, 20.0, 0.2, 0.03, 0.02]) ** 2  # m, m/s
    c1 = rtn_to_inertial(rtn, r1 * KM, v1 * KMS)
    c2 = rtn_to_inertial(4 * rtn, r2 * KM, v2 * KMS)
    return vv.ConjunctionDataMessage.from_states(TCA, r1 * KM, v1 * KMS, c1, r2 * KM, v2 * KMS,
                                                 c2, names=("A", "B"))


def _with_object2_in_itrf(msg):
    sections = vv.read_cdm(msg.to_kvn()).sections()  # a copy to edit
    state = sections["object2"]["state_vector"].values
    r = np.array([state[k] for k in ("X", "Y", "Z")])
    v = np.array([state[k] for k in ("X_DOT", "Y_DOT", "Z_DOT")])
    ri, vi = gcrs_to_itrs(r, v, TCA)
    for k, axis in enumerate("XYZ"):
        state[axis], state[f"{axis}_DOT"] = float(ri[k]), float(vi[k])
    sections["object2"]["metadata"].values["REF_FRAME"] = "ITRF"
    with pytest.warns(UserWarning, match="msg.states"):
        return vv.read_cdm(vv.ConjunctionDataMessage(sections).to_kvn())


def test_object2_in_itrf_gives_the_all_gcrf_miss_and_pc():
    gcrf = _gcrf_message()
    mixed = _with_object2_in_itrf(gcrf)
    assert (mixed.object1.frame, mixed.object2.frame) == ("GCRF", "ITRF")
    a, b = gcrf.states(), mixed.states()
    for k in (0, 1, 3, 4):  # r1, v1, r2, v2: the ITRF state back on GCRF to < 1 um, 1e-9 m/s
        assert np.abs((b[k] - a[k]).to_value(KM if k in (0, 3) else KMS)).max() < 1e-9
    for k in (2, 5):  # covariances, in units of their sigmas
        d = np.sqrt(np.diag(a[k]))
        assert np.abs((b[k] - a[k]) / np.outer(d, d)).max() < 1e-8
    miss = np.linalg.norm((b[0] - b[3]).to_value(u.m))
    assert miss == pytest.approx(gcrf.miss_distance.to_value(u.m), abs=1e-3)
    assert miss == pytest.approx(np.sqrt(0.1**2 + 2 * 0.02**2) * 1e3, rel=1e-6)
    pc = gcrf.probability(20 * u.m)
    assert 1e-6 < pc < 1e-1
    assert mixed.probability(20 * u.m) == pytest.approx(pc, rel=1e-7)
    # as written, the two states are thousands of km apart: the old path's Pc was 0
    o1, o2 = mixed.object1, mixed.object2
    assert np.linalg.norm((o1.r - o2.r).to_value(KM)) > 1000
    old = vv.collision_probability(o1.r, o1.v, o1.covariance, o2.r, o2.v, o2.covariance,
                                   20 * u.m)
    assert old == 0.0


def test_states_refuse_frames_visviva_cannot_rotate():
    gcrf = _gcrf_message()
    sections = vv.read_cdm(gcrf.to_kvn()).sections()  # a copy to edit
    sections["object2"]["metadata"].values["REF_FRAME"] = "EFG"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        msg = vv.read_cdm(vv.ConjunctionDataMessage(sections).to_kvn())
    with pytest.raises(vv.InvalidInputError, match="REF_FRAME = 'EFG'.*rotate"):
        msg.states()
    with pytest.raises(vv.InvalidInputError, match="one inertial frame"):
        gcrf.states("ITRF")
    # EME2000: the GCRF states turned by the frame bias (23 mas; 0.8 m at 7000 km)
    from visviva.ccsds.timeframes import FRAME_BIAS

    r1, v1, c1, r2, *_ = gcrf.states("EME2000")
    g1, _, g_c1, g2, *_ = gcrf.states("GCRF")
    np.testing.assert_allclose(r1.to_value(u.km), FRAME_BIAS @ g1.to_value(u.km), rtol=0,
                               atol=1e-12 * 7000)
    assert 0.5 < np.linalg.norm((r1 - g1).to_value(u.m)) < 1.0
    assert abs(np.linalg.norm((r1 - r2).to_value(u.m))
               - np.linalg.norm((g1 - g2).to_value(u.m))) < 1e-6  # the miss is kept
    b6 = np.kron(np.eye(2), FRAME_BIAS)
    np.testing.assert_allclose(c1, b6 @ g_c1 @ b6.T, rtol=1e-9, atol=1e-12 * np.abs(c1).max())


def test_orbit_centres_that_cannot_be_combined_are_refused_naming_the_lines():
    # ORBIT_CENTER = MOON with REF_FRAME = ITRF was turned with the Earth's rotation (a state
    # 6598 km from the numbers as written, silently), and objects about the Moon and the
    # Earth were subtracted as if they had one origin
    lines = SAMPLE.read_text().splitlines()
    at = [k for k, line in enumerate(lines) if line.startswith("REF_FRAME")]

    def variant(c1, c2, frame):
        out = list(lines)
        for k, c in zip(at[::-1], (c2, c1), strict=True):
            out[k] = f"REF_FRAME = {frame}"
            out.insert(k, f"ORBIT_CENTER = {c}")
        return "\n".join(out)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (the states no longer match MISS_DISTANCE)
        moon_itrf = vv.read_cdm(variant("MOON", "MOON", "ITRF"))
        mixed = vv.read_cdm(variant("MOON", "EARTH", "EME2000"))
        earth = vv.read_cdm(variant("EARTH", "EARTH", "ITRF"))
        moon = vv.read_cdm(variant("MOON", "MOON", "EME2000"))
    with pytest.raises(vv.InvalidInputError, match=f"line {at[0] + 1}: ORBIT_CENTER = MOON .*ITRF"):
        moon_itrf.states()
    with pytest.raises(vv.InvalidInputError, match="ORBIT_CENTER = MOON .*ITRF"):
        moon_itrf.object1.covariance  # noqa: B018
    with pytest.raises(vv.InvalidInputError, match=f"MOON \\(line {at[0] + 1}\\), OBJECT2's EARTH"):
        mixed.probability(20 * u.m)
    assert earth.states()[0].shape == (3,)  # Earth-centred ITRF: as before
    assert moon.states()[0].shape == (3,)  # both about the Moon on inertial axes: combined
