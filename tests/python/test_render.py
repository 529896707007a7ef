"""Rendering: frames of the Rust rasteriser through ``render_frame`` and the envs,
tiles of vector envs, the animate command, human mode without a display, and bad
input. Geometry of the flat views is checked against the documented conventions (e1
to the right, gravity down) by locating coloured pixels; the 3-D view's pictures are
held against stored images in ``test_render_3d.py``."""

from __future__ import annotations

import copy
import pickle
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from PIL import Image

from chaincart_env import ChainCart, ChainCartEnv, ChainCartError, ChainCartVectorEnv, _core
from chaincart_env.__main__ import main
from chaincart_env.config import ChainCartConfig
from chaincart_env.rendering import (
    RenderUnavailable,
    check_display,
    tile_frames,
    tile_grid,
)
from chaincart_env.rendering.frames import render_fps, steps_per_frame
from chaincart_env.tools.animate import _label_height, animate, load_sb3_model, parse_settings
from chaincart_env.tools.bench.render_benchmark import render_benchmark

SMALL = dict(render_width=96, render_height=48)


def mask_of(frame: np.ndarray, color: str) -> np.ndarray:
    """Pixels of a scene colour: the force arrow (red), the masses (orange), the cart (blue)."""
    r, g, b = (frame[..., k].astype(int) for k in range(3))
    if color == "red":
        return (r > 150) & (g < 90) & (b < 90)
    if color == "orange":
        return (r > 180) & (g > 80) & (g < 160) & (b < 80)
    if color == "blue":
        return (b > 120) & (r < 90) & (g < 110)
    raise ValueError(color)


def centroid(mask: np.ndarray) -> np.ndarray:
    """(row, column) centre of the True pixels."""
    rows, cols = np.nonzero(mask)
    assert rows.size > 0, "no pixel of that colour"
    return np.array([rows.mean(), cols.mean()])


def planar_state(angles: list[float], x: float = 0.0) -> np.ndarray:
    """Planar state with link i at angle angles[i] from hanging (q = (sin a, cos a) in e1-e3)."""
    n = len(angles)
    y = np.zeros(2 + 3 * n)
    y[0] = x
    for i, a in enumerate(angles):
        y[2 + 2 * i : 4 + 2 * i] = (np.sin(a), np.cos(a))
    return y


# -- frames ----------------------------------------------------------------------------


@pytest.mark.parametrize("scene", ["inverted-2", "paper-fig3"])
@pytest.mark.parametrize("size", [(480, 240), (64, 40), (33, 17)])
def test_frames_are_uint8_height_width_3(scene: str, size: tuple[int, int]) -> None:
    env = ChainCartEnv(scene=scene, render_mode="rgb_array", render_width=size[0], render_height=size[1])
    env.reset(seed=0)
    frame = env.render()
    assert isinstance(frame, np.ndarray) and frame.dtype == np.uint8 and frame.shape == (size[1], size[0], 3)
    env.step(env.action_space.sample())
    assert env.render().shape == (size[1], size[0], 3)


def test_identical_states_give_bit_identical_frames_and_other_states_other_frames() -> None:
    a = ChainCartEnv(scene="paper-fig2", render_mode="rgb_array", **SMALL)
    b = ChainCartEnv(scene="paper-fig2", render_mode="rgb_array", **SMALL)
    a.reset(seed=5)
    b.reset(seed=5)
    np.testing.assert_array_equal(a.render(), b.render())
    action = np.array([0.4, -0.3], np.float32)
    for _ in range(200):
        a.step(action)
        b.step(action)
    np.testing.assert_array_equal(a.render(), b.render())
    before = a.render()
    y = a.model_state.copy()
    y[0] += 0.05  # the cart 5 cm further along e1
    a.set_state(y)
    assert not np.array_equal(a.render(), before)


def test_the_target_is_drawn() -> None:
    model = ChainCart(2, planar=False)
    y = model.equilibrium("hanging")
    plain = _core.render_frame([0.1, 0.1], y, [0.0, 0.0], width=96, height=48)
    with_target = _core.render_frame([0.1, 0.1], y, [0.0, 0.0], target=[-1.0, -1.0], width=96, height=48)
    assert not np.array_equal(plain, with_target)


