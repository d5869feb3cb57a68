#!/usr/bin/env python3
"""nav-replay on every real CARMEN log in DIR (default ../shared/data/laser) and on the scanners
derived from each (range cut to 30 m, every second beam, both; tools/derive_carmen.py): one line
per log with the figures docs/NAVIGATION.md explains, then the bounds of issue 26.

    tools/nav_suite.py [DIR] [nav-replay flags, e.g. --config F]
"""

import json
import os
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXE = os.environ.get("STEERNAV_BIN", str(ROOT / "target" / "release" / "steernav"))
DERIVED = {"30m": ["--max-range", "30"], "half": ["--every", "2"],
           "30m-half": ["--max-range", "30", "--every", "2"]}


def main():
    args = sys.argv[1:]
    folder = pathlib.Path(args.pop(0)) if args and not args[0].startswith("-") else ROOT.parent / "shared/data/laser"
    real = sorted(p for p in folder.iterdir() if p.name.endswith((".log", ".log.gz")))
    with tempfile.TemporaryDirectory() as tmp:
        logs = []
        for log in real:
            name = log.name.removesuffix(".gz").removesuffix(".log")
            logs.append((name, log))
            for tag, flags in DERIVED.items():
                out = pathlib.Path(tmp) / f"{name}@{tag}.log"
                subprocess.run([sys.executable, str(ROOT / "tools/derive_carmen.py"), str(log), str(out), *flags],
                               check=True, capture_output=True)
                logs.append((f"{name}@{tag}", out))
        print(f"{'log':28s} scans    free  mean |  fwd turn  rev stand | forward mean med  p90 | reference mean med  p90 | bounds")
        met = True
        for name, log in logs:
            r = json.loads(subprocess.run([EXE, "nav-replay", str(log), "--json", *args],
                                          check=True, capture_output=True, text=True).stdout)
            m, f, g = r["motion"], r["forward"], r["reference"]
            bounds = [r["free_fraction"] >= 0.99, r["mean_abs_deviation_deg"] <= 30,
                      f["mean_deg"] <= g["mean_deg"] + 5]
            met &= all(bounds)
            print(f"{name:28s} {r['scans']:5d} {100 * r['free_fraction']:6.2f}% {r['mean_abs_deviation_deg']:5.1f} | "
                  f"{m['forward']:4d} {m['turning_in_place']:4d} {m['reversing']:4d} {m['standing']:5d} | "
                  f"{f['mean_deg']:12.1f} {f['median_deg']:4.1f} {f['p90_deg']:4.1f} | "
                  f"{g['mean_deg']:14.1f} {g['median_deg']:4.1f} {g['p90_deg']:4.1f} | "
                  + "".join("." if b else "x" for b in bounds))
        print("bounds (free >= 99%, mean <= 30 deg, forward mean <= reference + 5 deg):",
              "all met" if met else "x = not met")


if __name__ == "__main__":
    main()
