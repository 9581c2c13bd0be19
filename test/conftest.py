import csv
import math
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"


def read_reference(name="elastica_parabola_p0_0.3.csv"):
    """Rows (dicts of floats, NaN for empty) and the '# event:' header records of a reference scan."""
    path = DATA / name
    events = []
    lines = []
    with open(path) as stream:
        for line in stream:
            if line.startswith("# event:"):
                fields = dict(item.split("=", 1) for item in line.split()[3:])
                events.append((line.split()[2], float(fields["x0"]), float(fields["alpha"])))
            elif not line.startswith("#"):
                lines.append(line)
    reader = csv.DictReader(lines)
    rows = [{k: (float(v) if v not in ("", "nan") else math.nan) for k, v in row.items()} for row in reader]
    return rows, events


@pytest.fixture(scope="session")
def reference_scan():
    return read_reference()
