"""What every command shares: argument types, loading a terrain argument, output checks, the
progress bar, figure saving and table formatting.

Output policy (one for every command): an output directory or the directory of an output file
may be missing; its missing parents are created when the results are written, after the work.
Before any work each command checks that the path can be created: the nearest existing
ancestor must be a directory in which a file can actually be created (a read-only filesystem,
``/proc`` or a path under a regular file is refused with one line). If the command then fails,
the directories it created are removed again, so a failed command leaves nothing behind.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import tempfile
from pathlib import Path
from typing import Callable, Iterator

import pandas as pd

from offroadbench.errors import InputError
from offroadbench.progress import ProgressFn

__all__ = [
    "int_at_least", "seed_arg", "positive_int", "float_at_least", "positive_float", "nonnegative_float",
    "parse_sets", "load_recipe_with_sets", "load_heightmap_arg", "crater_diameters",
    "grid_bytes", "check_memory", "check_recipe_memory", "available_memory_bytes",
    "check_output_file", "check_output_dir", "created_dirs", "save_figure", "format_table", "bar",
]


# --------------------------------------------------------------------------- argument types
def int_at_least(lo: int, what: str = "value") -> Callable[[str], int]:
    """An argparse type: an integer >= ``lo``; otherwise one line naming ``what`` and the range."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be an integer >= {lo}, got {text!r}") from None
        if v < lo:
            raise argparse.ArgumentTypeError(f"{what} must be an integer >= {lo}, got {v}")
        return v

    return parse


def float_at_least(lo: float, what: str = "value", *, open_: bool = False) -> Callable[[str], float]:
    """An argparse type: a finite number >= ``lo`` (> ``lo`` with ``open_``)."""
    rel = ">" if open_ else ">="

    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be a number {rel} {lo:g}, got {text!r}") from None
        if not math.isfinite(v) or v < lo or (open_ and v == lo):
            raise argparse.ArgumentTypeError(f"{what} must be a finite number {rel} {lo:g}, got {text}")
        return v

    return parse


seed_arg = int_at_least(0, "seed")
positive_int = int_at_least(1, "value")
positive_float = float_at_least(0.0, "value", open_=True)
nonnegative_float = float_at_least(0.0, "value")


# --------------------------------------------------------------------------- terrain arguments
def parse_sets(pairs: list[str] | None) -> dict[str, object]:
    """``["a.b=1", "c=x"]`` -> ``{"a.b": 1, "c": "x"}`` (values parsed as TOML)."""
    from offroadbench.config import parse_set_value

    out: dict[str, object] = {}
    for item in pairs or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--set {item!r}: expected KEY=VALUE with a dotted TOML key, e.g. layers.base.D_high=2.6")
        out[key.strip()] = parse_set_value(value.strip())
    return out


def load_recipe_with_sets(name: str, sets: list[str] | None):
    """A preset or recipe TOML with the ``--set`` overrides applied (validated)."""
    from offroadbench.terrain.recipe import apply_overrides, load_recipe

    recipe = load_recipe(name)
    overrides = parse_sets(sets)
    return apply_overrides(recipe, overrides) if overrides else recipe


def load_heightmap_arg(
    source: str, seed: int, cell_size_m: float | None = None, relief_m: float | None = None,
    sets: list[str] | None = None, force: bool = False,
):
    """(Heightmap, label, recipe or None) from a PNG path (16-bit, with sidecar) or a preset / recipe.

    A recipe whose grid would not fit in the available memory is refused before it is built
    (``force`` skips that check).
    """
    if source.lower().endswith(".png"):
        from offroadbench.io.png16 import png_shape, read_png16

        if sets:
            raise InputError("--set applies to presets and recipes, not to a PNG heightmap")
        rows, cols = png_shape(source)
        check_memory(grid_bytes(rows, cols), f"{source}: a {rows}x{cols} heightmap", force)
        return read_png16(source, cell_size_m=cell_size_m, relief_m=relief_m), Path(source).stem, None
    from offroadbench.terrain.recipe import generate_terrain

    recipe = load_recipe_with_sets(source, sets)
    check_recipe_memory(recipe, force)
    return generate_terrain(recipe, seed), f"{recipe.name} seed {seed}", recipe


def crater_diameters(recipe, seed: int):
    """Diameters (m) of the craters a recipe places, or None for a PNG or a crater-free recipe."""
    import numpy as np

    if recipe is None:
        return None
    from offroadbench.terrain.craters import recipe_craters

    tables = recipe_craters(recipe, seed)
    if not tables:
        return None
    return np.concatenate([np.asarray(t.diameter_m) for t in tables.values()])


# --------------------------------------------------------------------------- memory
#: bytes per grid cell that generating and classifying a terrain keeps alive at its peak
#: (float64 heights, W-M layers and products, gradient and class maps, closing masks)
GRID_BYTES_PER_CELL = 80

#: set to 1 to skip the memory estimate check (same as --force)
NO_MEMORY_CHECK_ENV = "OFFROADBENCH_NO_MEMORY_CHECK"


def grid_bytes(rows: int, cols: int) -> int:
    """Peak memory estimate of building and analysing a rows x cols terrain, bytes."""
    return int(rows) * int(cols) * GRID_BYTES_PER_CELL


