"""The exception contract: TypeError for wrong types, ValueError for wrong values
(as Gymnasium does), a RuntimeError carrying time and reason for a failed
integration, a LinAlgError for a failed analysis, all ChainCartErrors; sizes that
cannot be allocated are refused naming the value and the limit."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import chaincart_env
from chaincart_env import (
    AnalysisError,
    ChainCart,
    ChainCartConfig,
    ChainCartEnv,
    ChainCartError,
    ChainCartVectorEnv,
    IntegrationError,
    InvalidInputError,
    InvalidTypeError,
    MissingExtraError,
    UnknownKeyError,
    _core,
)


def test_the_hierarchy() -> None:
    assert issubclass(InvalidInputError, ChainCartError) and issubclass(InvalidInputError, ValueError)
    assert issubclass(InvalidTypeError, InvalidInputError) and issubclass(InvalidTypeError, TypeError)
    assert issubclass(IntegrationError, ChainCartError) and issubclass(IntegrationError, RuntimeError)
    assert issubclass(AnalysisError, ChainCartError) and issubclass(AnalysisError, np.linalg.LinAlgError)
    assert issubclass(MissingExtraError, ChainCartError) and issubclass(MissingExtraError, ImportError)
    assert issubclass(UnknownKeyError, InvalidInputError) and issubclass(UnknownKeyError, TypeError)
    assert not issubclass(UnknownKeyError, InvalidTypeError)
    assert not issubclass(IntegrationError, ValueError) and not issubclass(InvalidInputError, TypeError)
    for name in ("ChainCartError", "InvalidInputError", "InvalidTypeError", "IntegrationError", "AnalysisError"):
        assert getattr(_core, name) is getattr(chaincart_env, name)


WRONG_TYPES = {
    "planar": lambda: ChainCartConfig(planar="yes"),
    "n_links": lambda: ChainCartConfig(n_links="3"),
    "dt": lambda: ChainCartConfig(dt="0.01"),
    "config": lambda: ChainCartEnv(config=3),
    "num_envs": lambda: ChainCartVectorEnv("4"),
    "render_width": lambda: ChainCartEnv(render_mode="rgb_array", render_width="480"),
    "render_mode": lambda: ChainCartEnv(render_mode=1),
    "seed": lambda: ChainCartEnv().reset(seed="1"),
    "options": lambda: ChainCartEnv().reset(options=["state"]),
    "reset_mask": lambda: ChainCartVectorEnv(2).reset(options={"reset_mask": [True, False]}),
    "link_masses": lambda: ChainCart(2, 0.5, "heavy"),
    "target": lambda: ChainCart(2).equilibrium(3.5),
    "action": lambda: _stepped("abc"),
    "steps": lambda: ChainCart(1).simulate([0] * 10, lambda t, y: [0, 0], 0.01, steps=2.5),
}


def _stepped(action: object) -> None:
    env = ChainCartEnv()
    env.reset(seed=0)
    env.step(action)


@pytest.mark.parametrize("name", WRONG_TYPES)
def test_wrong_types_raise_type_error(name: str) -> None:
    with pytest.raises(TypeError) as error:
        WRONG_TYPES[name]()
    assert isinstance(error.value, InvalidTypeError) and isinstance(error.value, ValueError)


WRONG_VALUES = {
    "n_links": lambda: ChainCartConfig(n_links=0),
    "dt": lambda: ChainCartConfig(dt=-0.01),
    "scene": lambda: ChainCartConfig(scene="nope"),
    "seed": lambda: ChainCartEnv().reset(seed=-1),
    "num_envs": lambda: ChainCartVectorEnv(0),
    "render_width": lambda: ChainCartEnv(render_mode="rgb_array", render_width=4),
    "reset_mask shape": lambda: ChainCartVectorEnv(2, autoreset_mode="disabled").reset(
        options={"reset_mask": np.ones(3, np.bool_)}
    ),
    "NaN action": lambda: _stepped(np.array([np.nan], np.float32)),
    "action shape": lambda: _stepped(np.zeros(3, np.float32)),
    "state": lambda: ChainCart(2).energy([0.0] * 3),
}


@pytest.mark.parametrize("name", WRONG_VALUES)
def test_wrong_values_raise_value_error_not_type_error(name: str) -> None:
    with pytest.raises(ValueError) as error:
        WRONG_VALUES[name]()
    assert isinstance(error.value, InvalidInputError) and not isinstance(error.value, TypeError)


def test_an_unknown_keyword_is_a_type_error_as_python_and_gymnasium_make_expect() -> None:
    import gymnasium as gym

    for make in (lambda: ChainCartEnv(n_link=3), lambda: gym.make("ChainCart-v0", n_link=3)):
        with pytest.raises(TypeError) as info:
            make()
        assert type(info.value) is UnknownKeyError and isinstance(info.value, ValueError)
        assert '(did you mean "n_links"?)' in str(info.value)
    with pytest.raises(UnknownKeyError) as info:
        ChainCartEnv(n_link=3)
    assert pickle.loads(pickle.dumps(info.value)).args == info.value.args


def test_a_failed_integration_is_a_runtime_error_with_time_and_reason() -> None:
    model = ChainCart(2)
    y = model.equilibrium("inverted")
    y[4:7] = [np.sin(0.3), 0.0, -np.cos(0.3)]
    dt = 0.5
    with pytest.raises(RuntimeError) as caught:
        model.simulate(y, np.full((50, 2), 1e6), dt, "lie_euler")
    error = caught.value
    assert isinstance(error, IntegrationError)
    step = int(str(error).split("at step ")[1].split()[0])
    assert error.time == pytest.approx(step * dt) and f"at t = {error.time:g} s" in str(error).replace(".0 s", " s")
    assert error.reason in str(error) and "lie_euler integrator" in error.reason
    copy = pickle.loads(pickle.dumps(error))
    assert (type(copy), copy.time, copy.reason, str(copy)) == (IntegrationError, error.time, error.reason, str(error))
    with pytest.raises(IntegrationError):
        model.step(y, [1e9, 0.0], 5.0)


def test_a_failed_analysis_is_a_lin_alg_error() -> None:
    with pytest.raises(np.linalg.LinAlgError, match="no stabilising Riccati solution") as caught:
        ChainCart(2).lqr_gain("hanging", np.zeros((12, 12)))
    assert isinstance(caught.value, AnalysisError)


def test_an_env_never_raises_for_a_blow_up_it_flags_it() -> None:
    env = ChainCartEnv(dt=1.0, substeps=1, max_force=100.0)
    env.reset(seed=0)
    for _ in range(5):
        obs, _, terminated, _, info = env.step(np.ones(1, np.float32))
        assert np.all(np.isfinite(obs))
        if terminated:
            assert info["numerical_failure"]
            break
    else:
        pytest.fail("the 1 s control period did not fail")


def test_sizes_beyond_the_limits_name_the_value_and_the_limit() -> None:
    limit = _core.MAX_LINKS
    for make in (lambda: ChainCart(limit + 1), lambda: ChainCartConfig(n_links=10**12)):
        with pytest.raises(InvalidInputError, match=rf"n_links = \d+ is too large: expected at most {limit}"):
            make()
    rows = _core.MAX_STATE_VALUES // 8  # default scene: 8 numbers per state
    with pytest.raises(InvalidInputError, match=rf"num_envs = {rows + 1} is too large: expected at most {rows}"):
        ChainCartVectorEnv(rows + 1)
    big = ChainCart(50_000)  # 300 004 numbers per state
    steps = _core.MAX_STATE_VALUES // big.state_dim
    with pytest.raises(InvalidInputError, match=rf"steps = {steps + 1} is too large: expected at most {steps}"):
        big.simulate(big.equilibrium("hanging"), np.zeros((steps + 1, 2)), 0.01)
    assert big.energy(big.equilibrium("hanging")) < 0  # a large chain within the limit works
