"""Optimisers over the normalised box [-1, 1]^d, the harness that runs them on the tasks, and
result-record I/O.

The optimisers (``PSO``, ``RandomSearch``, ``maximise``) import only numpy. The harness names
(``run``, ``Record``, ``register_method``, ...) are imported on first use, because they
import Gymnasium and the model.
"""

from importlib import import_module
from typing import Any

from agents.fileio import read_json, to_jsonable, write_csv_atomic, write_json_atomic
from agents.optimiser import OptimisationResult, Progress, maximise, minimise
from agents.pso import PSO, PSOConfig
from agents.random_search import RandomSearch, RandomSearchConfig

# name -> module, for the lazily imported harness API.
_LAZY = {
    "run": "agents.harness",
    "prepare": "agents.harness",
    "run_job": "agents.harness",
    "prepare_job": "agents.harness",
    "PreparedJob": "agents.harness",
    "Job": "agents.records",
    "Record": "agents.records",
    "RecordStore": "agents.records",
    "load_records": "agents.records",
    "package_versions": "agents.records",
    "Method": "agents.methods",
    "SearchContext": "agents.methods",
    "SearchOutcome": "agents.methods",
    "available_methods": "agents.methods",
    "get_method": "agents.methods",
    "register_method": "agents.methods",
    "Condition": "agents.tasks",
    "TaskSpec": "agents.tasks",
    "get_task": "agents.tasks",
    "register_task": "agents.tasks",
}

__all__ = [
    "PSO",
    "Condition",
    "Job",
    "Method",
    "OptimisationResult",
    "PSOConfig",
    "PreparedJob",
    "Progress",
    "RandomSearch",
    "RandomSearchConfig",
    "Record",
    "RecordStore",
    "SearchContext",
    "SearchOutcome",
    "TaskSpec",
    "available_methods",
    "get_method",
    "get_task",
    "load_records",
    "maximise",
    "minimise",
    "package_versions",
    "prepare",
    "prepare_job",
    "read_json",
    "register_method",
    "register_task",
    "run",
    "run_job",
    "to_jsonable",
    "write_csv_atomic",
    "write_json_atomic",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'agents' has no attribute {name!r}")
    return getattr(import_module(module), name)
