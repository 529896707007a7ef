"""EnvBatch.set_precision: f32 physics on the rk4 lane kernel, f64 by default, clear
errors for anything else."""

from __future__ import annotations

import numpy as np
import pytest

from chaincart_env import ChainCartError
from chaincart_env.config import ChainCartConfig


def _run(*precisions: str, num_envs: int = 40, steps: int = 25) -> tuple[np.ndarray, np.ndarray]:
    """Observations and states after `steps` random pushes, the precisions set in turn first."""
    config = ChainCartConfig(n_links=3, planar=False)
    batch = config.make_batch(num_envs, "next_step", seed=5)
    assert batch.precision == "f64"
    for precision in precisions:
        batch.set_precision(precision)
        assert batch.precision == precision
    rng = np.random.default_rng(0)
    obs = batch.reset()
    for _ in range(steps):
        obs, rewards, *_ = batch.step(rng.uniform(-1, 1, (num_envs, config.force_dim)).astype(np.float32))
    return obs, batch.states()


def test_f32_physics_stays_close_to_f64_and_keeps_the_obs_dtype() -> None:
    obs64, y64 = _run("f64")
    obs32, y32 = _run("f32")
    assert obs32.dtype == obs64.dtype == np.float32
    assert not np.array_equal(y32, y64)
    # 25 control periods of 20 ms under random pushes: f32 round-off, not a new trajectory.
    assert np.max(np.abs(y32 - y64)) < 1e-3
    # Back to f64: the default's bits again.
    again = _run("f32", "f64")[1]
    assert np.array_equal(again, y64)


def test_bad_precisions_and_integrators_are_named() -> None:
    batch = ChainCartConfig().make_batch(4, "next_step")
    with pytest.raises(ChainCartError, match=r'unknown precision "f16"') as e:
        batch.set_precision("f16")
    assert "f32" in str(e.value) and "f64" in str(e.value)
    other = ChainCartConfig(integrator="rkmk4").make_batch(4, "next_step")
    other.set_precision("f64")
    with pytest.raises(ChainCartError, match="rkmk4") as e:
        other.set_precision("f32")
    assert "rk4" in str(e.value)
    assert other.precision == "f64"


def test_the_precision_keyword_reaches_every_env_class() -> None:
    from chaincart_env import ChainCartEnv, ChainCartVectorEnv

    single = ChainCartEnv(precision="f32", start_noise=0.05)
    vector = ChainCartVectorEnv(3, precision="f32", start_noise=0.05)
    assert single.config.precision == vector.config.precision == "f32"
    assert ChainCartEnv().config.precision == "f64"
    # Lanes never mix, so env i of an f32 batch is the f32 single env seeded s + i.
    vector.reset(seed=10)
    single.reset(seed=11)
    actions = np.random.default_rng(1).uniform(-1, 1, (20, 3, 1)).astype(np.float32)
    for a in actions:
        obs, *_ = vector.step(a)
        one, *_ = single.step(a[1])
        assert np.array_equal(obs[1], one)
    assert np.array_equal(vector.unwrapped.states[1], single.state)


def test_the_precision_keyword_is_checked_with_the_integrator() -> None:
    from chaincart_env import ChainCartConfig, InvalidInputError

    with pytest.raises(InvalidInputError, match=r'precision = "f32": expected "f64" with integrator "rkmk4"'):
        ChainCartConfig(precision="f32", integrator="rkmk4")
    with pytest.raises(InvalidInputError, match=r'unknown precision "f16": expected one of "f64", "f32"'):
        ChainCartConfig(precision="f16")
    assert ChainCartConfig(precision="f32").replace(precision="f64").precision == "f64"
