"""The batched MuJoCo engine on MuJoCo Warp (``engine = "mujoco_warp"``): many trials stepped
together as the worlds of one batch on a Warp device (``cpu`` or ``cuda``), each world on its own
terrain, the tyre or soil law a device kernel inside each MuJoCo step (docs/mujoco-warp.md).

model.py (the MuJoCo engine's model with one height field per terrain), kernels.py (the ``coulomb``
tyre law as Warp kernels), soil_kernels.py (the ``terramechanics`` soil law as Warp kernels),
batch.py (the batch on the device), world.py (one world as a TrialWorld, and the engine's own
world), runner.py (a batch of trials in lock step), settings.py (its
``[sim.mujoco_warp]`` table). Importing this package imports no engine; its modules do.
"""

from offroadbench.sim.engine import EngineCapabilities

#: what the MuJoCo Warp engine implements (offroadbench.sim.engine.engine_capabilities)
CAPABILITIES = EngineCapabilities(tyre_models=("coulomb", "terramechanics"), settings=("mujoco", "mujoco_warp"),
                                  batch_module="offroadbench.sim.engines.mujoco_warp.runner")
