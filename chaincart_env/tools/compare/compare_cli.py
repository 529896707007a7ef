"""Command line of the main job: ``compare`` (train the learned policies, evaluate them
and the model-based controllers, report) and ``evaluate`` (re-run the comparison of a
saved run). Registered as subcommands of
``python -m chaincart_env`` and as the console script ``chaincart-compare``.

Nothing heavy is imported here: stable-baselines3 (or Ray) and torch load when a command runs.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

from chaincart_env.errors import ChainCartError, InvalidInputError
from chaincart_env.tools.compare.curriculum import CURRICULA, JUDGED_STARTS, JUDGES
from chaincart_env.tools.compare.imitation import SCENE_IMITATIONS
from chaincart_env.tools.compare.recipes import GENERIC
from chaincart_env.tools.compare.scene_options import add_scene_options, config_from_options, parse_value
from chaincart_env.tools.compare.sweeps import DEFAULT_SWEEPS, SWEEP_AXES, parse_sweep
from chaincart_env.tools.controllers import CONTROLLERS, LEARNED

__all__ = ["add_commands", "compare_main"]

DEFAULT_OUT = Path("runs/compare")


def _integer(minimum: int, what: str) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} = {text!r}: expected an integer >= {minimum}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{what} = {value}: expected an integer >= {minimum}")
        return value

    return parse


def _add_evaluation_options(parser: argparse.ArgumentParser, defaults: bool) -> None:
    parser.add_argument("--eval-episodes", type=_integer(1, "eval-episodes"), default=50 if defaults else None,
                        help="seeded evaluation starts per policy" + (" (default: 50)" if defaults else
                                                                      " (default: the run's)"))
    parser.add_argument("--eval-seed", type=_integer(0, "eval-seed"), default=1_000_000 if defaults else None,
                        help="seed of the first evaluation start; start i uses eval-seed + i"
                        + (" (default: 1000000)" if defaults else " (default: the run's)"))
    parser.add_argument("--torch-threads", type=_integer(1, "torch-threads"), default=1,
                        help="torch threads (default 1: fastest for these small networks on a shared machine)")


def _configure_compare(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--timesteps", type=_integer(1, "timesteps"), default=None,
                        help=f"training budget in env steps of every learned policy (default: each one's training "
                        f"recipe for the scene, {GENERIC.timesteps} without one)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"output folder (default: {DEFAULT_OUT})")
    policies = parser.add_mutually_exclusive_group()
    policies.add_argument("--policies", default=None, metavar="P1,P2,...",
                          help=f"the controllers to compare, in any order, among: {', '.join(CONTROLLERS)}. "
                          f"Learned ones ({', '.join(LEARNED)}) train once per training seed with their recipe; "
                          "model-based ones are designed on the scene's nominal model. All run from the same seeded "
                          "starts on the same true systems; pretrained:<scene>/<name> adds a shipped agent as it is "
                          "(default: ppo,lqr)")
    policies.add_argument("--algo", type=str.lower, choices=LEARNED, default=None,
                          help="one stable-baselines3 algorithm compared with the LQR: --algo sac is --policies sac,lqr")
    seeds = parser.add_mutually_exclusive_group()
    seeds.add_argument("--seed", type=_integer(0, "seed"), default=None,
                       help="one training seed: agent and env i seeded seed + i (default: 0)")
    seeds.add_argument("--seeds", type=_seed_list, default=None, metavar="S1,S2,...",
                       help="several training seeds, one independent agent each; tables and curves aggregate over "
                       "them (mean and 95%% bootstrap interval over seeds)")
    parser.add_argument("--sweep", dest="sweeps", action="append", default=[], metavar="AXIS=V1,V2,...",
                        help="evaluate every policy on the same starts at each value of AXIS (repeatable; axes: "
                        f"{', '.join(sorted(SWEEP_AXES))}; default: {_default_sweeps()})")
    parser.add_argument("--eval-every", type=_integer(1, "eval-every"), default=20_000,
                        help="timesteps between deterministic evaluations during training (default: 20000)")
    parser.add_argument("--eval-starts", type=_integer(1, "eval-starts"), default=20,
                        help="seeded starts of each evaluation during training (default: 20)")
    parser.add_argument("--checkpoint-every", type=_integer(1, "checkpoint-every"), default=50_000,
                        help="timesteps between checkpoints, for --resume (default: 50000)")
    parser.add_argument("--resume", type=Path, default=None, metavar="RUN_DIR",
                        help="continue an interrupted run with its own settings (other options are ignored, but "
                        "--address)")
    parser.add_argument("--num-envs", type=_integer(1, "num-envs"), default=None,
                        help="training envs in the native VecEnv of the sb3 trainer, for every learned policy "
                        f"(default: each one's training recipe for the scene, {GENERIC.num_envs} without one)")
    parser.add_argument("--algo-kwarg", dest="algo_kwargs", action="append", default=[], metavar="[ALGO:]KEY=VALUE",
                        help="constructor keyword of the learned algorithms on top of their training recipe "
                        "(repeatable), e.g. --algo-kwarg n_steps=256; ALGO: for one of them only, e.g. --algo-kwarg "
                        "sac:learning_starts=1000; with --trainer rllib a PPOConfig.training keyword, "
                        "e.g. --algo-kwarg train_batch_size_per_learner=4096")
    parser.add_argument("--no-imitation", action="store_true",
                        help="train PPO from scratch on scenes whose recipe first imitates the planner's controller "
                        "(transitions-2)")
    parser.add_argument("--critic-warmup", type=int, default=None, metavar="STEPS",
                        help="after the scene's imitation, train only the value function for the first STEPS env "
                        f"steps (the policy frozen) (default: the scene's, {_scene_imitations('critic_warmup')})")
    parser.add_argument("--imitation-weight", type=float, default=None, metavar="C",
                        help="after the scene's imitation, keep its fit as a second loss of weight C: after every "
                        "rollout, as many minibatches of the imitation's data as PPO's update has; 0 turns it off "
                        f"(default: the scene's, {_scene_imitations('anchor_weight')})")
    parser.add_argument("--mirror-weight", type=float, default=0.0, metavar="C",
                        help="training only: a second loss of weight C beside PPO's asking the policy to act "
                        "mirror-symmetrically (the mirrored observation's action is the mirrored action; "
                        "chaincart_env.tools.compare.mirror_loss); PPO agents; 0 turns it off (default: 0)")
    parser.add_argument("--curriculum", choices=CURRICULA, default=None,
                        help="where the training episodes start: plan = a share of them (--plan-fraction) at states "
                        "drawn along the planner's swing-up, the rest at the scene's starts; reverse = the same, drawn "
                        "at first from the last tenth of the plan, a tenth more each time half of 256 such episodes "
                        "succeed; none = the scene's starts only (default: the scene's curriculum, none on most "
                        "scenes)")
    parser.add_argument("--curriculum-judge", choices=JUDGES, default=None,
                        help="with --curriculum reverse: what a plan-start episode must do for the window to widen: "
                        "success = the scene's success; held = reach the time limit within the scene's fall_limit "
                        "(--fall-limit, required), which a policy still exploring can do where its noise keeps it "
                        "outside the success tolerances (default: success)")
    parser.add_argument("--curriculum-window", type=float, default=None, metavar="W",
                        help="with --curriculum reverse: the share of the plan, from its end, drawn from at first and "
                        "added at each widening, in (0, 1] (default: 0.1)")
    parser.add_argument("--curriculum-threshold", type=float, default=None, metavar="T",
                        help="with --curriculum reverse: the share of 256 plan-start episodes that must pass for the "
                        "window to widen, in (0, 1] (default: 0.5)")
    parser.add_argument("--curriculum-judged-starts", choices=JUDGED_STARTS, default=None,
                        help="with --curriculum reverse: which plan-start episodes the widening counts: window = every "
                        "one; newest = those started in the band the last widening added (before the first widening, "
                        "the whole window), so that the window grows only once the policy holds the newest band "
                        "(default: window)")
    parser.add_argument("--curriculum-freeze-statistics", action="store_true",
                        help="with --curriculum reverse and a recipe that normalises observations: stop counting the "
                        "normalisation statistics at the first widening and clip at 100 standard deviations, so that "
                        "the wider starts do not rescale what the policy learned to balance on (default: off)")
    parser.add_argument("--curriculum-spread-floor", type=float, default=None, metavar="S",
                        help="with --curriculum plan or reverse and a recipe that normalises observations: divide each "
                        "observation component by at least S times its spread along the plan, in [0, 1], so that the "
                        "statistics of a balance do not magnify what barely moves near the target into hundreds of "
                        "standard deviations along the plan (default: 0, none)")
    parser.add_argument("--plan-fraction", type=float, default=None, metavar="F",
                        help="with --curriculum plan or reverse: the share of training episodes that start on the plan, in "
                        "(0, 1] (default: 0.5)")
    parser.add_argument("--training-reward", default=None, metavar="REWARD",
                        help="the reward the learned agents train on (exp or tolerance) instead of the scene's; "
                        "evaluations keep the scene's reward and success criterion (default: the scene's training reward: "
                        "exp on swingup-2, the scene's own reward elsewhere)")
    parser.add_argument("--warm-start", type=Path, default=None, metavar="PATH",
                        help="the learned agents start from the weights of the agent saved at PATH (a training run's "
                        "folder: its best model; or a model file), e.g. a nominal agent fine-tuned by ppo-robust; same "
                        "algorithm and observation/action spaces (the same --history). The file is loaded with SB3's "
                        "loader: trusted code only")
    parser.add_argument("--polish", type=_integer(0, "polish"), default=None, metavar="STEPS",
                        help="a second stage: each nominal learned agent trains STEPS more from its best model at a tenth "
                        "of its learning rate (--polish-learning-rate sets it), with its other settings; the kept model "
                        "is the best of that stage, whose first evaluation is the first stage's best; 0: none (sb3 "
                        f"trainer; default: the scene's with its recipe's budget, {_scene_polish_text()}, none elsewhere "
                        "or with --timesteps)")
    parser.add_argument("--polish-learning-rate", type=float, default=None, metavar="LR",
                        help="with --polish: the second stage's learning rate (default: a tenth of the run's)")
    parser.add_argument("--off-track-penalty", type=_scale("off_track_penalty"), default=None, metavar="P",
                        help="training only: subtract P from the reward of the step that leaves the track, so that "
                        "running off costs something while the reward is still near zero (chaincart_env.tools.compare."
                        "shaping); evaluations keep the scene's reward (default: 0)")
    parser.add_argument("--plan-bonus", type=_scale("plan_bonus"), default=None, metavar="C",
                        help="training only: add up to C to each step's reward for a state near the planner's "
                        "swing-up, more the further along it (chaincart_env.tools.compare.shaping); 0 turns it off; "
                        "evaluations keep the scene's reward (default: 0.3 on swingup-2, 0 elsewhere)")
    parser.add_argument("--action-change-penalty", type=_scale("action_change_penalty"), default=None, metavar="C",
                        help="training only: subtract C times the mean squared change of the action (in [-1, 1] "
                        "units) from each step's reward, for a smooth force (chaincart_env.tools.compare.shaping); "
                        "evaluations keep the scene's reward (default: 0)")
    parser.add_argument("--plan-tube", type=_scale("plan_tube"), default=None, metavar="R",
                        help="training only: end an episode at the first step where the chain lies farther than R "
                        "from every state of the planner's swing-up (link directions, and angular velocities in "
                        "tenths of rad/s; the cart left out), as motion imitation ends a motion that left its "
                        "reference (chaincart_env.tools.compare.plan_tube); 0 turns it off; evaluations end episodes "
                        "as the scene does (default: 0)")
    parser.add_argument("--history", type=_integer(1, "history"), default=None, metavar="K",
                        help="the learned agents observe the last K observations and actions too (oldest first, zeros "
                        "before an episode's start; chaincart_env.history), in training and in every evaluation, for "
                        "delays drawn per episode (action_delay=(0, k)); sb3 trainer, without the imitation warm start "
                        "(default: the plain observation)")
    _add_rllib_options(parser)
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    _add_evaluation_options(parser, defaults=True)
    add_scene_options(parser)
    # Errors are reported by this (sub)parser, whatever parser dispatched.
    parser.set_defaults(handler=lambda args, _dispatcher=None: _run_compare_command(args, parser))


def _scene_polish_text() -> str:
    from chaincart_env.tools.compare.stages import SCENE_POLISH

    return ", ".join(f"{steps} on {scene}" for scene, steps in SCENE_POLISH.items())


def _polish(args: argparse.Namespace, parser: argparse.ArgumentParser) -> Any:
    """``--polish`` and its learning rate as run_compare takes them (``"scene"`` when
    not given)."""
    if args.polish is None or args.polish == 0:
        if args.polish_learning_rate is not None:
            parser.error(f"--polish-learning-rate {args.polish_learning_rate}: expected --polish STEPS with it")
        return "scene" if args.polish is None else None
    return {"timesteps": args.polish, "learning_rate": args.polish_learning_rate}


def _scale(term: str) -> Callable[[str], float]:
    """A parser of a shaping term's value (a finite number >= 0), erring in its name."""

    def parse(text: str) -> float:
        from chaincart_env.tools.compare.shaping import Shaping

        try:
            value = float(text)
        except ValueError:
            value = text  # type: ignore[assignment]  # refused by name below
        try:
            return getattr(Shaping(**{term: value}), term)
        except ChainCartError as error:
            raise argparse.ArgumentTypeError(str(error)) from None

    return parse


