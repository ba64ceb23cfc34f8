"""Optimisers over the normalised box [-1, 1]^d and result-record I/O."""

from agents.optimiser import OptimisationResult, Progress, maximise, minimise
from agents.pso import PSO, PSOConfig
from agents.random_search import RandomSearch, RandomSearchConfig
from agents.records import package_versions, read_json, write_csv_atomic, write_json_atomic

__all__ = [
    "PSO",
    "OptimisationResult",
    "PSOConfig",
    "Progress",
    "RandomSearch",
    "RandomSearchConfig",
    "maximise",
    "minimise",
    "package_versions",
    "read_json",
    "write_csv_atomic",
    "write_json_atomic",
]
