#!/usr/bin/python3
"""tools/run-tests.sh bounds each test program's time: a program that hangs is stopped (SIGTERM,
then SIGKILL for one that ignores it), counted as one failed case, named under "failing
programs:" with "(timed out after N s)", and the run exits 1 with the usual summary line.
Fake test programs stand in for cmocka ones; every run here is itself bounded.

    python3 tests/tools/test_run_tests.py      prints "N passed, M failed", exit 1 on failure
"""
import os
import re
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, test  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
RUN_TESTS = os.path.join(ROOT, "tools", "run-tests.sh")

# A program that passes two cases, in cmocka's wording.
PASSING = """#!/bin/sh
echo '[==========] tests: Running 2 test(s).' >&2
echo '[  PASSED  ] 2 test(s).' >&2
"""
# One that hangs; one that hangs and ignores SIGTERM (only SIGKILL stops it).
SLEEPING = "#!/bin/sh\nsleep 60\n"
DEAF = "#!/bin/bash\ntrap '' TERM\nsleep 60 & wait; sleep 60\n"


def fake(d, name, text):
    path = os.path.join(d, name)
    with open(path, "w") as f:
        f.write(text)
    os.chmod(path, 0o755)
    return path


def run(progs, **env):
    e = dict(os.environ, **env)
    t0 = time.monotonic()
    r = subprocess.run([RUN_TESTS, *progs], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       text=True, env=e, timeout=40)
    return r, time.monotonic() - t0


@test
def hung_program_fails_with_its_bound_named():
    with tempfile.TemporaryDirectory() as d:
        ok = fake(d, "test_ok", PASSING)
        hung = fake(d, "test_hung", SLEEPING)
        r, dt = run([ok, hung], TEST_TIMEOUT="1")
        check(r.returncode == 1, f"exit {r.returncode}, not 1:\n{r.stdout}")
        check(dt < 20, f"took {dt:.1f} s with TEST_TIMEOUT=1")
        lines = r.stdout.splitlines()
        check(lines[-1] == "2 passed, 0 skipped, 1 failed", f"summary {lines[-1]!r}")
        check("failing programs:" in lines, f"no failing programs list:\n{r.stdout}")
        listed = lines[lines.index("failing programs:") + 1:-1]
        check(listed == [f"  {hung} (timed out after 1 s)"], f"listed {listed}")


@test
def program_ignoring_sigterm_is_killed():
    with tempfile.TemporaryDirectory() as d:
        deaf = fake(d, "test_deaf", DEAF)
        r, dt = run([deaf], TEST_TIMEOUT="1", TEST_KILL_AFTER="1")
        check(r.returncode == 1, f"exit {r.returncode}, not 1:\n{r.stdout}")
        check(dt < 20, f"took {dt:.1f} s with TEST_TIMEOUT=1 TEST_KILL_AFTER=1")
        check(f"  {deaf} (timed out after 1 s)" in r.stdout.splitlines(), r.stdout)
        check(r.stdout.splitlines()[-1] == "0 passed, 0 skipped, 1 failed", r.stdout)


@test
def fast_programs_are_untouched():
    with tempfile.TemporaryDirectory() as d:
        ok = fake(d, "test_ok", PASSING)
        r, _ = run([ok], TEST_TIMEOUT="5")
        check(r.returncode == 0, f"exit {r.returncode}:\n{r.stdout}")
        check("failing programs:" not in r.stdout, r.stdout)
        check(r.stdout.splitlines()[-1] == "2 passed, 0 skipped, 0 failed", r.stdout)


@test
def bad_timeout_is_refused():
    with tempfile.TemporaryDirectory() as d:
        ok = fake(d, "test_ok", PASSING)
        r, _ = run([ok], TEST_TIMEOUT="soon")
        check(r.returncode == 2, f"exit {r.returncode}, not 2:\n{r.stdout}")
        check(re.search(r"TEST_TIMEOUT", r.stdout) is not None, r.stdout)


if __name__ == "__main__":
    sys.exit(main())
