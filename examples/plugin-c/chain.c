/*
 * An rwg environment plugin in plain C, written against rwg_plugin.h alone.
 *
 * c_example/Chain-v0: walk right along a slippery chain of `length` cells.
 *   Observation (Box, 2 values in [0, 1]): the position as a fraction of the
 *     chain, and 1 if the last move slipped (went the other way), else 0.
 *   Actions (Discrete 2): 0 = left, 1 = right. Each move slips with
 *     probability 0.1.
 *   Reward: -0.01 per step, +1 on reaching the right end, which terminates
 *     the episode. Time limit 100 steps (applied by the host).
 *   Config: "" (length 10) or "length=N" with 2 <= N <= 1000.
 *
 * Build:  cc -std=c11 -O2 -shared -fPIC -fvisibility=hidden \
 *            -I../../rwg-env/include chain.c -o libchain.so
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rwg_plugin.h"

#define DEFAULT_LENGTH 10
#define MAX_LENGTH 1000
/* Slip probability 0.1 as a threshold on a 53-bit uniform integer. */
#define SLIP_THRESHOLD ((uint64_t)(0.1 * 9007199254740992.0))

/* The plugin defines the opaque instance type. */
struct rwg_env {
    int length;
    int pos;
    int started;    /* reset was called */
    int terminated; /* reached the end */
    uint64_t rng;   /* splitmix64 state: all randomness is per instance */
    char error[256];
};

