#!/usr/bin/env python3
"""Peer 3: EnvPool (C++ env pool; --threads worker threads, 2 by default) + batched numpy policy.

EnvPool in synchronous mode (batch_size = num_envs = B).  The slot/refill logic
is the same as gym_vector's (rwg_common.run_refill): each slot runs one episode
of one (sample, episode) job at a time and is refilled when it ends.  EnvPool
auto-resets like Gymnasium's NEXT_STEP mode: the step call after a terminal
step resets that env (reward 0, elapsed_step 0, action ignored); that call is
not counted as an env step.

EnvPool has CartPole-v0 itself (max_episode_steps=200), so no mapping is needed;
the fallback to CartPole-v1 with max_episode_steps=200 is only used if v0 is
missing from the installed EnvPool.

env_steps counts the transitions that belong to some job's episode;
env_steps_simulated counts every env transition EnvPool computed (B per call).
"""

import numpy as np
import envpool
import gymnasium as gym

from rwg_common import (Timer, layer_shapes, make_parser, parse_hidden, report,
                        run_refill, sample_weights, write_csv)

PEER = "envpool"


def main():
    p = make_parser(__doc__)
    p.add_argument("--batch", type=int, default=1000,
                   help="num_envs = batch_size B (capped at samples*episodes)")
    p.add_argument("--threads", type=int, default=2, help="EnvPool num_threads")
    args = p.parse_args()
    hidden = parse_hidden(args.hidden)
    env_id, kw, note = args.env, {}, ""
    available = set(envpool.list_all_envs())
    if env_id not in available and env_id == "CartPole-v0":
        env_id, kw = "CartPole-v1", {"max_episode_steps": 200}
        note = "CartPole-v0 not in envpool; ran CartPole-v1 with max_episode_steps=200"
    n_jobs = args.samples * args.episodes
    B = max(1, min(args.batch, n_jobs))
    E = args.episodes

    t = Timer()
    envs = envpool.make(env_id, env_type="gymnasium", num_envs=B, batch_size=B,
                        num_threads=args.threads, seed=args.seed, **kw)
    sobs, sact = envs.observation_space, envs.action_space
    obs_dim = sobs.shape[0]
    discrete = isinstance(sact, gym.spaces.Discrete)
    out_dim = int(sact.n) if discrete else sact.shape[0]
    high = None if discrete else np.asarray(sact.high, dtype=np.float64)
    shapes = layer_shapes(obs_dim, hidden, out_dim, args.bias)
    weights = sample_weights(args.samples, shapes, args.seed)
    env_ids = np.arange(B, dtype=np.int32)

    def reset():
        obs, _ = envs.reset()
        return obs

    def step(action):
        a = action.astype(np.int32) if discrete else action.astype(np.float32)
        obs, r, term, trunc, _ = envs.step(a, env_ids)
        return obs, r, term, trunc

    scores, steps, calls = run_refill(reset, step, weights, B, n_jobs, E, args.bias,
                                      discrete, high)
    envs.close()
    wall, cpu = t.wall(), t.cpu()
    scores = scores.reshape(args.samples, E)
    write_csv(args.out, scores)
    peer = PEER if args.threads == 2 else f"{PEER}-t{args.threads}"
    report(peer, args, wall, steps, scores, cpu_s=cpu, env_id_run=env_id,
           max_episode_steps=int(envs.spec.config.max_episode_steps), batch=B,
           num_threads=args.threads, env_steps_simulated=calls * B,
           envpool=envpool.__version__, numpy=np.__version__, note=note)


if __name__ == "__main__":
    main()
