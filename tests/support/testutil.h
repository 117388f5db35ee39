/* Helpers shared by the unit tests. */
#ifndef CNERF_TESTUTIL_H
#define CNERF_TESTUTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cn_buf.h"
#include "cn_synth.h"

/* A synthetic model as cnerf synth makes it (cn_synth_make), its input scales chosen from
 * seed as the encode pipeline would: ready for cn_write_stream. Returns 0 or -1. */
int tu_synth(cn_synth *s, const cnerf_info *hdr, uint64_t seed, double spread, char *err,
             size_t errlen);
/* A stream written from a synthetic model (header `hdr`, seed, spread). Fails the test
 * on error. The caller frees out->p. */
void tu_synth_stream(const cnerf_info *hdr, uint64_t seed, double spread, cn_buf *out,
                     cn_synth *model);

/* A small valid header: one or two networks of depth `depth` and width `width`. */
void tu_small_header(cnerf_info *hdr, unsigned depth, unsigned width, int two_nets);

/* Opens buf into a freshly allocated, aligned workspace; returns the status and the
 * workspace (free with free()). */
cnerf_status tu_open(cnerf_decoder *dec, const uint8_t *buf, size_t len, void **ws);
/* The same for scene `scene` of a several-scene stream. */
cnerf_status tu_open_scene(cnerf_decoder *dec, const uint8_t *buf, size_t len, unsigned scene,
                           void **ws);

/* Recomputes a chunk's CRC after the test edited it; `chunk` points at its tag. */
void tu_fix_crc(uint8_t *chunk);

/* Offset of the n-th chunk (0 = HEAD) of a stream, or 0 if there is none. */
size_t tu_chunk_offset(const uint8_t *buf, size_t len, unsigned n);

#endif
