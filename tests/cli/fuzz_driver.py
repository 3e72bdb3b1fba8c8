"""Run many CLI invocations cheaply: import the CLI once, then fork one real process per case.

Each child is a fresh process with its own file descriptors 1 and 2 (redirected to files), a
working directory, and the same top-level behaviour as the ``offroadbench`` console script
(``sys.exit(main(argv))``, an uncaught exception printing its traceback and exiting 1). The
parent snapshots the directory tree before and after each case, so a file left behind or a
file changed by a failed command is seen.

Usage: python fuzz_driver.py CASES.json BASE_DIR  ->  JSON list of results on stdout.
"""

from __future__ import annotations

import json
import os
import signal
import sys
import time
import traceback
from pathlib import Path

LIMIT_S = 30.0


def snapshot(base: Path) -> dict[str, tuple[int, int]]:
    out = {}
    for root, dirs, files in os.walk(base):
        for name in dirs + files:
            p = Path(root) / name
            try:
                st = p.lstat()
            except OSError:
                continue
            out[str(p.relative_to(base))] = (st.st_size, st.st_mtime_ns if p.is_file() else 0)
    return out


def run_case(argv: list[str], cwd: Path, logs: Path, env: dict[str, str]) -> dict:
    out_path, err_path = logs / "out.txt", logs / "err.txt"
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:  # the child: behave as the console script does
        code = 1
        try:
            os.chdir(cwd)
            os.environ.update(env)
            for fd, path in ((1, out_path), (2, err_path)):
                f = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
                os.dup2(f, fd)
                os.close(f)
            from offroadbench.cli import main

            try:
                code = main(argv)
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            except BaseException:  # what the interpreter does with an uncaught exception
                traceback.print_exc()
                code = 1
        finally:
            for stream in (sys.stdout, sys.stderr):
                try:
                    stream.flush()
                except Exception:
                    pass
            os._exit(code if isinstance(code, int) else 1)
    status = None
    while time.monotonic() - t0 < LIMIT_S:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        time.sleep(0.01)
    else:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        status = None
    elapsed = time.monotonic() - t0
    return {
        "code": None if status is None else os.waitstatus_to_exitcode(status),
        "timed_out": status is None,
        "elapsed_s": elapsed,
        "stdout": out_path.read_text(errors="replace"),
        "stderr": err_path.read_text(errors="replace"),
    }


def main() -> None:
    cases = json.loads(Path(sys.argv[1]).read_text())
    base = Path(sys.argv[2])
    logs = Path(sys.argv[3])
    # warm the interpreter the children are forked from: the CLI and what it imports
    os.environ.setdefault("MPLBACKEND", "Agg")
    import importlib

    from offroadbench.cli import build_parser
    from offroadbench.sim import import_pybullet_quietly

    import_pybullet_quietly()
    build_parser()  # imports every command module
    for name in ("pandas", "scipy.ndimage", "PIL.Image", "matplotlib.figure", "offroadbench.study",
                 "offroadbench.study.runner", "offroadbench.terrain.recipe", "offroadbench.analysis.describe",
                 "offroadbench.io.png16", "offroadbench.io.export", "offroadbench.sim.trial.batch", "offroadbench.sim.trial.vehicle"):
        importlib.import_module(name)
    results = []
    for case in cases:
        before = snapshot(base)
        res = run_case(case["argv"], base / case.get("cwd", "."), logs, case.get("env", {}))
        after = snapshot(base)
        res["added"] = sorted(set(after) - set(before))
        res["removed"] = sorted(set(before) - set(after))
        res["changed"] = sorted(k for k in set(before) & set(after) if before[k] != after[k] and before[k][1])
        res["id"] = case["id"]
        results.append(res)
    print(json.dumps(results))


if __name__ == "__main__":
    main()
