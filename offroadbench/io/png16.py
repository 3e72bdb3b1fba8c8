"""16-bit grayscale PNG heightmaps with a JSON sidecar, the exchange format for other simulators.

Encoding: pixel (row r, col c) is ``z[r, c]`` (no flips); the full 0..65535 range maps linearly to
``z_min_m .. z_max_m``, so the round-trip error is at most half a quantisation step
``(z_max_m - z_min_m) / 65535 / 2``.

Metadata is written twice: a sidecar ``NAME.json`` beside ``NAME.png`` (flat keys, read back
exactly) and PNG ``tEXt`` chunks with the same keys (so the PNG alone still says what it is).

The pair. The sidecar names the PNG it belongs to: ``png_bytes`` (its size) and ``png_sha256``
(its SHA-256, hex). The PNG is renamed into place first and the sidecar last, so the sidecar is
the pair's commit record; :func:`read_png16` refuses a sidecar whose size or checksum does not
match the PNG beside it (a crash between the two renames over an earlier output, or files copied
from different runs), instead of reading heights against another map's range. Sidecars written
before these keys existed are read as before.
Both carry the Unreal Engine Landscape import settings that reproduce the metres
(:func:`ue_landscape_settings`).

Unreal's mapping (Landscape Technical Guide, "Calculating Heightmap Z Scale"; UE source
``LandscapeDataAccess.h``: ``LANDSCAPE_ZSCALE = 1/128``, ``MidValue = 32768``): a 16-bit level v
lies at ``Location.Z + (v - 32768) / 128 * Scale.Z`` centimetres. Level 0..65535 therefore spans
``65535 / 128 * Scale.Z`` cm (:func:`ue_z_range_m`: 511.99 m at Scale.Z 100, the "-256..+256 m" of
the docs). Our level 0 is ``z_min`` and 65535 is ``z_max``, so the exact Z scale is
``relief_cm * 128 / 65535`` and the location ``z_min_cm + 256 * Scale.Z``: Unreal then puts every
level exactly where :func:`decode_png16` does. The only loss is the PNG's own quantisation, at
most half a step ``relief / 65535 / 2`` (29 um for the paper's 3.84 m), plus Unreal's float32
transform (relative 6e-8 of the numbers typed in).
"""

from __future__ import annotations

import hashlib
import json
import struct
from decimal import Decimal
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap
from offroadbench.io.atomic import atomic_path, check_writable
from offroadbench.levels16 import (
    LEVELS,
    UE_LEVELS_PER_CM,
    UE_ZERO_LEVEL,
    decode_levels,
    encode_levels,
    ue_z_range_m,
)

__all__ = [
    "FORMAT",
    "LEVELS",
    "encode_png16",
    "decode_png16",
    "sidecar_path",
    "check_sidecar_pair",
    "read_png16_metadata",
    "png_metadata",
    "write_png16",
    "read_png16",
    "png_shape",
    "ue_z_range_m",
    "ue_landscape_settings",
    "ue_heights_m",
]

FORMAT = "offroadbench-png16/1"


def ue_landscape_settings(hm: Heightmap) -> dict[str, float]:
    """Landscape import scale and location (cm) that reproduce ``hm`` in Unreal Engine exactly.

    Scale X = Scale Y = cell size in cm (vertex (col c, row r) at Location + (c * Scale.X,
    r * Scale.Y)); Scale Z = relief / :func:`ue_z_range_m` (1), i.e. relief_cm * 128 / 65535;
    Location Z = z_min_cm + 32768 / 128 * Scale Z, so level 0 lands on z_min and 65535 on z_max.
    A flat map gets Scale Z = 100 (any scale puts level 0 on z_min).
    """
    relief = hm.relief_m
    scale_z = relief / ue_z_range_m(1.0) if relief > 0 else 100.0
    cell_cm = float(Decimal(repr(hm.cell_size_m)) * 100)  # 0.07 m -> 7 cm, not 7.000000000000001
    return {
        "scale_x": cell_cm,
        "scale_y": cell_cm,
        "scale_z": scale_z,
        "location_x_cm": 0.0,
        "location_y_cm": 0.0,
        "location_z_cm": hm.z_min_m * 100.0 + UE_ZERO_LEVEL / UE_LEVELS_PER_CM * scale_z,
    }


