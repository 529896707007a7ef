"""``python -m chaincart_env export-agent RUN_OR_ZIP --scene S --name N``: a saved
stable-baselines3 agent as a shipped agent (:mod:`chaincart_env.pretrained_agents`):
its actor's weights and normalisation statistics as plain arrays (``<name>.npz``) and
its record (``<name>.json``), in ``chaincart_env/agents/<scene>/`` unless ``--out-dir``
says otherwise.

The input is a training run's folder of ``compare`` (``seed-<s>/``: ``model.zip``,
``config.json``, ``run.json``, ``vecnormalize.pkl``), one model file of such a folder
(``best_model.zip`` takes ``best_vecnormalize.pkl``), or any SB3 ``.zip``
(``--vecnormalize`` names its statistics). Loading it unpickles the user's own files,
which is why it is done here, once, and never when a shipped agent loads.

Before writing, the export checks that the numpy forward pass gives SB3's deterministic
actions on random and on real observations, then measures the agent's success from
``--episodes`` seeded starts (``--first-seed``, ``--first-seed`` + 1, ...), one
episode per start on its own, and records the outcome of each.
"""

from __future__ import annotations

import argparse
import datetime
import io
import json
import subprocess
import sys
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from chaincart_env.config import DEFAULT_SCENE, ChainCartConfig
from chaincart_env.errors import ChainCartError, InvalidInputError
from chaincart_env.pretrained_agents import (
    AGENTS_DIR,
    FORMAT,
    FORMAT_VERSION,
    PretrainedPolicy,
    load_agent,
)  # fmt: skip

__all__ = [
    "ALGORITHMS", "ExportedAgent", "actor_arrays", "add_export_command", "agent_record", "export_agent",
    "measure_success",
    "normalization_arrays",
]  # fmt: skip

#: The algorithms whose actor can be exported, by name: (module, class).
ALGORITHMS = {
    "ppo": ("stable_baselines3", "PPO"),
    "a2c": ("stable_baselines3", "A2C"),
    "sac": ("stable_baselines3", "SAC"),
    "td3": ("stable_baselines3", "TD3"),
    "ddpg": ("stable_baselines3", "DDPG"),
    "tqc": ("sb3_contrib", "TQC"),
}
#: Largest difference between the numpy actions and SB3's that an export accepts.
TOLERANCE = 1e-5
#: Random observations of the export's check, besides the real ones.
CHECK_OBSERVATIONS = 256


# -- reading the SB3 actor --------------------------------------------------------------


def _activation_name(module: Any) -> tuple[str, dict[str, float]]:
    from torch import nn

    if isinstance(module, nn.Tanh):
        return "tanh", {}
    if isinstance(module, nn.ReLU):
        return "relu", {}
    if isinstance(module, nn.ELU) and float(module.alpha) == 1.0:
        return "elu", {}
    if isinstance(module, nn.LeakyReLU):
        return "leaky_relu", {"negative_slope": float(module.negative_slope)}
    if isinstance(module, nn.SiLU):
        return "silu", {}
    raise InvalidInputError(
        f"activation {module!r}: expected Tanh, ReLU, ELU (alpha 1), LeakyReLU or SiLU, which the numpy forward pass "
        "implements"
    )


def _hidden_layers(modules: Sequence[Any], where: str) -> tuple[list[Any], str, dict[str, float]]:
    """The Linear layers of an SB3 MLP (Linear, activation, Linear, activation, ...) and
    its one activation."""
    from torch import nn

    linears, activations = list(modules[0::2]), list(modules[1::2])
    if len(linears) != len(activations) or not all(isinstance(m, nn.Linear) for m in linears):
        raise InvalidInputError(f"{where}: {list(modules)}: expected Linear layers each followed by an activation")
    names = [_activation_name(m) for m in activations]
    if len({(n, tuple(p.items())) for n, p in names}) > 1:
        raise InvalidInputError(f"{where}: activations {[n for n, _ in names]}: expected one activation throughout")
    name, parameters = names[0] if names else ("tanh", {})
    return linears, name, parameters


