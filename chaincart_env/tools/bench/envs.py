"""Throughput section: env-steps per second of the chaincart envs against Gymnasium's
CartPole (and, with MuJoCo installed, InvertedDoublePendulum-v5), measured in the same
run, with ratios.

Method: every measured callable runs in a loop for at least ``min_time``; the best
rate of ``repeats`` runs is kept (the machine may be shared, and the best run is the
one least disturbed). Actions are precomputed, so sampling costs nothing. Single envs
are reset when an episode ends, inside the timed loop; vector envs autoreset.

"Raw Rust batch" is the native ``EnvBatch.step`` that both vector envs wrap, called
directly from Python: physics plus the task layer (reward, termination, autoreset) in
one call with the GIL released. Python-side overhead of the vector env = time of
``ChainCartVectorEnv.step`` minus time of that raw call on the same batch, measured
interleaved so that load changes hit both alike.
"""

from __future__ import annotations

import itertools
from typing import Any, Callable, Optional, Sequence

import gymnasium as gym
import numpy as np

import chaincart_env  # noqa: F401  (registers ChainCart-v0)
from chaincart_env.config import DEFAULT_SCENE, ChainCartConfig
from chaincart_env.tools.bench.bench_report import fmt_rate, fmt_ratio
from chaincart_env.tools.bench.context import BenchContext, mujoco_available
from chaincart_env.tools.bench.timing import rate
from chaincart_env.vector import ChainCartVectorEnv

__all__ = ["throughput_section", "links_config"]


def links_config(n_links: int) -> ChainCartConfig:
    """The throughput benchmark's task for ``n_links``: the default scene's system and
    task (rk4, 2 substeps, 20 ms), made spatial so that every n costs the full 3-D model."""
    return ChainCartConfig(n_links=n_links, planar=False)


def _single_loop(env: gym.Env, actions: Sequence[Any]) -> Callable[[], None]:
    it = itertools.cycle(actions)

    def step() -> None:
        _, _, terminated, truncated, _ = env.step(next(it))
        if terminated or truncated:
            env.reset()

    return step


def _single_rate(env: gym.Env, actions: Sequence[Any], ctx: BenchContext) -> float:
    env.reset(seed=0)
    r = rate(_single_loop(env, actions), ctx.settings.min_time, ctx.settings.repeats)
    env.close()
    return r


def _peer_single_rates(ctx: BenchContext, rng: np.random.Generator) -> dict[str, tuple[str, Optional[float]]]:
    """CartPole-v1 and (when MuJoCo imports) InvertedDoublePendulum-v5 through gym.make."""
    peers: dict[str, tuple[str, Optional[float]]] = {}
    cart_actions = [int(a) for a in rng.integers(0, 2, 1000)]
    peers["CartPole-v1"] = ("4 numbers, Euler, 20 ms", _single_rate(gym.make("CartPole-v1"), cart_actions, ctx))
    if not mujoco_available():
        peers["InvertedDoublePendulum-v5"] = ("not measured: the `mujoco` extra is not installed", None)
        return peers
    try:
        env = gym.make("InvertedDoublePendulum-v5")
    except Exception as exc:  # gymnasium's MuJoCo envs may not support the installed mujoco
        peers["InvertedDoublePendulum-v5"] = (f"not measured: gym.make failed ({type(exc).__name__}: {exc})", None)
        return peers
    mujoco_env: Any = env.unwrapped
    model = mujoco_env.model
    what = f"MuJoCo, 9 obs, {_mujoco_integrator_name(model)} x{mujoco_env.frame_skip} of {model.opt.timestep * 1e3:g} ms"
    actions = list(rng.uniform(-1, 1, (1000, 1)).astype(np.float32))
    peers["InvertedDoublePendulum-v5"] = (what, _single_rate(env, actions, ctx))
    return peers


def _mujoco_integrator_name(model: Any) -> str:
    import mujoco

    return mujoco.mjtIntegrator(model.opt.integrator).name.removeprefix("mjINT_")


