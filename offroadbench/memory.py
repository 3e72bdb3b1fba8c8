"""The memory model: how much a piece of work needs, how much the machine has, and the check
every command runs before it starts.

Two estimates, both upper bounds of the measured peak (benchmarks/RESULTS.md):

* :func:`grid_bytes`: generating and analysing a rows x cols terrain (``generate``, ``analyze``,
  ``roughness-study``, ``drive``, ``export``), :data:`GRID_BYTES_PER_CELL` per cell;
* :func:`world_bytes`: a trial worker holding one terrain and its world (``study run``): on PyBullet
  the map's cells plus PyBullet's transient copy of one heightfield tile's triangles; on MuJoCo the
  map's cells, the model's float32 heights and its arena, plus numba and its compiled kernels where
  numba is installed (the MuJoCo world's tyre loop and height-field collision run in numba: about
  115 MB of a worker, more than MuJoCo itself).

:func:`check_memory` refuses work whose estimate exceeds :func:`available_memory_bytes` with one
line naming the estimate (``--force`` or ``OFFROADBENCH_NO_MEMORY_CHECK=1`` skips it);
:func:`workers_that_fit` is the default worker count of a study.
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from offroadbench.errors import InputError

__all__ = [
    "GRID_BYTES_PER_CELL", "WORKER_BYTES_PER_CELL", "TILE_BUILD_BYTES_PER_CELL", "WORKER_BASE_BYTES",
    "MUJOCO_WORKER_BASE_BYTES", "NUMBA_KERNELS_BYTES", "MUJOCO_BYTES_PER_CELL", "MUJOCO_ARENA_BYTES",
    "NO_MEMORY_CHECK_ENV", "grid_bytes", "world_bytes", "address_space_room_bytes", "available_memory_bytes",
    "check_memory",
    "check_recipe_memory", "workers_that_fit", "format_bytes", "WORLD_ENGINES", "MMAP_THRESHOLD_BYTES",
    "release_large_blocks", "TRIM_THRESHOLD_BYTES", "REUSE_MMAP_THRESHOLD_BYTES", "REUSE_TRIM_THRESHOLD_BYTES",
    "reusing_freed_blocks",
]


#: bytes per grid cell that generating and classifying a terrain keeps alive at its peak
#: (float64 heights, W-M layers and products, gradient and class maps, closing masks)
GRID_BYTES_PER_CELL = 80

#: set to 1 to skip the memory estimate check (same as --force)
NO_MEMORY_CHECK_ENV = "OFFROADBENCH_NO_MEMORY_CHECK"


def grid_bytes(rows: int, cols: int) -> int:
    """Peak memory estimate of building and analysing a rows x cols terrain, bytes."""
    return int(rows) * int(cols) * GRID_BYTES_PER_CELL


def address_space_room_bytes() -> int | None:
    """Address space this process may still map under its ``RLIMIT_AS`` (``ulimit -v``): the soft
    limit less the current virtual size (``VmSize`` of /proc/self/status); None when unlimited or
    unknown. Every process (each study worker too) has its own."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    except (ImportError, OSError, ValueError):
        return None
    if soft == resource.RLIM_INFINITY or soft < 0:
        return None
    used = 0
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmSize:"):
                used = int(line.split()[1]) * 1024
                break
    except (OSError, ValueError):
        pass
    return max(0, soft - used)


def available_memory_bytes(per_process: bool = True) -> int | None:
    """Memory this process may still use: MemAvailable, capped by a cgroup limit and (unless
    ``per_process`` is False: the machine's memory for several processes) by the room left under
    ``RLIMIT_AS`` (:func:`address_space_room_bytes`); None if unknown."""
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
    room = address_space_room_bytes() if per_process else None
    if room is not None:
        avail = room if avail is None else min(avail, room)
    return avail


def check_recipe_memory(recipe, force: bool = False) -> None:
    """Refuse a recipe whose grid would not fit in memory (see :func:`check_memory`)."""
    rows, cols = int(recipe.grid.rows), int(recipe.grid.cols)
    check_memory(grid_bytes(rows, cols), f"{recipe.name}: a {rows}x{cols} grid", force)


