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
    with pytest.raises(ChainCartError, match=r"precision = 'f16'|precision = \"f16\"") as e:
        batch.set_precision("f16")
    assert "f32" in str(e.value) and "f64" in str(e.value)
    other = ChainCartConfig(integrator="rkmk4").make_batch(4, "next_step")
    other.set_precision("f64")
    with pytest.raises(ChainCartError, match="rkmk4") as e:
        other.set_precision("f32")
    assert "rk4" in str(e.value)
    assert other.precision == "f64"
