"""Closed-loop policies: observation -> (v, omega), stress-tested by a study exactly like a planner.

A policy sees what an agent of ``offroadbench/Traverse-v0`` sees (offroadbench.navigation.observation:
the goal in the heading frame, attitude, rates, body velocity and a height patch) and returns the
env's action, ``(v, omega)`` in m/s and rad/s, clipped to the vehicle's limits. The trial runner
calls it at the control rate and applies the same failure rules and metrics as for a planned path,
so ``[planner] name = "reactive"`` in a study puts a policy on the same missions as ``straight``.

A policy is an object with ``reset(problem)`` (called once per mission with the
:class:`~offroadbench.navigation.problem.PlanningProblem`: a trained RL policy ignores it, a
model-predictive controller may read the map from it) and ``act(observation) -> (v, omega)``.
The registry holds :class:`PolicySpec` entries whose ``make(cfg, context)`` builds one, and what
it needs from the trial (``needs``, see offroadbench.navigation.drivers, where the registry, the
protocol and :class:`PolicyContext` live; this package re-exports them). Register in the same
process with :func:`register_policy`, or from an installed package with an entry point::

    [project.entry-points."offroadbench.policies"]
    my-rl = "my_package:POLICY"           # a PolicySpec

A stable-baselines3 model fits in a few lines: ``act = lambda obs: model.predict(obs, deterministic=True)[0]``.

Built in, one module each: ``reactive`` (:mod:`.reactive`), ``mppi`` (:mod:`.mppi`), ``ppo``
(:mod:`.ppo`: an MLP trained with PPO, shipped weights, numpy inference).
"""

from offroadbench.navigation.drivers import POLICIES, Policy, PolicyContext, PolicySpec, make_policy, register_policy
from offroadbench.navigation.policies.mppi import MppiConfig, MppiPolicy
from offroadbench.navigation.policies.ppo import PpoConfig, PpoPolicy
from offroadbench.navigation.policies.reactive import ReactiveConfig, ReactivePolicy

__all__ = ["Policy", "PolicyContext", "PolicySpec", "POLICIES", "register_policy", "make_policy",
           "ReactiveConfig", "ReactivePolicy", "MppiConfig", "MppiPolicy", "PpoConfig", "PpoPolicy"]
