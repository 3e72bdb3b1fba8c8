"""Getting from A to B without a physics engine: missions, planners, policies, failure rules, metrics.

* ``missions``: the mission sampler (Majhor & Bos 2023, Sec. 2.3);
* ``problem``: the planning problem and the vehicle's envelope, what every driver is given;
* ``drivers``: what a ``[planner]`` table names, a planner or a policy: both registries, what each
  entry needs from the trial, the checked ``plan`` and ``make_policy``;
* ``costmap``: the cost grid and footprint hazard of the terrain-aware planners;
* ``planners/``: ``straight``, ``astar``, ``lattice``, one module each; ``policies/``: ``reactive``;
* ``observation``: what a policy (and the Gymnasium env's agent) sees;
* ``rules``: the failure rules (tipped, stuck, timeout, off_map); ``metrics``: the paper's metrics.

Imports run one way: problem <- costmap, drivers <- planners, policies. Nothing in this package
imports pybullet; ``offroadbench.sim`` drives what is planned here.
"""
