"""``clearance.wing_clearance``: the least distance between the fore- and hind-wing surfaces over
a cycle (docs/model.md §1.7)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import tandem_env as te
from tandem_env.physics.clearance import _segment_distance, wing_clearance


def _case(lags) -> np.ndarray:
    """docs/model.md §5.7's stroke (f = 37 Hz, sweep ±35°, pitch ±50°, β = 15°), the hind-wing
    lagging by each of ``lags`` [deg]."""

    def wrap(a):
        return (a + 180.0) % 360.0 - 180.0

    fore = [37, 35, 1, 50, 0, 5, 0, 0, 0, 90, 0.01, 1, 0.01, 15]
    return np.array(
        [[*fore, 37, 35, 1, 50, 0, 5, 0, wrap(-g), wrap(-g), wrap(90 - g), 0.01, 1, 0.01, 15]
         for g in lags],
        dtype=float,
    )  # fmt: skip


def test_segment_distance_is_the_least_distance():
    """Against the least distance between densely sampled points of the two segments, which it
    may undercut by no more than the sampling's spacing, and never exceed."""
    rng = np.random.default_rng(0)
    s = np.linspace(0.0, 1.0, 4001)
    for _ in range(20):
        p0, u, q0, v = rng.normal(size=(4, 3))
        if rng.uniform() < 0.3:
            v = 0.7 * u  # parallel
        points = np.sqrt(
            (((p0 + s[:, None] * u)[:, None] - (q0 + s[:, None] * v)[None]) ** 2).sum(-1)
        )
        brute = points.min()
        exact = _segment_distance(p0, u, q0, v)
        spacing = (np.linalg.norm(u) + np.linalg.norm(v)) / 4000
        assert brute - spacing <= exact <= brute + 1e-12


def test_far_apart_wings_are_as_far_as_their_roots_allow():
    """Roots 1 m apart: the wings are at least 1 m less both lengths apart, and no more than
    the roots' distance."""
    insect = replace(te.DRAGONFLY, root_drop=1.0, root_spacing=0.0)
    clearance = wing_clearance(_case([0.0, 90.0]), insect, n_time=32, n_span=8)
    reach = insect.fore.length + insect.hind.length
    assert np.all(clearance >= 1.0 - reach) and np.all(clearance < 1.0)


def test_the_default_roots_keep_the_wings_apart_and_no_drop_does_not():
    """At §5.7's stroke the default roots (9 mm drop) keep the wings at least 2 mm apart at every
    lag; with the roots at one height (drop 0) they pass through each other at 90° and 180°."""
    lags = np.arange(0.0, 360.0, 45.0)
    assert np.all(wing_clearance(_case(lags)) > 2e-3)
    level = replace(te.DRAGONFLY, root_drop=0.0)
    assert np.all(wing_clearance(_case([90.0, 180.0]), level) < 1e-4)


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="n_time"):
        wing_clearance(_case([0.0]), n_time=2)
    with pytest.raises(ValueError, match="n_span"):
        wing_clearance(_case([0.0]), n_span=1.5)
    with pytest.raises(ValueError, match="insect"):
        wing_clearance(_case([0.0]), insect="dragonfly")
    with pytest.raises(ValueError, match="Table 4"):
        wing_clearance(np.zeros(28))
