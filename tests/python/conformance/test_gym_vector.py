"""Gymnasium's generic vector-env tests (tests/vector, tests/wrappers/vector) on
ChainCartVectorEnv: equal to SyncVectorEnv and AsyncVectorEnv of ChainCartEnv in every
autoreset mode (observations, rewards, flags and infos), the order of calls, the
render contract, and every vector wrapper native vs sync."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import wrappers as W
from gymnasium.error import ResetNeeded
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import AsyncVectorEnv, AutoresetMode, SyncVectorEnv
from gymnasium.wrappers import vector as VW

from chaincart_env import ChainCartEnv, ChainCartVectorEnv, InvalidInputError, InvalidTypeError

# Short episodes that end both ways (track and time limit).
CONFIG = dict(n_links=2, start_noise=0.25, max_episode_steps=15, track_limit=0.3, max_force=20.0)
N = 4
MODES = [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP, AutoresetMode.DISABLED]


def native(mode: AutoresetMode = AutoresetMode.NEXT_STEP, **kwargs: Any) -> ChainCartVectorEnv:
    return ChainCartVectorEnv(N, autoreset_mode=mode, **{**CONFIG, **kwargs})


def sync(mode: AutoresetMode = AutoresetMode.NEXT_STEP, wrap: Callable = lambda e: e, **kwargs: Any) -> SyncVectorEnv:
    return SyncVectorEnv([lambda: wrap(ChainCartEnv(**{**CONFIG, **kwargs})) for _ in range(N)], autoreset_mode=mode)


def run_together(a: gym.vector.VectorEnv, b: gym.vector.VectorEnv, mode: AutoresetMode, steps: int = 40) -> int:
    """Steps both with the same actions, asserting every output equal; returns the
    number of episode ends seen."""
    obs_a, info_a = a.reset(seed=123)
    obs_b, info_b = b.reset(seed=123)
    assert data_equivalence(obs_a, obs_b, exact=True) and data_equivalence(info_a, info_b, exact=True)
    a.action_space.seed(5)
    ends = 0
    for _ in range(steps):
        actions = a.action_space.sample()
        assert actions in b.action_space
        out_a, out_b = a.step(actions), b.step(actions)
        for x, y in zip(out_a, out_b):
            assert data_equivalence(x, y, exact=True), (x, y)
        ended = out_a[2] | out_a[3]
        ends += int(ended.sum())
        if mode == AutoresetMode.DISABLED and ended.any():
            reset_a, reset_b = a.reset(options={"reset_mask": ended}), b.reset(options={"reset_mask": ended})
            assert data_equivalence(reset_a, reset_b, exact=True)
    return ends


@pytest.mark.parametrize("diagnostics", [False, True])
@pytest.mark.parametrize("mode", MODES)
def test_native_equals_sync_vector_env(mode: AutoresetMode, diagnostics: bool) -> None:
    # With diagnostics, an env's reset step (next-step) carries none, and an ended
    # env's (same-step) are in final_info, as SyncVectorEnv gathers them.
    envs, reference = native(mode, diagnostics=diagnostics), sync(mode, diagnostics=diagnostics)
    assert envs.observation_space == reference.observation_space
    assert envs.single_observation_space == reference.single_observation_space
    assert envs.action_space == reference.action_space and envs.single_action_space == reference.single_action_space
    assert run_together(envs, reference, mode) > N


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_native_equals_async_vector_env(mode: AutoresetMode) -> None:
    reference = AsyncVectorEnv([lambda: ChainCartEnv(**CONFIG) for _ in range(N)], autoreset_mode=mode)
    try:
        assert run_together(native(mode), reference, mode, steps=25) > 0
    finally:
        reference.close()


def test_make_vec_modes_agree() -> None:
    # The episode length goes both to the env (config) and to gymnasium.make's
    # TimeLimit (max_episode_steps), which sync mode applies to each env.
    keywords = dict(config={k: v for k, v in CONFIG.items()}, max_episode_steps=CONFIG["max_episode_steps"])
    made = {
        mode: gym.make_vec("ChainCart-v0", N, vectorization_mode=mode, **keywords)
        for mode in ("vector_entry_point", "sync")
    }
    assert isinstance(made["vector_entry_point"].unwrapped, ChainCartVectorEnv)
    assert run_together(made["vector_entry_point"], made["sync"], AutoresetMode.NEXT_STEP) > 0


@pytest.mark.parametrize("make", [native, sync], ids=["native", "sync"])
def test_stepping_before_the_first_reset_raises(make: Callable) -> None:
    envs = make()
    with pytest.raises(ResetNeeded):
        envs.step(envs.action_space.sample())
    envs.reset(seed=0)
    envs.step(envs.action_space.sample())


@pytest.mark.parametrize("make", [native, sync], ids=["native", "sync"])
@pytest.mark.parametrize("actions", [0, 0.5, np.float32(0.1), np.array(0.3), None, True], ids=repr)
def test_a_scalar_action_is_a_type_error_like_sync(make: Callable, actions: Any) -> None:
    envs = make()
    envs.reset(seed=0)
    with pytest.raises(TypeError):
        envs.step(actions)


def test_a_scalar_action_names_the_value_and_moves_no_env() -> None:
    envs, twin = native(), native()
    envs.reset(seed=0)
    twin.reset(seed=0)
    with pytest.raises(InvalidTypeError, match=r"actions = 0: expected an array of shape \(4, 1\), not a scalar"):
        envs.step(0)
    with pytest.raises(ValueError):  # an InvalidTypeError is an InvalidInputError too
        envs.step(0.5)
    zeros = np.zeros((N, 1), np.float32)
    assert data_equivalence(envs.step(zeros), twin.step(zeros), exact=True)


def test_reset_options_have_gymnasiums_exception_types() -> None:
    envs = native(AutoresetMode.DISABLED)
    envs.reset(seed=0)
    for bad in ([True] * N, np.ones(N, np.int64), np.ones(N)):
        with pytest.raises(TypeError, match="reset_mask"):
            envs.reset(options={"reset_mask": bad})
    with pytest.raises(ValueError, match=r"reset_mask.*shape \(4,\)"):
        envs.reset(options={"reset_mask": np.ones(N + 1, np.bool_)})
    with pytest.raises(InvalidTypeError):
        envs.reset(options="reset everything")
    with pytest.raises(InvalidInputError):
        envs.reset(options={"no such option": 1})
    with pytest.raises(TypeError):
        envs.reset(seed="0")


# -- rendering -------------------------------------------------------------------------

RGB = dict(render_width=48, render_height=24)


def test_render_returns_a_tuple_of_every_envs_frame_like_sync() -> None:
    envs = native(render_mode="rgb_array", **RGB)
    reference = SyncVectorEnv([lambda: ChainCartEnv(render_mode="rgb_array", **{**CONFIG, **RGB}) for _ in range(N)])
    envs.reset(seed=1)
    reference.reset(seed=1)
    actions = envs.action_space.sample()
    envs.step(actions)
    reference.step(actions)
    frames = envs.render()
    assert isinstance(frames, tuple) and len(frames) == N
    assert data_equivalence(frames, reference.render(), exact=True)
    assert envs.render_tiled().shape == (2 * 24 + 2, 2 * 48 + 2, 3)


def test_rgb_array_list_collects_every_frame_since_the_last_render() -> None:
    envs = native(AutoresetMode.SAME_STEP, render_mode="rgb_array_list", **RGB)
    reference = gym.make_vec("ChainCart-v0", N, vectorization_mode="sync", render_mode="rgb_array_list",
                             vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP}, **{**CONFIG, **RGB})  # fmt: skip
    envs.reset(seed=2)
    reference.reset(seed=2)
    for _ in range(3):
        actions = envs.action_space.sample()
        envs.step(actions)
        reference.step(actions)
    lists = envs.render()
    assert len(lists) == N and all(len(frames) == 4 for frames in lists)
    assert data_equivalence(lists, reference.render(), exact=True)
    assert all(len(frames) == 0 for frames in envs.render())  # taken by the last call


@pytest.mark.parametrize("mode", MODES)
def test_record_video_on_the_native_vector_env(mode: AutoresetMode, tmp_path: Path) -> None:
    envs = VW.RecordVideo(native(mode, render_mode="rgb_array", **RGB), str(tmp_path / "videos"),
                          episode_trigger=lambda e: e == 1, step_trigger=lambda s: s == 0, name_prefix="chain")  # fmt: skip
    envs.reset(seed=3)
    envs.action_space.seed(3)
    for _ in range(40):
        _, _, terminated, truncated, _ = envs.step(envs.action_space.sample())
        if mode == AutoresetMode.DISABLED and (terminated | truncated).any():
            envs.reset(options={"reset_mask": terminated | truncated})
    envs.close()
    videos = sorted(p.name for p in (tmp_path / "videos").glob("*.mp4"))
    assert videos == ["chain-episode-1.mp4", "chain-step-0.mp4"]
    assert all(p.stat().st_size > 1000 for p in (tmp_path / "videos").glob("*.mp4"))


# -- vector wrappers: native vs sync with the single-env wrapper -------------------------

VECTOR_WRAPPERS: dict[str, tuple[Callable, Callable]] = {
    "FlattenObservation": (VW.FlattenObservation, W.FlattenObservation),
    "DtypeObservation": (lambda e: VW.DtypeObservation(e, np.float64), lambda e: W.DtypeObservation(e, np.float64)),
    "RescaleObservation": (
        lambda e: VW.RescaleObservation(e, *_rescale_bounds(e.single_observation_space)),
        lambda e: W.RescaleObservation(e, *_rescale_bounds(e.observation_space)),
    ),
    "ReshapeObservation": (lambda e: VW.ReshapeObservation(e, (2, 4)), lambda e: W.ReshapeObservation(e, (2, 4))),
    "ClipAction": (VW.ClipAction, W.ClipAction),
    "RescaleAction": (lambda e: VW.RescaleAction(e, 1.0, 2.0), lambda e: W.RescaleAction(e, 1.0, 2.0)),
    # A vector wrapper also clips the reward 0 of a next-step autoreset, which
    # SyncVectorEnv returns without stepping the wrapped env: bounds around 0.
    "ClipReward": (lambda e: VW.ClipReward(e, -0.5, 0.6), lambda e: W.ClipReward(e, -0.5, 0.6)),
}
#: Gymnasium's vector observation wrappers refuse same-step autoreset.
OBSERVATION_WRAPPERS = ("FlattenObservation", "DtypeObservation", "RescaleObservation", "ReshapeObservation")


def _rescale_bounds(space: gym.spaces.Box) -> tuple[np.ndarray, np.ndarray]:
    return np.where(np.isinf(space.low), space.low, 0.0), np.where(np.isinf(space.high), space.high, 1.0)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("name", VECTOR_WRAPPERS)
def test_vector_wrapper_on_native_equals_wrapper_in_sync(name: str, mode: AutoresetMode) -> None:
    vector_wrapper, env_wrapper = VECTOR_WRAPPERS[name]
    if name in OBSERVATION_WRAPPERS and mode == AutoresetMode.SAME_STEP:
        with pytest.raises(AssertionError):  # Gymnasium's own limitation, as for its envs
            vector_wrapper(native(mode))
        return
    wrapped_native = vector_wrapper(native(mode))
    wrapped_sync = sync(mode, wrap=env_wrapper)
    assert wrapped_native.single_observation_space == wrapped_sync.single_observation_space
    assert wrapped_native.single_action_space == wrapped_sync.single_action_space
    run_together(wrapped_native, wrapped_sync, mode, steps=30)


@pytest.mark.filterwarnings("ignore:.*precision lowered by casting")
@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_statistics_wrappers_on_the_native_vector_env(dtype: str) -> None:
    envs = VW.NormalizeReward(VW.NormalizeObservation(native(obs_dtype=dtype)))
    envs = VW.RecordEpisodeStatistics(VW.DtypeObservation(envs, np.float16))
    envs = VW.DictInfoToList(envs)
    obs, infos = envs.reset(seed=4)
    assert obs.dtype == np.float16 and infos == [{}] * N
    returns = np.zeros(N)
    envs.action_space.seed(4)
    episodes = 0
    for _ in range(40):
        obs, rewards, terminated, truncated, infos = envs.step(envs.action_space.sample())
        # (NormalizeObservation leaves the space's [-1, 1] bounds on the normalised
        # unit-vector entries, so membership is not asked here.)
        assert obs.shape == (N, 8) and np.all(np.isfinite(obs))
        returns += rewards
        for i in np.flatnonzero(terminated | truncated):
            episodes += 1
            assert infos[i]["episode"]["r"] == pytest.approx(returns[i], rel=1e-4)
            returns[i] = 0.0
            assert set(infos[i]) >= {"episode", "is_success", "e_q", "e_w"}
    assert episodes > 0
