/*
 * The container: the signature, the walk over the chunks with their CRCs and order rules,
 * and the payloads of the LAYR, SHFT and GRID chunks (the HEAD and UNIT chunks: head.c).
 * Every read is bounds-checked; limits are checked before any size is computed.
 */
#include "cn_internal.h"

void cn_memzero(void *p, size_t n)
{
    /* volatile: keeps the compiler from turning this loop into a memset call,
     * which a -nostdlib link cannot satisfy. Only small structs are zeroed. */
    volatile uint8_t *q = (volatile uint8_t *)p;
    while (n--)
        *q++ = 0;
}

uint32_t cnerf_crc32(uint32_t crc, const uint8_t *p, size_t len)
{
    static const uint32_t tab[16] = {
        0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u,
        0x4DB26158u, 0x5005713Cu, 0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
        0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
    crc = ~crc;
    while (len--) {
        crc ^= *p++;
        crc = (crc >> 4) ^ tab[crc & 15u];
        crc = (crc >> 4) ^ tab[crc & 15u];
    }
    return ~crc;
}

/* ---- the payloads of LAYR, SHFT and GRID ---- */

static int exp_ok(int32_t e) { return e >= CNERF_EXP_MIN && e <= CNERF_EXP_MAX; }

/* Where a coded matrix (latents or shifts) lies in its chunk. */
typedef struct coded_at {
    uint8_t prec, order;
    uint32_t table_bytes; /* the range, and prec, order and the table when coded */
    uint32_t table_offset, payload_offset, payload_bytes;
} coded_at;

/* The rest of a chunk [off, off + clen) after a coded matrix's range lo..hi, which the
 * reader r has just read: nothing for a constant matrix, else prec, order, the table and
 * the rANS payload (at least 4 bytes). */
static cnerf_status parse_coded(cn_reader *r, const uint8_t *buf, uint32_t off, uint32_t clen,
                                int32_t lo, int32_t hi, coded_at *c)
{
    c->prec = c->order = 0;
    c->table_bytes = 4u;
    if (lo == hi) {
        /* A constant matrix codes nothing. */
        c->table_offset = c->payload_offset = off + clen;
        c->payload_bytes = 0;
        return cn_rd_left(r) != 0u ? CNERF_E_CHUNK : CNERF_OK;
    }
    uint32_t prec = cn_rd_u8(r), k = cn_rd_u8(r);
    if (r->err)
        return CNERF_E_TABLE;
    if (prec < 1u || prec > CNERF_MAX_PREC || k > CNERF_MAX_EG_ORDER)
        return CNERF_E_TABLE;
    c->prec = (uint8_t)prec;
    c->order = (uint8_t)k;
    c->table_offset = off + (uint32_t)(r->p - (buf + off));
    cn_bits b;
    cn_bits_init(&b, r->p, cn_rd_left(r));
    /* hi - lo + 1 <= 65535 by the range check. */
    cnerf_status st = cn_table_read(&b, (uint32_t)(hi - lo) + 1u, prec, k, (uint32_t *)0);
    if (st != CNERF_OK)
        return st;
    uint32_t tbytes = (uint32_t)cn_bits_used(&b, r->p);
    c->table_bytes = 6u + tbytes;
    r->p += tbytes;
    c->payload_offset = off + (uint32_t)(r->p - (buf + off));
    c->payload_bytes = (uint32_t)cn_rd_left(r);
    return c->payload_bytes < 4u ? CNERF_E_PAYLOAD : CNERF_OK;
}

/* Parses one LAYR payload [p, p+clen) at absolute offset `off` of the stream. */
static cnerf_status parse_layer(const uint8_t *buf, uint32_t off, uint32_t clen,
                                cnerf_layer_info *L)
{
    cn_reader r;
    cn_rd_init(&r, buf + off, clen);
    uint32_t net = cn_rd_u8(&r), index = cn_rd_u8(&r);
    uint32_t n_in = cn_rd_u16(&r), n_out = cn_rd_u16(&r);
    if (r.err)
        return CNERF_E_CHUNK;
    if (net != L->net || index != L->index)
        return CNERF_E_CHUNK_ORDER;
    if (n_in != L->n_in || n_out != L->n_out)
        return CNERF_E_LAYER;
    const int32_t f_in = cn_rd_i8(&r);
    int32_t a_m = cn_rd_i24(&r), a_e = cn_rd_i8(&r);
    int32_t b_m = cn_rd_i24(&r), b_e = cn_rd_i8(&r);
    uint32_t bias_bits = cn_rd_u8(&r);
    int32_t bias_e = cn_rd_i8(&r);
    if (r.err)
        return CNERF_E_CHUNK;
    if (a_m < -CNERF_M24_ABS_MAX || b_m < -CNERF_M24_ABS_MAX || !exp_ok(a_e) || !exp_ok(b_e) ||
        !exp_ok(bias_e) || bias_bits > CNERF_MAX_BIAS_BITS || (bias_bits == 0u && bias_e != 0) ||
        f_in < CNERF_F_MIN || f_in > CNERF_F_MAX)
        return CNERF_E_FORMAT;
    L->f_in = (int8_t)f_in;
    L->a_m = a_m;
    L->a_e = (int8_t)a_e;
    L->b_m = b_m;
    L->b_e = (int8_t)b_e;
    L->bias_bits = (uint8_t)bias_bits;
    L->bias_e = (int8_t)bias_e;
    /* n_out * bias_bits <= 1024 * 24: no overflow. */
    const uint32_t bias_packed = (n_out * bias_bits + 7u) >> 3;
    if (cn_rd_left(&r) < bias_packed)
        return CNERF_E_CHUNK;
    L->bias_offset = off + (uint32_t)(r.p - (buf + off));
    r.p += bias_packed;
    int32_t kmin = cn_rd_i16(&r), kmax = cn_rd_i16(&r);
    if (r.err)
        return CNERF_E_CHUNK;
    if (kmin < -CNERF_MAX_ABS_K || kmax < -CNERF_MAX_ABS_K || kmin > kmax)
        return CNERF_E_RANGE;
    L->kmin = kmin;
    L->kmax = kmax;
    L->header_bytes = 7u;
    L->affine_bytes = 8u;
    L->bias_bytes = 2u + bias_packed;
    coded_at c;
    const cnerf_status st = parse_coded(&r, buf, off, clen, kmin, kmax, &c);
    L->prec = c.prec;
    L->eg_order = c.order;
    L->table_bytes = c.table_bytes;
    L->table_offset = c.table_offset;
    L->payload_offset = c.payload_offset;
    L->payload_bytes = c.payload_bytes;
    return st;
}

/* Parses one SHFT payload [off, off + clen) for layer L into S. */
static cnerf_status parse_shift(const uint8_t *buf, uint32_t off, uint32_t clen,
                                const cnerf_layer_info *L, cnerf_shift_info *S)
{
    cn_reader r;
    cn_rd_init(&r, buf + off, clen);
    const uint32_t net = cn_rd_u8(&r), index = cn_rd_u8(&r);
    const uint32_t n_in = cn_rd_u16(&r), n_out = cn_rd_u16(&r);
    const int32_t g_m = cn_rd_i24(&r), g_e = cn_rd_i8(&r);
    const int32_t smin = cn_rd_i16(&r), smax = cn_rd_i16(&r);
    if (r.err)
        return CNERF_E_CHUNK;
    if (net != L->net || index != L->index)
        return CNERF_E_CHUNK_ORDER;
    if (n_in != L->n_in || n_out != L->n_out)
        return CNERF_E_LAYER;
    if (g_m < -CNERF_M24_ABS_MAX || !exp_ok(g_e))
        return CNERF_E_FORMAT;
    if (smin < -CNERF_MAX_ABS_K || smax < -CNERF_MAX_ABS_K || smin > smax)
        return CNERF_E_RANGE;
    S->g_m = g_m;
    S->g_e = (int8_t)g_e;
    S->smin = smin;
    S->smax = smax;
    coded_at c;
    const cnerf_status st = parse_coded(&r, buf, off, clen, smin, smax, &c);
    S->prec = c.prec;
    S->eg_order = c.order;
    S->table_offset = c.table_offset;
    S->payload_offset = c.payload_offset;
    S->payload_bytes = c.payload_bytes;
    return st;
}

/* A GRID or BGRD chunk's fields (cnerf_info's grid_* fields). */
typedef struct grid_fields {
    uint8_t g, prec, by_blocks;
    uint16_t blocks;
    uint16_t f1[CNERF_GRID_CONTEXTS], fb1[CNERF_GRID_CONTEXTS];
    uint32_t payload_offset, payload_bytes;
} grid_fields;

/* CNERF_GRID_CONTEXTS frequencies of "occupied" of precision prec: 1 <= f < 2^prec. */
static cnerf_status grid_freqs(const uint32_t *f, unsigned prec, uint16_t *out)
{
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++) {
        if (f[c] < 1u || f[c] >= ((uint32_t)1u << prec))
            return CNERF_E_TABLE; /* both symbols need a frequency of at least 1 */
        out[c] = (uint16_t)f[c];
    }
    return CNERF_OK;
}

