#!/usr/bin/env python3
"""Other scanners from one real CARMEN log: the same drive seen by a shorter-range or sparser
scanner, for `nav-replay` to be judged on more than the logs at hand.

    tools/derive_carmen.py IN.log[.gz] OUT.log [--max-range M] [--every K] [--no-return V]
                           [--closer F]

--max-range M   readings beyond M metres become M, as a scanner of that range reports them
--every K       keep every K-th beam (the first and last kept), as a coarser scanner
--no-return V   a reading at or beyond the range limit is written as V instead (0 for
                scanners that report "no return" as zero)
--closer F      every reading times F (0 < F ≤ 1), before the range limit: a cramped building,
                its doorways and corridors narrower against the free test's cone, where the
                robot's real motion is often not free (the poses are not scaled)

Only FLASER lines change; every other line is copied. The pose, times and host are kept.
"""

import argparse
import gzip
import sys


def open_text(path):
    with open(path, "rb") as f:
        magic = f.read(2)
    return gzip.open(path, "rt") if magic == b"\x1f\x8b" else open(path, "rt")


def derive(fields, max_range, every, no_return, closer):
    n = int(fields[1])
    ranges = [float(v) for v in fields[2 : 2 + n]]
    rest = fields[2 + n :]
    keep = list(range(0, n, every))
    if keep[-1] != n - 1:
        keep.append(n - 1)
    out = []
    for i in keep:
        r = ranges[i] * closer
        if max_range is not None and r >= max_range:
            r = max_range if no_return is None else no_return
        out.append(f"{r:.3f}")
    return ["FLASER", str(len(out)), *out, *rest]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("input")
    p.add_argument("output")
    p.add_argument("--max-range", type=float)
    p.add_argument("--every", type=int, default=1)
    p.add_argument("--no-return", type=float)
    p.add_argument("--closer", type=float, default=1.0)
    a = p.parse_args()
    if a.every < 1:
        sys.exit("--every must be at least 1")
    if not 0 < a.closer <= 1:
        sys.exit("--closer must be in (0, 1]")
    lines = 0
    with open_text(a.input) as src, open(a.output, "w") as dst:
        for line in src:
            fields = line.split()
            if fields and fields[0] == "FLASER":
                line = " ".join(derive(fields, a.max_range, a.every, a.no_return, a.closer)) + "\n"
                lines += 1
            dst.write(line)
    print(f"{a.output}: {lines} FLASER scans", file=sys.stderr)


if __name__ == "__main__":
    main()
