"""One run of a study or a failure search in its run directory (issue 43).

:class:`RunSession` owns the run directory while a ``study run`` or ``search run`` goes: the lock
(:class:`~offroadbench.study.store.RunLock`), the store and its meta data (a resume whose inputs
changed is refused by :meth:`Store.init_meta`), the session row and its final status (``finished``,
``interrupted``, ``failed``; a session found still ``running`` by the next one is ``killed``), the
faults, the telemetry files, the progress and the line said on a stop. A study
(offroadbench.study.runner) and a search (offroadbench.search.runner) are two ways of feeding it
terrain tasks::

    with RunSession(run_dir, meta, kind="study", total=n, executor=ex, executor_name="local") as session:
        session.run(plan_tasks(study, plans, session.stored_keys()), trial_fn)
    summary = session.summary()

Whatever fed it, a faulted trial is done: it is stored as a fault (``faults`` table, no outcome)
and not run again, unless the run asks for it (``retry_faults``: every stored fault is run once
more by this session). A run that fails before its first trial is stored removes the store and the
directories it made; one that fails later keeps every committed trial and its error says how to
resume; one stopped by a signal raises :class:`~offroadbench.errors.RunInterrupted` whose message
is the one line to say.
"""

from __future__ import annotations

import errno
import logging
import signal
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from offroadbench import resources, stop
from offroadbench.errors import InputError, RunInterrupted, StudyError
from offroadbench.io.outputs import missing_dirs
from offroadbench.progress import ProgressFn, report
from offroadbench.study.execution.tasks import TerrainBuilt, TerrainTask, TrialDone, TrialFaulted, TrialFn, keeps_telemetry
from offroadbench.study.fingerprint import platform_fingerprint
from offroadbench.study.store.results import telemetry_paths
from offroadbench.study.store.store import RunLock, Store, remove_stale_temp_files, remove_store

log = logging.getLogger(__name__)

__all__ = ["FaultCount", "RunRates", "RunSession", "RunSummary", "code_version", "remove_dirs", "repair_telemetry",
           "save_trial_telemetry"]


@dataclass(frozen=True)
class FaultCount:
    """The faults of one kind (offroadbench.study.execution.tasks.TrialFaulted.kind) stored by one run."""

    kind: str
    count: int
    example: str
    """The reason of the first of them (one line)."""

    def describe(self) -> str:
        return f"{self.count} x {self.example}"


class RunRates:
    """What a run's summary derives from its ``ran``, ``wall_s`` and ``new_faults`` (RunSummary, and the
    failure search's SearchSummary)."""

    ran: int
    wall_s: float
    new_faults: tuple[FaultCount, ...]

    @property
    def faulted(self) -> int:
        """Trials this call stored as faults."""
        return sum(f.count for f in self.new_faults)

    @property
    def trials_per_s(self) -> float:
        """Trials this call stored (outcomes and faults) per wall second."""
        return (self.ran + self.faulted) / self.wall_s if self.wall_s > 0 else float("nan")


@dataclass(frozen=True)
class RunSummary(RunRates):
    """What one run (``run_study``, and the counts of ``run_search``) did."""

    run_dir: Path
    total: int
    """Trials in the whole study."""
    done: int
    """Trials stored after this call."""
    ran: int
    """Trials run by this call."""
    successes: int
    """Successful trials stored after this call."""
    wall_s: float
    """Wall time of this call, seconds."""
    faults: int = 0
    """Trials stored as faults after this call (no outcome: past their limit, thrown while
    settling; excluded from every statistic; a resume skips them unless ``retry_faults``)."""
    new_faults: tuple[FaultCount, ...] = ()
    """The faults this call stored, one entry per kind, most first."""

    @property
    def complete(self) -> bool:
        """Whether every trial of the study is stored, as a trial or as a fault."""
        return self.done + self.faults >= self.total