def ue_heights_m(levels: np.ndarray, scale_z: float, location_z_cm: float) -> np.ndarray:
    """World Z (metres) Unreal gives 16-bit ``levels`` at ``Scale.Z`` and ``Location.Z``."""
    return (location_z_cm + (np.asarray(levels, dtype=np.float64) - UE_ZERO_LEVEL) / UE_LEVELS_PER_CM * scale_z) / 100.0


def sidecar_path(png_path: str | Path) -> Path:
    """``NAME.json`` beside ``NAME.png``."""
    return Path(png_path).with_suffix(".json")


def encode_png16(hm: Heightmap) -> np.ndarray:
    """Quantise heights to uint16 over the map's full range (a flat map becomes all zeros)."""
    return encode_levels(hm.z, hm.z_min_m, hm.z_max_m)


def decode_png16(q: np.ndarray, cell_size_m: float, z_min_m: float, z_max_m: float) -> Heightmap:
    """Heights in metres from uint16 levels and the range they span (:func:`offroadbench.levels16.decode_levels`)."""
    if not z_max_m >= z_min_m:
        raise InputError(f"z_max_m ({z_max_m}) must be >= z_min_m ({z_min_m})")
    return Heightmap(z=decode_levels(q, z_min_m, z_max_m), cell_size_m=cell_size_m)