def check_memory(estimate_bytes: int, what: str, force: bool = False, per_process_bytes: int | None = None) -> None:
    """Refuse ``what`` up front if its memory estimate exceeds the memory available. With
    ``per_process_bytes`` (work spread over processes, e.g. a study's workers) the total is held
    against the machine's memory and each process's share against its own ``RLIMIT_AS``."""
    if force or os.environ.get(NO_MEMORY_CHECK_ENV, "") not in ("", "0"):
        return
    if per_process_bytes is not None:
        room = address_space_room_bytes()
        if room is not None and per_process_bytes > room:
            raise InputError(
                f"{what}: each process needs about {format_bytes(per_process_bytes)}, more than the "
                f"{format_bytes(room)} its address-space limit (ulimit -v) leaves; raise the limit, or pass --force "
                f"(or set {NO_MEMORY_CHECK_ENV}=1) to try anyway")
    avail = available_memory_bytes(per_process=per_process_bytes is None)
    if avail is not None and estimate_bytes > avail:
        limited = per_process_bytes is None and address_space_room_bytes() == avail
        raise InputError(
            f"{what} needs about {format_bytes(estimate_bytes)} of memory, more than the {format_bytes(avail)} available"
            f"{' under this process address-space limit (ulimit -v)' if limited else ''}; "
            f"make it smaller, or pass --force (or set {NO_MEMORY_CHECK_ENV}=1) to try anyway"
        )


def format_bytes(n: int) -> str:
    """``n`` bytes as "1.2 GB" (from 128 MiB) or "45 MB"."""
    return f"{n / 2**30:.1f} GB" if n >= 2**27 else f"{n / 2**20:.0f} MB"


#: memory a trial worker keeps per cell of its map (heights, class maps, the heightfields), bytes
WORKER_BYTES_PER_CELL = 60
#: PyBullet's transient triangle copy while one heightfield tile's heights are written, per cell of
#: the tile (sim/world.py): ~700 MB for an untiled 1009^2 map, ~45 MB for a 256-cell tile
TILE_BUILD_BYTES_PER_CELL = 690
#: memory of a PyBullet worker process before it builds a terrain (Python, numpy, pybullet), bytes.
#: With these, a 1009^2 worker is estimated at 266 MiB tiled (measured peak 203 MB) and 923 MiB
#: untiled (860 MB; benchmarks/RESULTS.md, "Heightfield tiles")
WORKER_BASE_BYTES = 160 * 2**20


#: memory of a MuJoCo trial worker before it builds a terrain, without numba (Python, numpy, scipy,
#: pandas, offroadbench, mujoco: 126 MB measured), bytes
MUJOCO_WORKER_BASE_BYTES = 140 * 2**20
#: numba once the MuJoCo world's compiled kernels are loaded from its cache (``import numba`` 54 MB,
#: the first kernel 61 MB: llvmlite's LLVM and numba's typing registry; the rest ~1 MB each), bytes
NUMBA_KERNELS_BYTES = 120 * 2**20
#: a MuJoCo world per cell of its map: the model's float32 heights (4 B) and their conversion
#: (written in blocks of rows, offroadbench.sim.engines.mujoco.world), bytes
MUJOCO_BYTES_PER_CELL = 5
#: the MuJoCo world's arena (``<size memory>``, offroadbench.sim.engines.mujoco.mjcf: 16 MB for four
#: wheels) and its compiled collision functions, bytes
MUJOCO_ARENA_BYTES = 20 * 2**20
#: engines :func:`world_bytes` knows (offroadbench.sim.engine.ENGINES)
WORLD_ENGINES = ("pybullet", "mujoco", "mujoco_warp")


def world_bytes(rows: int, cols: int, tile_cells: int, engine: str = "pybullet", numba: bool | None = None) -> int:
    """Peak memory estimate of a trial worker on a rows x cols map, bytes: on ``pybullet`` built as
    heightfield tiles of at most ``tile_cells`` cells (``SimConfig.heightfield_tile_cells``; 0: one
    heightfield); on ``mujoco`` (which has one height field whatever ``tile_cells``) with numba's
    compiled kernels when ``numba`` (None: when numba is installed)."""
    cells = int(rows) * int(cols)
    if engine in ("mujoco", "mujoco_warp"):  # the batched engine's host model is the MuJoCo engine's
        if numba is None:
            import importlib.util

            numba = importlib.util.find_spec("numba") is not None
        return (MUJOCO_WORKER_BASE_BYTES + (NUMBA_KERNELS_BYTES if numba else 0) + MUJOCO_ARENA_BYTES
                + (WORKER_BYTES_PER_CELL + MUJOCO_BYTES_PER_CELL) * cells)
    if engine != "pybullet":
        raise ValueError(f"world_bytes: engine {engine!r} is not one of {', '.join(WORLD_ENGINES)}")
    from offroadbench.sim.config import tile_spans  # pure config code: no pybullet

    tile_rows = max(b - a for a, b in tile_spans(int(rows) - 1, tile_cells)) + 1
    tile_cols = max(b - a for a, b in tile_spans(int(cols) - 1, tile_cells)) + 1
    return WORKER_BASE_BYTES + WORKER_BYTES_PER_CELL * cells + TILE_BUILD_BYTES_PER_CELL * tile_rows * tile_cols


