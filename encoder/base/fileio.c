/* Whole-file reads, and every file cnerf writes: the checks of an output, atomic writes
 * (temporary file, fsync, rename), directories, and the locks of long runs. No other file of
 * the encoder or the host program creates, renames or removes a file (tools/check_layers.py
 * keeps it so). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <dirent.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cn_buf.h"
#include "cn_file.h"

/* "PATH: N bytes, more than the MAX that KIND can need" (a pipe, read until it passed MAX:
 * "N bytes or more"). */
static void too_big(const char *path, uint64_t n, int exact, uint64_t max, const char *kind,
                    char *err, size_t errlen)
{
    if (kind)
        snprintf(err, errlen, "%s: %llu bytes%s, more than the %llu that %s can need", path,
                 (unsigned long long)n, exact ? "" : " or more", (unsigned long long)max, kind);
    else
        snprintf(err, errlen, "%s: is larger than the %llu bytes that cnerf reads", path,
                 (unsigned long long)max);
}

static int read_file(const char *path, uint64_t max, const char *kind, const char *sig,
                     size_t siglen, uint8_t **data, size_t *len, char *err, size_t errlen);

/* cn_files_discard: 1 when this process writes nothing to disk. What it writes is kept in
 * memory instead (the last bytes written to each path), and reading that path gives them
 * back, so that the process goes on as the one that writes does. */
static int discard;
static struct kept {
    char *path;
    uint8_t *data;
    size_t len;
} *kept;
static int n_kept;

void cn_files_discard(int on)
{
    discard = on;
    if (!on) {
        for (int i = 0; i < n_kept; i++) {
            free(kept[i].path);
            free(kept[i].data);
        }
        free(kept);
        kept = NULL;
        n_kept = 0;
    }
}

static struct kept *kept_find(const char *path)
{
    for (int i = 0; i < n_kept; i++)
        if (!strcmp(kept[i].path, path))
            return &kept[i];
    return NULL;
}

static int keep(const char *path, const void *data, size_t len, char *err, size_t errlen)
{
    struct kept *k = kept_find(path);
    if (!k) {
        struct kept *grown = realloc(kept, sizeof *kept * (size_t)(n_kept + 1));
        if (!grown)
            return cn_fail(err, errlen, "%s: out of memory", path);
        kept = grown;
        k = &kept[n_kept];
        *k = (struct kept){strdup(path), NULL, 0};
        if (!k->path)
            return cn_fail(err, errlen, "%s: out of memory", path);
        n_kept++;
    }
    uint8_t *copy = malloc(len ? len : 1);
    if (!copy)
        return cn_fail(err, errlen, "%s: out of memory", path);
    memcpy(copy, data, len);
    free(k->data);
    k->data = copy;
    k->len = len;
    return 0;
}

int cn_read_file(const char *path, uint8_t **data, size_t *len, char *err, size_t errlen)
{
    return read_file(path, CN_READ_MAX, NULL, NULL, 0, data, len, err, errlen);
}

int cn_read_file_max(const char *path, uint64_t max, const char *kind, uint8_t **data,
                     size_t *len, char *err, size_t errlen)
{
    return read_file(path, max, kind, NULL, 0, data, len, err, errlen);
}

int cn_read_file_sig(const char *path, const char *sig, size_t siglen, uint8_t **data,
                     size_t *len, char *err, size_t errlen)
{
    return read_file(path, CN_READ_MAX, NULL, sig, siglen, data, len, err, errlen);
}

