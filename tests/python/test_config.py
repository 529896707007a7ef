"""ChainCartConfig: scenes, overrides, normalisation and clear errors."""

from __future__ import annotations

import dataclasses
import json
import pickle
import traceback
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import chaincart_env
from chaincart_env import (
    DEFAULT_SCENE,
    SCENES,
    ChainCartConfig,
    ChainCartEnv,
    ChainCartError,
    ChainCartVectorEnv,
    RewardWeights,
    _core,
)
from chaincart_env.config import CONFIG_KEYS, REALITY_KEYS
from chaincart_env.errors import InvalidInputError, InvalidTypeError, UnknownKeyError
from chaincart_env.spec import plain_value

REALITY_NAMES = [k[0] for k in REALITY_KEYS]

KEYWORDS = [
    "n_links", "cart_mass", "link_masses", "link_lengths", "gravity", "planar", "target", "start",
    "start_noise", "dt", "integrator", "substeps", "max_force", "track_limit", "max_episode_steps",
    "reward_weights", "scene", "obs_dtype",
]  # fmt: skip


def test_the_config_has_the_agreed_keyword_names() -> None:
    names = [f.name for f in dataclasses.fields(ChainCartConfig) if f.init]
    assert names[: len(KEYWORDS)] == KEYWORDS
    # The only extras: success tolerances, the reward kind, the success hold, the fall limit
    # and its hold, the goal-conditioned task's pairs and observation, the diagnostics switch, the
    # physics' precision, the reality-gap keywords, exactly those the core defines, in
    # its order, the rendered view, the real rig's effects and its encoders.
    task = ["reward", "success_hold", "fall_limit", "fall_hold", "transitions", "goal_observation"]
    rig = ["joint_damping", "cart_viscous_friction", "cart_coulomb_friction", "coulomb_velocity", "actuation"]
    rig += ["max_acceleration", "max_voltage", "motor"]
    rig += ["angle_encoder_counts", "cart_encoder_counts", "velocity_filter", "angle_encoder_reference"]
    extras = ["success_tolerances", *task, "diagnostics", "precision", *(k[0] for k in REALITY_KEYS), "render_view", *rig]
    assert names[len(KEYWORDS) :] == extras


def test_default_scene_values() -> None:
    c = ChainCartConfig()
    assert c.scene == DEFAULT_SCENE == "inverted-2"
    assert (c.n_links, c.planar, c.target_signs, c.start, c.dt, c.max_force) == (
        2, True, (-1, -1), "target", 0.02, 20.0
    )  # fmt: skip
    assert (c.start_noise, c.track_limit, c.max_episode_steps, c.link_lengths) == (0.05, 2.4, 500, 0.5)
    assert (c.state_dim, c.force_dim) == (8, 1)
    assert c.reward_weights == RewardWeights(1.0, 0.1, 0.1, 0.1, 0.01)


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_every_scene_resolves_and_validates(scene: str) -> None:
    c = ChainCartConfig(scene=scene)
    assert c.scene == scene
    for key, value in SCENES[scene].items():
        got = getattr(c, key)
        if key in REALITY_NAMES:
            # Reality-gap values are kept in the core's canonical form.
            value = _core.resolve_config({key: value}).values()[key]
        assert got == value or (isinstance(value, str) and np.dtype(value).name == got)


def test_paper_scenes() -> None:
    fig1, fig2, fig3 = (ChainCartConfig(scene=f"paper-fig{k}") for k in (1, 2, 3))
    for c in (fig1, fig2, fig3):
        assert (c.n_links, c.cart_mass, c.link_masses, c.link_lengths, c.planar) == (5, 0.5, 0.1, 0.1, False)
        assert c.start_noise == 0.0 and c.substeps == 1
    # Continuous-time results: forces held for at most 1 ms (0.1 ms for Fig. 2), over
    # 10 s (12 s for Fig. 3, which settles at 11.3 s).
    assert [(c.dt, c.max_episode_steps) for c in (fig1, fig2, fig3)] == [(1e-3, 10_000), (1e-4, 100_000), (1e-3, 12_000)]
    assert fig1.max_force == 0.0 and fig1.target_signs == (-1, 1, -1, 1, -1)
    assert fig2.target_signs == (1,) * 5 and fig2.max_force == 100.0
    assert fig3.target_signs == (-1, -1, -1, 1, 1)