def available_memory_bytes() -> int | None:
    """Memory this process may still use: MemAvailable, capped by a cgroup limit; None if unknown."""
    avail = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                avail = int(line.split()[1]) * 1024
                break
    except (OSError, ValueError):
        pass
    for limit_file, usage_file in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                                   ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
                                    "/sys/fs/cgroup/memory/memory.usage_in_bytes")):
        try:
            text = Path(limit_file).read_text().strip()
            if text == "max":
                continue
            room = int(text) - int(Path(usage_file).read_text().strip())
            avail = room if avail is None else min(avail, room)
        except (OSError, ValueError):
            continue
    return avail


def check_recipe_memory(recipe, force: bool = False) -> None:
    """Refuse a recipe whose grid would not fit in memory (see :func:`check_memory`)."""
    rows, cols = int(recipe.grid.rows), int(recipe.grid.cols)
    check_memory(grid_bytes(rows, cols), f"{recipe.name}: a {rows}x{cols} grid", force)


def check_memory(estimate_bytes: int, what: str, force: bool = False) -> None:
    """Refuse ``what`` up front if its memory estimate exceeds the memory available."""
    if force or os.environ.get(NO_MEMORY_CHECK_ENV, "") not in ("", "0"):
        return
    avail = available_memory_bytes()
    if avail is not None and estimate_bytes > avail:
        raise InputError(
            f"{what} needs about {format_bytes(estimate_bytes)} of memory, more than the {format_bytes(avail)} available; "
            f"make it smaller, or pass --force (or set {NO_MEMORY_CHECK_ENV}=1) to try anyway"
        )


def format_bytes(n: int) -> str:
    return f"{n / 2**30:.1f} GB" if n >= 2**27 else f"{n / 2**20:.0f} MB"


# --------------------------------------------------------------------------- outputs
def _probe_dir(d: Path, flag: str, target: Path) -> None:
    """Raise InputError unless a file can be created in the existing directory ``d``."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".offroadbench-probe.", dir=d)
    except OSError as exc:
        raise InputError(f"{flag} {target}: cannot write into {d} ({exc.strerror})") from None
    os.close(fd)
    os.unlink(tmp)


def _nearest_existing(p: Path, flag: str, target: Path) -> Path:
    """The nearest existing ancestor of ``p`` (itself included); it must be a directory."""
    q = p
    while not q.exists() and not q.is_symlink():
        if q.parent == q:
            break
        q = q.parent
    if not q.is_dir():
        raise InputError(f"{flag} {target}: {q} is a file, not a directory")
    return q


def check_output_dir(path: str | Path, flag: str = "--out") -> Path:
    """Check, before any work, that ``path`` is (or can be created as) a writable directory."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise InputError(f"{flag} {p}: exists and is not a directory")
    _probe_dir(_nearest_existing(p, flag, p), flag, p)
    return p


def check_output_file(path: str | Path, flag: str = "--output", suffixes: tuple[str, ...] = ()) -> Path:
    """Check, before any work, that the file ``path`` can be written (its directory created)."""
    p = Path(path)
    if p.is_dir() or str(path).endswith(("/", os.sep)):
        raise InputError(f"{flag} {p}: is a directory; give a file name")
    if suffixes and p.suffix.lower() not in suffixes:
        raise InputError(f"{flag} {p}: must end in {' or '.join(suffixes)}")
    parent = p.parent if str(p.parent) else Path(".")
    _probe_dir(_nearest_existing(parent, flag, p), flag, p)
    return p


@contextlib.contextmanager
def created_dirs(*dirs: str | Path) -> Iterator[None]:
    """Create ``dirs`` (with missing parents); if the block fails, remove the ones created here."""
    made: list[Path] = []
    try:
        for d in dirs:
            missing = []
            q = Path(d)
            while not q.exists():
                missing.append(q)
                if q.parent == q:
                    break
                q = q.parent
            for m in reversed(missing):
                try:
                    m.mkdir()
                except OSError as exc:
                    raise InputError(f"cannot create directory {m} ({exc.strerror})") from None
                made.append(m)
        yield
    except BaseException:
        for m in reversed(made):
            with contextlib.suppress(OSError):
                m.rmdir()  # only empty ones: a file someone else put there stays
        raise


def save_figure(fig, path: str | Path, dpi: int = 150) -> Path:
    """Save a matplotlib Figure atomically (format from the suffix, default PNG)."""
    from offroadbench.io.atomic import atomic_path

    p = Path(path)
    with atomic_path(p) as tmp:
        fig.savefig(tmp, dpi=dpi, format=p.suffix.lstrip(".") or "png")
    return p


def format_table(df: pd.DataFrame, floatfmt: str = "{:.2f}") -> str:
    return df.to_string(index=False, float_format=lambda v: floatfmt.format(v))


# --------------------------------------------------------------------------- progress
@contextlib.contextmanager
def bar(desc: str, unit: str = "it", postfix: Callable[[], dict] | None = None) -> Iterator[ProgressFn]:
    """Yield a ``progress(done, total)`` callback that drives a tqdm bar on stderr.

    ``postfix``, if given, is a zero-argument callable returning a dict shown after the bar
    (e.g. the success rate so far). The bar is hidden when stderr is not a terminal.
    """
    from tqdm import tqdm

    pbar = tqdm(desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True, disable=None)

    first = [True]

    def update(done: int, total: int) -> None:
        if first[0]:  # a resumed study starts part-done: count the rate from here
            first[0] = False
            pbar.initial = pbar.n = pbar.last_print_n = done
        if pbar.total != total:
            pbar.total = total
        pbar.n = done
        if postfix is not None:
            pbar.set_postfix(postfix(), refresh=False)
        pbar.refresh()

    try:
        yield update
    finally:
        pbar.close()
