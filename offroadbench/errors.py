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