/* Parses a GRID (by_blocks 0) or BGRD (1) payload [off, off + clen) of the stream into gf:
 * g, prec, for BGRD the occupied blocks and the blocks' frequencies, the cells'
 * frequencies. */
static cnerf_status parse_grid(const uint8_t *buf, uint32_t off, uint32_t clen, int by_blocks,
                               grid_fields *gf)
{
    cn_reader r;
    cn_rd_init(&r, buf + off, clen);
    const uint32_t g = cn_rd_u8(&r), prec = cn_rd_u8(&r);
    const uint32_t blocks = by_blocks ? cn_rd_u16(&r) : 0u;
    uint32_t f1[CNERF_GRID_CONTEXTS], fb1[CNERF_GRID_CONTEXTS];
    for (unsigned c = 0; by_blocks && c < CNERF_GRID_CONTEXTS; c++)
        fb1[c] = cn_rd_u16(&r);
    for (unsigned c = 0; c < CNERF_GRID_CONTEXTS; c++)
        f1[c] = cn_rd_u16(&r);
    if (r.err)
        return CNERF_E_CHUNK;
    if (g < 1u || g > CNERF_MAX_GRID)
        return CNERF_E_LIMIT;
    const uint32_t nb = (g + CNERF_GRID_BLOCK - 1u) / CNERF_GRID_BLOCK;
    if (blocks > nb * nb * nb)
        return CNERF_E_LIMIT;
    if (prec < 1u || prec > CNERF_MAX_PREC)
        return CNERF_E_TABLE;
    cnerf_status st = by_blocks ? grid_freqs(fb1, prec, gf->fb1) : CNERF_OK;
    if (st == CNERF_OK)
        st = grid_freqs(f1, prec, gf->f1);
    if (st != CNERF_OK)
        return st;
    gf->g = (uint8_t)g;
    gf->prec = (uint8_t)prec;
    gf->by_blocks = (uint8_t)by_blocks;
    gf->blocks = (uint16_t)blocks;
    const uint32_t fixed = by_blocks ? CNERF_BGRD_FIXED_BYTES : CNERF_GRID_FIXED_BYTES;
    gf->payload_offset = off + fixed;
    gf->payload_bytes = clen - fixed;
    return gf->payload_bytes < 4u ? CNERF_E_PAYLOAD : CNERF_OK;
}

