"""rwg's Gymnasium worker: hosts N environment instances, stepped in lockstep.

rwg starts this program through boot.py and rwg-worker's loader (python -c
BOOT LOAD WORKER rwg_pipe PIPE rwg_env_values VALUES rwg_env_spaces SPACES)
and speaks the protocol described in docs/bridge-protocol.md over the child's
stdin/stdout through rwg_pipe, imported first: everything the environments
print goes to stderr (the protocol uses private duplicates of the original
stdin/stdout, and fd 0/1 are redirected before gymnasium is imported).
rwg_env_values judges what the env returns, rwg_env_spaces its spaces and
observations.

main() is the list of the worker's steps: the hello, then Worker's start-up
steps (Gymnasium imported, the instances made, their spaces and spec read,
the start-up checks), the ready message, then the exchange loop. This file
runs as __main__, which the filter of complex casts in import_gymnasium names.
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
    Refused,
    close,
    flag,
    old_api,
    reward_of,
    step_refusal,
    take_numpy_reals,
)
from rwg_env_spaces import Spaces

import json
import os
import sys
import traceback

PROTOCOL = 1
CHECK_SEED_1 = 1234567
CHECK_SEED_2 = 7654321


def main():
    """The worker's life, step by step, until rwg quits or closes the pipe."""
    w = Worker(read_hello())
    w.import_gymnasium()
    w.read_env_request()
    w.make_envs()
    w.read_spaces()
    w.read_spec()
    w.check_reset()
    w.probe_history()
    w.replace_checked_instances()
    mark = lane_marker(w.hello)  # before the ready: rwg then removes the file's name
    w.send_ready()
    w.exchange(mark)


def read_hello():
    """rwg's hello message (JSON), refused unless it speaks this worker's protocol."""
    tag, payload = read_msg()
    if tag != ord("H"):
        fail("protocol", "expected a hello message")
    hello = json.loads(payload.decode())
    if hello.get("protocol") != PROTOCOL:
        fail("protocol", f"rwg speaks protocol {hello.get('protocol')}, this worker {PROTOCOL}")
    return hello


def checked(call, *args, **kwargs):
    """A reset or step of the start-up checks, announced to rwg first (b"c",
    given rwg's step timeout; b"m" announces gym.make, given its start-up
    timeout)."""
    progress(b"c")
    return call(*args, **kwargs)


def lane_marker(hello):
    """The lane marker: the lane being reset/stepped (255: none), for rwg to
    name the episode when this process dies or hangs; in the lane file the
    hello names, else in memory only."""
    mark = bytearray(1)
    if hello.get("lane_file"):
        import mmap

        with open(hello["lane_file"], "r+b") as f:
            mark = mmap.mmap(f.fileno(), 8)
    mark[0] = 255
    return mark