def test_explicit_keywords_override_the_scene() -> None:
    c = ChainCartConfig(scene="paper-fig2", n_links=5, dt=0.005, target=(1, 1, -1, 1, 1), obs_dtype=np.float64)
    assert (c.dt, c.target_signs, c.obs_dtype, c.max_force) == (0.005, (1, 1, -1, 1, 1), "float64", 100.0)
    c = ChainCartConfig(n_links=2, link_lengths=[0.3, 0.4], reward_weights={"u": 0.5})
    assert c.link_lengths == (0.3, 0.4) and c.state_dim == 8
    assert c.reward_weights == RewardWeights(u=0.5)
    assert c.replace(max_force=3.0).max_force == 3.0
    assert ChainCartConfig(**c.to_dict()) == c
    assert pickle.loads(pickle.dumps(c)) == c


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(scene="cartpole"), 'unknown scene "cartpole"'),
        (dict(target="upright"), 'unknown equilibrium "upright"'),
        (dict(start="sideways"), 'unknown start "sideways"'),
        (dict(n_links=0), "n_links = 0: expected at least one link"),
        (dict(n_links=-1), "n_links = -1"),
        (dict(n_links=1.5), "n_links = 1.5: expected an integer"),
        (dict(n_links=True), "n_links = True: expected an integer"),
        (dict(cart_mass=-1.0), "cart_mass = -1: expected a finite number > 0"),
        (dict(link_masses=-0.1), "link_masses[0] = -0.1"),
        (dict(n_links=2, link_masses=[0.1]), "link_masses has length 1, expected 2"),
        (dict(n_links=2, target=(-1, -1, -1)), "target has length 3, expected 2"),
        (dict(target=(-1, 2)), "s[1] = 2: expected +1"),
        (dict(start=(1, 1, 1)), "start has length 3"),
        (dict(integrator="euler"), 'unknown integrator "euler"'),
        (dict(substeps=0), "substeps = 0"),
        (dict(dt=0.0), "dt = 0: expected a finite number > 0"),
        (dict(max_force=-5.0), "max_force = -5"),
        (dict(track_limit=float("inf")), "track_limit = inf"),
        (dict(max_episode_steps=0), "max_episode_steps = 0"),
        (dict(start_noise=-0.1), "start_noise = -0.1"),
        (dict(obs_dtype="int8"), 'unknown obs_dtype "int8"'),
        (dict(reward_weights={"tilt": 1.0}), "reward_weights has unknown key 'tilt'"),
        (dict(reward_weights={"q": -1.0}), "reward_weights.q = -1"),
        (dict(success_tolerances=(0.1,)), "success_tolerances"),
        (dict(planar="yes"), "planar = 'yes'"),
        (dict(scene="paper-fig3", planar=True), 'start "paper-fig3"'),
        (dict(start="paper-fig1"), "n_links = 2: expected 5 for the paper's Fig. 1"),
        (dict(target="paper-fig3", n_links=2), "n_links = 2: expected 5 for the paper's Fig. 3"),
    ],
)
def test_bad_config_raises_a_clear_error(kwargs: dict, message: str) -> None:
    with pytest.raises(ChainCartError) as e:
        ChainCartConfig(**kwargs)
    assert message in str(e.value), str(e.value)


def test_unknown_keywords_are_type_errors_suggesting_the_closest_keyword() -> None:
    with pytest.raises(UnknownKeyError, match=r'unknown config key "n_link" \(did you mean "n_links"\?\): expected one of'):
        ChainCartConfig(n_link=2)  # type: ignore[call-arg]
    with pytest.raises(InvalidInputError, match=r'"link_length" \(did you mean "link_lengths"\?\)'):
        ChainCartConfig(n_links=2, link_length=0.3)  # type: ignore[call-arg]
    with pytest.raises(TypeError) as far:
        ChainCartConfig(bogus=1)  # type: ignore[call-arg]
    assert 'unknown config key "bogus": expected one of "n_links", ' in str(far.value)


@pytest.mark.parametrize(
    "make",
    [
        lambda: ChainCartEnv(n_link=3),
        lambda: gym.make("ChainCart-v0", n_link=3),
        lambda: ChainCartVectorEnv(4, n_link=3),
        lambda: chaincart_env.ChainCartVecEnv(4, n_link=3),
        lambda: ChainCartConfig.coerce({"n_link": 3}),
        lambda: ChainCartConfig().replace(n_link=3),
    ],
)
def test_every_env_constructor_suggests_the_closest_keyword(make) -> None:
    with pytest.raises(UnknownKeyError, match=r'unknown config key "n_link" \(did you mean "n_links"\?\)'):
        make()


