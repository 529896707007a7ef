"""Pretrained agents shipped with the package, loaded without unpickling.

``chaincart_env.pretrained("inverted-2", "ppo")`` returns a :class:`PretrainedPolicy`:
SB3's ``predict`` (single observations and batches, deterministic actions) computed in
numpy, with the agent's :attr:`~PretrainedPolicy.record`. Each agent is two files in
``chaincart_env/agents/<scene>/``:

* ``<name>.npz``: the policy network's weights and biases and, when the agent was
  trained on normalised observations, the ``VecNormalize`` statistics (``obs_mean``,
  ``obs_var``), all plain arrays: it is read with ``np.load(..., allow_pickle=False)``,
  so loading runs no code and needs no torch;
* ``<name>.json``: the record: scene, name, algorithm, network (hidden sizes,
  activation, how the output becomes an action), observation and action spaces (the
  network's input: with ``history`` k > 0 the env's observation and its last k
  observations and actions, :mod:`chaincart_env.history`; with ``elapsed_time`` T > 0
  the elapsed fraction of the episode of T steps last, :mod:`chaincart_env.elapsed_time`;
  with ``residual`` (``{"scale": s, "config": {...}}``, and ``"plan_weights"`` if its base
  plans with other cost weights) the agent corrects the model-based controller designed
  on that configuration (:func:`chaincart_env.residual.base_controller`),
  and the base's command follows the env's observation wherever it appears,
  :mod:`chaincart_env.residual`), the normalisation's clip and epsilon, the env
  configuration, how it was trained (command, seed, git commit, steps) and the success
  it was measured at (which seeded starts, the outcome of each).

An agent with history keeps each env's last observations and actions itself, and an
agent that observes the elapsed time counts each env's steps: it acts on the env's
plain observations, restarting an env's history and clock where ``episode_start``
says (SB3's convention), at its first call, and after :meth:`PretrainedPolicy.reset`.

The forward pass is SB3's deterministic one: observations normalised as
``VecNormalize.normalize_obs`` does (``clip((obs - mean) / sqrt(var + epsilon))``,
then float32), the actor's hidden layers, its output layer, then either clipped to the
action bounds (PPO, A2C: the Gaussian's mean) or squashed by ``tanh`` and rescaled to
them (SAC, TQC: ``tanh`` of the squashed Gaussian's mean; TD3, DDPG: the actor's own
``tanh``). ``python -m chaincart_env export-agent`` writes these files from a saved SB3
model (:mod:`chaincart_env.tools.export_agent`).

A saved SB3 model (a ``.zip``, its ``vecnormalize.pkl``) is different: SB3 loads it by
unpickling, which runs code, so such a file must come from a trusted source. The
shipped agents are plain arrays and JSON.
"""

from __future__ import annotations

import json
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Optional

import numpy as np

from chaincart_env.errors import InvalidInputError

__all__ = [
    "AGENTS_DIR",
    "FORMAT",
    "FORMAT_VERSION",
    "PRETRAINED_PREFIX",
    "PretrainedPolicy",
    "PretrainedSceneWarning",
    "is_pretrained_slot",
    "load_agent",
    "parse_pretrained_slot",
    "pretrained",
    "shipped_agents",
]

#: Where the shipped agents live: one folder per scene.
AGENTS_DIR = Path(__file__).resolve().parent / "agents"
#: What a record's ``format`` says, and the version of the layout this module reads.
FORMAT = "chaincart-pretrained-agent"
FORMAT_VERSION = 1
#: How a ``--policy``/``--policies`` slot names a shipped agent: ``pretrained:<scene>/<name>``.
PRETRAINED_PREFIX = "pretrained:"
#: Activations the numpy forward pass implements (those of SB3's MLP policies).
ACTIVATIONS = ("tanh", "relu", "elu", "leaky_relu", "silu")
#: How the output layer becomes an action: ``clip`` to the bounds, or ``tanh`` then rescaled to them.
OUTPUTS = ("clip", "tanh")
_NAME = re.compile(r"^[a-z0-9][a-z0-9._-]*$")


