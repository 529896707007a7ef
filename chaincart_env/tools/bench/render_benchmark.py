"""Render cost: frames per second of ``env.render()`` (one env) and of a vector env's
tiled ``render_tiled()``, by frame size, to set beside each scene's ``render_fps``.

Called by the benchmark command; ``render_benchmark()`` returns the rows,
``markdown_table(rows)`` formats them.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any, Callable

import numpy as np

from chaincart_env.env import ChainCartEnv
from chaincart_env.vector import ChainCartVectorEnv

__all__ = ["render_benchmark", "markdown_table"]

#: ``(width, height)`` pairs measured by default: the default frame and twice it.
DEFAULT_SIZES = ((480, 240), (960, 480))
#: Scenes measured by default: planar (side view only) and the paper's spatial 5 links.
DEFAULT_SCENES = ("inverted-2", "paper-fig3")


def _calls_per_second(call: Callable[[], Any], seconds: float) -> float:
    """Repeats ``call`` for about ``seconds`` (at least 3 times, after one warm-up)."""
    call()
    count, start = 0, time.perf_counter()
    while True:
        call()
        count += 1
        elapsed = time.perf_counter() - start
        if count >= 3 and elapsed >= seconds:
            return count / elapsed


def _moving(env: Any, steps: int = 10) -> None:
    """Resets and pushes ``env`` a little, so that frames show a tilted chain and an arrow."""
    env.reset(seed=0)
    action = np.full(env.action_space.shape, 0.5, dtype=np.float32)
    for _ in range(steps):
        env.step(action)


def render_benchmark(
    sizes: Sequence[tuple[int, int]] = DEFAULT_SIZES,
    scenes: Sequence[str] = DEFAULT_SCENES,
    tiles: int = 4,
    seconds: float = 0.5,
) -> list[dict[str, Any]]:
    """One row per scene, frame size and kind (``"env"``: ``ChainCartEnv.render()``;
    ``"vector, k tiles"``: ``ChainCartVectorEnv(k).render_tiled()``, k frames of that size
    tiled), each timed for about ``seconds``: ``images_per_s`` (returned images),
    ``frames_per_s`` (env frames drawn, k per tiled image), ``ms_per_image``, the
    scene's ``render_fps`` and ``keeps_up`` (images_per_s >= render_fps). Timings on a
    busy machine are noisy."""
    rows: list[dict[str, Any]] = []
    for scene in scenes:
        for width, height in sizes:
            kinds: list[tuple[str, Any, int]] = [
                ("env", ChainCartEnv(scene=scene, render_mode="rgb_array", render_width=width, render_height=height), 1),
                (
                    f"vector, {tiles} tiles",
                    ChainCartVectorEnv(
                        tiles, scene=scene, render_mode="rgb_array", render_width=width, render_height=height
                    ),
                    tiles,
                ),
            ]
            for kind, env, frames_per_image in kinds:
                _moving(env)
                draw = env.render if frames_per_image == 1 else env.render_tiled
                rate = _calls_per_second(draw, seconds)
                image = draw()
                fps = int(env.metadata["render_fps"])
                rows.append(
                    {
                        "scene": scene,
                        "kind": kind,
                        "frame": f"{width}x{height}",
                        "image": f"{image.shape[1]}x{image.shape[0]}",
                        "images_per_s": rate,
                        "frames_per_s": rate * frames_per_image,
                        "ms_per_image": 1e3 / rate,
                        "render_fps": fps,
                        "keeps_up": rate >= fps,
                    }
                )
                env.close()
    return rows


def markdown_table(rows: Sequence[dict[str, Any]]) -> str:
    """The rows of :func:`render_benchmark` as a Markdown table."""
    lines = [
        "| scene | kind | frame (w x h) | image | images/s | env frames/s | ms/image | render_fps | keeps up |",
        "|---|---|---|---|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['scene']} | {r['kind']} | {r['frame']} | {r['image']} | {r['images_per_s']:.0f} | "
            f"{r['frames_per_s']:.0f} | {r['ms_per_image']:.2f} | {r['render_fps']} | {'yes' if r['keeps_up'] else 'NO'} |"
        )
    return "\n".join(lines)
