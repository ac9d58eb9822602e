/*
 * rwg_plugin.h -- the rwg environment plugin ABI, version 1.2.
 *
 * 1.1 (append-only over 1.0): the optional batched calls reset_many and
 * step_many at the end of rwg_env_vtable_t. A 1.0 plugin (a smaller
 * vtable struct_size) loads and runs unchanged on the single-step calls.
 * 1.2 (append-only over 1.1): the optional vector env, one object holding
 * many lanes of an environment (vec_create, vec_destroy, vec_reset,
 * vec_step, vec_last_error at the end of rwg_env_vtable_t), so a plugin can
 * keep its lanes' states as arrays and step them together. A 1.1 plugin
 * loads and runs unchanged on its batched calls.
 *
 * This header is the normative definition of the ABI. The Rust mirror
 * (rwg-env/src/plugin/abi.rs) follows it; where the two disagree, this file
 * is right and the Rust side has a bug.
 *
 * A plugin is a shared library (.so / .dylib / .dll) that exports ONE function,
 * rwg_plugin_entry_v1, which returns a static table describing the plugin: its
 * environments (id, spaces, time limit, solved score) and, for each
 * environment, a table of functions that create, reset, step and destroy
 * instances of it. Everything else crosses the boundary through those tables.
 *
 * ---------------------------------------------------------------------------
 * Rules that hold for the whole ABI
 * ---------------------------------------------------------------------------
 * Types.     Only fixed-width integers, double, size_t, pointers and function
 *            pointers cross the boundary: no C enums, no bool. Flags are
 *            uint8_t holding exactly 0 or 1; the host rejects other values.
 * Statuses.  Functions that can fail return rwg_status_t (int32_t), one of the
 *            RWG_OK / RWG_ERR_* constants below. A host treats an unknown
 *            non-zero code as RWG_ERR_INTERNAL.
 * Growth.    Structs that start with `struct_size` only ever grow at their
 *            end, and only in a new minor version. The side that fills such a
 *            struct sets struct_size to sizeof() of its own version; the
 *            reader refuses a struct smaller than the one of the minor version
 *            it needs and ignores bytes past the fields it knows. Structs
 *            without struct_size (rwg_space_t, rwg_step_out_t) are frozen for
 *            ABI v1. `reserved` fields must be written as 0 and are ignored on
 *            reading. New features come as new minor versions (new fields at
 *            the end) or as extensions (get_extension), never by changing the
 *            meaning of an existing field.
 * Strings.   NUL-terminated UTF-8. Strings the plugin hands out (ids,
 *            summaries, versions, the ABI tag) belong to the plugin and stay
 *            valid and unchanged until deinit, i.e. for the process lifetime in
 *            rwg, which never unloads a plugin. last_error strings follow their
 *            own, shorter rule (see last_error).
 * Memory.    Observation and action buffers and rwg_step_out_t belong to the
 *            host; the plugin only reads or writes them during the call it was
 *            given them in and never keeps a pointer to them. Descriptors,
 *            function tables and strings belong to the plugin. Nothing is ever
 *            freed across the boundary: an instance is freed only by its own
 *            table's destroy.
 * Threads.   The entry function, init, deinit, env_count, env_desc,
 *            env_vtable, get_extension, create and vec_create are thread-safe: the host
 *            may call them from any thread, concurrently (except that init
 *            and deinit are not called concurrently with anything else).
 *            Instance functions (reset, step, last_error, destroy, and 1.1's
 *            reset_many and step_many for each instance they are given) are
 *            called on one instance by one thread at a time, but an instance
 *            may move between threads between calls; different instances are
 *            used concurrently (1.2's vector envs likewise: one thread at a
 *            time per vector env). A plugin keeps NO hidden global or thread-local
 *            mutable state that affects results: an episode must depend only
 *            on its instance's config, seed and actions, never on which thread
 *            runs it or on what other instances do (`rwg check` tests this).
 * Crashes.   A function must never unwind (C++ exceptions, Rust panics) into
 *            the host: catch, return RWG_ERR_PANIC and poison the instance
 *            (every later call on it except last_error and destroy returns
 *            RWG_ERR_PANIC). Loading a plugin runs its code in the host
 *            process: a plugin that crashes takes the host with it. `rwg
 *            check` runs a plugin in a child process for that reason.
 * Floats.    Observations and rewards must be finite (no NaN, no infinity);
 *            the host turns a non-finite value into an error naming the
 *            plugin and environment.
 *
 * ---------------------------------------------------------------------------
 * What the reference implementation does where the rules above leave a choice
 * ---------------------------------------------------------------------------
 * "The shim" is the Rust export code every Rust plugin uses (rwg-env's
 * export_plugin!); "the host" is rwg (rwg-plugin-host). A C plugin may choose
 * otherwise where the rules allow it; these are what rwg's own code does, and
 * what its tests check.
 * Several errors at once.  The shim reports the first that applies, in this
 *            order: a NULL env (RWG_ERR_INVALID_ARGUMENT); a poisoned instance
 *            (RWG_ERR_PANIC); in reset, has_seed = 0 (RWG_ERR_UNSUPPORTED) or
 *            another value than 0 or 1 (RWG_ERR_INVALID_ARGUMENT); in step, a
 *            NULL out or action, then an action outside the action space
 *            (RWG_ERR_INVALID_ARGUMENT); then a wrong obs_len or a NULL obs
 *            (RWG_ERR_BUFFER_SIZE); only then the environment's own answer
 *            (RWG_ERR_RESET_NEEDED for a step before the first reset, ...).
 *            So a step before reset with an invalid action is
 *            RWG_ERR_INVALID_ARGUMENT. The host, reading a step, checks the
 *            status first, then the flags, then the reward, then the
 *            observation, and reports the first problem.
 * State after a failed call.  A call the shim refuses before reaching the
 *            environment (every case above except the environment's own
 *            answer) leaves the instance exactly as it was: the next call
 *            behaves as if the failed one had not been made. After
 *            RWG_ERR_PANIC the instance is poisoned (see Crashes). The host
 *            ends the episode at any failed call: `rwg run` stops the cell
 *            with an error naming the plugin, env, network ("sample"),
 *            episode and step (finished blocks are kept), and never calls the
 *            instance again except destroy.
 * Step after termination.  The host never steps an instance whose last step
 *            returned terminated or truncated: it resets it first. The shim
 *            passes such a step to the environment; rwg's built-in
 *            environments accept it (as Gymnasium's do).
 * Observations outside the declared space.  Finite values outside a Box's
 *            [low, high] are accepted by the host and used as they are (the
 *            network sees them); `rwg check` WARNs about them ("rollout").
 *            Non-finite values are errors (see Floats). The host fills the
 *            obs buffer with NaN before each reset and step, so an element
 *            the plugin leaves unwritten is a non-finite-observation error.
 * Reset without a seed.  rwg runs and checks always pass has_seed = 1, except
 *            `rwg check`'s "unseeded reset" check, which passes has_seed = 0
 *            once and accepts RWG_OK or RWG_ERR_UNSUPPORTED. The shim answers
 *            has_seed = 0 with RWG_ERR_UNSUPPORTED.
 * has_seed values.  The host only ever passes 0 or 1. The shim refuses any
 *            other value with RWG_ERR_INVALID_ARGUMENT, before touching the
 *            instance.
 * A struct_size from a newer header.  The host accepts an rwg_plugin_entry_t,
 *            rwg_env_desc_t or rwg_env_vtable_t whose struct_size is larger
 *            than its own (a plugin built with a newer minor), reads the
 *            fields it knows and ignores the rest; a smaller one is refused
 *            naming the struct and both sizes. The shim likewise accepts an
 *            rwg_host_t at least as large as 1.0's and refuses a smaller one
 *            (init returns RWG_ERR_INVALID_ARGUMENT).
 * A time limit of 0.  Legal: the environment has no time limit. `rwg run`
 *            needs one to bound every episode, so it refuses such an
 *            environment unless its [[envs]] entry sets max_episode_steps
 *            (the error says so); `rwg rollout` runs it until it terminates or
 *            the actions run out; `rwg check` WARNs ("truncation") that run
 *            will need max_episode_steps.
 *
 * ---------------------------------------------------------------------------
 * Call sequence
 * ---------------------------------------------------------------------------
 *   entry = rwg_plugin_entry_v1(RWG_PLUGIN_ABI_MAJOR, RWG_PLUGIN_ABI_MINOR);
 *   entry->init(&host, err, sizeof err)        (if init is not NULL)
 *   n = entry->env_count();
 *   for i in 0..n: desc = entry->env_desc(i); vt = entry->env_vtable(i);
 *   vt->create(i, config, &env, err, sizeof err);
 *   vt->reset(env, 1, seed, obs, obs_len);
 *   vt->step(env, action, action_len, obs, obs_len, &out);  ... repeatedly
 *   (1.1, if vt->step_many is set: vt->reset_many / vt->step_many on arrays
 *    of instances, in place of the single calls)
 *   vt->destroy(env);
 *   entry->deinit()                            (if deinit is not NULL; rwg never calls it)
 */
