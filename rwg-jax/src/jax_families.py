"""The JAX env families beyond gymnax and Brax, each adapted to the
interface the episode loop drives (`Adapted`): MuJoCo Playground, Jumanji,
Craftax, Navix, XLand-MiniGrid and Pgx. Each maker imports its library
(`import_family`: a missing package and a package that fails to import are
told apart), names the family's known ids for an unknown one, makes the env
with the family's own call, and keeps the family's own time limit, reward and
end of episode. `MAKERS` maps the protocol's source name to its maker, the
families here and those of `jax_envs`."""

from rwg_pipe import fail
from rwg_jax_worker_common import fail_exc, import_family, version_of
from rwg_jax_worker_envs import MAKERS as BASE_MAKERS, Adapted, BraxBox, gymnax_step, replace_params


class Discrete:
    """A family's discrete action space, in gymnax's terms."""

    def __init__(self, n, text):
        self.n, self.text = int(n), text

    def __repr__(self):
        return self.text


def unknown(family, name, known):
    fail("unknown-env", f"{family} has no environment {name!r}; its environments are: "
                        f"{', '.join(known)}")


def no_kwargs(family, kwargs, call):
    if kwargs:
        fail("make", f"{call} takes no arguments, so {family} envs take no kwargs "
                     f"(got {', '.join(sorted(kwargs))})")


def limit_or_manifest(limit, max_steps, what):
    """`max_steps` (the manifest's) if given, else the family's `limit`."""
    if max_steps is not None:
        return int(max_steps)
    if limit is None:
        fail("make", f"{what} has no time limit of its own: give max_episode_steps in the "
                     f"manifest's [[envs]] entry")
    return int(limit)


# --- MuJoCo Playground -------------------------------------------------------

def playground_assets(pg, name):
    """Playground's locomotion and manipulation robots come from MuJoCo
    Menagerie, which Playground clones with git on first load: refuse at
    start, saying where it must be, when it is not there."""
    from mujoco_playground._src import locomotion, manipulation, mjx_env

    if name not in locomotion.ALL_ENVS and name not in manipulation.ALL_ENVS:
        return
    path = mjx_env.MENAGERIE_PATH
    if not path.exists():
        fail("assets", f"Playground's {name} needs the robot models of MuJoCo Menagerie at {path}, "
                       f"which is missing (Playground clones "
                       f"https://github.com/deepmind/mujoco_menagerie at commit "
                       f"{mjx_env.MENAGERIE_COMMIT_SHA} there on first use, which needs git and "
                       f"the network); clone it there at that commit, or run "
                       f"`from mujoco_playground import registry; registry.load({name!r})` once "
                       f"on a machine with the network and copy that folder")


def playground_obs(obs):
    """A dict observation without the fields Playground gives its critic only
    (`privileged_state`, ...): the policy's inputs."""
    if isinstance(obs, dict):
        return {k: v for k, v in obs.items() if not k.startswith("privileged")}
    return obs


def make_playground(name, kwargs, max_steps, package):
    pg = import_family("mujoco_playground", package, "MuJoCo Playground")
    from mujoco_playground import registry

    known = list(registry.ALL_ENVS)
    if name not in known:
        unknown("MuJoCo Playground", name, known)
    playground_assets(pg, name)
    overrides = dict(kwargs)
    overrides.setdefault("impl", "jax")  # 0.2.0's default is Warp (a GPU kernel library)
    if max_steps is not None:
        overrides["episode_length"] = int(max_steps)
    try:
        config = registry.get_default_config(name)
        config.update_from_flattened_dict(overrides)
        env = registry.load(name, config=config)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"mujoco_playground.registry.load({name!r}) with config overrides "
                         f"{overrides!r}", e)
    if int(config.get("action_repeat", 1)) != 1:
        fail("make", f"{name}'s config has action_repeat = {config.action_repeat}; rwg steps "
                     f"Playground envs one control step at a time (action_repeat = 1)")

    def reset(key):
        s = env.reset(key)
        return playground_obs(s.obs), s

    def step(key, s, action):
        s = env.step(s, action)
        return playground_obs(s.obs), s, s.reward, s.done > 0.5

    return Adapted(reset, step, None, BraxBox(1.0, int(env.action_size)),
                   int(config.episode_length),
                   {"playground": version_of("playground"), "mujoco": version_of("mujoco"),
                    "mujoco-mjx": version_of("mujoco-mjx")},
                   settings={"impl": str(config.impl)})


# --- Jumanji -------------------------------------------------------------------

