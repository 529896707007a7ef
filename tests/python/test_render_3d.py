"""The 3-D view and the render_view key: stored golden images held to a small
tolerance (regenerate with ``python tests/python/test_render_3d.py --write`` after a
deliberate change of the picture, and look at them), frames that are neither blank
nor uniform, determinism, camera settings and their errors, the tip's trail, and
video recording with Gymnasium's ``RecordVideo`` on the single and the vector env."""

from __future__ import annotations

import sys
import threading
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from PIL import Image

from chaincart_env import ChainCartEnv, ChainCartError, ChainCartVectorEnv, _core
from chaincart_env.config import CONFIG_KEYS, ChainCartConfig
from chaincart_env.rendering import Camera, ChainRenderer, EnvRendering

GOLDEN = Path(__file__).resolve().parents[1] / "data" / "render"


def fig3_state() -> np.ndarray:
    return np.asarray(_core.paper_initial_condition("paper-fig3"))


def swinging_trail() -> np.ndarray:
    a = np.linspace(0.0, 2.5, 30)
    return np.column_stack([0.25 * np.sin(a), 0.1 * np.sin(2 * a), -0.45 * np.cos(a)])


#: name -> (frame, made by the current renderer). Small frames keep the files small.
GOLDEN_CASES: dict[str, Callable[[], np.ndarray]] = {
    "3d-paper-fig3": lambda: _core.render_frame(
        [0.1] * 5, fig3_state(), [6.0, -3.0], target=[-1.0, -1.0, -1.0, 1.0, 1.0], max_force=20.0,
        track_limit=10.0, width=160, height=120, view="3d", trail=swinging_trail(),
    ),
    "3d-planar-fixed": lambda: _core.render_frame(
        [0.5, 0.5], ChainCartEnv(scene="inverted-2").model.to_spatial(np.array([0.3, 0.0, 0.6, -0.8, -0.3, -0.95, 0, 0])),
        [-10.0, 0.0], target=[-1.0, -1.0], max_force=20.0, track_limit=1.5, width=160, height=120, view="3d",
        planar=True, azimuth=10.0, elevation=25.0,
    ),
    "side+top-paper-fig3": lambda: _core.render_frame(
        [0.1] * 5, fig3_state(), [6.0, -3.0], target=[-1.0, -1.0, -1.0, 1.0, 1.0], max_force=20.0,
        track_limit=10.0, width=128, height=64, view="side+top",
    ),
    "top-paper-fig3": lambda: _core.render_frame(
        [0.1] * 5, fig3_state(), [6.0, -3.0], max_force=20.0, track_limit=10.0, width=64, height=64, view="top",
    ),
}


def write_golden() -> None:
    GOLDEN.mkdir(parents=True, exist_ok=True)
    for name, make in GOLDEN_CASES.items():
        Image.fromarray(make()).save(GOLDEN / f"{name}.png", optimize=True)


@pytest.mark.parametrize("name", sorted(GOLDEN_CASES))
def test_frames_match_the_golden_images(name: str) -> None:
    frame = GOLDEN_CASES[name]()
    golden = np.asarray(Image.open(GOLDEN / f"{name}.png").convert("RGB"))
    assert frame.shape == golden.shape
    diff = np.abs(frame.astype(int) - golden.astype(int)).max(axis=2)
    # Small tolerance: last-bit differences of the maths library may move a few edge
    # pixels a little, never the picture.
    assert diff.mean() < 0.5, f"mean difference {diff.mean():.3f}"
    assert (diff > 24).mean() < 0.005, f"{(diff > 24).mean():.2%} of pixels differ by more than 24"


@pytest.mark.parametrize("name", sorted(GOLDEN_CASES))
def test_frames_are_neither_blank_nor_uniform(name: str) -> None:
    frame = GOLDEN_CASES[name]()
    colours = np.unique(frame.reshape(-1, 3), axis=0)
    assert frame.std() > 8 and len(colours) > 20, (frame.std(), len(colours))
    # The chain's orange masses and the cart's blue are there.
    r, g, b = (frame[..., k].astype(int) for k in range(3))
    assert ((r > 120) & (r > g + 40) & (g > b + 15)).sum() >= 4
    assert ((b > r + 40) & (b > g + 20)).sum() >= 4