#: The keyword list an unknown keyword's message ends with, from the core's own keys.
KEY_LIST = "expected one of " + ", ".join(f'"{name}"' for name, *_ in CONFIG_KEYS)


@pytest.mark.parametrize(
    "make",
    [
        lambda: gym.make("ChainCart-v0", n_link=3),
        lambda: gym.make("ChainCart-swingup-2-v0", n_link=3),
        lambda: ChainCartEnv(n_link=3),
        lambda: ChainCartVectorEnv(4, n_link=3),
        lambda: chaincart_env.ChainCartVecEnv(4, n_link=3),
        lambda: gym.make_vec("ChainCart-v0", num_envs=2, vectorization_mode="vector_entry_point", n_link=3),
        lambda: gym.make_vec("ChainCart-v0", num_envs=2, vectorization_mode="sync", n_link=3),
    ],
    ids=["gym.make", "gym.make-scene", "ChainCartEnv", "ChainCartVectorEnv", "ChainCartVecEnv", "make_vec", "make_vec-sync"],
)
def test_an_unknown_keyword_is_reported_once_under_its_own_name(make) -> None:
    with pytest.raises(UnknownKeyError) as info:
        make()
    error = info.value
    assert isinstance(error, TypeError) and isinstance(error, ValueError) and isinstance(error, InvalidInputError)
    assert not isinstance(error, InvalidTypeError)
    printed = "".join(traceback.format_exception(error))
    assert len(CONFIG_KEYS) > 30 and KEY_LIST in str(error)
    assert printed.count(KEY_LIST) == 1, printed
    assert printed.count('(did you mean "n_links"?)') == 1, printed
    assert printed.count("chaincart_env.errors.UnknownKeyError: ") == 1 and "InvalidTypeError" not in printed, printed


def test_a_mistyped_scene_suggests_the_closest_scene() -> None:
    with pytest.raises(InvalidInputError, match=r'unknown scene "inverted2" \(did you mean "inverted-2"\?\)'):
        ChainCartConfig(scene="inverted2")


def test_start_accepts_signs_and_full_states() -> None:
    c = ChainCartConfig(n_links=2, start=(1, 1))
    assert c.start == (1.0, 1.0)
    y = [0.1, 0.0, 0.0, -1.0, 0.0, -1.0, 0.0, 0.0]
    assert ChainCartConfig(n_links=2, start=y).start == tuple(y)
    with pytest.raises(ChainCartError, match=r"\|q_i\|"):
        ChainCartConfig(n_links=2, start=[0.1, 0.0, 0.0, -2.0, 0.0, -1.0, 0.0, 0.0])


BEFORE = json.loads((Path(__file__).parent / "data" / "config_before.json").read_text())


#: Keys added after the fixture was saved, with the default that keeps every result.
ADDED_SINCE = {
    "precision": "f64", "render_view": None, "force_noise": None,
    "reward": "exp", "success_hold": 0.0, "fall_limit": 0.0, "fall_hold": 0.0, "transitions": None, "goal_observation": False,
    "joint_damping": 0.0, "cart_viscous_friction": 0.0, "cart_coulomb_friction": 0.0,
    "coulomb_velocity": 0.01, "actuation": "force", "max_acceleration": 10.0, "max_voltage": 12.0,
    "motor": (0.02, 2.0, 5.0, 0.02, 5.0),
    "angle_encoder_counts": None, "cart_encoder_counts": None, "velocity_filter": 0.0,
    "angle_encoder_reference": "vertical",
}


def _saved_entry(c: ChainCartConfig) -> dict:
    """What the fixture saved of a config; keys added since must hold their default."""
    config = plain_value(c.to_dict())
    text = repr(c)
    for key, default in ADDED_SINCE.items():
        assert config.pop(key) == plain_value(default)
        text = text.replace(f" {key}={default!r},", "").replace(f", {key}={default!r})", ")")
    return {
        "config": config,
        "repr": text,
        "state_dim": c.state_dim,
        "force_dim": c.force_dim,
        "target_signs": list(c.target_signs),
    }