def _add_rllib_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("trainer (Ray RLlib on a cluster: needs the rllib extra)")
    group.add_argument("--trainer", choices=("sb3", "rllib"), default="sb3",
                       help="sb3: stable-baselines3 on --num-envs envs in this process (default); rllib: Ray RLlib "
                       "PPO on --num-env-runners runners of --envs-per-runner native envs each")
    group.add_argument("--num-env-runners", type=_integer(0, "num-env-runners"), default=2,
                       help="RLlib env runners, one CPU each (0: sample in the driver; default: 2)")
    group.add_argument("--envs-per-runner", type=_integer(1, "envs-per-runner"), default=4,
                       help="native envs in each RLlib env runner (default: 4)")
    group.add_argument("--address", default=None,
                       help="Ray cluster for the run: 'auto' (the one this machine joined with `ray start`), "
                       "HOST:PORT of its head, or 'local' (a new one on this machine). The study's independent "
                       "pieces (SB3 training seeds, evaluation cells) then run there as Ray tasks, with the same "
                       "results, and so do RLlib's env runners. Default: everything in this process (RLlib: a "
                       "local cluster for its runners). With --resume: replaces the run's cluster")


def _configure_evaluate(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", type=Path,
                        help="a run folder written by compare, or one training run's folder (seed-<s>/ or "
                        "<algo>/seed-<s>/) or its model.zip or rllib_checkpoint, or pretrained:<scene>/<name> (a "
                        "shipped agent, against the LQR on its scene)")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: MODEL_DIR/evaluation)")
    parser.add_argument("--address", default=None,
                        help="Ray cluster ('auto', HOST:PORT, or 'local' for a new one here) on which the evaluation "
                        "cells run as Ray tasks, with the same results (default: in this process)")
    _add_evaluation_options(parser, defaults=False)
    parser.set_defaults(handler=lambda args, _dispatcher=None: _run_evaluate_command(args, parser))


