#!/usr/bin/env python3
"""rwg against the Python peers, side by side in one sitting, per core.

For each workload (env x hidden layers, no bias) and each of --rounds rounds,
runs the whole `rwg run --threads 1` on a one-cell manifest and every chosen
peer script, one after the other in an order that rotates from round to round
and workload to workload, all pinned to one core (this process pins itself;
its children inherit the pinning). Compares env steps per CPU-second:

- rwg: the child's whole CPU time (user + system, getrusage of the waited-for
  child): start-up, sampling, block commits, statistics and the report;
- a peer: the CPU time its JSON line reports for its run (from env creation to
  the scores in memory; Python start-up, imports and, for gymnax, the XLA
  compilation excluded). Its whole process's CPU time is kept in --json too.

Env steps on both sides are the transitions inside episodes. A ratio is rwg's
rate over the peer's rate in the same round; the table gives the median and
min-max over the rounds. Run it with the Python of the peers' virtualenv (see
README.md), from anywhere:

    python benches/peers/side_by_side.py --rwg target/release/rwg
"""

import argparse
import datetime
import importlib.util
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))

# The standard workload: env id and hidden layer sizes ("" = no hidden layer).
WORKLOADS = [
    ("CartPole-v0", ""),
    ("CartPole-v0", "4,4"),
    ("Acrobot-v1", ""),
    ("MountainCarContinuous-v0", "4,4"),
    ("Pendulum-v1", "4"),
]

# Peer name -> (script, extra arguments, networks per run by default, module it needs).
# The slow peers get fewer networks: the figures compared are rates.
PEERS = {
    "ref_numpy": ("ref_numpy.py", [], 100, "gymnasium"),
    "gym_vector": ("gym_vector.py", [], 100, "gymnasium"),
    "envpool-t1": ("envpool_rwg.py", ["--threads", "1"], 300, "envpool"),
    "gymnax-raw": ("gymnax_rwg.py", ["--step", "raw"], 1000, "gymnax"),
}


def label(env, hidden):
    return f"{env} {'0HL' if not hidden else '[' + hidden + ']'}"


def manifest_text(env, hidden, samples, episodes, seed):
    layers = [h for h in hidden.split(",") if h]
    name = f"{len(layers)}HL" if layers else "0HL"
    return (f"seed = {seed}\nsamples = {samples}\nepisodes = {episodes}\nbias = [false]\n\n"
            f"[weights]\ndistribution = \"normal\"\nscale = 1.0\n\n"
            f"[[architectures]]\nname = \"{name}\"\nhidden = [{', '.join(layers)}]\n\n"
            f"[[envs]]\nid = \"{env}\"\n")


def children_cpu():
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def run_child(cmd, what):
    """Runs cmd to completion; returns (stdout, its CPU seconds)."""
    c0 = children_cpu()
    out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    cpu = children_cpu() - c0
    if out.returncode != 0:
        sys.exit(f"{what} failed (exit status {out.returncode}):\n{out.stderr}")
    return out.stdout, cpu


def last_json(stdout, what):
    lines = [line for line in stdout.splitlines() if line.strip()]
    try:
        return json.loads(lines[-1])
    except (IndexError, json.JSONDecodeError):
        sys.exit(f"{what}: its last line of output is not its JSON result:\n{stdout}")