#ifndef RWG_PLUGIN_H
#define RWG_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------------- */
/* Versions                                                                  */
/* ------------------------------------------------------------------------- */

/* A host and a plugin work together when their majors are equal. The minor
 * only adds (fields at the end of growable structs, flags, status codes,
 * extensions); each side uses only what the other side's minor provides. */
#define RWG_PLUGIN_ABI_MAJOR 1u
#define RWG_PLUGIN_ABI_MINOR 2u

/* rwg_plugin_entry_t.abi_tag must point to exactly this string. It guards
 * against a library that exports a function with the entry's name by chance. */
#define RWG_PLUGIN_ABI_TAG "rwg-env-plugin"

/* The name of the one exported function (the major version is part of it, so
 * a future v2 host can probe for _v2 and fall back to _v1). */
#define RWG_PLUGIN_ENTRY_SYMBOL "rwg_plugin_entry_v1"

/* ------------------------------------------------------------------------- */
/* Status codes                                                              */
/* ------------------------------------------------------------------------- */

typedef int32_t rwg_status_t;

/* Success. */
#define RWG_OK ((rwg_status_t)0)
/* An argument is not acceptable: an action outside the action space (a
 * discrete action that is not an integer in 0..n-1, a NaN or infinite
 * continuous action, a wrong action length), an invalid config string, a NULL
 * where a pointer is required, an unknown env_index. */
