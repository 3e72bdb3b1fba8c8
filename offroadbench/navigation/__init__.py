"""Getting from A to B without a physics engine: missions, planners, metrics.

Nothing in this package imports pybullet; ``offroadbench.sim`` drives what is planned here.
"""
