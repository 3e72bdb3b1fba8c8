"""Writing an animation: frames of one matplotlib Figure through matplotlib's animation writer
interface, ``.gif`` with Pillow (a dependency already) and ``.mp4`` with matplotlib's ffmpeg
writer (when an ``ffmpeg`` is on PATH, or the optional ``imageio-ffmpeg`` package is installed).
The file appears whole or not at all: frames go to a temporary file beside it, renamed at the end.

GIF frames share one palette (taken from the last frame, which shows every line and mark), so that Pillow stores each frame as
its difference from the one before: a replay's map and strip stay still while the vehicle moves,
and the file is several times smaller than with a palette per frame (matplotlib's PillowWriter).
The palette holds every colour the figure's lines, markers and texts are drawn in exactly (the rest
is a median cut of the frame), so a small legend mark or a goal hidden under the vehicle in the last
frame keeps its colour instead of taking a neighbour's (an orange curve's legend drawn in the
failure red)."""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Callable, Iterable
from pathlib import Path

from offroadbench.errors import InputError

__all__ = ["ANIMATION_SUFFIXES", "check_animation_path", "save_animation"]

ANIMATION_SUFFIXES = (".gif", ".mp4")


def _ffmpeg() -> str | None:
    """The ffmpeg executable: on PATH, else the one the imageio-ffmpeg package ships, else None."""
    found = shutil.which("ffmpeg")
    if found:
        return found
    try:
        import imageio_ffmpeg
    except ImportError:
        return None
    return imageio_ffmpeg.get_ffmpeg_exe()


def _gif_writer_class():
    """The GIF writer class (built on first use: it subclasses matplotlib.animation's writer)."""
    from matplotlib import animation

    class SharedPaletteGifWriter(animation.AbstractMovieWriter):
        """A GIF writer (matplotlib's movie-writer interface) whose frames share one palette."""

        def setup(self, fig, outfile, dpi=None):
            super().setup(fig, outfile, dpi=dpi)
            self._frames = []
            self._palette = None

        def _rgb(self, **savefig_kwargs):
            import io

            from PIL import Image

            buf = io.BytesIO()
            self.fig.savefig(buf, **{**savefig_kwargs, "format": "rgba", "dpi": self.dpi})
            w, h = (int(round(v)) for v in self.frame_size)
            return Image.frombuffer("RGBA", (w, h), buf.getbuffer(), "raw", "RGBA", 0, 1).convert("RGB")

        def prime_palette(self, **savefig_kwargs):
            """Take the palette from the figure as it is now (call with the fullest frame drawn)."""
            self._palette = _palette_for(self._rgb(**savefig_kwargs), self.fig)

        def grab_frame(self, **savefig_kwargs):
            from PIL import Image

            frame = self._rgb(**savefig_kwargs)
            if self._palette is None:
                self._palette = _palette_for(frame, self.fig)
            self._frames.append(frame.quantize(palette=self._palette, dither=Image.Dither.NONE))

        def finish(self):
            self._frames[0].save(self.outfile, format="GIF", save_all=True, append_images=self._frames[1:],
                                 duration=int(round(1000 / self.fps)), loop=0)

    return SharedPaletteGifWriter


def _key_colours(fig, limit: int = 64) -> list[tuple[int, int, int]]:
    """The opaque colours of the figure's lines, markers and texts, as 8-bit RGB (at most ``limit``)."""
    from matplotlib.colors import to_rgba
    from matplotlib.lines import Line2D
    from matplotlib.text import Text

    out: list[tuple[int, int, int]] = []
    for artist in fig.findobj(lambda a: isinstance(a, (Line2D, Text))):
        specs = ([artist.get_color(), artist.get_markerfacecolor(), artist.get_markeredgecolor()]
                 if isinstance(artist, Line2D) else [artist.get_color()])
        for spec in specs:
            try:
                r, g, b, a = to_rgba(spec)
            except (ValueError, TypeError):
                continue
            rgb = (round(255 * r), round(255 * g), round(255 * b))
            if a == 1.0 and rgb not in out:
                out.append(rgb)
    return out[:limit]


def _palette_for(frame, fig):
    """A palette image: the figure's key colours exactly, then a median cut of ``frame`` (256 in all)."""
    from PIL import Image

    keys = _key_colours(fig)
    cut = frame.quantize(colors=256 - len(keys))
    rest = cut.getpalette()[: 3 * (256 - len(keys))]
    pal = Image.new("P", (1, 1))
    pal.putpalette([v for rgb in keys for v in rgb] + rest + [0] * max(0, 768 - 3 * len(keys) - len(rest)))
    return pal


def check_animation_path(path: str | Path, flag: str = "--animate") -> Path:
    """The path's suffix must be .gif or .mp4, and an .mp4 needs ffmpeg: an InputError otherwise
    (checked before any work)."""
    p = Path(path)
    if p.suffix.lower() not in ANIMATION_SUFFIXES:
        raise InputError(f"{flag} {p}: must end in {' or '.join(ANIMATION_SUFFIXES)}")
    if p.suffix.lower() == ".mp4" and _ffmpeg() is None:
        raise InputError(f"{flag} {p}: writing .mp4 needs ffmpeg (on PATH, or `pip install imageio-ffmpeg`); "
                         ".gif needs nothing more")
    return p


def save_animation(fig, draw_frame: Callable[[int], None], frames: Iterable[int], path: str | Path, *,
                   fps: float = 10.0, dpi: int = 80, progress: Callable[[int, int], None] | None = None) -> Path:
    """Write ``draw_frame(k)`` for each ``k`` of ``frames`` as one frame of ``path`` (.gif or .mp4);
    ``progress(done, total)`` is called after each frame (offroadbench.progress)."""
    from matplotlib import animation, rc_context

    p = check_animation_path(path, "animation")
    tmp = p.with_name(f".{p.stem}.partial{p.suffix}")
    rc = {}
    if p.suffix.lower() == ".gif":
        writer = _gif_writer_class()(fps=fps)
    else:
        rc["animation.ffmpeg_path"] = _ffmpeg()
        writer = animation.FFMpegWriter(fps=fps, codec="h264", extra_args=["-pix_fmt", "yuv420p"])
    try:
        with rc_context(rc):
            writer.setup(fig, str(tmp), dpi)
            frames = list(frames)
            try:
                if frames and hasattr(writer, "prime_palette"):
                    draw_frame(frames[-1])  # the last frame shows every line and mark: its colours
                    writer.prime_palette()
                for done, k in enumerate(frames, 1):
                    draw_frame(k)
                    writer.grab_frame()
                    if progress is not None:
                        progress(done, len(frames))
            except BaseException:
                proc = getattr(writer, "_proc", None)  # an ffmpeg pipe: stop it, write nothing
                if proc is not None:
                    proc.kill()
                    proc.wait()
                raise
            writer.finish()
        os.replace(tmp, p)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
    return p