def test_side_view_has_e1_to_the_right_and_gravity_down() -> None:
    # A track shorter than twice the chain is shown whole (a longer one scrolls with the cart).
    env = ChainCartEnv(scene="inverted-1", track_limit=0.9, render_mode="rgb_array", render_width=200, render_height=100)
    env.reset(seed=0)
    cart = lambda: centroid(mask_of(env.render(), "blue"))  # noqa: E731
    mass = lambda: centroid(mask_of(env.render(), "orange"))  # noqa: E731
    env.set_state(planar_state([0.0]))  # hanging: the mass below the cart (rows grow downwards)
    assert mass()[0] > cart()[0] + 10
    env.set_state(planar_state([np.pi]))  # upright: above
    assert mass()[0] < cart()[0] - 10
    env.set_state(planar_state([np.pi / 2]))  # q = +e1: to the right, level with the cart
    assert mass()[1] > cart()[1] + 10 and abs(mass()[0] - cart()[0]) < 5
    left = cart()[1]
    env.set_state(planar_state([np.pi / 2], x=0.5))  # the cart moved along +e1
    assert cart()[1] > left + 5


def test_a_scrolling_track_shows_the_carts_motion() -> None:
    env = ChainCartEnv(scene="paper-fig2", render_mode="rgb_array", **SMALL)
    env.reset(seed=0)
    y = env.model_state.copy()
    before = env.render()
    y[0] += 0.03  # the view follows the cart; the marks on the track move
    env.set_state(y)
    assert not np.array_equal(env.render(), before)


def test_the_force_arrow_shows_the_last_applied_force() -> None:
    env = ChainCartEnv(scene="inverted-1", render_mode="rgb_array", render_width=200, render_height=100)
    env.reset(seed=1)
    start = env.model_state.copy()
    assert not mask_of(env.render(), "red").any(), "no force before the first step"
    frames = {}
    for push in (1.0, -1.0, 0.0):
        env.reset(seed=1)
        env.step(np.array([push], np.float32))
        env.set_state(start)  # same state, so only the arrow differs
        frames[push] = env.render()
    cart_column = centroid(mask_of(frames[0.0], "blue"))[1]
    assert centroid(mask_of(frames[1.0], "red"))[1] > cart_column + 5
    assert centroid(mask_of(frames[-1.0], "red"))[1] < cart_column - 5
    assert not mask_of(frames[0.0], "red").any()
    # Actions beyond [-1, 1] are clipped, as the core clips them: the same arrow.
    env.reset(seed=1)
    env.step(np.array([7.0], np.float32))
    env.set_state(start)
    np.testing.assert_array_equal(env.render(), frames[1.0])
    env.reset(seed=1)  # a reset clears the force
    assert not mask_of(env.render(), "red").any()


def test_spatial_force_shows_in_the_top_view() -> None:
    env = ChainCartEnv(scene="paper-fig2", render_view="side+top", render_mode="rgb_array", render_width=300,
                       render_height=100)
    env.reset(seed=0)
    start = env.model_state.copy()
    frames = []
    for action in ([0.0, 1.0], [0.0, -1.0]):
        env.reset(seed=0)
        env.step(np.array(action, np.float32))
        env.set_state(start)
        frames.append(env.render())
    # A push along e2 has no side-view component: only the top view (right panel,
    # e2 up the screen) differs, with the arrow up for +e2 and down for -e2.
    up, down = (centroid(mask_of(f, "red")) for f in frames)
    assert up[1] > 0.62 * 300 and down[1] > 0.62 * 300
    assert up[0] < down[0] - 5


