"""The physics engines, one package each (``pybullet``, ``mujoco``), behind the engine boundary
(offroadbench.sim.engine): only a package here imports its engine. ``base`` holds what they share.

Importing this package imports no engine.
"""
