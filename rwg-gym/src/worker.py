"""rwg's Gymnasium worker: hosts N environment instances, stepped in lockstep.

rwg starts this program through boot.py and rwg-worker's loader (python -c
BOOT LOAD WORKER rwg_pipe PIPE rwg_env_values VALUES) and speaks the protocol
described in docs/bridge-protocol.md over the child's stdin/stdout through
rwg_pipe, imported first: everything the environments print goes to stderr
(the protocol uses private duplicates of the original stdin/stdout, and fd
0/1 are redirected before gymnasium is imported). rwg_env_values judges what
the env returns.
"""

from rwg_pipe import (  # the pipe first: it redirects fd 0/1
    HEAD,
    decode_kwargs,
    fail,
    floats,
    in_fd,
    out_fd,
    progress,
    read_msg,
    send_json,
    write_msg,
)
from rwg_env_values import (
    FINITE,
    OLD_RESET,
    OLD_STEP,
    Refused,
    close,
    describe,
    flag,
    floats_text,
    not_real,
    old_api,
    outside_space,
    reward_of,
    take_numpy_reals,
)

import json
import os
import sys
import traceback

PROTOCOL = 1
CHECK_SEED_1 = 1234567
CHECK_SEED_2 = 7654321


def checked(call, *args, **kwargs):
    """A reset or step of the start-up checks, announced to rwg first (b"c",
    given rwg's step timeout; b"m" announces gym.make, given its start-up
    timeout)."""
    progress(b"c")
    return call(*args, **kwargs)


