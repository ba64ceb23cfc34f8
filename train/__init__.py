"""Training of Stable-Baselines3 agents (PPO, SAC) on the tandem-wing envs (docs/training.md):
``python -m train --algo sac --env TandemWing/LevelFlight-v0`` (:func:`train.run.train` from
Python) with the zoo-format hyperparameters of ``train/hyperparams/`` (``envelope/``: tuned by
``python -m train.tune`` for the whole envelope). The package itself imports nothing.
"""