def _check_features(extractor: Any, where: str) -> None:
    from stable_baselines3.common.torch_layers import FlattenExtractor

    if not isinstance(extractor, FlattenExtractor):
        raise InvalidInputError(
            f"{where}: features extractor {type(extractor).__name__}: expected SB3's FlattenExtractor (MlpPolicy)"
        )


def _actor_modules(model: Any) -> tuple[list[Any], Any, str]:
    """The hidden Linear layers (with their activations), the output layer and how its
    output becomes an action (``clip`` or ``tanh``) of an SB3 model's actor; anything
    but an MlpPolicy of PPO/A2C, SAC/TQC or TD3/DDPG is an error."""
    from gymnasium import spaces
    from torch import nn

    algorithm = type(model).__name__
    policy = model.policy
    if not isinstance(model.observation_space, spaces.Box) or not isinstance(model.action_space, spaces.Box):
        raise InvalidInputError(
            f"{algorithm} with observation space {model.observation_space} and action space {model.action_space}: "
            "expected Box spaces"
        )
    if getattr(model, "use_sde", False) or getattr(policy, "use_sde", False):
        raise InvalidInputError(f"{algorithm} with use_sde=True: expected a policy without gSDE exploration")
    if algorithm in ("PPO", "A2C"):
        from stable_baselines3.common.distributions import DiagGaussianDistribution

        _check_features(policy.pi_features_extractor, algorithm)
        if not isinstance(policy.action_dist, DiagGaussianDistribution) or policy.squash_output:
            raise InvalidInputError(
                f"{algorithm} with {type(policy.action_dist).__name__} (squash_output={policy.squash_output}): "
                "expected the MlpPolicy's diagonal Gaussian"
            )
        return list(policy.mlp_extractor.policy_net), policy.action_net, "clip"
    if algorithm in ("SAC", "TQC"):
        actor = policy.actor
        _check_features(actor.features_extractor, algorithm)
        return list(actor.latent_pi), actor.mu, "tanh"
    if algorithm in ("TD3", "DDPG"):
        actor = policy.actor
        _check_features(actor.features_extractor, algorithm)
        modules = list(actor.mu)
        if len(modules) < 2 or not isinstance(modules[-1], nn.Tanh):
            raise InvalidInputError(f"{algorithm} actor {modules}: expected an MLP ending in Linear, Tanh")
        return modules[:-2], modules[-2], "tanh"
    raise InvalidInputError(f"algorithm {algorithm}: expected one of PPO, A2C, SAC, TQC, TD3, DDPG")


