/* encoder/base/fileio.c: a process that writes nothing (cn_files_discard), as the ranks of a
 * shared training other than rank 0 are: its writes reach no disk and read back from memory,
 * its locks lock nothing, and turning it off forgets them. */
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cn_file.h"
#include "testutil.h"

#define DIR_ CNERF_BINARY_DIR "/test_files_tmp"

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static void read_back(const char *path, const char *want)
{
    uint8_t *data;
    size_t len;
    char err[256];
    assert_int_equal(cn_read_file(path, &data, &len, err, sizeof err), 0);
    assert_int_equal(len, strlen(want));
    assert_memory_equal(data, want, len);
    free(data);
}

static void test_discard(void **state)
{
    (void)state;
    char err[256], lock[512];
    assert_int_equal(cn_make_dir(DIR_, err, sizeof err), 0);
    unlink(DIR_ "/out");
    cn_files_discard(1);
    assert_int_equal(cn_output_check(DIR_ "/out", err, sizeof err), 0);
    assert_int_equal(cn_write_file_atomic(DIR_ "/out", "abc", 3, err, sizeof err), 0);
    assert_false(exists(DIR_ "/out"));
    read_back(DIR_ "/out", "abc");
    assert_int_equal(cn_write_file_atomic(DIR_ "/out", "defg", 4, err, sizeof err), 0);
    read_back(DIR_ "/out", "defg"); /* the last bytes written */
    int busy = 1;
    const int fd = cn_lock(DIR_ "/out", lock, sizeof lock, &busy, err, sizeof err);
    assert_true(fd >= 0);
    assert_int_equal(busy, 0);
    assert_false(exists(DIR_ "/out.lock"));
    cn_unlock(fd, lock); /* closes nothing of this process's */
    cn_lock_abandon(lock);
    assert_int_equal(cn_make_dir(DIR_ "/sub", err, sizeof err), 0);
    assert_false(exists(DIR_ "/sub"));
    /* The checks still read the disk: a directory is not an output. */
    assert_int_equal(cn_output_check(DIR_, err, sizeof err), -1);
    cn_files_discard(0);
    uint8_t *data;
    size_t len;
    assert_int_equal(cn_read_file(DIR_ "/out", &data, &len, err, sizeof err), -1);
    assert_int_equal(cn_write_file_atomic(DIR_ "/out", "xy", 2, err, sizeof err), 0);
    assert_true(exists(DIR_ "/out"));
    read_back(DIR_ "/out", "xy");
    unlink(DIR_ "/out");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_discard),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
