#!/usr/bin/python3
"""What a remote costs or gains against the pair alone, per class of monte_carlo_family's runs
(docs/accuracy.md, "A family of disturbances"): the remote's scale error over the pair-only
default's, as the ratio of their medians and of their 95th percentiles over the same stations,
each with a 90 % interval from a bootstrap over the stations (2000 resamples, fixed seed). Classes
are pooled as "pair covers < 90 %" (the pair biased) and ">= 90 %" (not), by the pair-only
coverage of the same stations.

    /usr/bin/python3 scripts/family_remote_cost.py RUN.txt [RUN.txt ...]

Reads the per-seed lines ("seed CLASS SEED pair SCALE ANGLE COVERED ... | remote SCALE ANGLE
COVERED ..."). Prints a Markdown table.
"""
import argparse
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
                out.setdefault(words[1], []).append(
                    (float(words[pair_at + 1]), float(words[remote_at + 1]), int(words[pair_at + 3])))
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", help="monte_carlo_family outputs")
    args = parser.parse_args()
    by_class = stations(args.runs)
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
