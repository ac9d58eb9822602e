/*
 * An LD_PRELOAD shim for the tests: file-system semantics of network and
 * FUSE mounts, in a process that asks for them.
 *
 *   RWG_TEST_DIR_FSYNC=EINVAL   fsync of a folder fails with EINVAL (a file
 *                               system that cannot sync folders: some FUSE
 *                               mounts, CIFS)
 *   RWG_TEST_RENAME_TO=SUFFIX   rename onto a path ending in SUFFIX fails
 *   RWG_TEST_RENAME_ERRNO=N     with errno N (default EXDEV, 18)
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static int ends_with(const char *path, const char *suffix) {
    size_t n = strlen(path), m = strlen(suffix);
    return n >= m && strcmp(path + n - m, suffix) == 0;
}

/* (built with -fvisibility=hidden: the interposed functions are exported) */
__attribute__((visibility("default"))) int rename(const char *from, const char *to) {
    const char *suffix = getenv("RWG_TEST_RENAME_TO");
    if (suffix != NULL && to != NULL && ends_with(to, suffix)) {
        const char *n = getenv("RWG_TEST_RENAME_ERRNO");
        errno = n != NULL ? atoi(n) : EXDEV;
        return -1;
    }
    int (*real)(const char *, const char *);
    *(void **)(&real) = dlsym(RTLD_NEXT, "rename");
    return real(from, to);
}

__attribute__((visibility("default"))) int fsync(int fd) {
    const char *dir = getenv("RWG_TEST_DIR_FSYNC");
    struct stat st;
    if (dir != NULL && strcmp(dir, "EINVAL") == 0 && fstat(fd, &st) == 0 && S_ISDIR(st.st_mode)) {
        errno = EINVAL;
        return -1;
    }
    int (*real)(int);
    *(void **)(&real) = dlsym(RTLD_NEXT, "fsync");
    return real(fd);
}