def jumanji_action(spec):
    """Jumanji's action spec as a space rwg takes."""
    import numpy as np

    kind = type(spec).__name__
    if kind == "DiscreteArray":
        return Discrete(spec.num_values, repr(spec))
    if kind == "BoundedArray" and np.issubdtype(np.dtype(spec.dtype), np.floating):
        box = BraxBox(0.0, int(np.prod(spec.shape, dtype=np.int64)) or 1)
        box.low = np.broadcast_to(np.asarray(spec.minimum, np.float64), spec.shape).copy()
        box.high = np.broadcast_to(np.asarray(spec.maximum, np.float64), spec.shape).copy()
        box.shape = tuple(spec.shape)
        return box
    fail("space", f"action spec {spec!r} is a {kind}: rwg's policy gives one discrete action "
                  f"(DiscreteArray) or a box of floats (BoundedArray); multi-agent and "
                  f"multi-discrete Jumanji envs are not single networks' tasks")


def jumanji_split(obs):
    """(the observation without `action_mask`, the mask or None)."""
    if hasattr(obs, "_fields") and "action_mask" in obs._fields:
        return obs._replace(action_mask=None), obs.action_mask
    if isinstance(obs, dict) and "action_mask" in obs:
        return {k: v for k, v in obs.items() if k != "action_mask"}, obs["action_mask"]
    return obs, None


def jumanji_make_error(name, e):
    if name.startswith("Sokoban"):
        fail("assets", f"Jumanji's {name} loads DeepMind's Boxoban levels on first use (from the "
                       f"Hugging Face hub, into its cache under ~/.cache/huggingface or $HF_HOME), "
                       f"and that failed: {type(e).__name__}: {str(e).rstrip('.')}; make the env "
                       f"once on a machine with the network and copy the cache, or point HF_HOME "
                       f"at a copy")
    fail_exc("make", f"jumanji.make({name!r})", e)


def make_jumanji(name, kwargs, max_steps, package):
    import jax

    jumanji = import_family("jumanji", package, "Jumanji")
    known = sorted(jumanji.registered_environments())
    if name not in known:
        unknown("Jumanji", name, known)
    try:
        env = jumanji.make(name, **kwargs)
    except BaseException as e:  # noqa: BLE001
        jumanji_make_error(name, e)
    act = jumanji_action(env.action_spec)
    mask_shape = jax.eval_shape(lambda k: jumanji_split(env.reset(k)[1].observation)[1],
                                jax.random.PRNGKey(0))
    masked = (isinstance(act, Discrete) and mask_shape is not None
              and tuple(mask_shape.shape) == (act.n,) and str(mask_shape.dtype) == "bool")

    def reset(key):
        state, ts = env.reset(key)
        obs, mask = jumanji_split(ts.observation)
        return obs, (state, mask if masked else None)

    def step(key, s, action):
        state, ts = env.step(s[0], action)
        obs, mask = jumanji_split(ts.observation)
        return obs, (state, mask if masked else None), ts.reward, ts.last()

    limit = getattr(env, "time_limit", None)
    return Adapted(reset, step, None, act,
                   limit_or_manifest(limit, max_steps, f"Jumanji's {name}"),
                   {"jumanji": version_of("jumanji")},
                   legal=(lambda s: s[1]) if masked else None)


# --- Craftax ---------------------------------------------------------------------

# The names make_craftax_env_from_name knows without auto-reset.
CRAFTAX_ENVS = ["Craftax-Symbolic-v1", "Craftax-Pixels-v1", "Craftax-Classic-Symbolic-v1",
                "Craftax-Classic-Pixels-v1"]


def make_craftax(name, kwargs, max_steps, package):
    mod = import_family("craftax.craftax_env", package, "Craftax")
    if name not in CRAFTAX_ENVS:
        unknown("Craftax", name, CRAFTAX_ENVS)
    try:
        env = mod.make_craftax_env_from_name(name, auto_reset=False)
        params = env.default_params
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"make_craftax_env_from_name({name!r}, auto_reset=False)", e)
    params = replace_params(params, kwargs, f"Craftax {name}'s env params")
    if max_steps is not None:
        params = params.replace(max_timesteps=int(max_steps))
    return Adapted(lambda k: env.reset(k, params), gymnax_step(env, params),
                   env.observation_space(params), env.action_space(params),
                   int(params.max_timesteps), {"craftax": version_of("craftax")},
                   settings={"auto_reset": "false"})


# --- Navix ---------------------------------------------------------------------------

def make_navix(name, kwargs, max_steps, package):
    nx = import_family("navix", package, "Navix")
    known = sorted(nx.registry())
    if name not in known:
        unknown("Navix", name, known)
    kw = dict(kwargs)
    if max_steps is not None:
        kw["max_steps"] = int(max_steps)
    try:
        env = nx.make(name, **kw)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"navix.make({name!r}, **{kw!r})", e)
    # Navix's step resets a finished episode (a lax.cond, which vmap turns into
    # computing both branches); rwg ends the episode there, so it steps with
    # the step without the reset.
    raw_step = getattr(env, "_step", env.step)

    def step(key, ts, action):
        ts = raw_step(ts, action)
        return ts.observation, ts, ts.reward, ts.is_done()

    def reset(key):
        ts = env.reset(key)
        return ts.observation, ts

    n = len(env.action_set)
    return Adapted(reset, step, None, Discrete(n, f"Discrete({n})"), int(env.max_steps),
                   {"navix": version_of("navix")})