#define RWG_ERR_INVALID_ARGUMENT ((rwg_status_t)1)
/* step was called before the first reset of the instance. */
#define RWG_ERR_RESET_NEEDED ((rwg_status_t)2)
/* obs_len is not the observation space's length. */
#define RWG_ERR_BUFFER_SIZE ((rwg_status_t)3)
/* The plugin does not support the request (e.g. reset without a seed). */
#define RWG_ERR_UNSUPPORTED ((rwg_status_t)4)
/* The plugin caught a panic or exception in this call or an earlier one on
 * this instance; the instance is poisoned and can only be destroyed. */
#define RWG_ERR_PANIC ((rwg_status_t)5)
/* Any other failure inside the plugin. */
#define RWG_ERR_INTERNAL ((rwg_status_t)6)

/* ------------------------------------------------------------------------- */
/* Spaces                                                                    */
/* ------------------------------------------------------------------------- */

/* rwg_space_t.kind. 0 is deliberately invalid, so a zeroed space is refused. */
#define RWG_SPACE_DISCRETE 1u /* the integers 0..n-1 */
#define RWG_SPACE_BOX 2u      /* vectors of n doubles with low[i] <= x[i] <= high[i] */

/* An observation or action space. Frozen for ABI v1 (no struct_size).
 * Owned by the plugin, valid until deinit. */
typedef struct rwg_space {
    uint32_t kind;      /* RWG_SPACE_DISCRETE or RWG_SPACE_BOX */
    uint32_t reserved;  /* 0 */
    /* Discrete: the number of values, >= 1 and <= 2^53 (actions cross as
     * doubles, see step). Box: the number of dimensions, >= 1. */
    uint64_t n;
    /* Box: n lower bounds and n upper bounds, low[i] <= high[i], neither NaN;
     * -INFINITY / INFINITY mean unbounded. Discrete: NULL (ignored). */
    const double *low;
    const double *high;
} rwg_space_t;

/* ------------------------------------------------------------------------- */
/* Environment descriptor                                                    */
/* ------------------------------------------------------------------------- */

/* What an environment is. Owned by the plugin, valid and unchanged until
 * deinit. Growable (struct_size). */