class PretrainedSceneWarning(UserWarning):
    """A shipped agent runs on a scene other than the one it was trained and measured
    on (same observation and action spaces, so it can run; its recorded success does
    not apply there)."""


def shipped_agents(directory: Optional[Path] = None) -> dict[str, list[str]]:
    """The shipped agents by scene: ``{"inverted-2": ["ppo"], ...}`` (sorted)."""
    root = AGENTS_DIR if directory is None else Path(directory)
    if not root.is_dir():
        return {}
    agents = {}
    for scene in sorted(p for p in root.iterdir() if p.is_dir()):
        names = sorted(p.stem for p in scene.glob("*.json") if p.with_suffix(".npz").is_file())
        if names:
            agents[scene.name] = names
    return agents


def _shipped_text(directory: Optional[Path] = None) -> str:
    agents = shipped_agents(directory)
    if not agents:
        return "no agent is shipped"
    return "shipped: " + ", ".join(f"{scene}/{name}" for scene, names in agents.items() for name in names)


def is_pretrained_slot(text: Any) -> bool:
    """Whether a ``--policy`` value names a shipped agent (starts with ``pretrained:``)."""
    return isinstance(text, str) and text.strip().lower().startswith(PRETRAINED_PREFIX)


def parse_pretrained_slot(text: str, option: str = "--policy") -> tuple[str, str]:
    """``"pretrained:<scene>/<name>"`` as ``(scene, name)``, the agent checked to be
    shipped; a clear error for bad syntax or an agent that is not shipped."""
    body = str(text).strip()[len(PRETRAINED_PREFIX):] if is_pretrained_slot(text) else None
    scene, sep, name = (body or "").partition("/")
    if body is None or not sep or not _NAME.match(scene) or not _NAME.match(name):
        raise InvalidInputError(
            f"{option} {text!r}: expected {PRETRAINED_PREFIX}<scene>/<name>, e.g. {PRETRAINED_PREFIX}inverted-2/ppo "
            f"({_shipped_text()})"
        )
    try:
        _agent_files(scene, name)
    except InvalidInputError as error:
        raise InvalidInputError(f"{option} {text!r}: {error}") from None
    return scene, name


def _agent_files(scene: str, name: str, directory: Optional[Path] = None) -> tuple[Path, Path]:
    """The ``.npz`` and ``.json`` of a shipped agent, or an error listing what is shipped."""
    root = AGENTS_DIR if directory is None else Path(directory)
    for what, value in (("scene", scene), ("name", name)):
        if not isinstance(value, str) or not _NAME.match(value):
            raise InvalidInputError(f"pretrained agent {what} {value!r}: expected a name like 'inverted-2' or 'ppo'")
    weights, record = root / scene / f"{name}.npz", root / scene / f"{name}.json"
    if not (weights.is_file() and record.is_file()):
        raise InvalidInputError(f"pretrained agent {scene}/{name} is not shipped: {_shipped_text(directory)}")
    return weights, record


def pretrained(scene: str, name: str) -> "PretrainedPolicy":
    """The shipped agent ``name`` of ``scene`` (e.g. ``pretrained("inverted-2", "ppo")``):
    a policy with SB3's ``predict`` computed in numpy, and its ``record``. An agent that
    is not shipped is an error listing those that are."""
    return load_agent(*_agent_files(scene, name))


def load_agent(weights: Path, record: Path) -> "PretrainedPolicy":
    """The agent stored in ``weights`` (``.npz``) and ``record`` (``.json``), checked
    against each other; nothing is unpickled."""
    try:
        data = json.loads(Path(record).read_text())
    except (OSError, json.JSONDecodeError) as error:
        raise InvalidInputError(f"{record}: cannot read the agent's record ({error}): expected JSON") from None
    try:
        with np.load(weights, allow_pickle=False) as archive:
            arrays = {key: np.asarray(archive[key]) for key in archive.files}
    except (OSError, ValueError) as error:
        raise InvalidInputError(f"{weights}: cannot read the agent's arrays ({error}): expected a plain .npz") from None
    return PretrainedPolicy(data, arrays, source=str(weights))


