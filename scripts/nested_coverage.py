#!/usr/bin/python3
"""How often the windows of a real record hold the whole record's estimate in their intervals.

    scripts/nested_coverage.py WINDOWS.json WHOLE.json

WINDOWS.json: `calibrate_records --window W --step W --json` (disjoint windows of one record);
WHOLE.json: the same record as one window (`calibrate_records --json`, its last window). For each
window and each of the six parameters (scale x, y, z; non-orthogonality xy, xz, yz) the nested
z = (window - whole) / sqrt(se_window^2 - se_whole^2), se = ci95 / interval_quantile: the window's
deviation from the whole record in units of what its interval allows beyond the whole record's.
With no truth on a real record this is the nearest thing to coverage: prints the share of |z|
within the normal's 1.96 and within each window's own Student quantile (its ci95 in standard
errors), and the rms of z. Windows whose se is not above the whole record's are left out (counted).
"""
import json
import math
import sys

# (value key, interval key, index): scale ratios are lists x, y, z; non-orthogonalities are
# objects keyed "xy", "xz", "yz" (docs/programs.md).
PARAMETERS = [("scale_ratio", "scale_ratio_ci95", k) for k in range(3)] + \
    [("nonorthogonality_deg", "nonorthogonality_ci95_deg", pair) for pair in ("xy", "xz", "yz")]


def value_and_se(window, name, ci_name, index):
    return window[name][index], window[ci_name][index] / window["interval_quantile"]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    windows = [w for w in json.load(open(sys.argv[1]))["windows"] if w["quality"] == "ok"]
    whole = json.load(open(sys.argv[2]))["windows"][-1]
    inside_normal = inside_t = count = left_out = 0
    z2 = 0.0
    quantiles = []
    for w in windows:
        quantiles.append(w["interval_quantile"])
        for parameter in PARAMETERS:
            v, se = value_and_se(w, *parameter)
            v0, se0 = value_and_se(whole, *parameter)
            if not se > se0:
                left_out += 1
                continue
            z = (v - v0) / math.sqrt(se * se - se0 * se0)
            count += 1
            z2 += z * z
            inside_normal += abs(z) <= 1.959964
            inside_t += abs(z) <= w["interval_quantile"]
    quantiles.sort()
    print(f"{len(windows)} windows, {count} window-parameters ({left_out} left out: se not above the whole's)")
    print(f"window half-widths in se: {quantiles[0]:.3f}-{quantiles[-1]:.3f}, median {quantiles[len(quantiles) // 2]:.3f}")
    print(f"within 1.96 se: {100.0 * inside_normal / count:.1f} %; within the window's Student quantile: "
          f"{100.0 * inside_t / count:.1f} %; rms z {math.sqrt(z2 / count):.2f}")


if __name__ == "__main__":
    main()
