"""What every command shares: argument types, loading a terrain argument, output checks, the
progress bar, figure saving and table formatting.

The output-path policy (offroadbench.io.outputs) and the memory model (offroadbench.memory) live
in the library; this module re-exports their checks for the commands.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator

from offroadbench.errors import InputError
from offroadbench.io.outputs import check_output_dir, check_output_file, created_dirs
from offroadbench.memory import available_memory_bytes, check_memory, check_recipe_memory, grid_bytes
from offroadbench.progress import ProgressFn

if TYPE_CHECKING:  # only format_table needs pandas: ``study run`` forks its workers without it (issue 41)
    import pandas as pd

__all__ = [
    "int_at_least", "seed_arg", "positive_int", "float_at_least", "positive_float", "nonnegative_float",
    "parse_sets", "put_setting", "load_recipe_with_sets", "load_heightmap_arg", "crater_diameters",
    "sets_text", "terrain_label", "recipe_meta", "count_text", "medians_text", "run_caption",
    "add_plot_option", "plot_path",
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


def put_setting(tables: dict, item: str) -> None:
    """Put ``--set SECTION.FIELD=VALUE`` into ``tables[SECTION]`` (a settings table of
    offroadbench.sim.trial.settings.TrialSettings), and ``SECTION.SUB.FIELD=VALUE`` into its nested
    table ``[SECTION.SUB]`` where SUB is a field holding a config class (``sim.mujoco.hfield_collision``
    into ``[sim.mujoco]``), as the TOML nests them. A SUB that is no such table is refused here; the
    field's name and value are checked where the tables are built (offroadbench.config.from_dict),
    with the same one-line errors as the TOML's."""
    import typing

    from offroadbench.config import dataclass_type, set_dotted
    from offroadbench.sim.trial.settings import TrialSettings

    key = item.partition("=")[0].strip()
    head, _, rest = key.partition(".")
    (value,) = parse_sets([item]).values()
    cls, parts = dataclass_type(typing.get_type_hints(TrialSettings).get(head)), rest.split(".")
    for depth, part in enumerate(parts[:-1]):
        nested = _nested_tables(cls)
        if part not in nested:
            form = f"{'.'.join([head, *parts[:depth]])}.FIELD=VALUE"
            allowed = f" or {form.replace('FIELD', 'TABLE.FIELD')} with TABLE one of {', '.join(nested)}" if nested else ""
            raise InputError(f"--set {item!r}: a settings key is {form}{allowed}")
        cls = nested[part]
    if not all(parts):
        raise InputError(f"--set {item!r}: a settings key is {head}.FIELD=VALUE")
    tables[head] = set_dotted(tables.get(head, {}), rest, value)


def _nested_tables(cls: type | None) -> dict[str, type]:
    """The fields of config class ``cls`` that are nested tables: name -> their config class."""
    import dataclasses
    import typing

    from offroadbench.config import dataclass_type

    if cls is None:
        return {}
    hints = typing.get_type_hints(cls)
    return {f.name: sub for f in dataclasses.fields(cls) if (sub := dataclass_type(hints.get(f.name))) is not None}


def sets_text(overrides: dict[str, object] | None) -> str:
    """``{"layers.base.D_high": 2.6}`` -> ``"layers.base.D_high=2.6"`` (as typed after ``--set``)."""
    import json

    return ", ".join(f"{k}={v if isinstance(v, str) else json.dumps(v)}" for k, v in (overrides or {}).items())


def terrain_label(recipe, seed: int, overrides: dict[str, object] | None = None) -> str:
    """What a terrain is called in headers, titles and sidecars: the preset, its ``--set``
    overrides (a changed terrain is not the preset) and the seed, e.g.
    ``paper-d2.45 + layers.base.D_high=2.6 seed 0``."""
    extra = sets_text(overrides)
    return f"{recipe.name}{' + ' + extra if extra else ''} seed {seed}"


