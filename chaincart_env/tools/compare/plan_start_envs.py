"""The native training envs with a share of their episodes starting along the planner's
plan: the curriculum of :mod:`chaincart_env.tools.compare.curriculum` as an SB3
``VecEnvWrapper``."""

from __future__ import annotations

from typing import Any, Optional

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnvWrapper, unwrap_vec_wrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvObs, VecEnvStepReturn

from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.curriculum import CURRICULUM_FILE, FROZEN_CLIP, SEED_OFFSET, PlanStarts, window_start

__all__ = ["CURRICULUM_FILE", "FreezeStatisticsOnWidening", "PlanStartEnvs", "plan_start_envs_of", "write_curriculum_log"]


class PlanStartEnvs(VecEnvWrapper):
    """The native ``ChainCartVecEnv`` ``venv`` (or its
    :class:`~chaincart_env.tools.compare.plan_tube.PlanTube`) with a share of its
    episodes starting at one of ``states`` as ``curriculum`` says, the draws seeded by
    ``seed``. Place it directly around them (inside ``VecMonitor``). ``windows`` lists each
    window the draw used, with the env steps at which it began (a reverse curriculum's
    progress)."""

    def __init__(self, venv: Any, states: np.ndarray, curriculum: PlanStarts, seed: int) -> None:
        states = np.asarray(states, dtype=np.float64)
        if states.ndim != 2 or states.shape[0] < 1:
            raise InvalidInputError(f"plan states of shape {states.shape}: expected (K + 1, state_dim) with K >= 0")
        if not isinstance(curriculum, PlanStarts):
            raise InvalidInputError(f"curriculum = {curriculum!r}: expected PlanStarts(...)")
        from chaincart_env.sb3 import ChainCartVecEnv
        from chaincart_env.tools.compare.plan_tube import PlanTube

        if not isinstance(venv, (ChainCartVecEnv, PlanTube)):
            raise InvalidInputError(f"plan starts wrap the native ChainCartVecEnv (or its plan tube): got "
                                    f"{type(venv).__name__}")
        native: Any = venv.unwrapped
        self.fall_limit = float(native.config.fall_limit)
        if curriculum.judge == "held" and self.fall_limit <= 0.0:
            raise InvalidInputError(f"plan-start judge 'held' with the scene's fall_limit = {self.fall_limit:g}: "
                                    "expected fall_limit > 0 (a held episode ends within it)")
        super().__init__(venv)
        self.states, self.curriculum = states, curriculum
        self.rng = np.random.default_rng(seed + SEED_OFFSET)
        self.plan_episodes = 0
        self.steps = 0
        self.window = curriculum.first_window()
        self.windows: list[tuple[int, float]] = [(0, self.window)]
        self._on_plan = np.zeros(self.num_envs, dtype=bool)
        self._judged = self._successes = 0
        self._start_index = np.zeros(self.num_envs, dtype=np.int64)  # each env's plan start

    def _first_index(self, window: Optional[float] = None) -> int:
        """The earliest plan step the draw may pick: the start of ``window`` (the current
        window by default)."""
        return window_start(self.states.shape[0] - 1, self.window if window is None else window)

    def _newest_band_end(self) -> int:
        """The plan step before which the newest band ends: the previous window's start
        (past the plan's end before the first widening: the whole window is new)."""
        if len(self.windows) < 2:
            return self.states.shape[0]
        return self._first_index(self.windows[-2][1])

    def _start_on_plan(self, envs: np.ndarray, observations: np.ndarray) -> None:
        """Moves each of ``envs`` (just reset) onto the plan with probability ``fraction``."""
        draws = self.rng.random(len(envs))
        picks = self.rng.integers(self._first_index(), self.states.shape[0], len(envs))
        chosen = [(int(i), int(k)) for i, k, u in zip(envs, picks, draws) if u < self.curriculum.fraction]
        self._on_plan[envs] = False
        if not chosen:
            return
        native: Any = self.venv.unwrapped  # their observations after set_state are the new starts
        for i, k in chosen:
            native.env_method("set_state", self.states[k], indices=i)
            self._on_plan[i] = True
            self._start_index[i] = k
        fresh = native._batch.observations()
        for i, _ in chosen:
            observations[i] = fresh[i]
        self.plan_episodes += len(chosen)

    def _judge(self, ended: np.ndarray, infos: list[dict[str, Any]]) -> None:
        """Counts the ended plan-start episodes (with ``judged_starts="newest"`` those
        started in the newest band); widens the window when enough passed."""
        band_end = self._newest_band_end() if self.curriculum.judged_starts == "newest" else None
        for i in ended[self._on_plan[ended]]:
            if band_end is not None and self._start_index[i] >= band_end:
                continue
            self._judged += 1
            self._successes += int(self._passed(infos[i]))
        curriculum = self.curriculum
        if self.window < 1.0 and self._judged >= curriculum.judged:
            if self._successes >= curriculum.threshold * self._judged:
                self.window = min(1.0, self.window + curriculum.window)
                self.windows.append((self.steps, self.window))
                print(f"curriculum: {self._successes} of {self._judged} plan-start episodes passed; starts now "
                      f"drawn from the last {self.window:.0%} of the plan ({self.steps} env steps)", flush=True)
            self._judged = self._successes = 0

    def _passed(self, info: dict[str, Any]) -> bool:
        """Whether an ended plan-start episode passes the curriculum's judge."""
        if self.curriculum.judge == "held":
            return bool(info.get("TimeLimit.truncated", False)) and float(info.get("e_q", np.inf)) <= self.fall_limit
        return bool(info.get("is_success", False))

    def reset(self) -> VecEnvObs:
        """Resets every env; each then starts on the plan with the share's probability."""
        observations = np.asarray(self.venv.reset())
        self._start_on_plan(np.arange(self.num_envs), observations)
        return observations

    def step_wait(self) -> VecEnvStepReturn:
        """The envs' step; an env whose episode ended starts its next one on the plan with
        the share's probability (its observation replaced by the plan state's)."""
        stepped, rewards, dones, infos = self.venv.step_wait()
        observations = np.asarray(stepped)
        self.steps += self.num_envs
        ended = np.flatnonzero(dones)
        if ended.size:
            if self.curriculum.reverse:
                self._judge(ended, infos)
            self._start_on_plan(ended, observations)
        return observations, rewards, dones, infos

    # VecEnvWrapper keeps its class's members in an attribute and does not pickle; the
    # checkpoints pickle the training envs, so the wrapper pickles as its parts.
    _PROGRESS = ("plan_episodes", "steps", "window", "windows", "_on_plan", "_judged", "_successes", "_start_index")

    def __getstate__(self) -> dict[str, Any]:
        return {"venv": self.venv, "states": self.states, "curriculum": self.curriculum,
                "rng": self.rng.bit_generator.state, **{name: getattr(self, name) for name in self._PROGRESS}}

    def __setstate__(self, state: dict[str, Any]) -> None:
        PlanStartEnvs.__init__(self, state["venv"], state["states"], state["curriculum"], 0)
        self.rng.bit_generator.state = state["rng"]
        for name in self._PROGRESS:
            if name in state:  # checkpoints from before the newest-band judge lack the starts
                setattr(self, name, state[name])


