#!/usr/bin/env python3
"""Writes the numbers of docs/jax-atlas.md from the atlas's run files.

    python3 examples/jax-atlas-page.py runs/jax-atlas --classic runs/jax-atlas-classic
    python3 examples/jax-atlas-page.py --check      # does the page match docs/jax-atlas/?

`--page FILE.md` works on another copy of the page, its files in the folder FILE/.

With run directories: copies their `stats.csv`, `run.json` and `manifest.toml` into
docs/jax-atlas/ (several directories, e.g. the halves of a study run apart, are joined
into one file each), and with `--classic DIR` the classic set's files into
docs/jax-atlas/classic/, then rewrites every generated part of the page from those files.
With --check: rewrites nothing, and exits 1 if the page is not what the files give.

A generated part lies between `<!-- generated: NAME -->` and `<!-- end generated -->`
lines; everything else of the page is left as it is. Python's standard library only.
"""

import csv
import json
import math
import shutil
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PAGE = REPO / "docs" / "jax-atlas.md"
FILES = REPO / "docs" / "jax-atlas"  # PAGE without ".md"
RANDOM = "random"


def copy_runs(run_dirs):
    """Joins the runs' stats.csv rows and run.json cells into docs/jax-atlas/."""
    FILES.mkdir(exist_ok=True)
    header, rows, meta = [], [], None
    for d in map(Path, run_dirs):
        with open(d / "stats.csv", newline="") as f:
            r = csv.DictReader(f)
            # (a run with `non_finite = "end"` envs has one more column)
            header += [k for k in r.fieldnames if k not in header]
            rows.extend(r)
        m = json.loads((d / "run.json").read_text())
        if meta is None:
            meta = m
        else:
            meta["cells"].extend(m["cells"])
            meta["env_steps"] += m["env_steps"]
            meta["wall_s"] += m["wall_s"]
    with open(FILES / "stats.csv", "w", newline="") as f:
        w = csv.DictWriter(f, header, restval="", lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    (FILES / "run.json").write_text(json.dumps(meta, indent=2) + "\n")
    if len(run_dirs) == 1:
        shutil.copyfile(Path(run_dirs[0]) / "manifest.toml", FILES / "manifest.toml")


def copy_classic(run_dir):
    """The classic set's run files, into docs/jax-atlas/classic/."""
    to = FILES / "classic"
    to.mkdir(parents=True, exist_ok=True)
    for name in ("stats.csv", "run.json", "manifest.toml"):
        shutil.copyfile(Path(run_dir) / name, to / name)


def load():
    """The cells of docs/jax-atlas/ (stats.csv rows with run.json's fields),
    in the run's order, and run.json."""
    meta = json.loads((FILES / "run.json").read_text())
    with open(FILES / "stats.csv", newline="") as f:
        stats = {r["dir"]: r for r in csv.DictReader(f)}
    cells = []
    for c in meta["cells"]:
        row = dict(stats[c["dir"]])
        row["env_steps"] = c["env_steps"]
        row["solved_source"] = c.get("solved_source")
        cells.append(row)
    return cells, meta


def num(x):
    """A statistic as rwg's tables show it (4 significant digits)."""
    if x in ("", None):
        return "–"
    v = float(x)
    if v == 0:
        return "0"
    if abs(v) >= 1e5 or abs(v) < 1e-3:
        return f"{v:.2e}"
    return f"{v:.{max(0, 3 - int(math.floor(math.log10(abs(v)))))}f}"


def envs_of(cells):
    order = []
    for c in cells:
        if c["env"] not in order:
            order.append(c["env"])
    return order


def nets(cells, env):
    return [c for c in cells if c["env"] == env and c["arch"] != RANDOM]


def rand(cells, env):
    return next((c for c in cells if c["env"] == env and c["arch"] == RANDOM), None)


def non_finite(c):
    return int(c.get("non_finite_episodes") or 0)


def missing(cells):
    """The envs of manifest.toml's study with a cell the run files lack."""
    path = FILES / "manifest.toml"
    if not path.exists():
        return []
    m = tomllib.loads(path.read_text())
    have = {(c["env"], c["arch"]) for c in cells}
    return [e["id"] for e in m["envs"]
            if any((e["id"], a["name"]) not in have for a in m["architectures"])]


def counts(cells, meta):
    n_envs = len(envs_of(cells))
    libraries = {e.split(":")[0] for e in envs_of(cells)}
    text = (f"Each cell holds **{meta['samples']} networks × {meta['episodes']} episodes**: "
            f"{len(cells)} cells, {n_envs} env{'s' * (n_envs != 1)} of {len(libraries)} "
            f"librar{'ies' if len(libraries) != 1 else 'y'} "
            f"(`run.json` counts {meta['env_steps']:,} env steps).")
    lacking = missing(cells)
    if lacking:
        text += (f" The run files lack cells of {len(lacking)} envs of the study, which "
                 f"this page leaves out: {', '.join(lacking)}.")
    return text


def env_table(cells, meta):
    out = ["| env | solved at | random actions: mean M (mean length) | networks: median M "
           "| best M (arch) | solved: networks of "
           f"{meta['samples']} (0HL / [4] / [4,4]) | non-finite episodes |",
           "| :--- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for env in envs_of(cells):
        ns, r = nets(cells, env), rand(cells, env)
        best = max(ns, key=lambda c: float(c["best_mean"]))
        median = max(float(c["median_mean"]) for c in ns)
        solved = (" / ".join(c["solved_count"] for c in ns) if ns[0]["solved"] else "–")
        at = num(ns[0]["solved"]) if ns[0]["solved"] else "none"
        nf = sum(non_finite(c) for c in ns + ([r] if r else []))
        random = (f"{num(r['mean_of_means'])} ({num(r['mean_episode_length'])})" if r else "–")
        out.append(f"| {env} | {at} | {random} | {num(median)} | "
                   f"{num(best['best_mean'])} ({best['arch']}) | {solved} | {nf} |")
    return "\n".join(out)


def cell_table(cells, meta):
    out = ["| env | arch | best M | p99.9 M | mean M | p(solved) [95% Wilson] | 1/p [95%] "
           "| mean length |",
           "| :--- | :--- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for c in cells:
        if c["solved"]:
            p = f"{num(c['p_solved'])} [{num(c['p_solved_lo'])}, {num(c['p_solved_hi'])}]"
            if c["expected_guesses"]:
                g = (f"{num(c['expected_guesses'])} [{num(c['expected_guesses_lo'])}, "
                     f"{num(c['expected_guesses_hi'])}]")
            else:
                g = f"none seen (≥ {num(c['expected_guesses_lo'])})"
        else:
            p = g = "no solved score"
        out.append(f"| {c['env']} | {c['arch']} | {num(c['best_mean'])} | "
                   f"{num(c['p99.9_mean'])} | {num(c['mean_of_means'])} | {p} | {g} | "
                   f"{num(c['mean_episode_length'])} |")
    return "\n".join(out)


def shows(cells, meta):
    envs = envs_of(cells)
    with_score = [e for e in envs if nets(cells, e)[0]["solved"]]
    solved = [e for e in with_score if any(int(c["solved_count"]) for c in nets(cells, e))]
    lines = [f"- **Solved by random networks**: {len(solved)} of the {len(with_score)} envs "
             "that have a solved score."]
    for e in solved:
        parts = [f"{c['arch']} {c['solved_count']} of {c['samples']} (1/p = "
                 f"{num(c['expected_guesses'])})" for c in nets(cells, e)
                 if int(c["solved_count"])]
        r = rand(cells, e)
        by_random = (f"; random actions: {r['solved_count']} of {r['samples']}" if r else "")
        lines.append(f"  - {e}: {', '.join(parts)}{by_random}.")
    unsolved = [e for e in with_score if e not in solved]
    if unsolved:
        lines.append(f"  - Not solved by any network: {', '.join(unsolved)}.")
    by_random = [e for e in with_score if rand(cells, e) and int(rand(cells, e)["solved_count"])]
    where = ", ".join(f"{e} ({rand(cells, e)['solved_count']} of {rand(cells, e)['samples']}, "
                      f"1/p = {num(rand(cells, e)['expected_guesses'])})" for e in by_random)
    lines.append(f"- **Solved by random actions**: {where if by_random else 'none'}.")
    above = [e for e in envs if rand(cells, e) and max(float(c["best_mean"])
             for c in nets(cells, e)) > float(rand(cells, e)["best_mean"])]
    lines.append(f"- **Best network above the best random-action mean**: {len(above)} of "
                 f"{len(envs)} envs.")
    below = [e for e in envs if rand(cells, e) and
             sorted(float(c["median_mean"]) for c in nets(cells, e))[-1]
             < float(rand(cells, e)["mean_of_means"])]
    lines.append("- **Median network of every architecture below the random actions' mean "
                 f"return**: {', '.join(below) if below else 'none'}.")
    nf = [(c["env"], c["arch"], non_finite(c)) for c in cells if non_finite(c)]
    where = ", ".join(f"{e} {a} ({n})" for e, a, n in nf)
    lines.append("- **Non-finite physics** (episodes ended by `non_finite = \"end\"`): "
                 f"{where if nf else 'none'}.")
    return "\n".join(lines)


def run_table(cells, meta):
    """When the run ran and what it computed (run.json)."""
    return "\n".join([
        "| | |",
        "|---|---|",
        f"| started, ended (`run.json`) | {meta['start_time']}, {meta['end_time']} |",
        f"| cells, env steps | {len(meta['cells'])}, {meta['env_steps']:,} |",
    ])


BLOCKS = {"run": run_table, "counts": counts, "envs": env_table, "cells": cell_table, "shows": shows}


def render(page, cells, meta):
    out, lines, i = [], page.split("\n"), 0
    while i < len(lines):
        line = lines[i]
        out.append(line)
        i += 1
        if line.startswith("<!-- generated: "):
            name = line[len("<!-- generated: "):].split()[0]
            if name not in BLOCKS:
                sys.exit(f"{PAGE}: unknown generated part '{name}'")
            while i < len(lines) and lines[i] != "<!-- end generated -->":
                i += 1
            if i == len(lines):
                sys.exit(f"{PAGE}: generated part '{name}' has no end line")
            out.append(BLOCKS[name](cells, meta))
            out.append(lines[i])
            i += 1
    return "\n".join(out)


def main(argv):
    global PAGE, FILES
    if "--page" in argv:
        i = argv.index("--page")
        if i + 1 == len(argv) or not argv[i + 1].endswith(".md"):
            sys.exit("--page takes a file name ending in .md")
        PAGE = Path(argv[i + 1]).resolve()
        FILES = PAGE.with_suffix("")
        argv = argv[:i] + argv[i + 2:]
    classic = None
    if "--classic" in argv:
        i = argv.index("--classic")
        if i + 1 == len(argv):
            sys.exit("--classic takes the classic set's run directory")
        classic = argv[i + 1]
        argv = argv[:i] + argv[i + 2:]
    check = "--check" in argv
    runs = [a for a in argv if a != "--check"]
    if (runs or classic) and check:
        sys.exit("--check takes no run directory: it checks docs/jax-atlas/")
    if runs:
        copy_runs(runs)
    if classic:
        copy_classic(classic)
    cells, meta = load()
    lacking = missing(cells)
    cells = [c for c in cells if c["env"] not in lacking]
    page = PAGE.read_text()
    new = render(page, cells, meta)
    if check:
        if new != page:
            sys.exit(f"{PAGE} does not match {FILES}/: run "
                     "python3 examples/jax-atlas-page.py RUN_DIR")
        return
    PAGE.write_text(new)
    print(f"wrote {PAGE} from {FILES}/")


if __name__ == "__main__":
    main(sys.argv[1:])