/* ---- the walk: the signature, then chunk by chunk, one handler per chunk type ---- */

/* Four ASCII letters. */
static int tag_ok(uint32_t tag)
{
    for (int i = 0; i < 4; i++) {
        uint32_t c = (tag >> (8 * i)) & 0xFFu;
        if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z')))
            return 0;
    }
    return 1;
}

/* The walk's state between chunks. The order: the first HEAD, then SCNS (several scenes),
 * UNIT, one SHFT per layer; then per scene its HEAD (not for scene 0), GRID and layers;
 * DONE. `scene` is the scene whose chunks are being read; only the wanted one's go into
 * info, the others are checked the same way into scratch fields. */
typedef struct walk {
    const uint8_t *buf;
    cnerf_info *info;
    uint32_t want, scene;
    uint32_t next_layer, next_shift; /* the scene's layers and the shifts read so far */
    uint32_t head0_off, head0_len;   /* the first HEAD's payload */
    int seen_head, grid_seen, set;   /* set: a SCNS chunk was read */
    uint32_t chunks;                 /* chunks read, this one included */
} walk;

/* One chunk: its tag, its offset in the stream, its payload's offset and length, and its
 * bytes with the framing. */
typedef struct chunk {
    uint32_t tag, off, poff, clen, cbytes;
} chunk;