def save_trial_telemetry(run_dir: str | Path, cell: int, terrain: int, mission: int, kept: Mapping[str, Any]) -> list[str]:
    """Write a kept trial's 20 Hz telemetry and planned path (atomic Parquet files); returns
    their paths relative to ``run_dir``, as the trial's row in the store names them. A file that
    cannot be written (a full disk) is a StudyError naming it; the trial is then not stored."""
    from offroadbench.io.telemetry import save_telemetry

    tel_path, path_path = telemetry_paths(run_dir, cell, terrain, mission)
    try:
        tel_path.parent.mkdir(exist_ok=True)
        save_telemetry(kept["telemetry"], tel_path, sweep=False)  # the run swept its directory at the start
        xy = kept["path_xy"]
        save_telemetry({"x_m": xy[:, 0], "y_m": xy[:, 1]}, path_path, sweep=False)
    except (OSError, InputError) as exc:
        if isinstance(exc, InputError):
            why = str(exc)
        else:
            why = "no space left on the device" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
        raise StudyError(f"cannot write the telemetry of cell {cell}, terrain {terrain}, mission {mission} "
                         f"in {tel_path.parent} ({why})") from None
    return [str(q.relative_to(run_dir)) for q in (tel_path, path_path)]


def repair_telemetry(store: Store, run_dir: Path, setting: str) -> list[tuple[int, int, int]]:
    """Drop the stored trials whose telemetry files are missing, so this run does them again.

    A row names its files (schema 2); a row of a schema-1 store (which committed the row before
    writing the files) is expected to have them when ``setting`` keeps its telemetry. Returns the
    (cell, terrain, mission) keys dropped."""
    missing = []
    for cell, terrain, mission, success, files, run_id in store.trial_telemetry():
        if files is None:
            files = ([str(q.relative_to(run_dir)) for q in telemetry_paths(run_dir, cell, terrain, mission)]
                     if keeps_telemetry(setting, success) else [])
        if any(not (run_dir / f).is_file() for f in files):
            missing.append((cell, terrain, mission, run_id))
    if missing:
        log.warning("%s: %d stored trial(s) have no telemetry files; running them again", run_dir, len(missing))
        store.drop_trials(missing)
    return [k[:3] for k in missing]


