"""rwg_env_spaces: a Gymnasium env's spaces as rwg takes them, for rwg's
Gymnasium worker: the observation space flattened to a bounded number of
values, the action space a Discrete or a bounded Box, each observation
flattened (or refused, naming why) and the spaces of later instances held to
those of the first. A space rwg does not take fails (rwg_pipe's fail, kind
"space"); an observation rwg does not take raises Refused.
"""

from rwg_pipe import fail, floats
from rwg_env_values import OLD_RESET, Refused, describe, floats_text, not_real, outside_space


class Spaces:
    """The spaces of an env's first instance, read at start-up: numpy, gymnasium.spaces
    and numpy's ComplexWarning (made an error here) come from the worker,
    which has imported them."""

    def __init__(self, np, spaces, complex_warning, obs_space, act_space):
        self.np, self.spaces, self.complex_warning = np, spaces, complex_warning
        self.obs_space, self.act_space = obs_space, act_space
        self.obs_text, self.act_text = str(obs_space), str(act_space)

    def read_observation_space(self, name, hello):
        """The flat observation space (of the env `name`): a Box flattened
        row-major, others through spaces.flatten; refused without values or
        over the hello's max_obs."""
        np, spaces, obs_space = self.np, self.spaces, self.obs_space
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
        self.boxed, self.obs_dim = boxed, obs_dim
        # the shape of an observation the exchange loop copies as it is (a 1-D Box's)
        self.flat_shape = obs_space.shape if boxed and len(obs_space.shape) == 1 else None
        self.obs_low = np.asarray(flat_space.low, dtype=np.float64).reshape(-1)
        self.obs_high = np.asarray(flat_space.high, dtype=np.float64).reshape(-1)

    def read_action_space(self, hello):
        """The action space: Discrete (`start` added to the chosen index), or
        a bounded Box (act_dim values, given as act_dtype in act_shape)."""
        np, spaces, act_space = self.np, self.spaces, self.act_space
        self.start, self.act_shape, self.act_dtype = 0, None, None
        if isinstance(act_space, spaces.Discrete):
            self.action = {"type": "Discrete", "n": int(act_space.n), "start": int(act_space.start)}
            self.act_dim = 0
            self.start = int(act_space.start)
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
            self.action = {"type": "Box", "low": floats(low), "high": floats(high),
                           "shape": list(act_space.shape)}
            self.act_dim = int(low.size)
            self.act_low, self.act_high = low, high
            self.act_shape = tuple(act_space.shape)
            self.act_dtype = np.float32 if hello.get("action_dtype") == "float32" else np.float64
        else:
            fail("space", f"action space {act_space} is not supported: rwg takes Discrete and bounded "
                          f"Box actions (MultiDiscrete, MultiBinary, Dict, Tuple, Text, Graph are not); "
                          f"wrap the env (gymnasium.ActionWrapper) to give one of those")

    def random_action(self, rng):
        """An action drawn from numpy Generator `rng`, uniform over the space."""
        if self.act_dim:
            return rng.uniform(self.act_low, self.act_high).astype(self.act_dtype).reshape(
                self.act_shape)
        return self.start + int(rng.integers(self.action["n"]))

    def flat_obs(self, o):
        """The observation `o` as a flat array of obs_dim numbers; Refused
        (naming what is wrong) when it is not one of its space."""
        np, obs_space, obs_dim, boxed = self.np, self.obs_space, self.obs_dim, self.boxed
        if not boxed:
            outside = outside_space(obs_space, o)
            if outside:
                raise Refused(outside)
        try:
            a = np.asarray(o) if boxed else self.spaces.flatten(obs_space, o)
        except self.complex_warning:
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

    def reset_obs(self, r, seed):
        """The flat observation of `r`, what reset(seed=seed) returned."""
        if type(r) is not tuple or len(r) != 2:
            n = f"a tuple of {len(r)} values" if type(r) is tuple else describe(r)
            raise Refused(f"reset(seed={seed}) returned {n}; {OLD_RESET}")
        try:
            return self.flat_obs(r[0])
        except Refused as e:
            raise Refused(f"reset(seed={seed}) returned {e}") from None

    def check_spaces(self, env, which):
        """Refuses `env` (`which` names it) if its spaces are not those of
        instance 0 when the worker started: an identity test, and a
        comparison of their text only when they are other objects."""
        o, a = env.observation_space, env.action_space
        obs_space, act_space = self.obs_space, self.act_space
        if (o is obs_space or str(o) == self.obs_text) and (a is act_space or str(a) == self.act_text):
            return
        raise Refused(f"{which} has observation space {o} and action space {a}, where the "
                      f"env started with {obs_space} and {act_space}; rwg runs every episode "
                      f"of a cell under one set of spaces, so an env must not change them "
                      f"(between instances or episodes)")
