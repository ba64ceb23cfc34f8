"""The optimiser configs' records and the job keys do not change when their boilerplate moves:
a config's ``to_dict`` goes into every record, and a job's key names its stored result."""

from __future__ import annotations

import json
from importlib.metadata import version

import pytest

from agents.cmaes_search import CMAESConfig
from agents.jobs import Job
from agents.methods import available_methods, get_method, providers
from agents.pso import PSOConfig
from agents.random_search import RandomSearchConfig

CMAES = f"cmaes {version('cmaes')}"
CMAES_CITATION = (
    "CMA-ES (Hansen 2016, arXiv:1604.00772) with margin for discrete coordinates (Hamano et al. "
    f"2022, Proc. GECCO pp. 639-647), cmaes package {version('cmaes')} (Nomura & Shibata 2024, "
    "arXiv:2402.01373); BIPOP restarts (Hansen 2009, Proc. GECCO companion pp. 2389-2396)"
)
CMAES_RULES = {
    "popsize_factor": 2,
    "bounds": "redraw up to `resampling` times, then clip onto [-1, 1] (cmaes)",
    "package": CMAES,
    "citation": CMAES_CITATION,
}
PSO_CITATION = {
    "constriction": "global-best PSO (Kennedy & Eberhart 1995) with Clerc & Kennedy (2002) "
    "constriction coefficients in inertia-weight form (chi = 0.72984 for phi = 4.1; IEEE Trans. "
    "Evol. Comput. 6(1):58-73): w = 0.7298, c1 = 1.49618, c2 = 1.49618",
    "linear": "global-best PSO (Kennedy & Eberhart 1995) with linearly decreasing inertia weight "
    "(Shi & Eberhart 1998, Proc. IEEE ICEC pp. 69-73; 0.9 -> 0.4 schedule of Shi & Eberhart "
    "1999, Proc. CEC pp. 1945-1950): w = 0.9 -> 0.4 linearly, c1 = 1.0, c2 = 2.0 (cognitive "
    "overridden)",
}
RANDOM_CITATION = "uniform random search over [-1, 1]^d (i.i.d. samples, no adaptation; baseline)"

#: (config, its to_dict as the configs wrote it before their boilerplate was derived).
CONFIGS = [
    (
        PSOConfig(max_evaluations=100),
        {
            "algorithm": "pso",
            "swarm_size": 40,
            "inertia": "constriction",
            "inertia_weight": 0.7298,
            "cognitive": 1.49618,
            "social": 1.49618,
            "velocity_clamp": 0.5,
            "boundary": "clip",
            "max_evaluations": 100,
            "citation": PSO_CITATION["constriction"],
        },
    ),
    (
        PSOConfig(
            max_evaluations=50,
            swarm_size=10,
            inertia="linear-decreasing",
            cognitive=1.0,
            boundary="reflect",
        ),
        {
            "algorithm": "pso",
            "swarm_size": 10,
            "inertia": "linear-decreasing",
            "inertia_weight": [0.9, 0.4],
            "cognitive": 1.0,
            "social": 2.0,
            "velocity_clamp": 0.5,
            "boundary": "reflect",
            "max_evaluations": 50,
            "citation": PSO_CITATION["linear"],
        },
    ),
    (
        RandomSearchConfig(max_evaluations=7, batch_size=3),
        {
            "algorithm": "random-search",
            "batch_size": 3,
            "max_evaluations": 7,
            "citation": RANDOM_CITATION,
        },
    ),
    (
        CMAESConfig(max_evaluations=100, discrete=((0, 3), (2, 4))),
        {
            "algorithm": "cmaes",
            "max_evaluations": 100,
            "popsize": None,
            "sigma0": 0.5,
            "restarts": "bipop",
            "patience": None,
            "tolerance": 0.0001,
            "resampling": 100,
            "discrete": [[0, 3], [2, 4]],
            "popsize_rule": "4 (4 + floor(3 ln d))",
            "patience_rule": "120 + ceil(30 d / popsize)",
            **CMAES_RULES,
        },
    ),
    (
        CMAESConfig(max_evaluations=100, popsize=8, patience=5, sigma0=0.3),
        {
            "algorithm": "cmaes",
            "max_evaluations": 100,
            "popsize": 8,
            "sigma0": 0.3,
            "restarts": "bipop",
            "patience": 5,
            "tolerance": 0.0001,
            "resampling": 100,
            "discrete": [],
            "popsize_rule": "given",
            "patience_rule": "given",
            **CMAES_RULES,
        },
    ),
]


@pytest.mark.parametrize(("config", "expected"), CONFIGS)
def test_config_records_are_unchanged(config: object, expected: dict[str, object]) -> None:
    """Same keys and values, plain JSON (a record stores it as it is; records and their
    checksums read JSON objects, whose key order is no part of them)."""
    found = config.to_dict()  # type: ignore[attr-defined]
    assert json.dumps(found, sort_keys=True) == json.dumps(expected, sort_keys=True)
    assert type(config.build(3, 0).config) is type(config)  # type: ignore[attr-defined]


def test_job_keys_are_unchanged() -> None:
    """A job's key names its stored record: the keys computed before the change."""
    jobs = [
        Job("pso", "level", 1.5, 400, 0),
        Job(
            "cmaes",
            "accelerate",
            20.0,
            1000,
            3,
            env_kwargs={"objective": "horizontal"},
            method_config={"popsize": 8},
        ),
        Job("random", "level", 1.0, 40, 1, method_config={"batch_size": 20}, preset="quick"),
    ]
    # as they were before the key held the model's revision, and with revision 1's
    keys = ["b3749d1d905831c6126e", "e061e240443fa3186df2", "45084073cc37364f33b1"]
    assert [job.key_at("0.2.0", None) for job in jobs] == keys
    keys = ["7a9ff059f0afcb296e09", "fcdbc5209edadaef5ed0", "d7b8d5f57c4289cd11eb"]
    assert [job.key_at("0.2.0", 1) for job in jobs] == keys


def test_one_registry_names_every_method() -> None:
    """The built-in optimisers, the training package's methods and plug-ins share one registry;
    a built-in optimiser's settings are its config's fields."""
    assert {"pso", "random", "cmaes", "ppo", "sac", "policy"} <= set(available_methods())
    # the built-in optimisers come as a plug-in's do: named by the module that registers them
    modules = {
        "pso": "agents.pso",
        "random": "agents.random_search",
        "cmaes": "agents.cmaes_search",
    }
    assert {name: providers()[name] for name in modules} == modules
    assert providers()["ppo"] == "train.policies"
    method = get_method("random", {"batch_size": 5})
    assert method.config(12).to_dict()["batch_size"] == 5  # type: ignore[attr-defined]
    with pytest.raises(ValueError, match="unknown setting"):
        get_method("pso", {"no_such_setting": 1})
