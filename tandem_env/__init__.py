"""tandem_env: the tandem flapping-wing model of Faisal & Filippone (2016) and its Gymnasium envs."""

from .physics import *  # noqa: F403
from .physics import __all__ as _physics_all

__all__ = list(_physics_all)
__version__ = "0.2.0"

# Register the Gymnasium ids (TandemWing/LevelFlight-v0, TandemWing/Accelerate-v0,
# TandemWing/SpeedChange-v0).
from .envs.registration import register_envs as _register_envs

_register_envs()

# The reference optima and the normalised score (docs/reference.md).
from .envs.reference import normalised_score, reference  # noqa: E402  (after the ids' registration)

__all__ += ["normalised_score", "reference"]


def __getattr__(name: str):
    """``evaluate_torch`` and ``TorchResult`` (the torch backend), imported on first use."""
    from . import physics

    if name in physics._TORCH_NAMES:
        return getattr(physics, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