def _require(record: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in record:
        raise InvalidInputError(f"{where}: the record has no {key!r}: expected a record written by export-agent")
    return record[key]


def _activate(name: str, x: np.ndarray, slope: float) -> np.ndarray:
    if name == "tanh":
        return np.tanh(x)
    if name == "relu":
        return np.maximum(x, 0)
    if name == "elu":
        return np.where(x > 0, x, np.expm1(np.minimum(x, 0)))
    if name == "leaky_relu":
        return np.where(x >= 0, x, x * np.float32(slope))
    return x / (1 + np.exp(-x))  # silu


@dataclass(frozen=True)
class _Layer:
    weight: np.ndarray  # (out, in), float32 as torch keeps it
    bias: np.ndarray


class PretrainedPolicy:
    """A shipped agent's deterministic policy: ``predict`` like an SB3 model's, in
    numpy. Build it with :func:`pretrained` (or :func:`load_agent`)."""

    def __init__(self, record: Mapping[str, Any], arrays: Mapping[str, np.ndarray], source: str = "") -> None:
        where = source or "pretrained agent"
        if record.get("format") != FORMAT or record.get("format_version") != FORMAT_VERSION:
            raise InvalidInputError(
                f"{where}: format {record.get('format')!r} version {record.get('format_version')!r}: expected "
                f"{FORMAT!r} version {FORMAT_VERSION}"
            )
        self.record: dict[str, Any] = dict(record)
        self.scene: str = str(_require(record, "scene", where))
        self.name: str = str(_require(record, "name", where))
        network = _require(record, "network", where)
        self.activation = str(network.get("activation"))
        self.output = str(network.get("output"))
        if self.activation not in ACTIVATIONS:
            raise InvalidInputError(f"{where}: activation {self.activation!r}: expected one of {list(ACTIVATIONS)}")
        if self.output not in OUTPUTS:
            raise InvalidInputError(f"{where}: output {self.output!r}: expected one of {list(OUTPUTS)}")
        self._slope = float(network.get("negative_slope", 0.01))
        hidden = [int(size) for size in network.get("hidden", [])]
        observation, action = _require(record, "observation_space", where), _require(record, "action_space", where)
        #: The network's input: the observation, with its history when ``history`` > 0.
        self.input_shape = tuple(int(n) for n in observation["shape"])
        self.action_shape = tuple(int(n) for n in action["shape"])
        self.action_low = np.asarray(action["low"], dtype=np.float32).reshape(self.action_shape)
        self.action_high = np.asarray(action["high"], dtype=np.float32).reshape(self.action_shape)
        #: Steps of observation and action history the network reads (0: none).
        self.history = self._history_steps(record.get("history", 0), where)
        #: The episode length whose elapsed fraction ends the network's input (0: none).
        self.elapsed_time = self._elapsed_time_steps(record.get("elapsed_time", 0), where)
        #: The planner's controller the agent corrects (:mod:`chaincart_env.residual`), or ``None``.
        self.residual = self._residual_setting(record.get("residual"), where)
        #: The env's observation, which ``predict`` takes.
        self.observation_shape = self._env_observation_shape(where)
        sizes = [int(np.prod(self.input_shape))] + hidden + [int(np.prod(self.action_shape))]
        names = [f"hidden.{i}" for i in range(len(hidden))] + ["output"]
        self._layers = [self._layer(arrays, key, n_in, n_out, where)
                        for key, n_in, n_out in zip(names, sizes[:-1], sizes[1:])]
        self._normalization = self._statistics(record.get("normalization"), arrays, sizes[0], where)
        self._adapter = self._history_policy() if self.history or self.elapsed_time or self.residual else None

    @staticmethod
    def _history_steps(value: Any, where: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise InvalidInputError(f"{where}: history {value!r}: expected an integer >= 0")
        return value

    @staticmethod
    def _elapsed_time_steps(value: Any, where: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise InvalidInputError(f"{where}: elapsed_time {value!r}: expected an integer >= 0 (the episode's "
                                    "length in steps, 0 for none)")
        return value

    @staticmethod
    def _residual_setting(value: Any, where: str) -> Optional[dict[str, Any]]:
        from chaincart_env.residual import checked_setting

        try:
            return checked_setting(value)
        except InvalidInputError as error:
            raise InvalidInputError(f"{where}: residual: {error}") from None

    def _env_observation_shape(self, where: str) -> tuple[int, ...]:
        """The env's observation shape: the input less the elapsed time, ``history``
        observations and actions, and the base's command of a residual agent."""
        if not self.history and not self.elapsed_time and not self.residual:
            return self.input_shape
        k, actions = self.history, int(np.prod(self.action_shape))
        size, left = divmod(int(np.prod(self.input_shape)) - (1 if self.elapsed_time else 0) - k * actions, k + 1)
        size -= actions if self.residual else 0
        if len(self.input_shape) != 1 or left or size < 1:
            raise InvalidInputError(f"{where}: input of shape {self.input_shape} with history {k}, elapsed_time "
                                    f"{self.elapsed_time} and residual {self.residual is not None}: expected obs + "
                                    f"{k} * (obs + {actions}) numbers, plus 1 with the elapsed time, obs holding "
                                    "the base's command after the env's observation for a residual agent")
        return (size,)

    def _history_policy(self) -> Any:
        """The network behind the adapters that keep each env's history
        (:class:`~chaincart_env.history.HistoryPolicy`) and clock
        (:class:`~chaincart_env.elapsed_time.ElapsedTimePolicy`)."""
        from gymnasium import spaces

        from chaincart_env.elapsed_time import with_adapters

        observation = spaces.Box(-np.inf, np.inf, self.observation_shape, np.float32)
        action = spaces.Box(self.action_low, self.action_high, dtype=np.float32)
        if self.residual is not None:  # the base's command first, then the history and clock inside
            from chaincart_env.residual import ResidualPolicy

            return ResidualPolicy(_Network(self), self.residual, observation, action, self.elapsed_time)
        return with_adapters(_Network(self), self.history, self.elapsed_time, observation, action)

    @staticmethod
    def _layer(arrays: Mapping[str, np.ndarray], key: str, n_in: int, n_out: int, where: str) -> _Layer:
        weight, bias = arrays.get(f"{key}.weight"), arrays.get(f"{key}.bias")
        if weight is None or bias is None or weight.shape != (n_out, n_in) or bias.shape != (n_out,):
            found = None if weight is None else weight.shape
            raise InvalidInputError(
                f"{where}: layer {key} has weight of shape {found}: expected {key}.weight of shape ({n_out}, {n_in}) "
                f"and {key}.bias of shape ({n_out},), as the record's network says"
            )
        return _Layer(weight.astype(np.float32), bias.astype(np.float32))

    @staticmethod
    def _statistics(
        setting: Optional[Mapping[str, Any]], arrays: Mapping[str, np.ndarray], size: int, where: str
    ) -> Optional[tuple[np.ndarray, np.ndarray, float, float]]:
        if setting is None:
            return None
        mean, var = arrays.get("obs_mean"), arrays.get("obs_var")
        if mean is None or var is None or mean.shape != (size,) or var.shape != (size,):
            raise InvalidInputError(
                f"{where}: the record says observations are normalised: expected obs_mean and obs_var of shape "
                f"({size},) in the arrays"
            )
        return mean.astype(np.float64), var.astype(np.float64), float(setting["clip_obs"]), float(setting["epsilon"])

    # -- what the record says ------------------------------------------------------------

    @property
    def success(self) -> dict[str, Any]:
        """How the agent was measured: ``seeds`` (the seeded starts), ``outcomes`` (1: a
        success, per seed), ``successes``, ``episodes``, ``rate``."""
        return dict(self.record.get("success", {}))

    @property
    def label(self) -> str:
        """``pretrained:<scene>/<name>``, the agent's ``--policy`` slot and its label in tables."""
        return f"{PRETRAINED_PREFIX}{self.scene}/{self.name}"

    def config(self) -> Any:
        """The env configuration the agent was trained and measured on (a ``ChainCartConfig``)."""
        from chaincart_env.config import ChainCartConfig

        return ChainCartConfig(**self.record["config"])

    def check_config(self, config: Any) -> None:
        """Checks that the agent can act in ``config``'s env: a different observation or
        action shape is an :class:`~chaincart_env.InvalidInputError` (the network cannot
        read it); a different scene with the same shapes is a
        :class:`PretrainedSceneWarning` (it runs, but its recorded success is not for
        that scene)."""
        observed, forces = (int(config.obs_dim),), (int(config.force_dim),)
        if observed != self.observation_shape or forces != self.action_shape:
            raise InvalidInputError(
                f"{self.label} observes shape {self.observation_shape} and acts with shape {self.action_shape}, but "
                f"scene {config.scene!r} observes {observed} and acts with {forces}: expected a scene with the spaces "
                f"of {self.scene!r}, the one it was trained on"
            )
        if config.scene != self.scene:
            warnings.warn(
                f"{self.label} was trained and measured on scene {self.scene!r}, not {config.scene!r}: it runs (same "
                "spaces), but its recorded success does not apply there", PretrainedSceneWarning, stacklevel=2,
            )

    # -- acting --------------------------------------------------------------------------

    def normalize(self, observation: np.ndarray) -> np.ndarray:
        """``observation`` as the network reads it: normalised with the agent's statistics
        (``VecNormalize.normalize_obs``), float32."""
        if self._normalization is None:
            return np.asarray(observation, dtype=np.float32)
        mean, var, clip, epsilon = self._normalization
        scaled = (np.asarray(observation, dtype=np.float64) - mean) / np.sqrt(var + epsilon)
        return np.clip(scaled, -clip, clip).astype(np.float32)

    def forward(self, observation: np.ndarray) -> np.ndarray:
        """The deterministic actions of a batch of observations (shape ``(n, obs_dim)``)."""
        x = self.normalize(observation)
        for layer in self._layers[:-1]:
            x = _activate(self.activation, x @ layer.weight.T + layer.bias, self._slope)
        out = x @ self._layers[-1].weight.T + self._layers[-1].bias
        if self.output == "clip":
            return np.clip(out, self.action_low, self.action_high)
        return self.action_low + 0.5 * (np.tanh(out) + 1.0) * (self.action_high - self.action_low)

    def predict(
        self, observation: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ) -> tuple[np.ndarray, Any]:
        """SB3's ``predict``: ``(actions, state)`` for one observation (actions of the
        action space's shape) or a batch (one row each); ``state`` is returned as given
        (the policy has none). Only the deterministic policy is shipped, so
        ``deterministic=False`` is an error."""
        if not deterministic:
            raise InvalidInputError(
                f"{self.label}: deterministic=False: a shipped agent keeps only its deterministic policy (no "
                "exploration noise); expected deterministic=True"
            )
        obs = np.asarray(observation)
        single = obs.shape == self.observation_shape
        if not single and obs.shape[1:] != self.observation_shape:
            raise InvalidInputError(
                f"{self.label}: observation of shape {obs.shape}: expected {self.observation_shape} or a batch "
                f"(n, {', '.join(map(str, self.observation_shape))})"
            )
        if self._adapter is not None:
            return self._adapter.predict(obs, state=state, episode_start=episode_start)  # type: ignore[no-any-return]
        batch = obs.reshape(1 if single else obs.shape[0], -1)
        actions = self.forward(batch).reshape((-1, *self.action_shape))
        return (actions[0] if single else actions), state

    def reset(self) -> None:
        """Forgets every env's history and clock (an agent with either begins new
        episodes at its next call); nothing for an agent without."""
        if self._adapter is not None:
            self._adapter.reset()

    def __repr__(self) -> str:
        hidden = [layer.weight.shape[0] for layer in self._layers[:-1]]
        return (f"PretrainedPolicy({self.label}, {self.record.get('algorithm')}, hidden {hidden}, {self.activation}, "
                f"normalised={self._normalization is not None}, history={self.history}, "
                f"elapsed_time={self.elapsed_time}, residual={self.residual is not None})")


class _Network:
    """A policy's network as a ``predict`` on its whole input (history included)."""

    def __init__(self, policy: PretrainedPolicy) -> None:
        from gymnasium import spaces

        self._policy = policy
        #: The network's input, from which the adapters read what it holds.
        self.observation_space = spaces.Box(-np.inf, np.inf, policy.input_shape, np.float32)

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        return self._policy.forward(observation), state