def actor_arrays(model: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The actor of an SB3 model as arrays (``hidden.<i>.weight``/``bias``,
    ``output.weight``/``bias``, float32) and the record's ``network``."""
    from torch import nn

    hidden_modules, output, squash = _actor_modules(model)
    linears, activation, parameters = _hidden_layers(hidden_modules, type(model).__name__)
    if not isinstance(output, nn.Linear):
        raise InvalidInputError(f"{type(model).__name__} output layer {output!r}: expected a Linear layer")
    arrays: dict[str, np.ndarray] = {}
    for key, layer in [(f"hidden.{i}", m) for i, m in enumerate(linears)] + [("output", output)]:
        arrays[f"{key}.weight"] = layer.weight.detach().cpu().numpy().astype(np.float32)
        arrays[f"{key}.bias"] = layer.bias.detach().cpu().numpy().astype(np.float32)
    network = dict(policy="MlpPolicy", hidden=[int(m.out_features) for m in linears], activation=activation,
                   output=squash, **parameters)
    return arrays, network


def normalization_arrays(statistics: Any) -> tuple[dict[str, np.ndarray], Optional[dict[str, Any]]]:
    """A ``VecNormalize``'s observation statistics as arrays (``obs_mean``, ``obs_var``,
    float64 as SB3 keeps them) and the record's ``normalization`` (``None``: observations
    are not normalised)."""
    if statistics is None or not getattr(statistics, "norm_obs", False):
        return {}, None
    rms = statistics.obs_rms
    if isinstance(rms, dict):
        raise InvalidInputError("VecNormalize of a Dict observation space: expected Box observations")
    from chaincart_env.tools.compare.normalization import observation_variance

    arrays = {"obs_mean": np.asarray(rms.mean, dtype=np.float64),
              "obs_var": np.asarray(observation_variance(statistics), dtype=np.float64)}  # any floor applied
    return arrays, dict(clip_obs=float(statistics.clip_obs), epsilon=float(statistics.epsilon),
                        count=float(rms.count))


# -- loading the user's saved agent (trusted files: SB3 unpickles them) ------------------


def _algorithm(name: str) -> Any:
    import importlib

    from chaincart_env.tools.controllers import CONTROLLERS

    key = name.lower()
    if key in CONTROLLERS and CONTROLLERS[key].learned:  # a trained variant such as ppo-robust: its algorithm
        key = CONTROLLERS[key].recipe_algorithm
    if key not in ALGORITHMS:
        raise InvalidInputError(f"algorithm {name!r}: expected one of {list(ALGORITHMS)}")
    module, attribute = ALGORITHMS[key]
    try:
        return getattr(importlib.import_module(module), attribute)
    except ImportError as error:
        raise InvalidInputError(f"algorithm {name!r} needs {module} ({error}): install it to export this agent") from None


def _load_model(path: Path, algo: Optional[str]) -> tuple[Any, str]:
    if algo is not None:
        return _algorithm(algo).load(path, device="cpu"), algo.lower()
    failures = []
    for name in ALGORITHMS:
        try:
            return _algorithm(name).load(path, device="cpu"), name
        except Exception as error:  # a zip of another algorithm fails in its own way
            failures.append(f"{name}: {type(error).__name__}")
    raise InvalidInputError(f"could not load {path} as an SB3 model ({'; '.join(failures)}): expected --algo")


def _source_files(path: Path) -> tuple[Path, Path]:
    """The model file and the folder that may hold its ``run.json``/``config.json``."""
    from chaincart_env.tools.compare.run_files import MODEL_FILE

    path = Path(path)
    if path.is_dir():
        if not (path / MODEL_FILE).is_file():
            raise InvalidInputError(
                f"{path} holds no {MODEL_FILE}: expected a training run's folder (seed-<s>/ or <algo>/seed-<s>/ of a "
                "compare run) or an SB3 .zip"
            )
        return path / MODEL_FILE, path
    if path.suffix != ".zip" or not path.is_file():
        raise InvalidInputError(f"{path}: expected a training run's folder of compare or an SB3 model .zip that exists")
    return path, path.parent


def _json_beside(folder: Path, name: str) -> dict[str, Any]:
    file = folder / name
    if not file.is_file():
        return {}
    data = json.loads(file.read_text())
    return data if isinstance(data, dict) else {}


def _git_commit() -> Optional[str]:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=Path(__file__).resolve().parent, capture_output=True,
                             text=True, timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


# -- checking and measuring -----------------------------------------------------------------


def _check_against_sb3(policy: PretrainedPolicy, model: Any, statistics: Any, real: np.ndarray, seed: int) -> float:
    """The largest difference between the numpy actions and SB3's deterministic ones
    (on ``statistics``-normalised observations); an error above :data:`TOLERANCE`."""
    rng = np.random.default_rng(seed)
    # The network's inputs: a start observation has an empty (zero) history.
    real = np.concatenate([real, np.zeros((real.shape[0], policy.input_shape[0] - real.shape[1]))], axis=1)
    scale = np.maximum(np.abs(real).max(axis=0), 1.0)
    observations = np.concatenate([real, rng.uniform(-2, 2, (CHECK_OBSERVATIONS, real.shape[1])) * scale])
    observations = observations.astype(model.observation_space.dtype)
    normalized = observations if statistics is None else statistics.normalize_obs(observations)
    expected, _ = model.predict(normalized, deterministic=True)
    actual = policy.forward(observations)
    difference = float(np.max(np.abs(actual - expected)))
    if not difference <= TOLERANCE:
        raise InvalidInputError(
            f"the numpy forward pass differs from SB3's predict by {difference:.3g} (expected at most {TOLERANCE}): "
            "the agent's network is not one this export reproduces"
        )
    return difference


def _start_observations(config: ChainCartConfig, seeds: Sequence[int]) -> np.ndarray:
    batch = config.make_batch(len(seeds), "same_step")
    return np.asarray(batch.reset(list(seeds), None), dtype=np.float64)


def measure_success(policy: Any, config: ChainCartConfig, seeds: Sequence[int]) -> list[int]:
    """The outcome (1: success) of one deterministic episode of ``policy`` from each
    seeded start, each episode run on its own (so that an outcome does not depend on
    the batch it ran in)."""
    from chaincart_env.tools.compare.evaluation import rollout

    return [int(rollout(policy, "agent", config, [seed]).success[0]) for seed in seeds]


# -- export -------------------------------------------------------------------------------


def agent_record(
    model: Any, statistics: Any, config: ChainCartConfig, name: str, training: Optional[dict[str, Any]] = None,
    history: int = 0, elapsed_time: int = 0,
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The record (without its measured success) and arrays of the SB3 ``model``
    (normalising with the ``VecNormalize`` ``statistics``, or ``None``; observing
    ``history`` steps of history and, for ``elapsed_time`` > 0, the elapsed fraction of
    episodes of that many steps; correcting the planner's controller if the model
    records a residual setting) as the agent ``name`` of ``config``'s scene: what
    :class:`PretrainedPolicy` loads."""
    from chaincart_env.residual import residual_setting

    arrays, network = actor_arrays(model)
    statistic_arrays, normalization = normalization_arrays(statistics)
    arrays.update(statistic_arrays)
    record: dict[str, Any] = dict(
        format=FORMAT, format_version=FORMAT_VERSION, scene=config.scene, name=name, algorithm=type(model).__name__,
        network=network,
        observation_space=dict(shape=list(model.observation_space.shape), dtype=str(model.observation_space.dtype)),
        action_space=dict(shape=list(model.action_space.shape), low=model.action_space.low.tolist(),
                          high=model.action_space.high.tolist()),
        history=history, elapsed_time=elapsed_time, residual=residual_setting(model), normalization=normalization,
        config=config.to_dict(), training=training or {},
    )
    return record, arrays


class ExportedAgent(dict):  # type: ignore[type-arg]
    """The record written (a dict), with where its files went."""

    weights: Path
    record_path: Path


def _training_record(info: dict[str, Any], model: Any, command: Optional[str], git_commit: Optional[str],
                     config: ChainCartConfig, algo: str) -> dict[str, Any]:
    seed = info.get("seed", getattr(model, "seed", None))
    if command is None and info:
        command = (f"python -m chaincart_env compare --scene {config.scene} --policies {algo} --seed {seed} "
                   f"--timesteps {info.get('timesteps')}")
        command_source = "reconstructed from run.json"
    else:
        command_source = "given" if command is not None else "unknown"
    commit, commit_source = (git_commit, "given") if git_commit else (info.get("git_commit"), "run.json")
    if not commit:
        commit, commit_source = _git_commit(), "the checkout at export"
    return dict(
        command=command, command_source=command_source, seed=seed, git_commit=commit, git_commit_source=commit_source,
        timesteps=int(model.num_timesteps), hyperparameters=info.get("hyperparameters"),
        num_envs=info.get("num_envs"), normalize=info.get("normalize"),
    )


def _observation_extras(model: Any, config: ChainCartConfig, model_path: Path) -> tuple[int, int]:
    """``(history, elapsed_time)``: the steps of history ``model`` observes on
    ``config``'s env and the episode length whose elapsed fraction it observes (0, 0:
    its plain observation), or an error naming both spaces."""
    from chaincart_env.elapsed_time import observation_extras
    from chaincart_env.env import action_space, observation_space
    from chaincart_env.residual import residual_setting, residual_space

    expected = f"({config.obs_dim},) and ({config.force_dim},), the spaces of scene {config.scene!r}"
    if tuple(model.action_space.shape) != (config.force_dim,):
        raise InvalidInputError(f"{model_path} acts with {model.action_space.shape}: expected {expected}")
    observed = observation_space(config)
    if residual_setting(model) is not None:  # the base's command follows the env's observation
        observed = residual_space(observed, action_space(config))
    try:
        k, timed = observation_extras(model.observation_space, observed, action_space(config))
    except InvalidInputError:
        raise InvalidInputError(f"{model_path} observes {model.observation_space.shape}: expected {expected}, "
                                "or those with k steps of history (--history k) and the elapsed time") from None
    return k, int(config.max_episode_steps) if timed else 0


def export_agent(
    source: Path,
    *,
    scene: Optional[str] = None,
    name: str,
    algo: Optional[str] = None,
    vecnormalize: Optional[Path] = None,
    out_dir: Optional[Path] = None,
    episodes: int = 50,
    first_seed: int = 0,
    command: Optional[str] = None,
    git_commit: Optional[str] = None,
    notes: str = "",
    force: bool = False,
) -> ExportedAgent:
    """Exports the SB3 agent saved at ``source`` (a training run's folder or a ``.zip``)
    as the shipped agent ``scene/name`` into ``out_dir`` (default: the package's
    ``agents`` folder); returns its record. The scene is the one the run's
    ``config.json`` names (``scene``, if given, must be it); a ``.zip`` without one is
    taken to be of ``scene``'s default configuration (default: the default scene)."""
    import stable_baselines3

    from chaincart_env.pretrained_agents import _NAME
    from chaincart_env.tools.compare.evaluation import evaluation_seeds
    from chaincart_env.tools.compare.normalization import normalization_file, read_statistics

    for what, value in (("scene", scene or DEFAULT_SCENE), ("name", name)):
        if not _NAME.match(str(value)):
            raise InvalidInputError(f"--{what} {value!r}: expected lower-case letters, digits, '.', '_' or '-'")
    seeds = evaluation_seeds(first_seed, episodes)
    model_path, folder = _source_files(Path(source))
    info, saved_config = _json_beside(folder, "run.json"), _json_beside(folder, "config.json")
    config = ChainCartConfig(**saved_config) if saved_config else ChainCartConfig(scene=scene or DEFAULT_SCENE)
    if scene is not None and config.scene != scene:
        raise InvalidInputError(f"--scene {scene!r}: the run at {folder} was trained on scene {config.scene!r}")
    scene = config.scene
    root = AGENTS_DIR if out_dir is None else Path(out_dir)
    weights_path, record_path = root / scene / f"{name}.npz", root / scene / f"{name}.json"
    if not force and (weights_path.exists() or record_path.exists()):
        raise InvalidInputError(f"{record_path} exists: expected a new name, or --force to replace it")
    statistics_path = Path(vecnormalize) if vecnormalize is not None else normalization_file(model_path)
    if vecnormalize is not None and not statistics_path.is_file():
        raise InvalidInputError(f"--vecnormalize {statistics_path}: the file does not exist")
    statistics = read_statistics(statistics_path.read_bytes()) if statistics_path.is_file() else None
    model, algo_name = _load_model(model_path, algo or info.get("algo"))
    history, elapsed_time = _observation_extras(model, config, model_path)
    record, arrays = agent_record(model, statistics, config, name,
                                  training=_training_record(info, model, command, git_commit, config, algo_name),
                                  history=history, elapsed_time=elapsed_time)
    record["exported"] = dict(date=datetime.date.today().isoformat(), from_file=model_path.name,
                              statistics_file=statistics_path.name if statistics is not None else None,
                              stable_baselines3=stable_baselines3.__version__)
    if notes:
        record["notes"] = notes
    policy = PretrainedPolicy(record, arrays, source=f"{scene}/{name}")
    difference = _check_against_sb3(policy, model, statistics, _start_observations(config, seeds), first_seed)
    record["exported"]["max_action_difference_from_sb3"] = difference
    outcomes = measure_success(policy, config, seeds)
    record["success"] = dict(
        episodes=len(seeds), first_seed=first_seed, seeds=seeds, outcomes=outcomes, successes=sum(outcomes),
        rate=sum(outcomes) / len(seeds),
        how="one deterministic episode of the numpy policy from each seeded start, each run alone (compare's "
        "evaluation rollout on one env reset with that seed); success is the env's is_success",
    )
    weights_path.parent.mkdir(parents=True, exist_ok=True)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)  # type: ignore[arg-type]  # numpy's stub reads a name as allow_pickle
    weights_path.write_bytes(buffer.getvalue())
    record_path.write_text(json.dumps(record, indent=2) + "\n")
    load_agent(weights_path, record_path)  # what was written loads back
    exported = ExportedAgent(record)
    exported.weights, exported.record_path = weights_path, record_path
    return exported


# -- command line -------------------------------------------------------------------------


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    try:
        exported = export_agent(
            args.source, scene=args.scene, name=args.name, algo=args.algo, vecnormalize=args.vecnormalize,
            out_dir=args.out_dir, episodes=args.episodes, first_seed=args.first_seed, command=args.command,
            git_commit=args.git_commit, notes=args.notes, force=args.force,
        )
    except ChainCartError as error:
        parser.error(str(error))
    success = exported["success"]
    size = exported.weights.stat().st_size + exported.record_path.stat().st_size
    print(f"wrote {exported.weights} and {exported.record_path} ({size / 1024:.1f} KiB): {exported['algorithm']}, "
          f"hidden {exported['network']['hidden']} {exported['network']['activation']}, success "
          f"{success['successes']}/{success['episodes']} on seeds {success['seeds'][0]}..{success['seeds'][-1]}; "
          f"use it as pretrained:{exported['scene']}/{args.name}")
    return 0


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected an integer >= 0")
    return value


def add_export_command(commands: "argparse._SubParsersAction[argparse.ArgumentParser]") -> None:
    """Adds ``export-agent`` to a subcommand set (its handler runs it)."""
    from chaincart_env.cli_text import plain, scene_help

    parser = commands.add_parser(
        "export-agent", help="write a saved SB3 agent as a shipped agent (plain arrays and a JSON record)",
        description=plain(__doc__ or ""), formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("source", type=Path, metavar="RUN_OR_ZIP",
                        help="a training run's folder of compare (seed-<s>/), or an SB3 model .zip")
    parser.add_argument("--scene", default=None,
                        help=scene_help(f"the run's, from its config.json, which --scene must match; else {DEFAULT_SCENE}"))
    parser.add_argument("--name", required=True, help="the agent's name: pretrained:<scene>/<name>")
    parser.add_argument("--algo", default=None, choices=list(ALGORITHMS),
                        help="the algorithm (default: run.json's, else the first that loads the file)")
    parser.add_argument("--vecnormalize", type=Path, default=None,
                        help="the VecNormalize statistics (default: the file compare saves beside the model, if any)")
    parser.add_argument("--out-dir", type=Path, default=None, help=f"where to write (default: {AGENTS_DIR})")
    parser.add_argument("--episodes", type=_count, default=50, help="seeded starts the success is measured on (default 50)")
    parser.add_argument("--first-seed", type=_count, default=0, help="the first of them (default 0)")
    parser.add_argument("--command", default=None, help="the command that trained the agent (default: from run.json)")
    parser.add_argument("--git-commit", default=None, help="the commit it was trained at (default: the current one)")
    parser.add_argument("--notes", default="", help="a sentence for the record")
    parser.add_argument("--force", action="store_true", help="replace an agent of the same scene and name")
    parser.set_defaults(handler=lambda args, _top=None: _run(args, parser),
                        needs=lambda args: {"sb3": ("stable_baselines3", "torch")})


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``export-agent`` on its own (``python -m chaincart_env.tools.export_agent``)."""
    parser = argparse.ArgumentParser(prog="export-agent")
    commands = parser.add_subparsers(dest="command", required=True)
    add_export_command(commands)
    args = parser.parse_args(["export-agent", *(sys.argv[1:] if argv is None else argv)])
    return int(args.handler(args, parser))


if __name__ == "__main__":
    sys.exit(main())