/* 1 once the chunks every scene shares are read: the shifts, one per layer, after SCNS. */
static int shared_done(const walk *w) { return !w->set || w->next_shift == w->info->n_layers; }

/* HEAD: the first one describes the stream; each later one starts the next scene. */
static cnerf_status on_head(walk *w, const chunk *c)
{
    cnerf_info *info = w->info;
    cnerf_status st;
    if (!w->seen_head) {
        if ((st = cn_parse_head(w->buf + c->poff, c->clen, info)) != CNERF_OK)
            return st;
        w->seen_head = 1;
        w->head0_off = c->poff;
        w->head0_len = c->clen;
    } else {
        /* The next scene: after every layer of this one, within the scene count. */
        if (w->scene + 1u >= info->n_scenes || w->next_layer != info->n_layers)
            return CNERF_E_CHUNK_ORDER;
        w->scene++;
        w->next_layer = 0;
        w->grid_seen = 0;
        if ((st = cn_parse_scene_head(w->buf + c->poff, c->clen, w->buf + w->head0_off,
                                      w->head0_len, info, w->scene == w->want)) != CNERF_OK)
            return st;
    }
    if (w->scene == w->want) {
        info->head_bytes = c->cbytes;
        info->scene_bytes += c->cbytes;
    }
    return CNERF_OK;
}

/* SCNS: the scene count. Right after the first HEAD (ancillary chunks aside), at most once. */
static cnerf_status on_scns(walk *w, const chunk *c)
{
    cnerf_info *info = w->info;
    if (w->set || info->unit_bytes || w->grid_seen || w->next_layer > 0u)
        return CNERF_E_CHUNK_ORDER;
    if (c->clen != 1u)
        return CNERF_E_CHUNK;
    const uint32_t n = w->buf[c->poff];
    if (n < 1u || n > CNERF_MAX_SCENES)
        return CNERF_E_LIMIT;
    info->n_scenes = (uint8_t)n;
    w->set = 1;
    info->shared_bytes += c->cbytes;
    return CNERF_OK;
}

/* SHFT: a layer's shared shift. One per layer, in order, after SCNS and UNIT, before scene
 * 0's grid and layers. */
static cnerf_status on_shft(walk *w, const chunk *c)
{
    cnerf_info *info = w->info;
    if (!w->set || w->scene > 0u || w->grid_seen || w->next_layer > 0u ||
        w->next_shift >= info->n_layers)
        return CNERF_E_CHUNK_ORDER;
    cnerf_shift_info *S = &info->shift[w->next_shift];
    const cnerf_layer_info *L = &info->layer[w->next_shift];
    const cnerf_status st = parse_shift(w->buf, c->poff, c->clen, L, S);
    if (st != CNERF_OK)
        return st;
    S->chunk_offset = c->off;
    S->chunk_bytes = c->cbytes;
    if (cn_has_shift(S))
        info->n_shift_params += (uint32_t)L->n_in * L->n_out;
    info->shared_bytes += c->cbytes;
    w->next_shift++;
    return CNERF_OK;
}