typedef struct rwg_env_desc {
    uint32_t struct_size; /* sizeof(rwg_env_desc_t) of the plugin's header */
    uint32_t flags;       /* no flags are defined in 1.0: write 0; hosts ignore unknown bits */
    /* Gymnasium-style id "[namespace/]Name-vN", e.g. "example/PointMass-v0":
     * non-empty, no whitespace or control characters, unique in the plugin.
     * Plugins should namespace their ids so they never collide with rwg's
     * built-in environments or with other plugins. */
    const char *id;
    /* One line describing the task, for `rwg envs`. May be NULL (= ""). */
    const char *summary;
    /* Must be a Box. */
    rwg_space_t observation_space;
    /* A Box or a Discrete space. */
    rwg_space_t action_space;
    /* Episode length limit, 0 = none. The plugin does NOT apply it: the host
     * truncates episodes itself, like Gymnasium's TimeLimit wrapper (it sets
     * `truncated` on the step whose count reaches the limit). */
    uint32_t max_episode_steps;
    uint32_t reserved; /* 0 */
    /* Gymnasium's reward_threshold: the episode return at which the task
     * counts as solved. NaN = none. Must not be infinite. */
    double reward_threshold;
} rwg_env_desc_t;

/* ------------------------------------------------------------------------- */
/* Instances                                                                 */
/* ------------------------------------------------------------------------- */

/* An environment instance; opaque to the host. */
typedef struct rwg_env rwg_env_t;

/* ABI 1.2: a vector env, many lanes of one environment in one object (see
 * vec_create); opaque to the host. */
typedef struct rwg_vec_env rwg_vec_env_t;

/* What step returns besides the observation. Owned by the host. Frozen for
 * ABI v1. On RWG_OK the plugin writes all three fields. */
typedef struct rwg_step_out {
    double reward;       /* finite */
    uint8_t terminated;  /* 0 or 1: the episode ended inside the MDP */
    /* 0 or 1: the plugin cut the episode for a reason of its own. Plugins
     * normally write 0: the time limit is applied by the host. */
    uint8_t truncated;
    uint8_t reserved[6]; /* ignored */
} rwg_step_out_t;

/* The functions of one environment. Owned by the plugin, valid until deinit.
 * Growable (struct_size). No function pointer may be NULL. */
