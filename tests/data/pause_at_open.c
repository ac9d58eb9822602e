/*
 * An LD_PRELOAD shim for the tests: the first time the process opens a file
 * whose path ends in $RWG_TEST_PAUSE_AT, it creates the file
 * $RWG_TEST_PAUSED and waits (up to 60 s) until the file $RWG_TEST_GO
 * exists, then returns the open file. A test uses it to let another process
 * change a run directory at the one moment a reader is most exposed (after
 * it opened an index, before it read it and the files it lists).
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static int paused = 0;

static void pause_if_wanted(const char *path) {
    const char *at = getenv("RWG_TEST_PAUSE_AT");
    const char *signal_file = getenv("RWG_TEST_PAUSED");
    const char *go = getenv("RWG_TEST_GO");
    if (paused || at == NULL || signal_file == NULL || go == NULL || path == NULL) return;
    size_t n = strlen(path), m = strlen(at);
    if (n < m || strcmp(path + n - m, at) != 0) return;
    paused = 1;
    FILE *f = fopen(signal_file, "w");
    if (f != NULL) fclose(f);
    struct timespec tick = {0, 10 * 1000 * 1000};
    for (int i = 0; i < 6000 && access(go, F_OK) != 0; i++) nanosleep(&tick, NULL);
}

typedef int (*open_fn)(const char *, int, ...);

static int call_open(const char *name, const char *path, int flags, mode_t mode) {
    open_fn real;
    *(void **)(&real) = dlsym(RTLD_NEXT, name);
    int fd = real(path, flags, mode);
    if (fd >= 0) pause_if_wanted(path);
    return fd;
}

/* (built with -fvisibility=hidden: the interposed functions are exported) */
__attribute__((visibility("default"))) int open(const char *path, int flags, ...) {
    va_list ap;
    va_start(ap, flags);
    mode_t mode = (flags & (O_CREAT | O_TMPFILE)) ? (mode_t)va_arg(ap, int) : 0;
    va_end(ap);
    return call_open("open", path, flags, mode);
}

__attribute__((visibility("default"))) int open64(const char *path, int flags, ...) {
    va_list ap;
    va_start(ap, flags);
    mode_t mode = (flags & (O_CREAT | O_TMPFILE)) ? (mode_t)va_arg(ap, int) : 0;
    va_end(ap);
    return call_open("open64", path, flags, mode);
}
