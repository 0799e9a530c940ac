"""NORAD catalogue numbers: the one place that reads them, checks them, hands them to sgp4 and
writes them into a TLE.

The catalogue runs from 1 to 999,999,999 (nine digits; 18 SDS / Space-Track publish numbers
above 339,999 in CCSDS OMMs only). A TLE holds five characters: digits up to 99,999, then the
alpha-5 scheme (a letter for the leading two digits, I and O skipped: 100000 -> ``A0000``, up to
339999 -> ``Z9999``). The ``sgp4`` package keeps the number in those five characters too:
``Satrec.sgp4init`` raises ``ValueError`` above 339,999, and ``Satrec.satnum`` is read-only.

SGP4 never uses the number (it only labels the record), so a larger one is kept on visviva's
side: sgp4 is initialised with :data:`SGP4_PLACEHOLDER` (0, a number no object carries) and
:attr:`visviva.Satellite.satnum` returns the real one. Propagation is bit for bit that of the
same elements under a five-digit number (tests/test_catalog_numbers.py).
"""

from __future__ import annotations

import re

from ..errors import InvalidInputError

__all__ = ["ALPHA5_MAX", "CATALOGUE_MAX", "SGP4_PLACEHOLDER", "catalogue_number",
           "sgp4_number", "tle_number"]

#: the largest number a TLE (and sgp4's record) can hold: alpha-5 ``Z9999``
ALPHA5_MAX = 339_999
#: the largest NORAD catalogue number (nine digits; 900,000,000 and up are uncorrelated tracks)
CATALOGUE_MAX = 999_999_999
#: the number sgp4 is initialised with for a catalogue number above :data:`ALPHA5_MAX`
SGP4_PLACEHOLDER = 0

_ALPHA5 = re.compile(r"[A-HJ-NP-Z][0-9]{4}", re.ASCII)
_DIGITS = re.compile(r"[0-9]+", re.ASCII)


def catalogue_number(value) -> int:
    """A catalogue number (``NORAD_CAT_ID``) as an int, checked.

    Parameters
    ----------
    value : int, float or str
        Digits (``25544``, ``"123456789"``, an integral float as JSON readers may give), or an
        alpha-5 string (a letter A-Z other than I and O, then four digits: ``"A0001"`` is
        100001).

    Returns
    -------
    int
        In 0 .. :data:`CATALOGUE_MAX` (0 is accepted as "unknown", as TLE files use ``00000``).

    Raises
    ------
    ValueError
        Anything else (a sign, letters I or O, more than nine digits), saying what is accepted.
    """
    if isinstance(value, bool):
        raise ValueError(f"NORAD_CAT_ID {value!r} is a boolean, not a catalogue number")
    if isinstance(value, float) and value.is_integer() and value >= 0:
        value = int(value)
    text = str(value).strip()
    if _ALPHA5.fullmatch(text):
        from sgp4.alpha5 import from_alpha5

        return int(from_alpha5(text))
    if _DIGITS.fullmatch(text):
        number = int(text)
        if number <= CATALOGUE_MAX:
            return number
        raise ValueError(
            f"NORAD_CAT_ID {value!r} has more than nine digits; catalogue numbers run from 1 to "
            f"{CATALOGUE_MAX:,}"
        )
    raise ValueError(
        f"NORAD_CAT_ID {value!r} is neither a catalogue number (up to nine digits) nor an "
        "alpha-5 number (a letter A-Z other than I and O, then four digits, e.g. 'A0001')"
    )


def sgp4_number(number: int) -> int:
    """The number to initialise sgp4 with: ``number`` itself up to :data:`ALPHA5_MAX`, else
    :data:`SGP4_PLACEHOLDER` (the caller keeps the real number).

    Parameters
    ----------
    number : int
        A checked catalogue number (:func:`catalogue_number`).

    Returns
    -------
    int
    """
    return int(number) if number <= ALPHA5_MAX else SGP4_PLACEHOLDER


def tle_number(number: int) -> str:
    """The five characters of a TLE's catalogue-number columns (3-7 of both lines).

    Parameters
    ----------
    number : int
        Catalogue number, 1 .. :data:`ALPHA5_MAX`.

    Returns
    -------
    str
        Five digits, or alpha-5 above 99,999 (``"A0000"`` for 100000).

    Raises
    ------
    InvalidInputError
        A number outside 1 .. 339,999, which no TLE can hold; the message says to write an
        OMM instead.
    """
    from sgp4.alpha5 import to_alpha5

    number = int(number)
    if number > ALPHA5_MAX:
        raise InvalidInputError(
            f"catalogue number {number} cannot be written in a TLE: its five columns hold at "
            f"most {ALPHA5_MAX} (alpha-5 'Z9999'), and numbers above that are published only "
            "as CCSDS OMMs. Write an OMM instead: sat.to_omm() and vv.write_omm(...)."
        )
    if number < 1:
        raise InvalidInputError(
            f"catalogue number {number} cannot be written in a TLE (1 .. {ALPHA5_MAX}); give "
            "the element set its number (e.g. fit_tle(..., satnum=N)) or write an OMM."
        )
    return to_alpha5(number)
