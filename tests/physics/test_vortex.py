"""The vortex reading's Biot-Savart core and geometry (tandem_env/physics/vortex.py) against
closed forms: a straight filament, a long one, a ring, mirror images, the viscous core, the
ring lattice's bookkeeping, and the wing's frame against the model's own (docs/model.md §5.8)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tandem_env.physics import DRAGONFLY, blade
from tandem_env.physics.kinematics import fill_angles, wing_params_radians
from tandem_env.physics.vortex import (
    TRAILING_EDGE,
    lattice_segments,
    prescribed_wake,
    segment_velocity,
    stroke_angles,
    wing_lines,
)

GAMMA = 2.0e-3  # [m²/s], about a dragonfly wing's bound circulation


def _rotation(seed: int) -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))  # proper rotation


def _one(a, b, points, gamma=GAMMA, core=0.0):
    return segment_velocity(np.array([[a, b]], dtype=float), np.array([gamma]), points, core)


@pytest.mark.parametrize("core", [0.0, 0.3e-3])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_straight_filament_matches_its_closed_form(core: float, seed: int) -> None:
    # Segment along z from −L1 to L2, points at distance h on x: Γ/(4πh)(cos θ1 − cos θ2) along
    # y, times Vatistas' h²/sqrt(h⁴ + r_c⁴); the whole set turned and moved anywhere.
    l1, l2 = 3e-3, 7e-3
    h = np.array([0.1e-3, 0.3e-3, 1e-3, 5e-3])
    z = np.array([-5e-3, 0.0, 2e-3, 9e-3])  # beside, and beyond either end
    rot, shift = _rotation(seed), np.array([1e-3, -2e-3, 4e-3])
    points = np.stack([h, 0 * h, z], -1)
    found = _one(
        rot @ [0, 0, -l1] + shift, rot @ [0, 0, l2] + shift, points @ rot.T + shift, core=core
    )
    cos1 = (z + l1) / np.hypot(z + l1, h)
    cos2 = (z - l2) / np.hypot(z - l2, h)
    speed = GAMMA / (4 * np.pi * h) * (cos1 - cos2) * h**2 / np.sqrt(h**4 + core**4)
    expected = np.stack([0 * h, speed, 0 * h], -1) @ rot.T
    assert found == pytest.approx(expected, rel=1e-12, abs=1e-15)


def test_a_long_filament_tends_to_the_infinite_line() -> None:
    h = 1e-3
    for length, tolerance in ((1e-1, 1e-4), (1e1, 1e-8)):
        v = _one([0, 0, -length], [0, 0, length], np.array([[h, 0.0, 0.0]]))[0, 1]
        assert v == pytest.approx(GAMMA / (2 * np.pi * h), rel=tolerance)
        assert abs(v / (GAMMA / (2 * np.pi * h)) - 1) > tolerance / 1e3  # finite, not exact


def test_the_core_regularises_the_axis() -> None:
    core = 0.2e-3
    h = np.geomspace(1e-9, 1e-2, 200)
    points = np.stack([h, 0 * h, 0 * h], -1)
    v = _one([0, 0, -1.0], [0, 0, 1.0], points, core=core)[:, 1]
    assert np.all(np.isfinite(v))
    # Largest at h = r_c: Γ/(2π r_c)/√2; linear, so vanishing, at the axis; the line far out.
    assert v.max() == pytest.approx(GAMMA / (2 * np.pi * core) / np.sqrt(2), rel=1e-3)
    assert h[np.argmax(v)] == pytest.approx(core, rel=0.05)
    assert v[0] == pytest.approx(GAMMA / (2 * np.pi) * h[0] / core**2, rel=1e-6)
    assert v[-1] == pytest.approx(GAMMA / (2 * np.pi * h[-1]), rel=1e-4)
    on_axis = np.array([[0, 0, 0.0], [0, 0, 2.0], [0, 0, -1.0]])  # inside, beyond, at an end
    assert np.abs(_one([0, 0, -1.0], [0, 0, 1.0], on_axis, core=core)).max() == 0.0


def test_no_circulation_no_velocity_and_the_far_field_falls_off() -> None:
    rng = np.random.default_rng(3)
    segments = rng.normal(size=(6, 2, 3)) * 1e-3
    points = rng.normal(size=(5, 3)) * 1e-2
    assert np.all(segment_velocity(segments, np.zeros(6), points, 1e-4) == 0.0)
    # A segment's far field falls as its length over the distance squared: 1/4 per doubling.
    direction = np.array([0.6, 0.0, 0.8])
    far = [
        np.linalg.norm(_one([0, -1e-3, 0], [0, 1e-3, 0], d * direction[None])) for d in (1.0, 2.0)
    ]
    assert far[1] / far[0] == pytest.approx(0.25, rel=1e-6)


@pytest.mark.parametrize("n", [8, 16, 64, 256])
def test_a_discretised_ring_converges_to_its_centre_velocity(n: int) -> None:
    radius = 5e-3
    angle = 2 * np.pi * np.arange(n + 1) / n
    nodes = np.stack([radius * np.cos(angle), radius * np.sin(angle), 0 * angle], -1)
    segments = np.stack([nodes[:-1], nodes[1:]], 1)
    v = segment_velocity(segments, np.full(n, GAMMA), np.zeros((1, 3)), 1e-4)[0]
    # The inscribed polygon, exactly: Γ/(2R)·tan(π/n)/(π/n), second order in 1/n, with the
    # core's h²/sqrt(h⁴ + r_c⁴) at the sides' distance h = R·cos(π/n).
    h = radius * math.cos(math.pi / n)
    core = h**2 / math.sqrt(h**4 + 1e-4**4)
    exact = GAMMA / (2 * radius) * math.tan(math.pi / n) / (math.pi / n) * core
    assert v == pytest.approx([0.0, 0.0, exact], rel=1e-12, abs=1e-16)
    assert abs(v[2] / (GAMMA / (2 * radius)) - 1) < 3.5 * (math.pi / n) ** 2 / 3


def test_mirror_images_give_mirrored_velocities() -> None:
    # Mirroring through the x-z plane flips y of every point; vorticity is an axial vector, so
    # the image filament carries −Γ: the velocity at the image point is the mirrored velocity.
    rng = np.random.default_rng(4)
    segments, gamma = rng.normal(size=(7, 2, 3)) * 1e-3, rng.normal(size=7) * GAMMA
    points = rng.normal(size=(9, 3)) * 3e-3
    flip = np.array([1.0, -1.0, 1.0])
    v = segment_velocity(segments, gamma, points, 2e-4)
    image = segment_velocity(segments * flip, -gamma, points * flip, 2e-4)
    assert image == pytest.approx(v * flip, rel=1e-12, abs=1e-18)
    # A symmetric pair of filaments induces no lateral velocity on the mid-plane.
    both = segment_velocity(
        np.concatenate([segments, segments * flip]), np.concatenate([gamma, -gamma]),
        points * [1.0, 0.0, 1.0], 2e-4,
    )  # fmt: skip
    assert np.abs(both[:, 1]).max() < 1e-12 * np.abs(both).max()


def test_leading_axes_broadcast_and_each_batch_is_its_own() -> None:
    rng = np.random.default_rng(5)
    segments, gamma = rng.normal(size=(3, 4, 2, 3)) * 1e-3, rng.normal(size=(3, 4))
    points, core = rng.normal(size=(3, 5, 3)) * 1e-3, np.full((3, 4), 1e-4)
    found = segment_velocity(segments, gamma, points, core)
    for b in range(3):
        assert found[b] == pytest.approx(
            segment_velocity(segments[b], gamma[b], points[b], 1e-4), rel=1e-14
        )
    with pytest.raises(ValueError, match=r"allowed: segments \(..., S, 2, 3\)"):
        segment_velocity(segments[..., :2], gamma, points, 1e-4)


def test_a_ring_lattice_is_the_sum_of_its_rings() -> None:
    rng = np.random.default_rng(6)
    nodes = rng.normal(size=(4, 5, 3)) * 1e-3  # 3 rows of 4 rings
    rings = rng.normal(size=(3, 4)) * GAMMA
    points = rng.normal(size=(6, 3)) * 3e-3
    segments, gamma = lattice_segments(nodes, rings)
    assert segments.shape == (4 * 4 + 3 * 5, 2, 3)
    expected = 0.0
    for k in range(3):
        for j in range(4):
            corners = nodes[[k, k, k + 1, k + 1, k], [j, j + 1, j + 1, j, j]]
            ring = np.stack([corners[:-1], corners[1:]], 1)
            expected = expected + segment_velocity(ring, np.full(4, rings[k, j]), points, 1e-4)
    assert segment_velocity(segments, gamma, points, 1e-4) == pytest.approx(expected, rel=1e-11)
    # Helmholtz: at every node the circulation flowing in equals that flowing out.
    flat = nodes.reshape(-1, 3)
    balance = np.zeros(len(flat))
    for (start, end), g in zip(segments, gamma, strict=True):
        balance[np.flatnonzero((flat == start).all(1))] -= g
        balance[np.flatnonzero((flat == end).all(1))] += g
    assert np.abs(balance).max() < 1e-15
    with pytest.raises(ValueError, match=r"rings \(..., K, N - 1\)"):
        lattice_segments(nodes, rings[:, :3])


def test_the_wake_is_released_at_the_trailing_edge_and_carried() -> None:
    rng = np.random.default_rng(7)
    n, k_rows = 8, 11
    bound, edge = rng.normal(size=(2, 1, n, 3, 3))
    gamma = rng.normal(size=(1, n, 2))
    step = np.array([-1e-3, 0.0, -2e-4])
    carried = np.arange(k_rows + 1)[None, :, None] * step
    nodes, rings = prescribed_wake(bound, edge, gamma, carried)
    assert nodes.shape == (1, n, k_rows + 2, 3, 3) and rings.shape == (1, n, k_rows + 1, 2)
    i = 5
    assert np.array_equal(nodes[0, i, 0], bound[0, i])
    assert np.array_equal(nodes[0, i, 1], edge[0, i])
    # Row k + 1: released at sample i − k (periodic), carried k steps.
    assert nodes[0, i, 10] == pytest.approx(edge[0, (i - 9) % n] + 9 * step, rel=1e-14)
    assert np.array_equal(rings[0, i, 0], gamma[0, i])
    assert rings[0, i, 3] == pytest.approx(0.5 * (gamma[0, i - 2] + gamma[0, i - 3]))
    with pytest.raises(ValueError, match=r"allowed: \(B, K \+ 1, 3\), K >= 1"):
        prescribed_wake(bound, edge, gamma, carried[:, :1])


def test_the_wing_lines_follow_the_models_frame() -> None:
    # The chord direction between two chord positions equals the kernel's e_c in earth axes
    # (blade.fill_frame_coefficients), the span line starts at the root, right wing.
    wing = np.array(
        [37.0, 40.0, 10.0, 50.0, 5.0, 8.0, -10.0, 30.0, 20.0, 80.0, 0.5, 2.0, 1.0, 20.0]
    )
    params = wing_params_radians(wing)[None]
    tau = np.linspace(0.0, 2 * np.pi, 7, endpoint=False)[None]
    fraction = np.array([0.0, 0.5, 1.0])
    chord = DRAGONFLY.fore.chord(fraction) + 1e-3
    root = np.array([1e-3, 2e-3, -3e-3])
    angles = stroke_angles(params, tau)
    lead = wing_lines(angles, params[:, 13], fraction, 0.03, chord, 0.5, root)
    edge = wing_lines(angles, params[:, 13], fraction, 0.03, chord, TRAILING_EDGE, root)
    angles = np.empty((7, 9))
    fill_angles(params[0], tau[0], angles)
    coef = np.empty((7, blade.N_COEF))
    blade.fill_frame_coefficients(angles, np.ones(7), params[0, 13], False, 1, coef)
    direction = (lead - edge) / chord[None, None, :, None]
    expected = coef[:, [blade.C_ECXE, blade.C_ECY, blade.C_ECZE]]
    assert direction[0] == pytest.approx(np.repeat(expected[:, None], 3, 1), abs=1e-13)
    mid = 0.5 * (lead + edge)
    assert mid[0, :, 0] == pytest.approx(np.broadcast_to(root, (7, 3)), abs=1e-15)
    assert np.linalg.norm(mid[0, :, 2] - root, axis=-1) == pytest.approx(np.full(7, 0.03))


torch = pytest.importorskip("torch")


def test_torch_matches_numpy_and_has_gradients() -> None:
    from tandem_env.physics.torch_model import TORCH

    rng = np.random.default_rng(8)
    segments, gamma = rng.normal(size=(2, 6, 2, 3)) * 1e-3, rng.normal(size=(2, 6)) * GAMMA
    points, core = rng.normal(size=(2, 4, 3)) * 2e-3, np.full((2, 6), 3e-4)
    expected = segment_velocity(segments, gamma, points, core)
    args = [
        torch.tensor(a, dtype=torch.float64, requires_grad=True)
        for a in (segments, gamma, points, core)
    ]
    found = segment_velocity(*args, xp=TORCH)
    assert found.detach().numpy() == pytest.approx(expected, rel=1e-12, abs=1e-18)
    assert torch.autograd.gradcheck(lambda *a: segment_velocity(*a, xp=TORCH), args)
    # the lattice and the wake on tensors, too
    nodes, rings = rng.normal(size=(3, 4, 3)) * 1e-3, rng.normal(size=(2, 3))
    seg_np, gam_np = lattice_segments(nodes, rings)
    seg_t, gam_t = lattice_segments(torch.tensor(nodes), torch.tensor(rings), TORCH)
    assert np.array_equal(seg_t.numpy(), seg_np) and np.array_equal(gam_t.numpy(), gam_np)
    wake = rng.normal(size=(1, 6, 3, 3)), rng.normal(size=(1, 6, 3, 3)), rng.normal(size=(1, 6, 2))
    carried = np.arange(5)[None, :, None] * np.array([-1e-3, 0.0, -1e-4])
    for found, expected in zip(
        prescribed_wake(*(torch.tensor(a) for a in (*wake, carried)), TORCH),
        prescribed_wake(*wake, carried),
        strict=True,
    ):
        assert np.array_equal(found.numpy(), expected)
    wing = np.array(
        [37.0, 40.0, 10.0, 50.0, 5.0, 8.0, -10.0, 30.0, 20.0, 80.0, 0.5, 2.0, 1.0, 20.0]
    )
    params = wing_params_radians(wing)[None]
    tau = np.linspace(0.0, 2 * np.pi, 5, endpoint=False)[None]
    fraction, chord, root = np.array([0.2, 0.9]), np.array([5e-3, 4e-3]), np.zeros(3)
    lines = wing_lines(stroke_angles(params, tau), params[:, 13], fraction, 0.03, chord, 0.25, root)
    params_t, tau_t = torch.tensor(params), torch.tensor(tau)
    lines_t = wing_lines(
        stroke_angles(params_t, tau_t, TORCH), params_t[:, 13], torch.tensor(fraction), 0.03,
        torch.tensor(chord), 0.25, torch.tensor(root), TORCH,
    )  # fmt: skip
    assert lines_t.numpy() == pytest.approx(lines, rel=1e-13, abs=1e-18)
