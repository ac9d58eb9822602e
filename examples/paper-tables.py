#!/usr/bin/env python3
"""The tables of docs/paper.md, from two rwg runs and the paper's published values.

    python3 examples/paper-tables.py runs/paper-blocks-nobias runs/paper-blocks-bias

NOBIAS is a run of examples/paper-blocks-nobias.toml after `rwg stats NOBIAS --at-n 10000`;
BIAS a run of examples/paper-blocks-bias.toml after `rwg stats BIAS --at-n 10000` and
`rwg stats BIAS --at-n 20000 --no-write --format json > BIAS/stats-at-20000.json`.
With `--runtime FILE` (the CSV examples/paper-runtime.py prints) it also prints the runtime
table. Standard library only. tests/cli_paper.rs recomputes every number in Rust.

How a published value v (printed by the paper to one decimal) is placed among K blocks: a
block value b is below v if b < v - 0.05, level with it if v - 0.05 <= b < v + 0.05 (b
printed to one decimal, rounding half up, is v) and above otherwise; "reach" counts the
blocks level or above. Its position u = (below + level/2 + 1/2) / (K + 1) is uniform on
(0, 1) when v is one more draw of the same statistic (mean 1/2, variance 1/12).

The bias comparison: p(solved) by Newcombe's interval for a difference of two proportions
(from the runs' 95% Wilson intervals); best mean and 99.9th percentile at 10^4 networks by
the Hodges-Lehmann shift between the two sets of blocks (bias minus no bias), with its 95%
interval from the Mann-Whitney statistic (normal approximation).
"""

import argparse
import csv
import json
import math
import os
import sys

ARCHS = ["0HL", "1HL-4", "2HL-4-4"]
STATS = {"best_mean": "best", "p99_9_mean": "p99.9"}
HERE = os.path.dirname(os.path.abspath(__file__))


def published(path):
    rows = [r for r in csv.DictReader(line for line in open(path) if not line.startswith("#"))]
    for r in rows:
        r["value"] = float(r["value"])
    return rows


def cells_by_key(stats_json):
    cells = json.load(open(stats_json))["cells"]
    return {(c["env"], c["arch"]): c for c in cells}


def csv_by_key(stats_csv):
    return {(r["env"], r["arch"]): r for r in csv.DictReader(open(stats_csv))}


def place(v, blocks):
    below = sum(b < v - 0.05 for b in blocks)
    above = sum(b >= v + 0.05 for b in blocks)
    level = len(blocks) - below - above
    u = (below + level / 2 + 0.5) / (len(blocks) + 1)
    return below, level, above, u


def verdict(below, level, above):
    k = below + level + above
    if below == k:
        return f"above all {k}"
    if above == k:
        return f"below all {k}"
    return "inside"


def spread(at_n_stat):
    return f"{at_n_stat['median']:.2f} [{at_n_stat['min']:.2f}, {at_n_stat['max']:.2f}]"


def shown(v):
    return f"{v:.1f}"