def main():
    tag, payload = read_msg()
    if tag != ord("H"):
        fail("protocol", "expected a hello message")
    hello = json.loads(payload.decode())
    if hello.get("protocol") != PROTOCOL:
        fail("protocol", f"rwg speaks protocol {hello.get('protocol')}, this worker {PROTOCOL}")
    try:
        import numpy as np
        import gymnasium as gym
        from gymnasium import spaces
    except ImportError as e:
        fail("python", f"{e} (Python {sys.version.split()[0]} at {sys.executable})")
    take_numpy_reals(np)
    # A complex observation or reward cast to float (here or in Gymnasium's
    # flatten) raises instead of dropping the imaginary part; an env's own
    # casts are left alone.
    import warnings

    complex_warning = getattr(getattr(np, "exceptions", np), "ComplexWarning")
    for module in ("__main__", "gymnasium.spaces.utils"):
        warnings.filterwarnings("error", category=complex_warning, module=module)

    env_id = hello["env"]
    name = env_id
    if ":" in env_id:
        module, name = env_id.split(":", 1)
        import importlib

        try:
            importlib.import_module(module)
        except BaseException as e:  # noqa: BLE001 -- anything the import raises
            fail("import", f"cannot import module '{module}': {type(e).__name__}: {e}",
                 traceback.format_exc())
    kwargs = {k: decode_kwargs(v) for k, v in (hello.get("kwargs") or {}).items()}
    if hello.get("max_episode_steps") is not None:
        kwargs["max_episode_steps"] = int(hello["max_episode_steps"])
    lanes = int(hello["lanes"])
    groups = int(hello.get("groups", 1))
    # MuJoCo writes its warnings (e.g. HalfCheetah's deprecated `settotalmass`)
    # to MUJOCO_LOG.TXT in the current directory, the user's, besides stderr:
    # route them to stderr alone, before a MuJoCo model is compiled.
    try:
        entry = gym.spec(name).entry_point
    except BaseException:  # noqa: BLE001 -- gym.make below reports an unknown id
        entry = None
    if isinstance(entry, str) and "mujoco" in entry:
        try:
            import mujoco  # noqa: F401
        except BaseException:  # noqa: BLE001 -- gym.make below reports it
            pass
    quiet_mujoco()
    envs = []
    for _ in range(lanes * groups):
        try:
            envs.append(gym.make(name, **kwargs))
            quiet_mujoco()  # an env of another package may import mujoco in make
        except gym.error.UnregisteredEnv as e:
            fail("not_registered", f"{type(e).__name__}: {e}")
        except BaseException as e:  # noqa: BLE001
            fail("make", f"gym.make({name!r}, **{kwargs!r}) raised {type(e).__name__}: {e}",
                 traceback.format_exc())
    env0 = envs[0]
    obs_space, act_space = env0.observation_space, env0.action_space
    for k, e in enumerate(envs):
        if str(e.observation_space) != str(obs_space) or str(e.action_space) != str(act_space):
            fail("space", f"gym.make gave instances of other spaces: observation space "
                          f"{e.observation_space}, action space {e.action_space} (instance {k}) vs "
                          f"{obs_space}, {act_space} (instance 0); rwg runs every episode of a cell "
                          f"under one set of spaces, so they must not depend on the instance (on "
                          f"counters, files or random numbers the env reads when it is made)")

    # --- observation space: Box flattened row-major, others through spaces.flatten
    if isinstance(obs_space, spaces.Box):
        flat_space, boxed = obs_space, True
    else:
        try:
            flat_space = spaces.flatten_space(obs_space)
        except BaseException as e:  # noqa: BLE001
            fail("space", f"observation space {obs_space} cannot be flattened "
                          f"({type(e).__name__}: {e}); rwg takes Box, Discrete, MultiDiscrete, "
                          f"MultiBinary, Dict and Tuple observations: wrap the env "
                          f"(gymnasium.ObservationWrapper) to give one of those")
        if not isinstance(flat_space, spaces.Box):
            fail("space", f"observation space {obs_space} does not flatten to a Box; wrap the env "
                          f"(gymnasium.ObservationWrapper) to give a Box")
        boxed = False
    obs_dim = int(np.prod(flat_space.shape, dtype=np.int64))
    if obs_dim == 0:
        fail("space", f"observation space {obs_space} has no values; rwg's networks need at least "
                      f"one observation value: wrap the env (gymnasium.ObservationWrapper) to give "
                      f"some")
    max_obs = int(hello["max_obs"])
    if obs_dim > max_obs:
        hint = ("for Atari, pass kwargs = { obs_type = \"ram\" } (128 bytes of RAM)"
                if name.startswith("ALE/") else
                "wrap the env to give smaller observations (e.g. gymnasium.wrappers."
                "ResizeObservation + GrayscaleObservation for images)")
        fail("space", f"observation space {obs_space} has {obs_dim} values, more than the "
                      f"limit of {max_obs} (rwg's networks take the flat observation as input); {hint}")
    obs_low = np.asarray(flat_space.low, dtype=np.float64).reshape(-1)
    obs_high = np.asarray(flat_space.high, dtype=np.float64).reshape(-1)

    # --- action space: Discrete, or a bounded Box
    if isinstance(act_space, spaces.Discrete):
        action = {"type": "Discrete", "n": int(act_space.n), "start": int(act_space.start)}
        act_dim = 0
        start = int(act_space.start)
    elif isinstance(act_space, spaces.Box):
        low = np.asarray(act_space.low, dtype=np.float64).reshape(-1)
        high = np.asarray(act_space.high, dtype=np.float64).reshape(-1)
        if not (np.all(np.isfinite(low)) and np.all(np.isfinite(high))):
            fail("space", f"action space {act_space} is unbounded; rwg maps tanh outputs onto the "
                          f"bounds, so every dimension needs finite low and high: wrap the env "
                          f"(gymnasium.wrappers.RescaleAction, or an ActionWrapper) to give bounds")
        if low.size == 0:
            fail("space", f"action space {act_space} has no values; rwg's networks need at least "
                          f"one action to choose: wrap the env (gymnasium.ActionWrapper) to give "
                          f"some")
        action = {"type": "Box", "low": floats(low), "high": floats(high),
                  "shape": list(act_space.shape)}
        act_dim = int(low.size)
        act_shape = tuple(act_space.shape)
        act_dtype = np.float32 if hello.get("action_dtype") == "float32" else np.float64
    else:
        fail("space", f"action space {act_space} is not supported: rwg takes Discrete and bounded "
                      f"Box actions (MultiDiscrete, MultiBinary, Dict, Tuple, Text, Graph are not); "
                      f"wrap the env (gymnasium.ActionWrapper) to give one of those")

    spec = env0.spec
    max_steps = spec.max_episode_steps if spec is not None else None
    threshold = spec.reward_threshold if spec is not None else None
    if max_steps is not None and not (type(max_steps) is int and 0 < max_steps < 2**32):
        fail("spec", f"the env's spec registers max_episode_steps = {max_steps!r}; rwg takes a "
                     f"whole number of steps from 1 to {2**32 - 1}: set max_episode_steps in the "
                     f"manifest's [[envs]] entry")
    if threshold is not None:
        try:
            threshold = floats([threshold])[0]
        except (TypeError, ValueError):
            fail("spec", f"the env's spec registers reward_threshold = {threshold!r}, not a "
                         f"number; register a number or None")

    def flat_obs(o):
        if not boxed:
            outside = outside_space(obs_space, o)
            if outside:
                raise Refused(outside)
        try:
            a = np.asarray(o) if boxed else spaces.flatten(obs_space, o)
        except complex_warning:
            raise Refused(not_real("an observation with complex values",
                                   "gymnasium.ObservationWrapper")) from None
        if a.size != obs_dim:
            of_type = f", type {type(o).__name__}" if boxed and type(o) is not np.ndarray else ""
            raise Refused(f"an observation of {a.size} values (shape {np.shape(a)}{of_type}) "
                          f"where the observation space {obs_space} has {obs_dim}")
        if a.dtype.kind == "O":
            raise Refused(f"an observation of dtype object ({floats_text(a)}); rwg takes "
                          f"arrays of numbers (bool, int, float): give np.asarray(obs, "
                          f"dtype=np.float64) in the env, or wrap it "
                          f"(gymnasium.ObservationWrapper)")
        if a.dtype.kind not in "biuf":
            raise Refused(not_real(f"an observation of dtype {a.dtype} ({floats_text(a)})",
                                   "gymnasium.ObservationWrapper"))
        return a.reshape(obs_dim)

    def reset_obs(r, seed):
        """The flat observation of `r`, what reset(seed=seed) returned."""
        if type(r) is not tuple or len(r) != 2:
            n = f"a tuple of {len(r)} values" if type(r) is tuple else describe(r)
            raise Refused(f"reset(seed={seed}) returned {n}; {OLD_RESET}")
        try:
            return flat_obs(r[0])
        except Refused as e:
            raise Refused(f"reset(seed={seed}) returned {e}") from None

    def step_refusal(res, e):
        """Why rwg refuses step()'s result `res`, where unpacking or reading it
        raised `e` (in this frame, not in the env)."""
        if type(res) is not tuple or len(res) != 5:
            n = f"{len(res)} values" if type(res) is tuple else describe(res)
            return f"step() returned {n}; {OLD_STEP}"
        return (f"rwg cannot read what step() returned ({type(e).__name__}: {e}): terminated "
                f"and truncated must be booleans (they are {res[2]!r} and {res[3]!r}), the "
                f"reward a real number")

    def check_spaces(env, which):
        """Refuses `env` (`which` names it) if its spaces are not those of
        instance 0 when the worker started: an identity test, and a
        comparison of their text only when they are other objects."""
        o, a = env.observation_space, env.action_space
        if (o is obs_space or str(o) == obs_text) and (a is act_space or str(a) == act_text):
            return
        raise Refused(f"{which} has observation space {o} and action space {a}, where the "
                      f"env started with {obs_space} and {act_space}; rwg runs every episode "
                      f"of a cell under one set of spaces, so an env must not change them "
                      f"(between instances or episodes)")

    obs_text, act_text = str(obs_space), str(act_space)

    # --- determinism: two resets with the same seed give the same observation
    # (and the same as in rwg's other workers: the observation goes to rwg)
    check_obs = None
    if hello.get("check_reset"):
        s = int(hello["check_reset"])
        try:
            first = np.array(reset_obs(checked(env0.reset, seed=s), s), dtype=np.float64)
            second = np.array(reset_obs(checked(envs[-1].reset, seed=s), s), dtype=np.float64)
            third = np.array(reset_obs(checked(env0.reset, seed=s), s), dtype=np.float64)
            bad = np.flatnonzero(~np.isfinite(first))
            if bad.size:
                raise Refused(f"reset(seed={s}) returned a non-finite observation: value "
                              f"{bad[0]} of {obs_dim} is {floats(first[bad[:1]])[0]}; {FINITE}")
        except Refused as e:
            fail("api", str(e))
        except BaseException as e:  # noqa: BLE001
            if old_api(e):
                fail("api", old_api(e))
            fail("reset", f"reset(seed={s}) raised {type(e).__name__}: {e}", traceback.format_exc())
        for other, how in ((second, "another instance"), (third, "the same instance again")):
            if not np.array_equal(first, other, equal_nan=True):
                fail("nondeterministic",
                     f"reset(seed={s}) gave different observations on {how} "
                     f"({floats(first[:4])}... vs {floats(other[:4])}...); rwg needs "
                     f"environments whose reset(seed=s) determines the episode")
        check_obs = floats(first)

    # --- history: does an episode depend on the episodes the instance ran
    # before? (Some envs keep state across reset, e.g. BipedalWalker-v3.) Then
    # every episode gets a fresh instance, so results do not depend on which
    # worker ran which episodes before.
    def probe(env, seed, steps=200):
        rng = np.random.default_rng(seed)
        out = [np.array(reset_obs(checked(env.reset, seed=seed), seed), dtype=np.float64)]
        for _ in range(steps):
            if act_dim:
                a = rng.uniform(low, high).astype(act_dtype).reshape(act_shape)
            else:
                a = start + int(rng.integers(action["n"]))
            stepped = checked(env.step, a)
            try:
                o, r, term, trunc, _ = stepped
                out.append(np.append(np.array(flat_obs(o), dtype=np.float64), reward_of(r)))
                done = flag("terminated", term) or flag("truncated", trunc)
                if not np.all(np.isfinite(out[-1])):
                    raise Refused(f"a non-finite observation or reward (observation "
                                  f"{floats(out[-1][:-1][:4])}, reward {floats(out[-1][-1:])[0]}) "
                                  f"to random actions; {FINITE}")
            except Refused as e:
                raise Refused(f"step() returned {e}") from None
            except Exception as e:  # noqa: BLE001 -- unpacking or reading the result
                if e.__traceback__.tb_next is not None:
                    raise
                raise Refused(step_refusal(stepped, e)) from None
            if done:
                break
        return out

    fresh = bool(hello.get("fresh_per_episode"))
    if hello.get("probe_history"):
        try:
            progress(b"m")
            other = gym.make(name, **kwargs)
            want = probe(other, CHECK_SEED_2)
            close(other, "after probing it")
            probe(env0, CHECK_SEED_1)
            got = probe(env0, CHECK_SEED_2)
        except Refused as e:
            fail("api", str(e))
        except BaseException as e:  # noqa: BLE001
            if old_api(e):
                fail("api", old_api(e))
            fail("reset", f"the env raised while rwg probed it with random actions: "
                          f"{type(e).__name__}: {e}", traceback.format_exc())
        same = len(want) == len(got) and all(
            np.array_equal(x, y, equal_nan=True) for x, y in zip(want, got))
        fresh = fresh or not same

    # The checks used instances 0 and N-1: replace them, so that every lane
    # starts as gym.make left it (no reset yet).
    if hello.get("check_reset") or hello.get("probe_history"):
        progress(b"m")
        for idx in {0, len(envs) - 1}:
            try:
                close(envs[idx], "after its start-up checks")
            except Refused as e:
                fail("api", str(e))
            envs[idx] = gym.make(name, **kwargs)

    send_json(ord("R"), {
        "fresh_per_episode": fresh,
        "check_obs": check_obs,
        "protocol": PROTOCOL,
        "gymnasium": gym.__version__,
        "python": sys.version.split()[0],
        "spec_id": spec.id if spec is not None else None,
        "observation_space": str(obs_space),
        "obs_dim": obs_dim,
        "obs_low": floats(obs_low),
        "obs_high": floats(obs_high),
        "action_space": str(act_space),
        "action": action,
        "max_episode_steps": max_steps,
        "reward_threshold": threshold,
    })

    # --- the lane marker: the lane being reset/stepped (255: none), for rwg to
    # name the episode when this process dies or hangs
    mark = bytearray(1)
    if hello.get("lane_file"):
        import mmap

        with open(hello["lane_file"], "r+b") as f:
            mark = mmap.mmap(f.fileno(), 8)
    mark[0] = 255

    # --- the exchange loop (the hot path: one message in, one out, per exchange)
    n = lanes
    words = max(1, act_dim)
    ops_len = (n + 7) // 8 * 8
    res_len = 8 + ops_len + 8 * n + 8 * n * obs_dim
    inbuf = bytearray(13 + ops_len + 8 * n * words)
    inview = memoryview(inbuf)
    res = bytearray(res_len)
    head = bytearray(HEAD.pack(res_len + 1, ord("O")))
    flags = memoryview(res)[8:8 + n]
    no_flags = bytes(n)
    rewards = np.frombuffer(res, np.float64, n, 8 + ops_len)
    obs_out = np.frombuffer(res, np.float64, n * obs_dim, 8 + ops_len + 8 * n).reshape(n, obs_dim)
    rew = [0.0] * n
    steps = [e.step for e in envs]
    shp = obs_space.shape if boxed and len(obs_space.shape) == 1 else None
    ndarray = np.ndarray
    while True:
        # The host sends the next message only after this one's answer, so a
        # read never takes bytes of the next message.
        got = 0
        need = 5
        while got < need:
            k = os.readv(in_fd, [inview[got:]])
            if k == 0:
                sys.exit(0)
            got += k
            if need == 5 and got >= 5:
                need = 4 + HEAD.unpack_from(inbuf)[0]
                if need > len(inbuf):
                    fail("protocol", f"message of {need} bytes, at most {len(inbuf)} expected")
        tag = inbuf[4]
        if tag == ord("Q"):
            return
        if tag != ord("S"):
            fail("protocol", f"unexpected message tag {tag}")
        group = inbuf[5]
        if group >= groups:
            fail("protocol", f"group {group} of {groups}")
        base = group * n
        res[0] = group
        ops = inbuf[13:13 + n]
        if act_dim:
            acts = np.frombuffer(inbuf, np.float64, n * words, 13 + ops_len).reshape(n, words)
        else:
            acts = np.frombuffer(inbuf, np.int64, n, 13 + ops_len).tolist()
        flags[:] = no_flags
        errors = None
        for i in range(n):
            op = ops[i]
            if op == 0:
                continue
            if op > 2:
                fail("protocol", f"unknown lane op {op}")
            mark[0] = base + i
            stepped = None
            try:
                if op == 2:
                    if act_dim:
                        a = np.array(acts[i], dtype=act_dtype).reshape(act_shape)
                    else:
                        a = acts[i] + start
                    stepped = steps[base + i](a)
                    o, r, term, trunc, _ = stepped
                    if type(o) is ndarray and o.shape == shp and o.dtype.kind in "biuf":
                        obs_out[i] = o
                    else:
                        obs_out[i] = flat_obs(o)
                    rew[i] = r if type(r) is float else reward_of(r)
                    if not (term is True or term is False):
                        term = flag("terminated", term)
                    if not (trunc is True or trunc is False):
                        trunc = flag("truncated", trunc)
                    flags[i] = 1 | (2 if term else 0) | (4 if trunc else 0)
                elif op == 1:
                    if fresh:
                        close(envs[base + i], "before the fresh instance of the next episode "
                                              "(the env's episodes depend on its history)")
                        envs[base + i] = gym.make(name, **kwargs)
                        steps[base + i] = envs[base + i].step
                        check_spaces(envs[base + i], "the fresh instance rwg made for this "
                                                     "episode (gym.make)")
                    at = 13 + ops_len + 8 * words * i
                    seed = int.from_bytes(inview[at:at + 8], "little")
                    obs_out[i] = reset_obs(envs[base + i].reset(seed=seed), seed)
                    check_spaces(envs[base + i], f"the instance after reset(seed={seed})")
                    rew[i] = 0.0
                    flags[i] = 1
            except Refused as e:
                flags[i] = 8
                errors = errors or []
                message = str(e) if op == 1 else f"step() returned {e}"
                errors.append({"lane": i, "message": message, "traceback": ""})
            except BaseException as e:  # noqa: BLE001 -- the env's own failure, reported to rwg
                flags[i] = 8
                errors = errors or []
                if op == 2 and stepped is not None and e.__traceback__.tb_next is None:
                    # raised here, unpacking or reading what step() returned
                    errors.append({"lane": i, "message": step_refusal(stepped, e),
                                   "traceback": ""})
                    continue
                if old_api(e):
                    errors.append({"lane": i, "message": old_api(e), "traceback": ""})
                    continue
                what = "step" if op == 2 else "reset"
                not_exception = "" if isinstance(e, Exception) else (
                    f" (not an Exception: {type(e).__name__} derives from BaseException only; "
                    f"an env's failure should raise an Exception)")
                errors.append({"lane": i,
                               "message": f"{what} raised {type(e).__name__}: {e}{not_exception}",
                               "traceback": traceback.format_exc()})
        mark[0] = 255
        rewards[:] = rew
        if errors:
            write_msg(ord("O"), bytes(res), json.dumps(errors).encode())
        else:
            out = [head, res]
            while out:
                k = os.writev(out_fd, out)
                while out and k >= len(out[0]):
                    k -= len(out[0])
                    out.pop(0)
                if out and k:
                    out[0] = memoryview(out[0])[k:]



def _mujoco_warning(msg):
    print(f"MuJoCo warning: {msg}", file=sys.stderr, flush=True)


def quiet_mujoco():
    """MuJoCo's warnings to stderr only (not MUJOCO_LOG.TXT), once mujoco is imported."""
    m = sys.modules.get("mujoco")
    setter = getattr(m, "set_mju_user_warning", None)
    if setter is not None and getattr(m, "get_mju_user_warning", lambda: None)() is None:
        try:
            setter(_mujoco_warning)
        except BaseException:  # noqa: BLE001 -- an old mujoco: its default behaviour stays
            pass


if __name__ == "__main__":
    main()
