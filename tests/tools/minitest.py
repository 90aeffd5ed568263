"""The Python tools' tests share this: a registry of test functions, `check`, and `main`, which
runs them and prints the summary lines tools/run-tests.sh counts (cmocka's wording)."""
import traceback

TESTS = []


def test(f):
    """Registers f as a test (run in definition order)."""
    TESTS.append(f)
    return f


def check(cond, what):
    if not cond:
        raise AssertionError(what)


def main():
    """Runs every registered test; returns the exit status (1 when any failed)."""
    passed = failed = 0
    for t in TESTS:
        try:
            t()
            passed += 1
            print(f"ok   {t.__name__}")
        except Exception:
            failed += 1
            print(f"FAIL {t.__name__}")
            traceback.print_exc()
    print(f"{passed} passed, {failed} failed")
    print(f"[  PASSED  ] {passed} test(s).")
    if failed:
        print(f"[  FAILED  ] {failed} test(s), listed above.")
    return 1 if failed else 0


def need_numpy(name):
    """numpy, or this test run again by Debian's /usr/bin/python3 (which has it: another python3
    found first on PATH may not); exit 1 when neither has it."""
    import os
    import sys
    try:
        import numpy
        return numpy
    except ImportError:
        deb = "/usr/bin/python3"
        if os.path.exists(deb) and os.path.realpath(sys.executable) != os.path.realpath(deb):
            os.execv(deb, [deb] + sys.argv)
        print(f"{name}: needs numpy (Debian python3-numpy)", file=sys.stderr)
        sys.exit(1)
