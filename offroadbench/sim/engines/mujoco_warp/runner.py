"""Many trials at once: the trial runner's own per-tick code in every world of a MuJoCo Warp batch,
the physics of all worlds advanced together once per trial tick.

Each world of the batch is a slot: a greenlet (a coroutine of the ``greenlet`` package, switched
in this thread) that takes the next pending trial, drives it with
offroadbench.sim.trial.runner.drive_mission on its :class:`~offroadbench.sim.engines.mujoco_warp.world.WorldView`
(the spawn, planner, pure pursuit, speed loop, failure rules, telemetry and metrics: the very code
and row definitions of the one-world engines), and takes the next when it ends. A view only counts
its physics steps; when the trial reads the state (at its 20 Hz telemetry and control ticks) the
slot switches back to :class:`Lockstep`. Once every busy slot waits, the scheduler advances the
whole batch by the fewest steps any of them waits for, reads the state to the host once, and runs
the slots whose steps are done, one after the other in world order, each until it waits again.
Nothing runs concurrently, so no lock is needed: a trial reads and writes only its own world's
rows, and its row does not depend on which slot ran it, on the other trials of the batch or on
the number of worlds (on Warp's CPU device: bit for bit; offroadbench.sim.engines.mujoco_warp.kernels
on the order of the sums).

Greenlets and not threads: a switch costs well under a microsecond, where handing the GIL between
threads cost more than the trial code it ran (benchmarks/RESULTS.md, 'the batch's slots as greenlets').

A trial that raises (TrialFault: thrown while settling; PluginError: the planner failed) gives its
exception in place of its record; the other trials go on. An interrupt (KeyboardInterrupt,
SystemExit), in whichever slot it lands, ends the batch at once.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Sequence

from greenlet import greenlet

from offroadbench.progress import ProgressFn, report
from offroadbench.sim.engines.mujoco_warp.batch import WarpBatch
from offroadbench.sim.engines.mujoco_warp.model import BatchModel
from offroadbench.sim.engines.mujoco_warp.world import WorldView

__all__ = ["BatchRun", "Lockstep", "drive_batch", "drive_terrain_batched"]


class Lockstep:
    """The scheduler of a batch's slots: :meth:`run` runs one greenlet per slot and advances the
    batch whenever every busy slot waits for its counted steps (:meth:`wait`)."""

    def __init__(self, batch: WarpBatch) -> None:
        self.batch = batch
        self._hub: greenlet | None = None
        self._waiting: dict[int, WorldView] = {}
        self.advances = 0
        """Times the batch was advanced (each one host exchange)."""
        self.advance_s = 0.0
        """Wall seconds spent in those advances (the physics and the exchange)."""
        self.ticks = 0
        """Times a slot waited for its steps: the busy worlds' trial ticks (an idle world has none)."""

    def wait(self, view: WorldView) -> None:
        """Called in a slot: return once the batch has run ``view``'s counted steps."""
        self._waiting[view.world] = view
        self.ticks += 1
        self._hub.switch()

    def run(self, slots: Sequence[Any], between: Callable[[], None] | None = None) -> None:
        """Run ``slots`` (callables taking the slot's world index) to the end, one greenlet each;
        ``between()`` is called whenever every slot waits (and once at the end): the place to hand
        finished work on. An exception a slot lets out ends the run and is raised here."""
        self._hub = greenlet.getcurrent()

        def body(w: int, fn) -> None:
            try:
                fn(w)
            finally:
                self.batch.ctrl[w] = 0.0  # an idle world stands still

        lets = [greenlet(body) for _ in slots]
        ready = [(w, (w, fn)) for w, fn in enumerate(slots)]  # (slot, arguments of its first switch)
        while True:
            for w, args in ready:
                lets[w].switch(*args)  # returns when the slot waits or has ended (an exception: raised here)
            if between is not None:
                between()
            if not self._waiting:
                break
            steps = min(v.pending for v in self._waiting.values())
            t0 = time.perf_counter()
            self.batch.advance(steps)
            self.advance_s += time.perf_counter() - t0
            self.advances += 1
            ready = []
            for w in sorted(self._waiting):
                v = self._waiting[w]
                v.pending -= steps
                if v.pending == 0:
                    del self._waiting[w]
                    ready.append((w, ()))


@dataclass(frozen=True)
class BatchRun:
    """What :func:`drive_batch` returns: per terrain, per mission (in order), the TrialRecord or the
    exception the trial raised; and the batch's counts."""

    records: list[list[Any]]
    worlds: int
    """Worlds in the batch."""
    world_steps: int
    """MuJoCo steps summed over the worlds (idle worlds included), what the batch computed."""
    advances: int
    """Host exchanges (one per lock-step advance)."""
    advance_s: float = 0.0
    """Wall seconds inside those advances (the device's steps and the exchange); the rest of a
    batch's wall time is the host's: the trials' per-tick code in the slots and their scheduling."""
    ticks: int = 0
    """The busy worlds' trial ticks (each a slot's turn between two advances): what the host's
    time is spent on, where ``advances * worlds`` also counts the worlds whose trials have ended."""


