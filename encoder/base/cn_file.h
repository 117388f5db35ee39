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
/* The same with a limit of the file's kind: more than max bytes (a regular file by its size,
 * a pipe as it is read) is refused with "PATH: N bytes, more than the MAX that KIND can need". */
int cn_read_file_max(const char *path, uint64_t max, const char *kind, uint8_t **data,
                     size_t *len, char *err, size_t errlen);
/* cn_read_file for a kind of file that begins with sig[0..siglen): a pipe whose first bytes
 * differ is read no further than its first block (64 KiB), which the caller's parser then
 * refuses, instead of up to CN_READ_MAX. A regular file is read whole as before. */
int cn_read_file_sig(const char *path, const char *sig, size_t siglen, uint8_t **data,
                     size_t *len, char *err, size_t errlen);

/* ---- every file cnerf writes goes through these (tools/check_layers.py) ---- */

/* The inputs of this run (files and folders), recorded before its work starts and, by the
 * dataset loader, each file it reads: no output may be one of them or lie inside one of the
 * folders. `role` (a string that outlives the run) names it in messages ("the dataset";
 * NULL: "the input"). A path that does not exist is skipped. Returns -1 when out of memory.
 * Process-wide, for one command's run; not thread-safe (call it from one thread). */
int cn_input_add(const char *path, const char *role);
/* Forgets the inputs and the checked outputs (and frees them). */
void cn_inputs_clear(void);
/* From on = 1, this process writes nothing to disk: cn_write_file_atomic keeps the bytes in
 * memory (the last written to each path), where cn_read_file* finds them again; cn_make_dir
 * makes nothing and cn_lock takes no lock (its descriptor is not a file's). The checks still
 * read the disk. For the ranks of a shared training other than the one that writes, which
 * then go through a command exactly as it does. on = 0 frees what was kept. */
void cn_files_discard(int on);
/* `path` can be written: it is absent or a regular file (not a link, device, FIFO or
 * directory), not an input nor inside an input folder, and its directory takes a new file.
 * Returns 0, or -1 with a message naming `path`. */
int cn_output_check(const char *path, char *err, size_t errlen);
/* Checks again every output that cn_output_check passed, against the inputs recorded since:
 * a command calls it once its dataset is loaded, so that an output that is a hard link to one
 * of the images is refused before the work starts, not when the result is written. */
int cn_outputs_recheck(char *err, size_t errlen);
/* The same for an output directory, existing or to be made: a directory if it exists, not an
 * input, not inside one. */
int cn_output_dir_check(const char *dir, char *err, size_t errlen);
/* Makes an output directory after cn_output_dir_check (an existing one is fine). */
int cn_make_dir(const char *dir, char *err, size_t errlen);
/* Writes a whole file atomically (temporary file, fsync, rename), with cn_output_check's
 * checks. */
int cn_write_file_atomic(const char *path, const void *data, size_t len, char *err,
                         size_t errlen);
/* An exclusive lock on PATH.lock (written into lock[]) for a run that writes PATH, so that two
 * runs never write one output; the kernel drops it when the process dies. Holding it, removes
 * the PATH.tmp.PID files that runs killed in the middle of a write left (their PID gone).
 * Returns the descriptor for cn_unlock, or -1 with a message (*busy = 1: another process
 * holds it). flock is not reliable on some network file systems (older NFS, some SMB
 * mounts): two runs there may not see each other's lock. */
int cn_lock(const char *path, char lock[], size_t locklen, int *busy, char *err, size_t errlen);
/* Removes PATH.lock while still holding it, then releases it. */
void cn_unlock(int fd, const char *lock);
/* For a run that a signal stops while it holds PATH.lock: removes PATH.lock and this
 * process's unfinished PATH.tmp.PID. No allocation; safe from any thread (the process exits
 * next, and the kernel drops the lock). */
void cn_lock_abandon(const char *lock);

#endif /* CNERF_ENC_FILE_H */
