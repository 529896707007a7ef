"""The physics model from Python: :class:`ChainCart`, the native model plus a
``simulate`` that also accepts a feedback policy."""

from __future__ import annotations

from typing import Callable, Optional, Union

import numpy as np
import numpy.typing as npt

from chaincart_env import _core
from chaincart_env.errors import InvalidInputError, InvalidTypeError

__all__ = ["ChainCart", "Policy"]

#: ``policy(t, state) -> force``: a feedback law for :meth:`ChainCart.simulate`.
Policy = Callable[[float, np.ndarray], npt.ArrayLike]


class ChainCart(_core.ChainCart):
    """The chain pendulum on a cart: ``n_links`` links (point masses ``link_masses`` at
    the ends of massless rods of ``link_lengths``; scalars or one value per link) on a
    cart of ``cart_mass``, gravity ``gravity`` along e3; ``planar=True`` for the planar
    special case (cart on e1, links in the e1-e3 plane).

    States follow docs/physics.md: ``[x, xdot, q_1..q_n, w_1..w_n]``, length ``4 + 6n``
    (planar: ``[x, xdot, (q_i . e1, q_i . e3)_i, w_i . e2]``, length ``2 + 3n``).
    Everything is float64 NumPy in and out; bad input raises :class:`ChainCartError`.
    """

    def simulate(  # type: ignore[override]
        self,
        state: npt.ArrayLike,
        forces: Union[npt.ArrayLike, Policy],
        dt: float,
        integrator: str = "rk4",
        substeps: int = 1,
        *,
        steps: Optional[int] = None,
    ) -> np.ndarray:
        """Trajectory of shape ``(steps + 1, state_dim)`` from ``state``.

        ``forces`` is an array of shape ``(steps, force_dim)`` (force k held over
        ``[k dt, (k+1) dt)``), or a callable ``policy(t, state) -> force`` evaluated at
        the start of each control period, together with ``steps=``. An integration
        failure raises :class:`ChainCartError` naming the step.
        """
        if callable(forces):
            if steps is None:
                raise InvalidInputError("simulate with a policy needs steps=: expected an integer >= 0")
            if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)):
                raise InvalidTypeError(f"steps = {steps!r}: expected an integer >= 0")
            if steps < 0:
                raise InvalidInputError(f"steps = {steps!r}: expected an integer >= 0")
            y = np.array(state, dtype=np.float64)
            if y.shape != (self.state_dim,):
                raise InvalidInputError(f"state has shape {y.shape}, expected ({self.state_dim},)")
            traj = np.empty((int(steps) + 1, self.state_dim))
            traj[0] = y
            for k in range(int(steps)):
                u = np.asarray(forces(k * dt, traj[k].copy()), dtype=np.float64).reshape(-1)
                traj[k + 1] = self.step(traj[k], u, dt, integrator, substeps)
            return traj
        if steps is not None:
            f = np.asarray(forces)
            if f.ndim < 1 or f.shape[0] != steps:
                raise InvalidInputError(f"forces has {f.shape[0] if f.ndim else 0} rows but steps = {steps}")
        return super().simulate(state, forces, dt, integrator, substeps)
