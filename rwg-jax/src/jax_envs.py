"""The environment sources of rwg's JAX worker: each makes an env from its
library (gymnax, Brax, a user's `jax:module:callable`) and adapts it to the one
interface the episode loop drives (`Adapted`). `MAKERS` maps the protocol's
source name to its maker."""

from rwg_pipe import fail
from rwg_jax_worker_common import fail_exc, import_family, version_of

import importlib.abc
import importlib.machinery
import sys
import types


class Adapted:
    """An env as the episode loop drives it: reset(key) -> (obs, state),
    step(key, state, action) -> (obs, state, reward, done); its spaces and
    time limit; `versions` of what made it; `settings`, the choices rwg made
    for it (recorded); `legal(state)`, the legal actions of a state (a bool
    per discrete action) where the family gives them, else None.

    `obs_space` None: the observation is a pytree that `jax_obs.structured`
    flattens and describes. After `structured`, obs is one vector."""

    def __init__(self, reset, step, obs_space, act_space, max_steps, versions,
                 settings=None, legal=None):
        self.reset, self.step = reset, step
        self.obs_space, self.act_space = obs_space, act_space
        self.max_steps, self.versions = max_steps, versions
        self.settings = settings or {}
        self.legal = legal


def gymnax_step(env, params):
    """gymnax's raw step (no auto-reset) where the env has one."""
    raw = getattr(env, "step_env", None) or env.step

    def step(key, state, action):
        out = raw(key, state, action, params)
        if len(out) == 6:  # (obs, state, reward, terminated, truncated, info)
            return out[0], out[1], out[2], out[3] | out[4]
        return out[0], out[1], out[2], out[3]

    return step


def replace_params(params, kwargs, where):
    """`params.replace(**kwargs)`, refusing fields params does not have."""
    import dataclasses

    if not kwargs:
        return params
    try:
        fields = [f.name for f in dataclasses.fields(params)]
    except TypeError:
        fields = None
    if fields is not None:
        unknown = sorted(k for k in kwargs if k not in fields)
        if unknown:
            fail("make", f"{where} has no field {', '.join(unknown)}; its fields are: "
                         f"{', '.join(fields)}")
    for k, v in kwargs.items():
        wrong = wrong_type(v, getattr(params, k, None))
        if wrong:
            fail("make", f"{where}: {k} = {v!r} is a {type(v).__name__}, where the field takes "
                         f"{wrong}")
    try:
        return params.replace(**kwargs)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"{where}.replace(**{kwargs!r})", e)


def wrong_type(value, default):
    """What a params field of `default` takes, if `value` is not of it
    (gymnax casts nothing: a string fails deep in tracing, a bool or 2.5
    for a whole number is taken as a number); None if it is."""
    import numpy as np

    if default is None or isinstance(default, (str, bytes)):
        return None
    d = np.asarray(default)
    is_bool = isinstance(value, (bool, np.bool_))
    number = isinstance(value, (int, float, np.number)) and not is_bool
    shown = default if d.ndim == 0 else d.tolist()
    if d.dtype == np.bool_:
        ok, want = is_bool, "true or false"
    elif np.issubdtype(d.dtype, np.integer):
        ok, want = number and isinstance(value, (int, np.integer)), "a whole number"
    elif np.issubdtype(d.dtype, np.floating):
        ok, want = number, "a number"
    else:
        return None
    if d.ndim > 0:
        ok = np.shape(value) == d.shape and all(
            isinstance(x, (int, float, np.number)) and not isinstance(x, (bool, np.bool_))
            for x in np.ravel(np.asarray(value, dtype=object)))
        want = f"a list of shape {d.shape} of numbers"
    return None if ok else f"{want} (its default: {shown!r})"


def limit_of(params, max_steps, what):
    if max_steps is not None:
        return int(max_steps)
    t = getattr(params, "max_steps_in_episode", None)
    if t is None:
        fail("make", f"{what} has no params.max_steps_in_episode: give max_episode_steps in the "
                     f"manifest's [[envs]] entry")
    return int(t)


class _Deferred(types.ModuleType):
    """A module gymnax imports only to draw (matplotlib, seaborn), not loaded:
    rwg never draws, and loading them takes seconds."""

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        raise AttributeError(f"{self.__name__}.{name}: rwg's JAX worker does not load "
                             f"{self.__name__.split('.')[0]} (gymnax imports it to draw)")


class _DeferDrawing(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """While gymnax is imported: `_Deferred` stand-ins for its drawing modules."""

    ROOTS = ("matplotlib", "seaborn")

    def find_spec(self, name, path, target=None):
        if name.split(".")[0] in self.ROOTS:
            return importlib.machinery.ModuleSpec(name, self, is_package=True)
        return None

    def create_module(self, spec):
        m = _Deferred(spec.name)
        m.__path__ = []
        return m

    def exec_module(self, module):
        pass


def import_gymnax(package):
    """gymnax, imported without its drawing modules where it allows (else
    as it is, failures reported as import_family reports them): seconds less
    per worker."""
    import importlib

    if any(r in sys.modules for r in _DeferDrawing.ROOTS):
        return import_family("gymnax", package, "gymnax")
    finder = _DeferDrawing()
    sys.meta_path.insert(0, finder)
    try:
        return importlib.import_module("gymnax")
    except BaseException:  # noqa: BLE001 -- import it as it is: that says why it fails
        for m in [m for m in sys.modules if m.split(".")[0] == "gymnax"]:
            del sys.modules[m]
    finally:
        sys.meta_path.remove(finder)
        for m in [m for m in sys.modules if m.split(".")[0] in _DeferDrawing.ROOTS]:
            if isinstance(sys.modules[m], _Deferred):
                del sys.modules[m]
    return import_family("gymnax", package, "gymnax")


def make_gymnax(name, kwargs, max_steps, package):
    gymnax = import_gymnax(package)
    known = list(gymnax.registered_envs)
    if name not in known:
        fail("unknown-env", f"gymnax has no environment {name!r}; its environments are: "
                            f"{', '.join(known)}")
    try:
        env, params = gymnax.make(name)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"gymnax.make({name!r})", e)
    params = replace_params(params, kwargs, f"gymnax {name}'s env params")
    if max_steps is not None and hasattr(params, "max_steps_in_episode"):
        params = params.replace(max_steps_in_episode=int(max_steps))
    return Adapted(lambda k: env.reset(k, params), gymnax_step(env, params),
                   env.observation_space(params), env.action_space(params),
                   limit_of(params, max_steps, f"gymnax {name}"),
                   {"gymnax": version_of("gymnax")})