def drive_batch(prepared: Sequence[Any], settings: Any, *, worlds: int | None = None,
                progress: ProgressFn | None = None,
                on_terrain: Callable[[int, list[Any]], None] | None = None) -> BatchRun:
    """Drive every mission of every prepared terrain (offroadbench.sim.trial.pipeline.PreparedTerrain,
    all on one grid) as trials of one MuJoCo Warp batch of at most ``worlds`` worlds (default
    ``[sim.mujoco_warp] worlds``), each trial as offroadbench.sim.trial.runner.drive_mission drives it.
    ``settings``: one TrialSettings for all, or one per prepared terrain (the study's cells: they may
    differ in all but the vehicle and the physics, which the batch's one model fixes).
    ``on_terrain(k, records)``: called in this thread as soon as every mission of terrain ``k`` has
    ended (while no slot runs), so a caller can store a terrain's trials before the batch ends."""
    from offroadbench.errors import InputError
    from offroadbench.sim.trial.runner import drive_mission

    prepared = list(prepared)
    per = list(settings) if isinstance(settings, (list, tuple)) else [settings] * len(prepared)
    sims = {p.sim_for(s.sim) for p, s in zip(prepared, per, strict=True)}
    if len(sims) != 1 or any(s.vehicle != per[0].vehicle for s in per):
        raise InputError("engine 'mujoco_warp': one batch's trials must share the vehicle, the physics settings, "
                         "the gravity and the soil")
    sim = sims.pop()
    if sim.tyre_model == "terramechanics" and any(p.soil_map_for(s.sim) is not None for p, s in zip(prepared, per, strict=True)):
        raise InputError("engine 'mujoco_warp' cannot read a soil map (its soil kernels hold one soil's tables); "
                         "set [sim] soil or use engine 'mujoco'")
    cfg = sim.mujoco_warp
    jobs = [(k, i) for k, p in enumerate(prepared) for i in range(len(p.missions))]
    records: list[list[Any]] = [[None] * len(p.missions) for p in prepared]
    if not jobs:
        return BatchRun(records, 0, 0, 0)
    for p, s in zip(prepared, per, strict=True):
        if "classes" in s.planner.needs and p.maps is None:
            raise InputError(f"planner {s.planner.name!r} needs the terrain's class map; prepare the terrain first")
    model = BatchModel([p.hm for p in prepared], per[0].vehicle, sim)
    n = min(len(jobs), worlds or cfg.worlds)
    batch = WarpBatch(model, [jobs[w][0] for w in range(n)], device=cfg.device, nconmax=cfg.nconmax, njmax=cfg.njmax,
                       cuda_graph=cfg.cuda_graph)
    sched = Lockstep(batch)
    queue = list(reversed(jobs))
    done = [0]
    left = [len(p.missions) for p in prepared]  # missions of each terrain not ended yet
    ended: list[int] = []  # terrains whose missions all ended, not yet handed to on_terrain

    def hand_on() -> None:
        while ended and on_terrain is not None:
            k = ended.pop(0)
            on_terrain(k, records[k])

    def slot(w: int) -> None:
        while True:
            if not queue:
                return
            k, i = queue.pop()
            p, s = prepared[k], per[k]
            view = WorldView(batch, w, k, sched.wait)
            try:
                rec = drive_mission(view, p.missions[i], settings=s,
                                    classes=p.maps.closed if "classes" in s.planner.needs else None)
            except (KeyboardInterrupt, SystemExit):
                raise
            except Exception as exc:  # noqa: BLE001 - the trial's outcome is its fault
                rec = exc
            records[k][i] = rec
            done[0] += 1
            left[k] -= 1
            if left[k] == 0:
                ended.append(k)
            report(progress, done[0], len(jobs))

    sched.run([slot] * n, between=hand_on)
    return BatchRun(records, n, batch.steps * n, sched.advances, sched.advance_s, sched.ticks)


def drive_terrain_batched(prepared: Any, settings: Any, *, progress: ProgressFn | None = None) -> Iterator[Any]:
    """offroadbench.sim.trial.pipeline.drive_terrain on this engine: the terrain's missions as one
    batch; one TrialRecord per mission in order, a trial's exception raised at its turn."""
    run = drive_batch([prepared], settings, progress=progress)
    for rec in run.records[0]:
        if isinstance(rec, BaseException):
            raise rec
        yield rec
