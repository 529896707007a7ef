"""Text generated from the core's one definition of the configuration stays in step
with it: the docs tables, the env docstring's argument list and the command line's
option help; and Python's config object has exactly the core's keys."""

from __future__ import annotations

import argparse
import dataclasses

from chaincart_env import ChainCartConfig, ChainCartEnv, RewardWeights, _core
from chaincart_env.env import observation_space
from chaincart_env.tools.compare.scene_options import add_scene_options
from chaincart_env.tools.config_docs import generated_pages, main, option_help


def test_the_committed_docs_tables_are_generated_from_the_core() -> None:
    stale = [str(path) for path, (committed, generated) in generated_pages().items() if committed != generated]
    assert not stale, f"run python -m chaincart_env docs --write: {stale}"
    assert main(write=False) == 0


def test_the_env_docstring_lists_every_key_with_its_help() -> None:
    doc = ChainCartEnv.__doc__ or ""
    assert "<configuration keys>" not in doc
    for name, _, help_text, _ in _core.CONFIG_KEYS:
        assert f"``{name}``" in doc and help_text in doc, name


def test_the_command_line_help_is_each_keys_help() -> None:
    parser = argparse.ArgumentParser()
    add_scene_options(parser)
    options = {action.dest: action.help for action in parser._actions}
    for name, _, help_text, _ in _core.CONFIG_KEYS:
        assert options[f"config_{name}"] == option_help(name)
        assert help_text.replace("%", "%%") in str(options[f"config_{name}"])


def test_the_config_object_has_the_cores_keys_and_defaults() -> None:
    names = [f.name for f in dataclasses.fields(ChainCartConfig) if f.init]
    assert names == [name for name, *_ in _core.CONFIG_KEYS]
    assert dataclasses.asdict(RewardWeights()) == dict(_core.REWARD_WEIGHTS)
    resolved = ChainCartConfig(scene=_core.DEFAULT_SCENE).to_dict()
    for name, default, _, _ in _core.CONFIG_KEYS:
        if name == "reward_weights":
            assert tuple(resolved[name].values()) == default
        else:
            assert resolved[name] == default, name


def test_the_model_defaults_are_the_paper_scenes_system() -> None:
    from chaincart_env import ChainCart

    paper = ChainCartConfig(scene="paper-fig1")
    model = ChainCart(paper.n_links)
    assert model.params == paper.make_model().params


def test_the_observation_bounds_follow_the_cores_state_layout() -> None:
    for planar in (True, False):
        config = ChainCartConfig(n_links=3, planar=planar)
        start, stop = config.state_layout["q"]
        space = observation_space(config)
        assert (space.high[start:stop] == 1.0).all() and (space.high[:start] == float("inf")).all()
        assert (space.high[stop:] == float("inf")).all()
