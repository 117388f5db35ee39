/* Whole-file reads and atomic writes (temporary file, fsync, rename). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cn_buf.h"
#include "cn_file.h"

int cn_read_file(const char *path, uint8_t **data, size_t *len, char *err, size_t errlen)
{
    *data = NULL;
    *len = 0;
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
    else if (S_ISREG(st.st_mode) && (uint64_t)st.st_size > CN_READ_MAX)
        what = "is larger than the 4294967295 bytes that cnerf reads";
    if (what) {
        snprintf(err, errlen, "%s: %s", path, what);
        fclose(f);
        return -1;
    }
    /* A pipe or FIFO has no size: read up to the limit, and stop at the first failed
     * allocation. */
    cn_buf b = {0};
    uint8_t chunk[65536];
    size_t got;
    while (!b.oom && b.n <= CN_READ_MAX && (got = fread(chunk, 1, sizeof chunk, f)) > 0)
        cn_buf_put(&b, chunk, got);
    const int bad = ferror(f), big = b.n > CN_READ_MAX;
    fclose(f);
    if (bad || b.oom || big) {
        snprintf(err, errlen, "%s: %s", path,
                 bad ? "read error"
                 : big ? "is larger than the 4294967295 bytes that cnerf reads"
                       : "out of memory");
        cn_buf_free(&b);
        return -1;
    }
    *data = b.p;
    *len = b.n;
    return 0;
}

int cn_write_file_atomic(const char *path, const void *data, size_t len, char *err,
                         size_t errlen)
{
    size_t pl = strlen(path);
    char *tmp = malloc(pl + 16);
    if (!tmp) {
        snprintf(err, errlen, "%s: out of memory", path);
        return -1;
    }
    snprintf(tmp, pl + 16, "%s.tmp.%ld", path, (long)getpid());
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) {
        snprintf(err, errlen, "%s: cannot create: %s", tmp, strerror(errno));
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
        snprintf(err, errlen, "%s: cannot write: %s", path, strerror(e));
        unlink(tmp);
        free(tmp);
        return -1;
    }
    free(tmp);
    return 0;
}
