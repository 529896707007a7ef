"""``python -m chaincart_env animate``: a GIF (Pillow) or MP4 (imageio with
imageio-ffmpeg) of one episode of any scene under one or several policies side by
side from the same start, or a PNG still of chosen moments. Each ``--policy`` is, on
its own, a built-in one (``random``, ``zero``, ``lqr``, ``trajectory``,
``trajectory-soft``, ``mpc``, ``energy``) or a saved stable-baselines3 model (a ``.zip``, or a run folder written by
``compare`` holding ``model.zip``, ``config.json`` and ``run.json``) or a shipped agent
(``pretrained:<scene>/<name>``), so built-in policies and saved models mix in any
order. Without ``--scene`` the scene is the saved models' and shipped agents' (they
must agree), else the default.

Frames are drawn by the env's ``rgb_array`` rendering in the 3-D view (``--view``
picks another), each under a band naming its policy with the time stamp, one every
``round(1 / (dt * fps))`` steps, so the animation plays in real time at
``1 / (dt * stride)`` frames per second (GIF frame delays are whole centiseconds:
at most 50 fps). A policy whose episode ended keeps showing its last frame.
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
from chaincart_env.env import ChainCartEnv
from chaincart_env.errors import ChainCartError, InvalidInputError, MissingExtraError
from chaincart_env.pretrained_agents import is_pretrained_slot, parse_pretrained_slot, pretrained
from chaincart_env.rendering import RENDER_VIEWS, Camera, default_frame_size

__all__ = ["Animation", "animate", "add_animate_command", "load_sb3_model", "parse_settings", "make_policy"]

#: Policies by name; anything else is a path to a saved SB3 model.
POLICY_NAMES = ("random", "zero", "lqr", "trajectory", "trajectory-soft", "mpc", "energy")
#: Frame rate asked for unless ``--fps`` says otherwise.
DEFAULT_FPS = 25.0
#: Fastest GIF: frame delays are whole centiseconds and browsers slow anything under 2.
MAX_GIF_FPS = 50.0
#: SB3 algorithms tried, in order, on a model whose algorithm no JSON names.
SB3_ALGORITHMS = ("PPO", "SAC", "TD3", "A2C", "DDPG")
#: Seconds of the tip's path drawn as a trail unless asked otherwise.
DEFAULT_TRAIL = 1.0
#: Frames of a still (``.png``) unless ``times`` are given: evenly spaced over the run.
DEFAULT_STILL_FRAMES = 4

Policy = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Animation:
    """What :func:`animate` wrote. ``episode_return`` and ``ended`` are the first
    policy's; ``returns`` and ``endings`` every policy's, in order."""

    path: Path
    frames: int
    fps: float
    steps: int
    steps_per_frame: int
    episode_return: float
    ended: str  # "time limit", "out of track", "numerical failure" or "step limit"
    width: int
    height: int
    policies: tuple[str, ...] = ()
    returns: tuple[float, ...] = ()
    endings: tuple[str, ...] = ()

    def summary(self) -> str:
        """One line saying what was written: file, frames, size, frame rate, steps."""
        runs = "; ".join(f"{p}: return {r:.2f}, ended by {e}" for p, r, e in zip(self.policies, self.returns, self.endings))
        if self.path.suffix.lower() == ".png":
            return f"wrote {self.path}: a still of {self.frames} frames of {self.width}x{self.height} ({runs})"
        return (
            f"wrote {self.path}: {self.frames} frames of {self.width}x{self.height} at {self.fps:g} fps "
            f"({self.frames / self.fps:.2f} s), {self.steps} steps ({self.steps_per_frame} per frame); {runs}"
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
    the first of PPO, SAC, TD3, A2C, DDPG that loads the file. With normalisation statistics
    beside it (``compare``'s ``vecnormalize.pkl``), it acts on observations normalised with them."""
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
            model = algorithm.load(model_path, device="cpu")
        except Exception as e:  # a zip saved by another algorithm fails in its own way
            failures.append(f"{name}: {type(e).__name__}: {e}")
            continue
        from chaincart_env.tools.compare.normalization import load_statistics, with_statistics

        return with_statistics(model, load_statistics(model_path))
    raise InvalidInputError(f"could not load {model_path} as an SB3 model ({'; '.join(failures)})")