static int read_file(const char *path, uint64_t max, const char *kind, const char *sig,
                     size_t siglen, uint8_t **data, size_t *len, char *err, size_t errlen)
{
    *data = NULL;
    *len = 0;
    const struct kept *k = discard ? kept_find(path) : NULL;
    if (k) {
        if (k->len > max) {
            too_big(path, k->len, 1, max, kind, err, errlen);
            return -1;
        }
        if (!(*data = malloc(k->len ? k->len : 1))) {
            snprintf(err, errlen, "%s: out of memory", path);
            return -1;
        }
        memcpy(*data, k->data, k->len);
        *len = k->len;
        return 0;
    }
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "%s: cannot open: %s", path, strerror(errno));
        return -1;
    }
    struct stat st;
    const char *what = NULL;
    if (fstat(fileno(f), &st) != 0)
        what = "cannot stat";
    else if (S_ISDIR(st.st_mode))
        what = "is a directory, not a file";
    else if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode))
        what = "is a device, not a regular file";
    if (what || (S_ISREG(st.st_mode) && (uint64_t)st.st_size > max)) {
        if (what)
            snprintf(err, errlen, "%s: %s", path, what);
        else
            too_big(path, (uint64_t)st.st_size, 1, max, kind, err, errlen);
        fclose(f);
        return -1;
    }
    /* A pipe or FIFO has no size: read up to the limit, and stop at the first failed
     * allocation. */
    cn_buf b = {0};
    uint8_t chunk[65536];
    size_t got;
    while (!b.oom && b.n <= max && (got = fread(chunk, 1, sizeof chunk, f)) > 0) {
        cn_buf_put(&b, chunk, got);
        /* a pipe that does not begin like the file it should hold: what was read is enough
         * for the parser to refuse it with its own message */
        if (sig && !S_ISREG(st.st_mode) && b.n >= siglen && memcmp(b.p, sig, siglen) != 0)
            break;
    }
    const int bad = ferror(f), big = b.n > max;
    fclose(f);
    if (bad || b.oom || big) {
        if (big)
            too_big(path, b.n, 0, max, kind, err, errlen);
        else
            snprintf(err, errlen, "%s: %s", path, bad ? "read error" : "out of memory");
        cn_buf_free(&b);
        return -1;
    }
    *data = b.p;
    *len = b.n;
    return 0;
}

/* ---- the files and folders a run reads ---- */

/* Process-wide: the command records its inputs before its work starts (and the loader each
 * file it reads), and its writes (on its main thread) check against them. */
typedef struct cn_input {
    dev_t dev;
    ino_t ino;
    int dir;
    char *real; /* a folder's real path (to tell what lies inside it); NULL for a file */
    char *name; /* as the user gave it */
    const char *role;
} cn_input;

static cn_input *cn_inputs;
static int cn_n_inputs, cn_cap_inputs;
/* The outputs cn_output_check passed, for cn_outputs_recheck once the inputs are all known. */
static char **cn_outputs;
static int cn_n_outputs, cn_cap_outputs;

static int grow(void **a, int *cap, int n, size_t elem)
{
    if (n < *cap)
        return 0;
    const int c = *cap ? 2 * *cap : 16;
    void *p = realloc(*a, (size_t)c * elem);
    if (!p)
        return -1;
    *a = p;
    *cap = c;
    return 0;
}

int cn_input_add(const char *path, const char *role)
{
    struct stat st;
    if (!path || stat(path, &st) != 0)
        return 0; /* not there: its reader says so */
    for (int i = 0; i < cn_n_inputs; i++)
        if (cn_inputs[i].dev == st.st_dev && cn_inputs[i].ino == st.st_ino)
            return 0;
    if (grow((void **)&cn_inputs, &cn_cap_inputs, cn_n_inputs, sizeof *cn_inputs))
        return -1;
    cn_input *in = &cn_inputs[cn_n_inputs];
    in->dev = st.st_dev;
    in->ino = st.st_ino;
    in->dir = S_ISDIR(st.st_mode);
    in->real = NULL;
    if (in->dir && !(in->real = realpath(path, NULL)))
        return 0;
    if (!(in->name = strdup(path))) {
        free(in->real);
        return -1;
    }
    in->role = role ? role : "the input";
    cn_n_inputs++;
    return 0;
}

void cn_inputs_clear(void)
{
    for (int i = 0; i < cn_n_inputs; i++) {
        free(cn_inputs[i].real);
        free(cn_inputs[i].name);
    }
    for (int i = 0; i < cn_n_outputs; i++)
        free(cn_outputs[i]);
    free(cn_inputs);
    free(cn_outputs);
    cn_inputs = NULL;
    cn_outputs = NULL;
    cn_n_inputs = cn_cap_inputs = cn_n_outputs = cn_cap_outputs = 0;
}

static const char *kind_of(mode_t m)
{
    return S_ISREG(m) ? "a regular file" : S_ISLNK(m) ? "a symbolic link"
         : S_ISDIR(m) ? "a directory" : S_ISCHR(m) || S_ISBLK(m) ? "a device"
         : S_ISFIFO(m) ? "a FIFO" : S_ISSOCK(m) ? "a socket" : "not a regular file";
}

