"""The sim-to-real keywords from Python: randomised and mismatched parameters, sensor
noise, control delay, force-rate limit and force noise through gym.make, the vector
envs, SB3 and the LQR policies."""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest

from chaincart_env import SCENES, ChainCart, ChainCartConfig, ChainCartEnv, ChainCartVectorEnv
from chaincart_env.errors import InvalidInputError
from chaincart_env.policies.lqr import LQRPolicy, OracleLQRPolicy
from chaincart_env.sb3 import ChainCartVecEnv

RANDOMIZE = {"cart_mass": 0.3, "link_masses": {"scale": [0.8, 1.2]}, "link_lengths": {"range": [0.4, 0.6], "per_link": False}}
EVERYTHING = dict(
    randomize=RANDOMIZE,
    obs_noise=0.01,
    action_delay=1,
    force_rate_limit=500.0,
    force_noise={"multiplicative": 0.2, "additive": 0.5},
    obs_dtype="float64",
)


def actions(step: int, num_envs: int) -> np.ndarray:
    return np.array([[np.sin(0.4 * step + 1.1 * i)] for i in range(num_envs)], dtype=np.float32)


def test_gym_make_reports_the_true_parameters_and_keeps_the_model_nominal() -> None:
    env = gym.make("ChainCart-v0", randomize=RANDOMIZE)
    obs, info = env.reset(seed=3)
    base = env.unwrapped
    assert base.model.cart_mass == 1.0 and tuple(base.model.link_lengths) == (0.5, 0.5)
    p = info["params"]
    assert p == base.true_params == base.get_true_params()
    assert 0.7 <= p["cart_mass"] < 1.3 and p["cart_mass"] != 1.0
    assert all(0.08 <= m < 0.12 for m in p["link_masses"])
    assert p["link_lengths"][0] == p["link_lengths"][1] and 0.4 <= p["link_lengths"][0] < 0.6
    # A new episode, new parameters; the same seed, the same ones.
    assert env.reset()[1]["params"] != p
    assert env.reset(seed=3)[1]["params"] == p
    # Without a parameter gap the reset info stays empty.
    assert gym.make("ChainCart-v0").reset(seed=0)[1] == {}


def test_the_spec_round_trip_and_pickling_keep_the_keywords() -> None:
    env = gym.make("ChainCart-v0", **EVERYTHING)
    again = gym.make(env.spec)
    assert again.unwrapped.config == env.unwrapped.config
    assert pickle.loads(pickle.dumps(env.unwrapped.config)) == env.unwrapped.config
    a, b = env.reset(seed=5)[0], again.reset(seed=5)[0]
    np.testing.assert_array_equal(a, b)


def test_env_i_of_the_vector_env_is_the_single_env_seeded_seed_plus_i() -> None:
    num_envs = 5
    vec = gym.make_vec("ChainCart-v0", num_envs=num_envs, vectorization_mode="vector_entry_point", **EVERYTHING)
    obs, info = vec.reset(seed=40)
    params = vec.unwrapped.true_params
    assert info["_params"].all() and np.array_equal(info["params"]["cart_mass"], params["cart_mass"])
    singles = [ChainCartEnv(**EVERYTHING) for _ in range(num_envs)]
    for i, env in enumerate(singles):
        o, inf = env.reset(seed=40 + i)
        np.testing.assert_array_equal(o, obs[i])
        assert inf["params"]["cart_mass"] == params["cart_mass"][i]
        np.testing.assert_array_equal(inf["params"]["link_lengths"], params["link_lengths"][i])
    for step in range(30):
        a = actions(step, num_envs)
        obs, rewards, term, trunc, _ = vec.step(a)
        for i, env in enumerate(singles):
            if env.unwrapped._needs_reset:
                break  # the vector env autoresets on its next step; stop comparing this env
            o, r, te, tr, _ = env.step(a[i])
            np.testing.assert_array_equal(o, obs[i], err_msg=f"env {i} step {step}")
            assert r == rewards[i]


