"""What every part of tools/fleet shares: the repository's root, the default plan and tours, the
launcher's messages (say; refuse and fail: one line, then exit), the step under way (NOW, step: for
the line an interruption prints) and small helpers (run_quiet, shown, oserror). Imports nothing of
the launcher's own, so that every fleet_*.py module can import it."""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_PLAN = os.path.join(ROOT, "host_sim/plans/apartment.svg")
DEFAULT_PATHS = os.path.join(ROOT, "host_sim/plans/apartment")


def say(msg):
    print(f"fleet: {msg}", flush=True)


def refuse(msg):
    """A bad option: one line, exit 2 (nothing has been written or moved yet)."""
    msg = "; ".join(l.strip() for l in str(msg).splitlines() if l.strip())
    print(f"tools/fleet: error: {msg} (see tools/fleet --help)", file=sys.stderr, flush=True)
    sys.exit(2)


def fail(msg, code=1):
    if code == 2:
        refuse(msg)
    print(f"fleet: {msg}", file=sys.stderr, flush=True)
    sys.exit(code)


# What the launcher is doing, for the line an interruption prints (interrupted()).
NOW = {"step": "checking the options", "run_dir": None, "moved": None, "partial": None, "robots": False}


def step(what, partial=None):
    """Names the step under way (and the file or folder it writes, incomplete if interrupted)."""
    NOW["step"], NOW["partial"] = what, partial


def run_quiet(cmd, timeout=None, cwd=None):
    return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=timeout, cwd=cwd)


def shown(path):
    """path as the user would type it: relative when under the working folder."""
    rel = os.path.relpath(path)
    return path if rel.startswith("..") else rel


def oserror(e):
    return f"{e.filename}: {e.strerror}" if e.filename and e.strerror else str(e)
