"""A warm start for a learned agent: imitation of the planner's controller.

Where reinforcement learning alone stalls (one goal-conditioned policy for every
transition between equilibria), an agent can first copy a model-based controller that
solves the task, then train on as usual. The copy is DAgger (Ross, Gordon and Bagnell,
2011) seeded with noisy demonstrations (DART, Laskey et al., 2017):

1. the expert (the planner's :class:`~chaincart_env.policies.TrajectoryPolicy`) runs the
   training scene with Gaussian noise on its actions, and every state it visits is
   labelled with its clean action;
2. the policy's mean action is fitted to the labels (mean squared error in the normalised
   action space, observations normalised with the demonstrations' statistics);
3. each round, the learner itself runs the scene, the expert labels the states the
   learner visits, the labels join the data and the fit goes on.

The learner sees what the agent will see in training: an agent observing history or the
elapsed time (:mod:`chaincart_env.history`, :mod:`chaincart_env.elapsed_time`) runs its
rounds through the same wrappers, while the expert reads the plain observation. The
time is what lets a policy copy the planner's controller, which is time-varying.

Only the policy's mean is fitted; the value function learns in the training that
follows, and the policy's exploration noise is set to :attr:`Imitation.action_std`.
What keeps the copy while reinforcement learning trains on (a critic trained first, the
fit kept as a second loss) is :mod:`~chaincart_env.tools.compare.anchoring`; its data,
the imitation's labelled observations, is :data:`IMITATION_DATA_FILE`.
"""

from __future__ import annotations

import csv
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Mapping, Optional

import numpy as np

from chaincart_env.errors import InvalidInputError
from chaincart_env.tools.compare.shaping import check_scale

__all__ = [
    "IMITATING_ALGOS", "IMITATION_DATA_FILE", "IMITATION_FILE", "SCENE_IMITATIONS", "Imitation", "imitate",
    "mean_action", "scene_imitation",
]

#: The per-round log of an imitation, in the training directory.
IMITATION_FILE = "imitation.csv"
#: The imitation's labelled observations (raw, as the envs gave them), kept in the
#: training directory when the training that follows anchors the policy to them.
IMITATION_DATA_FILE = "imitation_data.npz"
_COLUMNS = ("round", "drawn_pairs", "samples", "learner_episodes", "learner_success", "fit_loss", "wall_time_s")