def test_sb3_reads_each_envs_parameters() -> None:
    vec = ChainCartVecEnv(4, randomize=RANDOMIZE, seed=11)
    vec.reset()
    rows = vec.get_attr("true_params")
    assert rows == vec.env_method("get_true_params")
    assert [r["cart_mass"] for r in rows] == [vec.reset_infos[i]["params"]["cart_mass"] for i in range(4)]
    assert len({r["cart_mass"] for r in rows}) == 4
    native = ChainCartVectorEnv(4, randomize=RANDOMIZE)
    native.reset(seed=11)
    np.testing.assert_array_equal([r["cart_mass"] for r in rows], native.true_params["cart_mass"])


def test_a_randomised_env_steps_as_a_model_with_its_parameters() -> None:
    env = ChainCartEnv(randomize=RANDOMIZE, obs_dtype="float64", scene="inverted-2")
    env.reset(seed=8)
    p = env.true_params
    true_model = ChainCart(2, p["cart_mass"], p["link_masses"], p["link_lengths"], p["gravity"], True)
    c = env.config
    for step in range(10):
        y = env.model_state.copy()
        a = float(np.float32(np.sin(step)))  # the env sees the float32 action
        obs = env.step(np.array([a], dtype=np.float32))[0]
        expected = true_model.step(y, [a * c.max_force], c.dt, c.integrator, c.substeps)
        np.testing.assert_array_equal(obs, expected)
        nominal = env.model.step(y, [a * c.max_force], c.dt, c.integrator, c.substeps)
        assert not np.array_equal(obs, nominal)


def test_fixed_mismatch_and_params() -> None:
    env = ChainCartEnv(params={"link_lengths": [0.4, 0.7]}, mismatch={"cart_mass": 1.5, "gravity": 0.5})
    _, info = env.reset(seed=0)
    assert info["params"] == {"cart_mass": 1.5, "link_masses": [0.1, 0.1], "link_lengths": [0.4, 0.7], "gravity": 4.905}
    assert env.model.cart_mass == 1.0
    # A ChainCart as params: all its parameters.
    env = ChainCartEnv(params=ChainCart(2, 2.0, 0.2, 0.3, 9.0, True))
    assert env.reset(seed=0)[1]["params"]["link_lengths"] == [0.3, 0.3]


def test_noise_is_added_to_observations_only() -> None:
    noisy = ChainCartEnv(obs_noise=[0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], obs_dtype="float64")
    clean = ChainCartEnv(obs_dtype="float64")
    o1, o2 = noisy.reset(seed=2)[0], clean.reset(seed=2)[0]
    diff = o1 - o2
    assert diff[1] != 0 and np.all(np.delete(diff, 1) == 0)
    for _ in range(5):
        o1, o2 = noisy.step(np.array([0.5]))[0], clean.step(np.array([0.5]))[0]
        np.testing.assert_array_equal(noisy.model_state, clean.model_state)
        assert o1[1] != o2[1] and o1[0] == o2[0]


def test_a_one_step_delay_applies_the_previous_action() -> None:
    delayed, plain = ChainCartEnv(action_delay=1), ChainCartEnv()
    delayed.reset(seed=4)
    plain.reset(seed=4)
    previous = np.zeros(1, dtype=np.float32)
    for step in range(8):
        a = actions(step, 1)[0]
        np.testing.assert_array_equal(delayed.step(a)[0], plain.step(previous)[0])
        previous = a


def test_the_rate_limit_ramps_the_force() -> None:
    # 20 N max force, 250 N/s at 20 ms: 5 N per step, so a full push takes 4 steps.
    env = ChainCartEnv(force_rate_limit=250.0, obs_dtype="float64", start_noise=0.0)
    c = env.config
    env.reset(seed=0)
    y = env.model_state.copy()
    for a, force in ((1.0, 5.0), (1.0, 10.0), (1.0, 15.0), (1.0, 20.0), (1.0, 20.0), (-1.0, 15.0), (0.0, 10.0)):
        obs = env.step(np.array([a]))[0]
        y = env.model.step(y, [force], c.dt, c.integrator, c.substeps)
        np.testing.assert_array_equal(obs, y)