@pytest.mark.parametrize(
    "wild",
    [
        {0: 1e12},
        {0: -1e300, 2: 1e300},
        {4: np.nan},
        {5: np.inf, 8: -np.inf},
        {0: np.nan, 1: np.nan, 7: 1e12},
        {0: 50.0},  # the cart far beyond the track, off-screen
    ],
)
@pytest.mark.parametrize("view", ["3d", "side", "top", "side+top"])
def test_wild_states_draw_without_crashing(wild: dict[int, float], view: str) -> None:
    y = ChainCart(3).equilibrium("inverted")
    for index, value in wild.items():
        y[index] = value
    for track_limit in (2.0, np.inf):
        frame = _core.render_frame(
            [0.2, 0.2, 0.2], y, [5.0, -1e9], target=[-1.0] * 3, max_force=10.0, track_limit=track_limit,
            width=64, height=32, view=view, trail=np.array([[np.nan, 0, 0], [1e300, 0, 0], [0.0, 0, 0]]),
        )
        assert frame.shape == (32, 64, 3) and frame.dtype == np.uint8


def test_an_env_far_off_the_track_renders() -> None:
    # Huge but valid states (finite, unit links) go through the env's checked set_state.
    for scene, position in (("inverted-2", 1e12), ("paper-fig3", -1e300)):
        env = ChainCartEnv(scene=scene, render_mode="rgb_array", **SMALL)
        env.reset(seed=0)
        y = env.model_state.copy()
        y[0] = position
        env.set_state(y)
        near = env.render()
        assert near.shape == (48, 96, 3)
        env.step(env.action_space.sample())  # ends by leaving the track
        assert env.render().shape == (48, 96, 3)


def test_rgb_array_env_passes_gymnasiums_render_check() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # Infinite bounds are Gymnasium's convention for unbounded components; its own
        # env tests ignore these two warnings of the checker as well.
        warnings.filterwarnings("ignore", message=r".*Box observation space m(in|ax)imum value is -?infinity")
        # Without a spec the checker tries no other modes (human needs a display).
        warnings.filterwarnings("ignore", message=".*Not able to test alternative render modes")
        gym_check_env(ChainCartEnv(render_mode="rgb_array", **SMALL))
    env = gym.make("ChainCart-v0", render_mode="rgb_array", **SMALL)
    env.reset(seed=0)
    assert env.render().shape == (48, 96, 3)
    assert env.metadata["render_modes"] == ["rgb_array", "human"]


def test_render_fps_is_real_time_capped_at_50() -> None:
    assert (render_fps(0.02), steps_per_frame(0.02)) == (50, 1)
    assert (render_fps(0.05), steps_per_frame(0.05)) == (20, 1)
    assert (render_fps(1e-3), steps_per_frame(1e-3)) == (50, 20)
    assert (render_fps(1e-4), steps_per_frame(1e-4)) == (50, 200)
    assert ChainCartEnv(scene="paper-fig3").metadata["render_fps"] == 50
    assert ChainCartVectorEnv(2, dt=0.04).metadata["render_fps"] == 25


def test_copies_render_the_same_frame() -> None:
    env = ChainCartEnv(scene="paper-fig2", render_mode="rgb_array", **SMALL)
    env.reset(seed=2)
    env.step(np.array([0.5, 0.5], np.float32))
    for clone in (copy.deepcopy(env), pickle.loads(pickle.dumps(env))):
        np.testing.assert_array_equal(clone.render(), env.render())


# -- vector envs -----------------------------------------------------------------------


def test_tile_grid_and_tile_frames() -> None:
    assert [tile_grid(k) for k in (1, 2, 3, 4, 5, 9, 10)] == [(1, 1), (1, 2), (2, 2), (2, 2), (2, 3), (3, 3), (3, 4)]
    frames = [np.full((5, 7, 3), k, np.uint8) for k in range(5)]
    tiled = tile_frames(frames)
    assert tiled.shape == (2 * 5 + 2, 3 * 7 + 2 * 2, 3)
    np.testing.assert_array_equal(tiled[7:12, 9:16], frames[4])  # row 1, column 1
    assert (tiled[7:12, 18:25] == 120).all()  # the empty cell is grey
    with pytest.raises(ChainCartError, match="shape"):
        tile_frames([frames[0], np.zeros((5, 8, 3), np.uint8)])


