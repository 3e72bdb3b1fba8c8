"""GIF frames share a palette that holds the figure's line, marker and text colours exactly
(issue 33: a failed trial's orange roll curve had its legend drawn in the failure red)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from PIL import Image

from offroadbench.io.animation import _key_colours, save_animation

ORANGE, RED = (255, 127, 14), (214, 32, 32)


def _hex(rgb):
    return "#%02x%02x%02x" % rgb


def test_small_marks_keep_their_exact_colours(tmp_path):
    fig = Figure(figsize=(4, 3), dpi=80)
    ax = fig.add_subplot()
    # a large smooth gradient to crowd the median cut, and two small marks of near colours
    ax.imshow(np.linspace(0, 1, 400).reshape(20, 20), cmap="autumn", extent=(0, 1, 0, 1))
    (curve,) = ax.plot([0.1, 0.2], [0.5, 0.5], color=_hex(ORANGE), lw=1, label="roll")
    (mark,) = ax.plot([], [], "X", color=_hex(RED), mec="black", ms=4)
    ax.legend(loc="upper right", fontsize=6)
    assert ORANGE in _key_colours(fig) and RED in _key_colours(fig)

    def draw(k):
        mark.set_data(([0.9], [0.1]) if k == 2 else ([], []))

    out = save_animation(fig, draw, [0, 1, 2], tmp_path / "a.gif", fps=5)
    with Image.open(out) as gif:
        palette = np.array(gif.getpalette()[:768]).reshape(-1, 3)
        used = set()
        for i in range(gif.n_frames):
            gif.seek(i)
            rgb = np.asarray(gif.convert("RGB")).reshape(-1, 3)
            used |= {tuple(int(v) for v in c) for c in np.unique(rgb, axis=0)}
    assert {ORANGE, RED} <= {tuple(int(v) for v in c) for c in palette}
    assert ORANGE in used and RED in used  # drawn in their own colours, not a neighbour's