typedef struct rwg_env_vtable {
    uint32_t struct_size; /* sizeof(rwg_env_vtable_t) of the plugin's header */
    uint32_t reserved;    /* 0 */

    /* Creates an instance.
     *   env_index  the index i this table was obtained with (env_vtable(i)),
     *              so that one create function can serve several envs.
     *   config     NUL-terminated UTF-8, never NULL; "" means defaults. Its
     *              syntax is the plugin's (rwg passes the user's text through).
     *              Only read during the call.
     *   out_env    on RWG_OK receives the new instance; untouched otherwise.
     *   err_buf    host-owned buffer of err_len bytes (err_len may be 0 and
     *              err_buf then NULL). On failure the plugin writes a
     *              NUL-terminated UTF-8 message there, truncated to fit.
     * Returns RWG_OK, RWG_ERR_INVALID_ARGUMENT (bad config or env_index),
     * RWG_ERR_PANIC or RWG_ERR_INTERNAL.
     * Thread-safe. A new instance needs reset before step. */
    rwg_status_t (*create)(uint32_t env_index, const char *config, rwg_env_t **out_env,
                           char *err_buf, size_t err_len);

    /* Frees an instance. NULL-safe (does nothing on NULL). Works on a
     * poisoned instance too. The instance must not be used afterwards, and
     * strings returned by its last_error die with it. */
    void (*destroy)(rwg_env_t *env);

    /* Starts an episode and writes the first observation into obs.
     *   has_seed  1: seed the episode with `seed` (Gymnasium's
     *             reset(seed=seed)); the same seed must give the same episode
     *             for the same actions, on any instance, in any thread.
     *             0: continue the instance's own random stream (Gymnasium's
     *             reset() without seed); a plugin may answer
     *             RWG_ERR_UNSUPPORTED. rwg always passes has_seed = 1.
     *   obs       host buffer of obs_len doubles; obs_len must equal the
     *             observation space's n, else RWG_ERR_BUFFER_SIZE.
     * Returns RWG_OK, RWG_ERR_INVALID_ARGUMENT, RWG_ERR_BUFFER_SIZE,
     * RWG_ERR_UNSUPPORTED, RWG_ERR_PANIC or RWG_ERR_INTERNAL.
     * One thread at a time per instance. */
    rwg_status_t (*reset)(rwg_env_t *env, uint8_t has_seed, uint64_t seed, double *obs,
                          size_t obs_len);

    /* Applies an action, writes the next observation into obs and the reward
     * and flags into *out.
     *   action, action_len  host buffer. Box action space: action_len == n
     *             and every value finite (values outside [low, high] are the
     *             plugin's to clip or refuse). Discrete action space:
     *             action_len == 1 and action[0] holds the action as an
     *             integral double in 0..n-1 (exact up to 2^53). Anything else
     *             (NaN, 0.5, -1, n, a wrong length) is RWG_ERR_INVALID_ARGUMENT;
     *             a plugin must never crash on it.
     *   obs, obs_len  as for reset.
     *   out       host-owned; written on RWG_OK.
     * After an episode has terminated the host resets before stepping again;
     * a plugin may keep accepting steps (Gymnasium's envs do) or refuse them
     * with RWG_ERR_RESET_NEEDED.
     * Returns RWG_OK, RWG_ERR_INVALID_ARGUMENT, RWG_ERR_RESET_NEEDED (no
     * reset yet), RWG_ERR_BUFFER_SIZE, RWG_ERR_PANIC or RWG_ERR_INTERNAL.
     * One thread at a time per instance. */
    rwg_status_t (*step)(rwg_env_t *env, const double *action, size_t action_len,
                         double *obs, size_t obs_len, rwg_step_out_t *out);

    /* A NUL-terminated UTF-8 message describing why the most recent call on
     * this instance failed; "" (or NULL) if it did not fail. Never fails.
     * The string belongs to the plugin and is valid until the next call on
     * this instance (including destroy), so no thread-local storage is
     * needed. One thread at a time per instance. */
    const char *(*last_error)(const rwg_env_t *env);

    /* ---- ABI 1.1: batched calls. Optional: both NULL, or both set (the
     * host refuses a table with only one). A host reads them only when
     * struct_size covers them (a 1.0 table ends at last_error).
     *
     * They reset or step many instances of THIS table's environment in one
     * call, over host-owned structure-of-arrays buffers. "Lane" i is
     * envs[i]; for n lanes:
     *   envs       n distinct instances created by this table's create (with
     *              the same config), host-owned array, read during the call.
     *   mask       n flags (0 or 1), or NULL = every lane. Only lanes with
     *              mask[i] = 1 are touched; the slots of the others, in every
     *              buffer, are neither read nor written.
     *   obs        n * obs_len doubles: lane i's observation at
     *              obs + i * obs_len; obs_len is ONE lane's length (the
     *              observation space's n, else RWG_ERR_BUFFER_SIZE).
     *   failed     host-owned; on a status other than RWG_OK receives the
     *              lane that failed (n if the call was refused as a whole, e.g.
     *              a NULL buffer: then no lane was touched and there is no
     *              message). May be NULL.
     * Meaning: exactly the single calls on the masked lanes in increasing i,
     * stopping at the first that fails: lanes before it are done (outputs
     * written), the failing lane i is left as its single call leaves it (its
     * message in last_error(envs[i]), poisoned after RWG_ERR_PANIC), lanes
     * after it are not touched. The results are bit for bit those of the
     * single calls (`rwg check` tests it), so a host may use either path.
     * Threads: a call uses all its n instances, so none of them may be in
     * use by another thread during it; calls on disjoint instance sets may
     * run concurrently. Memory: every buffer belongs to the host and is only
     * used during the call. n = 0 is RWG_OK and does nothing. */

    /* reset(envs[i], 1, seeds[i], obs + i * obs_len, obs_len) for every
     * masked lane: always seeded (rwg always seeds; has_seed = 0 exists only
     * on the single call). seeds: n values. */
    rwg_status_t (*reset_many)(rwg_env_t *const *envs, size_t n, const uint8_t *mask,
                               const uint64_t *seeds, double *obs, size_t obs_len,
                               size_t *failed);

    /* step(envs[i], actions + i * action_len, action_len,
     *      obs + i * obs_len, obs_len, &out_i) for every masked lane, out_i's
     * fields going to rewards[i], terminated[i] and truncated[i].
     *   actions     n * action_len doubles; action_len is ONE lane's length,
     *               with the single step's rules (1 for a Discrete space, the
     *               action an integral double; n of a Box, finite values).
     *               The same doubles as the single step: a plugin that rounds
     *               actions to float32 does so in both.
     *   rewards     n doubles; terminated, truncated: n flags (0 or 1).
     * The host applies the time limit itself, as for step. */
    rwg_status_t (*step_many)(rwg_env_t *const *envs, size_t n, const uint8_t *mask,
                              const double *actions, size_t action_len, double *obs,
                              size_t obs_len, double *rewards, uint8_t *terminated,
                              uint8_t *truncated, size_t *failed);

    /* ---- ABI 1.2: the vector env. Optional: all five NULL, or all five set
     * (the host refuses a table with some). A host reads them only when
     * struct_size covers them (a 1.1 table ends at step_many).
     *
     * A vector env holds `lanes` instances ("lanes") of THIS table's
     * environment with one config, in one object, so the plugin may keep
     * their states as arrays and compute a step of all of them together
     * (EnvPool's and Gymnasium's VectorEnv's shape). Lane i behaves exactly
     * as an instance made by create with the same config: the same seed and
     * actions give the same observations, rewards and flags, bit for bit
     * (`rwg check` tests it), so a host may use either.
     * Buffers, for a vector env of n lanes, all host-owned and used only
     * during the call:
     *   mask       n flags (0 or 1), or NULL = every lane. Only lanes with
     *              mask[i] = 1 take part; the slots of the others, in every
     *              buffer but `status`, are neither read nor written.
     *   obs        n * obs_len doubles, lane i's at obs + i * obs_len;
     *              obs_len is ONE lane's length (the observation space's n).
     *   status     n rwg_status_t, or NULL. When the call returns other
     *              than RWG_OK, the plugin has written every lane's status
     *              there: RWG_OK for a lane done (or not masked), else the
     *              lane's error, its message in vec_last_error(vec, i). On
     *              RWG_OK it may have written them too (or not).
     * Meaning: the single call on every masked lane. A lane that fails does
     * not stop the others: they are done all the same. The call returns
     * RWG_OK when every masked lane succeeded, else the status of the
     * lowest lane that failed. A call refused as a whole (a NULL buffer, a
     * mask value other than 0 or 1, a wrong obs_len or action_len) touches
     * no lane and gives its status to every lane. A panic or
     * exception caught in a call poisons the whole vector env: its masked
     * lanes fail with RWG_ERR_PANIC, and every later call fails every
     * masked lane with RWG_ERR_PANIC (only vec_destroy and vec_last_error
     * still work).
     * Threads: one thread at a time per vector env (it may move between
     * threads between calls); different vector envs, and instances made by
     * create, are used concurrently. */

    /* Creates a vector env of `lanes` >= 1 lanes (the plugin may refuse a
     * count it cannot hold with RWG_ERR_INVALID_ARGUMENT). env_index, config,
     * err_buf and err_len as for create. Thread-safe. Every lane needs a
     * vec_reset before it steps. */
    rwg_status_t (*vec_create)(uint32_t env_index, const char *config, size_t lanes,
                               rwg_vec_env_t **out_vec, char *err_buf, size_t err_len);

    /* Frees a vector env. NULL-safe. Works on a poisoned one too. */
    void (*vec_destroy)(rwg_vec_env_t *vec);

    /* reset(lane i, 1, seeds[i], obs + i * obs_len, obs_len) for every
     * masked lane (always seeded). seeds: n values. */
    rwg_status_t (*vec_reset)(rwg_vec_env_t *vec, const uint8_t *mask, const uint64_t *seeds,
                              double *obs, size_t obs_len, rwg_status_t *status);

    /* step(lane i, actions + i * action_len, action_len, obs + i * obs_len,
     * obs_len, &out_i) for every masked lane, out_i's fields going to
     * rewards[i], terminated[i] and truncated[i]; action_len and the
     * actions as for step_many. The host applies the time limit itself. */
    rwg_status_t (*vec_step)(rwg_vec_env_t *vec, const uint8_t *mask, const double *actions,
                             size_t action_len, double *obs, size_t obs_len, double *rewards,
                             uint8_t *terminated, uint8_t *truncated, rwg_status_t *status);

    /* Why lane `lane` failed in the most recent call on this vector env: a
     * NUL-terminated UTF-8 message, "" (or NULL) if it did not fail; lane n
     * (or more) gives the message of the call as a whole. Never fails. Valid
     * until the next call on this vector env (including vec_destroy). */
    const char *(*vec_last_error)(const rwg_vec_env_t *vec, size_t lane);
} rwg_env_vtable_t;

