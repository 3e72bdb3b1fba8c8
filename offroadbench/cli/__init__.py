"""The ``offroadbench`` command line. Each command group lives in its own module with a
``register(subparsers)`` function; ``main`` turns every InputError into one line on stderr
and exit status 2."""

from __future__ import annotations

import argparse
import errno
import importlib
import logging
import os
import signal
import sys

from offroadbench.errors import InputError, PluginError, StudyError, TrialFault

#: command modules under offroadbench.cli, each with register(subparsers)
COMMAND_MODULES = ("terrain", "study", "search", "drive", "export", "vehicle", "soil", "config", "suite")

EXIT_BAD_INPUT = 2
EXIT_FAILED = 1


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


class _Parser(argparse.ArgumentParser):
    """argparse that exits with status 2 and one line (its default prints usage too)."""

    def error(self, message: str) -> None:  # noqa: D401
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(EXIT_BAD_INPUT)


def build_parser() -> argparse.ArgumentParser:
    from offroadbench import __version__

    parser = _Parser(prog="offroadbench", description="Benchmark off-road ground vehicles on synthetic terrain.")
    parser.add_argument("--version", action="version", version=f"offroadbench {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in COMMAND_MODULES:
        importlib.import_module(f"offroadbench.cli.{name}").register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    # process-wide choices belong to the application, not the library: the figure backend
    # (the library draws on Figure objects and never picks one) and pybullet's banner
    os.environ.setdefault("MPLBACKEND", "Agg")
    from offroadbench.sim import import_pybullet_quietly

    import_pybullet_quietly()
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.INFO if args.verbose else logging.WARNING
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    # Dask reads its log level when distributed is imported (here and in the workers it starts)
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "info" if args.verbose else "critical")  # a worker's ERRORs: the study says it in one line
    logging.getLogger("distributed").setLevel(level)
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        sys.stderr.write(f"offroadbench: error: {_one_line(exc)}\n")
        return EXIT_BAD_INPUT
    except StudyError as exc:
        sys.stderr.write(f"offroadbench: study stopped: {_one_line(exc)}\n")
        return EXIT_FAILED
    except PluginError as exc:
        sys.stderr.write(f"offroadbench: plug-in fault: {_one_line(exc)}\n")
        return EXIT_FAILED
    except TrialFault as exc:  # a trial outside a study (drive, checks): thrown while settling, past its limit
        sys.stderr.write(f"offroadbench: trial fault: {_one_line(exc)}\n")
        return EXIT_FAILED
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM during a run (errors.Stopped): the same one line
        signum = getattr(exc, "signum", signal.SIGINT)
        word = "terminated" if signum == signal.SIGTERM else "interrupted"
        detail = f"; {_one_line(exc)}" if str(exc) else ""
        sys.stderr.write(f"offroadbench: {word}{detail}\n")
        return 128 + signum
    except MemoryError as exc:  # past the up-front estimate (--force, or an estimate too low)
        sys.stderr.write(f"offroadbench: error: out of memory ({_one_line(exc) or 'MemoryError'}); make the work "
                         "smaller or give it more memory\n")
        return EXIT_FAILED
    except BrokenPipeError:
        # the reader (e.g. `| head`) went away: stop quietly, as command-line tools do
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except OSError as exc:  # after BrokenPipeError, itself an OSError
        if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
            raise
        where = f" writing {os.fsdecode(exc.filename)}" if exc.filename else ""
        sys.stderr.write(f"offroadbench: error: no space left on the device{where}; nothing was left half written\n")
        return EXIT_FAILED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
