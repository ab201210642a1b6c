#!/usr/bin/python3
"""Does a shorter window predict how long a record its intervals need? Checked on a real record.

    scripts/record_length_check.py REPORT.json

REPORT.json: `calibrate_records --intervals K --json` (K intervals, then the whole record). Each
interval measured how its 95 % half-widths narrow with length on its own halves and quarters
(the window's "interval_narrowing": half-width ~ length^-a) and so predicts the length at which
each of its nine half-widths (scale x, y, z; non-orthogonality xy, xz, yz; misalignment x, y, z)
would fall to the whole record's: L_interval * (ci_interval / ci_whole)^(1/a). The whole record
is the truth: prints, per interval, a and the predicted / actual length ratio of each parameter,
their geometric mean, then the median ratio and the share within +-30 %. An interval whose narrowing was not measured
(every verdict decided, or a flagged interval) is left out and said so.
"""
import json
import math
import statistics
import sys


def half_widths(window):
    """The nine half-widths in the verdicts' order."""
    return {v["parameter"]: v["ci95"] for v in window["verdicts"]}


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    with open(sys.argv[1]) as f:
        report = json.load(f)
    windows = report["windows"]
    whole = [w for w in windows if w["label"] == "whole record"]
    if not whole or len(windows) < 2:
        sys.exit(f"{sys.argv[1]}: no intervals and whole record (calibrate_records --intervals K --json)")
    whole = whole[0]
    whole_length = whole["samples"] * whole["sample_period"]
    whole_ci = half_widths(whole)
    ratios = []
    for w in windows:
        if w is whole:
            continue
        narrowing = w["interval_narrowing"]
        a = narrowing["exponent"]
        if a is None:
            print(f"{w['label']}: left out: {narrowing['text']}")
            continue
        length = w["samples"] * w["sample_period"]
        row = []
        logs = []
        for name, ci in half_widths(w).items():
            if not ci or not whole_ci.get(name):
                continue
            predicted = length * (ci / whole_ci[name]) ** (1.0 / a)
            ratios.append(predicted / whole_length)
            logs.append(math.log(predicted / whole_length))
            row.append(f"{name} {predicted / whole_length:.2f}")
        geometric = math.exp(sum(logs) / len(logs)) if logs else float("nan")
        print(f"{w['label']}: exponent {a:.3f} +- {narrowing['exponent_se'] or float('nan'):.3f}; "
              f"predicted / actual length: " + ", ".join(row) + f"; geometric mean {geometric:.2f}")
    if not ratios:
        sys.exit("no interval measured its narrowing")
    within = sum(1 for r in ratios if abs(r - 1.0) <= 0.3)
    print(f"median predicted / actual {statistics.median(ratios):.3f}; within +-30 %: {within} of {len(ratios)} "
          f"({100.0 * within / len(ratios):.0f} %)")


if __name__ == "__main__":
    main()