class BraxBox:
    """A brax env's observation or action space, in gymnax's Box terms."""

    def __init__(self, bound, size):
        import numpy as np

        self.low = np.full((size,), -bound)
        self.high = np.full((size,), bound)
        self.shape = (size,)

    def __repr__(self):
        return f"Box({self.low[0]}, {self.high[0]}, {self.shape})"


def make_brax(name, kwargs, max_steps, package):
    brax = import_family("brax.envs", package, "brax")
    known = sorted(getattr(brax, "_envs", {}))
    if known and name not in known:
        fail("unknown-env", f"brax has no environment {name!r}; its environments are: "
                            f"{', '.join(known)}")
    try:
        env = brax.get_environment(name, **kwargs)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"brax.envs.get_environment({name!r}, **{kwargs!r})", e)

    def reset(key):
        s = env.reset(key)
        return s.obs, s

    def step(key, state, action):
        s = env.step(state, action)
        return s.obs, s, s.reward, s.done > 0.5

    return Adapted(reset, step, BraxBox(float("inf"), int(env.observation_size)),
                   BraxBox(1.0, int(env.action_size)),
                   int(max_steps) if max_steps is not None else 1000,
                   {"brax": version_of("brax")})


def make_custom(target, kwargs, max_steps, package):
    import importlib
    import sys
    import traceback

    module, _, attr = target.partition(":")
    if not module or not attr:
        fail("make", f"jax:{target} is not jax:module:callable (e.g. jax:my_pkg.envs:make_env)")
    try:
        mod = importlib.import_module(module)
    except ImportError as e:
        fail("import", f"cannot import module {module!r} ({type(e).__name__}: {e}); install the "
                       f"package that provides it (`{sys.executable} -m pip install ...`) or put "
                       f"its folder on PYTHONPATH", traceback.format_exc())
    except BaseException as e:  # noqa: BLE001
        fail_exc("import", f"import {module}", e)
    fn = getattr(mod, attr, None)
    if not callable(fn):
        fail("make", f"module {module} has no callable {attr!r}")
    try:
        env, params = fn(**kwargs)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"{target}(**{kwargs!r})", e)
    adapted = Adapted(lambda k: env.reset(k, params), gymnax_step(env, params),
                      env.observation_space(params), env.action_space(params),
                      limit_of(params, max_steps, f"jax:{target}"),
                      {"module": version_of(module.split(".")[0])})
    adapted.source = module_source(module.split(".")[0])
    return adapted


# The most source files of a module's package digested, and bytes read.
MAX_SOURCE_FILES, MAX_SOURCE_BYTES = 4096, 64 << 20


def module_source(top):
    """What the code of a `jax:` env's top module is: the SHA-256 of its
    package's `.py` files (relative path and bytes, in path order; a lone
    module's file), how many, and, when it was found through PYTHONPATH or
    the current directory (not installed), the PYTHONPATH a command run
    elsewhere needs (absolute; None for an installed one)."""
    import hashlib
    import os
    import sys

    mod = sys.modules.get(top)
    paths = list(getattr(mod, "__path__", None) or [])
    files = []
    if paths:
        for base in paths:
            for folder, dirs, names in os.walk(base):
                dirs[:] = sorted(d for d in dirs if d != "__pycache__")
                files += [os.path.join(folder, n) for n in sorted(names) if n.endswith(".py")]
        root = os.path.dirname(os.path.abspath(paths[0]))
    elif getattr(mod, "__file__", None):
        files = [mod.__file__]
        root = os.path.dirname(os.path.abspath(mod.__file__))
    else:
        return None
    h, read = hashlib.sha256(), 0
    for f in files[:MAX_SOURCE_FILES]:
        try:
            with open(f, "rb") as fh:
                data = fh.read(MAX_SOURCE_BYTES - read + 1)
        except OSError:
            continue
        read += len(data)
        h.update(os.path.relpath(f, root).encode() + b"\0" + data + b"\0")
        if read > MAX_SOURCE_BYTES:
            break
    on_path = [os.path.abspath(p) for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    if root == os.getcwd() and root not in on_path:
        on_path.append(root)
    return {"module": top, "sha256": h.hexdigest(), "files": len(files),
            "pythonpath": os.pathsep.join(on_path) if root in on_path else None}


# The hello message's `source` -> make(name, kwargs, max_steps, package) ->
# Adapted (`package`: what to pip install for the source's library).
MAKERS = {"gymnax": make_gymnax, "brax": make_brax, "jax": make_custom}