@pytest.mark.parametrize("num_envs, render_envs, grid", [(5, None, (2, 2)), (5, 5, (2, 3)), (3, 1, (1, 1)), (2, None, (1, 2))])
def test_vector_env_tiles_have_the_grid_shape(num_envs: int, render_envs, grid: tuple[int, int]) -> None:
    envs = ChainCartVectorEnv(num_envs, render_mode="rgb_array", render_envs=render_envs, **SMALL)
    envs.reset(seed=0)
    rows, columns = grid
    image = envs.render_tiled()
    assert image.dtype == np.uint8 and image.shape == (rows * 48 + (rows - 1) * 2, columns * 96 + (columns - 1) * 2, 3)


def test_vector_tiles_are_the_single_envs_frames() -> None:
    # Env i of a vector env seeded s is the single env seeded s + i, bit for bit: so
    # are its frames, force arrows included.
    envs = gym.make_vec("ChainCart-v0", num_envs=3, vectorization_mode="vector_entry_point",
                        render_mode="rgb_array", render_envs=3, scene="paper-fig2", **SMALL)
    singles = [ChainCartEnv(scene="paper-fig2", render_mode="rgb_array", **SMALL) for _ in range(3)]
    envs.reset(seed=10)
    for i, env in enumerate(singles):
        env.reset(seed=10 + i)
    actions = np.array([[0.3, 0.1], [-0.8, 0.0], [0.0, 1.0]], np.float32)
    for _ in range(3):
        envs.step(actions)
        for env, action in zip(singles, actions):
            env.step(action)
    image = envs.render_tiled()
    frames = envs.render()
    assert isinstance(frames, tuple) and len(frames) == 3
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(frames[i], env.render())
        r, c = divmod(i, 2)
        np.testing.assert_array_equal(image[r * 50 : r * 50 + 48, c * 98 : c * 98 + 96], env.render())


def test_an_autoreset_env_shows_no_force() -> None:
    envs = ChainCartVectorEnv(2, scene="inverted-1", render_mode="rgb_array", render_envs=2,
                              config=ChainCartConfig(scene="inverted-1", max_episode_steps=2), **SMALL)
    envs.reset(seed=0)
    push = np.ones((2, 1), np.float32)
    envs.step(push)
    assert mask_of(envs.render_tiled(), "red").any()
    envs.step(push)  # the episodes end (time limit)
    envs.step(push)  # next-step autoreset: the action is ignored
    assert not mask_of(envs.render_tiled(), "red").any()


def test_sb3_vecenv_images_and_tiles() -> None:
    from chaincart_env import ChainCartVecEnv

    venv = ChainCartVecEnv(5, seed=3, render_mode="rgb_array", scene="paper-fig2", **SMALL)
    venv.reset()
    actions = np.tile(np.array([[0.5, -0.5]], np.float32), (5, 1))
    venv.step(actions)
    images = venv.get_images()
    assert len(images) == 5 and all(im.shape == (48, 96, 3) for im in images)
    single = ChainCartEnv(scene="paper-fig2", render_mode="rgb_array", **SMALL)
    single.reset(seed=3 + 4)
    single.step(actions[4])
    np.testing.assert_array_equal(images[4], single.render())
    np.testing.assert_array_equal(venv.env_method("render", indices=[4])[0], images[4])
    assert venv.render().shape == (2 * 48 + 2, 2 * 96 + 2, 3)
    assert venv.metadata["render_fps"] == 50 and "rgb_array" in venv.metadata["render_modes"]
    assert ChainCartVecEnv(2).get_images() == [None, None]


# -- human mode ------------------------------------------------------------------------


def headless_steps(make) -> None:
    """A human-mode env that cannot show anything still resets, steps and renders."""
    env = make()
    obs, _ = env.reset(seed=0)
    env.step(np.zeros(env.action_space.shape, np.float32))
    assert env.render() is None and np.all(np.isfinite(obs))
    env.close()