def spread(values):
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def git_commit():
    """The commit of the checkout these scripts are in (the rwg measured is
    the caller's to match)."""
    try:
        out = subprocess.run(["git", "-C", HERE, "rev-parse", "--short", "HEAD"],
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        return out.stdout.strip() or "unknown"
    except OSError:
        return "unknown"


def load_avg():
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "unknown"


def parse_args():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rwg", default="target/release/rwg", help="the rwg binary to measure")
    p.add_argument("--peers", default=None,
                   help=f"comma-separated peers out of {', '.join(PEERS)} (default: all "
                        "whose packages this Python has)")
    p.add_argument("--env", action="append", default=[],
                   help="run only this env's workloads (repeatable)")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--rwg-samples", type=int, default=3000, help="networks per rwg run")
    p.add_argument("--peer-samples", action="append", default=[], metavar="PEER=N",
                   help="networks per run of a peer (repeatable; defaults: "
                        + ", ".join(f"{k} {v[2]}" for k, v in PEERS.items()) + ")")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--cpu", type=int, default=0, help="the core everything is pinned to")
    p.add_argument("--work-dir", default=None,
                   help="where run directories and CSVs go (default: a temporary directory)")
    p.add_argument("--json", default=None, metavar="FILE",
                   help="also write every measurement to FILE")
    return p.parse_args()


def chosen_peers(args):
    if args.peers is not None:
        names = [n for n in args.peers.split(",") if n]
        for n in names:
            if n not in PEERS:
                sys.exit(f"--peers: unknown peer {n!r}; peers: {', '.join(PEERS)}")
        return names
    names = []
    for n, (_, _, _, module) in PEERS.items():
        if importlib.util.find_spec(module) is None:
            print(f"note: {n} left out: this Python has no `{module}` (see README.md)",
                  file=sys.stderr)
        else:
            names.append(n)
    return names


def main():
    args = parse_args()
    if min(args.rounds, args.rwg_samples, args.episodes) < 1:
        sys.exit("--rounds, --rwg-samples and --episodes must be at least 1")
    peers = chosen_peers(args)
    samples = {n: v[2] for n, v in PEERS.items()}
    for item in args.peer_samples:
        name, _, n = item.partition("=")
        if name not in PEERS or not n.isdigit() or int(n) < 1:
            sys.exit(f"--peer-samples {item!r}: expected PEER=N with PEER one of "
                     f"{', '.join(PEERS)} and N >= 1")
        samples[name] = int(n)
    known = {w[0] for w in WORKLOADS}
    for e in args.env:
        if e not in known:
            sys.exit(f"--env {e}: no workload uses it; workloads: {', '.join(sorted(known))}")
    workloads = [w for w in WORKLOADS if not args.env or w[0] in args.env]
    rwg = os.path.abspath(args.rwg)
    if not os.path.isfile(rwg):
        sys.exit(f"--rwg {args.rwg} not found: build it with cargo build --release -p rwg-cli")
    os.sched_setaffinity(0, {args.cpu})
    work = args.work_dir or tempfile.mkdtemp(prefix="rwg-side-by-side-")
    os.makedirs(work, exist_ok=True)
    setup = {
        "date_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M"),
        "cpu_model": cpu_model(), "cpus": os.cpu_count(), "pinned_cpu": args.cpu,
        "commit": git_commit(), "load_avg_start": load_avg(), "rounds": args.rounds,
        "episodes": args.episodes, "seed": args.seed, "rwg_samples": args.rwg_samples,
        "peer_samples": {n: samples[n] for n in peers}, "python": sys.version.split()[0],
    }
    sides = ["rwg"] + peers
    rows = {w: {s: [] for s in sides} for w in workloads}
    for rnd in range(args.rounds):
        for i, (env, hidden) in enumerate(workloads):
            k = (rnd + i) % len(sides)
            for side in sides[k:] + sides[:k]:
                tag = f"w{i}-{side}"
                what = f"{side} ({label(env, hidden)})"
                if side == "rwg":
                    manifest = os.path.join(work, f"w{i}.toml")
                    with open(manifest, "w") as f:
                        f.write(manifest_text(env, hidden, args.rwg_samples, args.episodes,
                                              args.seed))
                    out_dir = os.path.join(work, tag)
                    _, cpu = run_child([rwg, "run", manifest, "--threads", "1", "--force-new",
                                        "--out", out_dir], what)
                    with open(os.path.join(out_dir, "run.json")) as f:
                        steps = json.load(f)["env_steps"]
                    m = {"env_steps": steps, "cpu_s": cpu, "process_cpu_s": cpu}
                else:
                    script, extra, _, _ = PEERS[side]
                    cmd = [sys.executable, os.path.join(HERE, script), *extra, "--env", env,
                           "--hidden", hidden, "--no-bias", "--samples", str(samples[side]),
                           "--episodes", str(args.episodes), "--seed", str(args.seed),
                           "--out", os.path.join(work, tag + ".csv")]
                    stdout, cpu = run_child(cmd, what)
                    j = last_json(stdout, what)
                    m = {"env_steps": j["env_steps"], "cpu_s": j["cpu_s"],
                         "process_cpu_s": cpu}
                m["steps_per_cpu_s"] = m["env_steps"] / m["cpu_s"]
                rows[(env, hidden)][side].append(m)
                print(f"round {rnd + 1}/{args.rounds}  {what:<44} "
                      f"{m['steps_per_cpu_s']:.3e} steps/CPU-s", file=sys.stderr, flush=True)
    setup["load_avg_end"] = load_avg()
    report = {"setup": setup, "rows": []}
    for (env, hidden), by_side in rows.items():
        rates = {s: [m["steps_per_cpu_s"] for m in ms] for s, ms in by_side.items()}
        report["rows"].append({
            "env": env, "hidden": hidden, "measurements": by_side,
            "steps_per_cpu_s": {s: spread(v) for s, v in rates.items()},
            "rwg_over": {p: spread([r / q for r, q in zip(rates["rwg"], rates[p])])
                         for p in peers},
        })
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)
    print_table(report, peers)


def print_table(report, peers):
    s = report["setup"]
    print(f"{s['date_utc']} UTC, {s['cpu_model']} ({s['cpus']} CPUs), all pinned to CPU "
          f"{s['pinned_cpu']}, checkout at {s['commit']}, {s['rounds']} rounds, load average "
          f"{s['load_avg_start']} -> {s['load_avg_end']}")
    print(f"rwg run --threads 1: {s['rwg_samples']} networks x {s['episodes']} episodes; peers: "
          + ", ".join(f"{n} {k}" for n, k in s["peer_samples"].items())
          + " networks; env steps per CPU-second, median [min-max]\n")

    def rate(x):
        return f"{x['median'] / 1e6:.3g}M [{x['min'] / 1e6:.3g}-{x['max'] / 1e6:.3g}]"

    def ratio(x):
        return f"{x['median']:.2f}x [{x['min']:.2f}-{x['max']:.2f}]"

    head = ["workload", "rwg"] + [f"{p} (rwg / {p})" for p in peers]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in report["rows"]:
        cells = [label(r["env"], r["hidden"]), rate(r["steps_per_cpu_s"]["rwg"])]
        cells += [f"{rate(r['steps_per_cpu_s'][p])} ({ratio(r['rwg_over'][p])})" for p in peers]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
