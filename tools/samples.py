#!/usr/bin/python3
"""Read host_sim sample files (format: host_sim/sim_samples.h) and summarise or plot them.

    tools/samples.py info FILE...            header, counts, occupied fraction, CRC check
    tools/samples.py plot FILE --out P.png   scatter of free (grey) and occupied (black) points
                                             in metres (needs matplotlib)
As a module: `load(path)` returns (header dict, numpy structured array with x, y, occ), and
`to_metres(header, records)` gives the points in plan coordinates.
Every check of the C reader is repeated: magic, version, sizes, header CRC, exact length,
data CRC, record ranges. A malformed file raises SamplesError (exit status 1 from the CLI).
"""
import argparse
import struct
import sys
import zlib

import numpy as np

MAGIC = b"FSSAMPLE"
VERSION = 1
HEADER_SIZE = 208
RECORD_SIZE = 12
SOURCE_MAX = 132
RECORD = np.dtype([("x", "<f4"), ("y", "<f4"), ("occ", "<f4")])


class SamplesError(Exception):
    pass


def load(path):
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 8 or data[:8] != MAGIC:
        raise SamplesError(f"{path}: not a samples file (bad magic)")
    if len(data) < HEADER_SIZE + 4:
        raise SamplesError(f"{path}: truncated header ({len(data)} bytes)")
    version, header_size, record_size, flags, count = struct.unpack_from("<IIIIQ", data, 8)
    if version != VERSION:
        raise SamplesError(f"{path}: unsupported version {version}")
    if header_size != HEADER_SIZE or record_size != RECORD_SIZE:
        raise SamplesError(f"{path}: bad header size {header_size} or record size {record_size}")
    (hcrc,) = struct.unpack_from("<I", data, 204)
    if hcrc != zlib.crc32(data[:204]):
        raise SamplesError(f"{path}: header CRC mismatch (corrupted header)")
    min_x, min_y, max_x, max_y = struct.unpack_from("<4d", data, 32)
    (seed,) = struct.unpack_from("<Q", data, 64)
    source = data[72:72 + SOURCE_MAX].split(b"\0", 1)[0].decode("utf-8", "replace")
    body = len(data) - HEADER_SIZE - 4
    if count * RECORD_SIZE > body:
        raise SamplesError(f"{path}: truncated: header says {count} records but only {body} bytes follow")
    if count * RECORD_SIZE != body:
        raise SamplesError(f"{path}: bad count: {count} records in header, {body} bytes of records")
    recs = data[HEADER_SIZE:HEADER_SIZE + body]
    (dcrc,) = struct.unpack_from("<I", data, HEADER_SIZE + body)
    if dcrc != zlib.crc32(recs):
        raise SamplesError(f"{path}: data CRC mismatch (corrupted records)")
    arr = np.frombuffer(recs, dtype=RECORD, count=count)
    ok = (np.isfinite(arr["x"]) & np.isfinite(arr["y"]) & np.isfinite(arr["occ"]) &
          (np.abs(arr["x"]) <= 1) & (np.abs(arr["y"]) <= 1) & (arr["occ"] >= 0) & (arr["occ"] <= 1))
    if not ok.all():
        raise SamplesError(f"{path}: record {int(np.argmin(ok))} out of range")
    header = dict(version=version, count=count, min_x=min_x, min_y=min_y, max_x=max_x,
                  max_y=max_y, seed=seed, source=source)
    return header, arr


def to_metres(header, arr):
    x = header["min_x"] + (arr["x"].astype(np.float64) + 1.0) * 0.5 * (header["max_x"] - header["min_x"])
    y = header["min_y"] + (arr["y"].astype(np.float64) + 1.0) * 0.5 * (header["max_y"] - header["min_y"])
    return x, y


def cmd_info(args):
    for p in args.files:
        h, a = load(p)
        occ = float((a["occ"] > 0.5).mean()) if len(a) else 0.0
        print(f"{p}: {h['count']} samples, {100 * occ:.2f}% occupied, seed {h['seed']}, "
              f"box [{h['min_x']:.3f}, {h['max_x']:.3f}] x [{h['min_y']:.3f}, {h['max_y']:.3f}] m, "
              f"source '{h['source']}'")
    return 0


def cmd_plot(args):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    h, a = load(args.file)
    x, y = to_metres(h, a)
    occ = a["occ"] > 0.5
    n = len(a)
    step = max(1, n // args.max_points)
    free = ~occ
    fig, ax = plt.subplots(figsize=(8, 8 * (h["max_y"] - h["min_y"]) / (h["max_x"] - h["min_x"])))
    ax.scatter(x[free][::step], y[free][::step], s=0.3, c="0.75", label="free")
    ax.scatter(x[occ], y[occ], s=0.6, c="k", label="occupied")
    ax.set_aspect("equal")
    ax.set_xlim(h["min_x"], h["max_x"])
    ax.set_ylim(h["min_y"], h["max_y"])
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{n} samples, {int(occ.sum())} occupied")
    ax.legend(loc="upper right", markerscale=10)
    fig.savefig(args.out, dpi=100, bbox_inches="tight")
    print(f"wrote {args.out}")
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    pi = sub.add_parser("info", help="summarise sample files")
    pi.add_argument("files", nargs="+")
    pp = sub.add_parser("plot", help="scatter plot of a sample file")
    pp.add_argument("file")
    pp.add_argument("--out", required=True)
    pp.add_argument("--max-points", type=int, default=200000, help="free points drawn at most")
    args = ap.parse_args(argv)
    try:
        return cmd_info(args) if args.cmd == "info" else cmd_plot(args)
    except (SamplesError, OSError) as e:
        print(f"samples.py: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
