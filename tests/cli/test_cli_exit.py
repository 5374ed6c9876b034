"""The console script's exit (``rinscal.cli.main``): once the command has returned, the
streams are flushed, the exit handlers run and the process ends with the command's status,
without the interpreter's teardown; where a thread is still working, Python's own exit
waits for it as before."""

from __future__ import annotations

import subprocess
import sys

# an exit handler that says it ran, then the console script's entry point with the arguments
SCRIPT = """
import atexit, sys, threading, time
atexit.register(lambda: print("exit handler ran", flush=True))
mode = sys.argv.pop(1)
if mode == "thread":
    def late():
        time.sleep(0.3)
        print("thread finished", flush=True)
    threading.Thread(target=late).start()
sys.argv[0] = "rinscal"
from rinscal.cli import main
main()
"""


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", SCRIPT, *args], capture_output=True, text=True, timeout=120
    )


def test_a_command_that_succeeds_exits_0_with_its_output_and_exit_handlers() -> None:
    res = _run("plain", "--help")
    assert res.returncode == 0, res.stderr
    assert "Usage: rinscal" in res.stdout and "navigate" in res.stdout
    assert res.stdout.rstrip().endswith("exit handler ran")


def test_a_refused_command_keeps_its_status_and_message() -> None:
    res = _run("plain", "navigate", "--bogus")
    assert res.returncode == 2
    assert "No such option: --bogus" in res.stderr
    assert "exit handler ran" in res.stdout


def test_a_thread_still_working_is_waited_for() -> None:
    res = _run("thread", "--help")
    assert res.returncode == 0, res.stderr
    assert "thread finished" in res.stdout and "exit handler ran" in res.stdout
