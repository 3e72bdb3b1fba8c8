"""The MuJoCo world's whole ``terramechanics`` trial step in one numba call: MuJoCo's ``mj_step1``,
the compiled soil kernel (offroadbench.sim.engines.mujoco._soil_c.apply_soil), ``mj_step2``, at each
of the trial step's MuJoCo steps, with no Python between MuJoCo's calls (issue 41). The same calls
in the same order as MuJoCoTyres._step_soil_compiled, so the same bits (tests/sim/test_whole_step.py).
No contact is read (the wheels do not collide under the soil model), so no struct layout is needed:
only the addresses of the model, the data and MuJoCo's step functions
(offroadbench.sim.engines.mujoco._layout.step_functions)."""

from __future__ import annotations

from numba import njit, types

from offroadbench.sim.engines.mujoco._cabi import call_step, swap_entry
from offroadbench.sim.engines.mujoco._soil_c import apply_soil

__all__ = ["STEP", "step_trial_soil"]

_SIG = types.void(types.int64, types.int64, types.UniTuple(types.int64, 3), types.UniTuple(types.int64, 4),
                  types.float64[:], types.float64[:, :], types.float64[:, :], types.float64[:, :],
                  types.float64[::1], types.int64[::1], types.float64[::1], types.int64, types.boolean)


@njit(_SIG, cache=True)
def step_trial_soil(m, d, fns, table, qvel, xmat, xipos, xfrc, f, st, tab, substeps, each):  # pragma: no cover - compiled
    """One trial step: ``substeps`` times ``mj_step1``, :func:`apply_soil`, ``mj_step2`` (``each``), or
    that once and then plain ``mj_step`` with the forces held. ``m``, ``d``: the mjModel and mjData
    addresses; ``fns``: ``mj_step``, ``mj_step1``, ``mj_step2``; ``table``: the world's height-field
    collision functions for MuJoCo's table during these calls (as _tyres_c.step_trial); the arrays
    as for :func:`apply_soil`."""
    old0 = swap_entry(table[0], table[1])
    old1 = swap_entry(table[2], table[3])
    for k in range(substeps):
        if each or k == 0:
            call_step(fns[1], m, d)
            apply_soil(qvel, xmat, xipos, xfrc, f, st, tab)
            call_step(fns[2], m, d)
        else:
            call_step(fns[0], m, d)
    if table[1] != 0:
        swap_entry(table[0], old0)
    if table[3] != 0:
        swap_entry(table[2], old1)


def _entry(kernel):
    """``kernel``'s compiled entry point (no per-call type dispatch), as _tyres_c._entry."""
    try:
        (result,) = kernel.overloads.values()
        return result.entry_point
    except (AttributeError, ValueError):
        return kernel


#: :func:`step_trial_soil` without numba's per-call type dispatch
STEP = _entry(step_trial_soil)