def test_frames_are_deterministic_across_calls_and_threads() -> None:
    # The renderer reuses per-thread buffers: frames drawn after others, or on other
    # threads at once, are bit for bit the same.
    first = {name: make() for name, make in GOLDEN_CASES.items()}
    again = {name: make() for name, make in reversed(list(GOLDEN_CASES.items()))}
    results: dict[tuple[int, str], np.ndarray] = {}

    def work(k: int) -> None:
        for name, make in GOLDEN_CASES.items():
            results[(k, name)] = make()

    threads = [threading.Thread(target=work, args=(k,)) for k in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for name in GOLDEN_CASES:
        np.testing.assert_array_equal(first[name], again[name])
        for k in range(3):
            np.testing.assert_array_equal(first[name], results[(k, name)])


# -- the render_view key -----------------------------------------------------------------


def test_render_view_is_a_config_key_with_the_scene_default() -> None:
    assert "render_view" in [k[0] for k in CONFIG_KEYS]
    assert ChainCartConfig(scene="inverted-2").render_view is None
    assert ChainCartConfig(scene="inverted-2").view == "side"
    assert ChainCartConfig(scene="paper-fig3").view == "3d"
    assert ChainCartConfig(planar=False).view == "3d"
    for view in ("3d", "side", "top", "side+top"):
        assert ChainCartConfig(render_view=view).view == view
    with pytest.raises(ChainCartError, match='unknown render_view "3D" \\(did you mean "3d"\\?\\): expected one of "3d", "side", "top", "side\\+top"'):
        ChainCartConfig(render_view="3D")


def test_default_frame_sizes_follow_the_view() -> None:
    for scene, view, shape in (("inverted-2", None, (240, 480, 3)), ("paper-fig3", None, (360, 480, 3)),
                               ("inverted-2", "3d", (360, 480, 3)), ("paper-fig3", "side+top", (240, 480, 3))):
        env = ChainCartEnv(scene=scene, render_view=view, render_mode="rgb_array")
        env.reset(seed=0)
        assert env.render().shape == shape


def test_every_view_draws_through_the_env() -> None:
    frames = {}
    for view in ("3d", "side", "top", "side+top"):
        env = ChainCartEnv(scene="paper-fig2", render_view=view, render_mode="rgb_array", render_width=96,
                           render_height=64)
        env.reset(seed=1)
        env.step(np.array([0.5, -0.5], np.float32))
        frames[view] = env.render()
        assert frames[view].shape == (64, 96, 3) and frames[view].std() > 5
    assert len({f.tobytes() for f in frames.values()}) == 4


# -- camera ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "settings, message",
    [
        ({"elevation": 95.0}, r"elevation = 95: expected an angle in degrees in \[-90, 90\]"),
        ({"fov": 0.0}, r"fov = 0: expected a vertical field of view in degrees in \[1, 120\]"),
        ({"fov": 170.0}, r"fov = 170"),
        ({"distance": -1.0}, r"distance = -1: expected a finite distance > 0"),
        ({"distance": float("inf")}, r"distance = inf"),
        ({"azimuth": float("nan")}, r"azimuth = NaN: expected a finite angle"),
        ({"azimuth": "north"}, r"camera azimuth = 'north': expected a number"),
        ({"follow": "yes"}, r"camera follow = 'yes': expected True, False or None"),
        ({"zoom": 2.0}, r"unknown settings \['zoom'\]"),
    ],
)
def test_bad_camera_values_get_a_clear_error(settings: dict[str, Any], message: str) -> None:
    for make in (
        lambda: ChainCartEnv(render_mode="rgb_array", render_camera=settings),
        lambda: ChainCartVectorEnv(2, render_mode="rgb_array", render_camera=settings),
        lambda: ChainCartEnv(render_camera=settings),  # checked without a render mode too
    ):
        with pytest.raises(ChainCartError, match=message):
            make()
    with pytest.raises(ChainCartError):
        ChainCartEnv(render_camera=42)


def test_camera_settings_change_the_picture_and_round_trip() -> None:
    def frame(**camera: Any) -> np.ndarray:
        env = ChainCartEnv(scene="paper-fig3", render_mode="rgb_array", render_width=96, render_height=72,
                           render_camera=camera)
        env.reset(seed=0)
        return env.render()

    base = frame()
    np.testing.assert_array_equal(base, frame(**Camera().as_kwargs()))
    for change in ({"azimuth": 120.0}, {"elevation": 60.0}, {"distance": 3.0}, {"fov": 60.0}, {"follow": False}):
        assert not np.array_equal(base, frame(**change)), change
    assert Camera(elevation=45).elevation == 45.0 and Camera.coerce({"fov": 50}).fov == 50.0
    assert Camera.coerce(None) == Camera()


# -- trail -------------------------------------------------------------------------------


def test_the_trail_follows_the_tip_and_clears_at_reset() -> None:
    def env(trail: float) -> ChainCartEnv:
        e = ChainCartEnv(scene="paper-fig1", render_mode="rgb_array", render_width=96, render_height=72,
                         render_trail=trail, render_camera={"follow": True})
        e.reset(seed=0)
        return e

    with_trail, without = env(0.2), env(0.0)
    assert np.array_equal(with_trail.render(), without.render())  # one point: no line yet
    for _ in range(120):
        with_trail.step(np.zeros(2, np.float32))
        without.step(np.zeros(2, np.float32))
    assert not np.array_equal(with_trail.render(), without.render())
    with_trail.reset(seed=0)
    without.reset(seed=0)
    np.testing.assert_array_equal(with_trail.render(), without.render())
    with pytest.raises(ChainCartError, match="render_trail = -1.0: expected a number of seconds >= 0"):
        ChainCartEnv(render_trail=-1.0)


