#!/usr/bin/python3
"""What a remote costs or gains against the pair alone, per class of monte_carlo_family's runs
(docs/accuracy.md, "A family of disturbances"): the remote's scale error over the pair-only
default's, as the ratio of their medians and of their 95th percentiles over the same stations,
each with a 90 % interval from a bootstrap over the stations (2000 resamples, fixed seed). Classes
are pooled as "pair covers < 90 %" (the pair biased) and ">= 90 %" (not), by the pair-only
coverage of the same stations.

    /usr/bin/python3 scripts/family_remote_cost.py RUN.txt [RUN.txt ...]
    /usr/bin/python3 scripts/family_remote_cost.py --by-own-share RUN.txt [RUN.txt ...]

--by-own-share: instead, over the classes the pair covers >= 90 %, the geometric mean of the
per-station ratio by the remote vertical's own share of its variance (the per-seed "own X/Z").

Reads the per-seed lines ("seed CLASS SEED pair SCALE ANGLE COVERED ... | remote SCALE ANGLE
COVERED ..."). Prints a Markdown table.
"""
import argparse
import math
import random


def percentile(values, p):
    """Linear interpolation between order statistics, as benchmark/percentile.hpp."""
    v = sorted(values)
    pos = p * (len(v) - 1)
    i = int(pos)
    return v[i] + (pos - i) * (v[i + 1] - v[i]) if i + 1 < len(v) else v[i]


def stations(paths):
    """Per class, in order of first appearance: [(pair scale %, remote scale %, pair covered of 6)]."""
    out = {}
    for path in paths:
        with open(path, encoding="utf-8") as f:
            for line in f:
                if not line.startswith("seed "):
                    continue
                words = line.split()
                pair_at, remote_at = words.index("pair"), words.index("remote")
                own_z = float(words[words.index("own") + 1].split("/")[1])
                out.setdefault(words[1], []).append(
                    (float(words[pair_at + 1]), float(words[remote_at + 1]), int(words[pair_at + 3]), own_z))
    return out


def ratios(rows):
    pair = [r[0] for r in rows]
    remote = [r[1] for r in rows]
    return (percentile(remote, 0.5) / percentile(pair, 0.5), percentile(remote, 0.95) / percentile(pair, 0.95))


def interval(rows, rng, resamples=2000):
    """90 % bootstrap intervals of the two ratios, resampling stations (pairs kept together)."""
    medians, tops = [], []
    for _ in range(resamples):
        sample = [rows[rng.randrange(len(rows))] for _ in rows]
        m, t = ratios(sample)
        medians.append(m)
        tops.append(t)
    return (percentile(medians, 0.05), percentile(medians, 0.95)), (percentile(tops, 0.05), percentile(tops, 0.95))


def row(name, rows, rng):
    coverage = 100.0 * sum(r[2] for r in rows) / (6 * len(rows))
    m, t = ratios(rows)
    (m_lo, m_hi), (t_lo, t_hi) = interval(rows, rng)
    return (f"| {name} | {len(rows)} | {coverage:.1f} % | {m:.2f} ({m_lo:.2f}-{m_hi:.2f}) "
            f"| {t:.2f} ({t_lo:.2f}-{t_hi:.2f}) |")


def by_own_share(by_class):
    """Geometric mean of remote / pair scale error by the remote vertical's own share, unbiased classes."""
    rows = [r for rows in by_class.values() if sum(x[2] for x in rows) / (6 * len(rows)) >= 0.9 for r in rows]
    print("| remote vertical's own share | stations | remote / pair scale error, geometric mean | 1 / sqrt(1 - share) at the middle |")
    print("|---|---|---|---|")
    for low, high in ((0.0, 0.25), (0.25, 0.4), (0.4, 0.5001)):
        part = [r for r in rows if low <= r[3] < high and r[0] > 0.0 and r[1] > 0.0]
        if not part:
            continue
        mean = math.exp(sum(math.log(r[1] / r[0]) for r in part) / len(part))
        middle = 0.5 * (low + min(high, 0.5))
        print(f"| {low:.2f}-{min(high, 0.5):.2f} | {len(part)} | {mean:.2f} | {1.0 / math.sqrt(1.0 - middle):.2f} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", help="monte_carlo_family outputs")
    parser.add_argument("--by-own-share", action="store_true", help="ratio by the remote vertical's own share")
    args = parser.parse_args()
    by_class = stations(args.runs)
    if args.by_own_share:
        by_own_share(by_class)
        return
    rng = random.Random(57)
    print("| class | stations | pair-only coverage | remote / pair scale error, median (90 % interval) "
          "| remote / pair, 95th percentile (90 % interval) |")
    print("|---|---|---|---|---|")
    biased, unbiased = [], []
    for name, rows in by_class.items():
        print(row(name, rows, rng))
        coverage = sum(r[2] for r in rows) / (6 * len(rows))
        (biased if coverage < 0.9 else unbiased).extend(rows)
    if unbiased:
        print(row("classes the pair covers >= 90 %", unbiased, rng))
    if biased:
        print(row("classes the pair covers < 90 %", biased, rng))


if __name__ == "__main__":
    main()
