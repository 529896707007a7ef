"""``python -m chaincart_env animate``: a GIF (Pillow) or MP4 (imageio with
imageio-ffmpeg) of one episode of any scene under any policy: ``random``, ``zero``,
``lqr`` or a saved stable-baselines3 model (a ``.zip``, or a run folder written by
``compare`` holding ``model.zip``, ``config.json`` and ``run.json``).

Frames are drawn by the env's ``rgb_array`` rendering, one every
``round(1 / (dt * fps))`` steps, so the animation plays in real time at
``1 / (dt * stride)`` frames per second (GIF frame delays are whole centiseconds:
at most 50 fps).
"""

from __future__ import annotations

import argparse
import ast
import json
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np

from chaincart_env.cli_text import plain, scene_help
from chaincart_env.config import DEFAULT_SCENE, ChainCartConfig
from chaincart_env.errors import ChainCartError, InvalidInputError, MissingExtraError
from chaincart_env.env import ChainCartEnv
from chaincart_env.rendering import DEFAULT_FRAME_SIZE

__all__ = ["Animation", "animate", "add_animate_command", "load_sb3_model", "parse_settings", "make_policy"]

#: Policies by name; anything else is a path to a saved SB3 model.
POLICY_NAMES = ("random", "zero", "lqr")
#: Frame rate asked for unless ``--fps`` says otherwise.
DEFAULT_FPS = 25.0
#: Fastest GIF: frame delays are whole centiseconds and browsers slow anything under 2.
MAX_GIF_FPS = 50.0
#: SB3 algorithms tried, in order, on a model whose algorithm no JSON names.
SB3_ALGORITHMS = ("PPO", "SAC", "TD3", "A2C", "DDPG")

Policy = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Animation:
    """What :func:`animate` wrote."""

    path: Path
    frames: int
    fps: float
    steps: int
    steps_per_frame: int
    episode_return: float
    ended: str  # "time limit", "out of track", "numerical failure" or "step limit"
    width: int
    height: int

    def summary(self) -> str:
        """One line saying what was written: file, frames, size, frame rate, steps."""
        return (
            f"wrote {self.path}: {self.frames} frames of {self.width}x{self.height} at {self.fps:g} fps "
            f"({self.frames / self.fps:.2f} s), {self.steps} steps ({self.steps_per_frame} per frame), "
            f"return {self.episode_return:.2f}, ended by {self.ended}"
        )


# -- configuration -------------------------------------------------------------------


