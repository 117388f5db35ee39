/* MD5 (RFC 1321) for the firmware: C99, freestanding, no libc, endian-independent.
 * Streaming: fw_md5_init, any number of fw_md5_update calls, fw_md5_final. */
#ifndef CNERF_FW_MD5_H
#define CNERF_FW_MD5_H

#include <stddef.h>
#include <stdint.h>

typedef struct fw_md5 {
    uint32_t state[4];
    uint32_t len_lo, len_hi; /* message length in bytes, 64 bits */
    uint8_t block[64];       /* pending input, len_lo % 64 bytes of it */
} fw_md5;

void fw_md5_init(fw_md5 *c);
void fw_md5_update(fw_md5 *c, const uint8_t *data, size_t len);
/* Pads, writes the 16-byte digest and leaves `c` unusable until fw_md5_init. */
void fw_md5_final(fw_md5 *c, uint8_t digest[16]);
/* The digest as 32 lower-case hex digits and a NUL. */
void fw_md5_hex(const uint8_t digest[16], char hex[33]);

#endif
