"""Child processes that never outlive their test, and the handshake that says when to signal one.

A Ctrl-C test starts a long run in a child and sends it SIGINT once the child says it is inside
the run: the child writes a line to a pipe its test made (the file descriptor named by the
environment variable HANDSHAKE) at the point the test waits for, e.g. when its run starts
watching for Ctrl-C (`announce_when_watching`) or at a point of its own (`announce`); the test
waits for that line (`Child.says`). No clock decides anything: a busy machine only makes the
wait longer. The one timeout, HANG, guards against a child that hangs; it is not a speed claim.

If the child does not stop (the behaviour under test is broken, or SIGINT is ignored),
`communicate(timeout=HANG)` raises and the child would go on computing after the test failed:
it is killed here instead."""

from __future__ import annotations

import os
import select
import signal
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

HANDSHAKE = "NEMC_TEST_HANDSHAKE"  # the child's end of the pipe, a file descriptor number
HANG = 600.0  # seconds: only a hung child waits this long (a guard, never a speed claim)
WATCHING = "watching for Ctrl-C"  # announce_when_watching's line
TESTS = Path(__file__).resolve().parent


class Child(subprocess.Popen):
    """A child process whose handshake lines its test can wait for."""

    handshake = -1  # the test's end of the pipe
    heard = b""

    def says(self, line: str) -> None:
        """Wait until the child announces LINE; fail (with its output) if it ends first."""
        while b"\n" not in self.heard:
            ready, _, _ = select.select([self.handshake], [], [], HANG)
            assert ready, f"the child hung: no {line!r} after {HANG:g} s"
            data = os.read(self.handshake, 4096)
            if not data:  # the child ended without saying it
                out, err = self.communicate(timeout=HANG)
                raise AssertionError(f"the child ended (status {self.returncode}) before "
                                     f"saying {line!r}:\n{out}\n{err}")
            self.heard += data
        said, self.heard = self.heard.split(b"\n", 1)
        assert said.decode() == line, f"the child said {said!r}, not {line!r}"


@contextmanager
def child_process(command: list[str], **options: Any) -> Iterator[Child]:
    """Child(command, **options) with a handshake pipe (and tests/ on its PYTHONPATH, for
    `import children`), killed if it still runs when the block ends."""
    read_end, write_end = os.pipe()
    env = dict(options.pop("env", None) or os.environ)
    env[HANDSHAKE] = str(write_end)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(TESTS), env.get("PYTHONPATH")) if p)
    try:
        child = Child(command, pass_fds=(write_end,), env=env, **options)
    finally:
        os.close(write_end)  # the child's copy only: its end closes when it exits
    child.handshake = read_end
    try:
        yield child
    finally:
        if child.poll() is None:
            child.kill()
            child.communicate()
        os.close(read_end)


def interrupted(child: Child, line: str = WATCHING) -> tuple[Any, Any]:
    """SIGINT sent to CHILD once it says LINE; its output (stdout, stderr) once it has ended."""
    child.says(line)
    child.send_signal(signal.SIGINT)
    return child.communicate(timeout=HANG)


# ---- in the child ----------------------------------------------------------------------------


def announce(line: str) -> None:
    """Say LINE to the test waiting in Child.says."""
    os.write(int(os.environ[HANDSHAKE]), (line + "\n").encode())


def announce_when_watching(line: str = WATCHING) -> None:
    """Announce LINE the first time a run of this process starts watching for Ctrl-C: nemc's
    guard armed in the main thread (runs.interrupt_flag entered: from then on SIGINT sets the
    run's flag, and the run returns what it has). A scipy run and an ensemble arm it as they
    start, a single run in C once it has done some work (runs.arm_interrupts)."""
    from nemc.runtime import runs

    enter = runs.interrupt_flag.__enter__
    said: list[bool] = []

    def entered(guard: runs.interrupt_flag) -> Any:
        flag = enter(guard)
        if guard.guarded and not said:
            said.append(True)
            announce(line)
        return flag

    runs.interrupt_flag.__enter__ = entered  # type: ignore[method-assign]
