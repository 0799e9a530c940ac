"""The README's example runs and prints what it promises."""

import re
import subprocess
import sys
from pathlib import Path

README = Path(__file__).parents[1] / "README.md"


def test_readme_example_runs():
    code = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    first = out.stdout.splitlines()[0]
    # Vallado Example 2-5: a = 36127.343 km, e = 0.832853, i = 87.87 deg
    a, e, i = (float(x) for x in re.findall(r"[-\d.]+(?:e[-+]\d+)?", first)[:3])
    assert abs(a - 36127.343) < 0.02 and abs(e - 0.832853) < 2e-6 and abs(i - 87.87) < 0.002


def test_readme_has_exactly_the_two_fresh_machine_commands():
    text = README.read_text()
    assert re.findall(r"^    make (\w+)$", text, re.M) == ["validate", "test"]
