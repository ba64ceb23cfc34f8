"""The default pipeline ends at certified optima on every listed flyer (docs/harness.md,
"Certified, and what an uncertified number means"): level flight at 1.5 m/s, CMA-ES with its
polish (the harness defaults) at the documented budget of 16 000 evaluations, seeds 0 and 1.
Certified: feasible, the polish converged, the KKT residual at the reported stroke <= 1e-4."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from agents.harness import run
from agents.polish import certified
from tandem_env.envs.config import insect_keyword

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
#: The listed flyers (docs/harness.md): the paper's specimen, two example files and the specimen
#: 1.5 times as heavy (what a file holding only ``body_mass: 182.85e-6`` gives).
FLYERS: dict[str, Any] = {
    "paper": None,
    "orthetrum": EXAMPLES / "orthetrum_cancellatum.yaml",
    "scaled": EXAMPLES / "scaled_dragonfly.yaml",
    "heavier": {"body_mass": 182.85e-6},
}


@pytest.mark.slow
@pytest.mark.parametrize("flyer", FLYERS)
def test_the_default_pipeline_certifies_level_flight_on_every_listed_flyer(flyer: str) -> None:
    source = FLYERS[flyer]
    options = {} if source is None else {"env_kwargs": {"insect": insect_keyword(source)}}
    for record in run("cmaes", "level", 1.5, 16_000, [0, 1], progress=False, **options):
        seed, c = record.job.seed, record.certificate
        assert record.feasible and record.evaluations <= 16_000, (flyer, seed)
        assert certified(c), (flyer, seed, c)
