"""Shared pieces of the RWG peer scripts: CLI, weight sampling, CSV and JSON output.

Network convention (same as the paper's reference FFNN): for each layer a weight
matrix W of shape (out, in [+1 if bias]); forward pass per layer is
    x = tanh(W @ [x, (1.0 if bias)])
including the output layer.  Discrete envs take argmax of the outputs (tanh is
monotonic, so it does not change the argmax); continuous envs take
action = high * tanh(output).

Weights: all i.i.d. N(0, 1), drawn from numpy.random.default_rng(seed) as one
(N_samples, N_params) matrix, so sample i has the same weights whatever N_samples
is (the first 100 samples of a 1000-sample run equal a 100-sample run), and every
peer evaluates exactly the same networks for a given seed.
"""

import argparse
import json
import os
import sys
import time
import warnings

import numpy as np

# gymnasium warns that CartPole-v0 is "out of date"; v0 is what the paper used.
warnings.filterwarnings("ignore", category=DeprecationWarning)
# EnvPool's spaces make gymnasium warn about float64 bounds cast to float32.
warnings.filterwarnings("ignore", message=".*precision lowered by casting.*")

# Score at or above which an environment counts as "solved" (paper / gym).
SOLVED = {
    "CartPole-v0": 195.0,
    "CartPole-v1": 475.0,
    "MountainCar-v0": -110.0,
    "MountainCarContinuous-v0": 90.0,
    "Pendulum-v0": -140.0,
    "Pendulum-v1": -140.0,
    "Acrobot-v1": -60.0,
}


def make_parser(description):
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--env", required=True, help="environment id, e.g. CartPole-v0")
    p.add_argument("--hidden", default="",
                   help='hidden layer sizes, comma separated: "" (linear), "4", "4,4"')
    p.add_argument("--bias", action=argparse.BooleanOptionalAction, default=False,
                   help="append a constant 1.0 input to every layer (default: --no-bias)")
    p.add_argument("--samples", type=int, default=1000, help="number of networks")
    p.add_argument("--episodes", type=int, default=20, help="episodes per network")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", required=True, help="CSV file: sample,episode,score")
    return p


def parse_hidden(s):
    return [int(t) for t in s.replace(" ", "").split(",") if t]


def layer_shapes(obs_dim, hidden, out_dim, bias):
    """List of (out, in) weight-matrix shapes, `in` including the bias input."""
    sizes = [obs_dim] + list(hidden) + [out_dim]
    return [(sizes[i + 1], sizes[i] + (1 if bias else 0)) for i in range(len(sizes) - 1)]


def sample_weights(n_samples, shapes, seed):
    """List (one per layer) of arrays of shape (n_samples, out, in), float64."""
    n_params = sum(o * i for o, i in shapes)
    flat = np.random.default_rng(seed).standard_normal((n_samples, n_params))
    out, k = [], 0
    for o, i in shapes:
        out.append(np.ascontiguousarray(flat[:, k:k + o * i].reshape(n_samples, o, i)))
        k += o * i
    return out


def write_csv(path, scores):
    """scores: (N_samples, N_episodes) array -> CSV with sample,episode,score."""
    n, e = scores.shape
    d = os.path.dirname(path)
    if d:
        os.makedirs(d, exist_ok=True)
    s_idx = np.repeat(np.arange(n), e)
    e_idx = np.tile(np.arange(e), n)
    with open(path, "w") as f:
        f.write("sample,episode,score\n")
        f.write("".join(f"{a},{b},{c!r}\n" for a, b, c in
                        zip(s_idx.tolist(), e_idx.tolist(), scores.reshape(-1).tolist())))


def summary(env_id, scores):
    """Statistics over per-sample mean scores."""
    means = scores.mean(axis=1)
    solved = SOLVED.get(env_id)
    return {
        "frac_solved": None if solved is None else float(np.mean(means >= solved)),
        "best_mean": float(means.max()),
        "p999_mean": float(np.percentile(means, 99.9)),
        "mean_of_means": float(means.mean()),
    }


