#!/usr/bin/env python3
"""Compare two `portalfind run` output directories, timings aside.

usage: same_results.py BEFORE_DIR AFTER_DIR
Exits 0 when result.json (without timing fields and the model path), weight_curve.csv and
cells.svg are equal; prints the first differences otherwise.
"""
import json
import sys
from pathlib import Path

TIMING = ("timings", "seconds", "stages")


def strip(x):
    if isinstance(x, dict):
        return {k: strip(v) for k, v in x.items() if not any(t in k for t in TIMING) and k != "path"}
    if isinstance(x, list):
        return [strip(v) for v in x]
    return x


def main():
    a, b = Path(sys.argv[1]), Path(sys.argv[2])
    ok = strip(json.loads((a / "result.json").read_text())) == strip(json.loads((b / "result.json").read_text()))
    print(f"result.json (timings aside): {'equal' if ok else 'DIFFERENT'}")
    for f in ("weight_curve.csv", "cells.svg"):
        same = (a / f).read_bytes() == (b / f).read_bytes()
        print(f"{f}: {'identical' if same else 'DIFFERENT'}")
        ok &= same
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
