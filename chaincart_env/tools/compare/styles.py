"""One look per policy in every picture of the main job: its colour, line style,
marker and the hatch of its interval band, so that a policy reads the same in each
plot and policies whose curves coincide stay apart (and are named as hidden)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Optional, Sequence

import numpy as np

__all__ = ["PolicyStyle", "band", "coinciding_with", "legend_label", "policy_style"]


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


_BASELINE = PolicyStyle("black", "--", "s", "\\\\\\\\")
_ORACLE = PolicyStyle("tab:purple", ":", "D", "....")
_AGENT = PolicyStyle("tab:blue", "-", "o", "////")
_AGENT_BEST = PolicyStyle("tab:orange", "-.", "^", "xxxx")
#: Policies of other names (e.g. a second algorithm), in order of appearance.
_OTHERS = (
    PolicyStyle("tab:green", (0, (5, 1)), "v", "||||"),
    PolicyStyle("tab:red", (0, (3, 1, 1, 1, 1, 1)), "P", "----"),
    PolicyStyle("tab:brown", (0, (1, 2)), "X", "++++"),
)
_SEED = re.compile(r" \(seed \d+\)$")


def policy_style(name: str, others: Sequence[str] = ()) -> PolicyStyle:
    """The style of policy ``name`` (``"PPO"``, ``"PPO (seed 3)"``, ``"PPO best"``,
    ``"LQR"``, ``"LQR oracle"``, ...); a trained policy's seeds share its style.
    ``others``: the names of the other trained policies in the picture, in order, for
    a policy that is neither the first trained one nor a baseline."""
    label = _SEED.sub("", name)
    if label == "LQR":
        return _BASELINE
    if label == "LQR oracle":
        return _ORACLE
    trained = [n for n in dict.fromkeys(_SEED.sub("", o) for o in others) if n not in ("LQR", "LQR oracle")]
    first = next((n for n in trained if not n.endswith(" best")), label.removesuffix(" best"))
    if label == first:
        return _AGENT
    if label == f"{first} best":
        return _AGENT_BEST
    position = trained.index(label) if label in trained else 0
    return _OTHERS[position % len(_OTHERS)]


def coinciding_with(x: np.ndarray, y: np.ndarray, drawn: Sequence[tuple[str, np.ndarray, np.ndarray]]) -> Optional[str]:
    """The name of an already drawn series ``(name, x, y)`` that this one lies on."""
    for name, other_x, other_y in drawn:
        if other_x.shape == x.shape and np.array_equal(other_x, x) and np.array_equal(other_y, y, equal_nan=True):
            return name
    return None


def legend_label(name: str, hidden_behind: Optional[str]) -> str:
    """``name``, marked when its curve lies exactly on another one's."""
    return name if hidden_behind is None else f"{name} (same as {hidden_behind}: lines coincide)"


def band(ax: Any, x: np.ndarray, low: Sequence[float], high: Sequence[float], style: PolicyStyle) -> None:
    """A 95% interval band in the policy's colour and hatch (bands of different
    policies overlap without mixing into one colour)."""
    ax.fill_between(x, low, high, facecolor=style.color, alpha=0.08, linewidth=0)
    ax.fill_between(x, low, high, facecolor="none", edgecolor=style.color, hatch=style.hatch, alpha=0.35, linewidth=0)
