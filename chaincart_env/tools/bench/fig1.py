"""Accuracy and cost on the paper's Fig. 1 start (5 links, perturbed folded equilibrium,
u = 0), shared by the MuJoCo and speed-vs-accuracy sections.

* Error at t = 1 s: the largest distance of a link mass from where the reference puts
  it. Reference: chaincart's rk4 at dt = 2e-6 s (500 000 steps); its own error is
  estimated by comparing with rk4 at 4e-6 s, and it is cross-checked against the
  adaptive 5(4) method at a 1e-4 s control period (both reported).
* Energy drift over 10 s: ``max_t |E(t) - E(0)| / max_t T(t)`` (T the kinetic
  energy), E sampled every millisecond (every step for longer steps) with chaincart's
  energy function for every engine (MuJoCo states are mapped to ours first).
* Wall time per simulated second: the best of ``repeats`` timed 1-s runs made in ONE
  native call (``ChainCart.simulate`` with a forces array; ``mujoco.rollout`` with
  nbatch = 1, one thread), so Python overhead is one call per simulated second.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Optional

import numpy as np

from chaincart_env import _core
from chaincart_env.errors import ChainCartError
from chaincart_env.model import ChainCart
from chaincart_env.tools.bench.timing import rate

__all__ = [
    "FIG1",
    "AccuracyPoint",
    "paper_model",
    "mass_positions",
    "Reference",
    "reference",
    "chaincart_point",
    "energy_drift",
    "STEP_SIZES",
    "QUICK_STEP_SIZES",
]

FIG1 = "paper-fig1"
STEP_SIZES = (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4)
QUICK_STEP_SIZES = (1e-2, 1e-3)
DRIFT_HORIZON = 10.0
ENERGY_SAMPLE_PERIOD = 1e-3
#: Longest trajectory held in memory at once (steps).
CHUNK = 100_000


@dataclass(frozen=True)
class AccuracyPoint:
    """One engine, integrator and step size of the speed-vs-accuracy comparison: error at 1 s (m),
    energy drift over 10 s, wall time per simulated second (``None`` where the run failed, with
    why)."""

    engine: str  # "chaincart" or "mujoco"
    integrator: str
    dt: float
    error_1s: Optional[float]  # m; None if the run failed
    drift_10s: Optional[float]
    wall_per_sim_s: Optional[float]  # s of wall time per simulated s
    failure: str = ""

    @property
    def label(self) -> str:
        """``"<engine> <integrator>"``, the point's series in tables and plots."""
        return f"{self.engine} {self.integrator}"


def paper_model() -> ChainCart:
    """The paper's system (the ChainCart defaults): 0.5 kg cart, 5 x (0.1 kg, 0.1 m)."""
    return ChainCart(5)


def fig1_state() -> np.ndarray:
    """The paper's Fig. 1 initial condition (spatial, 5 links)."""
    return _core.paper_initial_condition(FIG1)