class Timer:
    """Wall and process-CPU time (CPU time sums all threads of this process)."""

    def __init__(self):
        self.w0 = time.perf_counter()
        self.c0 = time.process_time()

    def wall(self):
        return time.perf_counter() - self.w0

    def cpu(self):
        return time.process_time() - self.c0


def report(peer, args, wall_s, env_steps, scores, cpu_s=None, **extra):
    """Print the one-line JSON result (last line of stdout)."""
    d = {
        "peer": peer,
        "env": args.env,
        "hidden": args.hidden,
        "bias": bool(args.bias),
        "samples": args.samples,
        "episodes": args.episodes,
        "wall_s": round(wall_s, 4),
        "env_steps": int(env_steps),
        "steps_per_s": round(env_steps / wall_s, 1) if wall_s > 0 else None,
    }
    if cpu_s is not None:
        d["cpu_s"] = round(cpu_s, 4)
        d["steps_per_cpu_s"] = round(env_steps / cpu_s, 1) if cpu_s > 0 else None
    d.update(extra)
    d.update(summary(args.env, scores))
    d["python"] = sys.version.split()[0]
    print(json.dumps(d), flush=True)
    return d


def run_refill(reset, step, weights, batch, n_jobs, episodes, bias, discrete, high):
    """Run n_jobs episodes on a vector env of `batch` slots with NEXT_STEP autoreset.

    Job j is (sample j // episodes, episode j % episodes).  Each slot runs one job's
    episode at a time and is refilled with the next job when that episode ends.
    NEXT_STEP autoreset (Gymnasium's default, and EnvPool's behaviour): the step call
    after a slot's terminal step only resets that slot (reward 0, action ignored),
    and the observation it returns starts the slot's next job.  That call is not
    counted as an env step.

    reset() -> obs (B, obs_dim); step(action) -> (obs, reward, terminated, truncated)
    Returns (scores of shape (n_jobs,), useful env steps, number of step calls).
    """
    B = batch
    slot_w = [np.zeros((B,) + w.shape[1:]) for w in weights]
    job = np.full(B, -1, dtype=np.int64)          # job of each slot, -1 = idle
    pending = np.zeros(B, dtype=bool)            # slot is reset by the next call
    ret = np.zeros(B)
    scores = np.full(n_jobs, np.nan)
    state = {"next": 0}

    def assign(slots):
        nxt = state["next"]
        k = min(len(slots), n_jobs - nxt)
        s, rest = slots[:k], slots[k:]
        if k:
            js = np.arange(nxt, nxt + k)
            state["next"] = nxt + k
            job[s] = js
            samp = js // episodes
            for l in range(len(weights)):
                slot_w[l][s] = weights[l][samp]
            ret[s] = 0.0
        job[rest] = -1

    obs = reset()
    assign(np.arange(B))
    ones = np.ones((B, 1))
    done_jobs = steps = calls = 0
    while done_jobs < n_jobs:
        x = np.asarray(obs, dtype=np.float64)
        for W in slot_w:
            if bias:
                x = np.concatenate((x, ones), axis=1)
            x = np.tanh(np.einsum("boi,bi->bo", W, x))
        action = np.argmax(x, axis=1) if discrete else high * x
        obs, r, term, trunc = step(action)
        calls += 1
        active = (job >= 0) & ~pending
        steps += int(active.sum())
        ret[active] += r[active]
        fin = active & (term | trunc)
        if fin.any():
            scores[job[fin]] = ret[fin]
            done_jobs += int(fin.sum())
        was_reset = np.flatnonzero(pending)   # these slots now hold a fresh episode
        if len(was_reset):
            assign(was_reset)
        pending = fin
    assert not np.isnan(scores).any()
    return scores, steps, calls
