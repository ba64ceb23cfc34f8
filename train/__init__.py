"""Training of Stable-Baselines3 agents (PPO, SAC) on the tandem-wing envs (docs/training.md):
``python -m train --algo sac --env TandemWing/LevelFlight-v0`` with the zoo-format
hyperparameters in ``train/hyperparams/``; :func:`train.run.train` is the same from Python.
The package itself imports nothing.
"""