def test_oracle_lqr_designs_on_the_true_parameters() -> None:
    vec = ChainCartVectorEnv(3, mismatch={"link_masses": 1.3}, randomize={"cart_mass": 0.3})
    obs, _ = vec.reset(seed=1)
    nominal = LQRPolicy.from_env(vec)
    oracle = LQRPolicy.from_env(vec, oracle=True)
    assert isinstance(oracle, OracleLQRPolicy)
    np.testing.assert_array_equal(nominal.gain, vec.model.lqr_gain([-1, -1]))
    gains = oracle.gains()
    p = vec.true_params
    for i in range(3):
        true_model = ChainCart(2, p["cart_mass"][i], p["link_masses"][i], p["link_lengths"][i], p["gravity"][i], True)
        np.testing.assert_array_equal(gains[i], true_model.lqr_gain([-1, -1]))
        assert not np.allclose(gains[i], nominal.gain)
    acts = oracle.predict(obs)[0]
    assert acts.shape == (3, 1)
    # Without a gap the oracle is the nominal design.
    env = ChainCartEnv()
    o, _ = env.reset(seed=0)
    np.testing.assert_array_equal(LQRPolicy.from_env(env, oracle=True).predict(o)[0], LQRPolicy.from_env(env).predict(o)[0])


@pytest.mark.parametrize(
    "scene", ["inverted-2-randomized", "inverted-2-noisy", "spatial-inverted-2-randomized", "spatial-inverted-2-noisy"]
)
def test_the_sim_to_real_scenes_run_under_the_nominal_lqr(scene: str) -> None:
    assert scene in SCENES
    vec = ChainCartVectorEnv(8, scene=scene)
    obs, _ = vec.reset(seed=0)
    policy = LQRPolicy.from_env(vec)
    ended = np.zeros(8, dtype=bool)
    for _ in range(100):
        obs, _, term, trunc, _ = vec.step(policy.predict(obs)[0])
        ended |= term
    # The nominal LQR still holds these (moderate) gaps for 2 s.
    assert not ended.any(), scene


@pytest.mark.parametrize(
    ("keywords", "needle"),
    [
        (dict(randomize={"pole_mass": 0.1}), 'randomize key "pole_mass"'),
        (dict(randomize={"cart_mass": 1.0}), "randomize.cart_mass range [0, 2]"),
        (dict(randomize={"gravity": {"range": [10.0, 9.0]}}), "randomize.gravity range [10, 9]"),
        (dict(randomize={"gravity": {"log_range": [-1.0, 9.0]}}), "randomize.gravity range [-1, 9]"),
        (dict(randomize={"link_masses": {"scale": 0.1, "range": [1, 2]}}), "only one distribution"),
        (dict(randomize={"link_masses": {"shape": [1, 2]}}), 'unknown key "shape"'),
        (dict(randomize="all"), "randomize = all"),
        (dict(mismatch={"link_lengths": [1.0, 1.0, 1.0]}), "mismatch.link_lengths has length 3, expected 2"),
        (dict(params={"cart_mass": -1.0}), "params.cart_mass = -1"),
        (dict(obs_noise=-0.1), "obs_noise[0] = -0.1"),
        (dict(obs_noise=[0.1, 0.2]), "obs_noise has length 2, expected 8"),
        (dict(action_delay=-1), "action_delay = -1"),
        (dict(force_rate_limit=0.0), "force_rate_limit = 0"),
        (dict(force_noise={"multiplicative": -0.1}), "force_noise.multiplicative = -0.1: expected a finite number >= 0"),
        (dict(force_noise={"additive": float("nan")}), "force_noise.additive = NaN: expected a finite number >= 0"),
        (dict(force_noise={"additive": float("inf")}), "force_noise.additive = inf"),
        (dict(force_noise={"gain": 0.1}), 'force_noise has unknown key \'gain\': expected some of "multiplicative", "additive"'),
        (dict(force_noise={"additive": "big"}), "force_noise['additive'] = 'big': expected a finite number >= 0"),
        (dict(force_noise=0.1), 'force_noise = 0.1: expected None or a dict with some of "multiplicative", "additive"'),
    ],
)
def test_bad_settings_raise_errors_naming_them(keywords: dict, needle: str) -> None:
    with pytest.raises(InvalidInputError) as e:
        ChainCartConfig(**keywords)
    assert needle in str(e.value)


