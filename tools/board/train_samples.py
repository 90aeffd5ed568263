#!/usr/bin/python3
"""Makes the sample file the board images train on (tools/board/train_samples.bin) from a
host_sim sample file: N records drawn without replacement over the whole tour (seeded, so
the file is reproducible; an even stride would miss the hits, 1 point in 25), written raw
(x, y, occ as little-endian float32, 12 bytes each, no header), the layout of the firmware's
ai_sample_t, so a board reads it straight into its AI core's pool.

    tools/board/train_samples.py SAMPLES --out train_samples.bin [--count N] [--seed S]

The committed file came from robot 0 of `host_sim scan` on the default plan, seed 1
(`make experiments` writes it to results/paper/runs/data-s1/samples/robot_0.samples)."""
import argparse
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import samples  # noqa: E402  (tools/samples.py: the checked reader)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("samples", help="host_sim sample file")
    ap.add_argument("--out", required=True, help="raw records to write")
    ap.add_argument("--count", type=int, default=2048, help="records to keep (default 2048)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the draw (default 1)")
    a = ap.parse_args(argv)
    try:
        _, rec = samples.load(a.samples)
    except (OSError, samples.SamplesError) as e:
        print(f"train_samples: {a.samples}: {e}", file=sys.stderr)
        return 1
    if a.count < 1 or a.count > len(rec):
        print(f"train_samples: --count must be 1..{len(rec)}", file=sys.stderr)
        return 2
    import numpy as np
    idx = np.sort(np.random.default_rng(a.seed).choice(len(rec), size=a.count, replace=False))
    rec[idx].astype(samples.RECORD).tofile(a.out)
    occ = float(rec[idx]["occ"].mean())
    print(f"train_samples: {a.count} of {len(rec)} records to {a.out} ({occ:.1%} occupied)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