/* ------------------------------------------------------------------------- */
/* Host and plugin tables                                                    */
/* ------------------------------------------------------------------------- */

/* What the host tells the plugin in init. Owned by the host, valid until
 * deinit. Growable (struct_size): later minors may append host services. */
typedef struct rwg_host {
    uint32_t struct_size; /* sizeof(rwg_host_t) of the host's header */
    uint32_t abi_major;   /* the host's RWG_PLUGIN_ABI_MAJOR */
    uint32_t abi_minor;   /* the host's RWG_PLUGIN_ABI_MINOR */
    uint32_t reserved;    /* 0 */
    const char *name;     /* "rwg" */
    const char *version;  /* the host's version, e.g. "0.1.0" */
} rwg_host_t;

/* The plugin's table, returned by rwg_plugin_entry_v1. Owned by the plugin,
 * static: valid for as long as the library is loaded. Growable (struct_size). */
typedef struct rwg_plugin_entry {
    uint32_t struct_size; /* sizeof(rwg_plugin_entry_t) of the plugin's header */
    uint32_t abi_major;   /* RWG_PLUGIN_ABI_MAJOR the plugin was built with */
    uint32_t abi_minor;   /* RWG_PLUGIN_ABI_MINOR the plugin was built with */
    uint32_t reserved;    /* 0 */
    const char *abi_tag;  /* RWG_PLUGIN_ABI_TAG */
    /* The plugin's name, e.g. "classic_control" (non-empty). */
    const char *plugin_id;
    /* The plugin's version, free text, e.g. "0.1.0" (may be ""). */
    const char *plugin_version;

    /* Called once by the host after the handshake and before anything below.
     * May be NULL (nothing to do). On failure returns non-RWG_OK and writes a
     * message into err_buf (as for create); the host then refuses the plugin.
     * A library may be loaded more than once (init called again each time):
     * plugins count init/deinit pairs if they hold resources. */
    rwg_status_t (*init)(const rwg_host_t *host, char *err_buf, size_t err_len);
    /* Undoes one init. May be NULL. rwg never calls it (it never unloads
     * plugins), so plugins must not rely on it running. */
    void (*deinit)(void);

    /* The number of environments (>= 1). Thread-safe, after init. */
    uint32_t (*env_count)(void);
    /* The descriptor of environment i (0 <= i < env_count()), NULL if out of
     * range. Thread-safe, after init. */
    const rwg_env_desc_t *(*env_desc)(uint32_t index);
    /* The function table of environment i, NULL if out of range. Thread-safe,
     * after init. */
    const rwg_env_vtable_t *(*env_vtable)(uint32_t index);
    /* Optional interfaces by string id with a revision, e.g. "rwg.state/1";
     * NULL if unknown. None are defined in 1.0. May itself be NULL. */
    const void *(*get_extension)(const char *extension_id);
} rwg_plugin_entry_t;