/* The real path of `path`, or of the directory it would be created in; 0 when neither is
 * there. */
static int real_target(const char *path, char out[PATH_MAX])
{
    if (realpath(path, out))
        return 1;
    char parent[PATH_MAX];
    snprintf(parent, sizeof parent, "%s", path);
    char *slash = strrchr(parent, '/');
    if (!slash)
        snprintf(parent, sizeof parent, ".");
    else if (slash == parent)
        parent[1] = 0;
    else
        *slash = 0;
    return realpath(parent, out) != NULL;
}

static int inside(const char *real, const char *dir)
{
    const size_t n = strlen(dir);
    return !strncmp(real, dir, n) && (real[n] == 0 || real[n] == '/' || (n == 1 && dir[0] == '/'));
}

/* What `path` may not be: an input, or inside an input folder. */
static int not_an_input(const char *path, const struct stat *out, int exists, char *err,
                        size_t errlen)
{
    for (int i = 0; exists && i < cn_n_inputs; i++)
        if (cn_inputs[i].dev == out->st_dev && cn_inputs[i].ino == out->st_ino)
            return cn_fail(err, errlen, "%s is also %s %s: choose another output", path,
                           cn_inputs[i].role, cn_inputs[i].name);
    char real[PATH_MAX];
    if (!real_target(path, real))
        return 0;
    for (int i = 0; i < cn_n_inputs; i++)
        if (cn_inputs[i].dir && inside(real, cn_inputs[i].real))
            return cn_fail(err, errlen, "%s lies inside %s %s: write it elsewhere", path,
                           cn_inputs[i].role, cn_inputs[i].name);
    return 0;
}

/* What the file at `path` may be: absent or a regular file, not an input. */
static int may_replace(const char *path, char *err, size_t errlen)
{
    struct stat out;
    const int exists = lstat(path, &out) == 0;
    if (exists && !S_ISREG(out.st_mode))
        return cn_fail(err, errlen, "%s is %s; cnerf writes regular files only (it would "
                       "replace it): choose another output", path, kind_of(out.st_mode));
    return not_an_input(path, &out, exists, err, errlen);
}

static int output_record(const char *path)
{
    for (int i = 0; i < cn_n_outputs; i++)
        if (!strcmp(cn_outputs[i], path))
            return 0;
    if (grow((void **)&cn_outputs, &cn_cap_outputs, cn_n_outputs, sizeof *cn_outputs))
        return -1;
    if (!(cn_outputs[cn_n_outputs] = strdup(path)))
        return -1;
    cn_n_outputs++;
    return 0;
}

int cn_output_check(const char *path, char *err, size_t errlen)
{
    if (may_replace(path, err, errlen))
        return -1;
    if (output_record(path))
        return cn_fail(err, errlen, "%s: out of memory", path);
    if (discard)
        return 0;
    /* The writer's own temporary name, created and removed: the directory exists and takes
     * a new file. */
    char tmp[PATH_MAX + 32];
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid());
    const int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0)
        return cn_fail(err, errlen, "cannot write %s: %s", path, strerror(errno));
    close(fd);
    unlink(tmp);
    return 0;
}

int cn_outputs_recheck(char *err, size_t errlen)
{
    for (int i = 0; i < cn_n_outputs; i++)
        if (may_replace(cn_outputs[i], err, errlen))
            return -1;
    return 0;
}

int cn_output_dir_check(const char *dir, char *err, size_t errlen)
{
    struct stat st;
    const int exists = lstat(dir, &st) == 0;
    if (exists && S_ISLNK(st.st_mode) && stat(dir, &st) != 0)
        return cn_fail(err, errlen, "%s is a broken symbolic link, not a directory", dir);
    if (exists && !S_ISDIR(st.st_mode))
        return cn_fail(err, errlen, "%s is %s, not a directory", dir, kind_of(st.st_mode));
    return not_an_input(dir, &st, 0, err, errlen); /* itself an input folder: "inside" */
}

int cn_make_dir(const char *dir, char *err, size_t errlen)
{
    if (discard)
        return 0;
    if (cn_output_dir_check(dir, err, errlen))
        return -1;
    if (mkdir(dir, 0755) != 0 && errno != EEXIST)
        return cn_fail(err, errlen, "%s: cannot create directory: %s", dir, strerror(errno));
    return 0;
}

/* ---- atomic writes ---- */

