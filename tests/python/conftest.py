"""pytest runs in YADE's Python (/usr/bin/python3.11): make yade, the built package and the
developer tools (tools/, not installed) importable."""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
for path in (os.path.join(ROOT, "build", "python"), "/usr/lib/x86_64-linux-gnu/yade-double/py",
             os.path.join(ROOT, "tools")):
    if path not in sys.path:
        sys.path.insert(0, path)

import pytest  # noqa: E402
import yade  # noqa: E402,F401  (initialises YADE once for the whole session)
from yade import O  # noqa: E402


@pytest.fixture(autouse=True)
def fresh_scene():
    """Every test starts from an empty YADE scene."""
    O.reset()
    yield
    O.reset()
