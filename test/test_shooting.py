"""The core's closed forms against the independent shooting solver on full scans."""

import numpy as np
import pytest

from vibrissa_ros.core import Catenary, Parabola, TwoCircles, run_scan
from vibrissa_ros.core.checks.shooting import ShootingScan

CASES = [Parabola(0.3), Parabola(0.6), Catenary(0.5, 0.6), TwoCircles(0.4, 0.8, 1.6)]


@pytest.mark.parametrize("profile", CASES, ids=lambda p: p.describe())
def test_core_agrees_with_shooting_on_a_full_scan(profile):
    grid = np.round(np.arange(2.0, -2.0, -0.05), 12)
    reference = ShootingScan(profile).run(grid)
    core = run_scan(profile, grid).states
    compared = 0
    phases = set()
    for ref, st in zip(reference, core):
        if ref is None:
            assert st.phase == 0
            continue
        assert st.phase == ref.phase, f"x0 = {st.x0}"
        phases.add(st.phase)
        for name in ("f", "m0", "fx", "fy", "s1", "alpha", "tip_slope"):
            assert getattr(st, name) == pytest.approx(getattr(ref, name), abs=1e-8), (name, st.x0)
        compared += 1
    assert compared >= 30
    assert 2 in phases
    # the shooting continuation loses the branch where the core snaps (the fold)
    snap = [e for e in run_scan(profile, grid).events if e.kind == "snap"][0]
    assert len(reference) < len(grid)
    assert grid[len(reference) - 1] >= snap.x0 > grid[len(reference)]
