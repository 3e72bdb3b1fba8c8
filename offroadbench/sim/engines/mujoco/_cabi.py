"""Raw memory and C calls for the MuJoCo world's numba kernels (offroadbench.sim.engines.mujoco.
_hfield_c, ``_tyres_c``): addresses as int64, loads of a struct's pointer and int fields at byte
offsets (offroadbench.sim.engines.mujoco._layout), and calls of MuJoCo's C functions through their
addresses (``mjfCollision``; ``mj_step1`` and its kin, ``void (const mjModel*, mjData*)``).

The addresses are run-time arguments, never compiled in, so the kernels that use these stay in
numba's on-disk cache across processes (and address-space layouts). numba's cache checks only the
calling kernel's own source file: after editing this module, clear the ``__pycache__`` ``*.nbi`` /
``*.nbc`` files of ``_hfield_c`` and ``_tyres_c`` (an installed release rewrites them all)."""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import carray, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["as_address", "as_pointer", "call_collision", "call_step", "f64_field", "i32_field", "int_at",
           "pointer_at", "swap_entry"]


@intrinsic
def as_pointer(typingctx, address):
    """int64 address -> void pointer."""
    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)
    return types.voidptr(types.int64), codegen


@intrinsic
def as_address(typingctx, pointer):
    """void pointer -> int64 address."""
    def codegen(context, builder, signature, args):
        return builder.ptrtoint(args[0], ir.IntType(64))
    return types.int64(types.voidptr), codegen


@intrinsic
def call_collision(typingctx, fn, m, d, con, g1, g2, margin):
    """Call the ``mjfCollision`` at address ``fn`` with (m, d, con addresses, g1, g2, margin)."""
    sig = types.int32(types.int64, types.int64, types.int64, types.int64, types.int32, types.int32, types.float64)

    def codegen(context, builder, signature, args):
        i8p = cgutils.voidptr_t
        fnty = ir.FunctionType(ir.IntType(32), [i8p, i8p, i8p, ir.IntType(32), ir.IntType(32), ir.DoubleType()])
        target = builder.inttoptr(args[0], fnty.as_pointer())
        ptrs = [builder.inttoptr(a, i8p) for a in args[1:4]]
        return builder.call(target, [*ptrs, args[4], args[5], args[6]])
    return sig, codegen


@intrinsic
def call_step(typingctx, fn, m, d):
    """Call ``void fn(const mjModel* m, mjData* d)`` (``mj_step``, ``mj_step1``, ``mj_step2``) at address ``fn``."""
    sig = types.void(types.int64, types.int64, types.int64)

    def codegen(context, builder, signature, args):
        i8p = cgutils.voidptr_t
        fnty = ir.FunctionType(ir.VoidType(), [i8p, i8p])
        target = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(target, [builder.inttoptr(args[1], i8p), builder.inttoptr(args[2], i8p)])
        return context.get_dummy_value()
    return sig, codegen


@njit(cache=True)
def pointer_at(base, offset):  # pragma: no cover - compiled
    """The pointer stored at ``base + offset`` (a struct's pointer field), as an int64 address."""
    return carray(as_pointer(base + offset), (1,), np.int64)[0]


@njit(cache=True)
def int_at(base, offset):  # pragma: no cover - compiled
    """The C int stored at ``base + offset`` (a struct's int field)."""
    return carray(as_pointer(base + offset), (1,), np.int32)[0]


@njit(cache=True)
def f64_field(base, offset, n):  # pragma: no cover - compiled
    """The first ``n`` mjtNum of the array that the pointer field at ``base + offset`` points to."""
    return carray(as_pointer(pointer_at(base, offset)), (n,), np.float64)


@njit(cache=True)
def i32_field(base, offset, n):  # pragma: no cover - compiled
    """The first ``n`` ints of the array that the pointer field at ``base + offset`` points to."""
    return carray(as_pointer(pointer_at(base, offset)), (n,), np.int32)


@njit(cache=True)
def swap_entry(slot, fn):  # pragma: no cover - compiled
    """Write function address ``fn`` into the collision-table entry at address ``slot`` and return
    what was there (``fn`` 0: leave it, return 0)."""
    if fn == 0:
        return 0
    entry = carray(as_pointer(slot), (1,), np.int64)
    old = entry[0]
    entry[0] = fn
    return old
