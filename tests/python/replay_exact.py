#!/usr/bin/env python3
"""Replays networks exported by `rwg replay --export-weights` in plain Python.

    python3 replay_exact.py W1.json [W2.json ...]

Unlike replay_in_gymnasium.py (numpy's forward pass, equal up to the last
bit), the network runs with rwg_net (rwg's own arithmetic, bit for bit), so
the scores must equal rwg's exactly, continuous control included. Works for
`gymnasium:` envs: `env` is then the id for gym.make and `gym_kwargs` its
keyword arguments. Prints one JSON line per file: {"file": ..., "scores": [...]}.
"""

import json
import os
import sys

import gymnasium as gym
import numpy as np
from gymnasium import spaces

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rwg_net  # noqa: E402


def main():
    for path in sys.argv[1:]:
        w = json.load(open(path))
        kwargs = rwg_net.gym_kwargs(w)
        env = gym.make(w["env"], max_episode_steps=w["max_episode_steps"], **kwargs)
        boxed = isinstance(env.observation_space, spaces.Box)
        act_space = env.action_space
        dtype = np.float64 if w["action_dtype"] == "float64" else np.float32
        scores = []
        for seed in w["reset_seeds"]:
            obs, _ = env.reset(seed=seed)
            total, done = 0.0, False
            while not done:
                flat = (np.asarray(obs) if boxed else spaces.flatten(env.observation_space, obs))
                a = rwg_net.act(w, np.asarray(flat, dtype=np.float64).reshape(-1).tolist())
                if isinstance(act_space, spaces.Discrete):
                    a = int(act_space.start) + a
                else:
                    a = np.array(a, dtype=dtype).reshape(act_space.shape)
                obs, r, terminated, truncated, _ = env.step(a)
                total += float(r)
                done = terminated or truncated
            scores.append(total)
        print(json.dumps({"file": path, "scores": scores}))


if __name__ == "__main__":
    main()
