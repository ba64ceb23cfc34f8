"""The cycle means of positive parts (``cycle.mean_positive_part``, ``torch_model``'s twin): the
trigonometric interpolant of the samples integrated exactly between its zero crossings.

A crossing pair can sit between two samples of one sign (the interpolant dips across zero and
back). Found only once a sample crossed zero, such a pair made the mean jump there, by the
area of the dip, and made the model's thrust and power discontinuous in the stroke (a local
optimiser then stalls on the jump). These tests hold the mean continuous and exact.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from tandem_env.physics import cycle, torch_model

N = 128
H = 2.0 * np.pi / N
S = H * np.arange(N)
#: the dip's bottom, half-way between samples 40 and 41
BOTTOM = 40.5 * H


def dip(c: float) -> np.ndarray:
    """Samples of c + 1 − cos(s − s₀): a parabola-like dip of depth c between two samples, which
    stay positive while c > −(1 − cos(h/2)) ≈ −3e-4."""
    return c + 1.0 - np.cos(S - BOTTOM)


def exact(c: float) -> float:
    """Cycle mean of max(c + 1 − cos(s − s₀), 0) [-]: with u = 1 + c, the mean of
    max(u − cos, 0) = (u·(π − acos(u)) + √(1 − u²))/π for |u| < 1, and u for u ≥ 1."""
    u = 1.0 + c
    if u >= 1.0:
        return u  # no crossing: the integrand is never negative
    return (u * (np.pi - np.arccos(u)) + np.sqrt(1.0 - u * u)) / np.pi


def numba_mean(g: np.ndarray) -> float:
    return float(cycle.mean_positive_part(g, *cycle.fourier_tables(g.shape[0])))


@pytest.mark.parametrize("c", [-2e-4, -1e-4, -3e-5, -1e-6])
def test_a_dip_between_samples_of_one_sign_is_integrated_exactly(c):
    g = dip(c)
    assert np.all(g > 0.0)  # the samples do not see the dip
    # the two crossings of a shallow dip are ill-conditioned (a near-double root): ~1e-12
    assert numba_mean(g) == pytest.approx(exact(c), rel=1e-11)
    assert numba_mean(g) > g.mean()  # the dip's negative area is left out


def test_the_mean_is_continuous_as_a_dip_crosses_the_samples():
    # c from inside the samples' reach to past it: the mean's slope is the share of the cycle
    # where the integrand is positive (≤ 1), so no step may exceed the change of c
    cs = np.linspace(-6e-4, 1e-4, 3501)
    means = np.array([numba_mean(dip(c)) for c in cs])
    steps = np.diff(means) / np.diff(cs)
    # (a near-double root costs ~1e-11 of the mean: ~1e-4 of a step of 2e-7; a missed dip
    # jumps by its area, ~1e-6, a slope of ~5)
    assert steps.min() >= 0.0 and steps.max() <= 1.01
    # as c → 0 the two crossings merge into a double root, where the crossings' six Newton
    # steps leave ~1e-11 of the mean
    np.testing.assert_allclose(means, [exact(c) for c in cs], rtol=1e-10)


def test_torch_twin_agrees_and_differentiates_through_a_dip():
    cs = (-2e-4, -1e-4, 5e-5, -4e-4)
    g = torch.tensor(np.array([dip(c) for c in cs]), requires_grad=True)
    means = torch_model.mean_positive_part(g)
    np.testing.assert_allclose(
        means.detach().numpy(), [numba_mean(dip(c)) for c in cs], rtol=1e-10, atol=1e-15
    )
    # the derivatives w.r.t. every sample, summed, are d mean / d c: the share of the cycle
    # where c + 1 − cos > 0, (π − acos(1 + c))/π (1 where c ≥ 0)
    means.sum().backward()
    slope = g.grad.sum(dim=1).numpy()
    expected = [(np.pi - np.arccos(min(1.0 + c, 1.0))) / np.pi for c in cs]
    np.testing.assert_allclose(slope, expected, rtol=1e-6)