def _seed_list(text: str) -> list[int]:
    try:
        seeds = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"seeds = {text!r}: expected integers >= 0 separated by commas") from None
    if not seeds or min(seeds) < 0 or len(set(seeds)) != len(seeds):
        raise argparse.ArgumentTypeError(f"seeds = {text!r}: expected distinct integers >= 0 separated by commas")
    return seeds


def _default_sweeps() -> str:
    return " ".join(f"{axis}={','.join(f'{v:g}' for v in values)}" for axis, values in DEFAULT_SWEEPS.items())


def _algo_kwargs(texts: Sequence[str]) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
    """``--algo-kwarg`` options as the keywords of every learned algorithm and those of
    one algorithm (``ALGO:KEY=VALUE``)."""
    shared: dict[str, Any] = {}
    per_algo: dict[str, dict[str, Any]] = {}
    for text in texts:
        target, sep, value = text.partition("=")
        algo, colon, key = target.rpartition(":")
        algo, key = algo.strip().lower(), key.strip()
        if not sep or not key.isidentifier() or (colon and algo not in LEARNED):
            raise InvalidInputError(
                f"--algo-kwarg {text!r}: expected [ALGO:]KEY=VALUE with ALGO one of {', '.join(LEARNED)}, "
                "e.g. --algo-kwarg n_steps=256 or --algo-kwarg sac:learning_starts=1000"
            )
        # A zoo-style "dict(key=..., ...)" stays one string (its commas are not a list's).
        parsed = value.strip() if value.strip().startswith("dict(") else parse_value(value)
        (per_algo.setdefault(algo, {}) if colon else shared)[key] = parsed
    return shared, per_algo