def _sb3_policy(name: str, model: Any, env: ChainCartEnv) -> Policy:
    expected = tuple(env.observation_space.shape or ())
    if tuple(model.observation_space.shape) != expected:
        raise InvalidInputError(
            f"policy {name!r}: the model observes shape {tuple(model.observation_space.shape)} but scene "
            f"{env.config.scene!r} observes shape {expected}: expected the scene the model was trained on "
            "(drop --scene, or pick it)"
        )
    return lambda obs: model.predict(obs, deterministic=True)[0]


def make_policy(name: str, env: ChainCartEnv, seed: int, model: Any = None) -> Policy:
    """``obs -> action`` for ``random`` (seeded), ``zero``, ``lqr`` (the paper's
    controller for the env's target), the large-motion controllers ``trajectory``,
    ``trajectory-soft``, ``mpc`` and ``energy`` (designed on the env's model; the episode
    starts at the first call), a loaded SB3 ``model``, a shipped agent
    ``pretrained:<scene>/<name>``, or else the SB3 model saved at the path ``name`` (see
    :func:`load_sb3_model`)."""
    if model is not None:
        return _sb3_policy(name, model, env)
    if is_pretrained_slot(name):
        agent = pretrained(*parse_pretrained_slot(name))
        agent.check_config(env.config)
        return lambda obs: agent.predict(obs)[0]
    if name not in POLICY_NAMES:
        return _sb3_policy(name, load_sb3_model(Path(name)), env)
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
        from chaincart_env.policies.lqr import LQRPolicy

        lqr = LQRPolicy.from_env(env)
        return lambda obs: lqr.predict(obs)[0]
    # The other built-in names are the large-motion controllers of the controller table.
    from chaincart_env.tools.controllers import NotApplicable, build_model_based

    try:
        controller = build_model_based(name, env.config)
    except NotApplicable as error:
        raise InvalidInputError(f"--policy {name}: {error}") from None
    return lambda obs: controller.predict(obs)[0]


# -- writing ---------------------------------------------------------------------------


def _check_pillow(what: str) -> None:
    try:
        import PIL  # noqa: F401
    except ImportError as e:
        raise MissingExtraError(f"{what} needs Pillow: pip install 'chaincart-env[plot]'") from e


def _check_output(path: Path) -> str:
    """The container of ``path`` (``gif``, ``mp4`` or ``png``), checking what it needs
    (Pillow draws the labels of every kind)."""
    suffix = path.suffix.lower()
    if suffix == ".png":
        _check_pillow("writing a PNG still")
        return "png"
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
        _check_pillow("labelling the frames")
        return "mp4"
    raise InvalidInputError(f"--out {str(path)!r}: expected a file name ending in .gif, .mp4 or .png")


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


class _Run:
    """One policy's episode from the shared start, stepped on demand, with its frame."""

    def __init__(self, name: str, env: ChainCartEnv, policy: Policy, seed: int) -> None:
        self.name, self.env, self.policy = name, env, policy
        self.obs, _ = env.reset(seed=seed)
        self.steps, self.episode_return, self.ended = 0, 0.0, "step limit"
        self.over = False
        self.frame = self._render()

    def _render(self) -> np.ndarray:
        image = self.env.render()
        assert image is not None  # rgb_array mode
        return image

    def advance(self, to_step: int) -> None:
        """Steps until ``to_step`` steps are done (or the episode ends), then draws."""
        if self.over or self.steps >= to_step:
            return
        while self.steps < to_step:
            self.obs, reward, terminated, truncated, info = self.env.step(self.policy(self.obs))
            self.steps += 1
            self.episode_return += float(reward)
            if terminated or truncated:
                self.over = True
                self.ended = (
                    "out of track" if info.get("out_of_track")
                    else "fell" if info.get("fell")
                    else "numerical failure" if info.get("numerical_failure")
                    else "time limit"
                )
                break
        self.frame = self._render()


def _font(size: int) -> Any:
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: one bitmap size
        return ImageFont.load_default()


def _label_height(height: int) -> int:
    """Height of the band above each frame holding its label: about a 16th of the
    frame, at least 12 pixels, even (video encoders want even sizes)."""
    return 2 * max(6, round(height / 32))


