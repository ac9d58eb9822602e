#!/usr/bin/env bash
# What the plugin ABI costs: `rwg run` on the built-in CartPole-v0 and on the
# same code through the reference plugin (classic_control/CartPole-v0), one
# worker thread, for three architectures; the plugin through its single
# calls (RWG_PLUGIN_BATCH=0, "single"), through ABI 1.1's batched calls
# (RWG_PLUGIN_VEC=0, "batched") and through ABI 1.2's vector env (rwg run's
# default for a plugin that has one, "vec"). Runs alternate (built-in, single,
# batched, vec, built-in, ...)
# and the medians of RUNS runs are reported: user CPU time per environment step
# (robust on a busy machine) and wall time of the whole `rwg run` (what you
# wait for, results written included; a plugin run also loads the plugin and
# runs its determinism checks first). For every classic env in one process,
# without the start-up: `rwg bench plugin --plugin FILE`.
#
#   cargo build --release -p rwg-cli -p rwg-plugin-classic-control
#   examples/plugin-overhead.sh            # RUNS=5 SAMPLES=10000 EPISODES=20
#
# CartPole is the worst case: the cheapest env step, so the fixed cost of
# crossing the ABI (two calls, checks on both sides) weighs most. The ids
# differ, so the seeds differ: the runs are compared per step, not by score.
set -euo pipefail

RWG=${RWG:-target/release/rwg}
PLUGIN=${PLUGIN:-target/release/librwg_plugin_classic_control.so}
RUNS=${RUNS:-5}
SAMPLES=${SAMPLES:-10000}
EPISODES=${EPISODES:-20}
for f in "$RWG" "$PLUGIN"; do
    [ -e "$f" ] || { echo "$f not found: cargo build --release -p rwg-cli -p rwg-plugin-classic-control" >&2; exit 1; }
done
PLUGIN=$(cd "$(dirname "$PLUGIN")" && pwd)/$(basename "$PLUGIN")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }

printf '%-8s  %-9s  %12s  %10s  %8s  %10s\n' arch env "env steps" "ns/step" "CPU x" "wall s"
for arch in "0HL:" "1HL-4:4" "2HL-4-4:4, 4"; do
    name=${arch%%:*}
    hidden=${arch#*:}
    for env in builtin single batched vec; do
        if [ "$env" = builtin ]; then
            entry='id = "CartPole-v0"'
        else
            entry=$(printf 'id = "classic_control/CartPole-v0"\nplugin = "%s"' "$PLUGIN")
        fi
        printf 'seed = 0\nsamples = %s\nepisodes = %s\n[[architectures]]\nname = "%s"\nhidden = [%s]\n[[envs]]\n%s\n' \
            "$SAMPLES" "$EPISODES" "$name" "$hidden" "$entry" >"$tmp/$env.toml"
    done
    for _ in $(seq "$RUNS"); do
        for env in builtin single batched vec; do
            batch=1 vec=1
            [ "$env" = single ] && batch=0
            [ "$env" = batched ] && vec=0
            TIMEFORMAT="%U %R"
            { time RWG_PLUGIN_BATCH=$batch RWG_PLUGIN_VEC=$vec "$RWG" run "$tmp/$env.toml" --threads 1 --no-report --out "$tmp/$env" --force-new >/dev/null 2>&1; } 2>>"$tmp/$env.times"
        done
    done
    base=
    for env in builtin single batched vec; do
        steps=$(grep -m1 '"env_steps"' "$tmp/$env/run.json" | tr -dc '0-9')
        user=$(cut -d' ' -f1 "$tmp/$env.times" | median)
        wall=$(cut -d' ' -f2 "$tmp/$env.times" | median)
        ns=$(awk -v u="$user" -v s="$steps" 'BEGIN {printf "%.1f", u * 1e9 / s}')
        [ -z "$base" ] && base=$ns
        ratio=$(awk -v a="$ns" -v b="$base" 'BEGIN {printf "%.2f", a / b}')
        printf '%-8s  %-9s  %12s  %10s  %8s  %10s\n' "$name" "$env" "$steps" "$ns" "$ratio" "$wall"
    done
    rm -f "$tmp"/*.times
done
