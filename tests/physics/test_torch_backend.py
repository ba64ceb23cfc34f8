"""The torch backend (``torch_model``) against the numba kernel: values, gradients, bad input.

Equality: every ``Result`` field within 1e-8 relative (denominator floored at 1e-6) under
option sets generated from ``ModelOptions``' fields (every pair of two options' values, every
``Literal`` value and numeric alternative among them), both planforms, hover and forward
flight (V from 0 to 2 m/s), climbing and descending. Gradients: autograd against central differences
of the numba model (relative norm 1e-4, the discrete N excluded).
"""

from __future__ import annotations

import subprocess
import sys
from dataclasses import fields
from itertools import combinations, product
from pathlib import Path

import numpy as np
import pytest

import tandem_env as te
from tandem_env.physics.model import _METADATA, OPTIONAL_FIELDS, Result
from tandem_env.physics.stroke import DISCRETE, LOWER, UPPER

sys.path.insert(0, str(Path(__file__).parent))
from option_cases import all_pairs, alternatives, levels

torch = pytest.importorskip("torch")
from tandem_env.physics import torch_model  # noqa: E402

CUDA = pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device in this run")

RELATIVE = 1e-8
FLOOR = 1e-6


#: Values the equality test adds to the toy option test's: an odd n_time, a finer blade grid,
#: a tight tolerance and caps the inflow solve hits.
TORCH_VALUES = {
    "n_time": (63,),
    "n_blade": (10,),
    "tolerance": (1e-7,),
    "interference": (0.6,),
    "max_evaluations": (3,),
}
#: The convected slipstream acts under coupled induction only: always meet there, in hover and
#: forward flight (every case has both), at an odd and an even n_time, with the literal hover.
TOGETHER = (
    {"induction": "coupled", "slipstream": "convected", "n_time": 63},
    {"induction": "coupled", "slipstream": "convected", "n_time": 128},
    {"induction": "coupled", "slipstream": "convected", "hover_inflow": "none"},
)


def _option_sets() -> list[te.ModelOptions]:
    """Every pair of values of two options (tests/physics/option_cases.py: every value of every
    ``Literal`` option, the toy option test's numeric alternatives, :data:`TORCH_VALUES`), in
    sets built from the options' types: a new option or value is tested here untouched."""
    return [te.ModelOptions(**row) for row in all_pairs(levels(TORCH_VALUES), TOGETHER)]


OPTION_SETS = _option_sets()


def _case(seed: int, batch: int = 6):
    rng = np.random.default_rng(seed)
    strokes = te.normalised_to_physical(rng.uniform(-1.0, 1.0, (batch, 28)))
    speed = rng.uniform(0.0, 2.0, batch)
    speed[0] = 0.0  # hover
    gamma = rng.uniform(-0.4, 0.4, batch)
    gamma[1], gamma[2] = 0.3, -0.3  # climbing and descending
    return strokes, speed, gamma


def _assert_equal(expected: Result, got: Result) -> None:
    for name, want in expected.as_dict().items():
        have = getattr(got, name)
        assert have.dtype == want.dtype, name
        if want.dtype == bool or np.issubdtype(want.dtype, np.integer):
            np.testing.assert_array_equal(have, want, err_msg=name)
        else:
            error = np.abs(have - want) / np.maximum(np.abs(want), FLOOR)
            assert error.max() <= RELATIVE, f"{name}: relative difference {error.max():.3g}"


def test_option_sets_cover_every_pair_of_values():
    values = levels(TORCH_VALUES)
    for a, b in combinations(values, 2):
        met = {(getattr(o, a), getattr(o, b)) for o in OPTION_SETS}
        assert met == set(product(values[a], values[b])), (a, b)
    for name, value in alternatives():  # the toy option test's, on both backends here
        assert any(getattr(o, name) == value for o in OPTION_SETS), (name, value)
    assert len(OPTION_SETS) <= 25  # pairs, not the product (the run time stays)
    convected = [o for o in OPTION_SETS if o.slipstream == "convected" and o.induction == "coupled"]
    assert len(convected) >= 3 and any(o.n_time % 2 for o in convected)


@pytest.mark.parametrize("index", range(len(OPTION_SETS)))
def test_equal_to_numba(index):
    options = OPTION_SETS[index]
    insect = te.DRAGONFLY.with_planform(("tear-drop", "real")[index % 2])
    strokes, speed, gamma = _case(index)
    kwargs = dict(flight_path_angle=gamma, insect=insect, options=options)
    expected = te.evaluate(strokes, speed, **kwargs)
    _assert_equal(expected, te.evaluate(strokes, speed, backend="torch", **kwargs))


