"""Where the examples write their figures: $VISVIVA_EXAMPLES_OUT, or the current folder."""

import os
from pathlib import Path


def figure_path(name: str) -> Path:
    """Path for a figure file named ``name`` in the examples' output folder (created if needed)."""
    folder = Path(os.environ.get("VISVIVA_EXAMPLES_OUT", "."))
    folder.mkdir(parents=True, exist_ok=True)
    return folder / name