def code_version() -> str:
    """The package version, plus the git commit (and ``-dirty``) when the package is a git checkout."""
    import subprocess

    from offroadbench import __version__

    src = resources.package_dir()

    def git(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", "-C", str(src), *args], capture_output=True, text=True, timeout=10)

    try:
        # an installed copy inside some other checkout (e.g. a .venv in it) is not that checkout's code
        if git("ls-files", "--error-unmatch", "__init__.py").returncode != 0:
            return __version__
        head = git("rev-parse", "--short", "HEAD")
        if head.returncode != 0:
            return __version__
        dirty = git("status", "--porcelain", "--untracked-files=no", "--", ".")
        return f"{__version__}+git.{head.stdout.strip()}{'-dirty' if dirty.stdout.strip() else ''}"
    except (OSError, subprocess.SubprocessError):
        return __version__


def remove_dirs(made: list[Path]) -> None:
    """Remove the (empty) directories a failed run created, deepest first."""
    for d in made:
        try:
            (d / "telemetry").rmdir()
        except OSError:
            pass
        try:
            d.rmdir()
        except OSError:
            break


#: a stored fault's row instead, for a feeder that stores some faults as trials (None: a fault)
FaultRow = Callable[[TrialFaulted], "Mapping[str, Any] | None"]


class RunSession:
    """One run in ``run_dir`` (see the module docstring). ``meta`` is what the store records (a
    study's :func:`offroadbench.study.runner.study_meta`, a search's ``search_meta``; its
    ``version`` is the session's), ``kind`` is ``study`` or ``search`` (a run directory holds one
    kind), ``total`` the trials of the whole run, ``executor`` the executor object (its
    ``workers`` and ``run``) and ``executor_name`` its name in the session row. ``telemetry`` is
    the study's telemetry setting (for a schema-1 store's repair). ``progress(stored, total)``
    counts stored trials and faults; ``on_trial(row)`` sees each new trial's row; ``fault_row``
    may turn a fault into a stored trial row (a search's proposal whose terrain holds no mission).
    With ``retry_faults`` every stored fault is run once more; with ``retry_mark`` too, a retried
    trial's row records the fault it follows under that key (a search keeps its history as its
    proposals saw it)."""

    def __init__(self, run_dir: str | Path, meta: Mapping[str, Any], *, kind: str, total: int, executor: Any,
                 executor_name: str, telemetry: str = "failed", retry_faults: bool = False,
                 progress: ProgressFn | None = None, on_trial: Callable[[Mapping[str, Any]], None] | None = None,
                 fault_row: FaultRow | None = None, retry_mark: str | None = None) -> None:
        self.run_dir = Path(run_dir)
        self.meta, self.kind, self.total = meta, kind, total
        self.executor, self.executor_name = executor, executor_name
        self.telemetry, self.retry_faults = telemetry, retry_faults
        self.progress, self.on_trial, self.fault_row = progress, on_trial, fault_row
        self.retry_mark = retry_mark
        self._retried: dict[tuple[int, int, int], str] = {}  # with retry_mark: key -> the fault's reason
        self.store: Store | None = None
        self.run_id: int | None = None
        self.ran = 0
        self.stored = 0
        self._faults: dict[str, list] = {}  # kind -> [count, first reason]
        self._lock: RunLock | None = None
        self._made: list[Path] = []
        self._running = False
        self._t0 = time.perf_counter()
        self._summary: RunSummary | None = None

    # ------------------------------------------------------------------ opening
    def __enter__(self) -> "RunSession":
        self._t0 = time.perf_counter()
        try:
            self._open()
        except RunInterrupted:
            raise
        except KeyboardInterrupt as exc:  # before the session row: nothing of this run is stored
            raise RunInterrupted(self.stop_line(), signum=getattr(exc, "signum", signal.SIGINT)) from None
        return self

    def _open(self) -> None:
        """Take the lock, open (or make) the store, check and record the meta data and the session."""
        self._made = missing_dirs(self.run_dir)  # the output-path policy (offroadbench.io.outputs)
        try:
            self._lock = RunLock(self.run_dir).acquire()  # "a study is running in DIR (pid N)" while another holds it
        except BaseException:
            remove_dirs(self._made)
            raise
        try:
            remove_stale_temp_files(self.run_dir)
            self.store = Store(self.run_dir, create=True)
        except BaseException:
            self._lock.release()
            remove_dirs(self._made)
            raise
        try:
            self._prepare()
        except BaseException as exc:
            self._finish(exc)  # a stop after the session's row was written: the row says so
            replacement = self._close(exc)
            if replacement is not None:
                raise replacement from None
            raise

    def _prepare(self) -> None:
        """Check and record the meta data, close the killed sessions, open this one."""
        store = self.store
        held = store.meta()
        if held and held.get("kind", "study") != self.kind:
            raise InputError(f"{self.run_dir} holds a {held.get('kind', 'study')}, not a {self.kind}; "
                             "use another --out directory")
        store.init_meta(self.meta)
        store.mark_killed_sessions()  # we hold the lock: a session still "running" was killed
        store.ensure_faults_table()
        if self.retry_faults:
            if self.retry_mark is not None:
                self._retried = {(r[0], r[1], r[2]): r[5] for r in store.fault_rows()}
            n = store.clear_faults()
            if n:
                log.info("%s: trying %d faulted trial(s) again", self.run_dir, n)
        repair_telemetry(store, self.run_dir, self.telemetry)
        self.stored = store.counts()[0] + len(store.faulted_trials())
        report(self.progress, self.stored, self.total)
        with stop.deferred():  # a Ctrl-C between the row's insert and keeping its id would leave it "running"
            self.run_id = store.start_run(self.executor_name, self.executor.workers, self.meta.get("version", ""),
                                          platform_fingerprint())

    def stored_keys(self) -> set[tuple[int, int, int]]:
        """(cell, terrain, mission) of every trial stored, as an outcome or as a fault."""
        return self.store.done_trials() | self.store.faulted_trials()

    # ------------------------------------------------------------------ running
    def run(self, tasks: Sequence[TerrainTask], trial_fn: TrialFn | None) -> None:
        """Run ``tasks`` on the executor, storing every message as it arrives."""
        self._running = True
        if tasks:
            self.executor.run(tasks, trial_fn, self.handle)

    def handle(self, msg: TerrainBuilt | TrialDone | TrialFaulted) -> None:
        """Store one message of a task (the executors call this in this process)."""
        stop.check()  # a stop asked while a message was on its way (the inline executor has no loop of its own)
        if isinstance(msg, TerrainBuilt):
            self.store.add_terrain(msg.cell, msg.terrain, msg.terrain_seed, msg.stats)
        elif isinstance(msg, TrialFaulted):
            self._fault(msg)
        else:
            self._trial(msg)

    def _fault(self, msg: TrialFaulted) -> None:
        row = self.fault_row(msg) if self.fault_row is not None else None
        if row is not None:
            self._add_trial(msg, row, [])
            return
        if self.store.add_fault(msg.cell, msg.terrain, msg.mission, msg.terrain_seed, msg.mission_seed, msg.reason,
                                run_id=self.run_id):
            # one line per kind at the end (RunSummary.new_faults), not one per fault
            log.info("cell %d, terrain %d, mission %d: stored as a fault (%s)", msg.cell, msg.terrain, msg.mission,
                     msg.reason)
            self._faults.setdefault(msg.kind, [0, " ".join(msg.reason.split())])[0] += 1
            self.stored += 1
            report(self.progress, self.stored, self.total)

    def _trial(self, msg: TrialDone) -> None:
        files: list[str] = []
        if msg.kept is not None and not self.store.has_trial(msg.cell, msg.terrain, msg.mission):
            # the files first, then the row that names them: a stored trial has its telemetry
            files = save_trial_telemetry(self.run_dir, msg.cell, msg.terrain, msg.mission, msg.kept)
        row = msg.row
        retried = self._retried.get((msg.cell, msg.terrain, msg.mission))
        if retried is not None:  # the row says which fault it follows (retry_mark)
            row = {**row, self.retry_mark: retried}
        self._add_trial(msg, row, files)

    def _add_trial(self, msg: TrialDone | TrialFaulted, row: Mapping[str, Any], files: list[str]) -> None:
        if self.store.add_trial(msg.cell, msg.terrain, msg.mission, msg.terrain_seed, msg.mission_seed, row,
                                run_id=self.run_id, telemetry=files):
            self.ran += 1
            self.stored += 1
            if self.on_trial is not None:
                self.on_trial(row)
            report(self.progress, self.stored, self.total)

    # ------------------------------------------------------------------ closing
    def __exit__(self, exc_type, exc: BaseException | None, tb) -> bool:
        self._finish(exc)
        replacement = self._close(exc)
        if replacement is not None:
            raise replacement from None
        return False

    def _finish(self, exc: BaseException | None) -> None:
        """Close this session's row (when it was written): interrupted, failed or finished."""
        if self.run_id is None:
            return
        if isinstance(exc, KeyboardInterrupt):
            status, error = "interrupted", None
        elif exc is not None:
            status, error = "failed", f"{type(exc).__name__}: {exc}"
        else:
            status, error = "finished", None
        self.store.finish_run(self.run_id, status, error)

    def _close(self, exc: BaseException | None) -> BaseException | None:
        """Close the store and release the lock (a store that holds nothing after a failure is
        removed, with the directories this run made); returns the exception to raise instead of
        ``exc`` (with what was saved and how to resume), or None."""
        store = self.store
        try:
            done, successes = store.counts()
            faults = len(store.faulted_trials())
        finally:
            store.close()
        self._summary = RunSummary(
            run_dir=self.run_dir, total=self.total, done=done, ran=self.ran, successes=successes,
            wall_s=time.perf_counter() - self._t0, faults=faults,
            new_faults=tuple(FaultCount(k, n, why) for k, (n, why) in
                             sorted(self._faults.items(), key=lambda kv: -kv[1][0])))
        stored = done + faults
        if exc is not None and store.created and stored == 0:
            remove_store(self.run_dir)  # failed before any trial: leave no store (and no directory) behind
            self._lock.release()
            remove_dirs(self._made)
        else:
            self._lock.release()
        if isinstance(exc, KeyboardInterrupt):
            return RunInterrupted(self.stop_line(), signum=getattr(exc, "signum", signal.SIGINT))
        if self._running and isinstance(exc, (StudyError, InputError)) and stored:
            hint = (f"{stored} of {self.total} trials are saved in {self.run_dir}; "
                    "fix the cause and run the same command again to resume")
            return type(exc)(f"{exc}; {hint}")
        return None

    def stop_line(self) -> str:
        """What a stopped run says: the trials this run saved, those stored in all, how to resume."""
        s = self._summary
        if s is None:
            return (f"the run stopped before it ran a trial; every trial stored in {self.run_dir} is kept; "
                    "run the same command again to resume")
        if s.done + s.faults == 0:
            return f"no trial was saved in {self.run_dir}; run the same command again to start"
        return (f"{s.ran + s.faulted} trial(s) of this run saved, {s.done + s.faults} of {s.total} stored in "
                f"{self.run_dir}; run the same command again to resume")

    def summary(self) -> RunSummary:
        """What this session did (after it closed)."""
        if self._summary is None:
            raise RuntimeError("RunSession.summary() before the session closed")
        return self._summary