def _curriculum(
    name: Optional[str],
    fraction: Optional[float],
    judge: Optional[str] = None,
    window: Optional[float] = None,
    threshold: Optional[float] = None,
    freeze_statistics: bool = False,
    judged_starts: Optional[str] = None,
    spread_floor: Optional[float] = None,
) -> Any:
    """``--curriculum``, ``--plan-fraction``, ``--curriculum-spread-floor`` and the reverse
    curriculum's ``--curriculum-judge``, ``--curriculum-window``, ``--curriculum-threshold``,
    ``--curriculum-freeze-statistics`` and ``--curriculum-judged-starts`` as
    ``run_compare``'s ``curriculum``."""
    from chaincart_env.tools.compare.curriculum import PlanStarts

    for option, share in {"--plan-fraction": fraction, "--curriculum-spread-floor": spread_floor}.items():
        if share is not None and name not in ("plan", "reverse"):
            raise InvalidInputError(f"{option} {share:g} without --curriculum plan or reverse: expected "
                                    "--curriculum plan or reverse with it")
    reverse_only = {"--curriculum-judge": judge, "--curriculum-window": window, "--curriculum-threshold": threshold,
                    "--curriculum-freeze-statistics": True if freeze_statistics else None,
                    "--curriculum-judged-starts": judged_starts}
    for option, value in reverse_only.items():
        if value is not None and name != "reverse":
            shown = "" if value is True else f" {value}" if isinstance(value, str) else f" {value:g}"
            raise InvalidInputError(f"{option}{shown} without --curriculum reverse: expected "
                                    "--curriculum reverse with it")
    if name is None:
        return "scene"
    if name == "none":
        return None
    settings: dict[str, Any] = {"reverse": name == "reverse"}
    if fraction is not None:
        settings["fraction"] = fraction
    if judge is not None:
        settings["judge"] = judge
    if window is not None:
        settings["window"] = window
    if threshold is not None:
        settings["threshold"] = threshold
    if freeze_statistics:
        settings["freeze_statistics"] = True
    if judged_starts is not None:
        settings["judged_starts"] = judged_starts
    if spread_floor is not None:
        settings["spread_floor"] = spread_floor
    return PlanStarts(**settings)