/* ------------------------------------------------------------------------- */
/* The exported entry point                                                  */
/* ------------------------------------------------------------------------- */

#if defined(_WIN32) || defined(__CYGWIN__)
#define RWG_PLUGIN_EXPORT __declspec(dllexport)
#elif defined(__GNUC__) || defined(__clang__)
#define RWG_PLUGIN_EXPORT __attribute__((visibility("default")))
#else
#define RWG_PLUGIN_EXPORT
#endif

/* The one symbol a plugin exports. The host passes its own ABI version; the
 * plugin returns its static table, or NULL if it cannot serve that host (e.g.
 * a different major). Has no other effect: resources are acquired in init.
 * Thread-safe; may be called more than once and must return the same table. */
RWG_PLUGIN_EXPORT const rwg_plugin_entry_t *rwg_plugin_entry_v1(uint32_t host_abi_major,
                                                                uint32_t host_abi_minor);

typedef const rwg_plugin_entry_t *(*rwg_plugin_entry_fn)(uint32_t host_abi_major,
                                                         uint32_t host_abi_minor);

/* ------------------------------------------------------------------------- */
/* Layout checks (mirrored by const assertions in abi.rs)                    */
/* ------------------------------------------------------------------------- */

#ifdef __cplusplus
#define RWG_STATIC_ASSERT(cond, msg) static_assert(cond, msg)
#else
#define RWG_STATIC_ASSERT(cond, msg) _Static_assert(cond, msg)
#endif

