#!/usr/bin/env python3
"""Paired comparisons of policies over parts, from `s2g eval --results DIR` files.

    scripts/paired_ci.py [--against random,fixed-fine,fixed-coarse,heuristic] [--seed 0]
                         [--resamples 10000] [--name POLICY=LABEL]... DIR [DIR...]

Reads every `*.eval.json` of the folders (runs without fine-tuning or ablation), keeps the
parts that every policy has a run of, and prints in Markdown, per policy: mean IoU, mean
machining time and its ratio to fixed fine's, mean reward (Eq. 13), and for each policy
named by --against the mean of the per-part reward difference with a 95 % percentile
bootstrap interval over parts (resampling parts with replacement, seeded: the same files
give the same bytes). An interval whose lower end is above zero marks a lead.
"""
import argparse
import glob
import json
import os
import random
import sys


def load(dirs):
    runs = {}  # policy -> part -> scores
    for d in dirs:
        for path in sorted(glob.glob(os.path.join(d, "*.eval.json"))):
            with open(path) as f:
                r = json.load(f)
            for run in r["runs"]:
                if run["finetune"] or run["without"] is not None:
                    continue
                runs.setdefault(run["policy"], {})[r["part"]] = run
    return runs


def bootstrap(diffs, resamples, seed):
    rng = random.Random(seed)
    n = len(diffs)
    means = sorted(sum(diffs[rng.randrange(n)] for _ in range(n)) / n for _ in range(resamples))
    return means[int(0.025 * resamples)], means[int(0.975 * resamples) - 1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--against", default="random,fixed-fine,fixed-coarse,heuristic")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--resamples", type=int, default=10000)
    ap.add_argument("--name", action="append", default=[], help="POLICY=LABEL for the table")
    a = ap.parse_args()
    runs = load(a.dirs)
    if not runs:
        sys.exit("no results")
    labels = dict(n.split("=", 1) for n in a.name)
    parts = sorted(set.intersection(*(set(p) for p in runs.values())))
    if not parts:
        sys.exit("no part has a run of every policy")
    against = [p for p in a.against.split(",") if p in runs]
    n = len(parts)
    mean = lambda pol, key: sum(runs[pol][p][key] for p in parts) / n
    fine_t = mean("fixed-fine", "machining_time_s") if "fixed-fine" in runs else None
    print(f"{n} parts; reward differences: mean over parts [95 % bootstrap interval, "
          f"{a.resamples} resamples, seed {a.seed}]\n")
    head = ["policy", "IoU", "T (s)", "T / fine", "reward"] + [f"- {b}" for b in against]
    print("| " + " | ".join(head) + " |")
    print("|" + " --- |" * len(head))
    for pol in sorted(runs, key=lambda p: (p not in against, p)):
        row = [labels.get(pol, pol), f"{mean(pol, 'iou'):.4f}", f"{mean(pol, 'machining_time_s'):,.0f}",
               f"{mean(pol, 'machining_time_s') / fine_t:.3f}" if fine_t else "",
               f"{mean(pol, 'reward'):.4f}"]
        for b in against:
            if b == pol:
                row.append("")
                continue
            d = [runs[pol][p]["reward"] - runs[b][p]["reward"] for p in parts]
            lo, hi = bootstrap(d, a.resamples, a.seed)
            mark = " **+**" if lo > 0 else (" **-**" if hi < 0 else "")
            row.append(f"{sum(d) / n:+.4f} [{lo:+.4f}, {hi:+.4f}]{mark}")
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
