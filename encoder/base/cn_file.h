/*
 * Whole files: read into memory with limits, written atomically. Host C11 (POSIX).
 */
#ifndef CNERF_ENC_FILE_H
#define CNERF_ENC_FILE_H

#include <stddef.h>
#include <stdint.h>

/* The largest file read whole: a stream's limit (its sizes are 32-bit). */
#define CN_READ_MAX 4294967295u

/* Reads a whole file; returns 0 or -1 with a message in err. *data is malloc'ed. Refuses a
 * directory, a device and anything larger than CN_READ_MAX (a pipe is read up to it), and
 * stops at the first failed allocation. */
int cn_read_file(const char *path, uint8_t **data, size_t *len, char *err, size_t errlen);
/* Writes a whole file atomically (temporary file, fsync, rename). */
int cn_write_file_atomic(const char *path, const void *data, size_t len, char *err,
                         size_t errlen);

#endif /* CNERF_ENC_FILE_H */
