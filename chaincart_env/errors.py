"""The exceptions of chaincart, one base class and one class per kind of failure.

======================  ==============================  ==========================================
class                   also a                          raised for
======================  ==============================  ==========================================
``ChainCartError``      ``Exception``                   (base class of all below)
``InvalidInputError``   ``ValueError``                  an argument with a wrong value
``InvalidTypeError``    ``InvalidInputError``,          an argument of a wrong type (a string
                        ``TypeError``                   where a number is needed, a non-bool mask)
``UnknownKeyError``     ``InvalidInputError``,          a configuration keyword that does not exist
                        ``TypeError``                   (the message names the closest one and
                                                        lists them all, once)
``IntegrationError``    ``RuntimeError``                ``ChainCart.simulate``/``step`` failing
                                                        numerically (``time``, ``reason``)
``AnalysisError``       ``numpy.linalg.LinAlgError``    linearisation, LQR and Lyapunov solves
                        (a ``ValueError``)              that have no (stable) solution
``PlanningError``       ``RuntimeError``                a policy whose plan does not reach its
                                                        target (the message names the duration
                                                        and force limit to change)
======================  ==============================  ==========================================

The native module raises them too (it imports this module), with the core's message.
This module imports nothing of chaincart, so the native module can load it first.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ChainCartError",
    "InvalidInputError",
    "InvalidTypeError",
    "UnknownKeyError",
    "IntegrationError",
    "AnalysisError",
    "PlanningError",
]


class ChainCartError(Exception):
    """Base class of every error chaincart raises on purpose."""


class InvalidInputError(ChainCartError, ValueError):
    """An argument is not admissible; the message names the value and what was expected."""


class InvalidTypeError(InvalidInputError, TypeError):
    """An argument has the wrong type (both a ``TypeError`` and an
    :class:`InvalidInputError`, so code catching ``ValueError`` still catches it)."""


class UnknownKeyError(InvalidInputError, TypeError):
    """A configuration keyword that does not exist (``n_link=3``): the message names the
    closest keyword (``did you mean "n_links"?``) and lists every keyword.

    A ``TypeError`` as Python's own unexpected keyword argument is, and as
    ``gymnasium.make`` expects of an env constructor; an :class:`InvalidInputError` (a
    ``ValueError``) like every other bad configuration value.

    Its message is complete, so it hides the exception it was raised while handling:
    ``gymnasium.make`` re-raises an env constructor's ``TypeError`` as a new exception of
    the same type whose message is the old one plus the env id and keywords, and the
    traceback then shows the keyword list once, not once per exception.
    """

    def __init__(self, *args: object) -> None:
        super().__init__(*args)
        self.__suppress_context__ = True


class IntegrationError(ChainCartError, RuntimeError):
    """The integration of the model failed: ``time`` is the time (s, from the start of
    the call) at which the failing step began, ``reason`` what went wrong."""

    def __init__(self, message: str, time: float = float("nan"), reason: str = "") -> None:
        super().__init__(message)
        self.time = float(time)
        self.reason = reason or message

    def __reduce__(self) -> tuple[type, tuple[str, float, str]]:
        return (type(self), (str(self), self.time, self.reason))


class AnalysisError(ChainCartError, np.linalg.LinAlgError):
    """A linear-algebra analysis (linearisation, LQR gain, Lyapunov solve, ...) has no
    solution of the kind asked for, e.g. an uncontrollable equilibrium."""


class PlanningError(ChainCartError, RuntimeError):
    """The planner found no plan that reaches the target within the force limit, the
    track and the duration; the message says why and names the values to change."""


class MissingExtraError(ChainCartError, ImportError):
    """An optional dependency is not installed; the message names the extra to install
    (``pip install 'chaincart-env[plot]'``, ...)."""