def png_metadata(hm: Heightmap, extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The flat metadata dict written to the sidecar and the PNG text chunks."""
    from offroadbench import __version__

    relief = hm.relief_m
    ue = ue_landscape_settings(hm)
    meta: dict[str, Any] = {
        "format": FORMAT,
        "rows": hm.rows,
        "cols": hm.cols,
        "cell_size_m": hm.cell_size_m,
        "z_min_m": hm.z_min_m,
        "z_max_m": hm.z_max_m,
        "relief_m": relief,
        "quantisation_step_m": relief / LEVELS,
        "ue_scale_x": ue["scale_x"],
        "ue_scale_y": ue["scale_y"],
        "ue_scale_z": ue["scale_z"],
        "ue_location_z_cm": ue["location_z_cm"],
        "offroadbench_version": __version__,
    }
    for k, v in (extra or {}).items():
        meta[k] = v
    return meta


def _read_ihdr(path: Path) -> tuple[int, int, int, int]:
    """(width, height, bit depth, colour type) from a PNG header, or InputError if not a PNG."""
    from offroadbench.io.inputs import check_input_file

    check_input_file(path, "heightmap PNG")
    try:
        with path.open("rb") as fh:
            head = fh.read(33)
    except OSError as exc:
        raise InputError(f"heightmap PNG {path}: cannot be read ({exc.strerror})") from None
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        raise InputError(f"{path}: not a PNG file (no PNG signature)")
    if len(head) < 33 or head[12:16] != b"IHDR":
        raise InputError(f"{path}: truncated PNG file (no complete header)")
    width, height, depth, ctype = struct.unpack(">IIBB", head[16:26])
    return width, height, depth, ctype


_COLOUR_TYPES = {0: "grayscale", 2: "RGB colour", 3: "palette colour", 4: "grayscale+alpha", 6: "RGBA colour"}


def write_png16(hm: Heightmap, path: str | Path, meta: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Write ``path`` (16-bit grayscale PNG) and its JSON sidecar atomically; return the metadata.

    ``meta`` adds keys (e.g. ``recipe``, ``seed``); values that are not strings are stored as JSON.
    Nothing is left behind under the final names if anything fails.
    """
    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    png = Path(path)
    if png.suffix.lower() != ".png":
        raise InputError(f"output path {png}: must end in .png")
    check_writable(png)
    data = png_metadata(hm, meta)
    info = PngInfo()
    for k, v in data.items():
        text = v if isinstance(v, str) else json.dumps(v)
        # iTXt is UTF-8: a non-UTF-8 file name (surrogate escapes) is kept with U+FFFD in its place
        info.add_text(k, text.encode("utf-8", "surrogateescape").decode("utf-8", "replace"))
    q = encode_png16(hm)
    img = Image.fromarray(q)  # uint16 -> mode "I;16": one 16-bit grayscale channel
    side = sidecar_path(png)
    # exits run inner first: the PNG is renamed into place, then the sidecar that names it
    with atomic_path(side) as tmp_json, atomic_path(png) as tmp_png:
        img.save(tmp_png, format="PNG", pnginfo=info)
        size, digest = _file_digest(tmp_png)
        data = {**data, "png_bytes": size, "png_sha256": digest}
        tmp_json.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    return data


def _file_digest(path: Path) -> tuple[int, str]:
    """(size in bytes, SHA-256 hex) of a file."""
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
            size += len(chunk)
    return size, h.hexdigest()


def check_sidecar_pair(png: Path, meta: Mapping[str, Any], source: str) -> None:
    """InputError unless the sidecar's ``png_bytes`` and ``png_sha256`` (when present) match ``png``."""
    if "png_bytes" not in meta and "png_sha256" not in meta:
        return  # a sidecar of an older offroadbench
    size, digest = _file_digest(png)
    if meta.get("png_bytes") != size or meta.get("png_sha256") != digest:
        raise InputError(
            f"{source}: belongs to another PNG than {png} (it names {meta.get('png_bytes')!r} bytes, sha256 "
            f"{str(meta.get('png_sha256'))[:12]}...; the PNG has {size} bytes, sha256 {digest[:12]}...); "
            "the pair comes from different writes: write the map again"
        )


def read_png16(
    path: str | Path,
    *,
    cell_size_m: float | None = None,
    relief_m: float | None = None,
    z_min_m: float = 0.0,
) -> Heightmap:
    """Read a 16-bit grayscale PNG heightmap.

    Metadata comes from the sidecar if it exists, else from offroadbench's PNG text chunks, else
    from ``cell_size_m`` and ``relief_m`` (with ``z_min_m``, default 0) given by the caller. An
    8-bit or colour image is refused: it cannot hold the 65536 height levels.
    """
    from PIL import Image

    p = Path(path)
    width, height, depth, ctype = _read_ihdr(p)
    if ctype != 0:
        raise InputError(
            f"{p}: is a {_COLOUR_TYPES.get(ctype, 'colour')} PNG, not a heightmap; a heightmap must be a single-channel "
            "16-bit grayscale PNG"
        )
    if depth != 16:
        raise InputError(
            f"{p}: is {'an' if depth == 8 else 'a'} {depth}-bit grayscale PNG; a heightmap must be 16-bit "
            f"({2 ** depth} levels cannot resolve terrain heights)"
        )
    import warnings

    try:
        # the size was checked against the memory before (offroadbench.memory): PIL's own
        # "decompression bomb" limits (a warning at 89 Mpixel, an error at twice that) say nothing more
        limit = Image.MAX_IMAGE_PIXELS
        try:
            Image.MAX_IMAGE_PIXELS = None
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                img = Image.open(p)
        finally:
            Image.MAX_IMAGE_PIXELS = limit
        with img:
            img.load()
            q = np.asarray(img, dtype=np.uint16) if img.mode != "I" else np.asarray(img).astype(np.uint16)
            text = dict(getattr(img, "text", {}) or {})
    except MemoryError:
        raise InputError(f"{p}: a {height}x{width} PNG does not fit in memory") from None
    except Exception as exc:  # PIL reports a damaged file as OSError, SyntaxError, ValueError, ...
        raise InputError(f"{p}: cannot decode the PNG, the file is truncated or damaged ({' '.join(str(exc).split())})") from None
    if q.shape != (height, width):
        raise InputError(f"{p}: decoded shape {q.shape} does not match the PNG header {height}x{width}")
    meta = _metadata_for(p, text)
    if meta is not None:
        source, meta = meta
        if source == str(sidecar_path(p)):
            check_sidecar_pair(p, meta, source)
        cell = _number(meta, "cell_size_m", source, positive=True)
        z_min, z_max = _number(meta, "z_min_m", source), _number(meta, "z_max_m", source)
        if z_max < z_min:
            raise InputError(f"{source}: z_max_m = {z_max} is below z_min_m = {z_min}; allowed: z_max_m >= z_min_m")
        from offroadbench.bounds import check_heights

        check_heights(z_min, z_max, where=source)  # before decoding: a range of +-1e308 overflows (inf * 0)
        for key, n in (("rows", height), ("cols", width)):
            if key in meta and meta[key] != n:
                raise InputError(f"{source}: {key} = {meta[key]!r} does not match the PNG's {n}")
        return decode_png16(q, cell, z_min, z_max)
    if cell_size_m is None or relief_m is None:
        raise InputError(
            f"{p}: has no sidecar {sidecar_path(p).name} and no offroadbench metadata; "
            "give the cell size (m) and the relief (m) it spans"
        )
    if not relief_m >= 0:
        raise InputError(f"relief_m must be >= 0, got {relief_m}")
    return decode_png16(q, cell_size_m, z_min_m, z_min_m + relief_m)


def read_png16_metadata(path: str | Path) -> dict[str, Any]:
    """The metadata stored with a PNG heightmap (sidecar, else text chunks; {} if none), e.g. the
    ``recipe`` it was generated from."""
    from PIL import Image

    p = Path(path)
    try:
        with Image.open(p) as img:
            text = dict(getattr(img, "text", {}) or {})
    except Exception:  # a damaged file: read_png16 reports it
        text = {}
    meta = _metadata_for(p, text)
    return {} if meta is None else dict(meta[1])


def _metadata_for(png: Path, text: Mapping[str, str]) -> tuple[str, dict[str, Any]] | None:
    side = sidecar_path(png)
    if side.is_file():
        try:
            meta = json.loads(side.read_text())
        except RecursionError:
            raise InputError(f"{side}: JSON nested too deeply; a sidecar is a flat JSON object") from None
        except (ValueError, UnicodeDecodeError) as exc:  # JSONDecodeError, or an integer of 4300+ digits
            raise InputError(f"{side}: not valid JSON ({' '.join(str(exc).split())[:200]})") from None
        except OSError as exc:
            raise InputError(f"{side}: cannot be read ({exc.strerror})") from None
        if not isinstance(meta, dict):
            raise InputError(f"{side}: must hold a JSON object with cell_size_m, z_min_m and z_max_m")
        source = str(side)
    elif text.get("format") == FORMAT:
        meta = {k: _maybe_json(v) for k, v in text.items()}
        source = f"{png} text chunks"
    else:
        return None
    missing = [k for k in ("cell_size_m", "z_min_m", "z_max_m") if k not in meta]
    if missing:
        raise InputError(f"{source}: missing {', '.join(missing)}")
    return source, meta


def _number(meta: Mapping[str, Any], key: str, source: str, positive: bool = False) -> float:
    """A finite number from sidecar metadata, or InputError naming the key and what is allowed."""
    v = meta[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or (positive and not v > 0):
        allowed = "a finite number > 0" if positive else "a finite number"
        raise InputError(f"{source}: {key} = {v!r} is not allowed; allowed: {allowed} (metres)")
    return float(v)


def png_shape(path: str | Path) -> tuple[int, int]:
    """(rows, cols) of a PNG from its header, without decoding it (InputError if not a PNG)."""
    width, height, _, _ = _read_ihdr(Path(path))
    return height, width


def _maybe_json(v: str) -> Any:
    try:
        return json.loads(v)
    except json.JSONDecodeError:
        return v
