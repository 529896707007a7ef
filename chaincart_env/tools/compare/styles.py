"""One look per controller in every picture, the main job's and the leaderboard's: its
colour, line style, marker and the hatch of its interval band (one table,
:data:`LOOKS`), so that a controller reads the same in each plot, and policies whose
curves coincide stay apart (and are named as hidden)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional, Sequence

import numpy as np

from chaincart_env.tools.controllers import controller_of_label

__all__ = ["LOOKS", "PolicyStyle", "band", "coinciding_with", "legend_label", "policy_style"]


@dataclass(frozen=True)
class PolicyStyle:
    """How one policy is drawn."""

    color: str
    linestyle: Any  # a name or a (offset, dashes) tuple
    marker: str
    hatch: str

    def line(self) -> dict[str, Any]:
        """Keywords of ``Axes.plot`` for this policy's line."""
        return dict(color=self.color, ls=self.linestyle, marker=self.marker)


#: The look of every controller (by its ``--policies`` name) and of its variants: the
#: best model of a training run (``best``), the LQR designed on the true parameters
#: (``oracle``). Every entry differs from every other in colour, line style, marker
#: and hatch.
LOOKS: dict[tuple[str, str], PolicyStyle] = {
    ("ppo", ""): PolicyStyle("tab:blue", "-", "o", "////"),
    ("ppo", "best"): PolicyStyle("tab:orange", "-.", "^", "xxxx"),
    ("sac", ""): PolicyStyle("tab:green", (0, (5, 1)), "v", "||||"),
    ("sac", "best"): PolicyStyle("tab:olive", (0, (5, 1, 1, 1)), "<", "oo"),
    ("td3", ""): PolicyStyle("tab:red", (0, (3, 1, 1, 1, 1, 1)), "P", "----"),
    ("td3", "best"): PolicyStyle("tab:pink", (0, (4, 1, 1, 1, 1, 1, 1, 1)), ">", "OO"),
    ("ppo-robust", ""): PolicyStyle("navy", (0, (6, 2)), "d", "\\\\||"),
    ("ppo-robust", "best"): PolicyStyle("darkgoldenrod", (0, (2, 2)), "p", "x."),
    ("ppo-residual", ""): PolicyStyle("darkgreen", (0, (3, 3)), "8", "//.."),
    ("ppo-residual", "best"): PolicyStyle("crimson", (0, (1, 1)), "H", "|.."),
    ("lqr", ""): PolicyStyle("black", "--", "s", "\\\\\\\\"),
    ("lqr", "oracle"): PolicyStyle("tab:purple", ":", "D", "...."),
    ("mpc", ""): PolicyStyle("tab:brown", (0, (5, 2, 1, 2)), "X", "++++"),
    ("trajectory", ""): PolicyStyle("tab:cyan", (0, (8, 3)), "h", "**"),
    ("trajectory-soft", ""): PolicyStyle("teal", (0, (8, 2, 2, 2)), "1", "*|"),
    ("energy", ""): PolicyStyle("tab:gray", (0, (1, 3)), "*", "-\\\\"),
}
#: Anything that is no controller of the table (a policy a user passes in).
_OTHER = PolicyStyle("0.35", (0, (2, 1, 2, 3)), ".", "")


def policy_style(name: str) -> PolicyStyle:
    """The look of the policy a table or legend names: a controller's name or label
    (``"ppo"``, ``"PPO"``, ``"PPO (seed 3)"``, ``"PPO (RLlib)"``) or a variant's
    (``"PPO best"``, ``"LQR oracle"``); a training run's seeds share its look."""
    controller, variant = controller_of_label(name)
    if controller is None:
        return _OTHER
    return LOOKS.get((controller, variant), LOOKS.get((controller, ""), _OTHER))


def coinciding_with(x: np.ndarray, y: np.ndarray, drawn: Sequence[tuple[str, np.ndarray, np.ndarray]]) -> Optional[str]:
    """The name of an already drawn series ``(name, x, y)`` that this one lies on."""
    for name, other_x, other_y in drawn:
        if other_x.shape == x.shape and np.array_equal(other_x, x) and np.array_equal(other_y, y, equal_nan=True):
            return name
    return None


def legend_label(name: str, hidden_behind: Optional[str]) -> str:
    """``name``, marked when its curve lies exactly on another one's."""
    return name if hidden_behind is None else f"{name} (same as {hidden_behind}: lines coincide)"


def band(
    ax: Any, x: np.ndarray, low: np.ndarray | Sequence[float], high: np.ndarray | Sequence[float], style: PolicyStyle
) -> None:
    """A 95% interval band in the policy's colour and hatch (bands of different
    policies overlap without mixing into one colour)."""
    ax.fill_between(x, low, high, facecolor=style.color, alpha=0.08, linewidth=0)
    ax.fill_between(x, low, high, facecolor="none", edgecolor=style.color, hatch=style.hatch, alpha=0.35, linewidth=0)
