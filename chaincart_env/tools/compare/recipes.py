"""Training recipes: the number of envs, the budget and the algorithm's keywords that
``compare`` (and the leaderboard) use for a scene unless told otherwise.

The recipes are RL Baselines3 Zoo hyperparameter files shipped with the package,
``chaincart_env/hyperparams/<algo>.yml``: one entry per env id (``ChainCart-<scene>-v0``)
with the zoo's keys (``n_envs``, ``n_timesteps``, ``policy``, ``policy_kwargs``,
``normalize``: observation and reward normalisation, see
:mod:`chaincart_env.tools.compare.normalization`) and the algorithm's keywords. The same file trains the same agent with the zoo::

    python -m rl_zoo3.train --algo ppo --env ChainCart-swingup-2-v0 \\
        --gym-packages chaincart_env -conf <the file>

A scene without an entry trains with :data:`GENERIC` (SB3's defaults on 8 envs). A
controller that trains on a variant of the scene (``ppo-robust``:
``ChainCart-<scene>-robust-v0``) takes that id's entry, or the scene's without one. The
one zoo wrapper a recipe may name is the observation history,
``env_wrapper: [{chaincart_env.history.HistoryObservation: {k: 2}}]``, which ``compare``
builds as :class:`~chaincart_env.history.VecHistoryObservation` around its native envs
(the same observations); the other is the elapsed time,
``env_wrapper: [{chaincart_env.history.HistoryObservation: {k: 1}},
{chaincart_env.elapsed_time.ElapsedTimeObservation: {}}]`` (after the history, if
any: the zoo wraps in list order, so the time ends the observation), built as
:class:`~chaincart_env.elapsed_time.VecElapsedTimeObservation`. A recipe's ``env_kwargs`` (configuration keys, as the zoo
gives them to ``gym.make``) are the conditions the agent trains under, e.g. a control
delay drawn per episode, ``env_kwargs: {action_delay: [0, 2]}``: on top of the scene
(and of a variant's conditions), in training and in the evaluations that choose the
kept model, never in the study's or the leaderboard's own evaluations; a key the
study's configuration sets itself (``compare --action-delay 2``) keeps that value.
Command-line options (``--num-envs``, ``--timesteps``, ``--algo-kwarg``) override a
recipe's entries one by one. Keywords are kept as the file writes them (so that a run's
``run.json`` records them) and turned into SB3's objects by :func:`sb3_keywords` when the
agent is built. How each recipe was chosen is in the file's comments and in
``docs/main-job.md``.
"""

from __future__ import annotations

import ast
import functools
import json
from dataclasses import dataclass, field
from importlib import resources
from typing import Any, Callable, Mapping, NamedTuple, Optional

from chaincart_env.errors import InvalidInputError
from chaincart_env.registration import scene_env_id

__all__ = [
    "ELAPSED_TIME_WRAPPER", "GENERIC", "HISTORY_WRAPPER", "NORMALIZE_KEYS", "RESIDUAL_WRAPPER", "TrainingRecipe",
    "conditions_setting", "elapsed_time_setting", "history_setting", "hyperparameter_file", "residual_scenes", "residual_setting",
    "load_recipes", "normalize_setting", "recipe_for", "sb3_keywords", "schedule_start",
    "training_conditions", "WrapperSettings", "wrapper_settings",
]  # fmt: skip

#: Zoo keys a recipe may hold besides the algorithm's keywords.
ZOO_KEYS = ("n_envs", "n_timesteps", "policy", "normalize", "env_wrapper", "env_kwargs")
#: ``VecNormalize`` keywords a recipe's ``normalize`` may set.
NORMALIZE_KEYS = ("norm_obs", "norm_reward", "clip_obs", "clip_reward")
#: Zoo keys that ask for wrappers ``compare`` does not build: refused rather than ignored.
UNSUPPORTED_ZOO_KEYS = ("vec_env_wrapper", "frame_stack", "callback")
#: The wrappers a recipe's ``env_wrapper`` may name: the residual action, the observation
#: history, then the elapsed time.
RESIDUAL_WRAPPER = "chaincart_env.residual.ResidualAction"
HISTORY_WRAPPER = "chaincart_env.history.HistoryObservation"
ELAPSED_TIME_WRAPPER = "chaincart_env.elapsed_time.ElapsedTimeObservation"


