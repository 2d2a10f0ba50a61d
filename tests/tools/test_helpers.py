"""tests/helpers.py: a child is waited for without a wall deadline, and stopped only as a
runaway (CPU time) or a deadlock (no CPU time at all for a while)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests import helpers


def test_run_returns_what_subprocess_run_returns():
    p = helpers.run([sys.executable, "-c", "import sys; print(sys.stdin.read()[::-1]); "
                     "sys.exit(3)"], input="abc", capture_output=True, text=True)
    assert (p.returncode, p.stdout, p.stderr) == (3, "cba\n", "")
    with pytest.raises(subprocess.CalledProcessError):
        helpers.run([sys.executable, "-c", "raise SystemExit(1)"], check=True)


def test_a_runaway_child_and_its_children_are_killed():
    spin = "import subprocess, sys; subprocess.run([sys.executable, '-c', 'while True: pass'])"
    with pytest.raises(AssertionError, match="runaway child killed"):
        helpers.run([sys.executable, "-c", spin], capture_output=True, cpu_limit=1.0)


def test_a_child_without_cpu_progress_is_a_deadlock():
    with pytest.raises(AssertionError, match="deadlocked child killed"):
        helpers.run([sys.executable, "-c", "import time; time.sleep(60)"], stall_s=1.0)


def test_wait_until_reports_a_child_that_ended():
    proc = subprocess.Popen([sys.executable, "-c", "print('bye')"], stdout=subprocess.PIPE,
                            text=True)
    with pytest.raises(AssertionError, match="bye"):
        helpers.wait_until(lambda: False, proc, "never")
