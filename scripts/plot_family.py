#!/usr/bin/python3
"""Plots monte_carlo_family's summary tables (docs/accuracy.md, "A family of disturbances"): per
class, the pair-only default's coverage of the unflagged stations and its flag rate, and the
remote's coverage (%).

    /usr/bin/python3 scripts/plot_family.py RUN.txt [RUN.txt ...] -o docs/figures/family_coverage.png
"""
import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def rows(paths):
    """The per-class rows of the programs' summary tables, in order, without the "all" rows."""
    out = []
    for path in paths:
        with open(path, encoding="utf-8") as f:
            for line in f:
                cells = [c.strip() for c in line.strip().strip("|").split("|")]
                if len(cells) < 14 or cells[0] in ("class", "all") or cells[0].startswith("---"):
                    continue
                out.append(cells)
    return out


def percent(text):
    return float(text.rstrip(" %")) if text not in ("-", "") else float("nan")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+")
    parser.add_argument("-o", "--output", required=True)
    args = parser.parse_args()
    table = rows(args.runs)
    names = [r[0] for r in table]
    x = range(len(names))
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.plot(x, [percent(r[5]) for r in table], "o", label="pair only: coverage of unflagged stations")
    ax.plot(x, [percent(r[10]) for r in table], "s", label="with a remote: coverage")
    ax.bar(x, [percent(r[6]) for r in table], color="0.85", label="pair only: flagged stations")
    ax.axhspan(93, 97, color="tab:green", alpha=0.12, label="93-97 %")
    ax.axhline(90, color="tab:red", lw=0.8, ls="--", label="90 %")
    ax.set_xticks(list(x))
    ax.set_xticklabels(names, rotation=35, ha="right")
    ax.set_ylabel("%")
    ax.set_ylim(0, 101)
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title("Family of disturbances: six parameters inside their 95 % intervals, and flags")
    fig.tight_layout()
    fig.savefig(args.output, dpi=110)


if __name__ == "__main__":
    main()