@dataclass(frozen=True)
class TrainingRecipe:
    """How to train one algorithm on one scene."""

    num_envs: int
    timesteps: int
    hyperparameters: dict[str, Any] = field(default_factory=dict)
    #: Where it comes from: ``"ppo.yml: ChainCart-inverted-2-v0"``, or SB3's defaults.
    source: str = ""
    #: ``VecNormalize`` keywords (the zoo's ``normalize``), or ``None``: no normalisation.
    normalize: Optional[dict[str, Any]] = None
    #: Steps of observation and action history the agent sees (the zoo's ``env_wrapper``
    #: :data:`HISTORY_WRAPPER`), or ``None``: the plain observation.
    history: Optional[int] = None
    #: Configuration keys the agent trains under on top of the scene (the zoo's
    #: ``env_kwargs``), as plain JSON values.
    conditions: dict[str, Any] = field(default_factory=dict)
    #: The agent observes the elapsed fraction of its episode (the zoo's ``env_wrapper``
    #: :data:`ELAPSED_TIME_WRAPPER`).
    elapsed_time: bool = False
    #: The agent corrects a model-based controller: :class:`~chaincart_env.residual.ResidualAction`'s
    #: keywords (the zoo's ``env_wrapper`` :data:`RESIDUAL_WRAPPER`: the scale, and the
    #: base planner's cost weights if given), or ``None``.
    residual: Optional[dict[str, Any]] = None


#: SB3's defaults on 8 envs: what a scene without a recipe trains with.
GENERIC = TrainingRecipe(8, 400_000, {}, "SB3's defaults")


def hyperparameter_file(algo: str) -> Any:
    """The packaged zoo file of ``algo`` (a :class:`importlib.resources` traversable)."""
    return resources.files("chaincart_env") / "hyperparams" / f"{algo.lower()}.yml"


def _recipe(algo: str, env_id: str, entry: Any) -> TrainingRecipe:
    where = f"{algo}.yml: {env_id}"
    if not isinstance(entry, Mapping):
        raise InvalidInputError(f"{where}: expected a mapping of hyperparameters, got {entry!r}")
    refused = sorted(set(entry) & set(UNSUPPORTED_ZOO_KEYS))
    if refused:
        raise InvalidInputError(f"{where}: {refused} are zoo wrappers compare does not build; expected none of them")
    if entry.get("policy", "MlpPolicy") != "MlpPolicy":
        raise InvalidInputError(f"{where}: policy {entry['policy']!r}: expected 'MlpPolicy'")
    try:
        num_envs, timesteps = int(entry.get("n_envs", 1)), int(float(entry["n_timesteps"]))
    except (KeyError, TypeError, ValueError):
        raise InvalidInputError(f"{where}: expected an integer n_envs and a number n_timesteps") from None
    keywords = {key: value for key, value in entry.items() if key not in ZOO_KEYS}
    sb3_keywords(keywords, where)  # checked now, so a bad file fails before any training
    wrappers = wrapper_settings(entry.get("env_wrapper"), where)
    return TrainingRecipe(num_envs, timesteps, keywords, where, normalize_setting(entry.get("normalize"), where),
                          wrappers.history, conditions_setting(entry.get("env_kwargs"), where),
                          wrappers.elapsed_time, wrappers.residual)


def conditions_setting(value: Any, where: str = "env_kwargs") -> dict[str, Any]:
    """A zoo ``env_kwargs`` as training conditions: a mapping of configuration keys
    (none without one), its values as JSON has them. An unknown key is refused by name;
    the values are checked when the training env is built."""
    from chaincart_env.config import CONFIG_KEYS

    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise InvalidInputError(f"{where}: env_kwargs = {value!r}: expected a mapping of configuration keys")
    known = {name for name, *_ in CONFIG_KEYS}  # the core's key table, as ChainCartConfig checks it
    unknown = sorted(str(key) for key in value if key not in known)
    if unknown:
        raise InvalidInputError(f"{where}: env_kwargs keys {unknown}: expected configuration keys")
    try:
        return dict(json.loads(json.dumps(dict(value))))
    except (TypeError, ValueError):
        raise InvalidInputError(f"{where}: env_kwargs = {value!r}: expected plain values (numbers, text, "
                                "lists, mappings)") from None