# --- XLand-MiniGrid -----------------------------------------------------------------------

def xland_ruleset(xm, kwargs):
    """The `benchmark` and `ruleset` kwargs (rwg's, not xminigrid.make's): the
    ruleset of that benchmark as an env param; the files must be on disk."""
    import os

    bench, index = kwargs.pop("benchmark", None), kwargs.pop("ruleset", None)
    if bench is None and index is None:
        return None
    from xminigrid import benchmarks

    known = list(benchmarks.registered_benchmarks())
    if bench not in known or not isinstance(index, int) or isinstance(index, bool):
        fail("make", f"XLand-MiniGrid's kwargs `benchmark` and `ruleset` go together: one of "
                     f"{', '.join(known)} and a ruleset index (an integer), got {bench!r} and "
                     f"{index!r}")
    path = os.path.join(benchmarks.DATA_PATH, benchmarks.NAME2HFFILENAME[bench])
    if not os.path.exists(path):
        fail("assets", f"XLand-MiniGrid's benchmark {bench!r} is not at {path} (xminigrid "
                       f"downloads it from https://huggingface.co/datasets/"
                       f"{benchmarks.HF_REPO_ID}/resolve/main/{benchmarks.NAME2HFFILENAME[bench]} "
                       f"on first use, which needs the network); put that file there, or set "
                       f"XLAND_MINIGRID_DATA to the folder that holds it")
    try:
        b = benchmarks.load_benchmark_from_path(path)
        if not 0 <= index < b.num_rulesets():
            fail("make", f"benchmark {bench!r} has rulesets 0 to {b.num_rulesets() - 1}, not "
                         f"{index}")
        return b.get_ruleset(index)
    except SystemExit:
        raise
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"loading XLand-MiniGrid's benchmark {bench!r} from {path}", e)


def make_xminigrid(name, kwargs, max_steps, package):
    xm = import_family("xminigrid", package, "XLand-MiniGrid")
    known = list(xm.registered_environments())
    if name not in known:
        unknown("XLand-MiniGrid", name, known)
    kw = dict(kwargs)
    ruleset = xland_ruleset(xm, kw)
    try:
        env, params = xm.make(name, **kw)
        if ruleset is not None:
            params = params.replace(ruleset=ruleset)
        if max_steps is not None:
            params = params.replace(max_steps=int(max_steps))
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"xminigrid.make({name!r}, **{kw!r})", e)

    def reset(key):
        ts = env.reset(params, key)
        return ts.observation, ts

    def step(key, ts, action):
        ts = env.step(params, ts, action)
        return ts.observation, ts, ts.reward, ts.last()

    n = int(env.num_actions(params))
    return Adapted(reset, step, None, Discrete(n, f"Discrete({n})"), int(params.max_steps),
                   {"xminigrid": version_of("xminigrid")})


# --- Pgx -----------------------------------------------------------------------------------

def pgx_single_player(pgx):
    """Pgx's single-player games."""
    out = []
    for e in pgx.available_envs():
        try:
            if pgx.make(e).num_players == 1:
                out.append(e)
        except BaseException:  # noqa: BLE001 -- a game that needs more to make
            pass
    return out


def make_pgx(name, kwargs, max_steps, package):
    pgx = import_family("pgx", package, "Pgx")
    known = list(pgx.available_envs())
    if name not in known:
        unknown("Pgx", name, known)
    no_kwargs("Pgx", kwargs, "pgx.make")
    try:
        env = pgx.make(name)
    except BaseException as e:  # noqa: BLE001
        fail_exc("make", f"pgx.make({name!r})", e)
    if env.num_players != 1:
        fail("make", f"Pgx's {name} is a game of {env.num_players} players: rwg measures one "
                     f"network acting in an environment, so it takes Pgx's single-player games: "
                     f"{', '.join(pgx_single_player(pgx))}")

    def reset(key):
        s = env.init(key)
        return s.observation, s

    def step(key, s, action):
        s = env.step(s, action, key)
        return s.observation, s, s.rewards[0], s.terminated | s.truncated

    n = int(env.num_actions)
    return Adapted(reset, step, None, Discrete(n, f"Discrete({n})"),
                   limit_or_manifest(None, max_steps, f"Pgx's {name}"),
                   {"pgx": version_of("pgx")}, settings={"game_version": str(env.version)},
                   legal=lambda s: s.legal_action_mask)


# The hello message's `source` -> make(name, kwargs, max_steps, package) -> Adapted.
MAKERS = dict(BASE_MAKERS, playground=make_playground, jumanji=make_jumanji,
              craftax=make_craftax, navix=make_navix, xminigrid=make_xminigrid, pgx=make_pgx)