@dataclass(frozen=True)
class Imitation:
    """How much the agent imitates before it trains. Action noise and the fit's
    loss are in the env's normalised action space ([-1, 1] per force axis)."""

    #: Steps per env of noisy demonstrations, for each noise level.
    demonstration_steps: int = 3000
    #: Standard deviations of the noise on the expert's actions, one demonstration run each.
    noise: tuple[float, ...] = (0.0, 0.03, 0.06)
    #: Passes over the demonstrations in the first fit.
    epochs: int = 30
    #: DAgger rounds, the steps per env each round runs the learner, and the passes over
    #: all the data after each round.
    rounds: int = 20
    round_steps: int = 1500
    round_epochs: int = 3
    learning_rate: float = 1e-3
    batch_size: int = 4096
    #: The policy's exploration standard deviation once imitation is over.
    action_std: float = 0.1
    #: Further DAgger rounds on goal-conditioned scenes, every other one drawing only the
    #: transitions the learner still misses (measured before it from
    #: :attr:`focus_starts` seeded starts of each transition); they stop early when it
    #: misses none.
    focus_rounds: int = 0
    focus_starts: int = 4
    #: Env steps at the start of the training that follows during which only the value
    #: function trains (:class:`~chaincart_env.tools.compare.anchoring.CriticWarmup`).
    #: With it or an anchor, the observation statistics stay the imitation's
    #: (:func:`~chaincart_env.tools.compare.anchoring.fix_statistics`).
    critic_warmup: int = 0
    #: Weight of the imitation's fit as a second loss during that training, 0 for none
    #: (:class:`~chaincart_env.tools.compare.anchoring.ImitationAnchor`).
    anchor_weight: float = 0.0
    #: Where the expert's plans start (``"equilibrium"``: one plan from the start
    #: equilibrium, ``"state"``: a plan per episode), ``None``: the scene's
    #: (:data:`~chaincart_env.policies.settings.SCENE_PLANS`).
    plan_from: Optional[str] = None

    def __post_init__(self) -> None:
        for name in ("demonstration_steps", "epochs", "rounds", "round_steps", "round_epochs", "batch_size",
                     "focus_rounds", "focus_starts", "critic_warmup"):
            value, least = getattr(self, name), 0 if name in ("rounds", "focus_rounds", "critic_warmup") else 1
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                raise InvalidInputError(f"imitation {name} = {value!r}: expected an integer >= {least}")
        if not self.noise or not all(isinstance(v, (int, float)) and 0.0 <= v < 1.0 for v in self.noise):
            raise InvalidInputError(f"imitation noise = {self.noise!r}: expected standard deviations in [0, 1)")
        for name in ("learning_rate", "action_std"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InvalidInputError(f"imitation {name} = {value!r}: expected a number > 0")
        check_scale(self.anchor_weight, "imitation anchor_weight")
        from chaincart_env.policies.planned import PLAN_FROM

        if self.plan_from is not None and self.plan_from not in PLAN_FROM:
            raise InvalidInputError(f"imitation plan_from = {self.plan_from!r}: expected one of {list(PLAN_FROM)} "
                                    "or None (the scene's)")

    def record(self) -> dict[str, Any]:
        """The settings as ``run.json`` records them."""
        out = asdict(self)
        out["noise"] = list(self.noise)
        return out

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> "Imitation":
        """The settings :meth:`record` wrote."""
        return cls(**{**record, "noise": tuple(record["noise"])})


#: The scenes whose PPO agents start from an imitation of the planner: the
#: goal-conditioned transitions of two links, where PPO alone learned only the
#: transitions to hanging (docs/main-job.md), and the double swing-up, whose agent
#: observes the elapsed time and so can copy the planner's time-varying controller.
#: PPO then trains on with a small exploration noise (0.03 of the force limit), its value
#: function alone for the first 500k (250k) steps and the imitation kept as a second
#: loss of weight 10: with these, one seed's training lifted the transitions' copy from
#: 11 to 12 transitions (and lost it again later; compare keeps the best model), and
#: the swing-up's agents keep the copy's hold of force-rate limits and cart friction.
SCENE_IMITATIONS: dict[str, Imitation] = {
    "transitions-2": Imitation(focus_rounds=8, action_std=0.03, critic_warmup=500_000, anchor_weight=10.0),
    "swingup-2": Imitation(rounds=10, action_std=0.03, critic_warmup=250_000, anchor_weight=10.0),
}
#: The algorithms whose policy an imitation can fit (a Gaussian actor-critic).
IMITATING_ALGOS = ("ppo", "a2c")


def scene_imitation(scene: Optional[str], algo: str) -> Optional[Imitation]:
    """The imitation ``algo``'s agents start from on ``scene``, or ``None``."""
    return SCENE_IMITATIONS.get(scene or "") if algo.lower() in IMITATING_ALGOS else None


def mean_action(policy: Any, normalized: Any) -> Any:
    """The mean action of an SB3 Gaussian actor-critic ``policy`` at ``normalized``
    observations (a tensor), with gradients."""
    features = policy.extract_features(normalized, policy.pi_features_extractor)
    return policy.action_net(policy.mlp_extractor.forward_actor(features))


class _Fit:
    """The policy's mean action, fitted to labelled observations with Adam."""

    def __init__(self, model: Any, imitation: Imitation, seed: int) -> None:
        import torch

        self.torch = torch
        self.policy = model.policy
        self.imitation = imitation
        self.optimizer = torch.optim.Adam(self.policy.parameters(), lr=imitation.learning_rate)
        self.generator = torch.Generator().manual_seed(seed)

    def act(self, normalized: np.ndarray) -> np.ndarray:
        with self.torch.no_grad():
            mean = mean_action(self.policy, self.torch.as_tensor(normalized, dtype=self.torch.float32))
        return np.clip(mean.numpy(), -1.0, 1.0).astype(np.float32)

    def run(self, observations: np.ndarray, actions: np.ndarray, epochs: int) -> float:
        """``epochs`` passes in shuffled minibatches; the last pass's mean loss."""
        torch = self.torch
        inputs = torch.as_tensor(observations, dtype=torch.float32)
        targets = torch.as_tensor(actions, dtype=torch.float32)
        n, size = inputs.shape[0], self.imitation.batch_size
        loss_sum = 0.0
        for _ in range(epochs):
            loss_sum = 0.0
            for chunk in torch.randperm(n, generator=self.generator).split(size):
                loss = ((mean_action(self.policy, inputs[chunk]) - targets[chunk]) ** 2).mean()
                self.optimizer.zero_grad()
                loss.backward()
                self.optimizer.step()
                loss_sum += float(loss.detach()) * len(chunk)
        return loss_sum / n


def _rollout(
    venv: Any, expert: Any, steps: int, act: Any, plain: int
) -> tuple[np.ndarray, np.ndarray, list[bool]]:
    """``steps`` steps of ``venv`` acting with ``act(observation, expert_action)``, the
    expert reading the first ``plain`` columns (the env's own observation); the
    observations, the expert's actions there, and the success of every episode that ended."""
    observation = venv.reset()
    begins = np.ones(venv.num_envs, dtype=bool)
    observations, labels, successes = [], [], []
    for _ in range(steps):
        label, _ = expert.predict(observation[:, :plain], episode_start=begins)
        observations.append(observation.copy())
        labels.append(label)
        observation, _, begins, infos = venv.step(act(observation, label))
        successes += [bool(info.get("is_success", False)) for done, info in zip(begins, infos) if done]
    return np.concatenate(observations), np.concatenate(labels), successes


def imitate(model: Any, config: Any, imitation: Imitation, seed: int, directory: Path) -> dict[str, Any]:
    """Fits ``model``'s policy (an SB3 actor-critic with a Gaussian policy, observations
    normalised by its ``VecNormalize``) to the planner's controller on ``config``, with
    ``model.n_envs`` envs seeded from ``seed``; writes :data:`IMITATION_FILE` in
    ``directory`` (and, where ``imitation`` anchors the training that follows,
    :data:`IMITATION_DATA_FILE`) and returns the last round's summary."""
    from chaincart_env.elapsed_time import observation_extras, with_observation_extras
    from chaincart_env.env import action_space, observation_space
    from chaincart_env.policies import TrajectoryPolicy
    from chaincart_env.sb3 import ChainCartVecEnv

    policy = model.policy
    if not (hasattr(policy, "action_net") and hasattr(policy, "log_std")):
        raise InvalidInputError(f"imitation fits a Gaussian actor-critic policy (PPO, A2C): "
                                f"{type(model).__name__} has none")
    statistics = model.get_vec_normalize_env()
    n_envs, rng, start = int(model.n_envs), np.random.default_rng(seed), time.perf_counter()
    fit = _Fit(model, imitation, seed)
    log = _Log(Path(directory) / IMITATION_FILE)

    plain = config.obs_dim
    extras = observation_extras(model.observation_space, observation_space(config), action_space(config))

    def envs(block: int, drawn: Any = config) -> tuple[Any, Any]:
        # Seeds apart from the training envs' (seed + i) and the evaluations' (1 000 000 + k).
        native = ChainCartVecEnv(n_envs, drawn, seed=seed + 100_000 + block * n_envs)
        return with_observation_extras(native, *extras), TrajectoryPolicy.from_env(native, plan_from=imitation.plan_from)

    observations, labels = [], []
    for block, noise in enumerate(imitation.noise):
        venv, expert = envs(block)

        def noisy(_: np.ndarray, label: np.ndarray, noise: float = noise) -> np.ndarray:
            return np.clip(label + noise * rng.standard_normal(label.shape), -1.0, 1.0).astype(np.float32)

        seen, said, _ = _rollout(venv, expert, imitation.demonstration_steps, noisy, plain)
        observations.append(seen)
        labels.append(said)
    raw = np.concatenate(observations)
    if statistics is not None and statistics.norm_obs:
        statistics.obs_rms.mean = raw.mean(axis=0).astype(np.float64)
        statistics.obs_rms.var = raw.var(axis=0).astype(np.float64)
        statistics.obs_rms.count = float(raw.shape[0])

    def normalized(raw_observations: np.ndarray) -> np.ndarray:
        return statistics.normalize_obs(raw_observations) if statistics is not None else raw_observations

    loss = fit.run(normalized(raw), np.concatenate(labels), imitation.epochs)
    pairs = config.pairs or []
    log.add(_row(0, len(pairs), raw.shape[0], [], loss, start))
    learner = lambda obs, _: fit.act(normalized(obs))  # noqa: E731
    focus = imitation.focus_rounds if pairs else 0
    for round_ in range(1, imitation.rounds + focus + 1):
        drawn = config
        if round_ > imitation.rounds and (round_ - imitation.rounds) % 2 == 1:
            missed = [pair for pair in pairs if _pair_success(learner, config, pair, imitation.focus_starts,
                                                              seed + 200_000 + round_, extras) < 1.0]
            if not missed:
                break
            drawn = config.replace(transitions=missed)
        venv, expert = envs(len(imitation.noise) + round_, drawn)
        seen, said, successes = _rollout(venv, expert, imitation.round_steps, learner, plain)
        observations.append(seen)
        labels.append(said)
        raw = np.concatenate(observations)
        loss = fit.run(normalized(raw), np.concatenate(labels), imitation.round_epochs)
        log.add(_row(round_, len(drawn.pairs or []), raw.shape[0], successes, loss, start))
    with fit.torch.no_grad():  # the exploration of the training that follows
        policy.log_std.fill_(math.log(imitation.action_std))
    if imitation.anchor_weight > 0:
        np.savez(Path(directory) / IMITATION_DATA_FILE, observations=np.concatenate(observations).astype(np.float32),
                 labels=np.concatenate(labels).astype(np.float32))
    return log.last


def _pair_success(
    act: Any, config: Any, pair: Any, starts: int, seed: int, extras: tuple[int, bool] = (0, False)
) -> float:
    """The success of ``act`` over the first episodes of ``starts`` seeded envs of one
    transition (observed with ``extras``: history and elapsed time)."""
    from chaincart_env.elapsed_time import with_observation_extras
    from chaincart_env.sb3 import ChainCartVecEnv

    venv = with_observation_extras(ChainCartVecEnv(starts, config.replace(transitions=[pair]), seed=seed), *extras)
    observation, ended = venv.reset(), np.zeros(starts, dtype=bool)
    success = np.zeros(starts, dtype=bool)
    while not ended.all():
        observation, _, done, infos = venv.step(act(observation, None))
        for i in np.flatnonzero(done & ~ended):
            ended[i], success[i] = True, bool(infos[i].get("is_success", False))
    return float(success.mean())


def _row(round_: int, pairs: int, samples: int, successes: list[bool], loss: float, start: float) -> dict[str, Any]:
    return {
        "round": round_, "drawn_pairs": pairs, "samples": samples, "learner_episodes": len(successes),
        "learner_success": float(np.mean(successes)) if successes else float("nan"),
        "fit_loss": loss, "wall_time_s": round(time.perf_counter() - start, 3),
    }


class _Log:
    """The rounds' rows, written as they come (a long imitation can be watched)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.last: dict[str, Any] = {}
        with path.open("w", newline="") as file:
            csv.writer(file).writerow(_COLUMNS)

    def add(self, row: dict[str, Any]) -> None:
        self.last = row
        with self.path.open("a", newline="") as file:
            csv.DictWriter(file, fieldnames=_COLUMNS).writerow(row)
