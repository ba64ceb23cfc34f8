"""The reproduction studies of the paper's figures, run on the harness: ``python -m eval study``
(:mod:`eval.study`), :func:`eval.studies.suite.run_studies` from Python."""

from __future__ import annotations

from types import ModuleType

from eval.studies import convergence, kinematics, power, speed, wing_shape

#: The studies of ``study all`` (the paper's figures), in report order.
PAPER_STUDIES: dict[str, ModuleType] = {m.NAME: m for m in (speed, power, kinematics, wing_shape)}
#: Every study the command line offers.
STUDIES: dict[str, ModuleType] = {**PAPER_STUDIES, convergence.NAME: convergence}

__all__ = ["PAPER_STUDIES", "STUDIES"]