def test_chunks_and_tensor_conditions_give_the_same_result():
    strokes, speed, gamma = _case(99, batch=5)
    expected = te.evaluate(strokes, speed, 60.0, flight_path_angle=gamma)
    result = te.evaluate_torch(
        torch.tensor(strokes),
        torch.tensor(speed),
        torch.tensor(60.0, dtype=torch.float64),
        flight_path_angle=torch.tensor(gamma),
        chunk_size=2,
    )
    assert isinstance(result.power, torch.Tensor) and result.power.dtype == torch.float64
    assert result.induction_evaluations.dtype == torch.int64
    assert result.induction_converged.dtype == torch.bool
    _assert_equal(expected, result.to_numpy())


def test_result_fields_follow_result():
    names = {f.name for f in fields(Result)}
    assert {f.name for f in fields(torch_model.TorchResult)} == names
    assert set(torch_model.RESULT_FIELDS) == names - set(_METADATA) - set(OPTIONAL_FIELDS)


def test_float32_error_is_small():
    """float32 against float64: within 2e-5 of each field's largest magnitude in the batch."""
    strokes, speed, gamma = _case(7, batch=8)
    args = [torch.tensor(a) for a in (strokes, speed, gamma)]
    with torch.no_grad():
        exact = te.evaluate_torch(args[0], args[1], flight_path_angle=args[2])
        single = te.evaluate_torch(
            *(a.float() for a in args[:2]), flight_path_angle=args[2].float()
        )
    assert single.power.dtype == torch.float32
    for name in ("lift_to_weight", "thrust", "drag", "power", "efficiency", "fore_inflow"):
        want = getattr(exact, name)
        error = (getattr(single, name).double() - want).abs().max() / want.abs().max()
        assert error < 2e-5, f"{name}: {float(error):.3g}"


# --- gradients ------------------------------------------------------------------------------
GRADIENT_METRICS = (
    "lift_to_weight",
    "thrust",
    "drag",
    "power",
    "efficiency",
    "excess_horizontal",
    "mean_angle_of_attack",
    "fore_inflow",
    "hind_inflow",
)


def _relative_norm(got: np.ndarray, want: np.ndarray) -> float:
    """|got − want|/|want| (0 where both vanish: a wing with no inflow has none to vary)."""
    return float(np.linalg.norm(got - want) / max(np.linalg.norm(want), 1e-300))


def test_gradients_match_central_differences_of_numba():
    # two strokes whose wings both have induced velocity (so the inflow's derivatives count)
    rng = np.random.default_rng(0)
    strokes = te.normalised_to_physical(rng.uniform(-0.9, 0.9, (2, 28)))
    speed, gamma = 1.2, 0.15
    x = torch.tensor(strokes, requires_grad=True)
    result = te.evaluate_torch(x, speed, flight_path_angle=gamma)
    columns = np.flatnonzero(~DISCRETE)
    step = 1e-6 * (UPPER - LOWER)[columns]
    for b in range(strokes.shape[0]):
        probes = np.repeat(strokes[b : b + 1], 2 * columns.size, axis=0)
        probes[0::2, columns] += np.diag(step)
        probes[1::2, columns] -= np.diag(step)
        numba = te.evaluate(probes, speed, flight_path_angle=gamma)
        for name in GRADIENT_METRICS:
            (grad,) = torch.autograd.grad(getattr(result, name)[b], x, retain_graph=True)
            values = getattr(numba, name)
            central = (values[0::2] - values[1::2]) / (2.0 * step)
            error = _relative_norm(grad[b, columns].numpy(), central)
            assert error <= 1e-4, f"stroke {b}, d {name}/d stroke: relative error {error:.3g}"


def test_gradients_with_respect_to_the_condition():
    strokes = te.normalised_to_physical(np.random.default_rng(12).uniform(-0.9, 0.9, (1, 28)))
    speed, gamma, power = 0.8, -0.2, 50.0
    tensors = [
        torch.tensor(value, dtype=torch.float64, requires_grad=True)
        for value in (speed, gamma, power)
    ]
    result = te.evaluate_torch(
        torch.tensor(strokes), tensors[0], tensors[2], flight_path_angle=tensors[1]
    )
    metric = result.lift_to_weight + result.excess_horizontal + result.available_power
    grads = torch.autograd.grad(metric.sum(), tensors)
    h = (1e-6, 1e-6, 1e-4)
    for k, name in enumerate(("speed", "flight_path_angle", "available_power")):
        values = [speed, gamma, power]
        plus, minus = list(values), list(values)
        plus[k] += h[k]
        minus[k] -= h[k]
        outs = [te.evaluate(strokes, v[0], v[2], flight_path_angle=v[1]) for v in (plus, minus)]
        f = [o.lift_to_weight + o.excess_horizontal + o.available_power for o in outs]
        central = float((f[0] - f[1])[0] / (2.0 * h[k]))
        assert abs(float(grads[k]) - central) <= 1e-4 * max(abs(central), 1e-3), name


