"""The main job: train a stable-baselines3 agent on a chaincart scene and compare it
with the LQR baseline (``python -m chaincart_env compare`` / ``evaluate``).

* :mod:`.scene_options`: command-line scene options -> ``ChainCartConfig``.
* :mod:`.training`: SB3 training on ``ChainCartVecEnv`` with a CSV episode log.
* :mod:`.evaluation`: seeded deterministic rollouts and the compared metrics.
* :mod:`.learning_curve`, :mod:`.tables`, :mod:`.plots`, :mod:`.filmstrip`: outputs.
* :mod:`.run_files`: saving and loading a trained run.
* :mod:`.job`: the two pipelines; :mod:`.cli`: their command line.
"""