def plan_start_envs_of(envs: Any) -> Optional[PlanStartEnvs]:
    """The :class:`PlanStartEnvs` inside the wrapped training ``envs``, or ``None``."""
    return unwrap_vec_wrapper(envs, PlanStartEnvs)


class FreezeStatisticsOnWidening(BaseCallback):
    """Stops the agent's normalisation statistics counting once its reverse curriculum
    first widens, and lets them clip at :data:`FROZEN_CLIP` standard deviations
    (:class:`~chaincart_env.tools.compare.curriculum.PlanStarts`' ``freeze_statistics``
    says why). The frozen flag and clip are the ``VecNormalize``'s own, so checkpoints and
    saved agents keep them."""

    def _init_callback(self) -> None:  # the training envs, found once rather than at every step
        self._statistics = self.model.get_vec_normalize_env()
        self._plan = plan_start_envs_of(self.model.get_env())

    def _on_step(self) -> bool:
        statistics, plan = self._statistics, self._plan
        if statistics is None or plan is None or len(plan.windows) < 2:
            return True
        if statistics.training or statistics.clip_obs != FROZEN_CLIP:  # statistics an imitation fixed clip here too
            statistics.training = False
            statistics.clip_obs = FROZEN_CLIP
            print(f"curriculum: observation statistics frozen at the first widening ({plan.steps} env steps)",
                  flush=True)
        return True


def write_curriculum_log(envs: Any, path: Any) -> bool:
    """Writes the windows of the :class:`PlanStartEnvs` inside the wrapped training
    ``envs`` (``env_steps,window,plan_episodes`` rows; the last row the end of training) to
    ``path``; ``False`` when the envs have no plan starts."""
    import csv

    envs = plan_start_envs_of(envs)
    if envs is None:
        return False
    with open(path, "w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(("env_steps", "window"))
        writer.writerows((steps, f"{window:.6g}") for steps, window in envs.windows)
    return True