class Worker:
    """The worker's state, filled in by its start-up steps in main()'s
    order: the hello, Gymnasium's modules, the env instances, their flat
    spaces and spec, what the start-up checks found; then the exchange loop."""

    def __init__(self, hello):
        self.hello = hello

    def import_gymnasium(self):
        """numpy and Gymnasium, with a cast of complex values to real ones an error."""
        try:
            import numpy as np
            import gymnasium as gym
            from gymnasium import spaces
        except ImportError as e:
            fail("python", f"{e} (Python {sys.version.split()[0]} at {sys.executable})")
        take_numpy_reals(np)
        # A complex observation or reward cast to float (here, in rwg_env_spaces
        # or in Gymnasium's flatten) raises instead of dropping the imaginary
        # part; an env's own casts are left alone.
        import warnings

        complex_warning = getattr(getattr(np, "exceptions", np), "ComplexWarning")
        for module in ("__main__", "rwg_env_spaces", "gymnasium.spaces.utils"):
            warnings.filterwarnings("error", category=complex_warning, module=module)
        self.np, self.gym, self.gym_spaces = np, gym, spaces
        self.complex_warning = complex_warning

    def read_env_request(self):
        """What the hello asks for: the env's name (its module imported, for
        an id `module:name`), gym.make's keyword arguments, lanes and groups."""
        hello = self.hello
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
        self.name, self.kwargs = name, kwargs
        self.lanes = int(hello["lanes"])
        self.groups = int(hello.get("groups", 1))

    def make_envs(self):
        """The lanes x groups instances (gym.make), MuJoCo's warnings routed to
        stderr first; refused unless all have the spaces of instance 0."""
        self.route_mujoco_warnings()
        gym, name, kwargs = self.gym, self.name, self.kwargs
        envs = []
        for _ in range(self.lanes * self.groups):
            try:
                envs.append(gym.make(name, **kwargs))
                quiet_mujoco()  # an env of another package may import mujoco in make
            except gym.error.UnregisteredEnv as e:
                fail("not_registered", f"{type(e).__name__}: {e}")
            except BaseException as e:  # noqa: BLE001
                fail("make", f"gym.make({name!r}, **{kwargs!r}) raised {type(e).__name__}: {e}",
                     traceback.format_exc())
        self.envs = envs
        self.check_same_spaces()

    def route_mujoco_warnings(self):
        """MuJoCo writes its warnings (e.g. HalfCheetah's deprecated
        `settotalmass`) to MUJOCO_LOG.TXT in the current directory, the
        user's, besides stderr: route them to stderr alone, before a MuJoCo
        model is compiled."""
        try:
            entry = self.gym.spec(self.name).entry_point
        except BaseException:  # noqa: BLE001 -- gym.make below reports an unknown id
            entry = None
        if isinstance(entry, str) and "mujoco" in entry:
            try:
                import mujoco  # noqa: F401
            except BaseException:  # noqa: BLE001 -- gym.make below reports it
                pass
        quiet_mujoco()

    def check_same_spaces(self):
        """The spaces of instance 0, refused unless every instance has them."""
        obs_space, act_space = self.envs[0].observation_space, self.envs[0].action_space
        for k, e in enumerate(self.envs):
            if str(e.observation_space) != str(obs_space) or str(e.action_space) != str(act_space):
                fail("space", f"gym.make gave instances of other spaces: observation space "
                              f"{e.observation_space}, action space {e.action_space} (instance {k}) vs "
                              f"{obs_space}, {act_space} (instance 0); rwg runs every episode of a cell "
                              f"under one set of spaces, so they must not depend on the instance (on "
                              f"counters, files or random numbers the env reads when it is made)")
        self.obs_space, self.act_space = obs_space, act_space

    def read_spaces(self):
        """The spaces of instance 0 as rwg takes them (rwg_env_spaces)."""
        sp = Spaces(self.np, self.gym_spaces, self.complex_warning, self.obs_space, self.act_space)
        sp.read_observation_space(self.name, self.hello)
        sp.read_action_space(self.hello)
        self.sp = sp

    def read_spec(self):
        """The env's spec (of instance 0) and what it registers: the episode
        length and the reward threshold, refused unless rwg can take them."""
        spec = self.envs[0].spec
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
        self.spec, self.max_steps, self.threshold = spec, max_steps, threshold

    def check_reset(self):
        """Determinism: two resets with the same seed give the same
        observation (and the same as in rwg's other workers: the observation
        goes to rwg, as check_obs)."""
        np, sp, envs, hello = self.np, self.sp, self.envs, self.hello
        self.check_obs = None
        if not hello.get("check_reset"):
            return
        s = int(hello["check_reset"])
        try:
            first = np.array(sp.reset_obs(checked(envs[0].reset, seed=s), s), dtype=np.float64)
            second = np.array(sp.reset_obs(checked(envs[-1].reset, seed=s), s), dtype=np.float64)
            third = np.array(sp.reset_obs(checked(envs[0].reset, seed=s), s), dtype=np.float64)
            bad = np.flatnonzero(~np.isfinite(first))
            if bad.size:
                raise Refused(f"reset(seed={s}) returned a non-finite observation: value "
                              f"{bad[0]} of {sp.obs_dim} is {floats(first[bad[:1]])[0]}; {FINITE}")
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
        self.check_obs = floats(first)

    def probe_history(self):
        """History: does an episode depend on the episodes the instance ran
        before? (Some envs keep state across reset, e.g. BipedalWalker-v3.)
        Then every episode gets a fresh instance (fresh_per_episode), so
        results do not depend on which worker ran which episodes before."""
        np = self.np
        self.fresh = bool(self.hello.get("fresh_per_episode"))
        if not self.hello.get("probe_history"):
            return
        try:
            progress(b"m")
            other = self.gym.make(self.name, **self.kwargs)
            want = self.probe(other, CHECK_SEED_2)
            close(other, "after probing it")
            self.probe(self.envs[0], CHECK_SEED_1)
            got = self.probe(self.envs[0], CHECK_SEED_2)
        except Refused as e:
            fail("api", str(e))
        except BaseException as e:  # noqa: BLE001
            if old_api(e):
                fail("api", old_api(e))
            fail("reset", f"the env raised while rwg probed it with random actions: "
                          f"{type(e).__name__}: {e}", traceback.format_exc())
        same = len(want) == len(got) and all(
            np.array_equal(x, y, equal_nan=True) for x, y in zip(want, got))
        self.fresh = self.fresh or not same

    def probe(self, env, seed, steps=200):
        """The flat observations (and rewards) of an episode of `env` from
        reset(seed=seed), with up to `steps` random actions drawn from `seed`."""
        np, sp = self.np, self.sp
        rng = np.random.default_rng(seed)
        out = [np.array(sp.reset_obs(checked(env.reset, seed=seed), seed), dtype=np.float64)]
        for _ in range(steps):
            stepped = checked(env.step, sp.random_action(rng))
            try:
                o, r, term, trunc, _ = stepped
                out.append(np.append(np.array(sp.flat_obs(o), dtype=np.float64), reward_of(r)))
                done = flag("terminated", term) or flag("truncated", trunc)
                if not np.all(np.isfinite(out[-1])):
                    if self.hello.get("non_finite_ends"):
                        break  # non_finite = "end": the run ends such an episode too
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

    def replace_checked_instances(self):
        """The checks used instances 0 and N-1: replace them, so that every
        lane starts as gym.make left it (no reset yet)."""
        if not (self.hello.get("check_reset") or self.hello.get("probe_history")):
            return
        progress(b"m")
        envs = self.envs
        for idx in {0, len(envs) - 1}:
            try:
                close(envs[idx], "after its start-up checks")
            except Refused as e:
                fail("api", str(e))
            envs[idx] = self.gym.make(self.name, **self.kwargs)

    def send_ready(self):
        """The ready message: what rwg records of the env and its spaces."""
        spec, sp = self.spec, self.sp
        send_json(ord("R"), {
            "fresh_per_episode": self.fresh,
            "check_obs": self.check_obs,
            "protocol": PROTOCOL,
            "gymnasium": self.gym.__version__,
            "python": sys.version.split()[0],
            "spec_id": spec.id if spec is not None else None,
            "observation_space": str(sp.obs_space),
            "obs_dim": sp.obs_dim,
            "obs_low": floats(sp.obs_low),
            "obs_high": floats(sp.obs_high),
            "action_space": str(sp.act_space),
            "action": sp.action,
            "max_episode_steps": self.max_steps,
            "reward_threshold": self.threshold,
        })

    def exchange(self, mark):
        """The exchange loop (the hot path: one message in, one out), until rwg quits
        (returns) or closes the pipe (exits); what it reads is bound to locals here, once."""
        np, sp, n, groups = self.np, self.sp, self.lanes, self.groups
        act_dim, start, act_shape, act_dtype = sp.act_dim, sp.start, sp.act_shape, sp.act_dtype
        words = max(1, act_dim)
        b = Buffers(np, n, words, sp.obs_dim)
        inbuf, inview, ops_len, out, out_len = b.inbuf, b.inview, b.ops_len, b.out, b.out_len
        res, flags, no_flags, rewards, obs_out = b.res, b.flags, bytes(n), b.rewards, b.obs_out
        rew = [0.0] * n
        self.steps = steps = [e.step for e in self.envs]
        flat_obs, shp, reset_lane, ndarray = sp.flat_obs, sp.flat_shape, self.reset_lane, np.ndarray
        while True:
            # The host sends the next message only after this one's answer, so a
            # read never takes bytes of the next message.
            got, need = 0, 5
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
            acts = (np.frombuffer(inbuf, np.float64, n * words, 13 + ops_len).reshape(n, words)
                    if act_dim else np.frombuffer(inbuf, np.int64, n, 13 + ops_len).tolist())
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
                        at = 13 + ops_len + 8 * words * i
                        reset_lane(obs_out, i, base + i, int.from_bytes(inview[at:at + 8], "little"))
                        rew[i] = 0.0
                        flags[i] = 1
                except BaseException as e:  # noqa: BLE001 -- the env's own failure, reported to rwg
                    flags[i] = 8
                    errors = errors or []
                    errors.append(lane_error(e, i, op, stepped))
            mark[0] = 255
            rewards[:] = rew
            if errors:
                write_msg(ord("O"), bytes(res), json.dumps(errors).encode())
            else:
                k = os.writev(out_fd, out)
                if k < out_len:
                    write_rest(out, k)

    def reset_lane(self, obs_out, i, k, seed):
        """Resets instance k (lane i of the exchange) with `seed`, its flat
        observation into obs_out[i]; a fresh instance first when the env's
        episodes depend on its history. Refused if the env changed its spaces."""
        envs, sp = self.envs, self.sp
        if self.fresh:
            close(envs[k], "before the fresh instance of the next episode "
                           "(the env's episodes depend on its history)")
            envs[k] = self.gym.make(self.name, **self.kwargs)
            self.steps[k] = envs[k].step
            sp.check_spaces(envs[k], "the fresh instance rwg made for this episode (gym.make)")
        obs_out[i] = sp.reset_obs(envs[k].reset(seed=seed), seed)
        sp.check_spaces(envs[k], f"the instance after reset(seed={seed})")