def hodges_lehmann(a, b):
    """Shift b - a: the median of all differences, with its 95% interval."""
    d = sorted(y - x for x in a for y in b)
    n1, n2 = len(a), len(b)
    m = n1 * n2
    mid = (d[(m - 1) // 2] + d[m // 2]) / 2
    c = math.floor(m / 2 - 1.96 * math.sqrt(m * (n1 + n2 + 1) / 12))
    if c < 1:
        return mid, d[0], d[-1]
    return mid, d[c - 1], d[m - c]


def newcombe(nobias, bias):
    """p(bias) - p(no bias) with its 95% interval, from both Wilson intervals."""
    p1, l1, u1 = (float(nobias[k]) for k in ["p_solved", "p_solved_lo", "p_solved_hi"])
    p2, l2, u2 = (float(bias[k]) for k in ["p_solved", "p_solved_lo", "p_solved_hi"])
    d = p2 - p1
    lo = d - math.sqrt((p2 - l2) ** 2 + (u1 - p1) ** 2)
    hi = d + math.sqrt((u2 - p2) ** 2 + (p1 - l1) ** 2)
    return d, lo, hi


def direction(lo, hi):
    if hi < 0:
        return "lower"
    if lo > 0:
        return "higher"
    return "no difference shown"


def wilson(c, n, z=1.96):
    """The 95% Wilson interval of c successes in n."""
    p = c / n
    den = 1 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, mid - half), min(1.0, mid + half)


def needed(stat, n):
    """How many of N networks must reach a value for the statistic to reach it: 1 for the
    best; for the 99.9th percentile (numpy's linear interpolation between the sorted means
    at positions floor(0.999 (N - 1)) and the next) those from that position up."""
    return 1 if stat == "best_mean" else n - math.floor(0.999 * (n - 1))


def at_least(j, n, q):
    """P(Binomial(n, q) >= j)."""
    if q <= 0:
        return 0.0 if j > 0 else 1.0
    if q >= 1:
        return 1.0
    below, log_c = 0.0, 0.0
    for k in range(j):
        if k > 0:
            log_c += math.log((n - k + 1) / k)
        below += math.exp(log_c + k * math.log(q) + (n - k) * math.log1p(-q))
    return max(0.0, 1.0 - below)


def means(run, env, arch, bias):
    """The networks' mean scores of one cell of `run`, from its samples.csv."""
    name = f"{env}__{arch}__{'bias' if bias else 'nobias'}"
    return [float(r["mean"]) for r in csv.DictReader(open(os.path.join(run, "cells", name, "samples.csv")))]


def tail(v, place_word, stat, n, m):
    """For a published value outside the blocks: the networks beyond it among the run's m
    (those reaching v's band when v is above all blocks, those above it when below), and the
    chance, with its 95% interval, that a study of n networks lies as far out as v."""
    if place_word.startswith("above"):
        c = sum(x >= v - 0.05 for x in m)
    else:
        c = sum(x >= v + 0.05 for x in m)
    lo, hi = wilson(c, len(m))
    j = needed(stat, n)
    if place_word.startswith("above"):
        chance = [at_least(j, n, q) for q in (c / len(m), lo, hi)]
    else:
        chance = [1 - at_least(j, n, q) for q in (c / len(m), hi, lo)]
    return c, len(m), chance


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("nobias")
    ap.add_argument("bias")
    ap.add_argument("--published", default=os.path.join(HERE, "paper-published.csv"))
    ap.add_argument("--runtime", help="CSV of examples/paper-runtime.py")
    ap.add_argument("--tails", help="read the tails from this CSV instead of the runs' samples.csv")
    ap.add_argument("--tails-out", help="write the tails computed from the runs to this CSV")
    args = ap.parse_args()

    pub = published(args.published)
    nob = cells_by_key(os.path.join(args.nobias, "stats.json"))
    b1 = cells_by_key(os.path.join(args.bias, "stats.json"))
    b2 = cells_by_key(os.path.join(args.bias, "stats-at-20000.json"))
    nob_csv = csv_by_key(os.path.join(args.nobias, "stats.csv"))
    bias_csv = csv_by_key(os.path.join(args.bias, "stats.csv"))
    n_no = next(iter(nob.values()))["at_n"]
    n_b1 = next(iter(b1.values()))["at_n"]
    n_b2 = next(iter(b2.values()))["at_n"]

    out = sys.stdout.write
    outside = []
    out(f"### No bias: {n_no['blocks']} blocks of {n_no['n']} networks\n\n")
    out("| env | arch | statistic | paper | rwg: median [min, max] | blocks reaching it | place |\n")
    out("| :--- | :--- | :--- | ---: | ---: | ---: | :--- |\n")
    for r in pub:
        if r["table"] != "score" or r["bias"] != "false":
            continue
        c = nob[(r["env"], r["arch"])]["at_n"][r["statistic"]]
        below, level, above, _ = place(r["value"], c["blocks"])
        if verdict(below, level, above) != "inside":
            outside.append((r, False, n_no["n"], verdict(below, level, above)))
        out(f"| {r['env']} | {r['arch']} | {STATS[r['statistic']]} | {shown(r['value'])} | "
            f"{spread(c)} | {level + above} of {len(c['blocks'])} | {verdict(below, level, above)} |\n")

    out(f"\n### With bias: {n_b1['blocks']} blocks of {n_b1['n']}, {n_b2['blocks']} blocks of {n_b2['n']}\n\n")
    out(f"| env | arch | statistic | paper | rwg at {n_b1['n']}: median [min, max] | reach | place "
        f"| rwg at {n_b2['n']}: median [min, max] | reach | place |\n")
    out("| :--- | :--- | :--- | ---: | ---: | ---: | :--- | ---: | ---: | :--- |\n")
    fit = {n_b1["n"]: [], n_b2["n"]: []}
    for r in pub:
        if r["table"] != "score" or r["bias"] != "true":
            continue
        row = f"| {r['env']} | {r['arch']} | {STATS[r['statistic']]} | {shown(r['value'])} |"
        informative = False
        placed = []
        for cells, n in [(b1, n_b1), (b2, n_b2)]:
            c = cells[(r["env"], r["arch"])]["at_n"][r["statistic"]]
            below, level, above, u = place(r["value"], c["blocks"])
            informative |= level != len(c["blocks"])
            placed.append((n["n"], below, level, above, u))
            if verdict(below, level, above) != "inside":
                outside.append((r, True, n["n"], verdict(below, level, above)))
            row += f" {spread(c)} | {level + above} of {len(c['blocks'])} | {verdict(below, level, above)} |"
        if informative:
            for n, below, level, above, u in placed:
                fit[n].append((below, level, above, u, r["statistic"]))
        out(row + "\n")


    out("\n### Outside the blocks: how rare\n\n")
    out("| env | arch | bias | statistic | paper | N | place | networks beyond it | chance at N |\n")
    out("| :--- | :--- | :--- | :--- | ---: | ---: | :--- | ---: | ---: |\n")
    rows = []
    if args.tails:
        for t in csv.DictReader(open(args.tails)):
            n, stat = int(t["n"]), t["statistic"]
            c, m = int(t["beyond"]), int(t["networks"])
            lo, hi = wilson(c, m)
            j = needed(stat, n)
            if t["place"].startswith("above"):
                chance = [at_least(j, n, q) for q in (c / m, lo, hi)]
            else:
                chance = [1 - at_least(j, n, q) for q in (c / m, hi, lo)]
            rows.append((t["env"], t["arch"], t["bias"] == "true", stat, float(t["value"]), n, t["place"], c, m, chance))
    else:
        for r, bias, n, word in outside:
            run = args.bias if bias else args.nobias
            c, m, chance = tail(r["value"], word, r["statistic"], n, means(run, r["env"], r["arch"], bias))
            rows.append((r["env"], r["arch"], bias, r["statistic"], r["value"], n, word, c, m, chance))
    if args.tails_out:
        with open(args.tails_out, "w") as f:
            f.write("env,arch,bias,statistic,value,n,place,beyond,networks\n")
            for env, arch, bias, stat, v, n, word, c, m, _ in rows:
                f.write(f"{env},{arch},{str(bias).lower()},{stat},{v},{n},{word},{c},{m}\n")
    for env, arch, bias, stat, v, n, word, c, m, (p, lo, hi) in rows:
        out(f"| {env} | {arch} | {'yes' if bias else 'no'} | {STATS[stat]} | {shown(v)} | {n} | {word} "
            f"| {c} of {m} | {p:.3g} [{lo:.3g}, {hi:.3g}] |\n")

    out("\n### Which N explains the with-bias values\n\n")
    out("| N | statistic | values | mean position u | z | above all blocks | inside | below all blocks |\n")
    out("| ---: | :--- | ---: | ---: | ---: | ---: | ---: | ---: |\n")
    for n, rows in fit.items():
        for name, keep in [("best", "best_mean"), ("p99.9", "p99_9_mean"), ("both", None)]:
            sel = [x for x in rows if keep is None or x[4] == keep]
            m = len(sel)
            mean_u = sum(x[3] for x in sel) / m
            z = (mean_u - 0.5) / math.sqrt(1 / (12 * m))
            k = [x[0] + x[1] + x[2] for x in sel]
            above_all = sum(x[0] == kk for x, kk in zip(sel, k))
            below_all = sum(x[2] == kk for x, kk in zip(sel, k))
            out(f"| {n} | {name} | {m} | {mean_u:.3f} | {z:+.2f} | {above_all} | {m - above_all - below_all} | {below_all} |\n")
    out(f"\n### Bias minus no bias (p(solved): all networks; best and p99.9: blocks of {n_no['n']})\n\n")
    out("| env | arch | p(solved) | best mean | p99.9 |\n")
    out("| :--- | :--- | ---: | ---: | ---: |\n")
    tally = {"p": {}, "best_mean": {}, "p99_9_mean": {}}
    envs = []
    for r in pub:
        if r["table"] == "score" and r["env"] not in envs:
            envs.append(r["env"])
    for env in envs:
        for arch in ARCHS:
            key = (env, arch)
            row = f"| {env} | {arch} |"
            if int(nob_csv[key]["solved_count"]) == 0 and int(bias_csv[key]["solved_count"]) == 0:
                row += " none solved |"
                tally["p"]["none solved"] = tally["p"].get("none solved", 0) + 1
            else:
                d, lo, hi = newcombe(nob_csv[key], bias_csv[key])
                word = direction(lo, hi)
                row += f" {d:+.5f} [{lo:+.5f}, {hi:+.5f}]: {word} |"
                tally["p"][word] = tally["p"].get(word, 0) + 1
            for stat in ["best_mean", "p99_9_mean"]:
                a = nob[key]["at_n"][stat]["blocks"]
                b = b1[key]["at_n"][stat]["blocks"]
                mid, lo, hi = hodges_lehmann(a, b)
                word = direction(lo, hi)
                tally[stat][word] = tally[stat].get(word, 0) + 1
                row += f" {mid:+.2f} [{lo:+.2f}, {hi:+.2f}]: {word} |"
            out(row + "\n")
    out("\n")
    for stat, name in [("p", "p(solved)"), ("best_mean", "best mean"), ("p99_9_mean", "p99.9")]:
        parts = ", ".join(f"{w} {n}" for w, n in sorted(tally[stat].items()))
        out(f"- {name}: {parts}\n")

    if args.runtime:
        rt = {(r["env"], r["arch"]): r for r in csv.DictReader(line for line in open(args.runtime) if not line.startswith("#"))}
        out("\n### Runtime per cell, one core\n\n")
        out("| env | arch | paper (s) | rwg CPU (s): median [min, max] | paper / rwg (per network) |\n")
        out("| :--- | :--- | ---: | ---: | ---: |\n")
        for r in pub:
            if r["table"] != "runtime":
                continue
            m = rt[(r["env"], r["arch"])]
            med = float(m["cpu_s_median"])
            # rwg's time scaled to the paper's 10^4 networks x 20 episodes
            scale = 10000 * 20 / (int(m["samples"]) * int(m["episodes"]))
            out(f"| {r['env']} | {r['arch']} | {r['value']:.1f} | {med:.3f} "
                f"[{float(m['cpu_s_min']):.3f}, {float(m['cpu_s_max']):.3f}] | {r['value'] / (med * scale):,.0f} |\n")


if __name__ == "__main__":
    main()
