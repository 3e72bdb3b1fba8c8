"""The batched MuJoCo Warp engine's settings table, ``[sim.mujoco_warp]`` (SimConfig.mujoco_warp):
plain data, no Warp import, so a study's settings validate without the engine installed. The model
itself (contact tuning, MuJoCo steps per trial step) is the MuJoCo engine's, ``[sim.mujoco]``."""

from __future__ import annotations

from dataclasses import dataclass

from offroadbench.config import check_int
from offroadbench.errors import InputError

__all__ = ["MuJoCoWarpConfig"]


@dataclass(frozen=True, kw_only=True)
class MuJoCoWarpConfig:
    """The ``mujoco_warp`` engine's own settings (a study's ``[sim.mujoco_warp]`` table); the other
    engines ignore them."""

    device: str = "cpu"
    """Warp device the batch runs on: ``cpu`` (single-threaded; for correctness, never for speed)
    or ``cuda`` / ``cuda:N`` (an NVIDIA GPU)."""
    worlds: int = 64
    """The most worlds stepped together: a batch of trials runs this many at a time, each world
    taking the next pending trial when its own ends."""
    nconmax: int = 64
    """Contacts allocated per world (MuJoCo Warp's ``nconmax``; the batch holds ``worlds`` times as
    many, shared). A Husky on a height field has 2.66 a touching wheel on average on MuJoCo (6 in 15 %
    of the wheel-steps; offroadbench.sim.engines.mujoco.world, 'Contact'), plus the chassis' when it
    strikes: a world's contacts on those missions (MuJoCo engine) were 6.9 a step on average, 16 at
    the 99th percentile, 57 at most."""
    njmax: int = 256
    """Constraint rows allocated per world (MuJoCo Warp's ``njmax``)."""
    cuda_graph: bool = True
    """On a CUDA device, capture the trial step (its MuJoCo steps, tyre or soil law and contact sums)
    once as a CUDA graph and launch that graph, instead of issuing its kernel launches one by one
    from Python; ignored on ``cpu``. Not yet run on a GPU here (docs/mujoco-warp.md): ``false`` is
    the way back if a GPU refuses the capture."""

    def __post_init__(self) -> None:
        dev = self.device
        if not isinstance(dev, str) or not (dev in ("cpu", "cuda") or (dev.startswith("cuda:") and dev[5:].isdigit())):
            raise InputError(f"MuJoCoWarpConfig.device = {dev!r}: allowed 'cpu', 'cuda' or 'cuda:N'")
        check_int(self, "worlds", self.worlds, lo=1, hi=1_000_000)
        check_int(self, "nconmax", self.nconmax, lo=8, hi=100_000)
        check_int(self, "njmax", self.njmax, lo=8, hi=100_000)
        if not isinstance(self.cuda_graph, bool):
            raise InputError(f"MuJoCoWarpConfig.cuda_graph = {self.cuda_graph!r}: allowed true or false")