def test_a_scene_setting_can_be_switched_off() -> None:
    c = ChainCartConfig(scene="inverted-2-noisy", obs_noise=0.0, action_delay=0, obs_dtype="float64")
    assert (c.obs_noise, c.action_delay) == ([0.0], 0)
    assert ChainCartConfig(scene="inverted-2-noisy").has_reality_gap and not ChainCartConfig().has_reality_gap
    assert not ChainCartConfig(scene="inverted-2-noisy").has_param_gap
    off, clean = ChainCartEnv(c), ChainCartEnv(obs_dtype="float64")
    np.testing.assert_array_equal(off.reset(seed=1)[0], clean.reset(seed=1)[0])
    np.testing.assert_array_equal(off.step(np.array([0.7]))[0], clean.step(np.array([0.7]))[0])
    assert ChainCartConfig(scene="inverted-2-randomized", randomize={}).randomize is None


def test_the_command_line_takes_the_keywords_with_the_cores_help() -> None:
    import argparse

    from chaincart_env.config import REALITY_KEYS
    from chaincart_env.tools.compare.scene_options import add_scene_options, config_from_options

    parser = argparse.ArgumentParser()
    add_scene_options(parser)
    text = parser.format_help()
    assert "Domain randomisation at every reset" in text and "--force-rate-limit" in text
    args = parser.parse_args(["--randomize", '{"link_masses": 0.3}', "--action-delay", "2", "--obs-noise", "0.01"])
    c = config_from_options(args)
    assert c.randomize == {"link_masses": {"scale": [0.7, 1.3], "per_link": True}}
    assert (c.action_delay, c.obs_noise) == (2, [0.01])
    assert "--force-noise" in text and "Gaussian disturbance of the force" in text
    args = parser.parse_args(["--force-noise", '{"additive": 1.5}'])
    assert config_from_options(args).force_noise == {"additive": 1.5}
    assert len(REALITY_KEYS) == 7


@pytest.mark.parametrize("cls", [ChainCartEnv, ChainCartVectorEnv, ChainCartVecEnv])
def test_copies_mid_episode_continue_identically_with_every_option(cls: type) -> None:
    import copy

    env = cls(**EVERYTHING) if cls is ChainCartEnv else cls(3, **EVERYTHING)
    n = 1 if cls is ChainCartEnv else 3
    if cls is ChainCartVecEnv:
        env.seed(5)
        env.reset()
    else:
        env.reset(seed=5)

    def run(e: object, steps: int) -> list[np.ndarray]:
        out = []
        for s in range(steps):
            a = actions(s, n)
            if cls is ChainCartEnv:
                obs, _, te, tr, _ = e.step(a[0])
                if te or tr:
                    e.reset()
            else:
                obs = e.step(a)[0]
            out.append(np.asarray(obs).copy())
        return out

    run(env, 7)
    twin, pickled = copy.deepcopy(env), pickle.loads(pickle.dumps(env))
    expected = run(env, 30)
    for other in (twin, pickled):
        for a, b in zip(run(other, 30), expected):
            np.testing.assert_array_equal(a, b)


