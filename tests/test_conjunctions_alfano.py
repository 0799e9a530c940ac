"""Alfano (2009) conjunction test cases 1-12 against NASA CARA's reference values.

The states, covariances, HBRs and reference Pc values are in ``tests/data/alfano2009_cara.csv``,
extracted from github.com/nasa/CARA_Analysis_Tools (the file says which files, sheets and
commit). ``cara_pc2d`` is CARA's ``Pc2D_Foster`` (an exact integral, computed there to 1e-9
relative), ``cara_pc3d`` its ``Pc3D_Hall`` (Hall 2021 3D-Nc), ``cara_pc_mc*`` its two-body Monte
Carlo with 1e8 trials and the 95 % interval.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np
import pytest

from visviva.conjunctions import collision_probability

DATA = Path(__file__).parent / "data" / "alfano2009_cara.csv"


def _load():
    lines = [line for line in DATA.read_text().splitlines(keepends=True)
             if not line.startswith("#")]
    cases = {}
    for row in csv.DictReader(io.StringIO("".join(lines))):
        case = {"hbr": float(row["hbr_m"]), "window": float(row["a09_final_time_s"])}
        for o in "12":
            case["r" + o] = np.array([float(row[f"r{o}_{a}_m"]) for a in "xyz"])
            case["v" + o] = np.array([float(row[f"v{o}_{a}_m_s"]) for a in "xyz"])
            case["c" + o] = np.array([float(row[f"cov{o}_{i}{j}"]) for i in range(1, 7)
                                      for j in range(1, 7)]).reshape(6, 6)
        for key in ("cara_pc2d", "cara_pc3d", "cara_pc_mc", "cara_pc_mc_lo95",
                    "cara_pc_mc_hi95"):
            case[key] = float(row[key]) if row[key] else math.nan
        cases[int(row["case"])] = case
    return cases


CASES = _load()


def _args(c):
    return c["r1"], c["v1"], c["c1"], c["r2"], c["v2"], c["c2"], c["hbr"]


def test_the_table_is_complete():
    assert sorted(CASES) == list(range(1, 13))
    # case 12: identical orbits, zero relative velocity (no 2-D Pc)
    assert math.isnan(CASES[12]["cara_pc2d"])
    assert np.allclose(CASES[12]["v1"], CASES[12]["v2"])
    for c in CASES.values():
        assert c["cara_pc_mc_lo95"] < c["cara_pc_mc"] < c["cara_pc_mc_hi95"]


@pytest.mark.parametrize("n", range(1, 12))
def test_foster_matches_cara_pc2d(n):
    # an exact integral on both sides; CARA's tolerance is 1e-9, ours 1e-13
    c = CASES[n]
    assert collision_probability(*_args(c)) == pytest.approx(c["cara_pc2d"], rel=1e-10)
