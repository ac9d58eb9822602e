#!/usr/bin/env python3
"""Replays networks exported by `rwg replay --export-weights` in real Gymnasium.

    python3 replay_in_gymnasium.py W1.json [W2.json ...]

Prints one JSON line per file: {"file": ..., "scores": [one per reset seed]}.
This is the recipe of the README ("Replay"), written out for every action space.
"""

import json
import sys

import gymnasium as gym
import numpy as np


def main():
    for path in sys.argv[1:]:
        w = json.load(open(path))
        Ws = [np.array(layer["weights"], dtype=np.float64) for layer in w["layers"]]
        env = gym.make(w["env"], max_episode_steps=w["max_episode_steps"])
        space = w["action_space"]
        dtype = np.float64 if w["action_dtype"] == "float64" else np.float32
        scores = []
        for seed in w["reset_seeds"]:
            obs, _ = env.reset(seed=seed)
            total, done = 0.0, False
            while not done:
                x = np.asarray(obs, dtype=np.float64)
                for W in Ws:
                    x = np.tanh(W @ (np.append(x, 1.0) if w["bias"] else x))
                if space["type"] == "Discrete":
                    action = int(np.argmax(x))
                else:
                    low, high = np.array(space["low"]), np.array(space["high"])
                    if np.all(low == -high):
                        a = high * x
                    else:
                        a = low + (x + 1.0) / 2.0 * (high - low)
                    action = np.asarray(a, dtype=dtype)
                obs, r, terminated, truncated, _ = env.step(action)
                total += float(r)
                done = terminated or truncated
            scores.append(total)
        print(json.dumps({"file": path, "scores": scores}))


if __name__ == "__main__":
    main()
