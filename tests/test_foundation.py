"""The foundation: units in one place, errors from one table, bodies with sources, lazy import."""

import subprocess
import sys

import numpy as np
import pytest
from astropy import units as u

import visviva as vv
from visviva import _units
from visviva.core import status
from visviva.errors import STATUS_TABLE, raise_for_status


def test_import_is_lazy_and_compiles_nothing():
    # numba's modules are imported ahead of the first call (visviva._startup), but no kernel
    # module, so nothing is compiled or loaded from the cache; astropy waits for a Quantity
    code = (
        "import sys, visviva; "
        "assert 'numba' in sys.modules; "
        "kernels = [m for m in sys.modules if m.startswith('visviva.core')]; "
        "assert not kernels, kernels; "
        "assert 'astropy' not in sys.modules, 'astropy imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_plain_number_calls_do_not_import_astropy():
    # astropy.units costs ~0.1 s of the first call; plain numbers never need it
    code = (
        "import sys, math, visviva as vv; "
        "E = vv.solve_kepler(1.0, 0.5); "
        "assert abs(E - 0.5 * math.sin(E) - 1.0) < 1e-15; "
        "assert 'astropy' not in sys.modules, 'astropy imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_units_error_is_astropys_and_pickles():
    import pickle

    from astropy.units import UnitsError as AstropyUnitsError

    assert issubclass(vv.UnitsError, AstropyUnitsError)
    assert issubclass(vv.UnitsError, vv.InvalidInputError)
    assert vv.UnitsError is vv.errors.UnitsError
    with pytest.raises(AstropyUnitsError, match="astropy Quantity"):
        vv.StateVectors([7000.0, 0, 0], [0, 7.5, 0] * u.km / u.s, vv.EARTH.gm)
    err = pickle.loads(pickle.dumps(vv.UnitsError("no unit")))
    assert type(err) is vv.UnitsError and str(err) == "no unit"
    assert set(_units.CANONICAL) >= {"length", "speed", "time", "gm"}


def test_public_names_resolve():
    for name in ("EARTH", "SUN", "MOON", "MERCURY", "NEPTUNE", "VisvivaError", "UnitsError"):
        assert getattr(vv, name) is not None
    with pytest.raises(AttributeError):
        vv.no_such_name  # noqa: B018


def test_bodies_carry_gm_radius_and_sources():
    assert vv.EARTH.gm.unit.is_equivalent(u.km**3 / u.s**2)
    assert vv.EARTH.gm.to_value(u.km**3 / u.s**2) == pytest.approx(398600.4355, rel=1e-9)
    assert vv.SUN.gm.to_value(u.km**3 / u.s**2) == pytest.approx(1.32712440041e11, rel=1e-10)
    assert vv.EARTH.radius.to_value(u.km) == pytest.approx(6378.1363)
    # EGM2008 J2 to the digits published (1.0826261738e-3 from C20 = -4.84165143790815e-4)
    assert vv.EARTH.j2 == pytest.approx(1.0826261738522e-3, rel=1e-12)
    assert "DE440" in vv.EARTH.source
    with pytest.raises(AttributeError, match="no zonal harmonics"):
        vv.MARS.j2  # noqa: B018


def test_units_convert_once_and_refuse_missing_units():
    r = _units.to_vector([1.0, 2.0, 3.0] * u.au, "length", "r")
    np.testing.assert_allclose(r, np.array([1.0, 2.0, 3.0]) * 149597870.7, rtol=1e-15)
    assert _units.to_array(vv.EARTH, "gm", "gm") == pytest.approx(398600.43550702266)
    assert _units.to_array(90.0 * u.deg, "angle", "inc") == pytest.approx(np.pi / 2)
    assert _units.to_array(0.5, "angle", "inc") == 0.5  # plain floats are radians
    with pytest.raises(vv.UnitsError, match="7000 \\* u.km"):
        _units.to_array(7000.0, "length", "r")
    with pytest.raises(vv.UnitsError, match="cannot be converted"):
        _units.to_array(1.0 * u.s, "length", "r")
    with pytest.raises(vv.InvalidInputError, match="NaN"):
        _units.to_array([1.0, np.nan] * u.km, "length", "r")
    with pytest.raises(vv.ShapeError, match=r"\(\.\.\., 3\)"):
        _units.to_vector([1.0, 2.0] * u.km, "length", "r")
    with pytest.raises(vv.InvalidInputError, match="> 0"):
        _units.require_positive(np.array([1.0, -2.0]), "gm")


def test_every_status_code_has_one_exception():
    codes = [v for k, v in vars(status).items() if k.isupper() and k != "OK"]
    assert sorted(codes) == sorted(STATUS_TABLE)
    raise_for_status(np.zeros((4, 5), dtype=np.int8))  # all OK: no exception
    with pytest.raises(vv.ConvergenceError, match=r"index \(1,\).*M=0.5"):
        raise_for_status(np.array([0, status.NO_CONVERGENCE]), "Kepler", M=np.array([0.1, 0.5]))
    with pytest.raises(ValueError):  # our input errors are ValueErrors too
        raise_for_status(status.BAD_GM)


def test_time_deltas_are_times():
    from astropy.time import TimeDelta

    assert _units.to_array(TimeDelta(1.5, format="jd"), "time", "dt") == 1.5 * 86400.0
    dt = _units.to_array(TimeDelta([1.0, 2.0] * u.min), "time", "dt")
    np.testing.assert_allclose(dt, [60.0, 120.0], rtol=1e-15)


def test_complex_input_is_refused_not_truncated():
    with pytest.raises(vv.InvalidInputError, match="complex"):
        _units.to_vector(np.array([7000 + 1j, 0, 0]) * u.km, "length", "r")
    with pytest.raises(vv.InvalidInputError, match="complex"):
        _units.to_array(0.5 + 0j, "angle", "inc")


def test_fmt_first_names_the_first_few_and_counts_the_rest():
    from visviva.errors import fmt_first

    assert fmt_first(["a", "b"]) == "a, b"
    assert fmt_first(list("abcdefg")) == "a, b, c, d, e and 2 more"
    assert fmt_first(list("abcd"), 3, "; ") == "a; b; c and 1 more"
    assert fmt_first([]) == ""
