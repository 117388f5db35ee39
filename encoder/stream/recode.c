/* Re-coding a stream chunk by chunk (cn_stream.h, cn_recode): the grids by blocks, the
 * level declared; the layers copied as they are. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_file.h"
#include "cn_reader.h"
#include "cn_stream.h"
#include "cnerf/tools.h"

/* Appends one chunk: tag, length, payload, CRC-32 of tag and payload. */
static void put_raw_chunk(cn_buf *out, uint32_t tag, const uint8_t *p, size_t n)
{
    uint8_t t[4];
    for (int i = 0; i < 4; i++)
        t[i] = (uint8_t)(tag >> (8 * i));
    cn_buf_put(out, t, 4);
    cn_buf_u32(out, (uint32_t)n);
    cn_buf_put(out, p, n);
    cn_buf_u32(out, cnerf_crc32(cnerf_crc32(0, t, 4), p, n));
}

/* Scene m's grid (described by I) as a BGRD payload into c, or a GRID one (cells). */
static int grid_payload(const uint8_t *buf, const cnerf_info *I, int cells_coding, cn_buf *c,
                        char *err, size_t errlen)
{
    const size_t g = I->grid_g, cells = g * g * g, wsz = cnerf_grid_workspace_size(I);
    uint8_t *bits = malloc((cells + 7) / 8), *occ = malloc(cells);
    void *ws = aligned_alloc(CNERF_WS_ALIGN, (wsz + 7) & ~(size_t)7);
    uint32_t n1 = 0;
    int rc = 0;
    cnerf_status st = CNERF_OK;
    if (!bits || !occ || !ws)
        rc = cn_fail(err, errlen, "out of memory");
    else if ((st = cnerf_grid_bitmap(buf, I, ws, wsz, bits, &n1)) != CNERF_OK)
        rc = cn_fail(err, errlen, "the grid does not decode (%s)", cnerf_status_str(st));
    for (size_t i = 0; rc == 0 && i < cells; i++)
        occ[i] = (uint8_t)(bits[i >> 3] >> (i & 7) & 1u);
    if (rc == 0 && (cells_coding ? cn_grid_encode_raster(occ, (uint32_t)g, CN_GRID_PREC, c)
                                 : cn_grid_encode(occ, (uint32_t)g, CN_GRID_PREC, c)))
        rc = cn_fail(err, errlen, "out of memory");
    free(bits);
    free(occ);
    free(ws);
    return rc;
}

int cn_recode(const uint8_t *buf, size_t len, int level, int cells, cn_buf *out, char *err,
              size_t errlen)
{
    out->n = 0;
    cnerf_info *I = malloc(sizeof *I);
    if (!I)
        return cn_fail(err, errlen, "out of memory");
    /* The input must be a valid stream; one over the level it declares is taken too (its
     * level is what changes). */
    cnerf_status st = cnerf_peek(buf, len, I);
    int rc = 0;
    if (st != CNERF_OK && st != CNERF_E_LEVEL_EXCEEDED)
        rc = cn_fail(err, errlen, "not a valid stream: %s", cnerf_status_str(st));
    const unsigned scenes = rc == 0 ? I->n_scenes : 0;
    const int declare = level < 0 ? I->level : level;
    int blocks = 0, scns = 0, contract = 0;
    cn_buf c = {0};
    if (rc == 0) {
        cn_buf_put(out, buf, 4);
        cn_buf_u16(out, CNERF_VERSION_MAJOR);
        cn_buf_u16(out, 0); /* the minor, set below */
    }
    unsigned scene = 0, heads = 0;
    for (size_t off = CNERF_SIGNATURE_BYTES; rc == 0 && off < len;) {
        const uint32_t tag = cn_le32(buf + off), n = cn_le32(buf + off + 4);
        const uint8_t *p = buf + off + 8;
        off += CNERF_CHUNK_OVERHEAD + n;
        if (tag == CNERF_TAG_HEAD) {
            scene = heads++;
            contract |= n > 0 && p[0] == CNERF_COORD_CONTRACT;
            put_raw_chunk(out, tag, p, n);
            if (heads == 1 && declare) {
                const uint8_t L = (uint8_t)declare;
                put_raw_chunk(out, CNERF_TAG_LEVL, &L, 1);
            }
        } else if (tag == CNERF_TAG_LEVL) {
            /* replaced by the one written after HEAD */
        } else if (tag == CNERF_TAG_GRID || tag == CNERF_TAG_BGRD) {
            st = cnerf_peek_scene(buf, len, scene, I);
            if (st != CNERF_OK && st != CNERF_E_LEVEL_EXCEEDED)
                rc = cn_fail(err, errlen, "scene %u: %s", scene, cnerf_status_str(st));
            c.n = 0;
            if (rc == 0)
                rc = grid_payload(buf, I, cells, &c, err, errlen);
            if (rc == 0)
                put_raw_chunk(out, cells ? CNERF_TAG_GRID : CNERF_TAG_BGRD, c.p, c.n);
            blocks |= !cells;
        } else {
            scns |= tag == CNERF_TAG_SCNS;
            put_raw_chunk(out, tag, p, n);
        }
    }
    cn_buf_free(&c);
    if (rc == 0 && out->oom)
        rc = cn_fail(err, errlen, "out of memory");
    if (rc == 0) {
        /* the lowest minor whose chunks and values the result holds, as the writer stamps */
        const unsigned minor = blocks || declare ? CNERF_VERSION_MINOR_BLOCKS
                               : contract        ? CNERF_VERSION_MINOR_CONTRACT
                               : scns            ? CNERF_VERSION_MINOR_SCENES
                                                 : 0u;
        out->p[6] = (uint8_t)minor;
        out->p[7] = (uint8_t)(minor >> 8);
    }
    for (unsigned m = 0; rc == 0 && m < scenes; m++) {
        st = cnerf_peek_scene(out->p, out->n, m, I);
        if (st == CNERF_E_LEVEL_EXCEEDED) {
            char why[256], which[32] = "the stream";
            if (scenes > 1)
                snprintf(which, sizeof which, "scene %u", m);
            cn_level_excess(I, I->level, why, sizeof why);
            rc = cn_fail(err, errlen, "%s does not fit level %u: %s", which, I->level, why);
        } else if (st != CNERF_OK) {
            rc = cn_fail(err, errlen, "the re-coded stream does not parse (%s)",
                         cnerf_status_str(st));
        }
    }
    free(I);
    return rc;
}
