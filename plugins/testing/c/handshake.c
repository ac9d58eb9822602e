/*
 * A minimal valid C plugin ("handshake/Ok-v0") whose handshake or descriptor
 * is broken in one way when compiled with one of these defines:
 *
 *   BROKEN_NO_ENTRY      exports no rwg_plugin_entry_v1
 *   BROKEN_NULL_ENTRY    the entry returns NULL
 *   BROKEN_WRONG_MAJOR   abi_major = 2 (a plugin built for a future ABI)
 *   BROKEN_SMALL_ENTRY   struct_size smaller than ABI 1.0's entry
 *   BROKEN_BAD_TAG       abi_tag is not "rwg-env-plugin"
 *   BROKEN_INIT_FAILS    init returns RWG_ERR_INTERNAL with a message
 *   BROKEN_NO_ENVS       env_count() returns 0
 *   BROKEN_EMPTY_ID      the env id is ""
 *   BROKEN_BAD_UTF8_ID   the env id is not UTF-8
 *   BROKEN_DUP_IDS       two envs with the same id
 *   BROKEN_LOW_GT_HIGH   observation low > high
 *   BROKEN_NULL_STEP     the vtable's step is NULL
 *   BROKEN_HALF_BATCH    step_many is set but reset_many is NULL (ABI 1.1
 *                        wants both or neither)
 *
 * ENV_ID (e.g. -DENV_ID='"CartPole-v0"') replaces the id "handshake/Ok-v0".
 * NO_TIME_LIMIT sets max_episode_steps = 0 (none; a valid plugin).
 * THRESHOLD_LEFT_AT_ZERO sets reward_threshold = 0.0 (legal, but "solved at
 * 0", usually a field left unset: rwg check warns).
 * PRINTF_IN_STEP makes step printf a line to stdout (a valid plugin that
 * talks: its output must never reach rwg's own stdout).
 * HANG_IN_CREATE_AFTER=N makes every create after the process's N-th
 * sleep for ever (a create that hangs, for the timeouts of isolation).
 * CHDIR_IN_CREATE (e.g. -DCHDIR_IN_CREATE='"/"') makes create change the
 * process's working directory (a plugin that finds its data files so):
 * nothing rwg writes may follow it.
 *
 * The tests in ../tests/c_plugins.rs compile each variant with cc.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "rwg_plugin.h"

#if defined(HANG_IN_CREATE_AFTER) || defined(CHDIR_IN_CREATE)
#include <unistd.h>
#endif
#ifdef HANG_IN_CREATE_AFTER
static int creates_so_far = 0;
#endif

struct rwg_env {
    int started;
};

static rwg_status_t create(uint32_t i, const char *config, rwg_env_t **out, char *err,
                           size_t err_len) {
    (void)i;
    (void)config;
    (void)err;
    (void)err_len;
#ifdef HANG_IN_CREATE_AFTER
    if (++creates_so_far > HANG_IN_CREATE_AFTER)
        for (;;) pause();
#endif
#ifdef CHDIR_IN_CREATE
    if (chdir(CHDIR_IN_CREATE) != 0) return RWG_ERR_INTERNAL;
#endif
    *out = calloc(1, sizeof **out);
    return *out ? RWG_OK : RWG_ERR_INTERNAL;
}

static void destroy(rwg_env_t *env) { free(env); }

static rwg_status_t reset(rwg_env_t *env, uint8_t has_seed, uint64_t seed, double *obs,
                          size_t obs_len) {
    (void)has_seed;
    if (obs_len != 1) return RWG_ERR_BUFFER_SIZE;
    env->started = 1;
    obs[0] = (double)(seed % 5);
    return RWG_OK;
}

static rwg_status_t step(rwg_env_t *env, const double *action, size_t action_len, double *obs,
                         size_t obs_len, rwg_step_out_t *out) {
    if (!env->started) return RWG_ERR_RESET_NEEDED;
    if (action_len != 1 || !(action[0] == 0.0 || action[0] == 1.0)) return RWG_ERR_INVALID_ARGUMENT;
    if (obs_len != 1) return RWG_ERR_BUFFER_SIZE;
#ifdef PRINTF_IN_STEP
    printf("handshake plugin: step with action %g\n", action[0]);
#endif
    obs[0] = action[0];
    out->reward = 1.0;
    out->terminated = 0;
    out->truncated = 0;
    return RWG_OK;
}

static const char *last_error(const rwg_env_t *env) {
    (void)env;
    return "";
}

#ifdef BROKEN_LOW_GT_HIGH
static const double LOW[1] = {1.0};
static const double HIGH[1] = {0.0};
#else
static const double LOW[1] = {0.0};
static const double HIGH[1] = {10.0};
#endif

#if defined(BROKEN_EMPTY_ID)
#define ENV_ID ""
#elif defined(BROKEN_BAD_UTF8_ID)
#define ENV_ID "handshake/\xff-v0"
#elif !defined(ENV_ID)
#define ENV_ID "handshake/Ok-v0"
#endif

static const rwg_env_desc_t DESC = {
    .struct_size = sizeof(rwg_env_desc_t),
    .id = ENV_ID,
    .summary = "a valid minimal env",
    .observation_space = {.kind = RWG_SPACE_BOX, .n = 1, .low = LOW, .high = HIGH},
    .action_space = {.kind = RWG_SPACE_DISCRETE, .n = 2},
#ifdef NO_TIME_LIMIT
    .max_episode_steps = 0,
#else
    .max_episode_steps = 5,
#endif
#ifdef THRESHOLD_LEFT_AT_ZERO
    /* the trap: a field left at its zero initialiser means "solved at 0" */
    .reward_threshold = 0.0,
