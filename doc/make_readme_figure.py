"""
Draw the README's picture with the project's own command (run from the package's folder).

    python doc/make_readme_figure.py

It writes doc/readme_figure.png: the paper's catenary example (Figs 2.1-2.3), back and forth,
as ``vibrissa scan --plot --small-png`` draws it (a deterministic PNG: the same code gives the
same file). The documentation site draws its own figures while it is built; this one is
committed because a README on a code host cannot run anything.
"""

import sys
import tempfile
from pathlib import Path

from vibrissa_ros.cli import main

COMMAND = ["scan", "--profile", "catenary", "--param", "p0=0.5", "--param", "c=0.6",
           "--from", "1.5", "--to", "-1.5", "--step", "0.005", "--back", "--small-png"]

if __name__ == "__main__":
    out = Path(__file__).resolve().parent / "readme_figure.png"
    with tempfile.TemporaryDirectory() as tmp:
        status = main(COMMAND + ["--csv", str(Path(tmp) / "catenary.csv"), "--plot", str(out)])
    print(f"-> {out}" if status == 0 else f"failed ({status})", file=sys.stderr)
    sys.exit(status)
