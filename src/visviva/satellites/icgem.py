"""Reading gravity fields in the ICGEM ``.gfc`` format (International Centre for Global Earth
Models; Barthelmes and Foerste 2011, "The ICGEM-format"), for
:class:`visviva.satellites.SphericalHarmonics`.

Static fields (``gfc`` lines: EGM2008, EIGEN-6C4, ...) are read; a time-variable field (ICGEM
2.0: ``gfct``, ``trnd``, ``acos``, ``asin`` lines) is refused, since its coefficients are not on
``gfc`` lines.
"""

from __future__ import annotations

import math

from ..errors import InvalidInputError

__all__ = ["read_gfc"]


#: the ``norm`` header values (the ICGEM spellings and the British ones): normalised?
_NORMS = {"fully_normalized": True, "fully_normalised": True, "unnormalized": False,
          "unnormalised": False}
#: data keys of time-variable ICGEM fields (format 2.0): reference values, trends, periodic terms
_TIME_VARIABLE_KEYS = ("gfct", "trnd", "acos", "asin")


def read_gfc(path):
    """Parse an ICGEM .gfc file: (GM m^3/s^2, radius m, normalised?, [(n, m, C, S), ...]).

    Every error names the file and the line: a header number that does not parse or is not
    positive, a ``norm`` other than ``fully_normalized`` or ``unnormalized`` (or their British
    spellings), a ``gfc`` line without four numbers, a degree and order outside 0 <= m <= n or
    given twice, a coefficient that is NaN or infinite, a data line of a time-variable field
    (``gfct``, ``trnd``, ``acos``, ``asin``: its coefficients are not on ``gfc`` lines) or of
    no known kind. Secular rates (``dot`` lines of format 1.0) are left out: the field is the
    one at the model's reference epoch."""
    gm = radius = None
    norm = True
    rows = []
    seen = {}
    in_head = True
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            text = fh.read().replace("\r\n", "\n").replace("\r", "\n").split("\n")
    except OSError as exc:
        raise InvalidInputError(f"cannot read the gravity-field file {path!r}: {exc}") from exc

    def bad(number, what):
        return InvalidInputError(f"{path}, line {number}: {what}: {text[number - 1][:80]!r}")

    def number_in(parts, k, number, what):
        try:
            value = float(parts[k].replace("D", "E").replace("d", "e"))
        except (IndexError, ValueError):
            raise bad(number, f"{what} is not a number") from None
        if not math.isfinite(value):
            raise bad(number, f"{what} is not finite")
        return value

    for number, line in enumerate(text, start=1):
        parts = line.split()
        if not parts:
            continue
        key = parts[0].lower()
        if in_head:
            if key == "end_of_head":
                in_head = False
            elif key in ("earth_gravity_constant", "radius") and len(parts) > 1:
                value = number_in(parts, 1, number, key)
                if value <= 0:
                    raise bad(number, f"{key} must be positive")
                gm, radius = (value, radius) if key == "earth_gravity_constant" else (gm, value)
            elif key == "norm" and len(parts) > 1:
                word = parts[1].lower()
                if word not in _NORMS:  # was: anything but 'unnormalized' read as normalised
                    raise bad(number, "norm must be 'fully_normalized' or 'unnormalized'")
                norm = _NORMS[word]
            continue
        if key in _TIME_VARIABLE_KEYS:
            raise bad(
                number,
                f"'{parts[0]}' is a term of a time-variable field (ICGEM format 2.0), which is not "
                "implemented (reading its 'gfc' lines alone would leave these coefficients out): "
                "use a static field such as EGM2008 or EIGEN-6C4",
            )
        if key == "dot":  # format 1.0 secular rates: the field at its reference epoch is used
            continue
        if key != "gfc":
            raise bad(number, f"'{parts[0]}' is not a data line of an ICGEM file ('gfc n m C S')")
        try:
            n, m = int(parts[1]), int(parts[2])
        except (IndexError, ValueError):
            raise bad(number, "a 'gfc n m C S' line needs the integers n and m") from None
        if not 0 <= m <= n:
            raise bad(number, f"degree n = {n} and order m = {m} need 0 <= m <= n")
        if (n, m) in seen:
            raise bad(number, f"C and S of degree {n}, order {m} are given again (first on line "
                              f"{seen[n, m]}): one value per coefficient")  # fmt: skip
        seen[n, m] = number
        rows.append((n, m, number_in(parts, 3, number, "C"), number_in(parts, 4, number, "S")))
    if gm is None or radius is None or not rows or in_head:
        raise InvalidInputError(
            f"{path!r} is not an ICGEM .gfc file: it needs earth_gravity_constant, radius and "
            "end_of_head in the header and 'gfc n m C S' lines after it."
        )
    return gm, radius, norm, rows
