"""``python -m train.tune``: the search space, the shipped first trial, bad input, a tiny
study end to end and its resumption."""

from __future__ import annotations

import csv
import importlib.util
import subprocess
import sys

import pytest

from train.config import load_entry, load_hyperparams_file, resolve_hyperparams
from train.tune import SEARCH_SPACES, SHIPPED, TuneConfig, overrides, tune

#: The tests that run a study need Optuna; the others check what ships without it.
needs_optuna = pytest.mark.skipif(
    importlib.util.find_spec("optuna") is None,
    reason='Optuna (the tune extra) is not installed: pip install -e ".[tune]"',
)

ENV = "TandemWing/LevelFlight-v0"
ENVELOPE = {"speed_range": (0.25, 2.0)}


def _resolved(algo: str, params: dict | None) -> dict:
    hp = resolve_hyperparams(
        load_entry(algo, ENV), None if params is None else overrides(algo, params), algo=algo
    )
    kwargs = dict(hp.model_kwargs)
    rate = kwargs.pop("learning_rate")
    # a schedule is a function: compare its values over the run instead
    rates = [rate(p) if callable(rate) else rate for p in (1.0, 0.5, 0.0)]
    return {"n_envs": hp.n_envs, "policy_kwargs": dict(hp.policy_kwargs), "rates": rates, **kwargs}


@pytest.mark.parametrize("algo", sorted(SEARCH_SPACES))
def test_the_first_trial_is_the_shipped_entry(algo):
    assert set(SHIPPED[algo]) == set(SEARCH_SPACES[algo])
    assert _resolved(algo, dict(SHIPPED[algo])) == _resolved(algo, None)


@pytest.mark.parametrize("algo", sorted(SEARCH_SPACES))
def test_every_value_of_the_search_space_is_a_valid_entry(algo):
    # each value (each end of a range) of each parameter, the others shipped; then all the
    # first values and all the last ones together
    space = SEARCH_SPACES[algo]
    points = [
        {**SHIPPED[algo], name: value} for name, (_, values) in space.items() for value in values
    ]
    points += [{n: values[end] for n, (_, values) in space.items()} for end in (0, -1)]
    for params in points:
        hp = resolve_hyperparams(load_entry(algo, ENV), overrides(algo, params), algo=algo)
        assert hp.model_kwargs["batch_size"] == params["batch_size"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"algo": "a2c"}, "algo = 'a2c'; allowed: ppo, sac"),
        ({"env_id": "TandemWing/SpeedChange-v0"}, "no reference table"),
        ({"trials": 0}, "--trials 0; allowed: an integer from 1 to"),
        ({"steps": 0}, "--steps 0; allowed: an integer from 1 to"),
        ({"seed": -1}, "--seed = -1; allowed: an integer from 0 to 2"),
        ({"seed": 2**32}, "--seed = 4294967296; allowed: an integer from 0 to 2"),
        ({"env_kwargs": {"wingspan": 3}}, "unknown argument.*'wingspan'"),
    ],
)
def test_bad_settings_are_refused_before_training(tmp_path, change, message):
    given = {"algo": "ppo", "env_id": ENV, "env_kwargs": ENVELOPE, "trials": 1, "steps": 1024,
             "seed": 0, "out": tmp_path / "study"} | change  # fmt: skip
    with pytest.raises(ValueError, match=message):
        tune(TuneConfig(**given), say=lambda _: None)
    assert not (tmp_path / "study").exists()


@needs_optuna
def test_the_command_line_refuses_bad_input_with_a_usage_error(tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "train.tune", "--algo", "ppo", "--trials", "0", "--steps", "10",
         "--out", str(tmp_path / "x")],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 2
    assert "--trials 0; allowed: an integer from 1 to" in done.stderr


