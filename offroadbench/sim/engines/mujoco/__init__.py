"""The MuJoCo engine (``engine = "mujoco"``): world.py (MuJoCoWorld, the TrialWorld, with its URDF ->
MJCF translation and tyre forces). Importing this package imports no engine; its modules do.
"""
