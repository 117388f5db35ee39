/* The firmware's MD5 (platform/cortex-m/md5.c) on the host: the RFC 1321 test suite, the
 * padding boundaries, a million 'a', and any split of the input into update calls. */
#include <stdio.h>
#include <string.h>

#include "testutil.h"

#include "../../platform/cortex-m/md5.c"

static void md5_of(const void *data, size_t len, char hex[33])
{
    fw_md5 c;
    uint8_t d[16];
    fw_md5_init(&c);
    fw_md5_update(&c, (const uint8_t *)data, len);
    fw_md5_final(&c, d);
    fw_md5_hex(d, hex);
}

static void test_rfc1321_suite(void **state)
{
    (void)state;
    static const struct {
        const char *msg, *md5;
    } suite[] = {
        {"", "d41d8cd98f00b204e9800998ecf8427e"},
        {"a", "0cc175b9c0f1b6a831c399e269772661"},
        {"abc", "900150983cd24fb0d6963f7d28e17f72"},
        {"message digest", "f96b697d7cb7938d525a2f31aaf161d0"},
        {"abcdefghijklmnopqrstuvwxyz", "c3fcd3d76192e4007dfb496cca67e13b"},
        {"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789",
         "d174ab98d277d9f5a5611c2c9f419d9f"},
        {"12345678901234567890123456789012345678901234567890123456789012345678901234567890",
         "57edf4a22be3c955ac49da2e2107b67a"},
    };
    for (size_t i = 0; i < sizeof suite / sizeof suite[0]; i++) {
        char hex[33];
        md5_of(suite[i].msg, strlen(suite[i].msg), hex);
        assert_string_equal(hex, suite[i].md5);
    }
}

/* Lengths around the 56-byte padding boundary and the block size (reference digests from
 * Python's hashlib of bytes (7 i + 3) mod 256). */
static void test_padding_boundaries(void **state)
{
    (void)state;
    static const struct {
        size_t n;
        const char *md5;
    } cases[] = {
        {55, "52c0e574e1198de5fe3f8f11440dcb1b"},  {56, "46c9907fc908ee68b1e7b8e71286a518"},
        {57, "1c805dd236c35cab25fcb1bc73802c51"},  {63, "a62f6d59e837867693f042f5b8f5a236"},
        {64, "7160b8fb5e9e4023d549c3971fbaeead"},  {65, "70bd662e7aefbda85a0f7244167b7897"},
        {119, "e84905d4214f4d1ca56c2cdcc152b143"}, {120, "e3eb5a6c8669ea01a8c185b8abc8a5dc"},
        {128, "10b2da1a82f16d99a81a7203fe9f02cb"},
    };
    uint8_t buf[128];
    for (size_t i = 0; i < sizeof buf; i++)
        buf[i] = (uint8_t)(i * 7 + 3);
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char hex[33];
        md5_of(buf, cases[i].n, hex);
        assert_string_equal(hex, cases[i].md5);
    }
}

static void test_million_a(void **state)
{
    (void)state;
    static uint8_t a[1000];
    memset(a, 'a', sizeof a);
    fw_md5 c;
    uint8_t d[16];
    char hex[33];
    fw_md5_init(&c);
    for (int i = 0; i < 1000; i++)
        fw_md5_update(&c, a, sizeof a);
    fw_md5_final(&c, d);
    fw_md5_hex(d, hex);
    assert_string_equal(hex, "7707d6ae4e027c70eea2a935c2296f21");
}

/* Every split of a 200-byte message into two or three update calls (including empty ones)
 * gives the one-shot digest. */
static void test_any_split(void **state)
{
    (void)state;
    uint8_t msg[200];
    for (size_t i = 0; i < sizeof msg; i++)
        msg[i] = (uint8_t)(i * 131 + 17);
    char ref[33];
    md5_of(msg, sizeof msg, ref);
    for (size_t a = 0; a <= sizeof msg; a++)
        for (size_t b = a; b <= sizeof msg; b += 13) {
            fw_md5 c;
            uint8_t d[16];
            char hex[33];
            fw_md5_init(&c);
            fw_md5_update(&c, msg, a);
            fw_md5_update(&c, msg + a, b - a);
            fw_md5_update(&c, msg + b, sizeof msg - b);
            fw_md5_final(&c, d);
            fw_md5_hex(d, hex);
            assert_string_equal(hex, ref);
        }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rfc1321_suite),
        cmocka_unit_test(test_padding_boundaries),
        cmocka_unit_test(test_million_a),
        cmocka_unit_test(test_any_split),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
