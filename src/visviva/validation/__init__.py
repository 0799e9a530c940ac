"""Cross-validation of visviva against REBOUND, Skyfield, astropy and sgp4.

Each capability contributes a module ``checks_<topic>.py`` in this package with a function
``checks(full: bool) -> list[Check]`` that runs its comparisons live against the installed
reference libraries. :func:`run` (``visviva validate``) collects them all.
"""

from .base import Check

__all__ = ["Check", "run"]


def run(full: bool = False, report_dir: str | None = "reference/report", only: str | None = None,
        **options) -> int:
    """Run every check, print one line each, write the report; return the exit code.

    ``options`` go to :func:`visviva.validation.runner.run` (``json_path``, ``strict``, ...).
    """
    from .runner import run as _run

    return _run(full=full, report_dir=report_dir, only=only, **options)
