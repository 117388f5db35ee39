/* MD5, RFC 1321: four rounds of 16 steps over 512-bit blocks, little-endian words. */
#include "md5.h"

/* K[i] = floor(|sin(i + 1)| * 2^32) */
static const uint32_t md5_k[64] = {
    0xd76aa478u, 0xe8c7b756u, 0x242070dbu, 0xc1bdceeeu,
    0xf57c0fafu, 0x4787c62au, 0xa8304613u, 0xfd469501u,
    0x698098d8u, 0x8b44f7afu, 0xffff5bb1u, 0x895cd7beu,
    0x6b901122u, 0xfd987193u, 0xa679438eu, 0x49b40821u,
    0xf61e2562u, 0xc040b340u, 0x265e5a51u, 0xe9b6c7aau,
    0xd62f105du, 0x02441453u, 0xd8a1e681u, 0xe7d3fbc8u,
    0x21e1cde6u, 0xc33707d6u, 0xf4d50d87u, 0x455a14edu,
    0xa9e3e905u, 0xfcefa3f8u, 0x676f02d9u, 0x8d2a4c8au,
    0xfffa3942u, 0x8771f681u, 0x6d9d6122u, 0xfde5380cu,
    0xa4beea44u, 0x4bdecfa9u, 0xf6bb4b60u, 0xbebfbc70u,
    0x289b7ec6u, 0xeaa127fau, 0xd4ef3085u, 0x04881d05u,
    0xd9d4d039u, 0xe6db99e5u, 0x1fa27cf8u, 0xc4ac5665u,
    0xf4292244u, 0x432aff97u, 0xab9423a7u, 0xfc93a039u,
    0x655b59c3u, 0x8f0ccc92u, 0xffeff47du, 0x85845dd1u,
    0x6fa87e4fu, 0xfe2ce6e0u, 0xa3014314u, 0x4e0811a1u,
    0xf7537e82u, 0xbd3af235u, 0x2ad7d2bbu, 0xeb86d391u,
};

/* Left-rotation amounts: four per round, repeated four times within the round. */
static const uint8_t md5_r[16] = {7, 12, 17, 22, 5, 9, 14, 20, 4, 11, 16, 23, 6, 10, 15, 21};

static uint32_t rotl(uint32_t x, unsigned n)
{
    return (x << n) | (x >> (32u - n));
}

static void md5_block(uint32_t state[4], const uint8_t p[64])
{
    uint32_t m[16];
    for (unsigned i = 0; i < 16; i++)
        m[i] = (uint32_t)p[4 * i] | (uint32_t)p[4 * i + 1] << 8 | (uint32_t)p[4 * i + 2] << 16 |
               (uint32_t)p[4 * i + 3] << 24;
    uint32_t a = state[0], b = state[1], c = state[2], d = state[3];
    for (unsigned i = 0; i < 64; i++) {
        uint32_t f;
        unsigned g;
        switch (i >> 4) {
        case 0:
            f = (b & c) | (~b & d);
            g = i;
            break;
        case 1:
            f = (d & b) | (~d & c);
            g = (5u * i + 1u) & 15u;
            break;
        case 2:
            f = b ^ c ^ d;
            g = (3u * i + 5u) & 15u;
            break;
        default:
            f = c ^ (b | ~d);
            g = (7u * i) & 15u;
            break;
        }
        const uint32_t t = d;
        d = c;
        c = b;
        b = b + rotl(a + f + md5_k[i] + m[g], md5_r[((i >> 4) << 2) | (i & 3u)]);
        a = t;
    }
    state[0] += a;
    state[1] += b;
    state[2] += c;
    state[3] += d;
}

void fw_md5_init(fw_md5 *c)
{
    c->state[0] = 0x67452301u;
    c->state[1] = 0xefcdab89u;
    c->state[2] = 0x98badcfeu;
    c->state[3] = 0x10325476u;
    c->len_lo = 0;
    c->len_hi = 0;
}

void fw_md5_update(fw_md5 *c, const uint8_t *data, size_t len)
{
    while (len > 0) {
        const unsigned used = c->len_lo & 63u;
        unsigned n = 64u - used;
        if ((size_t)n > len)
            n = (unsigned)len;
        if (used == 0 && n == 64u) {
            md5_block(c->state, data); /* a whole block straight from the input */
        } else {
            for (unsigned i = 0; i < n; i++)
                c->block[used + i] = data[i];
            if (used + n == 64u)
                md5_block(c->state, c->block);
        }
        const uint32_t lo = c->len_lo + n;
        c->len_hi += lo < c->len_lo;
        c->len_lo = lo;
        data += n;
        len -= n;
    }
}

void fw_md5_final(fw_md5 *c, uint8_t digest[16])
{
    /* The length in bits, taken before the padding changes the byte count. */
    const uint32_t bits_lo = c->len_lo << 3, bits_hi = (c->len_hi << 3) | (c->len_lo >> 29);
    static const uint8_t one = 0x80u, zero = 0;
    fw_md5_update(c, &one, 1);
    while ((c->len_lo & 63u) != 56u)
        fw_md5_update(c, &zero, 1);
    uint8_t len8[8];
    for (unsigned i = 0; i < 4; i++) {
        len8[i] = (uint8_t)(bits_lo >> (8 * i));
        len8[4 + i] = (uint8_t)(bits_hi >> (8 * i));
    }
    fw_md5_update(c, len8, 8);
    for (unsigned i = 0; i < 16; i++)
        digest[i] = (uint8_t)(c->state[i / 4] >> (8 * (i % 4)));
}

void fw_md5_hex(const uint8_t digest[16], char hex[33])
{
    static const char digits[] = "0123456789abcdef";
    for (unsigned i = 0; i < 16; i++) {
        hex[2 * i] = digits[digest[i] >> 4];
        hex[2 * i + 1] = digits[digest[i] & 15u];
    }
    hex[32] = '\0';
}