def test_human_mode_without_a_display_warns_once_and_keeps_working(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    monkeypatch.setattr("chaincart_env.rendering.window._warned_headless", False)
    with pytest.warns(UserWarning, match="DISPLAY nor WAYLAND_DISPLAY.*not shown") as caught:
        for make in (
            lambda: ChainCartEnv(render_mode="human"),
            lambda: gym.make("ChainCart-v0", render_mode="human"),
            lambda: ChainCartVectorEnv(2, render_mode="human"),
        ):
            headless_steps(make)
    assert sum("not shown" in str(w.message) for w in caught) == 1
    with pytest.raises(RenderUnavailable, match="DISPLAY nor WAYLAND_DISPLAY") as error:
        check_display()
    assert isinstance(error.value, ChainCartError) and isinstance(error.value, RuntimeError)


def test_human_mode_with_an_unusable_display_warns_and_keeps_working(monkeypatch: pytest.MonkeyPatch) -> None:
    # DISPLAY names an X server that does not exist: matplotlib finds no usable
    # interactive backend (or, if one loads, the window cannot open).
    import matplotlib

    backend = matplotlib.get_backend()
    monkeypatch.setenv("DISPLAY", ":4711")
    monkeypatch.setattr("chaincart_env.rendering.window._warned_headless", False)
    try:
        with pytest.warns(UserWarning, match="interactive matplotlib backend|could not open a window"):
            headless_steps(lambda: ChainCartEnv(render_mode="human"))
    finally:
        import matplotlib.pyplot as plt

        plt.switch_backend(backend)


# -- bad input -------------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["rgb", "ansi", 1, "RGB_ARRAY"])
def test_bad_render_modes_are_refused(mode) -> None:
    for make in (ChainCartEnv, lambda **k: ChainCartVectorEnv(2, **k)):
        with pytest.raises(ChainCartError, match=f"render_mode = {mode!r}: expected None or one of"):
            make(render_mode=mode)


@pytest.mark.parametrize("keyword, value", [("render_width", 8), ("render_height", 10_000), ("render_width", 64.5),
                                            ("render_height", True), ("render_width", "480")])
def test_bad_sizes_are_refused(keyword: str, value) -> None:
    with pytest.raises(ChainCartError, match=f"{keyword} = {value!r}: expected an integer number of pixels in"):
        ChainCartEnv(render_mode="rgb_array", **{keyword: value})
    with pytest.raises(ChainCartError, match=keyword):
        ChainCartVectorEnv(2, render_mode="rgb_array", **{keyword: value})


@pytest.mark.parametrize("render_envs", [0, 4, 2.0, True])
def test_bad_tile_counts_are_refused(render_envs) -> None:
    with pytest.raises(ChainCartError, match=r"render_envs = .*: expected an integer in \[1, num_envs = 3\]"):
        ChainCartVectorEnv(3, render_mode="rgb_array", render_envs=render_envs)


def test_render_without_a_mode_returns_none() -> None:
    env = ChainCartEnv()
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert env.render() is None
    assert ChainCartVectorEnv(2).render() is None


# -- animate ---------------------------------------------------------------------------


def decoded_frames(path: Path) -> list[np.ndarray]:
    with Image.open(path) as im:
        out = []
        for k in range(im.n_frames):
            im.seek(k)
            out.append(np.asarray(im.convert("RGB")))
        return out


def test_animate_writes_a_gif_with_one_frame_per_stride(tmp_path: Path) -> None:
    # dt = 20 ms at 25 fps: a frame every 2 steps, plus the start: 7 steps -> 0, 2, 4, 6, 7.
    out = tmp_path / "run.gif"
    assert main(["animate", "--policy", "random", "--steps", "7", "--out", str(out),
                 "--width", "64", "--height", "48", "--seed", "3"]) == 0
    frames = decoded_frames(out)
    band = _label_height(48)  # the label above the picture
    assert len(frames) == 5 and frames[0].shape == (48 + band, 64, 3)
    with Image.open(out) as im:
        assert im.info["duration"] == 40 and im.info["loop"] == 0
    # The first frame is the seeded start as the env draws it in the 3-D view (up to
    # the GIF palette), under its label.
    env = ChainCartEnv(render_view="3d", render_mode="rgb_array", render_width=64, render_height=48)
    env.reset(seed=3)
    assert np.abs(frames[0][band:].astype(int) - env.render()).mean() < 3
    assert frames[0][:band].min() < 100  # the label's text


def test_animate_api_counts_and_stops_at_the_episode_end(tmp_path: Path) -> None:
    config = ChainCartConfig(scene="paper-fig3", max_episode_steps=100)
    result = animate(config, tmp_path / "a.gif", "lqr", seconds=1.0, fps=25, width=40, height=20)
    # 1 ms steps at 25 fps: 40 steps per frame; the episode ends at 100 steps.
    assert (result.steps, result.steps_per_frame, result.fps, result.ended) == (100, 40, 25.0, "time limit")
    assert result.frames == 1 + 2 + 1 == len(decoded_frames(result.path))


def test_animate_names_a_fall_as_the_episode_end(tmp_path: Path) -> None:
    config = ChainCartConfig(scene="inverted-2", fall_limit=0.5, start_noise=0.05)
    result = animate(config, tmp_path / "f.gif", "zero", seconds=4.0, fps=10, width=40, height=20)
    assert result.ended == "fell" and result.steps < 200


def test_animate_a_scene_with_config_keywords(tmp_path: Path) -> None:
    out = tmp_path / "folded.gif"
    assert main(["animate", "--scene", "inverted-1", "--set", "n_links=3", "--set", "planar=False",
                 "--set", "target=folded_up", "--policy", "zero", "--steps", "3", "--fps", "50",
                 "--out", str(out), "--width", "40", "--height", "20"]) == 0
    assert len(decoded_frames(out)) == 4
    assert parse_settings(["a=0.5", "b=(1, -1)", "c=folded", "d=False"]) == {
        "a": 0.5, "b": (1, -1), "c": "folded", "d": False}


def test_animate_a_saved_sb3_model(tmp_path: Path) -> None:
    import json

    from stable_baselines3 import PPO, SAC

    from chaincart_env import ChainCartVecEnv

    config = ChainCartConfig(scene="inverted-1")
    run = tmp_path / "run"
    run.mkdir()
    PPO("MlpPolicy", ChainCartVecEnv(1, config), n_steps=16, batch_size=16, device="cpu").save(run / "model.zip")
    (run / "config.json").write_text(json.dumps(config.to_dict()))
    (run / "run.json").write_text(json.dumps({"algo": "ppo"}))
    out = tmp_path / "ppo.gif"
    assert main(["animate", "--policy", str(run), "--steps", "4", "--out", str(out), "--width", "40", "--height", "20"]) == 0
    assert len(decoded_frames(out)) == 3
    # A plain zip without JSON: the algorithm is found by trying PPO, SAC, TD3, ...
    SAC("MlpPolicy", ChainCartVecEnv(1, scene="paper-fig2"), device="cpu").save(tmp_path / "sac.zip")
    assert isinstance(load_sb3_model(tmp_path / "sac.zip"), SAC)
    with pytest.raises(SystemExit):  # trained on 5 spatial links, shown the default scene: a usage error
        main(["animate", "--policy", str(tmp_path / "sac.zip"), "--scene", "inverted-2", "--steps", "2",
              "--out", str(tmp_path / "x.gif")])


def saved_ppo_run(folder: Path, scene: str, seed: int, *, with_json: bool = True) -> Path:
    """A tiny untrained PPO model saved as ``compare`` saves one (``model.zip`` with
    ``config.json`` and ``run.json``), or as a bare ``.zip`` when ``with_json`` is false."""
    import json

    from stable_baselines3 import PPO

    from chaincart_env import ChainCartVecEnv

    config = ChainCartConfig(scene=scene)
    folder.mkdir(parents=True)
    model = PPO("MlpPolicy", ChainCartVecEnv(1, config), n_steps=16, batch_size=16, seed=seed, device="cpu")
    if not with_json:
        model.save(folder / f"{folder.name}.zip")
        return folder / f"{folder.name}.zip"
    model.save(folder / "model.zip")
    (folder / "config.json").write_text(json.dumps(config.to_dict()))
    (folder / "run.json").write_text(json.dumps({"algo": "ppo"}))
    return folder


def panels(frame: np.ndarray, width: int) -> list[np.ndarray]:
    """The side-by-side panels of an animation frame, each ``width`` pixels wide."""
    assert frame.shape[1] % width == 0
    return [frame[:, c * width:(c + 1) * width] for c in range(frame.shape[1] // width)]


def test_animate_a_built_in_policy_beside_saved_models_in_later_slots(tmp_path: Path) -> None:
    first = saved_ppo_run(tmp_path / "first", "inverted-1", seed=1)
    bare = saved_ppo_run(tmp_path / "bare", "inverted-1", seed=2, with_json=False)
    w, h = 48, 32
    band = _label_height(h)
    args = ["animate", "--policy", "lqr", "--policy", str(first), "--policy", str(bare), "--steps", "6",
            "--width", str(w), "--height", str(h), "--seed", "4"]
    outs = [tmp_path / "one.gif", tmp_path / "two.gif"]
    for out in outs:
        # No --scene: the saved run's config.json picks inverted-1 (not the default scene).
        assert main([*args, "--out", str(out)]) == 0
    assert outs[0].read_bytes() == outs[1].read_bytes()  # deterministic
    frames = decoded_frames(outs[0])
    # dt = 20 ms at 25 fps: a frame every 2 steps, plus the start: 0, 2, 4, 6.
    assert len(frames) == 4 and all(f.shape == (h + band, 3 * w, 3) for f in frames)
    start = panels(frames[0], w)
    for panel in start:
        assert panel[:band].min() < 100  # each panel's label
    # All three start from the same seeded state: the same picture under each label.
    assert np.array_equal(start[0][band:], start[1][band:]) and np.array_equal(start[0][band:], start[2][band:])
    # The second panel is the saved model's own episode, drawn by the env.
    from chaincart_env.tools.animate import load_sb3_model as load

    model = load(first)
    env = ChainCartEnv(scene="inverted-1", render_view="3d", render_mode="rgb_array", render_width=w, render_height=h)
    obs, _ = env.reset(seed=4)
    for _ in range(6):
        obs, *_ = env.step(model.predict(obs, deterministic=True)[0])
    assert np.abs(panels(frames[-1], w)[1][band:].astype(int) - env.render()).mean() < 3
    assert not np.array_equal(panels(frames[-1], w)[0][band:], panels(frames[-1], w)[1][band:])
    # Through the API: the labels name each policy, and every slot runs its own episode.
    result = animate(ChainCartConfig(scene="inverted-1"), tmp_path / "api.gif", ["lqr", str(first), str(bare)],
                     steps=6, width=w, height=h, seed=4)
    assert result.policies == ("lqr", "first", "bare") and result.width == w and len(result.returns) == 3
    assert result.path.read_bytes() == outs[0].read_bytes()


def test_animate_two_saved_models_side_by_side_in_an_mp4(tmp_path: Path) -> None:
    import imageio.v3 as iio

    # Two runs whose folders share a name: each label is then the path given.
    a = saved_ppo_run(tmp_path / "a" / "seed-0", "inverted-1", seed=1)
    b = saved_ppo_run(tmp_path / "b" / "seed-0", "inverted-1", seed=2)
    w, h = 64, 32
    outs = [tmp_path / "one.mp4", tmp_path / "two.mp4"]
    for out in outs:
        assert main(["animate", "--policy", str(a), "--policy", str(b), "--steps", "8", "--out", str(out),
                     "--width", str(w), "--height", str(h)]) == 0
    frames = iio.imread(outs[0])
    assert frames.shape == (5, h + _label_height(h), 2 * w, 3) and frames.dtype == np.uint8
    assert np.array_equal(frames, iio.imread(outs[1]))  # deterministic
    result = animate(ChainCartConfig(scene="inverted-1"), tmp_path / "api.mp4", [str(a), str(b)], steps=2,
                     width=w, height=h)
    assert result.policies == (str(a), str(b))


def test_animate_refuses_saved_models_of_different_configs_and_bad_later_slots(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    one = saved_ppo_run(tmp_path / "one", "inverted-1", seed=1)
    two = saved_ppo_run(tmp_path / "two", "inverted-2", seed=1)
    out = tmp_path / "x.gif"
    cases = [
        ([str(one), str(two)], f"policies {str(one)!r} and {str(two)!r} were saved with different configs"),
        (["lqr", "smart"], "policy 'smart': expected one of ['random', 'zero', 'lqr', 'trajectory', 'trajectory-soft', 'mpc', 'energy']"),
        (["lqr", str(tmp_path / "none.zip")], f"policy {str(tmp_path / 'none.zip')!r}: expected one of"),
    ]
    for policies, message in cases:
        with pytest.raises(SystemExit) as exit_:
            main(["animate", "--steps", "2", "--out", str(out), *[a for p in policies for a in ("--policy", p)]])
        assert exit_.value.code == 2
        assert message in capsys.readouterr().err
    # With --scene, a model trained on another scene says which policy and what it expected.
    with pytest.raises(SystemExit):
        main(["animate", "--scene", "inverted-2", "--policy", "zero", "--policy", str(one), "--steps", "2",
              "--out", str(out)])
    assert f"policy {str(one)!r}: the model observes shape" in capsys.readouterr().err
    assert not out.exists()


def test_animate_writes_an_mp4(tmp_path: Path) -> None:
    import imageio.v3 as iio

    out = tmp_path / "a.mp4"
    assert main(["animate", "--steps", "20", "--fps", "25", "--out", str(out), "--width", "64", "--height", "32"]) == 0
    frames = iio.imread(out)
    # One frame per 2 steps (dt 20 ms at 25 fps) plus the reset frame, each under its label.
    assert frames.shape == (11, 32 + _label_height(32), 64, 3) and frames.dtype == np.uint8
    assert frames.std() > 0


def test_animate_bad_input_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # Without imageio-ffmpeg, an MP4 is refused before any work, saying what to install.
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    assert main(["animate", "--steps", "2", "--out", str(tmp_path / "a.mp4")]) == 1
    assert "imageio-ffmpeg, not installed: pip install 'chaincart-env[plot]'" in capsys.readouterr().err
    assert not (tmp_path / "a.mp4").exists()
    cases = [
        (["--out", str(tmp_path / "a.bmp")], "expected a file name ending in .gif, .mp4 or .png"),
        (["--elevation", "95"], "elevation = 95"),
        (["--fov", "0.5"], "fov = 0.5"),
        (["--times", "0,x"], "expected seconds separated by commas"),
        (["--policy", "smart"], "expected one of ['random', 'zero', 'lqr', 'trajectory', 'trajectory-soft', 'mpc', 'energy'], an SB3 model .zip"),
        (["--scene", "paper-fig1", "--policy", "lqr"], "use --policy zero"),
        (["--width", "4"], "render_width = 4"),
        (["--set", "n_links"], "expected KEY=VALUE"),
        (["--fps", "0"], "fps = 0.0: expected a number > 0"),
    ]
    for args, message in cases:
        with pytest.raises(SystemExit) as exit_:
            main(["animate", "--steps", "2", *args] if "--out" in args else
                 ["animate", "--steps", "2", "--out", str(tmp_path / "b.gif"), *args])
        assert exit_.value.code == 2
        assert message in capsys.readouterr().err


def test_render_benchmark_rows() -> None:
    rows = render_benchmark(sizes=[(32, 16)], scenes=["inverted-1"], tiles=2, seconds=0.01)
    assert [r["kind"] for r in rows] == ["env", "vector, 2 tiles"]
    assert rows[1]["image"] == "66x16" and rows[0]["image"] == "32x16"
    for r in rows:
        assert r["images_per_s"] > 0 and r["frames_per_s"] >= r["images_per_s"] and r["render_fps"] == 50
