"""Writing an animation: frames of one matplotlib Figure through matplotlib's animation writers,
``.gif`` with Pillow (a dependency already) and ``.mp4`` with ffmpeg (when an ``ffmpeg`` is on
PATH, or the optional ``imageio-ffmpeg`` package is installed). The file appears whole or not at
all: frames go to a temporary file beside it, renamed at the end."""

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
                   fps: float = 10.0, dpi: int = 80) -> Path:
    """Write ``draw_frame(k)`` for each ``k`` of ``frames`` as one frame of ``path`` (.gif or .mp4)."""
    from matplotlib import animation, rc_context

    p = check_animation_path(path, "animation")
    tmp = p.with_name(f".{p.stem}.partial{p.suffix}")
    rc = {}
    if p.suffix.lower() == ".gif":
        writer = animation.PillowWriter(fps=fps)
    else:
        rc["animation.ffmpeg_path"] = _ffmpeg()
        writer = animation.FFMpegWriter(fps=fps, codec="h264", extra_args=["-pix_fmt", "yuv420p"])
    try:
        with rc_context(rc):
            writer.setup(fig, str(tmp), dpi)
            try:
                for k in frames:
                    draw_frame(k)
                    writer.grab_frame()
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