def workers_that_fit(per_worker_bytes: int) -> int:
    """As many workers as both the cores and the available memory allow (at least one)."""
    workers = os.cpu_count() or 1
    avail = available_memory_bytes(per_process=False)  # each worker has its own address-space limit
    if avail is not None:
        workers = max(1, min(workers, avail // per_worker_bytes))
    return workers


#: allocations from this size up get their own ``mmap`` in a study worker (:func:`release_large_blocks`),
#: bytes: glibc's initial threshold, held fixed
MMAP_THRESHOLD_BYTES = 128 * 1024
#: the heap's free top above this size goes back to the system at each ``free`` in a study worker, bytes:
#: glibc's default (``DEFAULT_TRIM_THRESHOLD``), held fixed with the mmap threshold
TRIM_THRESHOLD_BYTES = 128 * 1024
#: the thresholds while a terrain is prepared (:func:`reusing_freed_blocks`), bytes: the ceiling of
#: glibc's own adaptive mmap threshold on 64-bit (``DEFAULT_MMAP_THRESHOLD_MAX``, 32 MiB) and twice
#: it for the trim threshold, the pair glibc's adaptive rule ends at
REUSE_MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024
REUSE_TRIM_THRESHOLD_BYTES = 2 * REUSE_MMAP_THRESHOLD_BYTES
#: ``mallopt``'s parameter numbers (glibc's malloc.h)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3

_held = False  # release_large_blocks has set this process's thresholds


def _libc_malloc():
    """(mallopt, malloc_trim) of the process's C library, or None where it has not both (not glibc)."""
    import ctypes

    try:
        libc = ctypes.CDLL(None)
        mallopt, trim = libc.mallopt, libc.malloc_trim
    except (OSError, AttributeError):
        return None
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return mallopt, trim


def release_large_blocks() -> bool:
    """Make glibc's malloc give every block of :data:`MMAP_THRESHOLD_BYTES` or more back to the
    system when it is freed (its own ``mmap``), and the heap's free top above
    :data:`TRIM_THRESHOLD_BYTES`, for the rest of this process; False where the C library has no
    ``mallopt`` (not glibc) or refuses.

    By default glibc raises that threshold to the largest block freed so far (up to 32 MB), so
    after the first terrain a worker's 1009^2 arrays (8 MB of float64 each) come from the heap,
    which fragments and keeps what they freed: on the full MuJoCo paper study a worker peaked at
    404-417 MB (349-410 MB with every thread on one malloc arena, ``M_ARENA_MAX`` = 1); with the
    threshold held, 284-285 MB (benchmarks/RESULTS.md, issue 41). What it costs: each large
    array's pages are faulted in afresh; :func:`reusing_freed_blocks` gives that back where a
    terrain is prepared."""
    global _held
    calls = _libc_malloc()
    if calls is None:
        return False
    mallopt, _ = calls
    _held = bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES))
    return _held


@contextmanager
def reusing_freed_blocks() -> Iterator[None]:
    """In a process whose thresholds :func:`release_large_blocks` holds (a study worker): inside the
    block, glibc serves large blocks from the heap and keeps what they free for the next ones
    (:data:`REUSE_MMAP_THRESHOLD_BYTES`, :data:`REUSE_TRIM_THRESHOLD_BYTES`); on leaving, the held
    thresholds come back and every free page of the heap goes back to the system (``malloc_trim``).
    Elsewhere it does nothing.

    Around a terrain's preparation (offroadbench.sim.trial.pipeline.prepare_terrain): its
    W-M layers, the finufft transforms (whose fine grid and spreading grid, 6.5 and 6.9 MB a call
    on the paper's grid, finufft 2.5 allocates inside every ``execute``, so a reused ``Plan``
    allocates them again) and the class maps allocate and free the same sizes many times; with
    every one a fresh mapping, a 1009^2 terrain page-faulted 52-60 k times instead of 3-4 k
    (benchmarks/RESULTS.md, issue 41). What the terrain keeps (its heights, class maps) stays in
    the heap; what it freed is returned on leaving. Results are unchanged (allocation never
    changes a value: tests/terrain/test_bit_identical.py)."""
    calls = _libc_malloc() if _held else None
    if calls is None:
        yield
        return
    mallopt, trim = calls
    mallopt(_M_MMAP_THRESHOLD, REUSE_MMAP_THRESHOLD_BYTES)
    mallopt(_M_TRIM_THRESHOLD, REUSE_TRIM_THRESHOLD_BYTES)
    try:
        yield
    finally:
        mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
        mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)
        trim(0)