#: The wrappers a recipe's ``env_wrapper`` may list, in the order they must come.
_WRAPPER_ORDER = (RESIDUAL_WRAPPER, HISTORY_WRAPPER, ELAPSED_TIME_WRAPPER)


class WrapperSettings(NamedTuple):
    """What a recipe's ``env_wrapper`` asks for: steps of history (``None``: none), the
    elapsed time, and the residual's keywords (``None``: a plain agent)."""

    history: Optional[int] = None
    elapsed_time: bool = False
    residual: Optional[dict[str, Any]] = None


def wrapper_settings(value: Any, where: str = "env_wrapper") -> WrapperSettings:
    """A zoo ``env_wrapper``, checked once: some of :data:`RESIDUAL_WRAPPER`
    (``{scale: S, plan_weights: {...}}``, each optional), :data:`HISTORY_WRAPPER`
    (``{k: K}``) and :data:`ELAPSED_TIME_WRAPPER` (no keywords: ``{}``), alone or in a list
    in that order; anything else is refused, since ``compare`` would not build it."""
    from chaincart_env.residual import residual_keywords

    if value is None:
        return WrapperSettings()
    bad = InvalidInputError(
        f"{where}: env_wrapper = {value!r}: expected some of [{{{RESIDUAL_WRAPPER}: {{scale: <number in (0, 2]>, "
        "plan_weights: <the planner's cost weights> (optional)}}}}, "
        f"{{{HISTORY_WRAPPER}: {{k: <integer >= 1>}}}}, {{{ELAPSED_TIME_WRAPPER}: {{}}}}], in that order: the only "
        "wrappers compare builds"
    )
    entries = value if isinstance(value, list) else [value]
    names = [next(iter(e)) if isinstance(e, Mapping) and len(e) == 1 else None for e in entries]
    order = [_WRAPPER_ORDER.index(name) for name in names if name in _WRAPPER_ORDER]
    if not names or len(order) != len(names) or order != sorted(set(order)):  # known, each once, in order
        raise bad
    found = {str(name): entry[name] for name, entry in zip(names, entries)}
    history = found.get(HISTORY_WRAPPER)
    if HISTORY_WRAPPER in found:
        if not isinstance(history, Mapping) or set(history) != {"k"}:
            raise bad
        k = history["k"]
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise bad
    if ELAPSED_TIME_WRAPPER in found and found[ELAPSED_TIME_WRAPPER] != {}:  # the zoo calls wrapper(env, **keywords)
        raise bad
    residual = None
    if RESIDUAL_WRAPPER in found:
        try:
            residual = residual_keywords(found[RESIDUAL_WRAPPER])
        except InvalidInputError as error:
            raise InvalidInputError(f"{bad} ({error})") from None
    return WrapperSettings(None if history is None else int(history["k"]), ELAPSED_TIME_WRAPPER in found, residual)


def history_setting(value: Any, where: str = "env_wrapper") -> Optional[int]:
    """The history length of a zoo ``env_wrapper`` naming :data:`HISTORY_WRAPPER`
    (``{wrapper: {k: K}}``), or ``None`` without it (see :func:`wrapper_settings`)."""
    return wrapper_settings(value, where).history


def elapsed_time_setting(value: Any, where: str = "env_wrapper") -> bool:
    """Whether a zoo ``env_wrapper`` names :data:`ELAPSED_TIME_WRAPPER`."""
    return wrapper_settings(value, where).elapsed_time


def residual_setting(value: Any, where: str = "env_wrapper") -> Optional[dict[str, Any]]:
    """The residual keywords of a zoo ``env_wrapper`` naming :data:`RESIDUAL_WRAPPER`
    (:func:`chaincart_env.residual.residual_keywords`), or ``None`` without it."""
    return wrapper_settings(value, where).residual


