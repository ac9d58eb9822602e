"""One episode of a gymnax env under rwg's JAX convention, written apart from
rwg's worker: the replay recipe of a `gymnax:` network.

usage: python replay_check.py ENV HIDDEN BIAS SEED WEIGHTS...
  HIDDEN: comma-separated sizes ("" for none), BIAS: 0 or 1, SEED: rwg's reset
  seed (u64), WEIGHTS: the network's weights in rwg's layout (per layer, row
  major, bias weight last in each row). Prints the return (float32, as
  repr(float)) and the length.
"""

import importlib.util
import os
import sys

import numpy as np
import jax
import jax.numpy as jnp
import gymnax

# rwg's float32 sin and cos on a CPU (rwg-jax/src/jax_trig.py), part of its
# program: RWG_TRIG_MODULE names the file
spec = importlib.util.spec_from_file_location("jax_trig", os.environ["RWG_TRIG_MODULE"])
trig = importlib.util.module_from_spec(spec)
spec.loader.exec_module(trig)
trig.install(jax)

env_id, hidden, bias, seed = sys.argv[1], sys.argv[2], sys.argv[3] == "1", int(sys.argv[4])
weights = np.array([float(w) for w in sys.argv[5:]])
env, params = gymnax.make(env_id)
T = int(params.max_steps_in_episode)
n_out = env.action_space(params).n
sizes = [int(np.prod(env.observation_space(params).shape))]
sizes += [int(h) for h in hidden.split(",") if h] + [int(n_out)]
Ws, off = [], 0
for i in range(len(sizes) - 1):
    o, n_in = sizes[i + 1], sizes[i] + int(bias)
    Ws.append(jnp.asarray(weights[off:off + o * n_in].reshape(o, n_in), jnp.float32))
    off += o * n_in
assert off == len(weights), "weights for another architecture"

# the key: the threefry key of data [r >> 32, r & 0xFFFFFFFF]
key = jax.random.wrap_key_data(jnp.array([seed >> 32, seed & 0xFFFFFFFF], jnp.uint32),
                               impl="threefry2x32")


def act(obs):
    x = obs.ravel().astype(jnp.float32)
    for W in Ws:
        if bias:
            x = jnp.concatenate([x, jnp.ones((1,), jnp.float32)])
        x = jnp.tanh(W @ x)
    return jnp.argmax(x).astype(jnp.int32)


@jax.jit
def episode(key):
    k_reset, k_steps = jax.random.split(key)
    obs, state = env.reset(k_reset, params)

    def body(c):
        obs, state, t, ret, _ = c
        obs, state, r, d, _ = env.step_env(jax.random.fold_in(k_steps, t), state, act(obs), params)
        t = t + 1
        return obs, state, t, ret + r.astype(jnp.float32), d | (t >= T)

    c = (obs, state, jnp.int32(0), jnp.float32(0), jnp.bool_(False))
    _, _, t, ret, _ = jax.lax.while_loop(lambda c: ~c[4], body, c)
    return ret, t


ret, length = episode(key)
print(repr(float(ret)), int(length))