@pytest.mark.parametrize("scene", sorted(BEFORE["scenes"]))
def test_each_scene_resolves_to_the_values_it_had_when_scenes_were_defined_in_python(scene: str) -> None:
    saved = {k: v for k, v in BEFORE["scenes"][scene].items() if k != "task_kwargs"}
    assert _saved_entry(ChainCartConfig(scene=scene)) == saved


@pytest.mark.parametrize("case", BEFORE["overrides"], ids=lambda case: ",".join(case["kwargs"]))
def test_overridden_configs_resolve_as_before(case: dict) -> None:
    saved = {k: v for k, v in case.items() if k not in ("kwargs", "task_kwargs")}
    assert _saved_entry(ChainCartConfig(**case["kwargs"])) == saved


#: Scenes defined since the fixture was saved.
SCENES_ADDED_SINCE = {
    "swingup-2", "swingup-3", "spatial-swingup-2", "transitions-2", "transitions-3", "spatial-inverted-2",
    "inverted-2-motor", "inverted-3-servo",
}


def test_the_scenes_are_the_cores() -> None:
    assert sorted(SCENES) == sorted(_core.SCENES)
    assert set(SCENES) - SCENES_ADDED_SINCE == set(BEFORE["scenes"])
    assert DEFAULT_SCENE == _core.DEFAULT_SCENE


@pytest.mark.parametrize("key", [k[0] for k in CONFIG_KEYS])
def test_every_key_default_is_accepted_by_the_core(key: str) -> None:
    default = dict((k[0], k[1]) for k in CONFIG_KEYS)[key]
    resolved = _core.resolve_config({key: default}).values()
    assert resolved[key] == _core.resolve_config({}).values()[key]


def test_unknown_keys_and_scenes_name_the_value_and_the_choices() -> None:
    with pytest.raises(InvalidInputError, match=r'unknown config key "n_link" \(did you mean "n_links"\?\): expected one of "n_links", '):
        _core.resolve_config({"n_link": 2})
    with pytest.raises(InvalidInputError, match=r'unknown scene "cartpole": expected one of "inverted-1", '):
        _core.resolve_config({"scene": "cartpole"})


@pytest.mark.parametrize(
    "kwargs, error",
    [
        (dict(reward_weights=(1, 2)), InvalidTypeError),
        (dict(reward_weights="heavy"), InvalidTypeError),
        (dict(success_tolerances=[1, 2, 3]), InvalidInputError),
        (dict(success_tolerances=5), InvalidInputError),
        (dict(success_tolerances=(0.1, "a")), InvalidTypeError),
        (dict(integrator=3), InvalidInputError),
        (dict(obs_dtype=3), InvalidInputError),
        (dict(scene=3), InvalidInputError),
        (dict(link_lengths="long"), InvalidTypeError),
        (dict(target=5), InvalidTypeError),
        (dict(diagnostics=1), InvalidTypeError),
        (dict(substeps=1.5), InvalidTypeError),
        (dict(max_episode_steps=-3), InvalidInputError),
        (dict(force_rate_limit="x"), InvalidTypeError),
    ],
)
def test_each_bad_value_raises_the_exception_class_it_always_did(kwargs: dict, error: type) -> None:
    with pytest.raises(error) as caught:
        ChainCartConfig(**kwargs)
    assert type(caught.value) is error, caught.value
    assert f"{next(iter(kwargs))}" in str(caught.value)


def test_every_key_of_the_table_is_a_config_field_declared_or_not() -> None:
    # Adding a key to the core's table makes it a keyword without a line in config.py:
    # a class declaring one key gets all of them, in the table's order.
    from chaincart_env.config import _fields_of_the_key_table

    @dataclasses.dataclass(frozen=True)
    @_fields_of_the_key_table
    class OneDeclared:
        max_force: float = 1.0

    fields = {f.name: f for f in dataclasses.fields(OneDeclared)}
    assert list(fields) == [name for name, *_ in CONFIG_KEYS]
    assert fields["max_force"].type == "float" and fields["max_force"].default == 1.0
    assert fields["n_links"].default is None and OneDeclared().n_links is None


def test_a_declared_config_field_that_is_no_key_is_refused() -> None:
    from chaincart_env.config import _fields_of_the_key_table

    with pytest.raises(TypeError, match=r"declares \['max_forse'\]: expected keys of the core's table"):

        @_fields_of_the_key_table
        class Misspelt:
            max_forse: float = 1.0