/* P is the size of a pointer (data and function pointers alike). */
#define RWG_P_ sizeof(void *)
RWG_STATIC_ASSERT(sizeof(void (*)(void)) == sizeof(void *), "function pointers are data-pointer sized");
RWG_STATIC_ASSERT(sizeof(double) == 8, "double is IEEE binary64");

RWG_STATIC_ASSERT(offsetof(rwg_space_t, n) == 8, "rwg_space_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_space_t, low) == 16, "rwg_space_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_space_t, high) == 16 + RWG_P_, "rwg_space_t layout");
RWG_STATIC_ASSERT(sizeof(rwg_space_t) == 16 + 2 * RWG_P_, "rwg_space_t size");

#define RWG_S_ sizeof(rwg_space_t)
RWG_STATIC_ASSERT(offsetof(rwg_env_desc_t, flags) == 4, "rwg_env_desc_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_env_desc_t, id) == 8, "rwg_env_desc_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_env_desc_t, summary) == 8 + RWG_P_, "rwg_env_desc_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_env_desc_t, observation_space) == 8 + 2 * RWG_P_, "rwg_env_desc_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_env_desc_t, action_space) == 8 + 2 * RWG_P_ + RWG_S_, "rwg_env_desc_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_env_desc_t, max_episode_steps) == 8 + 2 * RWG_P_ + 2 * RWG_S_, "rwg_env_desc_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_env_desc_t, reward_threshold) == 16 + 2 * RWG_P_ + 2 * RWG_S_, "rwg_env_desc_t layout");
RWG_STATIC_ASSERT(sizeof(rwg_env_desc_t) == 24 + 2 * RWG_P_ + 2 * RWG_S_, "rwg_env_desc_t size");

RWG_STATIC_ASSERT(offsetof(rwg_step_out_t, terminated) == 8, "rwg_step_out_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_step_out_t, truncated) == 9, "rwg_step_out_t layout");
RWG_STATIC_ASSERT(sizeof(rwg_step_out_t) == 16, "rwg_step_out_t size");

RWG_STATIC_ASSERT(offsetof(rwg_env_vtable_t, create) == 8, "rwg_env_vtable_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_env_vtable_t, last_error) == 8 + 4 * RWG_P_, "rwg_env_vtable_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_env_vtable_t, reset_many) == 8 + 5 * RWG_P_, "rwg_env_vtable_t layout (1.1)");
RWG_STATIC_ASSERT(offsetof(rwg_env_vtable_t, step_many) == 8 + 6 * RWG_P_, "rwg_env_vtable_t layout (1.1)");
RWG_STATIC_ASSERT(offsetof(rwg_env_vtable_t, vec_create) == 8 + 7 * RWG_P_, "rwg_env_vtable_t layout (1.2)");
RWG_STATIC_ASSERT(offsetof(rwg_env_vtable_t, vec_last_error) == 8 + 11 * RWG_P_, "rwg_env_vtable_t layout (1.2)");
RWG_STATIC_ASSERT(sizeof(rwg_env_vtable_t) == 8 + 12 * RWG_P_, "rwg_env_vtable_t size (1.2; 1.0's ended at 8 + 5 * P, 1.1's at 8 + 7 * P)");

RWG_STATIC_ASSERT(offsetof(rwg_host_t, name) == 16, "rwg_host_t layout");
RWG_STATIC_ASSERT(sizeof(rwg_host_t) == 16 + 2 * RWG_P_, "rwg_host_t size");

RWG_STATIC_ASSERT(offsetof(rwg_plugin_entry_t, abi_tag) == 16, "rwg_plugin_entry_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_plugin_entry_t, init) == 16 + 3 * RWG_P_, "rwg_plugin_entry_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_plugin_entry_t, env_count) == 16 + 5 * RWG_P_, "rwg_plugin_entry_t layout");
RWG_STATIC_ASSERT(offsetof(rwg_plugin_entry_t, get_extension) == 16 + 8 * RWG_P_, "rwg_plugin_entry_t layout");
RWG_STATIC_ASSERT(sizeof(rwg_plugin_entry_t) == 16 + 9 * RWG_P_, "rwg_plugin_entry_t size");

#undef RWG_S_
#undef RWG_P_

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* RWG_PLUGIN_H */
