#!/usr/bin/env python3
"""Rewrites the results table of README.md (between the `results:begin` and `results:end` markers):
the default configuration, the thesis preset and the FDIV baseline on the eval folder and on the
self-calibration validation scenes (imperfect and ideal arrays), each number from a
`host-sim eval --json` run of this script.

Usage: scripts/results.py [--eval ../shared/data/eval] [--val /tmp/cma-selfcal-val/seed1]
  --val: a folder made by scripts/selfcal_validation.py (with imperfect/ and ideal/)
Needs a release build of host-sim (cargo build --release -p host-sim).
"""

import argparse
import os

from selfcal_report import ROOT, evaluate

CONFIGS = [
    ("default", []),
    ("thesis preset", ["--preset", "thesis"]),
    ("FDIV baseline", ["--method", "fdiv"]),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--eval", default=os.path.join(ROOT, "..", "shared", "data", "eval"))
    ap.add_argument("--val", default="/tmp/cma-selfcal-val/seed1")
    a = ap.parse_args()
    columns = []  # (title, folder, set)
    for s in ["anechoic", "room", "jump", "moving"]:
        columns.append((f"eval: {s}", a.eval, s))
    columns += [
        ("imperfect array, long, last 40 s", os.path.join(a.val, "imperfect"), "long_late"),
        ("imperfect array, short", os.path.join(a.val, "imperfect"), "short"),
        ("ideal array, long, last 40 s", os.path.join(a.val, "ideal"), "long_late"),
    ]
    rows = []
    for label, flags in CONFIGS:
        cache = {}
        cells = []
        for _, folder, s in columns:
            if folder not in cache:
                cache[folder] = evaluate(folder, flags)
            acc10, mae, _ = cache[folder][s]
            cells.append(f"{acc10:.1f} / {mae:.2f}")
        rows.append(f"| {label} | " + " | ".join(cells) + " |")
    block = [
        "<!-- results:begin (written by scripts/results.py; do not edit by hand) -->",
        "ACC10 % / MAE ° (frames within 10° / mean absolute error, settled frames):",
        "",
        "| configuration | " + " | ".join(c[0] for c in columns) + " |",
        "|---|" + "---|" * len(columns),
    ] + rows + ["<!-- results:end -->"]
    path = os.path.join(ROOT, "README.md")
    text = open(path).read()
    begin = text.index("<!-- results:begin")
    end = text.index("<!-- results:end -->") + len("<!-- results:end -->")
    text = text[:begin] + "\n".join(block) + text[end:]
    open(path, "w").write(text)
    print("\n".join(block))


if __name__ == "__main__":
    main()
