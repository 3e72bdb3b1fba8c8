"""Which compiled kernels a MuJoCo world uses (offroadbench.sim.engines.mujoco.world): the tyre and
soil loops (``_tyres_c``, ``_soil_c``), the whole trial step (``_tyres_c.step_trial``) and the
height-field collision functions (``_hfield_c``), each with its fallback when numba is missing or
MuJoCo's struct layout does not check out."""

from __future__ import annotations

import importlib
import logging

from offroadbench.errors import InputError

__all__ = ["compiled_loop", "hfield_functions", "soil_step", "whole_step"]

log = logging.getLogger(__name__)


def compiled_loop(choice: str, kernels: str = "_tyres_c"):
    """offroadbench.sim.engines.mujoco._tyres_c (coulomb) or ``_soil_c`` (terramechanics) for
    ``[sim.mujoco] tyre_loop = choice``, or None for the Python loop (``auto`` without numba)."""
    if choice == "python":
        return None
    try:
        module = importlib.import_module(f"offroadbench.sim.engines.mujoco.{kernels}")
    except ImportError:
        if choice == "compiled":
            raise InputError("MuJoCoConfig.tyre_loop = 'compiled' needs numba: pip install 'offroadbench[fast]'") from None
        return None
    except RuntimeError as exc:  # numba installed but unable to compile or cache (e.g. no writable cache folder)
        if choice == "compiled":
            raise InputError(f"MuJoCoConfig.tyre_loop = 'compiled': numba cannot build the loop ({exc})") from None
        log.warning("the compiled tyre loop is unavailable (%s); using the Python loop", exc)
        return None
    return module


def whole_step(model, data, hfield):
    """What the compiled tyre loop needs to run a whole trial step in one call
    (offroadbench.sim.engines.mujoco._tyres_c.step_trial): the model's and data's addresses, MuJoCo's
    ``mj_step``, ``mj_step1``, ``mj_step2``, where the contacts are, and the collision-table entries
    that the step writes for the world's height-field functions (``hfield``, or none); None where
    MuJoCo's layout does not check out (offroadbench.sim.engines.mujoco._layout: the loop then runs
    its kernels between the bindings' MuJoCo calls)."""
    from offroadbench.sim.engines.mujoco import _layout

    lay = _layout.step_layout()
    if lay is None:
        return None
    entries = hfield.entries() if hfield is not None else (0, 0, 0, 0)
    return model._address, data._address, _layout.step_functions(), lay.as_tuple(), entries


def soil_step(model, data, hfield):
    """What the compiled soil loop needs to run a whole trial step in one call
    (offroadbench.sim.engines.mujoco._soil_step_c.step_trial_soil): (its entry point, the model's and
    data's addresses, MuJoCo's ``mj_step``, ``mj_step1``, ``mj_step2``, the collision-table entries
    of the world's height-field functions ``hfield``)."""
    from offroadbench.sim.engines.mujoco import _layout, _soil_step_c

    entries = hfield.entries() if hfield is not None else (0, 0, 0, 0)
    return _soil_step_c.STEP, model._address, data._address, _layout.step_functions(), entries


def hfield_functions(mode: str, model, data):
    """The world's height-field collision functions for ``[sim.mujoco] hfield_collision = mode``
    (offroadbench.sim.engines.mujoco._hfield_c.HFieldCollision), or None for MuJoCo's own: mode
    ``mujoco``, or numba missing or unable to build them (logged)."""
    if mode == "mujoco":
        return None
    try:
        from offroadbench.sim.engines.mujoco import _hfield_c
    except ImportError:
        log.warning("MuJoCoConfig.hfield_collision = %r needs numba (pip install 'offroadbench[fast]'): "
                    "MuJoCo's own height-field collision", mode)
        return None
    except RuntimeError as exc:  # numba installed but unable to compile or cache
        log.warning("the compiled height-field collision is unavailable (%s): MuJoCo's own", exc)
        return None
    return _hfield_c.HFieldCollision.for_world(mode, model, data)