def _sweeps(texts: Sequence[str]) -> Optional[dict[str, list[float]]]:
    """``--sweep`` options as axis -> values (``None``: the default sweeps)."""
    if not texts:
        return None
    sweeps: dict[str, list[float]] = {}
    for text in texts:
        axis, values = parse_sweep(text)
        if axis in sweeps:
            raise InvalidInputError(f"--sweep {axis} is given twice: expected each axis once")
        sweeps[axis] = values
    return sweeps


def _run_compare_command(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from chaincart_env.tools.compare.job import DEFAULT_POLICIES, resume_compare, run_compare

    try:
        if args.resume is not None:
            resume_compare(args.resume, address=args.address)
            return 0
        config = config_from_options(args)
        hyperparameters, algo_hyperparameters = _algo_kwargs(args.algo_kwargs)
        sweeps = _sweeps(args.sweeps)
        curriculum = _curriculum(args.curriculum, args.plan_fraction, args.curriculum_judge, args.curriculum_window,
                                 args.curriculum_threshold, args.curriculum_freeze_statistics,
                                 args.curriculum_judged_starts, args.curriculum_spread_floor)
    except (ChainCartError, TypeError) as error:
        parser.error(str(error))
    if args.policies is not None:
        policies = [args.policies]
    elif args.algo is not None:
        policies = [args.algo, "lqr"]
    else:
        policies = list(DEFAULT_POLICIES)
    seeds = args.seeds if args.seeds is not None else [0 if args.seed is None else args.seed]
    try:
        run_compare(config, out=args.out, policies=policies, timesteps=args.timesteps, seeds=seeds,
                    num_envs=args.num_envs, eval_episodes=args.eval_episodes, eval_seed=args.eval_seed,
                    sweeps=sweeps, eval_every=args.eval_every, eval_starts=args.eval_starts,
                    checkpoint_every=args.checkpoint_every, progress_bar=not args.no_progress,
                    torch_threads=args.torch_threads, hyperparameters=hyperparameters,
                    algo_hyperparameters=algo_hyperparameters, trainer=args.trainer,
                    rllib=dict(num_env_runners=args.num_env_runners, envs_per_runner=args.envs_per_runner),
                    address=args.address, imitation=_imitation(args, parser), curriculum=curriculum,
                    training_reward="scene" if args.training_reward is None else args.training_reward,
                    history=args.history,
                    shaping=dict(off_track_penalty=args.off_track_penalty, plan_bonus=args.plan_bonus,
                                 action_change_penalty=args.action_change_penalty, plan_tube=args.plan_tube),
                    warm_start_from=args.warm_start, polish=_polish(args, parser), mirror_weight=args.mirror_weight)
    except ChainCartError as error:
        parser.error(str(error))
    return 0


def _scene_imitations(field: str) -> str:
    """A field of every scene's imitation, in words ("500000 on transitions-2")."""
    return ", ".join(f"{getattr(imitation, field):g} on {scene}" for scene, imitation in SCENE_IMITATIONS.items())


def _imitation(args: argparse.Namespace, parser: argparse.ArgumentParser) -> Any:
    """``run_compare``'s ``imitation``: off, the scene's, or the scene's with the fields given."""
    changes = {field: value for field, value in (("critic_warmup", args.critic_warmup),
                                                 ("anchor_weight", args.imitation_weight)) if value is not None}
    if args.no_imitation:
        if changes:
            parser.error("--critic-warmup and --imitation-weight keep an imitation: expected them without "
                         "--no-imitation")
        return False
    return changes or True


def _run_evaluate_command(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from chaincart_env.pretrained_agents import is_pretrained_slot
    from chaincart_env.tools.compare.job import run_evaluate

    runner: Callable[..., Any] = run_evaluate
    if is_pretrained_slot(str(args.model)):  # a shipped agent, not a saved run
        from chaincart_env.tools.compare.pretrained_evaluation import evaluate_pretrained

        runner = evaluate_pretrained
    try:
        runner(args.model, out=args.out, eval_episodes=args.eval_episodes, eval_seed=args.eval_seed,
               torch_threads=args.torch_threads, address=args.address)
    except ChainCartError as error:
        parser.error(str(error))
    return 0


def add_commands(commands: "argparse._SubParsersAction[argparse.ArgumentParser]") -> None:
    """Adds ``compare`` and ``evaluate`` to a subcommand set; each parser's ``handler``
    default runs it as ``args.handler(args, dispatching_parser)``."""
    _configure_compare(commands.add_parser(
        "compare", help="train learned agents (SB3 or RLlib) and compare them with model-based controllers (the main "
        "job)",
        description="Train each learned policy of --policies (stable-baselines3, or Ray RLlib PPO on a cluster) on a "
        "scene once per training seed, evaluate the agents and the model-based controllers (the paper's LQR, MPC, "
        "trajectory tracking, energy shaping) on the same seeded starts and sweeps, and write tables, a verdict, "
        "learning curves, error plots, a filmstrip and the models.",
    ))
    _configure_evaluate(commands.add_parser(
        "evaluate", help="re-run the comparison of a run saved by compare",
        description="Load the agents saved by compare and re-run their comparison with the run's model-based "
        "controllers.",
    ))


def compare_main(argv: Optional[Sequence[str]] = None) -> int:
    """The console script ``chaincart-compare``: ``compare`` with its options."""
    parser = argparse.ArgumentParser(
        prog="chaincart-compare",
        description="Train learned agents (stable-baselines3, or Ray RLlib PPO with --trainer rllib) and compare them "
        "with model-based controllers (--policies).",
    )
    _configure_compare(parser)
    args = parser.parse_args(argv)
    return int(args.handler(args, parser))


if __name__ == "__main__":
    sys.exit(compare_main())