class Buffers:
    """The exchange loop's buffers, made once: the S message read in
    (`inbuf`), the O message sent out (`out`: its head and body `res`), and
    views of the body's flags, rewards and observations."""

    def __init__(self, np, n, words, obs_dim):
        self.ops_len = ops_len = (n + 7) // 8 * 8
        res_len = 8 + ops_len + 8 * n + 8 * n * obs_dim
        self.inbuf = bytearray(13 + ops_len + 8 * n * words)
        self.inview = memoryview(self.inbuf)
        self.res = res = bytearray(res_len)
        self.out = [bytearray(HEAD.pack(res_len + 1, ord("O"))), res]
        self.out_len = 5 + res_len
        self.flags = memoryview(res)[8:8 + n]
        self.rewards = np.frombuffer(res, np.float64, n, 8 + ops_len)
        self.obs_out = np.frombuffer(res, np.float64, n * obs_dim,
                                     8 + ops_len + 8 * n).reshape(n, obs_dim)


def lane_error(e, i, op, stepped):
    """The error rwg gets for lane i, whose op (1: reset, 2: step) raised
    `e`, handled now in the exchange loop; `stepped`: what step() returned
    (None if it did not return)."""
    if isinstance(e, Refused):
        message = str(e) if op == 1 else f"step() returned {e}"
        return {"lane": i, "message": message, "traceback": ""}
    if op == 2 and stepped is not None and e.__traceback__.tb_next is None:
        # raised in the exchange loop, unpacking or reading what step() returned
        return {"lane": i, "message": step_refusal(stepped, e), "traceback": ""}
    if old_api(e):
        return {"lane": i, "message": old_api(e), "traceback": ""}
    what = "step" if op == 2 else "reset"
    not_exception = "" if isinstance(e, Exception) else (
        f" (not an Exception: {type(e).__name__} derives from BaseException only; "
        f"an env's failure should raise an Exception)")
    return {"lane": i, "message": f"{what} raised {type(e).__name__}: {e}{not_exception}",
            "traceback": traceback.format_exc()}


def write_rest(parts, k):
    """Writes to rwg what os.writev left of `parts` (buffers) after its
    first `k` bytes, as a pipe may take part of a message."""
    out = list(parts)
    while True:
        while out and k >= len(out[0]):
            k -= len(out[0])
            out.pop(0)
        if not out:
            return
        if k:
            out[0] = memoryview(out[0])[k:]
        k = os.writev(out_fd, out)


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
