/*
 * A valid C plugin ("hostile/Counter-v0": obs = steps taken, reward 1,
 * Discrete(2), 20 steps) that does, when compiled with one of these defines,
 * something a plugin may do to the process it runs in:
 *
 *   SPAWN_DAEMONS      the first create of each process forks a helper that
 *                      calls setsid, and the helper a daemon that calls
 *                      setsid again (out of reach of process groups); both
 *                      write their pid as a file name into the folder
 *                      $HOSTILE_PIDS and sleep for ever
 *   IGNORE_SIGNALS     init sets SIGINT, SIGTERM and SIGHUP to SIG_IGN
 *   IGNORE_IN_STEP     every step sets SIGINT, SIGTERM and SIGHUP to SIG_IGN
 *   ALARM_IN_CREATE    create calls alarm(1) (SIGALRM one second later)
 *   ABORT_AT_EXIT      init registers an exit handler that calls abort()
 *   ESCAPES_IN_ERROR   reset fails with an error text holding terminal
 *                      escape sequences (colour, window title, bell)
 *   CLOSE_STDERR       the first create of each process closes file
 *                      descriptors 1 and 2, and every step then writes a
 *                      line to fd 1 (wherever it points by then)
 *   ORPHAN_PER_RESET   the first 50 resets of the process each double-fork
 *                      a process that exits at once (an orphan,
 *                      re-parented, that dies: a zombie until someone
 *                      reaps it)
 *   FORK_HELPER        the first create of each process forks a helper that
 *                      stays in rwg's process group and sleeps (it gets the
 *                      terminal's Ctrl-C too)
 *   NULL_STDERR        create points file descriptors 1 and 2 at /dev/null
 *   IGNORE_SIGCHLD     init sets SIGCHLD to SIG_IGN (children reaped by the
 *                      kernel: no one can wait for them)
 *   THREAD_EXIT        init starts a thread that calls exit(3) a second later
 *   SLEEP_IN_STEP_MS=N every step sleeps N ms (a run that lasts)
 *   BUSY_IN_STEP_MS=N  every step computes for N ms of CPU time
 *
 * The tests in tests/cli_plugin_procs.rs compile each variant with cc.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "rwg_plugin.h"

struct rwg_env {
    int started;
    int t;
};

#ifdef SPAWN_DAEMONS
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/types.h>

/* Writes this process's pid as an empty file in $HOSTILE_PIDS. */
static void record_pid(void) {
    const char *dir = getenv("HOSTILE_PIDS");
    char path[4096];
    if (dir == NULL) return;
    snprintf(path, sizeof path, "%s/%ld", dir, (long)getpid());
    int fd = open(path, O_CREAT | O_WRONLY, 0644);
    if (fd >= 0) close(fd);
}

static void sleep_for_ever(void) {
    for (;;) pause();
}

static int spawned = 0;

static void spawn_daemons(void) {
    if (spawned) return;
    spawned = 1;
    pid_t helper = fork();
    if (helper == 0) {
        setsid();
        if (fork() == 0) {
            setsid();
            record_pid();
            sleep_for_ever();
        }
        record_pid();
        sleep_for_ever();
    }
}
#endif

#ifdef ORPHAN_PER_RESET
#include <sys/types.h>
#include <sys/wait.h>

static int orphans = 0;

static void orphan(void) {
    if (orphans++ >= 50) return;
    pid_t middle = fork();
    if (middle == 0) {
        if (fork() == 0) _exit(0);
        _exit(0);
    }
    if (middle > 0) waitpid(middle, NULL, 0);
}
#endif

#if defined(IGNORE_SIGNALS) || defined(IGNORE_IN_STEP)
static void ignore_signals(void) {
    signal(SIGINT, SIG_IGN);
    signal(SIGTERM, SIG_IGN);
    signal(SIGHUP, SIG_IGN);
}
#endif

#ifdef ABORT_AT_EXIT
static void abort_at_exit(void) { abort(); }
#endif

#ifdef FORK_HELPER
static int helped = 0;
#endif

#ifdef CLOSE_STDERR
static int closed_std = 0;
#endif

#ifdef NULL_STDERR
#include <fcntl.h>
#endif

#ifdef THREAD_EXIT
#include <pthread.h>
static void *exit_later(void *arg) {
    (void)arg;
    struct timespec ts = {1, 0};
    nanosleep(&ts, NULL);
    exit(3);
}
#endif

static rwg_status_t create(uint32_t i, const char *config, rwg_env_t **out, char *err,
                           size_t err_len) {
    (void)i;
    (void)config;
    (void)err;
    (void)err_len;
#ifdef SPAWN_DAEMONS
    spawn_daemons();
#endif
#ifdef ALARM_IN_CREATE
    alarm(1);
#endif
#ifdef CLOSE_STDERR
    if (!closed_std) {
        closed_std = 1;
        close(1);
        close(2);
    }
#endif
#ifdef NULL_STDERR
    int null = open("/dev/null", O_WRONLY);
    dup2(null, 1);
    dup2(null, 2);
    close(null);
#endif
#ifdef FORK_HELPER
    if (!helped) {
        helped = 1;
        if (fork() == 0)
            for (;;) pause();
    }
#endif
    *out = calloc(1, sizeof **out);
    return *out ? RWG_OK : RWG_ERR_INTERNAL;
}