def test_an_env_without_a_render_mode_keeps_no_trail_and_reads_no_state() -> None:
    rendering = EnvRendering(None, ChainCartConfig(scene="paper-fig1"), None, None, trail=1.0)

    def states() -> np.ndarray:
        raise AssertionError("states read without a render mode")

    rendering.record_tips(states)
    assert rendering.trails == [] and rendering.render([np.zeros(34)]) is None
    # A long trail at short steps keeps every k-th position, at most TRAIL_POINTS.
    config = ChainCartConfig(scene="inverted-2", dt=0.001)
    renderer = ChainRenderer(config, trail=0.5)
    assert (renderer.trail_length, renderer.trail_every) == (101, 5)
    assert ChainRenderer(config.replace(dt=0.02), trail=0.5).trail_length == 26


def test_a_trail_keeps_every_kth_point_and_the_newest() -> None:
    from chaincart_env.rendering import TipTrail

    trail = TipTrail(3, every=2)
    assert trail.points() is None
    for k in range(8):
        trail.add([k, 0.0, 0.0])
    # Kept: 2, 4, 6 (the last three of every second), then the newest, 7.
    np.testing.assert_array_equal(trail.points()[:, 0], [2, 4, 6, 7])
    trail.clear()
    trail.add([1.0, 2.0, 3.0])
    assert trail.points() is None


# -- video recording -----------------------------------------------------------------------


def video_frames(path: Path) -> np.ndarray:
    import imageio.v3 as iio

    return np.asarray(iio.imread(path))


def test_record_video_on_the_single_env_records_each_frame_of_the_episode(tmp_path: Path) -> None:
    from gymnasium.wrappers import RecordVideo

    def make() -> gym.Env:
        return gym.make("ChainCart-v0", render_mode="rgb_array", render_view="3d", render_width=96, render_height=64,
                        config={"max_episode_steps": 8}, max_episode_steps=8)

    env = RecordVideo(make(), str(tmp_path), episode_trigger=lambda e: e == 0, name_prefix="chain", disable_logger=True)
    reference = make()
    env.reset(seed=0)
    reference.reset(seed=0)
    expected = [reference.render()]
    env.action_space.seed(0)
    for _ in range(8):
        action = env.action_space.sample()
        _, _, terminated, truncated, _ = env.step(action)
        reference.step(action)
        expected.append(reference.render())
    assert truncated and not terminated
    env.reset(seed=1)  # ends the recording of episode 0
    env.close()
    assert sorted(p.name for p in tmp_path.glob("*.mp4")) == ["chain-episode-0.mp4"]
    frames = video_frames(tmp_path / "chain-episode-0.mp4")
    # The reset frame and one per step, each the env's frame (up to the video codec).
    assert frames.shape == (9, 64, 96, 3)
    for got, want in zip(frames, expected):
        assert np.abs(got.astype(int) - want).mean() < 4
    assert np.abs(frames[0].astype(int) - frames[-1]).mean() > 0.2  # the chain moved


@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_record_video_on_the_vector_env_follows_gymnasium(mode: AutoresetMode, tmp_path: Path) -> None:
    # Gymnasium 1.x: the vector RecordVideo records env 0's episodes (counted by env
    # 0), each frame all envs' frames in a grid near the aspect ratio asked for; with
    # same-step autoreset the episode's last frame is the next episode's first.
    from gymnasium.wrappers.vector import RecordVideo

    envs = RecordVideo(
        ChainCartVectorEnv(4, autoreset_mode=mode, render_mode="rgb_array", render_view="3d", render_width=48,
                           render_height=32, max_episode_steps=5),
        str(tmp_path), episode_trigger=lambda e: e in (0, 1), video_aspect_ratio=(1, 1), name_prefix="chain",
    )
    envs.reset(seed=0)
    f = envs.render()
    first = np.vstack([np.hstack([f[0], f[1]]), np.hstack([f[2], f[3]])])
    envs.action_space.seed(0)
    for _ in range(13):
        _, _, terminated, truncated, _ = envs.step(envs.action_space.sample())
        done = terminated | truncated
        if mode == AutoresetMode.DISABLED and done.any():
            envs.reset(options={"reset_mask": done})
    envs.close()
    assert sorted(p.name for p in tmp_path.glob("*.mp4")) == ["chain-episode-0.mp4", "chain-episode-1.mp4"]
    frames = video_frames(tmp_path / "chain-episode-0.mp4")
    assert frames.shape[1:] == (64, 96, 3)  # 4 envs of 48 x 32 in 2 x 2
    assert len(frames) == (5 if mode == AutoresetMode.SAME_STEP else 6)
    assert np.abs(frames[0].astype(int) - first).mean() < 4


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python tests/python/test_render_3d.py --write  (rewrites the golden images)")
    write_golden()
