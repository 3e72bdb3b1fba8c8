"""Error types. Every error caused by bad user input is an ``InputError`` (a ValueError):
the CLI turns it into one line on stderr and exit status 2."""


class InputError(ValueError):
    """Bad input that the user can fix: the message names the input and what is allowed."""


class StudyError(RuntimeError):
    """A study stopped for a reason other than bad input (a worker failed or died, a lost Dask
    scheduler, a hung trial); the trials committed so far stay in the store."""


class PluginError(RuntimeError):
    """A plug-in (planner, policy) broke its contract, e.g. a non-finite action or path, or the
    simulation state became non-finite: a fault, never a trial outcome. The message names the
    plug-in and the value; a study stops on it (its trial is not stored, so a resume runs it again)."""


class TrialFault(RuntimeError):
    """A trial that cannot give an outcome: the vehicle was thrown while it settled (a soil or
    vehicle far outside physical bounds), or the trial ran past its wall-clock limit. A study
    stores it as a fault (its ``faults`` table), never as an outcome, and goes on; no statistic
    counts it."""


class Stopped(KeyboardInterrupt):
    """A signal asked a run to stop (Ctrl-C is SIGINT, ``kill`` is SIGTERM): raised in the main
    thread by the command line's signal handlers; a run stops its workers and keeps every
    committed trial, as on Ctrl-C. ``signum`` is the signal's number."""

    def __init__(self, message: str = "", signum: int = 2) -> None:
        super().__init__(message)
        self.signum = signum


class RunInterrupted(Stopped):
    """A run of a study or a search stopped by a signal, after its session closed: the message is
    the one line saying what was saved and how to resume (offroadbench.study.session)."""