@needs_optuna
def test_a_tiny_study_writes_its_trials_and_best_entry_and_resumes(tmp_path):
    out = tmp_path / "study"
    config = TuneConfig("ppo", ENV, ENVELOPE, trials=2, steps=1024, seed=0, out=out)
    said: list[str] = []
    study = tune(config, say=said.append)
    with open(out / "trials.csv", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert [r["trial"] for r in rows] == ["0", "1"]
    assert float(rows[0]["learning_rate"]) == SHIPPED["ppo"]["learning_rate"]
    assert len(rows[0]["scores"].split()) == 8  # the training speeds 0.25, 0.5, ..., 2.0
    best = study.best_trial
    assert float(rows[best.number]["median_score"]) == pytest.approx(best.value, abs=1e-3)
    # the best entry is a zoo file that python -m train reads, with the best overrides
    entry = load_hyperparams_file(out / "ppo.yml")[ENV]
    assert entry["n_epochs"] == best.params["n_epochs"]
    resolve_hyperparams(entry, algo="ppo")
    assert "python -m train.tune --algo ppo" in (out / "ppo.yml").read_text()
    # the same command with more trials runs only the new one, and proposes a new point
    study = tune(
        TuneConfig("ppo", ENV, ENVELOPE, trials=3, steps=1024, seed=0, out=out), say=said.append
    )
    assert len(study.trials) == 3
    assert study.trials[2].params != study.trials[1].params
    assert "1 of 3 trials left" in said[-2]


@pytest.mark.parametrize("algo", sorted(SEARCH_SPACES))
def test_the_shipped_envelope_files_are_the_tuners_output_and_the_docs_quote_them(algo):
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    path = root / "train" / "hyperparams" / "envelope" / f"{algo}.yml"
    text = path.read_text(encoding="utf-8")
    assert f"python -m train.tune --algo {algo} --env {ENV}" in text
    entry = load_hyperparams_file(path)[ENV]
    resolve_hyperparams(entry, algo=algo)  # what python -m train --conf-file reads
    (best,) = [line for line in text.splitlines() if line.startswith("# Best: trial")]
    # the trial and its median score, as docs/training.md "Tuning for the envelope" says
    said = best.removeprefix("# Best: ").split(" at the training")[0]
    assert f"{algo.upper()}: {said}" in (root / "docs" / "training.md").read_text(encoding="utf-8")


@needs_optuna
def test_a_folder_holding_a_study_of_other_settings_is_refused(tmp_path):
    from train.tune import open_study

    out = tmp_path / "study"
    open_study(TuneConfig("ppo", ENV, ENVELOPE, trials=1, steps=1024, seed=0, out=out))
    with pytest.raises(
        ValueError, match=r"holds the study 'ppo-.*-1024-seed0-.*' of other settings"
    ):
        open_study(TuneConfig("ppo", ENV, ENVELOPE, trials=1, steps=2048, seed=0, out=out))
    # the same settings continue it
    open_study(TuneConfig("ppo", ENV, ENVELOPE, trials=2, steps=1024, seed=0, out=out))


# --- a hostile journal and env options the table does not cover ----------------------------------
def test_env_options_the_table_does_not_cover_are_refused_as_by_amortised_training(tmp_path):
    """The trials are scored against the reference table: n_time=64 would train a whole trial to
    a NaN score. The check is train.amortised.table_series, the amortised training's own."""
    from train.amortised import check_env_kwargs

    with pytest.raises(ValueError) as amortised:
        check_env_kwargs(ENV, {"n_time": 64})
    with pytest.raises(ValueError) as tuned:
        TuneConfig("ppo", ENV, {**ENVELOPE, "n_time": 64}, 1, 1024, 0, tmp_path / "study")
    assert "change the problem the reference table describes" in str(amortised.value)
    together = "'speed_range': (0.25, 2.0), 'n_time': 64"
    assert str(tuned.value) == str(amortised.value).replace("'n_time': 64", together)
    assert not (tmp_path / "study").exists()


def _journal_with(tmp_path, params, value, scores, distributions=None):
    """A study journal of the tiny config holding one finished trial made by hand."""
    import optuna

    config = TuneConfig("ppo", ENV, ENVELOPE, trials=1, steps=1024, seed=0, out=tmp_path / "s")
    config.out.mkdir()
    storage = optuna.storages.JournalStorage(
        optuna.storages.journal.JournalFileBackend(str(config.out / "study.journal"))
    )
    study = optuna.create_study(study_name=config.study_name, storage=storage,
                                direction="maximize")  # fmt: skip
    if distributions is None:
        distributions = {
            name: optuna.distributions.CategoricalDistribution(values)
            if kind == "choice"
            else optuna.distributions.FloatDistribution(*values, log=kind == "log")
            for name, (kind, values) in SEARCH_SPACES["ppo"].items()
        }
    study.add_trial(
        optuna.trial.create_trial(params=params, distributions=distributions, value=value,
                                  user_attrs={"scores": scores, "seconds": 1.0})
    )  # fmt: skip
    return config


SCORES = [50.0, 60.0, 70.0, 80.0, 80.0, 90.0, 95.0, 99.0]  # median 80


@needs_optuna
@pytest.mark.parametrize(
    ("params", "value", "scores", "match"),
    [
        # a forged best: a value its own scores do not give
        (SHIPPED["ppo"], 250.0, SCORES, r"its value 250.0 is not the median of 8 finite scores"),
        (SHIPPED["ppo"], 80.0, SCORES[:3], r"its value 80.0 is not the median of 8 finite"),
        (SHIPPED["ppo"], 80.0, [*SCORES[:7], float("nan")], r"is not the median of 8 finite"),
        (SHIPPED["ppo"], float("inf"), SCORES, r"its value inf is not the median"),
        # a trial of another search space
        ({"x": 1.0}, 80.0, SCORES, r"its parameters \['x'\] are not the search space's"),
        ({**SHIPPED["ppo"], "n_steps": 3}, 80.0, SCORES, r"n_steps = 3 is outside the search"),
    ],
)
def test_a_foreign_or_forged_trial_in_the_journal_is_refused(tmp_path, params, value, scores,
                                                             match):  # fmt: skip
    import optuna

    from train.tune import open_study

    distributions = None
    if set(params) != set(SHIPPED["ppo"]) or params.get("n_steps") == 3:
        distributions = {
            k: optuna.distributions.CategoricalDistribution((v, 2, 4, 8)) for k, v in params.items()
        }
    config = _journal_with(tmp_path, dict(params), value, scores, distributions)
    journal = config.out / "study.journal"
    before = journal.read_bytes()
    with pytest.raises(ValueError, match=match) as info:
        open_study(config)
    assert str(info.value).startswith(f"{journal}: trial 0 is not one this tuner recorded")
    assert journal.read_bytes() == before


@needs_optuna
def test_a_trial_the_objective_recorded_is_accepted(tmp_path):
    from train.tune import open_study

    config = _journal_with(tmp_path, dict(SHIPPED["ppo"]), 80.004, SCORES)
    assert open_study(config).best_trial.value == pytest.approx(80.004)


@needs_optuna
@pytest.mark.parametrize(
    "damage",
    ["{not json\n", '{"op_code": 99}\n', "[1]\n", b"\xff\xfe\n", '{"op_code": 4, "x": 1}\n'],
)
def test_a_damaged_journal_is_refused_naming_it(tmp_path, damage):
    from train.tune import open_study

    config = _journal_with(tmp_path, dict(SHIPPED["ppo"]), 80.0, SCORES)
    journal = config.out / "study.journal"
    with journal.open("ab") as handle:
        handle.write(damage if isinstance(damage, bytes) else damage.encode())
    before = journal.read_bytes()
    with pytest.raises(ValueError, match=rf"^{journal}: (not an Optuna journal as|its operations)"):
        open_study(config)
    assert journal.read_bytes() == before


@needs_optuna
def test_a_write_a_kill_cut_short_is_named_with_the_way_out(tmp_path):
    """Optuna's reader skips a last line without its newline, but its next write would be
    appended to it: refused, saying which line to remove; without it the study continues."""
    from train.tune import open_study

    config = _journal_with(tmp_path, dict(SHIPPED["ppo"]), 80.0, SCORES)
    journal = config.out / "study.journal"
    whole = journal.read_text(encoding="utf-8")
    journal.write_text(whole + '{"op_code": 5, "trial_id"', encoding="utf-8")
    with pytest.raises(ValueError, match=r"its last line is cut short .*remove that line"):
        open_study(config)
    journal.write_text(whole, encoding="utf-8")
    assert len(open_study(config).trials) == 1