int cn_write_file_atomic(const char *path, const void *data, size_t len, char *err,
                         size_t errlen)
{
    if (discard)
        return keep(path, data, len, err, errlen);
    if (may_replace(path, err, errlen)) /* the temporary's creation tests the directory */
        return -1;
    size_t pl = strlen(path);
    char *tmp = malloc(pl + 32);
    if (!tmp)
        return cn_fail(err, errlen, "%s: out of memory", path);
    snprintf(tmp, pl + 32, "%s.tmp.%ld", path, (long)getpid());
    int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0) {
        cn_fail(err, errlen, "cannot write %s: %s", path, strerror(errno));
        free(tmp);
        return -1;
    }
    const uint8_t *p = data;
    size_t left = len;
    while (left) {
        ssize_t w = write(fd, p, left);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            break;
        }
        p += w;
        left -= (size_t)w;
    }
    int e = left ? errno : 0;
    if (!e && fsync(fd) != 0)
        e = errno;
    if (close(fd) != 0 && !e)
        e = errno;
    if (!e && rename(tmp, path) != 0)
        e = errno;
    if (e) {
        cn_fail(err, errlen, "%s: cannot write: %s", path, strerror(e));
        unlink(tmp);
        free(tmp);
        return -1;
    }
    free(tmp);
    return 0;
}

/* ---- locks ---- */

/* Removes PATH.tmp.PID files of our naming whose process is gone (a run killed with kill -9
 * in the middle of a write), while the caller holds PATH.lock: no live run can be writing
 * them. A PID that is alive, or that we may not signal, keeps its file. */
static void sweep_stale(const char *path)
{
    char dir[PATH_MAX];
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    if (slash)
        snprintf(dir, sizeof dir, "%.*s", (int)(slash - path) + (slash == path), path);
    else
        snprintf(dir, sizeof dir, ".");
    DIR *d = opendir(dir);
    if (!d)
        return;
    const size_t bl = strlen(base);
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        const char *n = e->d_name;
        if (strncmp(n, base, bl) != 0 || strncmp(n + bl, ".tmp.", 5) != 0)
            continue;
        char *end;
        const long pid = strtol(n + bl + 5, &end, 10);
        if (*end || end == n + bl + 5 || pid <= 0 || pid == (long)getpid())
            continue;
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue;
        char full[PATH_MAX + NAME_MAX + 2];
        snprintf(full, sizeof full, "%s/%s", dir, n);
        struct stat st;
        if (lstat(full, &st) == 0 && S_ISREG(st.st_mode))
            unlink(full);
    }
    closedir(d);
}

int cn_lock(const char *path, char lock[], size_t locklen, int *busy, char *err, size_t errlen)
{
    snprintf(lock, locklen, "%s.lock", path);
    *busy = 0;
    if (discard)
        return INT_MAX; /* no lock: the writing process holds it */
    /* A run that ends removes the file while it holds it; a lock taken on that removed file
     * would guard nothing, so the lock must be on the file the name still points to. */
    for (int tries = 0; tries < 8; tries++) {
        const int fd = open(lock, O_WRONLY | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
        if (fd < 0)
            return cn_fail(err, errlen, "cannot create %s: %s", lock, strerror(errno));
        if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
            const int e = errno;
            close(fd);
            *busy = e == EWOULDBLOCK;
            return cn_fail(err, errlen, "cannot lock %s: %s", lock, strerror(e));
        }
        struct stat held, named;
        if (fstat(fd, &held) == 0 && stat(lock, &named) == 0 && held.st_dev == named.st_dev &&
            held.st_ino == named.st_ino) {
            sweep_stale(path);
            return fd;
        }
        close(fd); /* removed in between: take the new one */
    }
    return cn_fail(err, errlen, "cannot lock %s: it keeps being replaced", lock);
}

void cn_unlock(int fd, const char *lock)
{
    if (fd < 0 || discard)
        return;
    unlink(lock); /* while still held: no other run can have taken this file */
    close(fd);
}

void cn_lock_abandon(const char *lock)
{
    if (discard)
        return;
    char tmp[PATH_MAX + 32];
    const size_t n = strlen(lock);
    if (n > 5 && n - 5 < PATH_MAX) {
        snprintf(tmp, sizeof tmp, "%.*s.tmp.%ld", (int)(n - 5), lock, (long)getpid());
        unlink(tmp);
    }
    unlink(lock);
}