static uint64_t splitmix64(uint64_t *state) {
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static void write_error(char *buf, size_t len, const char *msg) {
    if (buf != NULL && len > 0) {
        snprintf(buf, len, "%s", msg);
    }
}

static rwg_status_t fail(rwg_env_t *env, rwg_status_t status, const char *msg) {
    snprintf(env->error, sizeof env->error, "%s", msg);
    return status;
}

static void write_obs(const rwg_env_t *env, double *obs, int slipped) {
    obs[0] = (double)env->pos / (double)(env->length - 1);
    obs[1] = slipped ? 1.0 : 0.0;
}

/* ---- the function table ------------------------------------------------ */

static rwg_status_t chain_create(uint32_t env_index, const char *config, rwg_env_t **out_env,
                                 char *err_buf, size_t err_len) {
    long length = DEFAULT_LENGTH;
    if (env_index != 0 || out_env == NULL) {
        write_error(err_buf, err_len, "chain: bad env_index or out_env");
        return RWG_ERR_INVALID_ARGUMENT;
    }
    if (config != NULL && config[0] != '\0') {
        char *end = NULL;
        if (strncmp(config, "length=", 7) != 0) {
            write_error(err_buf, err_len, "chain: unknown config (expected \"length=N\")");
            return RWG_ERR_INVALID_ARGUMENT;
        }
        length = strtol(config + 7, &end, 10);
        if (end == config + 7 || *end != '\0' || length < 2 || length > MAX_LENGTH) {
            write_error(err_buf, err_len, "chain: length must be an integer in 2..1000");
            return RWG_ERR_INVALID_ARGUMENT;
        }
    }
    rwg_env_t *env = calloc(1, sizeof *env);
    if (env == NULL) {
        write_error(err_buf, err_len, "chain: out of memory");
        return RWG_ERR_INTERNAL;
    }
    env->length = (int)length;
    env->rng = 0x243f6a8885a308d3ull; /* the stream before the first seeded reset */
    *out_env = env;
    return RWG_OK;
}

static void chain_destroy(rwg_env_t *env) {
    free(env); /* free(NULL) does nothing */
}

static rwg_status_t chain_reset(rwg_env_t *env, uint8_t has_seed, uint64_t seed, double *obs,
                                size_t obs_len) {
    if (env == NULL) {
        return RWG_ERR_INVALID_ARGUMENT;
    }
    env->error[0] = '\0';
    if (has_seed > 1) {
        return fail(env, RWG_ERR_INVALID_ARGUMENT, "has_seed must be 0 or 1");
    }
    if (obs == NULL || obs_len != 2) {
        return fail(env, RWG_ERR_BUFFER_SIZE, "the observation has 2 values");
    }
    if (has_seed) {
        env->rng = seed;
    } else {
        env->rng = splitmix64(&env->rng); /* continue the instance's stream */
    }
    env->pos = 0;
    env->started = 1;
    env->terminated = 0;
    write_obs(env, obs, 0);
    return RWG_OK;
}

static rwg_status_t chain_step(rwg_env_t *env, const double *action, size_t action_len,
                               double *obs, size_t obs_len, rwg_step_out_t *out) {
    if (env == NULL) {
        return RWG_ERR_INVALID_ARGUMENT;
    }
    env->error[0] = '\0';
    if (!env->started) {
        return fail(env, RWG_ERR_RESET_NEEDED, "step before reset");
    }
    if (action == NULL || action_len != 1) {
        return fail(env, RWG_ERR_INVALID_ARGUMENT, "a Discrete(2) action has length 1");
    }
    /* Exactly 0.0 or 1.0; NaN, 0.5, -1 and 2 all fail this test. */
    if (!(action[0] == 0.0 || action[0] == 1.0)) {
        return fail(env, RWG_ERR_INVALID_ARGUMENT, "the action must be 0 (left) or 1 (right)");
    }
    if (obs == NULL || obs_len != 2) {
        return fail(env, RWG_ERR_BUFFER_SIZE, "the observation has 2 values");
    }
    if (out == NULL) {
        return fail(env, RWG_ERR_INVALID_ARGUMENT, "out is NULL");
    }
    if (env->terminated) { /* Gymnasium-style: stay at the end, reward 0 */
        write_obs(env, obs, 0);
        out->reward = 0.0;
        out->terminated = 1;
        out->truncated = 0;
        return RWG_OK;
    }
    int right = action[0] == 1.0;
    int slipped = (splitmix64(&env->rng) >> 11) < SLIP_THRESHOLD;
    if (slipped) {
        right = !right;
    }
    if (right) {
        env->pos += 1;
    } else if (env->pos > 0) {
        env->pos -= 1;
    }
    env->terminated = env->pos == env->length - 1;
    write_obs(env, obs, slipped);
    out->reward = env->terminated ? 1.0 : -0.01;
    out->terminated = (uint8_t)env->terminated;
    out->truncated = 0;
    return RWG_OK;
}

static const char *chain_last_error(const rwg_env_t *env) {
    return env != NULL ? env->error : "env is NULL";
}

/* ---- ABI 1.1: the batched calls ------------------------------------------
 * Optional. Compiled against a 1.0 header (RWG_PLUGIN_ABI_MINOR 0) this file
 * is a 1.0 plugin without them, and rwg uses the single calls. Each is the
 * single call on every masked lane in order, stopping at the first failure,
 * so the results are the single calls' bit for bit. */
#if RWG_PLUGIN_ABI_MINOR >= 1
static rwg_status_t chain_reset_many(rwg_env_t *const *envs, size_t n, const uint8_t *mask,
                                     const uint64_t *seeds, double *obs, size_t obs_len,
                                     size_t *failed) {
    if (n > 0 && (envs == NULL || seeds == NULL || obs == NULL)) {
        if (failed != NULL) {
            *failed = n; /* refused as a whole */
        }
        return RWG_ERR_INVALID_ARGUMENT;
    }
    for (size_t i = 0; i < n; i++) {
        if (mask != NULL && mask[i] != 1) {
            continue;
        }
        rwg_status_t s = chain_reset(envs[i], 1, seeds[i], obs + i * obs_len, obs_len);
        if (s != RWG_OK) {
            if (failed != NULL) {
                *failed = i;
            }
            return s;
        }
    }
    return RWG_OK;
}

static rwg_status_t chain_step_many(rwg_env_t *const *envs, size_t n, const uint8_t *mask,
                                    const double *actions, size_t action_len, double *obs,
                                    size_t obs_len, double *rewards, uint8_t *terminated,
                                    uint8_t *truncated, size_t *failed) {
    if (n > 0 && (envs == NULL || actions == NULL || obs == NULL || rewards == NULL ||
                  terminated == NULL || truncated == NULL)) {
        if (failed != NULL) {
            *failed = n; /* refused as a whole */
        }
        return RWG_ERR_INVALID_ARGUMENT;
    }
    for (size_t i = 0; i < n; i++) {
        if (mask != NULL && mask[i] != 1) {
            continue;
        }
        rwg_step_out_t out;
        rwg_status_t s = chain_step(envs[i], actions + i * action_len, action_len,
                                    obs + i * obs_len, obs_len, &out);
        if (s != RWG_OK) {
            if (failed != NULL) {
                *failed = i;
            }
            return s;
        }
        rewards[i] = out.reward;
        terminated[i] = out.terminated;
        truncated[i] = out.truncated;
    }
    return RWG_OK;
}
#endif

/* ---- ABI 1.2: the vector env ----------------------------------------------
 * Optional. Compiled against a 1.1 header or older this file has none, and
 * rwg uses the batched calls. Here a vector env's lanes are an array of
 * instances, each stepped by the single call's code, so the results are the
 * single calls' bit for bit; an env with heavier arithmetic would keep its
 * lanes' states as arrays and compute a step of all of them together (see
 * the reference plugin). Unlike the batched calls, a lane that fails does not
 * stop the others. */
#if RWG_PLUGIN_ABI_MINOR >= 2
struct rwg_vec_env {
    size_t lanes;
    rwg_env_t *envs; /* `lanes` instances */
    char error[256]; /* the message of a call refused as a whole */
};

static rwg_status_t chain_vec_create(uint32_t env_index, const char *config, size_t lanes,
                                     rwg_vec_env_t **out_vec, char *err_buf, size_t err_len) {
    if (out_vec == NULL || lanes == 0 || lanes > SIZE_MAX / sizeof(rwg_env_t)) {
        write_error(err_buf, err_len, "chain: out_vec is NULL or the lane count is 0 or too large");
        return RWG_ERR_INVALID_ARGUMENT;
    }
    rwg_env_t *first = NULL; /* create checks the config and sets the defaults */
    rwg_status_t s = chain_create(env_index, config, &first, err_buf, err_len);
    if (s != RWG_OK) {
        return s;
    }
    rwg_vec_env_t *vec = calloc(1, sizeof *vec);
    rwg_env_t *envs = malloc(lanes * sizeof *envs);
    if (vec == NULL || envs == NULL) {
        free(first), free(vec), free(envs);
        write_error(err_buf, err_len, "chain: out of memory");
        return RWG_ERR_INTERNAL;
    }
    for (size_t i = 0; i < lanes; i++) {
        envs[i] = *first;
    }
    free(first);
    vec->lanes = lanes;
    vec->envs = envs;
    *out_vec = vec;
    return RWG_OK;
}

static void chain_vec_destroy(rwg_vec_env_t *vec) {
    if (vec != NULL) {
        free(vec->envs);
        free(vec);
    }
}

/* A call refused as a whole: its status and message for every lane (and
 * the message as the call's, lane n). */
static rwg_status_t vec_refuse(rwg_vec_env_t *vec, rwg_status_t *status, rwg_status_t s,
                               const char *msg) {
    snprintf(vec->error, sizeof vec->error, "%s", msg);
    for (size_t i = 0; i < vec->lanes; i++) {
        snprintf(vec->envs[i].error, sizeof vec->envs[i].error, "%s", msg);
        if (status != NULL) {
            status[i] = s;
        }
    }
    return s;
}

/* Whether the mask is NULL or holds only 0 and 1. */
static int mask_ok(const rwg_vec_env_t *vec, const uint8_t *mask) {
    for (size_t i = 0; mask != NULL && i < vec->lanes; i++) {
        if (mask[i] > 1) {
            return 0;
        }
    }
    return 1;
}

/* Records lane i's status; the call's is the first lane's that failed. */
static void vec_lane_done(rwg_vec_env_t *vec, size_t i, rwg_status_t s, rwg_status_t *status,
                          rwg_status_t *first) {
    if (status != NULL) {
        status[i] = s;
    }
    if (*first == RWG_OK) {
        *first = s;
    }
    (void)vec;
}

static rwg_status_t chain_vec_reset(rwg_vec_env_t *vec, const uint8_t *mask,
                                    const uint64_t *seeds, double *obs, size_t obs_len,
                                    rwg_status_t *status) {
    if (vec == NULL) {
        return RWG_ERR_INVALID_ARGUMENT;
    }
    vec->error[0] = '\0';
    if (seeds == NULL || obs == NULL || !mask_ok(vec, mask)) {
        return vec_refuse(vec, status, RWG_ERR_INVALID_ARGUMENT,
                          "a NULL buffer or a mask value other than 0 or 1");
    }
    if (obs_len != 2) {
        return vec_refuse(vec, status, RWG_ERR_BUFFER_SIZE, "the observation has 2 values");
    }
    rwg_status_t first = RWG_OK;
    for (size_t i = 0; i < vec->lanes; i++) {
        rwg_status_t s = RWG_OK;
        if (mask == NULL || mask[i] == 1) {
            s = chain_reset(&vec->envs[i], 1, seeds[i], obs + i * obs_len, obs_len);
        } else {
            vec->envs[i].error[0] = '\0';
        }
        vec_lane_done(vec, i, s, status, &first);
    }
    return first;
}

static rwg_status_t chain_vec_step(rwg_vec_env_t *vec, const uint8_t *mask,
                                   const double *actions, size_t action_len, double *obs,
                                   size_t obs_len, double *rewards, uint8_t *terminated,
                                   uint8_t *truncated, rwg_status_t *status) {
    if (vec == NULL) {
        return RWG_ERR_INVALID_ARGUMENT;
    }
    vec->error[0] = '\0';
    if (actions == NULL || obs == NULL || rewards == NULL || terminated == NULL ||
        truncated == NULL || !mask_ok(vec, mask)) {
        return vec_refuse(vec, status, RWG_ERR_INVALID_ARGUMENT,
                          "a NULL buffer or a mask value other than 0 or 1");
    }
    if (action_len != 1) {
        return vec_refuse(vec, status, RWG_ERR_INVALID_ARGUMENT,
                          "a Discrete(2) action has length 1");
    }
    if (obs_len != 2) {
        return vec_refuse(vec, status, RWG_ERR_BUFFER_SIZE, "the observation has 2 values");
    }
    rwg_status_t first = RWG_OK;
    for (size_t i = 0; i < vec->lanes; i++) {
        rwg_status_t s = RWG_OK;
        if (mask == NULL || mask[i] == 1) {
            rwg_step_out_t out;
            s = chain_step(&vec->envs[i], actions + i, 1, obs + i * obs_len, obs_len, &out);
            if (s == RWG_OK) {
                rewards[i] = out.reward;
                terminated[i] = out.terminated;
                truncated[i] = out.truncated;
            }
        } else {
            vec->envs[i].error[0] = '\0';
        }
        vec_lane_done(vec, i, s, status, &first);
    }
    return first;
}

static const char *chain_vec_last_error(const rwg_vec_env_t *vec, size_t lane) {
    if (vec == NULL) {
        return "vec is NULL";
    }
    return lane < vec->lanes ? vec->envs[lane].error : vec->error;
}
#endif

/* ---- static tables ----------------------------------------------------- */

static const double OBS_LOW[2] = {0.0, 0.0};
static const double OBS_HIGH[2] = {1.0, 1.0};

/* The env id; tests compile this file under other ids with -DCHAIN_ID=... */
#ifndef CHAIN_ID
#define CHAIN_ID "c_example/Chain-v0"
#endif

static const rwg_env_desc_t CHAIN_DESC = {
    .struct_size = sizeof(rwg_env_desc_t),
    .flags = 0,
    .id = CHAIN_ID,
    .summary = "walk right along a slippery chain (C plugin example)",
    .observation_space = {.kind = RWG_SPACE_BOX, .n = 2, .low = OBS_LOW, .high = OBS_HIGH},
    .action_space = {.kind = RWG_SPACE_DISCRETE, .n = 2, .low = NULL, .high = NULL},
    .max_episode_steps = 100,
    .reward_threshold = 0.8,
};

static const rwg_env_vtable_t CHAIN_VTABLE = {
    .struct_size = sizeof(rwg_env_vtable_t),
    .create = chain_create,
    .destroy = chain_destroy,
    .reset = chain_reset,
    .step = chain_step,
    .last_error = chain_last_error,
#if RWG_PLUGIN_ABI_MINOR >= 1
    .reset_many = chain_reset_many,
    .step_many = chain_step_many,
#endif
#if RWG_PLUGIN_ABI_MINOR >= 2
    .vec_create = chain_vec_create,
    .vec_destroy = chain_vec_destroy,
    .vec_reset = chain_vec_reset,
    .vec_step = chain_vec_step,
    .vec_last_error = chain_vec_last_error,
#endif
};

static uint32_t env_count(void) { return 1; }

static const rwg_env_desc_t *env_desc(uint32_t index) {
    return index == 0 ? &CHAIN_DESC : NULL;
}

static const rwg_env_vtable_t *env_vtable(uint32_t index) {
    return index == 0 ? &CHAIN_VTABLE : NULL;
}

static const rwg_plugin_entry_t ENTRY = {
    .struct_size = sizeof(rwg_plugin_entry_t),
    .abi_major = RWG_PLUGIN_ABI_MAJOR,
    .abi_minor = RWG_PLUGIN_ABI_MINOR,
    .abi_tag = RWG_PLUGIN_ABI_TAG,
    .plugin_id = "c_example",
    .plugin_version = "1.0.0",
    .init = NULL,   /* nothing to set up */
    .deinit = NULL,
    .env_count = env_count,
    .env_desc = env_desc,
    .env_vtable = env_vtable,
    .get_extension = NULL,
};

RWG_PLUGIN_EXPORT const rwg_plugin_entry_t *rwg_plugin_entry_v1(uint32_t host_abi_major,
                                                                uint32_t host_abi_minor) {
    (void)host_abi_minor;
    return host_abi_major == RWG_PLUGIN_ABI_MAJOR ? &ENTRY : NULL;
}