def parse_settings(items: Sequence[str]) -> dict[str, Any]:
    """``KEY=VALUE`` strings as config keywords; values are Python literals
    (``0.1``, ``False``, ``(1, -1)``) or else plain strings (``folded``)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise InvalidInputError(f"--set {item!r}: expected KEY=VALUE, e.g. --set n_links=3")
        try:
            out[key.strip()] = ast.literal_eval(text.strip())
        except (ValueError, SyntaxError):
            out[key.strip()] = text.strip()
    return out


# -- policies --------------------------------------------------------------------------


def _model_files(path: Path) -> tuple[Path, Path]:
    """The model zip and the folder holding its JSON files."""
    if path.is_dir():
        return path / "model.zip", path
    return path, path.parent


def _algorithm_named(folder: Path) -> Optional[str]:
    """The algorithm named by ``run.json`` or ``config.json`` beside a model, if any."""
    for name in ("run.json", "config.json"):
        file = folder / name
        if file.is_file():
            data = json.loads(file.read_text())
            if isinstance(data, dict):
                for key in ("algo", "algorithm"):
                    if isinstance(data.get(key), str):
                        return data[key]
    return None


def saved_config(path: Path) -> Optional[dict[str, Any]]:
    """The env keywords in ``config.json`` beside a saved model (``compare`` writes
    them), without any algorithm key; ``None`` when there is none."""
    file = _model_files(Path(path))[1] / "config.json"
    if not file.is_file():
        return None
    data = json.loads(file.read_text())
    if not isinstance(data, dict):
        raise InvalidInputError(f"{file} holds {type(data).__name__}: expected a JSON object of env keywords")
    return {k: v for k, v in data.items() if k not in ("algo", "algorithm")}


def load_sb3_model(path: Path) -> Any:
    """A stable-baselines3 model from a ``.zip`` or a folder with ``model.zip``. The
    algorithm is the one ``run.json`` / ``config.json`` names (key ``algo``), or else
    the first of PPO, SAC, TD3, A2C, DDPG that loads the file."""
    model_path, folder = _model_files(Path(path))
    if not model_path.is_file():
        raise InvalidInputError(
            f"policy {str(path)!r}: expected one of {list(POLICY_NAMES)}, an SB3 model .zip or a folder holding "
            "model.zip"
        )
    try:
        import stable_baselines3 as sb3
    except ImportError as e:
        raise MissingExtraError("loading a saved model needs stable-baselines3: pip install 'chaincart-env[sb3]'") from e
    named = _algorithm_named(folder)
    candidates = [named.upper()] if named else list(SB3_ALGORITHMS)
    failures = []
    for name in candidates:
        algorithm = getattr(sb3, name, None)
        if algorithm is None:
            failures.append(f"{name}: not a stable-baselines3 algorithm")
            continue
        try:
            return algorithm.load(model_path, device="cpu")
        except Exception as e:  # a zip saved by another algorithm fails in its own way
            failures.append(f"{name}: {type(e).__name__}: {e}")
    raise InvalidInputError(f"could not load {model_path} as an SB3 model ({'; '.join(failures)})")


def _sb3_policy(model: Any, env: ChainCartEnv) -> Policy:
    expected = tuple(env.observation_space.shape or ())
    if tuple(model.observation_space.shape) != expected:
        raise InvalidInputError(
            f"the model observes shape {tuple(model.observation_space.shape)} but this scene's observation has "
            f"shape {expected}: expected the scene the model was trained on (drop --scene, or pick it)"
        )
    return lambda obs: model.predict(obs, deterministic=True)[0]


def make_policy(name: str, env: ChainCartEnv, seed: int, model: Any = None) -> Policy:
    """``obs -> action`` for ``random`` (seeded), ``zero``, ``lqr`` (the paper's
    controller for the env's target) or a loaded SB3 ``model``."""
    if model is not None:
        return _sb3_policy(model, env)
    if name == "zero":
        zero = np.zeros(env.config.force_dim, dtype=np.float32)
        return lambda obs: zero
    if name == "random":
        env.action_space.seed(seed)
        return lambda obs: env.action_space.sample()
    if name == "lqr":
        if env.config.max_force <= 0:
            raise InvalidInputError(
                f"--policy lqr on scene {env.config.scene!r} with max_force = {env.config.max_force}: "
                "expected a scene with a force to control with (use --policy zero)"
            )
        from chaincart_env.lqr import LQRPolicy

        lqr = LQRPolicy.from_env(env)
        return lambda obs: lqr.predict(obs)[0]
    raise InvalidInputError(f"policy {name!r}: expected one of {list(POLICY_NAMES)} or a saved model")


# -- writing ---------------------------------------------------------------------------


def _check_output(path: Path) -> str:
    """The container of ``path`` (``gif`` or ``mp4``), checking what it needs."""
    suffix = path.suffix.lower()
    if suffix == ".gif":
        try:
            import PIL  # noqa: F401
        except ImportError as e:
            raise MissingExtraError("writing a GIF needs Pillow: pip install 'chaincart-env[plot]'") from e
        return "gif"
    if suffix == ".mp4":
        try:
            import imageio  # noqa: F401
            import imageio_ffmpeg  # noqa: F401
        except ImportError as e:
            raise MissingExtraError(
                f"writing {path.name} needs imageio and imageio-ffmpeg, not installed: "
                "pip install 'chaincart-env[plot]' (or write a .gif)"
            ) from e
        return "mp4"
    raise InvalidInputError(f"--out {str(path)!r}: expected a file name ending in .gif or .mp4")


def _write_gif(path: Path, frames: Iterator[np.ndarray], fps: float) -> None:
    from PIL import Image

    first = next(frames)
    # Pillow streams the rest from the iterator; identical consecutive frames are
    # merged into one of longer duration.
    Image.fromarray(first).save(
        path,
        save_all=True,
        append_images=(Image.fromarray(f) for f in frames),
        duration=1000.0 / fps,
        loop=0,
    )


def _write_mp4(path: Path, frames: Iterator[np.ndarray], fps: float) -> None:
    import imageio.v2 as imageio

    with imageio.get_writer(path, fps=fps, codec="libx264", macro_block_size=2) as writer:
        for frame in frames:
            writer.append_data(frame)  # type: ignore[attr-defined]


# -- the animation ---------------------------------------------------------------------


def _rollout_frames(
    env: ChainCartEnv, policy: Policy, seed: int, steps: int, stride: int, tally: dict[str, Any]
) -> Iterator[np.ndarray]:
    """Frames of one episode from ``reset(seed)``: the start, every ``stride``-th step,
    and the last step taken (at most ``steps``, fewer if the episode ends)."""
    def frame() -> np.ndarray:
        image = env.render()
        assert image is not None  # rgb_array mode
        return image

    obs, _ = env.reset(seed=seed)
    tally.update(frames=1, steps=0, episode_return=0.0, ended="step limit")
    yield frame()
    for k in range(1, steps + 1):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        tally["steps"], tally["episode_return"] = k, tally["episode_return"] + float(reward)
        over = terminated or truncated or k == steps
        if k % stride == 0 or over:
            tally["frames"] += 1
            yield frame()
        if terminated or truncated:
            tally["ended"] = (
                "out of track" if info.get("out_of_track")
                else "numerical failure" if info.get("numerical_failure")
                else "time limit"
            )
            return


def animate(
    config: ChainCartConfig,
    out: Path,
    policy: str = "lqr",
    *,
    seconds: Optional[float] = None,
    steps: Optional[int] = None,
    fps: float = DEFAULT_FPS,
    width: int = DEFAULT_FRAME_SIZE[0],
    height: int = DEFAULT_FRAME_SIZE[1],
    seed: int = 0,
    model: Any = None,
) -> Animation:
    """Writes an animation of one episode of ``config`` under ``policy`` (or a loaded
    SB3 ``model``) to ``out`` (``.gif`` or ``.mp4``): at most ``steps`` env steps, or
    ``seconds`` of simulated time, or else the whole episode."""
    out = Path(out)
    container = _check_output(out)
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and fps > 0):
        raise InvalidInputError(f"fps = {fps!r}: expected a number > 0")
    if seconds is not None and steps is not None:
        raise InvalidInputError("both seconds and steps given: expected at most one of them")
    if seconds is not None:
        if not (math.isfinite(seconds) and seconds > 0):
            raise InvalidInputError(f"seconds = {seconds!r}: expected a number > 0")
        steps = max(1, round(seconds / config.dt))
    if steps is None:
        steps = config.max_episode_steps
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise InvalidInputError(f"steps = {steps!r}: expected an integer >= 1")
    wanted = min(fps, MAX_GIF_FPS) if container == "gif" else fps
    stride = max(1, math.ceil(1.0 / (config.dt * wanted) - 1e-9))
    actual_fps = 1.0 / (config.dt * stride)
    env = ChainCartEnv(config, render_mode="rgb_array", render_width=width, render_height=height)
    act = make_policy(policy, env, seed, model)
    tally: dict[str, Any] = {}
    frames = _rollout_frames(env, act, seed, steps, stride, tally)
    out.parent.mkdir(parents=True, exist_ok=True)
    (_write_gif if container == "gif" else _write_mp4)(out, frames, actual_fps)
    env.close()
    return Animation(
        path=out,
        frames=tally["frames"],
        fps=actual_fps,
        steps=tally["steps"],
        steps_per_frame=stride,
        episode_return=tally["episode_return"],
        ended=tally["ended"],
        width=width,
        height=height,
    )


