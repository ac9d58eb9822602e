#!/usr/bin/env python3
"""rwg's CPU time per cell of the paper's study, one cell and one thread at a time.

    python3 examples/paper-runtime.py > runtime.csv
    python3 examples/paper-runtime.py --repeats 3 --samples 1000 --rwg target/release/rwg

The paper's runtime table gives, per cell (10^4 networks x 20 episodes, no bias), the
seconds its code took: one Python process per cell, on one core. This script runs each cell
of examples/paper-exact.toml (the paper's code's episode cap) the same way: `rwg run` of a
manifest holding that cell alone, `--threads 1`, and records the CPU time (user + system)
of the whole command, repeated `--repeats` times with the cells interleaved (cell 1..15,
then again), so a slow minute of a noisy machine spreads over all cells. It prints one CSV
row per cell: the median, minimum and maximum over the repeats. Standard library only
(Python 3.11 or later, for tomllib). examples/paper-tables.py turns it into the doc's table.
"""

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))


def cpu_model():
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def one_cell_manifest(study, env, arch, samples, episodes):
    """A manifest of `study` with only `env` x `arch`, no bias."""
    lines = [
        f"seed = {study['seed']}",
        f"samples = {samples}",
        f"episodes = {episodes}",
        "bias = [false]",
        "",
        "[weights]",
        f'distribution = "{study["weights"]["distribution"]}"',
        f"scale = {study['weights']['scale']}",
        "",
        "[[architectures]]",
        f'name = "{arch["name"]}"',
        f"hidden = {arch['hidden']}",
        "",
        "[[envs]]",
        f'id = "{env["id"]}"',
        f"solved = {env['solved']}",
        f"max_episode_steps = {env['max_episode_steps']}",
    ]
    return "\n".join(lines) + "\n"


def cpu_seconds(cmd):
    """Runs `cmd`; its CPU time (user + system, children included) in seconds."""
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    if proc.returncode != 0:
        sys.exit(f"paper-runtime: {' '.join(cmd)} failed (exit {proc.returncode}):\n{err}")
    return usage.ru_utime + usage.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--manifest", default=os.path.join(HERE, "paper-exact.toml"))
    ap.add_argument("--rwg", default="rwg", help="the rwg to time (default: rwg on PATH)")
    ap.add_argument("--samples", type=int, default=10000)
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()

    with open(args.manifest, "rb") as f:
        study = tomllib.load(f)
    cells = [(e, a) for e in study["envs"] for a in study["architectures"]]
    version = subprocess.run([args.rwg, "--version"], capture_output=True, text=True).stdout.strip()
    commit = subprocess.run(["git", "-C", HERE, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip() or "no git checkout"
    times = {i: [] for i in range(len(cells))}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeats):
            for i, (env, arch) in enumerate(cells):
                m = os.path.join(tmp, f"cell{i}.toml")
                with open(m, "w") as f:
                    f.write(one_cell_manifest(study, env, arch, args.samples, args.episodes))
                out = os.path.join(tmp, f"run{i}")
                cmd = [args.rwg, "run", m, "--out", out, "--threads", "1", "--no-report",
                       "-q", "--force-new"]
                times[i].append(cpu_seconds(cmd))
                print(f"repeat {r + 1}/{args.repeats}: {env['id']} {arch['name']} "
                      f"{times[i][-1]:.3f} s", file=sys.stderr)
    print(f"# {version} (source: commit {commit}); {cpu_model()}; {os.cpu_count()} logical CPUs; "
          f"{time.strftime('%Y-%m-%d', time.gmtime())}; {args.samples} networks x "
          f"{args.episodes} episodes per cell, one thread, {args.repeats} repeats interleaved")
    print("env,arch,samples,episodes,repeats,cpu_s_median,cpu_s_min,cpu_s_max")
    for i, (env, arch) in enumerate(cells):
        t = times[i]
        print(f"{env['id']},{arch['name']},{args.samples},{args.episodes},{args.repeats},"
              f"{statistics.median(t):.3f},{min(t):.3f},{max(t):.3f}")


if __name__ == "__main__":
    main()