@functools.lru_cache(maxsize=None)
def load_recipes(algo: str) -> dict[str, TrainingRecipe]:
    """Every recipe of ``algo``'s packaged zoo file, by env id (none without a file)."""
    import yaml

    algo = algo.lower()
    path = hyperparameter_file(algo)
    if not path.is_file():
        return {}
    entries = yaml.safe_load(path.read_text()) or {}
    return {env_id: _recipe(algo, env_id, entry) for env_id, entry in entries.items()}


def recipe_for(scene: str, algo: str) -> TrainingRecipe:
    """The recipe of ``scene`` and ``algo`` (any case): an algorithm, or a learned
    controller that trains on a variant of the scene (``ppo-robust``: the entry of
    ``ChainCart-<scene>-robust-v0`` in ``ppo.yml``, else the scene's; ``ppo-residual``:
    that of ``ChainCart-<scene>-residual-v0``, and without one a
    :class:`~chaincart_env.tools.controllers.NotApplicable` naming the scenes that have
    one); :data:`GENERIC` without one."""
    from chaincart_env.tools.controllers import CONTROLLERS

    name = algo.lower()
    controller = CONTROLLERS.get(name)
    recipes = load_recipes(controller.recipe_algorithm if controller is not None else name)
    variant = controller.variant if controller is not None else None
    if variant is not None and scene_env_id(scene, variant) in recipes:
        return recipes[scene_env_id(scene, variant)]
    if controller is not None and not controller.takes_scene_methods:
        from chaincart_env.tools.controllers import NotApplicable

        raise NotApplicable(
            f"{name} has no recipe for {scene}: expected an entry {scene_env_id(scene, variant)} in "
            f"{controller.recipe_algorithm}.yml (residual recipes exist for "
            f"{', '.join(residual_scenes(controller.recipe_algorithm)) or 'no scene'})"
        )
    return recipes.get(scene_env_id(scene), GENERIC)


def residual_scenes(algo: str) -> list[str]:
    """The scenes with a residual recipe in ``algo``'s packaged file."""
    from chaincart_env.config import SCENES
    from chaincart_env.residual import RESIDUAL_VARIANT

    recipes = load_recipes(algo)
    return [scene for scene in SCENES if scene_env_id(scene, RESIDUAL_VARIANT) in recipes]


def training_conditions(
    name: str, recipe: Optional[TrainingRecipe] = None, config: Any = None
) -> Optional[dict[str, Any]]:
    """The configuration keys learned controller ``name`` trains with on top of the
    scene's: its variant's (``ppo-robust``:
    :data:`~chaincart_env.robust_training.ROBUST_CONDITIONS`), then ``recipe``'s own
    (its ``env_kwargs``) over them; ``None``: the scene as it is. With ``config`` (the
    configuration the study runs on), a recipe's key that ``config`` sets to other than
    its scene's value is left out: what the user chose is not overridden."""
    from chaincart_env.robust_training import ROBUST_CONDITIONS, ROBUST_VARIANT
    from chaincart_env.tools.controllers import CONTROLLERS

    controller = CONTROLLERS.get(name.lower())
    variant: dict[str, Any] = {}
    if controller is not None and controller.variant is not None and controller.fine_tunes:
        if controller.variant != ROBUST_VARIANT:
            raise InvalidInputError(f"{name}: variant {controller.variant!r} has no training conditions; expected "
                                    f"{ROBUST_VARIANT!r}")
        variant = json.loads(json.dumps(ROBUST_CONDITIONS))  # a plain copy, as run.json records it
    own = dict(recipe.conditions) if recipe is not None else {}
    if config is not None and own:
        scene = type(config)(scene=config.scene)
        own = {key: value for key, value in own.items() if getattr(config, key) == getattr(scene, key)}
    conditions = {**variant, **own}
    return conditions or None


def _linear_schedule(start: float) -> Callable[[float], float]:
    """SB3's progress runs from 1 to 0: the value falls linearly from ``start`` to 0."""
    return lambda progress: progress * start


def schedule_start(value: Any) -> Optional[float]:
    """The value a zoo schedule ``lin_<x>`` (x > 0) starts from; ``None`` for anything else."""
    if not isinstance(value, str):
        return None
    kind, _, number = value.partition("_")
    try:
        start = float(number)
    except ValueError:
        return None
    return start if kind == "lin" and start > 0 else None


