"""Training of Stable-Baselines3 agents (PPO, SAC) on the tandem-wing envs (docs/training.md):
``python -m train --algo sac --env TandemWing/LevelFlight-v0`` with the zoo-format
hyperparameters in ``train/hyperparams/`` (``envelope/`` holds those tuned for a policy over the
whole envelope by ``python -m train.tune``); :func:`train.run.train` is the same from Python.
Stable-Baselines3 and torch are imported only by the submodules that need them; the package
itself imports nothing.
"""
