"""The files of a fleet run as tools/fleet_report.py and tools/fleet_figures.py both use them: the
one-line error (ReportError), the maps a run has, the few readers both need (a .npy grid, a file
named in run.json, maps/map.yaml's scalars) and atomic writes (a temporary file beside the output,
renamed). Imported by both, it imports neither (no import cycle).
"""
import glob
import os
import re
import tempfile

TOOLS_DIR = os.path.dirname(os.path.realpath(__file__))
TMP_PREFIX = ".fleet_report."
MAP_KINDS = ("mean", "std", "single")


class ReportError(Exception):
    """A malformed input or an output that cannot be written: one line, exit 1."""


# ---- reading ---------------------------------------------------------------------------------

def load_npy(np, path):
    try:
        a = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as e:
        raise ReportError(f"{path}: not a readable .npy array ({e})")
    if not isinstance(a, np.ndarray) or a.ndim != 2 or a.shape[0] < 1 or a.shape[1] < 1:
        raise ReportError(f"{path}: expected a 2-D (H, W) grid, got shape {getattr(a, 'shape', '?')}")
    if a.dtype.kind not in "fiu":
        raise ReportError(f"{path}: expected a numeric grid, got dtype {a.dtype}")
    return a.astype(np.float64)


def resolve_tour(p, run_dir):
    if os.path.isabs(p):
        return p if os.path.isfile(p) else None
    for base in (os.getcwd(), os.path.join(run_dir, "..", ".."), os.path.dirname(TOOLS_DIR), run_dir):
        q = os.path.normpath(os.path.join(base, p))
        if os.path.isfile(q):
            return q
    return None


def yaml_scalars(path):
    """The `key: value` lines of a flat YAML file (comments skipped), as strings; {} when unreadable."""
    out = {}
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                m = re.match(r"^([A-Za-z_]+):\s*(.*?)\s*$", line)
                if m:
                    out[m.group(1)] = m.group(2)
    except OSError:
        pass
    return out


# ---- writing ---------------------------------------------------------------------------------

def clear_stale_temps(run_dir):
    """Removes the temporary files a killed report left behind (only this tool's own)."""
    for f in glob.glob(os.path.join(run_dir, TMP_PREFIX + "*.tmp")):
        try:
            os.unlink(f)
        except OSError:
            pass


def write_atomic(path, writer):
    """Calls writer(file object) on a temporary file beside path, then renames it over path."""
    d = os.path.dirname(os.path.abspath(path))
    try:
        fd, tmp = tempfile.mkstemp(dir=d, prefix=TMP_PREFIX + os.path.basename(path) + ".", suffix=".tmp")
    except OSError as e:
        raise ReportError(f"{path}: {e.strerror or e}")
    try:
        with os.fdopen(fd, "wb") as f:
            writer(f)
            f.flush()
            os.fsync(f.fileno())
        if os.path.isdir(path):
            raise ReportError(f"{path}: Is a directory")
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would make the report private
        os.replace(tmp, path)
    except OSError as e:
        _unlink(tmp)
        raise ReportError(f"{path}: {e.strerror or e}")
    except BaseException:
        _unlink(tmp)
        raise


def _unlink(p):
    try:
        os.unlink(p)
    except OSError:
        pass


def round_map(exe, plan, models, out, res, mc, seed, timeout=600):
    """The consensus map of one round's checkpoints (`host_sim maps` of `models` into `out`), made
    once for the report's strip and the MCAP log alike: kept while its map_mean.npy is newer than
    every model and its map_meta.json names the same res, mc and seed. None when the map is there,
    else why it could not be made (one line)."""
    import json
    import subprocess
    npy, meta_path = os.path.join(out, "map_mean.npy"), os.path.join(out, "map_meta.json")
    try:
        with open(meta_path) as f:
            meta = json.load(f)
        fresh = (os.path.getmtime(npy) >= max(os.path.getmtime(m) for m in models) and
                 (meta.get("res"), meta.get("mc"), meta.get("seed")) == (float(res), int(mc), int(seed)))
    except (OSError, ValueError, AttributeError):
        fresh = False
    if fresh:
        return None
    cmd = [exe, "maps", "--plan", plan, "--out", out, "--res", str(res), "--mc", str(mc), "--seed", str(seed)] + models
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as e:
        return f"did not run ({e})"
    if p.returncode != 0 or not os.path.isfile(npy):
        why = (p.stderr or p.stdout).strip().splitlines()
        return f"failed (exit {p.returncode}" + (f": {why[-1]}" if why else "") + ")"
    return None