/* LAYR: the next layer of the scene, after the shared chunks. */
static cnerf_status on_layr(walk *w, const chunk *c)
{
    cnerf_info *info = w->info;
    if (w->next_layer >= info->n_layers || !shared_done(w))
        return CNERF_E_CHUNK_ORDER;
    const int record = w->scene == w->want;
    cnerf_layer_info other, *L = &info->layer[w->next_layer];
    if (!record) { /* another scene's layer: checked against the same shape */
        cn_memzero(&other, sizeof other); /* field by field: no memcpy here */
        other.net = L->net;
        other.index = L->index;
        other.n_in = L->n_in;
        other.n_out = L->n_out;
        L = &other;
    }
    const cnerf_status st = parse_layer(w->buf, c->poff, c->clen, L);
    if (st != CNERF_OK)
        return st;
    L->chunk_offset = c->off;
    L->chunk_bytes = c->cbytes;
    if (record)
        info->scene_bytes += c->cbytes;
    w->next_layer++;
    return CNERF_OK;
}

/* UNIT: the units per layer. At most one, before the shifts, the grid and the first layer. */
static cnerf_status on_unit(walk *w, const chunk *c)
{
    cnerf_info *info = w->info;
    if (info->unit_bytes || w->grid_seen || w->next_layer > 0u || w->next_shift > 0u ||
        w->scene > 0u)
        return CNERF_E_CHUNK_ORDER;
    const cnerf_status st = cn_parse_units(w->buf + c->poff, c->clen, info);
    if (st != CNERF_OK)
        return st;
    info->unit_bytes = c->cbytes;
    return CNERF_OK;
}

/* GRID or BGRD (2.3): the scene's occupancy grid. At most one per scene, before its first
 * layer (and after the shifts). A BGRD in a stream stamped below 2.3 is unknown there. */
static cnerf_status on_grid(walk *w, const chunk *c, int by_blocks)
{
    cnerf_info *info = w->info;
    if (by_blocks && info->version_minor < CNERF_VERSION_MINOR_BLOCKS)
        return CNERF_E_UNKNOWN_CHUNK;
    if (w->grid_seen || w->next_layer > 0u || !shared_done(w))
        return CNERF_E_CHUNK_ORDER;
    grid_fields gf;
    const cnerf_status st = parse_grid(w->buf, c->poff, c->clen, by_blocks, &gf);
    if (st != CNERF_OK)
        return st;
    w->grid_seen = 1;
    if (w->scene == w->want) {
        info->grid_g = gf.g;
        info->grid_prec = gf.prec;
        info->grid_by_blocks = gf.by_blocks;
        info->grid_blocks = gf.blocks;
        for (unsigned i = 0; i < CNERF_GRID_CONTEXTS; i++) {
            info->grid_f1[i] = gf.f1[i];
            info->grid_fb1[i] = by_blocks ? gf.fb1[i] : 0u;
        }
        info->grid_payload_offset = gf.payload_offset;
        info->grid_payload_bytes = gf.payload_bytes;
        info->grid_bytes = c->cbytes;
        info->scene_bytes += c->cbytes;
    }
    return CNERF_OK;
}

/* DONE: the end, after every scene's layers, with nothing after it (`left` bytes are). */
static cnerf_status on_done(walk *w, const chunk *c, size_t left)
{
    cnerf_info *info = w->info;
    if (c->clen != 0u)
        return CNERF_E_CHUNK;
    if (w->next_layer != info->n_layers || w->scene + 1u != info->n_scenes || !shared_done(w))
        return CNERF_E_CHUNK_ORDER;
    info->done_bytes = c->cbytes;
    info->file_bytes = c->off + c->cbytes;
    if (left)
        return CNERF_E_TRAILING;
    if (w->want >= info->n_scenes)
        return CNERF_E_ARG;
    info->scene = (uint8_t)w->want;
    return CNERF_OK;
}