def _single_env_table(ctx: BenchContext, rng: np.random.Generator) -> float:
    peers = _peer_single_rates(ctx, rng)
    base = peers["CartPole-v1"][1]
    if base is None:
        raise RuntimeError("CartPole-v1 was not measured: it is the single-env table's reference")
    rows = [[f"{name} (gym.make)", what, fmt_rate(r), f"{1e6 / r:.2f}" if r else "n/a", fmt_ratio(r, base)]
            for name, (what, r) in peers.items()]  # fmt: skip
    configs = [(f"ChainCart-v0 default ({DEFAULT_SCENE})", ChainCartConfig())]
    configs += [(f"ChainCart-v0 spatial, {n} link{'s' * (n > 1)}", links_config(n)) for n in ctx.settings.links]
    configs += [
        ("ChainCart-v0 paper 5-link, substeps 1", ChainCartConfig(scene="paper-fig2", substeps=1)),
        ("ChainCart-v0 paper-fig2 (scene as defined)", ChainCartConfig(scene="paper-fig2")),
    ]
    singles = {}
    for label, config in configs:
        actions = list(rng.uniform(-1, 1, (1000, config.force_dim)).astype(np.float32))
        r = _single_rate(gym.make("ChainCart-v0", config=config, max_episode_steps=config.max_episode_steps), actions, ctx)
        what = f"{config.state_dim} numbers, {config.integrator} x{config.substeps}, {config.dt * 1e3:g} ms"
        rows.append([label, what, fmt_rate(r), f"{1e6 / r:.2f}", fmt_ratio(r, base)])
        singles[label] = r
    ctx.results["single"] = {"CartPole-v1": base, **singles, "default": singles[configs[0][0]]}
    ctx.report.heading("Single env (`gym.make`, wrappers included)")
    ctx.report.table(["env", "state, integrator, control period", "steps/s", "us/step", "vs CartPole-v1"], rows, 2)
    idp = peers.get("InvertedDoublePendulum-v5", ("", None))
    if idp[1] is None:
        ctx.report.paragraph(f"InvertedDoublePendulum-v5: {idp[0]}.")
    return base


def _raw_model_table(ctx: BenchContext) -> None:
    rows = []
    for n in ctx.settings.links:
        config = links_config(n)
        model = config.make_model()
        state, force = model.equilibrium(config.target_signs), np.zeros(config.force_dim)
        dt, integrator, substeps = config.dt, config.integrator, config.substeps
        r = rate(lambda: model.step(state, force, dt, integrator, substeps), ctx.settings.min_time, ctx.settings.repeats)
        rows.append([f"spatial, {n} link(s), {integrator} x{substeps}", fmt_rate(r), f"{1e6 / r:.2f}"])
    ctx.report.heading("Raw model step (`ChainCart.step` from Python, one state per call)")
    ctx.report.table(["model", "steps/s", "us/step"], rows)


def _cartpole_vector_rate(ctx: BenchContext, num_envs: int, rng: np.random.Generator) -> float:
    env = gym.make_vec("CartPole-v1", num_envs=num_envs, vectorization_mode="vector_entry_point")
    env.reset(seed=0)
    actions = rng.integers(0, 2, num_envs)
    r = num_envs * rate(lambda: env.step(actions), ctx.settings.min_time, ctx.settings.repeats)
    env.close()
    return r


def _vector_rates(ctx: BenchContext, n_links: int, num_envs: int, rng: np.random.Generator) -> dict[str, float]:
    """Env-steps/s of the raw batch, the Gymnasium vector env and the SB3 VecEnv."""
    config = links_config(n_links)
    vec = ChainCartVectorEnv(num_envs, config)
    vec.reset(seed=0)
    actions = rng.uniform(-1, 1, (num_envs, config.force_dim)).astype(np.float32)
    native = vec._batch  # the Rust call the vector env wraps
    t_vec, t_native = [], []
    for _ in range(max(2, ctx.settings.repeats)):
        t_vec.append(1.0 / rate(lambda: vec.step(actions), ctx.settings.min_time, 1))
        t_native.append(1.0 / rate(lambda: native.step(actions), ctx.settings.min_time, 1))
    vec.close()
    out = {"vector_call": min(t_vec), "native_call": min(t_native)}
    out["vector"], out["native"] = num_envs / out["vector_call"], num_envs / out["native_call"]
    try:
        from chaincart_env.sb3 import ChainCartVecEnv
    except ImportError:  # the sb3 extra is not installed
        return out
    sb3 = ChainCartVecEnv(num_envs, config, seed=0)
    sb3.reset()
    out["sb3"] = num_envs * rate(lambda: sb3.step(actions), ctx.settings.min_time, ctx.settings.repeats)
    sb3.close()
    return out