def recipe_meta(recipe, seed: int, overrides: dict[str, object] | None = None) -> dict[str, object]:
    """The provenance a written terrain carries (PNG sidecar, exports): preset name, seed, terrain
    id, the resolved recipe, the ``--set`` overrides and the label, and the recipe's CRS if any."""
    meta: dict[str, object] = {"recipe_name": recipe.name, "seed": seed, "terrain_id": recipe.terrain_id(seed),
                               "recipe": dict(recipe.data)}
    if overrides:
        meta["overrides"] = dict(overrides)
    meta["label"] = terrain_label(recipe, seed, overrides)
    if recipe.data.get("recipe", {}).get("crs"):
        meta["crs"] = recipe.data["recipe"]["crs"]
    return meta


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
        from offroadbench.io.png16 import png_shape, read_png16, read_png16_metadata

        if sets:
            raise InputError("--set applies to presets and recipes, not to a PNG heightmap")
        rows, cols = png_shape(source)
        check_memory(grid_bytes(rows, cols), f"{source}: a {rows}x{cols} heightmap", force)
        hm = read_png16(source, cell_size_m=cell_size_m, relief_m=relief_m)
        made = read_png16_metadata(source).get("label")  # what generate named it (preset, overrides, seed)
        return hm, f"{Path(source).stem} ({made})" if made else Path(source).stem, None
    from offroadbench.terrain.recipe import load_terrain

    recipe = load_recipe_with_sets(source, sets)
    check_recipe_memory(recipe, force)
    return load_terrain(recipe, seed)[0], terrain_label(recipe, seed, parse_sets(sets)), recipe


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


def add_plot_option(p: argparse.ArgumentParser, what: str, default: str) -> None:
    """The one ``--plot [PATH]`` grammar of every command that draws: ``--plot PATH`` writes ``what``
    at PATH (.png, .pdf or .svg); a bare ``--plot`` writes it at ``default``."""
    p.add_argument("--plot", nargs="?", const=True, default=None, metavar="PATH",
                   help=f"write {what} to PATH (.png, .pdf or .svg); a bare --plot writes it to {default}")


def plot_path(plot: str | bool | None, default: str | Path) -> Path | None:
    """The checked figure path of a ``--plot [PATH]`` value (None: no figure)."""
    if not plot:
        return None
    return check_output_file(default if plot is True else plot, "--plot", suffixes=(".png", ".pdf", ".svg"))


def save_figure(fig, path: str | Path, dpi: int = 150) -> Path:
    """Save a matplotlib Figure atomically (format from the suffix, default PNG)."""
    from offroadbench.io.atomic import atomic_path

    from matplotlib.text import Text

    p = Path(path)
    for t in fig.findobj(Text):  # a file name that is not UTF-8 (surrogate escapes) cannot be drawn
        text = t.get_text()
        if isinstance(text, str) and printable(text) != text:
            t.set_text(printable(text))
    with atomic_path(p) as tmp:
        fig.savefig(tmp, dpi=dpi, format=p.suffix.lstrip(".") or "png")
    return p


def count_text(n: int, noun: str) -> str:
    """``1 mission``, ``3 missions``."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def medians_text(summary: dict) -> str:
    """The medians line of a drive summary (``median_*`` keys): said plainly when no trial succeeded
    (the metrics are of successful trials only), never a row of ``nan``."""
    medians = {k[len("median_"):]: v for k, v in summary.items() if k.startswith("median_")}
    if not int(summary.get("successes", 0)) or all(v != v for v in medians.values()):
        return "no trial succeeded, so no traversal metrics (they are of successful trials only)"
    return "medians of successful trials:\n  " + ", ".join(
        f"{k} {v:.3f}" for k, v in medians.items() if v == v)


def run_caption(sim) -> str:
    """``pybullet, g = 9.81 m/s^2``: the engine and gravity a figure of driven trials was made with."""
    return f"{sim.engine}, g = {sim.gravity_m_s2:g} m/s^2"


def printable(text: str) -> str:
    """``text`` with the surrogate escapes of a non-UTF-8 file name (os.fsdecode) shown as U+FFFD."""
    return text.encode("utf-8", "surrogateescape").decode("utf-8", "replace")


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
