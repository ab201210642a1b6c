#!/usr/bin/env python3
"""Default against plain Eq. 2 on the same simulated records, seed by seed.

Reads the per-seed lines of monte_carlo_unmodelled ("seed S METHOD dscale_x% dscale_y% dscale_z%
dnonorth_xy dnonorth_xz dnonorth_yz ...") and prints, for the largest scale error (%) and the
largest non-orthogonality error (deg) of each seed, the two estimators' median and 95th
percentile, the 95 % interval of their differences by a paired bootstrap over the seeds (1000
draws, fixed seed), and the share of seeds where the first estimator is worse.

  scripts/paired_difference.py [METHOD] FILE...     (METHOD: default unless given; against plain)
"""
import random
import statistics
import sys


def percentile(values, p):
    v = sorted(values)
    pos = p * (len(v) - 1)
    i = int(pos)
    f = pos - i
    return v[i] * (1 - f) + v[i + 1] * f if i + 1 < len(v) else v[i]


def load(path):
    by_method = {}
    with open(path) as f:
        for line in f:
            if not line.startswith("seed "):
                continue
            p = line.split()
            v = [float(x) for x in p[3:9]]
            by_method.setdefault(p[2], {})[int(p[1])] = (max(abs(x) for x in v[:3]), max(abs(x) for x in v[3:6]))
    return by_method


def main(argv):
    method = argv[1] if len(argv) > 1 and not argv[1].endswith(".txt") else "default"
    files = [a for a in argv[1:] if a.endswith(".txt")]
    if not files:
        sys.exit(__doc__)
    rng = random.Random(1)
    for path in files:
        d = load(path)
        if method not in d or "plain" not in d:
            sys.exit(f"{path}: no '{method}' or 'plain' lines")
        seeds = sorted(set(d[method]) & set(d["plain"]))
        for q, name in ((0, "scale %"), (1, "angle deg")):
            x = [d[method][s][q] for s in seeds]
            y = [d["plain"][s][q] for s in seeds]
            med, p95 = [], []
            for _ in range(1000):
                idx = [rng.randrange(len(x)) for _ in x]
                xi = [x[k] for k in idx]
                yi = [y[k] for k in idx]
                med.append(statistics.median(xi) - statistics.median(yi))
                p95.append(percentile(xi, 0.95) - percentile(yi, 0.95))
            worse = 100.0 * sum(a > b for a, b in zip(x, y)) / len(x)
            print(f"{path} {name}: median {statistics.median(x):.3f} vs {statistics.median(y):.3f} "
                  f"[{percentile(med, 0.025):+.3f}, {percentile(med, 0.975):+.3f}], "
                  f"95th pct {percentile(x, 0.95):.3f} vs {percentile(y, 0.95):.3f} "
                  f"[{percentile(p95, 0.025):+.3f}, {percentile(p95, 0.975):+.3f}], {method} worse in {worse:.0f} %")


if __name__ == "__main__":
    main(sys.argv)