def test_value_and_grad_helper():
    strokes = torch.tensor(te.normalised_to_physical(np.zeros((2, 28))))
    values, grad = torch_model.value_and_grad(strokes, "power_per_mass", 1.0)
    x = strokes.clone().requires_grad_(True)
    result = te.evaluate_torch(x, 1.0)
    (expected,) = torch.autograd.grad(result.power_per_mass.sum(), x)
    assert torch.equal(values, result.power_per_mass.detach())
    discrete = torch.as_tensor(DISCRETE)
    assert torch.all(grad[:, discrete] == 0.0)  # N is discrete: its column is 0, as documented
    assert torch.all(expected[:, discrete] != 0.0)  # (the formula's slope in N is not)
    assert torch.allclose(grad[:, ~discrete], expected[:, ~discrete], rtol=1e-12, atol=0.0)
    actions = np.zeros((2, 28))
    _, _, jacobian = torch_model.normalised_jacobian(actions, [lambda r: r.power_per_mass], 1.0)
    assert np.all(jacobian[:, :, DISCRETE] == 0.0)


# --- bad input and the import ----------------------------------------------------------------
@pytest.mark.parametrize(
    ("strokes", "match"),
    [
        (lambda: torch.zeros(3, 27, dtype=torch.float64), r"shape \(3, 27\); allowed: \(B, 28\)"),
        (lambda: torch.ones(2, 28, dtype=torch.int64), r"dtype torch.int64; allowed"),
        (lambda: torch.ones(2, 28, dtype=torch.float16), r"dtype torch.float16; allowed"),
        (lambda: np.zeros((2, 28)), r"strokes is a ndarray; allowed: a torch.Tensor"),
        (lambda: torch.zeros(1, 28, dtype=torch.float64), r"0 Hz is outside Table 4"),
    ],
)
def test_bad_strokes(strokes, match):
    with pytest.raises(ValueError, match=match):
        te.evaluate_torch(strokes())


def test_bad_condition_tensor():
    strokes = torch.tensor(te.normalised_to_physical(np.zeros((2, 28))))
    with pytest.raises(ValueError, match=r"speed has dtype torch.int64; allowed"):
        te.evaluate_torch(strokes, torch.tensor([1, 1]))
    with pytest.raises(ValueError, match=r"speed\[1\] = 30 m/s; allowed"):
        te.evaluate_torch(strokes, torch.tensor([1.0, 30.0], dtype=torch.float64))
    with pytest.raises(ValueError, match=r"speed is on device meta; allowed: the strokes' device"):
        te.evaluate_torch(strokes, torch.ones(2, dtype=torch.float64, device="meta"))
    with pytest.raises(ValueError, match=r"strokes is on device meta; allowed: a cpu or cuda"):
        te.evaluate_torch(torch.ones(2, 28, dtype=torch.float64, device="meta"))
    with pytest.raises(ValueError, match=r"chunk_size = 0; allowed"):
        te.evaluate_torch(strokes, chunk_size=0)


def test_bad_backend_and_device():
    strokes = te.normalised_to_physical(np.zeros((1, 28)))
    with pytest.raises(ValueError, match=r"backend = 'jax'; allowed: 'numba', 'torch'"):
        te.evaluate(strokes, backend="jax")
    with pytest.raises(ValueError, match=r"device = 'cpu' with backend 'numba'"):
        te.evaluate(strokes, device="cpu")
    with pytest.raises(ValueError, match=r"device = 'tpu' is not a torch device; allowed"):
        te.evaluate(strokes, backend="torch", device="tpu")
    with pytest.raises(ValueError, match=r"device = 'meta'; allowed"):
        te.evaluate(strokes, backend="torch", device="meta")
    insect = te.DRAGONFLY.with_coefficients(fore="dickinson1999")
    with pytest.raises(ValueError, match=r"insect.fore.coefficients = 'sinusoidal'; allowed"):
        te.evaluate(strokes, backend="torch", insect=insect)


@pytest.mark.skipif(torch.cuda.is_available(), reason="CUDA is available here")
def test_cuda_without_cuda_is_refused():
    strokes = te.normalised_to_physical(np.zeros((1, 28)))
    with pytest.raises(ValueError, match=r"device = 'cuda' but CUDA is not available"):
        te.evaluate(strokes, backend="torch", device="cuda")