def test_compare_evaluates_the_oracle_lqr_on_the_rollouts_own_envs() -> None:
    from chaincart_env.tools.compare.evaluation import evaluate_policies, evaluation_seeds
    from chaincart_env.tools.compare.job import lqr_baseline

    config = ChainCartConfig(scene="inverted-2-randomized", randomize={"cart_mass": 0.5, "link_lengths": 0.5})
    oracle = lqr_baseline(config, oracle=True)
    seeds = evaluation_seeds(7, 4)
    _, episodes, summaries = evaluate_policies([("LQR", lqr_baseline(config)), ("LQR oracle", oracle)], config, seeds)
    assert [s["policy"] for s in summaries] == ["LQR", "LQR oracle"]
    # The oracle read the rollout's own batch: its gains are those of each episode's
    # true system, seeded like a batch of the evaluation seeds.
    batch = config.make_batch(4, "same_step")
    batch.reset(list(seeds), None)
    p = batch.param_arrays()
    for i in range(4):
        true_model = ChainCart(2, p["cart_mass"][i], p["link_masses"][i], p["link_lengths"][i], p["gravity"][i], True)
        assert any(np.array_equal(g, true_model.lqr_gain([-1, -1])) for g in oracle._gains_by_params.values())


def test_force_noise_round_trips_in_its_canonical_form() -> None:
    c = ChainCartConfig(force_noise={"multiplicative": 0.3})
    assert c.force_noise == {"multiplicative": 0.3} and c.has_reality_gap and not c.has_param_gap
    both = ChainCartConfig(force_noise={"additive": 2, "multiplicative": 0.1})
    assert both.force_noise == {"multiplicative": 0.1, "additive": 2.0}
    for config in (c, both):
        assert ChainCartConfig(**config.to_dict()) == config
        assert pickle.loads(pickle.dumps(config)) == config
    # Standard deviations of 0, an empty dict and None are all "off".
    for off in ({"multiplicative": 0.0, "additive": 0}, {}, None):
        assert ChainCartConfig(force_noise=off).force_noise is None
    assert not ChainCartConfig(force_noise={}).has_reality_gap
    assert ChainCartConfig().force_noise is None


def test_force_noise_disturbs_the_motion_but_no_other_random_number() -> None:
    noisy = ChainCartEnv(obs_noise=0.01, force_noise={"multiplicative": 0.3, "additive": 1.0}, obs_dtype="float64")
    quiet = ChainCartEnv(obs_noise=0.01, obs_dtype="float64")
    np.testing.assert_array_equal(noisy.reset(seed=6)[0], quiet.reset(seed=6)[0])
    for step in range(5):
        a = actions(step, 1)[0]
        noisy.step(a)
        quiet.step(a)
        assert not np.array_equal(noisy.model_state, quiet.model_state)
    # Reseeded, both start again from the same noisy observation.
    np.testing.assert_array_equal(noisy.reset(seed=7)[0], quiet.reset(seed=7)[0])
    # The same seed reproduces the disturbed run bit for bit.
    again = ChainCartEnv(noisy.config)
    again.reset(seed=7)
    for step in range(5):
        a = actions(step, 1)[0]
        np.testing.assert_array_equal(again.step(a)[0], noisy.step(a)[0])


def test_the_vector_env_with_force_noise_is_n_single_envs_for_any_batch_path() -> None:
    keywords = dict(force_noise={"multiplicative": 0.25, "additive": 0.8}, obs_dtype="float64", max_episode_steps=12)
    num_envs = 6  # the lane kernel; one env steps env by env
    vec = ChainCartVectorEnv(num_envs, **keywords)
    obs, _ = vec.reset(seed=90)
    singles = [ChainCartEnv(**keywords) for _ in range(num_envs)]
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(env.reset(seed=90 + i)[0], obs[i])
    for step in range(10):
        a = actions(step, num_envs)
        obs, rewards, _, _, _ = vec.step(a)
        for i, env in enumerate(singles):
            o, r, *_ = env.step(a[i])
            np.testing.assert_array_equal(o, obs[i], err_msg=f"env {i} step {step}")
            assert r == rewards[i]
