"""Path planners: a registry of functions ``plan(problem, cfg) -> (N, 2) waypoints``.

A planner receives a :class:`~offroadbench.navigation.problem.PlanningProblem` (the heightmap, the
study's closed roughness-class map, start, goal, the mission border and the vehicle's envelope)
and its own frozen config, and returns waypoints in map metres (x, y), the first exactly the start
and the last exactly the goal. The trial runner follows them with pure pursuit
(offroadbench.sim.trial.controller: ``PathTracker``).

Registering a planner:

* in the same process, with the decorator (``needs``: what it reads of the problem beyond the
  mission, a subset of ``{"classes", "vehicle"}``; both by default, see offroadbench.navigation.drivers)::

      @register_planner("mine", config=MyConfig, needs=frozenset({"vehicle"}))
      def plan_mine(problem: PlanningProblem, cfg: MyConfig) -> np.ndarray: ...

* from an installed package, with an entry point in its ``pyproject.toml``::

      [project.entry-points."offroadbench.planners"]
      mine = "my_package:PLANNER"        # a PlannerSpec (or a plan function)

Then ``[planner] name = "mine"`` (plus the config's fields) in a study, ``drive --planner mine``
and ``TraverseEnv(planner="mine")`` use it. ``examples/offroadbench-example-planner`` is a
complete package.

Built-in planners, one module each (what each optimises and what it cannot see is in its docstring):

- ``straight`` (:mod:`.straight`): the paper's start-goal line (Majhor & Bos 2023, Sec. 2.3).
- ``astar`` (:mod:`.astar`): 8-connected A* on a hazard cost grid, string-pulled.
- ``lattice`` (:mod:`.lattice`): hybrid A* over arcs of bounded curvature (a state lattice in heading).

``astar`` and ``lattice`` share the cost grid of offroadbench.navigation.costmap. The registry,
:class:`PlannerChoice` (what a ``[planner]`` table names) and the checked :func:`plan` live in
offroadbench.navigation.drivers, the problem types in offroadbench.navigation.problem; this package
re-exports them, so ``from offroadbench.navigation.planners import PLANNERS, PlanningProblem, plan``
keeps working.
"""

from offroadbench.navigation.costmap import HAZARDS, CostConfig, CostGrid, cost_grid, footprint_hazard
from offroadbench.navigation.drivers import (
    PLANNERS,
    NoConfig,
    PlannerChoice,
    PlannerSpec,
    entry_config,
    plan,
    planner_from_table,
    register_planner,
)
from offroadbench.navigation.planners.astar import AStarConfig, plan_astar
from offroadbench.navigation.planners.lattice import LatticeConfig, plan_lattice
from offroadbench.navigation.planners.straight import plan_straight
from offroadbench.navigation.problem import PlanningProblem, VehicleEnvelope

__all__ = [
    "VehicleEnvelope",
    "PlanningProblem",
    "NoConfig",
    "PlannerSpec",
    "PLANNERS",
    "register_planner",
    "PlannerChoice",
    "planner_from_table",
    "plan",
    "entry_config",
    "CostConfig",
    "AStarConfig",
    "LatticeConfig",
    "CostGrid",
    "cost_grid",
    "footprint_hazard",
    "HAZARDS",
    "plan_straight",
    "plan_astar",
    "plan_lattice",
]