def test_import_does_not_import_torch():
    code = "import sys, tandem_env; assert 'torch' not in sys.modules, 'torch imported'"
    subprocess.run([sys.executable, "-c", code], check=True)


# --- CUDA (skipped without a GPU) ----------------------------------------------------------
@CUDA
def test_cuda_equal_to_numba_and_cpu():
    strokes, speed, gamma = _case(5, batch=64)
    expected = te.evaluate(strokes, speed, flight_path_angle=gamma)
    _assert_equal(
        expected,
        te.evaluate(strokes, speed, flight_path_angle=gamma, backend="torch", device="cuda"),
    )


@CUDA
def test_cuda_gradient_equals_cpu_gradient():
    strokes = torch.tensor(
        te.normalised_to_physical(np.random.default_rng(3).uniform(-0.9, 0.9, (4, 28)))
    )
    _, cpu = torch_model.value_and_grad(strokes, "power", 1.0)
    _, gpu = torch_model.value_and_grad(strokes.cuda(), "power", 1.0)
    assert gpu.device.type == "cuda"
    np.testing.assert_allclose(gpu.cpu().numpy(), cpu.numpy(), rtol=1e-8, atol=1e-14)


def test_gradients_under_the_convected_slipstream():
    """Autograd through the convected slipstream (docs/model.md §5.7: the fore-wing's shed
    loading, its Fourier series and the delay) against central differences of the numba model."""
    rng = np.random.default_rng(4)
    strokes = te.normalised_to_physical(rng.uniform(-0.9, 0.9, (1, 28)))
    options = te.ModelOptions(slipstream="convected")
    speed = 0.9
    x = torch.tensor(strokes, requires_grad=True)
    result = te.evaluate_torch(x, speed, options=options)
    mean = te.evaluate(strokes, speed)
    assert abs(result.hind_lift_to_weight.detach()[0].item() - mean.hind_lift_to_weight[0]) > 1e-3
    columns = np.flatnonzero(~DISCRETE)
    step = 1e-6 * (UPPER - LOWER)[columns]
    probes = np.repeat(strokes, 2 * columns.size, axis=0)
    probes[0::2, columns] += np.diag(step)
    probes[1::2, columns] -= np.diag(step)
    numba = te.evaluate(probes, speed, options=options)
    for name in ("lift_to_weight", "power", "hind_inflow"):
        (grad,) = torch.autograd.grad(getattr(result, name)[0], x, retain_graph=True)
        values = getattr(numba, name)
        central = (values[0::2] - values[1::2]) / (2.0 * step)
        error = _relative_norm(grad[0, columns].numpy(), central)
        assert error <= 1e-4, f"d {name}/d stroke: relative error {error:.3g}"


def test_convected_slipstream_gradients_in_hover_where_the_fore_wing_has_no_inflow():
    """In hover (tangential speed 0) a fore-wing with no induced velocity sends the hind-wing a
    wake whose through-flow speed is 0 at every sample: the square root there once had an
    infinite slope, and 0·∞ made every entry of the stroke's gradient NaN (12 of these 64)."""
    rng = np.random.default_rng(0)
    strokes = te.normalised_to_physical(rng.uniform(-1.0, 1.0, (64, 28)))
    options = te.ModelOptions(slipstream="convected")
    x = torch.tensor(strokes, requires_grad=True)
    result = te.evaluate_torch(x, 0.0, options=options)
    (gradient,) = torch.autograd.grad(result.power.sum(), x, retain_graph=True)
    still = np.flatnonzero(result.fore_inflow.detach().numpy() == 0.0)
    assert still.size >= 5  # the case this test is about occurs
    assert torch.isfinite(gradient).all()
    columns = np.flatnonzero(~DISCRETE)
    step = 1e-6 * (UPPER - LOWER)[columns]
    for b in still[:2]:
        probes = np.repeat(strokes[b : b + 1], 2 * columns.size, axis=0)
        probes[0::2, columns] += np.diag(step)
        probes[1::2, columns] -= np.diag(step)
        numba = te.evaluate(probes, 0.0, options=options)
        for name in ("lift_to_weight", "power"):
            (grad,) = torch.autograd.grad(getattr(result, name)[b], x, retain_graph=True)
            values = getattr(numba, name)
            central = (values[0::2] - values[1::2]) / (2.0 * step)
            error = _relative_norm(grad[b, columns].numpy(), central)
            assert error <= 1e-4, f"stroke {b}, d {name}/d stroke: relative error {error:.3g}"