def mass_positions(states: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Positions of the link masses, shape ``(..., n, 3)``, of spatial states ``(..., 4 + 6n)``."""
    n = len(lengths)
    q = states[..., 4 : 4 + 3 * n].reshape(states.shape[:-1] + (n, 3))
    cart = np.zeros(states.shape[:-1] + (1, 3))
    cart[..., 0, :2] = states[..., :2]
    return cart + np.cumsum(q * np.asarray(lengths)[:, None], axis=-2)


def position_error(state: np.ndarray, ref_positions: np.ndarray, lengths: np.ndarray) -> float:
    """The largest distance (m) of a link mass of ``state`` from its reference position."""
    return float(np.max(np.linalg.norm(mass_positions(state, lengths) - ref_positions, axis=-1)))


def run_chaincart(model: ChainCart, integrator: str, dt: float, t_end: float, every: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Final state after ``t_end`` and the states every ``every`` steps (with the start),
    in chunks of at most :data:`CHUNK` steps. Raises ChainCartError naming the step."""
    steps_left, y = int(round(t_end / dt)), fig1_state()
    samples, done = [y], 0
    while steps_left:
        k = min(CHUNK, steps_left)
        try:
            traj = model.simulate(y, np.zeros((k, 2)), dt, integrator)
        except ChainCartError as exc:
            match = re.search(r"at step (\d+)", str(exc))
            failed_at = (done + int(match.group(1))) * dt if match else float("nan")
            raise ChainCartError(f"failed at t = {failed_at:.3g} s") from exc
        if every:
            # Rows are the states after done + i steps; keep those at multiples of `every`.
            first = (-done) % every or every
            samples.append(traj[first::every])
        y, done, steps_left = traj[-1], done + k, steps_left - k
    return y, (np.vstack(samples) if every else np.empty((0, len(y))))


def energy_drift(model: ChainCart, states: np.ndarray) -> float:
    """``max |E - E(0)| / max T`` over the sampled states (the first is the start)."""
    energies = np.array([model.energy(s) for s in states])
    kinetic = max(model.kinetic_energy(s) for s in states)
    return float(np.max(np.abs(energies - energies[0])) / kinetic)


def sample_every(dt: float) -> int:
    """Steps of size ``dt`` between energy samples (one per :data:`ENERGY_SAMPLE_PERIOD`)."""
    return max(1, int(round(ENERGY_SAMPLE_PERIOD / dt)))


@dataclass(frozen=True)
class Reference:
    """The reference at 1 s from the Fig. 1 start: the link masses' positions (rk4 at 2 us) and two
    estimates of their own error."""

    positions: np.ndarray  # (5, 3) link masses at t = 1 s
    self_error: float  # vs rk4 at twice the step
    adaptive_difference: float  # vs the adaptive method at a 1e-4 s control period


def reference(model: ChainCart) -> Reference:
    """The :class:`Reference` of ``model``: rk4 at 2 us, its error estimated against rk4 at 4 us and
    against the adaptive method."""
    lengths = np.array(model.link_lengths)
    fine, _ = run_chaincart(model, "rk4", 2e-6, 1.0)
    coarse, _ = run_chaincart(model, "rk4", 4e-6, 1.0)
    adaptive, _ = run_chaincart(model, "adaptive", 1e-4, 1.0)
    positions = mass_positions(fine, lengths)
    return Reference(
        positions,
        # RK4: halving the step cuts the error 16-fold, so the fine run's error is ~1/15 of the difference.
        position_error(coarse, positions, lengths) / 15.0,
        position_error(adaptive, positions, lengths),
    )


def chaincart_point(model: ChainCart, ref: Reference, integrator: str, dt: float, min_time: float, repeats: int) -> AccuracyPoint:
    """chaincart's :class:`AccuracyPoint` for ``integrator`` at step ``dt`` (timing: best of
    ``repeats`` runs of at least ``min_time`` s)."""
    lengths = np.array(model.link_lengths)
    try:
        final, _ = run_chaincart(model, integrator, dt, 1.0)
        error = position_error(final, ref.positions, lengths)
        steps, y0 = int(round(1.0 / dt)), fig1_state()
        forces = np.zeros((steps, 2))
        wall = 1.0 / rate(lambda: model.simulate(y0, forces, dt, integrator), min_time, repeats)
    except ChainCartError as exc:
        return AccuracyPoint("chaincart", integrator, dt, None, None, None, str(exc))
    try:
        _, samples = run_chaincart(model, integrator, dt, DRIFT_HORIZON, sample_every(dt))
        drift: Optional[float] = energy_drift(model, samples)
        failure = ""
    except ChainCartError as exc:
        drift, failure = None, f"10-s run {exc}"
    return AccuracyPoint("chaincart", integrator, dt, error, drift, wall, failure)


def is_finite(x: Optional[float]) -> bool:
    """Whether ``x`` is a finite number (``None`` is not)."""
    return x is not None and math.isfinite(x)