#else
    .reward_threshold = NAN,
#endif
};

#ifdef BROKEN_HALF_BATCH
static rwg_status_t half_step_many(rwg_env_t *const *envs, size_t n, const uint8_t *mask,
                                   const double *actions, size_t action_len, double *obs,
                                   size_t obs_len, double *rewards, uint8_t *terminated,
                                   uint8_t *truncated, size_t *failed) {
    (void)envs, (void)mask, (void)actions, (void)action_len, (void)obs, (void)obs_len;
    (void)rewards, (void)terminated, (void)truncated;
    if (failed != NULL) {
        *failed = n;
    }
    return RWG_ERR_INTERNAL;
}
#endif

#ifdef BROKEN_PARTIAL_VEC
static void partial_vec_destroy(rwg_vec_env_t *vec) { (void)vec; }
#endif

static const rwg_env_vtable_t VTABLE = {
    .struct_size = sizeof(rwg_env_vtable_t),
    .create = create,
    .destroy = destroy,
    .reset = reset,
#ifndef BROKEN_NULL_STEP
    .step = step,
#endif
    .last_error = last_error,
#ifdef BROKEN_HALF_BATCH
    .step_many = half_step_many,
#endif
#ifdef BROKEN_PARTIAL_VEC
    .vec_destroy = partial_vec_destroy,
#endif
};

#ifdef BROKEN_NULL_STEP
/* Keep step referenced so -Werror=unused-function stays quiet. */
rwg_status_t (*const handshake_unused_step)(rwg_env_t *, const double *, size_t, double *, size_t,
                                            rwg_step_out_t *) = step;
#endif

static uint32_t env_count(void) {
#if defined(BROKEN_NO_ENVS)
    return 0;
#elif defined(BROKEN_DUP_IDS)
    return 2;
#else
    return 1;
#endif
}

static const rwg_env_desc_t *env_desc(uint32_t i) { return i < env_count() ? &DESC : NULL; }

static const rwg_env_vtable_t *env_vtable(uint32_t i) { return i < env_count() ? &VTABLE : NULL; }

static rwg_status_t init(const rwg_host_t *host, char *err_buf, size_t err_len) {
    if (host == NULL || host->struct_size < sizeof(rwg_host_t) || host->abi_major != 1) {
        return RWG_ERR_INVALID_ARGUMENT;
    }
#ifdef BROKEN_INIT_FAILS
    snprintf(err_buf, err_len, "the simulator licence has expired");
    return RWG_ERR_INTERNAL;
#else
    (void)err_buf;
    (void)err_len;
    return RWG_OK;
#endif
}

static const rwg_plugin_entry_t ENTRY = {
#ifdef BROKEN_SMALL_ENTRY
    .struct_size = 24,
#else
    .struct_size = sizeof(rwg_plugin_entry_t),
#endif
#ifdef BROKEN_WRONG_MAJOR
    .abi_major = 2,
#else
    .abi_major = RWG_PLUGIN_ABI_MAJOR,
#endif
    .abi_minor = RWG_PLUGIN_ABI_MINOR,
#ifdef BROKEN_BAD_TAG
    .abi_tag = "some-other-plugin-system",
#else
    .abi_tag = RWG_PLUGIN_ABI_TAG,
#endif
    .plugin_id = "handshake",
    .plugin_version = "0",
    .init = init,
    .env_count = env_count,
    .env_desc = env_desc,
    .env_vtable = env_vtable,
};

#ifndef BROKEN_NO_ENTRY
RWG_PLUGIN_EXPORT const rwg_plugin_entry_t *rwg_plugin_entry_v1(uint32_t major, uint32_t minor) {
    (void)major;
    (void)minor;
#ifdef BROKEN_NULL_ENTRY
    return major == 12345 ? &ENTRY : NULL; /* never serves a real host */
#else
    return &ENTRY;
#endif
}
#else
/* Something else is exported, so this is a valid library. */
RWG_PLUGIN_EXPORT const void *not_an_rwg_plugin(void) { return &ENTRY; }
#endif