def _compose(rows: Sequence[Sequence[tuple[np.ndarray, str]]]) -> np.ndarray:
    """Frames in a grid (rows of equal frames), each under a band with its label."""
    from PIL import Image, ImageDraw

    h, w, _ = rows[0][0][0].shape
    band = _label_height(h)
    columns = max(len(r) for r in rows)
    canvas = Image.new("RGB", (columns * w, len(rows) * (h + band)), (255, 255, 255))
    draw = ImageDraw.Draw(canvas)
    font = _font(max(9, round(0.75 * band)))
    for r, row in enumerate(rows):
        for c, (frame, label) in enumerate(row):
            top = r * (h + band)
            canvas.paste(Image.fromarray(frame), (c * w, top + band))
            draw.text((c * w + 4, top + band // 2), label, fill=(20, 20, 20), font=font, anchor="lm")
    return np.asarray(canvas)


def _stamp(run: _Run, dt: float) -> str:
    return f"{run.name}   t = {run.steps * dt:.2f} s"


def _animation_frames(runs: Sequence[_Run], steps: int, stride: int, dt: float, tally: dict[str, Any]) -> Iterator[np.ndarray]:
    """Side-by-side frames of the runs: the start, every ``stride``-th step, and the
    last step (at most ``steps``; fewer when every episode has ended)."""
    tally.update(frames=1, steps=0)
    yield _compose([[(run.frame, _stamp(run, dt)) for run in runs]])
    k = 0
    while k < steps and not all(run.over for run in runs):
        k = min(k + stride, steps)
        for run in runs:
            run.advance(k)
        tally.update(frames=tally["frames"] + 1, steps=max(run.steps for run in runs))
        yield _compose([[(run.frame, _stamp(run, dt)) for run in runs]])


def _still(runs: Sequence[_Run], moments: Sequence[int], dt: float) -> np.ndarray:
    """One row per run, one column per moment (steps from the start)."""
    rows: list[list[tuple[np.ndarray, str]]] = [[] for _ in runs]
    for k in sorted(moments):
        for run, row in zip(runs, rows):
            run.advance(k)
            row.append((run.frame, _stamp(run, dt)))
    return _compose(rows)


def _write_png(path: Path, image: np.ndarray) -> None:
    from PIL import Image

    # An adaptive palette keeps a still of smooth shading small.
    Image.fromarray(image).quantize(colors=256, dither=Image.Dither.NONE).save(path, optimize=True)


def _check_times(times: Sequence[float], steps: int, dt: float) -> list[int]:
    out = []
    for t in times:
        if not (isinstance(t, (int, float)) and math.isfinite(t) and 0 <= t <= steps * dt + 1e-9):
            raise InvalidInputError(f"times = {list(times)!r}: expected seconds in [0, {steps * dt:g}] (the run's length)")
        out.append(round(t / dt))
    if not out:
        raise InvalidInputError("times = []: expected at least one moment")
    return out


def animate(
    config: ChainCartConfig,
    out: Path,
    policy: str | Sequence[str] = "lqr",
    *,
    seconds: Optional[float] = None,
    steps: Optional[int] = None,
    fps: float = DEFAULT_FPS,
    width: Optional[int] = None,
    height: Optional[int] = None,
    seed: int = 0,
    model: Any = None,
    view: str = "3d",
    camera: "Camera | dict[str, Any] | None" = None,
    trail: float = DEFAULT_TRAIL,
    times: Optional[Sequence[float]] = None,
) -> Animation:
    """Writes an animation of one episode of ``config`` under ``policy`` (each a
    built-in name or the path of a saved SB3 model, in any mix; several side by side,
    each from the same ``seed``; a loaded SB3 ``model``, if given, is used for the
    first instead of loading it) to ``out``: ``.gif`` or ``.mp4``, at most ``steps`` env
    steps, or ``seconds`` of simulated time, or else the whole episode; or ``.png``,
    a still of the moments ``times`` (seconds; default: evenly spaced). Frames are of
    ``view`` (``"3d"`` default, seen by ``camera``, with the tip's path over the last
    ``trail`` seconds), ``width x height`` each (default: the view's)."""
    out = Path(out)
    container = _check_output(out)
    names = [policy] if isinstance(policy, str) else list(policy)
    if not names:
        raise InvalidInputError("policy = []: expected at least one policy")
    if view not in RENDER_VIEWS:
        raise InvalidInputError(f"view = {view!r}: expected one of {list(RENDER_VIEWS)}")
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
    shown = config.replace(render_view=view)
    width, height = (default_frame_size(view)[0] if width is None else width,
                     default_frame_size(view)[1] if height is None else height)
    runs = []
    for k, (name, label) in enumerate(zip(names, _policy_labels(names))):
        env = ChainCartEnv(shown, render_mode="rgb_array", render_width=width, render_height=height,
                           render_camera=camera, render_trail=trail)
        runs.append(_Run(label, env, make_policy(name, env, seed, model if k == 0 else None), seed))
    out.parent.mkdir(parents=True, exist_ok=True)
    tally: dict[str, Any] = {}
    if container == "png":
        moments = _check_times(times, steps, config.dt) if times is not None else [
            round(steps * i / (DEFAULT_STILL_FRAMES - 1)) for i in range(DEFAULT_STILL_FRAMES)]
        _write_png(out, _still(runs, moments, config.dt))
        tally.update(frames=len(moments) * len(runs), steps=max(run.steps for run in runs))
    else:
        frames = _animation_frames(runs, steps, stride, config.dt, tally)
        (_write_gif if container == "gif" else _write_mp4)(out, frames, actual_fps)
    for run in runs:
        run.env.close()
    return Animation(
        path=out,
        frames=tally["frames"],
        fps=actual_fps,
        steps=tally["steps"],
        steps_per_frame=stride,
        episode_return=runs[0].episode_return,
        ended=runs[0].ended,
        width=width,
        height=height,
        policies=tuple(run.name for run in runs),
        returns=tuple(run.episode_return for run in runs),
        endings=tuple(run.ended for run in runs),
    )


def _policy_label(name: str) -> str:
    """A policy's label: its name (a shipped agent's slot), or a saved model's folder or file name."""
    if name in POLICY_NAMES or is_pretrained_slot(name):
        return name
    return Path(name).stem if Path(name).suffix else Path(name).name


def _policy_labels(names: Sequence[str]) -> list[str]:
    """The labels of side-by-side policies: :func:`_policy_label`, or a saved model's
    path as given when that label would be shared with another policy's."""
    short = [_policy_label(str(n)) for n in names]
    return [s if short.count(s) == 1 or n in POLICY_NAMES else str(n) for n, s in zip(names, short)]


# -- command line ----------------------------------------------------------------------


def animate_needs(args: Any) -> dict[str, tuple[str, ...]]:
    """``{extra: modules}`` the animate command needs: Pillow for the labels, imageio and
    its ffmpeg for an MP4, stable-baselines3 for a saved model in any ``--policy`` slot."""
    needs: dict[str, tuple[str, ...]] = {}
    suffix = ".gif" if args.out is None else Path(str(args.out)).suffix.lower()  # default: SCENE.gif
    if suffix in (".gif", ".png", ".mp4"):
        needs["plot"] = ("PIL",)
    if suffix == ".mp4":
        needs["plot"] = ("PIL", "imageio", "imageio_ffmpeg")
    if any(str(p) not in POLICY_NAMES and not is_pretrained_slot(str(p)) for p in args.policies or ()):
        needs["sb3"] = ("stable_baselines3",)
    return needs


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
        "--policy", dest="policies", action="append", default=None, metavar="POLICY",
        help="random, zero, lqr (default), trajectory, trajectory-soft, mpc, energy (the large-motion controllers), "
             "a shipped agent "
             "pretrained:<scene>/<name>, or a saved SB3 model: a .zip or a compare run folder; "
             "repeat it to show several side by side from the same start (each a built-in policy or a saved "
             "model, in any order)",
    )
    length = parser.add_mutually_exclusive_group()
    length.add_argument("--seconds", type=float, default=None, help="simulated seconds (default: one episode)")
    length.add_argument("--steps", type=int, default=None, help="env steps (default: one episode)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output .gif, .mp4, or .png for a still (default: SCENE.gif)")
    parser.add_argument("--times", default=None, metavar="T1,T2,...",
                        help=f"a still's moments in seconds (default: {DEFAULT_STILL_FRAMES} evenly spaced)")
    parser.add_argument("--view", default="3d", choices=list(RENDER_VIEWS), help="picture of the frames (default 3d)")
    parser.add_argument("--azimuth", type=float, default=None, help="camera azimuth, degrees (3d view)")
    parser.add_argument("--elevation", type=float, default=None, help="camera elevation, degrees (3d view)")
    parser.add_argument("--distance", type=float, default=None, help="camera distance, m (default: framed)")
    parser.add_argument("--fov", type=float, default=None, help="vertical field of view, degrees")
    follow = parser.add_mutually_exclusive_group()
    follow.add_argument("--follow", dest="follow", action="store_true", default=None, help="camera follows the cart")
    follow.add_argument("--fixed", dest="follow", action="store_false", help="camera stays on the track's centre")
    parser.add_argument("--trail", type=float, default=DEFAULT_TRAIL,
                        help=f"seconds of the tip's path drawn (default {DEFAULT_TRAIL:g}; 0: none)")
    parser.add_argument("--fps", type=float, default=DEFAULT_FPS,
                        help=f"frame rate asked for (default {DEFAULT_FPS:g}; real time, so rounded to dt)")
    parser.add_argument("--width", type=int, default=None, help="frame width in pixels (default: the view's)")
    parser.add_argument("--height", type=int, default=None, help="frame height in pixels (default: the view's)")
    parser.add_argument("--seed", type=int, default=0, help="reset seed (and the random policy's)")
    # Usage errors print this subcommand's usage, not the top level's.
    parser.set_defaults(handler=lambda args, _top=None: run_animate_command(args, parser), needs=animate_needs)


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


def _camera_from_args(args: argparse.Namespace) -> dict[str, Any]:
    names = ("azimuth", "elevation", "distance", "fov", "follow")
    return {k: getattr(args, k) for k in names if getattr(args, k) is not None}


def _times_from_args(text: Optional[str]) -> Optional[list[float]]:
    if text is None:
        return None
    try:
        return [float(t) for t in text.split(",") if t.strip()]
    except ValueError as e:
        raise InvalidInputError(f"--times {text!r}: expected seconds separated by commas, e.g. 0,0.5,1") from e


def _saved_keywords(policies: Sequence[str]) -> dict[str, Any]:
    """The env keywords the saved models and shipped agents among ``policies`` were
    trained with (``config.json``, the agent's record), which must be the same config
    for all; ``{}`` when none says."""
    found: list[tuple[str, dict[str, Any]]] = []
    for name in policies:
        if is_pretrained_slot(name):
            found.append((name, pretrained(*parse_pretrained_slot(name)).record["config"]))
        elif name not in POLICY_NAMES:
            keywords = saved_config(Path(name))
            if keywords is not None:
                found.append((name, keywords))
    if not found:
        return {}
    first_name, first = found[0]
    first_config = ChainCartConfig(**first).to_dict()
    for name, keywords in found[1:]:
        other = ChainCartConfig(**keywords).to_dict()
        if other != first_config:
            differing = sorted(k for k in first_config.keys() | other.keys() if first_config.get(k) != other.get(k))
            raise InvalidInputError(
                f"policies {first_name!r} and {name!r} were saved with different configs (differing in "
                f"{', '.join(differing)}): expected saved models of one config, or a scene picked with --scene"
            )
    return first


def _animation_from_args(args: argparse.Namespace) -> Animation:
    settings = parse_settings(args.settings)
    policies = args.policies or ["lqr"]
    # Each slot is checked and loaded on its own when the animation starts; the scene
    # is --scene, else the saved models' own.
    keywords = {"scene": args.scene} if args.scene is not None else _saved_keywords(policies)
    config = ChainCartConfig(**{**keywords, **settings})
    out = args.out if args.out is not None else Path(f"{config.scene}.gif")
    return animate(
        config, out, policies, seconds=args.seconds, steps=args.steps, fps=args.fps,
        width=args.width, height=args.height, seed=args.seed, view=args.view,
        camera=_camera_from_args(args), trail=args.trail, times=_times_from_args(args.times),
    )
