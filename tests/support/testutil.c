#include "testutil.h"
#include "cn_reader.h"

#include <stdlib.h>
#include <string.h>

#include "cn_scales.h"

int tu_synth(cn_synth *s, const cnerf_info *hdr, uint64_t seed, double spread, char *err,
             size_t errlen)
{
    if (cn_synth_make(s, hdr, seed, spread, err, errlen))
        return -1;
    if (cn_choose_scales(&s->src, seed, NULL, err, errlen)) {
        cn_synth_free(s);
        return -1;
    }
    return 0;
}

void tu_synth_stream(const cnerf_info *hdr, uint64_t seed, double spread, cn_buf *out,
                     cn_synth *model)
{
    char err[256] = "";
    cn_synth local;
    cn_synth *s = model ? model : &local;
    if (tu_synth(s, hdr, seed, spread, err, sizeof err))
        fail_msg("synth: %s", err);
    memset(out, 0, sizeof *out);
    if (cn_write_stream(&s->src, out, NULL, err, sizeof err))
        fail_msg("write: %s", err);
    if (!model)
        cn_synth_free(&local);
}

void tu_small_header(cnerf_info *hdr, unsigned depth, unsigned width, int two_nets)
{
    assert_int_equal(cn_preset_header("tiny", hdr), 0);
    hdr->n_fine = two_nets ? 8 : 0;
    hdr->n_coarse = 8;
    hdr->n_nets = two_nets ? 2 : 1;
    hdr->l_pos = 2;
    hdr->l_dir = 1;
    for (unsigned n = 0; n < 2; n++) {
        hdr->net[n].depth = (uint8_t)depth;
        hdr->net[n].width = (uint16_t)width;
        hdr->net[n].skip = depth >= 3 ? 1 : CNERF_NO_SKIP;
        hdr->net[n].view_width = (uint16_t)(width / 2 ? width / 2 : 1);
    }
}

cnerf_status tu_open_scene(cnerf_decoder *dec, const uint8_t *buf, size_t len, unsigned scene,
                           void **ws)
{
    cnerf_info *info = malloc(sizeof *info);
    assert_non_null(info);
    cnerf_status st = cnerf_peek_scene(buf, len, scene, info);
    size_t n = st == CNERF_OK ? cnerf_workspace_size(info) : 64;
    free(info);
    *ws = aligned_alloc(CNERF_WS_ALIGN, (n + 7) & ~(size_t)7);
    assert_non_null(*ws);
    return cnerf_open_scene(dec, buf, len, scene, *ws, n);
}

cnerf_status tu_open(cnerf_decoder *dec, const uint8_t *buf, size_t len, void **ws)
{
    return tu_open_scene(dec, buf, len, 0, ws);
}

void tu_fix_crc(uint8_t *chunk)
{
    uint32_t len = cn_le32(chunk + 4);
    uint32_t crc = cnerf_crc32(0, chunk, 4);
    crc = cnerf_crc32(crc, chunk + 8, len);
    for (int i = 0; i < 4; i++)
        chunk[8 + len + i] = (uint8_t)(crc >> (8 * i));
}

size_t tu_chunk_offset(const uint8_t *buf, size_t len, unsigned n)
{
    size_t off = CNERF_SIGNATURE_BYTES;
    for (unsigned i = 0; off + 8 <= len; i++) {
        if (i == n)
            return off;
        off += CNERF_CHUNK_OVERHEAD + cn_le32(buf + off + 4);
    }
    return 0;
}