def _vector_tables(ctx: BenchContext, rng: np.random.Generator) -> None:
    sizes, links = ctx.settings.sizes, ctx.settings.links
    cartpole = {n: _cartpole_vector_rate(ctx, n, rng) for n in sizes}
    measured = {(k, n): _vector_rates(ctx, k, n, rng) for k in links for n in sizes}
    ctx.results["vector"] = {"cartpole": cartpole, "chaincart": measured}
    ctx.report.heading("Vector envs: env-steps/s (N envs x calls/s), ratio to CartPoleVectorEnv at the same N")
    config = links_config(links[0])
    ctx.report.paragraph(
        f"Spatial chain of n links, default task otherwise ({config.integrator} x{config.substeps}, "
        f"{config.dt * 1e3:g} ms). raw = native `EnvBatch.step` (physics + task in one Rust call); vector = "
        "`ChainCartVectorEnv` (Gymnasium); SB3 = `ChainCartVecEnv`. Overhead = vector minus raw call time; "
        "a negative overhead means the difference is below the timing noise."
    )
    rows = []
    for n in sizes:
        rows.append(["CartPoleVectorEnv", str(n), fmt_rate(cartpole[n]), "", "", "", "", "", ""])
        for k in links:
            m = measured[(k, n)]
            rows.append([
                f"ChainCart n={k}", str(n),
                fmt_rate(m["native"]), fmt_ratio(m["native"], cartpole[n]),
                fmt_rate(m["vector"]), fmt_ratio(m["vector"], cartpole[n]),
                fmt_rate(m.get("sb3")), fmt_ratio(m.get("sb3"), cartpole[n]),
                f"{1e6 * (m['vector_call'] - m['native_call']):.1f} us ({(m['vector_call'] - m['native_call']) / m['vector_call']:.0%})",
            ])  # fmt: skip
    header = ["env", "N", "raw", "vs CP", "vector", "vs CP", "SB3", "vs CP", "vector-env Python overhead per call"]
    ctx.report.table(header, rows, 1)
    _overhead_table(ctx, measured)
    _throughput_plot(ctx, cartpole, measured)


def _overhead_table(ctx: BenchContext, measured: dict[tuple[int, int], dict[str, float]]) -> None:
    ctx.report.heading("Python-side overhead of ChainCartVectorEnv.step")
    ctx.report.paragraph("Vector step time minus the raw native `EnvBatch.step` on the same batch (interleaved timings).")
    rows = []
    for (k, n), m in measured.items():
        tv, tn = m["vector_call"], m["native_call"]
        rows.append([str(k), str(n), f"{tv * 1e6:.2f}", f"{tn * 1e6:.2f}", f"{(tv - tn) * 1e6:.2f}", f"{(tv - tn) / tv:.1%}"])
    ctx.report.table(["links", "N", "vector step (us)", "native step (us)", "overhead (us)", "overhead / step"], rows, 0)


def _throughput_plot(ctx: BenchContext, cartpole: dict[int, float], measured: dict[tuple[int, int], dict[str, float]]) -> None:
    path = ctx.plot_path("throughput.png")
    if path is None:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = sorted(cartpole)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(sizes, [cartpole[n] for n in sizes], "k--o", label="CartPoleVectorEnv")
    for k in ctx.settings.links:
        ax.plot(sizes, [measured[(k, n)]["vector"] for n in sizes], "-o", label=f"ChainCartVectorEnv, {k} link(s)")
    ax.set(xscale="log", yscale="log", xlabel="number of envs N", ylabel="env-steps / s",
           title="Vector env throughput (higher is better)")  # fmt: skip
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


#: The sim-to-real variants of the reality-gap table: keywords on top of links_config.
REALITY_VARIANTS: dict[str, dict[str, Any]] = {
    "off": {},
    "randomized": {"randomize": {"cart_mass": 0.25, "link_masses": 0.25, "link_lengths": 0.25}},
    "noise + delay": {"obs_noise": 0.01, "action_delay": 1},
    "encoders": {"angle_encoder_counts": 4096, "cart_encoder_counts": 2000.0, "velocity_filter": 0.01},
    "rig": {"joint_damping": 0.01, "cart_viscous_friction": 0.5, "cart_coulomb_friction": 0.5},
    "rig draws": {"randomize": {"joint_damping": {"range": [0.0, 0.02]}, "cart_coulomb_friction": {"range": [0.0, 1.0]}}},
}


