/* Checks of the files a command will write, made before any work starts: a run must not
 * train for an hour and then find that it cannot write its result, nor replace its own input
 * or the dataset it reads. The checks themselves are the write module's (encoder/base/cn_file.h),
 * which every write goes through again. */
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"
#include "cn_ckpt.h"
#include "cn_file.h"
#include "cn_reader.h"

int cli_check_output(const char *cmd, const char *path, const char *const *inputs,
                     size_t n_inputs, const char *dataset)
{
    char err[8400];
    for (size_t i = 0; i < n_inputs; i++)
        if (cn_input_add(inputs[i], NULL))
            return cli_fail(cmd, "out of memory recording the inputs");
    if (cn_input_add(dataset, "the dataset"))
        return cli_fail(cmd, "out of memory recording the inputs");
    if (cn_output_check(path, err, sizeof err))
        return cli_fail(cmd, "%s", err);
    return 0;
}

int cli_check_not(const char *cmd, const char *path, const char *input)
{
    struct stat a, b;
    if (input && stat(path, &a) == 0 && stat(input, &b) == 0 && a.st_dev == b.st_dev &&
        a.st_ino == b.st_ino)
        return cli_fail(cmd, "%s is also the input %s: choose another output", path, input);
    return 0;
}

int cli_check_fresh(const char *cmd, const char *ckpt, const char *resume)
{
    struct stat st;
    if (lstat(ckpt, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size == 0)
        return 0; /* nothing to lose (what is not a regular file, cli_check_output refuses) */
    /* "CNCK", u32 version, u64 step; "CNJT", u32 version, u32 scenes, u64 step */
    uint8_t h[24] = {0};
    size_t n = 0;
    FILE *f = fopen(ckpt, "rb");
    if (f) {
        n = fread(h, 1, sizeof h, f);
        fclose(f);
    }
    const char *tail = "continues it, --force starts over in its place";
    if (n >= 16 && memcmp(h, CN_CKPT_MAGIC, 4) == 0)
        return cli_fail(cmd, "%s is a checkpoint at iteration %llu: %s %s", ckpt,
                        (unsigned long long)cn_le64(h + 8), resume, tail);
    if (n >= 24 && memcmp(h, CN_CKPT_JOINT_MAGIC, 4) == 0)
        return cli_fail(cmd, "%s is a checkpoint of %u scenes at iteration %llu: %s %s", ckpt,
                        (unsigned)cn_le32(h + 8), (unsigned long long)cn_le64(h + 12), resume,
                        tail);
    return cli_fail(cmd, "%s exists and is not a cnerf checkpoint: --force replaces it", ckpt);
}

int cli_check_output_dir(const char *cmd, const char *dir, const char *dataset)
{
    char err[8400];
    if (cn_input_add(dataset, "the dataset"))
        return cli_fail(cmd, "out of memory recording the inputs");
    if (cn_output_dir_check(dir, err, sizeof err))
        return cli_fail(cmd, "%s", err);
    return 0;
}

int cli_make_dir(const char *cmd, const char *dir)
{
    char err[8400];
    if (cn_make_dir(dir, err, sizeof err))
        return cli_fail(cmd, "%s", err);
    return 0;
}

int cli_lock_output(const char *cmd, const char *path, char lock[], size_t locklen)
{
    char err[8400];
    int busy;
    const int fd = cn_lock(path, lock, locklen, &busy, err, sizeof err);
    if (fd >= 0)
        return fd;
    if (busy)
        cli_fail(cmd, "%s is being written by another cnerf (it holds %s): wait for it or "
                 "choose another output", path, lock);
    else
        cli_fail(cmd, "%s", err);
    return -1;
}

void cli_unlock_output(int fd, const char *lock) { cn_unlock(fd, lock); }

int cli_lock_outputs(const char *cmd, const char *const *paths, int n, cli_locks *L)
{
    L->n = 0;
    for (int i = 0; i < n && i < CLI_MAX_LOCKS; i++) {
        if (!paths[i])
            continue;
        const int fd = cli_lock_output(cmd, paths[i], L->path[L->n], sizeof L->path[L->n]);
        if (fd < 0) {
            cli_unlock_outputs(L);
            return 1;
        }
        L->fd[L->n++] = fd;
    }
    cli_stop_watch(L);
    return 0;
}

void cli_unlock_outputs(cli_locks *L)
{
    cli_stop_unwatch();
    for (int i = L->n - 1; i >= 0; i--)
        cn_unlock(L->fd[i], L->path[i]);
    L->n = 0;
}
