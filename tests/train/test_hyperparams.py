"""The zoo-format hyperparameter files and the key=value parsing of the CLI."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from tandem_env.envs.registration import env_ids
from tandem_env.io.keyvalue import parse_pairs, parse_value
from train.config import (
    ALGOS,
    HYPERPARAMS_DIR,
    MAX_NETWORK_PARAMETERS,
    TrainConfig,
    eval_policy_kwargs,
    load_entry,
    network_parameters,
    resolve_hyperparams,
)


@pytest.mark.parametrize("algo", ALGOS)
def test_yml_has_default_and_both_env_ids(algo: str) -> None:
    with (HYPERPARAMS_DIR / f"{algo}.yml").open() as stream:
        entries = yaml.safe_load(stream)  # what rl_zoo3 uses
    assert "default" in entries
    for env_id in env_ids():
        assert env_id in entries
    for name, entry in entries.items():
        # The zoo's own keys, as the zoo spells them.
        for key in ("n_envs", "n_timesteps", "policy", "policy_kwargs"):
            assert key in entry, f"{algo}.yml {name}: {key} missing"
        assert isinstance(entry["policy_kwargs"], str)
        hp = resolve_hyperparams(entry, algo=algo)
        assert hp.n_envs >= 1 and hp.n_timesteps >= 1
        assert hp.policy == "MlpPolicy"


@pytest.mark.filterwarnings("ignore:You have specified a mini-batch size")
@pytest.mark.parametrize("algo", ALGOS)
def test_entries_build_models(algo: str) -> None:
    from tandem_env.envs.sb3 import make_sb3_vec_env
    from train.run import build_model

    for env_id in env_ids():
        hp = resolve_hyperparams(load_entry(algo, env_id), algo=algo, n_envs=2)
        venv = make_sb3_vec_env(env_id, n_envs=2, seed=0)
        model = build_model(algo, hp, venv, seed=0, tensorboard_log=None, verbose=0, device="cpu")
        assert model.n_envs == 2
        # The count the size limit refuses by is a lower bound of what SB3 builds.
        built = sum(p.numel() for p in model.policy.parameters())
        assert 0 < network_parameters(hp.policy_kwargs["net_arch"]) <= built
        venv.close()


@pytest.mark.parametrize(
    ("arch", "refused"),
    [
        ([4_000_000_000], True),  # a mistyped size: refused, not an allocator error
        ({"pi": [64], "vf": [20_000, 20_000]}, True),
        ({"pi": [8_000], "vf": [8_000, 8_000]}, False),  # 64 048 002 weights at least
    ],
)
def test_a_network_beyond_the_size_limit_is_refused_before_it_is_built(
    arch: list | dict, refused: bool
) -> None:
    entry = load_entry("ppo", env_ids()[0])
    overrides = {"policy_kwargs": f"dict(net_arch={arch!r})"}
    assert (network_parameters(arch) > MAX_NETWORK_PARAMETERS) is refused
    if refused:
        with pytest.raises(ValueError, match=r"has at least [\d,]+ weights; allowed: networks"):
            resolve_hyperparams(entry, overrides, algo="ppo")
    else:
        assert resolve_hyperparams(entry, overrides, algo="ppo").policy_kwargs["net_arch"] == arch


def test_parse_values_like_the_zoo() -> None:
    pairs = parse_pairs(
        ["speed=1.5", "speed_range:(0.25, 2.0)", "thrust_split=body", "clip_actions=True"],
        "--env-kwargs",
    )
    assert pairs == {
        "speed": 1.5,
        "speed_range": (0.25, 2.0),
        "thrust_split": "body",
        "clip_actions": True,
    }
    assert parse_value("1e5") == 100000.0
    assert parse_value("lin_1e-3") == "lin_1e-3"
    assert parse_value("dict(net_arch=[64])") == "dict(net_arch=[64])"
    with pytest.raises(ValueError, match="key=value"):
        parse_pairs(["speed"], "--env-kwargs")
    with pytest.raises(ValueError, match="twice"):
        parse_pairs(["a=1", "a=2"], "--hyperparams")


def test_policy_kwargs_strings_are_restricted() -> None:
    kwargs = eval_policy_kwargs("dict(net_arch=[64, 64], activation_fn=nn.ReLU)")
    assert kwargs["net_arch"] == [64, 64]
    with pytest.raises(ValueError, match="allowed names"):
        eval_policy_kwargs("dict(x=__import__('os'))")
    assert eval_policy_kwargs("dict(optimizer_class=th.optim.RMSprop)")["optimizer_class"]
    # Nothing runs: an attribute path to a function (torch imports os) is refused, not called.
    for text in ("dict(x=torch.os.getcwd())", "dict(x=th.load)", "dict(x=nn.ReLU())"):
        with pytest.raises(ValueError, match="allowed names"):
            eval_policy_kwargs(text)
    with pytest.raises(ValueError, match="not a Python expression"):
        eval_policy_kwargs("dict(x=" + "[" * 100_000 + "]" * 100_000 + ")")


def test_schedules_and_overrides() -> None:
    entry = load_entry("ppo", env_ids()[0])
    hp = resolve_hyperparams(
        entry, {"learning_rate": "lin_1e-3"}, algo="ppo", n_envs=8, n_timesteps=64
    )
    assert hp.n_envs == 8 and hp.n_timesteps == 64
    schedule = hp.model_kwargs["learning_rate"]
    assert schedule(1.0) == pytest.approx(1e-3) and schedule(0.0) == pytest.approx(0.0)
    with pytest.raises(ValueError, match="does not implement"):
        resolve_hyperparams(entry, {"frame_stack": 4}, algo="ppo")


def test_train_config_validates() -> None:
    with pytest.raises(ValueError, match="allowed: ppo, sac"):
        TrainConfig(algo="dqn", env_id=env_ids()[0])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="n_timesteps"):
        TrainConfig(algo="ppo", env_id=env_ids()[0], n_timesteps=0)
    with pytest.raises(ValueError, match="not both"):
        TrainConfig(algo="ppo", env_id=env_ids()[0], resume=True, run_dir="logs/x")


@pytest.mark.parametrize(
    ("override", "match"),
    [
        # SB3 took these unchecked: a diverging return, a crash after the first rollout
        ({"gamma": 2}, r"gamma = 2; allowed: a number from 0 to 1"),
        ({"gamma": float("nan")}, r"gamma = nan; allowed"),
        ({"n_epochs": 0}, r"n_epochs = 0; allowed: an integer from 1"),
        ({"batch_size": 1.5}, r"batch_size = 1.5; allowed: an integer from 1"),
        ({"ent_coef": -1}, r"ent_coef = -1; allowed: a number from 0"),
        ({"n_envs": 10**6}, r"n_envs = 1000000; allowed: an integer from 1 to 10,000"),
        ({"n_timesteps": 2**63}, r"n_timesteps = 9223372036854775808; allowed: .* to 1,000,000"),
        ({"policy_kwargs": "dict(net_arch=[0])"}, r"net_arch = \[0\]; allowed: a list of layer"),
        ({"policy_kwargs": {"net_arch": {"pi": [64], "vf": [-1]}}}, r"net_arch = .*'vf': \[-1\]"),
    ],
)
def test_hyperparameters_out_of_range_are_named(override: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        resolve_hyperparams({"n_timesteps": 64, **override}, algo="ppo")


def test_sac_entropy_auto_and_the_shipped_entries_pass_the_ranges() -> None:
    assert resolve_hyperparams({"n_timesteps": 64, "ent_coef": "auto_0.1"}, algo="sac")
    for algo in ALGOS:
        for env_id in env_ids():
            assert resolve_hyperparams(load_entry(algo, env_id), algo=algo).n_timesteps >= 1


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (b"::: [[[\n", r"is not plain YAML \(while parsing"),
        (b"a: !!python/object/apply:os.system ['true']\n", r"is not plain YAML .*python/object"),
        (b"\xff\x00", r"is not UTF-8 text \(byte 0\)"),
    ],
)
def test_a_hyperparameter_file_that_is_not_yaml_is_named(tmp_path, text: bytes, match: str) -> None:
    path = tmp_path / "conf.yml"
    path.write_bytes(text)
    with pytest.raises(ValueError, match=rf"hyperparameter file {path} {match}"):
        load_entry("ppo", env_ids()[0], path)


def test_verbose_beyond_debug_is_refused() -> None:
    with pytest.raises(ValueError, match="verbose = 9; allowed: 0 quiet, 1 info, 2 debug"):
        TrainConfig(algo="ppo", env_id=env_ids()[0], verbose=9)


def test_an_alias_bomb_in_a_run_folder_or_hyperparameter_file_is_refused(tmp_path: Path) -> None:
    """The run folder's YAML and a zoo hyperparameter file are read with the bounded loader: a
    few lines that expand to 10**9 items are refused naming the file, not built."""
    from train.config import load_hyperparams_file
    from train.saved import parse_run_yaml

    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 9)]
    bomb = tmp_path / "args.yml"
    bomb.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"args\.yml is not readable YAML.*expands to more than"):
        parse_run_yaml(bomb.read_text(encoding="utf-8"), bomb)
    with pytest.raises(ValueError, match=r"args\.yml is not plain YAML.*expands to more than"):
        load_hyperparams_file(bomb)
