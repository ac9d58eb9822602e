"""rwg_env_values: what a Gymnasium env returns, judged for rwg's Gymnasium
worker: rewards and flags of the right types, observations inside their
discrete spaces, the old Gym API recognised, close() failures named. A value
rwg does not take raises Refused, whose message says why and what to do.
"""


class Refused(Exception):
    """A value the env returned that rwg does not take (the message says why)."""


def close(env, when):
    """env.close(), which rwg calls `when`; what it raises is refused,
    naming the call (not the reset or probe that made rwg close it)."""
    try:
        env.close()
    except Exception as e:  # noqa: BLE001 -- the env's own failure
        raise Refused(f"close() raised {type(e).__name__}: {e} (rwg closes an instance {when})") \
            from None


def describe(v):
    """A short description of a returned value: its type and shape."""
    shape = getattr(v, "shape", None)
    return f"a value of type {type(v).__name__}" + (f", shape {shape}" if shape is not None else "")


def floats_text(a):
    """The first values of array `a`, for a message."""
    flat = list(a.reshape(-1)[:3])
    return ", ".join(repr(x.item() if hasattr(x, "item") else x) for x in flat) + (
        ", ..." if a.size > 3 else "")


def not_real(what, wrapper):
    return (f"{what}; rwg takes real numbers only (a complex value's imaginary part would be "
            f"lost, a string is not a number): wrap the env ({wrapper}) to give real numbers")


FINITE = ("rwg's networks take finite numbers only: fix the env, or wrap it "
          "(gymnasium.ObservationWrapper, gymnasium.wrappers.TransformReward)")
OLD_RESET = ("reset() must return (observation, info), as Gymnasium 0.26+ envs do (the old Gym "
             "API returned the observation alone): update the env to the Gymnasium API, or wrap "
             "it (shimmy's GymV21CompatibilityV0)")
OLD_STEP = ("step() must return (observation, reward, terminated, truncated, info), as "
            "Gymnasium 0.26+ envs do (the old Gym API returned (observation, reward, done, "
            "info)): update the env to the Gymnasium API, or wrap it (shimmy's "
            "GymV21CompatibilityV0)")


def step_refusal(res, e):
    """Why rwg refuses step()'s result `res`, where unpacking or reading it
    raised `e` (in the caller's frame, not in the env)."""
    if type(res) is not tuple or len(res) != 5:
        n = f"{len(res)} values" if type(res) is tuple else describe(res)
        return f"step() returned {n}; {OLD_STEP}"
    return (f"rwg cannot read what step() returned ({type(e).__name__}: {e}): terminated "
            f"and truncated must be booleans (they are {res[2]!r} and {res[3]!r}), the "
            f"reward a real number")


def old_api(e):
    """The message for `e`, raised where Gymnasium's own wrappers (those of
    gym.make) unpack what the env's reset() or step() returned, when the env
    follows the old Gym API; else None."""
    if not isinstance(e, (ValueError, TypeError)) or "unpack" not in str(e):
        return None
    tb = e.__traceback__
    while tb.tb_next is not None:
        tb = tb.tb_next
    code = tb.tb_frame.f_code
    if "gymnasium" not in code.co_filename:
        return None
    if code.co_name == "step":
        return f"the env's step() returned what Gymnasium cannot unpack ({e}); {OLD_STEP}"
    if code.co_name == "reset":
        return f"the env's reset() returned what Gymnasium cannot unpack ({e}); {OLD_RESET}"
    return None


_REAL = (int, float)  # and numpy's real scalar types, once numpy is imported


def take_numpy_reals(np):
    """Counts numpy's real scalar types as real numbers (numpy is imported)."""
    global _REAL
    _REAL = (int, float, np.floating, np.integer, np.bool_)


def reward_of(r):
    """The reward `r` as a float: a real number (bool, int, float, numpy's,
    or an array of one); anything else is refused."""
    if isinstance(r, _REAL):
        return float(r)
    import numpy as np

    a = np.asarray(r)
    if a.size != 1:
        raise Refused(f"a reward of {a.size} values ({describe(r)}: {r!r}); a reward must be "
                      f"one number: fix the env, or wrap it (gymnasium.wrappers."
                      f"TransformReward) to give one")
    if a.dtype.kind not in "biuf":
        raise Refused(not_real(f"the reward {r!r} ({type(r).__name__})",
                               "gymnasium.wrappers.TransformReward"))
    return float(a.reshape(()))


def flag(name, v):
    """`terminated` or `truncated` (`name`) as a bool: a Python bool or
    numpy's bool_; anything else is refused (a string "False" is true to
    Python, None false: neither says what the env meant)."""
    if v is True or v is False:
        return v
    import numpy as np

    if type(v) is np.bool_:
        return bool(v)
    raise Refused(f"{name} = {v!r} (type {type(v).__name__}); terminated and truncated must be "
                  f"booleans (Python bool or numpy.bool_): fix the env to return True or False")


def outside_space(space, o, where=""):
    """Why the observation `o` lies outside its discrete parts of `space`
    (a Discrete, MultiDiscrete or MultiBinary, or one inside a Dict or Tuple),
    which spaces.flatten would turn into another state's one-hot or an
    IndexError; None when it does not. Box parts are not checked: a Box
    observation beyond its bounds is taken as it is."""
    import numpy as np
    from gymnasium import spaces

    at = f" at {where}" if where else ""
    if isinstance(space, spaces.Discrete):
        lo, n = int(space.start), int(space.n)
        ok = isinstance(o, (int, np.integer, np.bool_))
        if not ok and isinstance(o, np.ndarray) and o.shape == () and o.dtype.kind in "iu":
            ok, o = True, o.item()
        if not ok:
            return (f"an observation {o!r} (type {type(o).__name__}){at} where the observation "
                    f"space {space} takes whole numbers {lo} to {lo + n - 1}")
        if not lo <= o < lo + n:
            return (f"an observation {o!r}{at} outside its space {space} (whole numbers {lo} "
                    f"to {lo + n - 1}); fix the env, or wrap it (gymnasium.ObservationWrapper)")
        return None
    if isinstance(space, (spaces.MultiDiscrete, spaces.MultiBinary)):
        a = np.asarray(o)
        if isinstance(space, spaces.MultiBinary):
            lo, hi, text = np.zeros(space.shape, np.int64), np.ones(space.shape, np.int64), "0 or 1"
        else:
            lo = np.asarray(space.start, np.int64)
            hi = lo + np.asarray(space.nvec, np.int64) - 1
            text = "whole numbers within start and start + nvec - 1"
        if a.shape != tuple(space.shape) or a.dtype.kind not in "biu":
            return (f"an observation {o!r} (type {type(o).__name__}, shape {a.shape}){at} where "
                    f"the observation space {space} takes {text} of shape {tuple(space.shape)}")
        bad = np.argwhere((a < lo) | (a > hi))
        if bad.size:
            k = tuple(int(x) for x in bad[0])
            return (f"an observation {o!r}{at} outside its space {space}: value {a[k].item()!r} at "
                    f"{list(k)} (each is {text}); fix the env, or wrap it "
                    f"(gymnasium.ObservationWrapper)")
        return None
    if isinstance(space, spaces.Dict) and isinstance(o, dict):
        for k, sub in space.spaces.items():
            if k in o:
                why = outside_space(sub, o[k], f"{where}[{k!r}]")
                if why:
                    return why
        return None
    if isinstance(space, spaces.Tuple) and isinstance(o, (tuple, list)):
        for k, (sub, v) in enumerate(zip(space.spaces, o)):
            why = outside_space(sub, v, f"{where}[{k}]")
            if why:
                return why
    return None
