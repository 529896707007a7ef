"""Command line: ``python -m chaincart_env {demo,bench} [options]``."""

from __future__ import annotations

import argparse
import sys
from typing import Optional, Sequence


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m chaincart_env", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)

    demo = commands.add_parser("demo", help="roll out one episode of a scene and print a summary")
    demo.add_argument("--scene", default=None, help="scene name (default: the default scene)")
    demo.add_argument("--policy", choices=("lqr", "zero", "random"), default="lqr")
    demo.add_argument("--seed", type=int, default=0)
    demo.add_argument("--steps", type=int, default=None, help="at most this many steps (default: one episode)")

    bench = commands.add_parser("bench", help="env-steps/s against Gymnasium's CartPole (Markdown tables)")
    bench.add_argument("--quick", action="store_true", help="short timings (a smoke run, noisy numbers)")
    bench.add_argument(
        "--sizes", default="1,16,256,4096", help="comma-separated vector sizes N (default: 1,16,256,4096)"
    )

    soak = commands.add_parser("soak", help="millions of random vector-env steps; RSS at start and end")
    soak.add_argument("--steps", type=int, default=10_000_000, help="env-steps in total (default: 10 million)")
    soak.add_argument("--num-envs", type=int, default=1024)
    soak.add_argument("--seed", type=int, default=0)
    soak.add_argument("--scene", default=None, help="scene name (default: the default scene)")

    args = parser.parse_args(argv)
    if args.command == "soak":
        from chaincart_env.soak import main as soak_main

        return soak_main(args.steps, args.num_envs, args.seed, args.scene)
    if args.command == "demo":
        from chaincart_env.demo import run_demo

        return run_demo(scene=args.scene, policy=args.policy, seed=args.seed, max_steps=args.steps)
    from chaincart_env.bench.envs import run_bench

    sizes = [int(s) for s in args.sizes.split(",") if s.strip()]
    return run_bench(quick=args.quick, sizes=sizes)


if __name__ == "__main__":
    sys.exit(main())