/* Any other chunk: an error when critical (an upper-case first letter), else skipped and
 * counted; the first META is remembered. */
static cnerf_status on_other(walk *w, const chunk *c)
{
    cnerf_info *info = w->info;
    if ((c->tag & 0xFFu) >= 'A' && (c->tag & 0xFFu) <= 'Z')
        return CNERF_E_UNKNOWN_CHUNK;
    info->ancillary_bytes += c->cbytes;
    if (c->tag == CNERF_TAG_META && info->meta_offset == 0u) {
        info->meta_offset = c->poff;
        info->meta_len = c->clen;
    }
    return CNERF_OK;
}

/* levl (2.3, ancillary): the stream's level, 1 byte, right after the first HEAD. A level
 * this decoder does not know is kept (a decoder without CNERF_MAX_LEVEL renders it). */
static cnerf_status on_levl(walk *w, const chunk *c)
{
    cnerf_info *info = w->info;
    if (w->chunks != 2u)
        return CNERF_E_CHUNK_ORDER;
    if (c->clen != 1u)
        return CNERF_E_CHUNK;
    if (w->buf[c->poff] == 0u)
        return CNERF_E_HEADER;
    info->level = w->buf[c->poff];
    info->ancillary_bytes += c->cbytes;
    return CNERF_OK;
}

#if CNERF_MAX_LEVEL < 0 || CNERF_MAX_LEVEL > CNERF_MAX_LEVELS
#error "CNERF_MAX_LEVEL: 0 (any stream) or a level from 1 to CNERF_MAX_LEVELS"
#endif

/* The described scene against the level its stream declares (docs/bitstream.md, levl),
 * and the stream's level against this decoder's (CNERF_MAX_LEVEL). */
static cnerf_status check_level(const cnerf_info *info)
{
    const uint32_t L = info->level;
#if CNERF_MAX_LEVEL > 0
    if (L == 0u || L > (uint32_t)CNERF_MAX_LEVEL)
        return CNERF_E_LEVEL;
#endif
    if (L == 0u || L > CNERF_MAX_LEVELS)
        return CNERF_OK; /* none, or a later level's caps, which this decoder does not know */
    uint32_t macs[CNERF_MAX_NETS]; /* element by element: an initializer may become memset */
    for (uint32_t n = 0; n < CNERF_MAX_NETS; n++)
        macs[n] = 0;
    for (uint32_t l = 0; l < info->n_layers; l++) /* < 2^26 latents: no overflow */
        macs[info->layer[l].net % CNERF_MAX_NETS] +=
            (uint32_t)info->layer[l].n_in * info->layer[l].n_out;
    for (uint32_t n = 0; n < CNERF_MAX_NETS; n++)
        if (macs[n] > CNERF_LEVEL_MACS(L))
            return CNERF_E_LEVEL_EXCEEDED;
    if (cnerf_workspace_size(info) > CNERF_LEVEL_WORKSPACE(L) ||
        cnerf_render_scratch_size(info) > CNERF_LEVEL_SCRATCH(L) ||
        info->grid_g > CNERF_LEVEL_GRID(L) ||
        (uint32_t)info->n_coarse + info->n_fine > CNERF_LEVEL_SAMPLES(L))
        return CNERF_E_LEVEL_EXCEEDED;
    return CNERF_OK;
}