def _reality_rates(
    ctx: BenchContext, config: ChainCartConfig, num_envs: int, rng: np.random.Generator, precision: str = "f64"
) -> tuple[float, float]:
    """Env-steps/s of the raw batch and the vector env for one config (interleaved),
    physics in ``precision``."""
    vec = ChainCartVectorEnv(num_envs, config)
    vec._batch.set_precision(precision)
    vec.reset(seed=0)
    actions = rng.uniform(-1, 1, (num_envs, config.force_dim)).astype(np.float32)
    native = vec._batch  # the Rust call the vector env wraps
    r_vec, r_native = 0.0, 0.0
    for _ in range(max(2, ctx.settings.repeats)):
        r_vec = max(r_vec, rate(lambda: vec.step(actions), ctx.settings.min_time, 1))
        r_native = max(r_native, rate(lambda: native.step(actions), ctx.settings.min_time, 1))
    vec.close()
    return num_envs * r_native, num_envs * r_vec


def _reality_table(ctx: BenchContext, rng: np.random.Generator) -> None:
    """Cost of the reality gap: raw batch and vector env with it off, with cart mass,
    link masses and lengths redrawn at every reset, and with sensor noise plus a
    one-step delay."""
    rows, results = [], {}
    for k in ctx.settings.links:
        for n in ctx.settings.sizes:
            rates = {v: _reality_rates(ctx, links_config(k).replace(**kw), n, rng) for v, kw in REALITY_VARIANTS.items()}
            results[(k, n)] = rates
            off_raw = rates["off"][0]
            rows.append([
                str(k), str(n),
                *(f"{fmt_rate(raw)} ({raw / off_raw:.0%}) / {fmt_rate(vec)}" for raw, vec in rates.values()),
            ])  # fmt: skip
    ctx.results["reality"] = {f"{k}x{n}": r for (k, n), r in results.items()}
    ctx.report.heading("Cost of the sim-to-real options: env-steps/s, raw batch (share of off) / vector env")
    ctx.report.paragraph(
        "Spatial chain of n links, default task. randomized = cart mass, link masses and lengths within "
        "+-25 % redrawn at every reset (per-env parameters); noise + delay = Gaussian observation noise 0.01 "
        "and a one-period control delay; encoders = 4096 counts per revolution, 2000 per metre, velocities "
        "from the counts through a 10 ms filter; rig = joint damping 0.01 N m s/rad and cart friction 0.5 N "
        "s/m plus 0.5 N Coulomb (every env steps alone, in f64); rig draws = joint damping in [0, 0.02] and "
        "Coulomb friction in [0, 1] N drawn at every reset."
    )
    ctx.report.table(["links", "N", *REALITY_VARIANTS], rows, 0)


def _planar_link_table(ctx: BenchContext, rng: np.random.Generator) -> None:
    """One planar link against CartPoleVectorEnv at the largest N, side by side in one run."""
    num_envs = max(ctx.settings.sizes)
    cartpole = _cartpole_vector_rate(ctx, num_envs, rng)
    rows = [["CartPoleVectorEnv (NumPy)", "", fmt_rate(cartpole), ""]]
    results: dict[str, Any] = {"cartpole": cartpole}
    for precision in ("f64", "f32"):
        raw, vec = _reality_rates(ctx, ChainCartConfig(n_links=1), num_envs, rng, precision)
        results[precision] = {"raw": raw, "vector": vec}
        rows.append([f"ChainCartVectorEnv, 1 planar link, {precision}", fmt_rate(raw), fmt_rate(vec), fmt_ratio(vec, cartpole)])
    ctx.results["planar_link"] = {"num_envs": num_envs, **results}
    ctx.report.heading(f"One planar link vs CartPoleVectorEnv, N = {num_envs}: env-steps/s")
    config = ChainCartConfig(n_links=1)
    ctx.report.paragraph(
        f"The default scene's system with one link (planar, {config.integrator} x{config.substeps}, "
        f"{config.dt * 1e3:g} ms; CartPole's is one Euler step of 20 ms), measured in the same run. "
        "raw = native `EnvBatch.step`; vector = `ChainCartVectorEnv.step`; f32 = `EnvBatch.set_precision(\"f32\")`."
    )
    ctx.report.table(["env", "raw", "vector", "vector vs CartPoleVectorEnv"], rows, 0)


def throughput_section(ctx: BenchContext) -> None:
    """The throughput section: single and vector envs against CartPole (and MuJoCo's pendulums when
    installed), the raw model, and env-steps/s by batch size."""
    rng = np.random.default_rng(0)
    _single_env_table(ctx, rng)
    _raw_model_table(ctx)
    _vector_tables(ctx, rng)
    _planar_link_table(ctx, rng)
    _reality_table(ctx, rng)
