"""The suite's figure: performance profiles of task scores (Agarwal et al. 2021, Sec. 4.1)."""

from __future__ import annotations

from typing import Mapping, Sequence

from offroadbench.plots.style import new_figure

__all__ = ["performance_profile_figure"]


def performance_profile_figure(profiles: Mapping[str, tuple[Sequence[float], Sequence[float]]], title: str,
                               highlight: str | None = None):
    """Fraction of terrains whose score exceeds tau, against tau, one step curve per planner.

    ``profiles``: {planner: (taus, fractions)}; ``highlight``: the planner drawn thick (the card's own)."""
    fig, ax = new_figure(figsize=(6.0, 3.8))
    for name, (taus, fractions) in profiles.items():
        thick = name == highlight
        ax.step(taus, fractions, where="post", linewidth=2.4 if thick else 1.3, label=name + (" (this run)" if thick else ""),
                zorder=3 if thick else 2)
    ax.set_xlim(0, 1)
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("tau (task score: success x nominal time / clipped time)")
    ax.set_ylabel("fraction of terrains with score > tau")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    return fig
