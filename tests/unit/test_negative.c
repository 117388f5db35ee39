/* Broken streams: one row per case with the status peek and open must return.
 * Never a crash, never an assert. */
#include <stdlib.h>
#include <string.h>

#include "cn_internal.h"
#include "cn_reader.h"
#include "negcases.h"
#include "testutil.h"

static cn_buf base;
static cnerf_info base_info;

static int setup(void **state)
{
    (void)state;
    assert_int_equal(neg_base_make(&base, &base_info), 0);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    cn_buf_free(&base);
    neg_base_free();
    return 0;
}

static cnerf_status open_status(const uint8_t *p, size_t n, unsigned scene)
{
    cnerf_decoder *dec = malloc(sizeof *dec);
    void *ws = NULL;
    cnerf_status st = tu_open_scene(dec, p, n, scene, &ws);
    free(ws);
    free(dec);
    return st;
}

static void test_table(void **state)
{
    (void)state;
    int failures = 0;
    for (size_t i = 0; i < neg_case_count; i++) {
        const neg_case *t = &neg_cases[i];
        cn_buf b;
        assert_int_equal(neg_build(i, &b), 0);
        cnerf_info info;
        cnerf_status p = cnerf_peek_scene(b.p ? b.p : (const uint8_t *)"", b.n, t->scene, &info);
        cnerf_status o = open_status(b.p ? b.p : (const uint8_t *)"", b.n, t->scene);
        if (p != t->peek || o != t->open) {
            print_error("case '%s': peek %s (want %s), open %s (want %s)\n", t->name,
                        cnerf_status_str(p), cnerf_status_str(t->peek), cnerf_status_str(o),
                        cnerf_status_str(t->open));
            failures++;
        }
        cn_buf_free(&b);
    }
    assert_int_equal(failures, 0);
}

/* Truncation at every byte offset of a valid stream. */
static void test_every_truncation(void **state)
{
    (void)state;
    cnerf_info info;
    for (size_t n = 0; n < base.n; n++) {
        cnerf_status st = cnerf_peek(base.p, n, &info);
        if (st != CNERF_E_TRUNCATED)
            fail_msg("cut at %zu of %zu: %s", n, base.n, cnerf_status_str(st));
        if (n % 37 == 0)
            assert_int_equal(open_status(base.p, n, 0), CNERF_E_TRUNCATED);
    }
    assert_int_equal(cnerf_peek(base.p, base.n, &info), CNERF_OK);
}

/* A bit flip in every chunk's payload or tag is caught by its CRC; a flip anywhere
 * else is an error too, except in the minor version. */
static void test_every_bit_flip(void **state)
{
    (void)state;
    uint8_t *p = malloc(base.n);
    cnerf_info info;
    for (size_t off = 0; off < base.n; off++) {
        for (int bit = 0; bit < 8; bit++) {
            memcpy(p, base.p, base.n);
            p[off] ^= (uint8_t)(1u << bit);
            cnerf_status st = cnerf_peek(p, base.n, &info);
            if (off == 6 || off == 7) { /* minor version: accepted */
                assert_int_equal(st, CNERF_OK);
                continue;
            }
            if (st == CNERF_OK)
                fail_msg("flip at byte %zu bit %d accepted", off, bit);
            /* Inside a chunk's tag or payload: the CRC catches it. */
            size_t c = 8;
            while (c + 12 <= base.n) {
                size_t len = cn_le32(base.p + c + 4);
                int in_tag = off >= c && off < c + 4;
                int in_payload = off >= c + 8 && off < c + 8 + len;
                if (in_tag || in_payload) {
                    if (st != CNERF_E_CRC)
                        fail_msg("flip at byte %zu bit %d: %s, want CNERF_E_CRC", off, bit,
                                 cnerf_status_str(st));
                    break;
                }
                c += 12 + len;
            }
        }
    }
    free(p);
}

static void test_status_strings(void **state)
{
    (void)state;
    for (int s = 0; s >= CNERF_E_LEVEL_EXCEEDED; s--) {
        const char *name = cnerf_status_str((cnerf_status)s);
        assert_non_null(name);
        assert_true(strncmp(name, "CNERF_", 6) == 0);
        assert_null(strstr(name, "UNKNOWN_STATUS"));
    }
    assert_string_equal(cnerf_status_str((cnerf_status)-999), "CNERF_E_UNKNOWN_STATUS");
    /* Never renumbered: pinned values. */
    assert_int_equal(CNERF_E_CRC, -8);
    assert_int_equal(CNERF_E_PAYLOAD, -16);
    assert_int_equal(CNERF_E_BUF_SMALL, -21);
    assert_int_equal(CNERF_E_IMAGE_ALIGN, -22);
    assert_int_equal(CNERF_E_IMAGE, -26);
    assert_int_equal(CNERF_E_LEVEL, -27);
    assert_int_equal(CNERF_E_LEVEL_EXCEEDED, -28);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_table),
        cmocka_unit_test(test_every_truncation),
        cmocka_unit_test(test_every_bit_flip),
        cmocka_unit_test(test_status_strings),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