# -- command line ----------------------------------------------------------------------


def add_animate_command(commands: "argparse._SubParsersAction[argparse.ArgumentParser]") -> None:
    """Adds ``animate`` to a subcommand set (its ``handler`` default runs it)."""
    parser = commands.add_parser(
        "animate",
        help="write a GIF or MP4 of one episode of a scene under a policy",
        description=plain(__doc__ or ""),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--scene", default=None, help=scene_help(f"a saved model's scene, else {DEFAULT_SCENE}"))
    parser.add_argument(
        "--set", dest="settings", action="append", default=[], metavar="KEY=VALUE",
        help="config keyword on top of the scene (repeatable), e.g. --set n_links=3 --set target=folded",
    )
    parser.add_argument(
        "--policy", default="lqr",
        help="random, zero, lqr (default) or a saved SB3 model: a .zip or a compare run folder",
    )
    length = parser.add_mutually_exclusive_group()
    length.add_argument("--seconds", type=float, default=None, help="simulated seconds (default: one episode)")
    length.add_argument("--steps", type=int, default=None, help="env steps (default: one episode)")
    parser.add_argument("--out", type=Path, default=None, help="output .gif or .mp4 (default: SCENE.gif)")
    parser.add_argument("--fps", type=float, default=DEFAULT_FPS,
                        help=f"frame rate asked for (default {DEFAULT_FPS:g}; real time, so rounded to dt)")
    parser.add_argument("--width", type=int, default=DEFAULT_FRAME_SIZE[0], help="frame width in pixels")
    parser.add_argument("--height", type=int, default=DEFAULT_FRAME_SIZE[1], help="frame height in pixels")
    parser.add_argument("--seed", type=int, default=0, help="reset seed (and the random policy's)")
    # Usage errors print this subcommand's usage, not the top level's.
    parser.set_defaults(handler=lambda args, _top=None: run_animate_command(args, parser))


def run_animate_command(args: argparse.Namespace, parser: Optional[argparse.ArgumentParser] = None) -> int:
    """Runs ``animate`` from parsed arguments; bad input ends with the parser's usage
    error (exit status 2) when a parser is given."""
    try:
        print(_animation_from_args(args).summary())
    except ChainCartError as e:
        if parser is None:
            raise
        parser.error(str(e))
    return 0


def _animation_from_args(args: argparse.Namespace) -> Animation:
    settings = parse_settings(args.settings)
    model = None
    keywords: dict[str, Any] = {}
    if args.policy not in POLICY_NAMES:
        model = load_sb3_model(Path(args.policy))
        if args.scene is None:
            keywords = saved_config(Path(args.policy)) or {}
    if args.scene is not None:
        keywords = {"scene": args.scene}
    config = ChainCartConfig(**{**keywords, **settings})
    out = args.out if args.out is not None else Path(f"{config.scene}.gif")
    return animate(
        config, out, args.policy, seconds=args.seconds, steps=args.steps, fps=args.fps,
        width=args.width, height=args.height, seed=args.seed, model=model,
    )