def _schedule(key: str, value: Any, where: str) -> Any:
    if isinstance(value, str):
        start = schedule_start(value)
        if start is None:
            raise InvalidInputError(f"{where}: {key} = {value!r}: expected a number or 'lin_<number > 0>'")
        return _linear_schedule(start)
    return value


def _dict_call(value: Any, bad: InvalidInputError) -> list[tuple[str, ast.expr]]:
    """The keywords of a zoo string ``"dict(key=..., ...)"`` with their unevaluated
    values (read with :mod:`ast`, never evaluated); ``bad`` for anything else."""
    try:
        call = ast.parse(str(value), mode="eval").body
    except SyntaxError:
        raise bad from None
    if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id == "dict" and not call.args):
        raise bad
    return [(str(keyword.arg), keyword.value) for keyword in call.keywords]


def _policy_kwargs(value: Any, where: str) -> dict[str, Any]:
    """A zoo ``policy_kwargs``: a mapping, or the string ``"dict(key=literal, ...)"``
    (``activation_fn=nn.ReLU``/``nn.Tanh`` allowed)."""
    if isinstance(value, Mapping):
        return dict(value)
    bad = InvalidInputError(f"{where}: policy_kwargs = {value!r}: expected dict(key=literal, ...)")
    out: dict[str, Any] = {}
    for key, node in _dict_call(value, bad):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "nn":
            import torch.nn

            if node.attr not in ("ReLU", "Tanh", "ELU", "LeakyReLU"):
                raise bad
            out[key] = getattr(torch.nn, node.attr)
            continue
        try:
            out[key] = ast.literal_eval(node)
        except ValueError:
            raise bad from None
    return out


def normalize_setting(value: Any, where: str = "normalize") -> Optional[dict[str, Any]]:
    """A zoo ``normalize`` value as SB3 ``VecNormalize`` keywords, or ``None`` for no
    normalisation: ``false``; ``true`` (the zoo's meaning: ``VecNormalize``'s defaults,
    observations and rewards); a mapping or the string
    ``"dict(norm_obs=True, norm_reward=False)"``. Keys other than those of
    :data:`NORMALIZE_KEYS` are refused (``gamma`` is the algorithm's, as in the zoo)."""
    if value is None or value is False:
        return None
    if value is True:
        return {}
    bad = InvalidInputError(f"{where}: normalize = {value!r}: expected true, false or dict(key=literal, ...) "
                            f"with keys among {list(NORMALIZE_KEYS)}")
    if isinstance(value, Mapping):
        keywords = {str(key): item for key, item in value.items()}
    else:
        try:
            keywords = {key: ast.literal_eval(node) for key, node in _dict_call(value, bad)}
        except ValueError:
            raise bad from None
    unsupported = sorted(set(keywords) - set(NORMALIZE_KEYS))
    if unsupported:
        raise InvalidInputError(f"{where}: normalize keys {unsupported} are not supported; expected some of "
                                f"{list(NORMALIZE_KEYS)} (gamma is the algorithm's)")
    for key in ("norm_obs", "norm_reward"):
        if not isinstance(keywords.get(key, True), bool):
            raise InvalidInputError(f"{where}: normalize {key} = {keywords[key]!r}: expected true or false")
    for key in ("clip_obs", "clip_reward"):
        clip = keywords.get(key, 10.0)
        if isinstance(clip, bool) or not isinstance(clip, (int, float)) or not clip > 0:
            raise InvalidInputError(f"{where}: normalize {key} = {clip!r}: expected a number > 0")
    return keywords


def sb3_keywords(hyperparameters: Mapping[str, Any], where: str = "hyperparameters") -> dict[str, Any]:
    """A recipe's keywords as SB3's constructor takes them: ``lin_<x>`` schedules become
    functions, a ``policy_kwargs`` string a dict, a ``train_freq`` list a tuple."""
    out = dict(hyperparameters)
    for key in ("learning_rate", "clip_range"):
        if key in out:
            out[key] = _schedule(key, out[key], where)
    if "policy_kwargs" in out:
        out["policy_kwargs"] = _policy_kwargs(out["policy_kwargs"], where)
    if isinstance(out.get("train_freq"), list):
        out["train_freq"] = tuple(out["train_freq"])
    return out
