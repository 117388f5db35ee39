/* Checks of the files a command will write, made before any work starts: a run must not
 * train for an hour and then find that it cannot write its result, nor replace its own input
 * or the dataset it reads. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"

static const char *kind_of(mode_t m)
{
    return S_ISREG(m) ? "a regular file" : S_ISLNK(m) ? "a symbolic link"
         : S_ISDIR(m) ? "a directory" : S_ISCHR(m) || S_ISBLK(m) ? "a device"
         : S_ISFIFO(m) ? "a FIFO" : S_ISSOCK(m) ? "a socket" : "not a regular file";
}

/* 1 when `path`, or the directory it would be created in, lies inside `dir` (or is it). */
static int inside_dir(const char *path, const char *dir)
{
    char d[PATH_MAX], p[PATH_MAX], parent[PATH_MAX];
    if (!realpath(dir, d))
        return 0;
    if (!realpath(path, p)) { /* not there yet: its directory */
        snprintf(parent, sizeof parent, "%s", path);
        char *slash = strrchr(parent, '/');
        if (!slash)
            snprintf(parent, sizeof parent, ".");
        else if (slash == parent)
            parent[1] = 0;
        else
            *slash = 0;
        if (!realpath(parent, p))
            return 0;
    }
    const size_t n = strlen(d);
    return !strncmp(p, d, n) && (p[n] == 0 || p[n] == '/' || (n == 1 && d[0] == '/'));
}

int cli_check_output(const char *cmd, const char *path, const char *const *inputs,
                     size_t n_inputs, const char *dataset)
{
    struct stat out;
    const int exists = lstat(path, &out) == 0;
    if (exists && !S_ISREG(out.st_mode))
        return cli_fail(cmd, "%s is %s; cnerf writes regular files only (it would replace "
                        "it): choose another output", path, kind_of(out.st_mode));
    for (size_t i = 0; exists && i < n_inputs; i++) {
        struct stat in;
        if (inputs[i] && stat(inputs[i], &in) == 0 && in.st_dev == out.st_dev &&
            in.st_ino == out.st_ino)
            return cli_fail(cmd, "%s is also the input %s: choose another output", path,
                            inputs[i]);
    }
    if (dataset && inside_dir(path, dataset))
        return cli_fail(cmd, "%s lies inside the dataset %s: write it elsewhere", path, dataset);
    /* The writer's own temporary name, created and removed: the directory exists and takes
     * a new file. */
    char tmp[PATH_MAX + 32];
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid());
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL, 0644);
    if (fd < 0)
        return cli_fail(cmd, "cannot write %s: %s", path, strerror(errno));
    close(fd);
    unlink(tmp);
    return 0;
}

int cli_check_output_dir(const char *cmd, const char *dir, const char *dataset)
{
    struct stat st;
    if (stat(dir, &st) == 0 && !S_ISDIR(st.st_mode))
        return cli_fail(cmd, "%s is %s, not a directory", dir, kind_of(st.st_mode));
    if (dataset && inside_dir(dir, dataset))
        return cli_fail(cmd, "%s lies inside the dataset %s: its images would be replaced; "
                        "write them elsewhere", dir, dataset);
    return 0;
}

int cli_lock_output(const char *cmd, const char *path, char lock[], size_t locklen)
{
    snprintf(lock, locklen, "%s.lock", path);
    /* A run that ends removes the file while it holds it; a lock taken on that removed file
     * would guard nothing, so the lock must be on the file the name still points to. */
    for (int tries = 0; tries < 8; tries++) {
        const int fd = open(lock, O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
        if (fd < 0) {
            cli_fail(cmd, "cannot create %s: %s", lock, strerror(errno));
            return -1;
        }
        if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
            const int e = errno;
            close(fd);
            if (e == EWOULDBLOCK)
                cli_fail(cmd, "%s is being written by another cnerf (it holds %s): wait for "
                         "it or choose another output", path, lock);
            else
                cli_fail(cmd, "cannot lock %s: %s", lock, strerror(e));
            return -1;
        }
        struct stat held, named;
        if (fstat(fd, &held) == 0 && stat(lock, &named) == 0 && held.st_dev == named.st_dev &&
            held.st_ino == named.st_ino)
            return fd;
        close(fd); /* removed in between: take the new one */
    }
    cli_fail(cmd, "cannot lock %s: it keeps being replaced", lock);
    return -1;
}

void cli_unlock_output(int fd, const char *lock)
{
    if (fd < 0)
        return;
    unlink(lock); /* while still held: no other run can have taken this file */
    close(fd);
}