static void destroy(rwg_env_t *env) { free(env); }

static rwg_status_t reset(rwg_env_t *env, uint8_t has_seed, uint64_t seed, double *obs,
                          size_t obs_len) {
    (void)has_seed;
    (void)seed;
    if (obs_len != 1) return RWG_ERR_BUFFER_SIZE;
#ifdef ESCAPES_IN_ERROR
    (void)env;
    (void)obs;
    return RWG_ERR_INTERNAL;
#else
#ifdef ORPHAN_PER_RESET
    orphan();
#endif
    env->started = 1;
    env->t = 0;
    obs[0] = 0.0;
    return RWG_OK;
#endif
}

static rwg_status_t step(rwg_env_t *env, const double *action, size_t action_len, double *obs,
                         size_t obs_len, rwg_step_out_t *out) {
    if (!env->started) return RWG_ERR_RESET_NEEDED;
    if (action_len != 1 || !(action[0] == 0.0 || action[0] == 1.0)) return RWG_ERR_INVALID_ARGUMENT;
    if (obs_len != 1) return RWG_ERR_BUFFER_SIZE;
#ifdef IGNORE_IN_STEP
    ignore_signals();
#endif
#ifdef CLOSE_STDERR
    static const char line[] = "hostile: a line written to fd 1\n";
    if (write(1, line, sizeof line - 1) < 0) {
    }
#endif
#ifdef BUSY_IN_STEP_MS
    clock_t until = clock() + (clock_t)BUSY_IN_STEP_MS * CLOCKS_PER_SEC / 1000;
    while (clock() < until) {
    }
#endif
#ifdef SLEEP_IN_STEP_MS
    struct timespec ts = {SLEEP_IN_STEP_MS / 1000, (SLEEP_IN_STEP_MS % 1000) * 1000000L};
    nanosleep(&ts, NULL);
#endif
    env->t += 1;
    obs[0] = (double)env->t;
    out->reward = 1.0;
    out->terminated = 0;
    out->truncated = 0;
    return RWG_OK;
}

static const char *last_error(const rwg_env_t *env) {
    (void)env;
#ifdef ESCAPES_IN_ERROR
    return "\x1b[31mred\x1b[0m \x1b]0;a new window title\x07 \x1b[2J cleared";
#else
    return "";
#endif
}

static const double LOW[1] = {0.0};
static const double HIGH[1] = {100.0};

static const rwg_env_desc_t DESC = {
    .struct_size = sizeof(rwg_env_desc_t),
    .id = "hostile/Counter-v0",
    .summary = "a valid env whose plugin does something hostile to its process",
    .observation_space = {.kind = RWG_SPACE_BOX, .n = 1, .low = LOW, .high = HIGH},
    .action_space = {.kind = RWG_SPACE_DISCRETE, .n = 2},
    .max_episode_steps = 20,
    .reward_threshold = NAN,
};

static const rwg_env_vtable_t VTABLE = {
    .struct_size = sizeof(rwg_env_vtable_t),
    .create = create,
    .destroy = destroy,
    .reset = reset,
    .step = step,
    .last_error = last_error,
};

static uint32_t env_count(void) { return 1; }

static const rwg_env_desc_t *env_desc(uint32_t i) { return i == 0 ? &DESC : NULL; }

static const rwg_env_vtable_t *env_vtable(uint32_t i) { return i == 0 ? &VTABLE : NULL; }

static rwg_status_t init(const rwg_host_t *host, char *err_buf, size_t err_len) {
    (void)err_buf;
    (void)err_len;
    if (host == NULL || host->struct_size < sizeof(rwg_host_t) || host->abi_major != 1) {
        return RWG_ERR_INVALID_ARGUMENT;
    }
#ifdef IGNORE_SIGNALS
    ignore_signals();
#endif
#ifdef ABORT_AT_EXIT
    atexit(abort_at_exit);
#endif
#ifdef IGNORE_SIGCHLD
    signal(SIGCHLD, SIG_IGN);
#endif
#ifdef THREAD_EXIT
    pthread_t t;
    pthread_create(&t, NULL, exit_later, NULL);
#endif
    return RWG_OK;
}

static const rwg_plugin_entry_t ENTRY = {
    .struct_size = sizeof(rwg_plugin_entry_t),
    .abi_major = RWG_PLUGIN_ABI_MAJOR,
    .abi_minor = RWG_PLUGIN_ABI_MINOR,
    .abi_tag = RWG_PLUGIN_ABI_TAG,
    .plugin_id = "hostile",
    .plugin_version = "0",
    .init = init,
    .env_count = env_count,
    .env_desc = env_desc,
    .env_vtable = env_vtable,
};

RWG_PLUGIN_EXPORT const rwg_plugin_entry_t *rwg_plugin_entry_v1(uint32_t major, uint32_t minor) {
    (void)major;
    (void)minor;
    return &ENTRY;
}