cnerf_status cn_parse(const uint8_t *buf, size_t len, uint32_t want, cnerf_info *info)
{
    cn_memzero(info, sizeof *info);
    static const uint8_t magic[4] = {CNERF_MAGIC_0, CNERF_MAGIC_1, CNERF_MAGIC_2, CNERF_MAGIC_3};
    for (size_t i = 0; i < 4u; i++) {
        if (i >= len)
            return CNERF_E_TRUNCATED; /* a prefix of the magic */
        if (buf[i] != magic[i])
            return CNERF_E_MAGIC;
    }
    if ((len >> 16) >> 16) /* offsets are 32-bit; written so 32-bit size_t warns not */
        return CNERF_E_LIMIT;
    cn_reader r;
    cn_rd_init(&r, buf, len);
    r.p += 4;
    info->version_major = (uint16_t)cn_rd_u16(&r);
    info->version_minor = (uint16_t)cn_rd_u16(&r);
    if (r.err)
        return CNERF_E_TRUNCATED;
    if (info->version_major != CNERF_VERSION_MAJOR)
        return CNERF_E_VERSION;
    info->signature_bytes = CNERF_SIGNATURE_BYTES;
    info->n_scenes = 1;
    walk w; /* field by field: an initializer may become a memset call */
    w.buf = buf;
    w.info = info;
    w.want = want;
    w.scene = w.next_layer = w.next_shift = w.head0_off = w.head0_len = 0;
    w.seen_head = w.grid_seen = w.set = 0;
    w.chunks = 0;
    for (;;) {
        chunk c;
        c.off = (uint32_t)(r.p - buf);
        if (cn_rd_left(&r) < 8u)
            return CNERF_E_TRUNCATED;
        c.tag = cn_rd_u32(&r);
        c.clen = cn_rd_u32(&r);
        if (cn_rd_left(&r) < 4u || cn_rd_left(&r) - 4u < c.clen)
            return CNERF_E_TRUNCATED;
        c.poff = c.off + 8u;
        c.cbytes = c.clen + CNERF_CHUNK_OVERHEAD;
        uint32_t crc = cnerf_crc32(0, buf + c.off, 4u);
        crc = cnerf_crc32(crc, buf + c.poff, c.clen);
        r.p += c.clen;
        const uint32_t stored = cn_rd_u32(&r);
#ifndef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
        if (stored != crc)
            return CNERF_E_CRC;
#else
        (void)stored; /* fuzz builds: let mutations reach the chunk parsers */
#endif
        if (!tag_ok(c.tag))
            return CNERF_E_CHUNK;
        if (!w.seen_head && c.tag != CNERF_TAG_HEAD)
            return CNERF_E_CHUNK_ORDER;
        w.chunks++;
        cnerf_status st;
        switch (c.tag) {
        case CNERF_TAG_HEAD: st = on_head(&w, &c); break;
        case CNERF_TAG_SCNS: st = on_scns(&w, &c); break;
        case CNERF_TAG_SHFT: st = on_shft(&w, &c); break;
        case CNERF_TAG_LAYR: st = on_layr(&w, &c); break;
        case CNERF_TAG_UNIT: st = on_unit(&w, &c); break;
        case CNERF_TAG_GRID: st = on_grid(&w, &c, 0); break;
        case CNERF_TAG_BGRD: st = on_grid(&w, &c, 1); break;
        case CNERF_TAG_LEVL: st = on_levl(&w, &c); break;
        case CNERF_TAG_DONE:
            st = on_done(&w, &c, cn_rd_left(&r));
            return st == CNERF_OK ? check_level(info) : st;
        default: st = on_other(&w, &c); break;
        }
        if (st != CNERF_OK)
            return st;
    }
}

cnerf_status cnerf_peek_scene(const uint8_t *buf, size_t len, uint32_t scene, cnerf_info *info)
{
    if (!info || (!buf && len))
        return CNERF_E_NULL;
    return cn_parse(buf ? buf : (const uint8_t *)"", len, scene, info);
}

cnerf_status cnerf_peek(const uint8_t *buf, size_t len, cnerf_info *info)
{
    return cnerf_peek_scene(buf, len, 0, info);
}
