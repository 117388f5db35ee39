/* Packed images (cnerf_pack, cnerf_open_packed; docs/decoder.md, "Rendering from flash"):
 * every valid conformance vector packed for every kernel set reads back the stream's
 * latents, biases and grid; packed for this CPU's kernels it renders the same bytes as the
 * stream; and every refusal has its own status. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_internal.h"
#include "cn_kernels.h"
#include "cnerf/tools.h"
#include "testutil.h"

static const char *const vectors[] = {
    "001-lego-encode-tiny", "002-fern-encode-tiny-ndc", "003-int16-latents",
    "004-black-background", "005-one-sample", "006-empty-range-layers", "007-no-view-branch",
    "008-small-preset", "009-largest-limits", "010-widest-layer", "013-lego-encode-grid",
    "016-grid-5-ball", "017-grid-empty", "019-grid-ndc", "020-lego-encode-pruned", "021-units",
    "022-two-scenes", "023-zero-shifts", "027-contract", "028-lego-encode-contract"};
static const char *const sets[] = {"c", "dsp", "mve", "neon", "simd128", "avx2"};

static uint8_t *read_vector(const char *name, const char *ext, size_t *len)
{
    char path[512];
    snprintf(path, sizeof path, "%s/vectors/valid/%s.%s", CNERF_SOURCE_DIR, name, ext);
    FILE *f = fopen(path, "rb");
    if (!f)
        fail_msg("%s: cannot open", path);
    fseek(f, 0, SEEK_END);
    const long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    buf[n] = 0;
    *len = (size_t)n;
    return buf;
}

/* An image of scene `scene` of buf for `set`, in memory aligned like a workspace. */
static uint8_t *pack(const uint8_t *buf, size_t len, uint32_t scene, const char *set,
                     size_t *image_len)
{
    static cnerf_decoder dec;
    cnerf_info info;
    assert_int_equal(cnerf_peek_scene(buf, len, scene, &info), CNERF_OK);
    const size_t ws_size = cnerf_workspace_size(&info);
    void *ws = aligned_alloc(CNERF_WS_ALIGN, (ws_size + 7u) & ~(size_t)7u);
    assert_non_null(ws);
    assert_int_equal(cnerf_pack(&dec, buf, len, scene, set, ws, ws_size, NULL, 0, image_len),
                     CNERF_OK);
    uint8_t *image = aligned_alloc(CNERF_WS_ALIGN, (*image_len + 8u) & ~(size_t)7u);
    assert_non_null(image);
    assert_int_equal(cnerf_pack(&dec, buf, len, scene, set, ws, ws_size, image, *image_len - 1u,
                                image_len),
                     CNERF_E_BUF_SMALL);
    assert_int_equal(
        cnerf_pack(&dec, buf, len, scene, set, ws, ws_size, image, *image_len, image_len),
        CNERF_OK);
    /* packing again gives the same bytes */
    uint8_t *again = malloc(*image_len);
    size_t n2;
    assert_int_equal(cnerf_pack(&dec, buf, len, scene, set, ws, ws_size, again, *image_len, &n2),
                     CNERF_OK);
    assert_int_equal(n2, *image_len);
    assert_memory_equal(image, again, n2);
    free(again);
    free(ws);
    return image;
}

/* The image's decoder against the stream's: the same info, and the same latents, shifts and
 * biases (a sample of them in the largest layers) and grid cells. */
static void same_model(const cnerf_decoder *a, const cnerf_decoder *b)
{
    assert_memory_equal(&a->info, &b->info, sizeof a->info);
    for (uint32_t l = 0; l < a->info.n_layers; l++) {
        const cnerf_layer_info *L = &a->info.layer[l];
        const uint32_t step = (uint32_t)L->n_out * L->n_in > 20000u ? 97u : 1u;
        for (uint32_t o = 0; o < L->n_out; o++) {
            assert_int_equal(cnerf_bias(a, l, o), cnerf_bias(b, l, o));
            for (uint32_t i = (o * 31u) % step; i < L->n_in; i += step) {
                if (cnerf_latent(a, l, o, i) != cnerf_latent(b, l, o, i))
                    fail_msg("layer %u latent (%u, %u): %d in the image, %d in the stream", l,
                             o, i, cnerf_latent(a, l, o, i), cnerf_latent(b, l, o, i));
                assert_int_equal(cnerf_shift(a, l, o, i), cnerf_shift(b, l, o, i));
            }
        }
    }
    const uint32_t g = a->info.grid_g;
    for (uint32_t c = 0; c < g * g * g; c++)
        assert_int_equal(cnerf_cell_occupied(a, c), cnerf_cell_occupied(b, c));
    assert_int_equal(cn_cstate_of(a)->grid_occupied, cn_cstate_of(b)->grid_occupied);
}

/* Every vector and scene packed for every set, read back with that set's layouts. */
static void test_every_set_reads_back(void **state)
{
    (void)state;
    unsigned forms[3] = {0, 0, 0};
    for (size_t k = 0; k < sizeof vectors / sizeof vectors[0]; k++) {
        size_t len;
        uint8_t *buf = read_vector(vectors[k], "cnrf", &len);
        cnerf_info info;
        assert_int_equal(cnerf_peek(buf, len, &info), CNERF_OK);
        for (uint32_t scene = 0; scene < info.n_scenes && scene < 2u; scene++) {
            static cnerf_decoder ref, dec;
            void *ws = NULL;
            assert_int_equal(tu_open_scene(&ref, buf, len, scene, &ws), CNERF_OK);
            for (size_t s = 0; s < sizeof sets / sizeof sets[0]; s++) {
                size_t n;
                uint8_t *image = pack(buf, len, scene, sets[s], &n);
                cn_dot_variant v;
                assert_true(cn_dot_variant_target(sets[s], &v));
                const cnerf_status st = cn_open_packed_with(&dec, image, n, &v);
                if (st != CNERF_OK)
                    fail_msg("%s scene %u for %s: %s", vectors[k], scene, sets[s],
                             cnerf_status_str(st));
                same_model(&dec, &ref);
                for (uint32_t l = 0; l < dec.info.n_layers; l++)
                    forms[cn_cstate_of(&dec)->form[l]]++;
                free(image);
            }
            free(ws);
        }
        free(buf);
    }
    /* every form went through an image: packed, int64 sums (009) and lists */
    assert_true(forms[CN_FORM_PACKED] > 0);
    assert_true(forms[CN_FORM_WIDE] > 0);
    assert_true(forms[CN_FORM_SPARSE] > 0);
}

/* Packed for this CPU's kernels, the image renders each vector's golden tiles to the bytes
 * the stream renders. */
static void test_renders_as_the_stream(void **state)
{
    (void)state;
    const cn_dot_variant own = cn_dot_select();
    for (size_t k = 0; k < sizeof vectors / sizeof vectors[0]; k++) {
        size_t len, cam_len, md5_len;
        uint8_t *buf = read_vector(vectors[k], "cnrf", &len);
        char *cams = (char *)read_vector(vectors[k], "cam", &cam_len);
        char *tiles = (char *)read_vector(vectors[k], "md5", &md5_len);
        static cnerf_decoder ref, dec;
        void *ws = NULL;
        assert_int_equal(tu_open(&ref, buf, len, &ws), CNERF_OK);
        size_t n;
        uint8_t *image = pack(buf, len, 0, own.name, &n);
        assert_int_equal(cnerf_open_packed(&dec, image, n), CNERF_OK);
        /* the first tile line and its camera */
        char cam_name[64];
        unsigned x0, y0, w, h, nc, nf;
        unsigned long ts;
        assert_int_equal(sscanf(tiles, "%63s %u %u %u %u %u %u %lu", cam_name, &x0, &y0, &w, &h,
                                &nc, &nf, &ts),
                         8);
        cnerf_camera cam;
        long long v[18];
        int found = 0;
        for (char *line = cams; line && *line && !found; line = strchr(line, '\n') + 1) {
            char nm[64] = "";
            int got = sscanf(line, "%lld %lld %lld %lld %lld %lld %lld %lld %lld %lld %lld %lld "
                                   "%lld %lld %lld %lld %lld %lld %63s",
                             &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6], &v[7], &v[8], &v[9],
                             &v[10], &v[11], &v[12], &v[13], &v[14], &v[15], &v[16], &v[17], nm);
            found = got == 19 && strcmp(nm, cam_name) == 0;
            if (!strchr(line, '\n'))
                break;
        }
        assert_true(found);
        for (int i = 0; i < 9; i++)
            cam.rot[i] = (int32_t)v[i];
        for (int i = 0; i < 3; i++)
            cam.pos[i] = v[9 + i];
        cam.fx = (int32_t)v[12], cam.fy = (int32_t)v[13], cam.cx = (int32_t)v[14],
        cam.cy = (int32_t)v[15];
        cam.width = (uint16_t)v[16], cam.height = (uint16_t)v[17];
        cnerf_render_opts opts;
        cnerf_render_defaults(&ref.info, &opts);
        opts.n_coarse = (uint16_t)nc, opts.n_fine = (uint16_t)nf, opts.t_stop = (uint32_t)ts;
        const size_t scratch_size = cnerf_render_scratch_size(&ref.info);
        void *scratch = aligned_alloc(8, (scratch_size + 7u) & ~(size_t)7u);
        uint8_t *a = calloc((size_t)w * h * 3u, 1), *b = calloc((size_t)w * h * 3u, 1);
        const cnerf_status sa =
            cnerf_render_tile(&ref, &cam, &opts, x0, y0, w, h, a, w * 3u, scratch, scratch_size);
        const cnerf_status sb =
            cnerf_render_tile(&dec, &cam, &opts, x0, y0, w, h, b, w * 3u, scratch, scratch_size);
        assert_int_equal(sa, CNERF_OK);
        assert_int_equal(sb, CNERF_OK);
        if (memcmp(a, b, (size_t)w * h * 3u) != 0)
            fail_msg("%s: the image renders other bytes than the stream", vectors[k]);
        free(a), free(b), free(scratch), free(image), free(ws), free(buf), free(cams), free(tiles);
    }
}

/* Refusals, each with its status; a refused open leaves the decoder zeroed. */
static void test_refusals(void **state)
{
    (void)state;
    size_t len, n;
    uint8_t *buf = read_vector("013-lego-encode-grid", "cnrf", &len);
    const cn_dot_variant own = cn_dot_select();
    uint8_t *image = pack(buf, len, 0, own.name, &n);
    uint8_t *copy = aligned_alloc(CNERF_WS_ALIGN, (n + 16u) & ~(size_t)7u);
    static cnerf_decoder dec;
    static const cnerf_decoder zero;
#define REFUSED(st, p, len_)                                                                  \
    do {                                                                                   \
        assert_int_equal(cnerf_open_packed(&dec, (p), (len_)), (st));                       \
        assert_memory_equal(&dec, &zero, sizeof dec);                                       \
    } while (0)
    REFUSED(CNERF_E_NULL, NULL, n);
    assert_int_equal(cnerf_open_packed(NULL, image, n), CNERF_E_NULL);
    /* misaligned: the same bytes one byte further */
    memcpy(copy + 1, image, n);
    REFUSED(CNERF_E_IMAGE_ALIGN, copy + 1, n);
    /* not an image: a stream */
    memcpy(copy, buf, len);
    REFUSED(CNERF_E_MAGIC, copy, len);
    /* truncated, in its header and in its body; a longer region is accepted */
    REFUSED(CNERF_E_TRUNCATED, image, 20);
    REFUSED(CNERF_E_TRUNCATED, image, n - 1u);
    memcpy(copy, image, n);
    copy[n] = 0xAA;
    assert_int_equal(cnerf_open_packed(&dec, copy, n + 1u), CNERF_OK);
    /* another decoder version, another target, another byte order */
    memcpy(copy, image, n);
    copy[4] ^= 0x40;
    REFUSED(CNERF_E_IMAGE_VERSION, copy, n);
    for (size_t s = 0; s < sizeof sets / sizeof sets[0]; s++) {
        if (strcmp(sets[s], own.name) == 0)
            continue;
        cn_dot_variant v;
        assert_true(cn_dot_variant_target(sets[s], &v));
        size_t m;
        uint8_t *other = pack(buf, len, 0, sets[s], &m);
        REFUSED(CNERF_E_IMAGE_TARGET, other, m);
        free(other);
    }
    memcpy(copy, image, n);
    copy[6] = copy[6] == 'L' ? 'B' : 'L';
    REFUSED(CNERF_E_IMAGE_TARGET, copy, n);
    /* a bit flipped anywhere after the header's target fields: the CRC */
    const size_t at[] = {20, 45, 48, 200, n / 2, n - 1};
    for (size_t i = 0; i < sizeof at / sizeof at[0]; i++) {
        memcpy(copy, image, n);
        copy[at[i]] ^= 0x10;
        REFUSED(at[i] >= 24 && at[i] < 28 ? CNERF_E_TRUNCATED : CNERF_E_IMAGE_CRC, copy, n);
    }
    free(copy), free(image), free(buf);
}

/* An image whose CRC is right but whose contents lie (a tool's bug, or a forged image) is
 * refused before the kernels read out of place or a sum could leave its accumulator. */
static void test_forged_contents(void **state)
{
    (void)state;
    size_t len, n;
    uint8_t *buf = read_vector("001-lego-encode-tiny", "cnrf", &len);
    const cn_dot_variant own = cn_dot_select();
    uint8_t *image = pack(buf, len, 0, own.name, &n);
    uint8_t *copy = aligned_alloc(CNERF_WS_ALIGN, (n + 7u) & ~(size_t)7u);
    static cnerf_decoder dec;
    const uint32_t ws_off = cn_le32(image + 28);
    /* changes at byte `off` (header or workspace), the CRC then made right again */
#define FORGED(st, off, val)                                                                 \
    do {                                                                                   \
        memcpy(copy, image, n);                                                            \
        copy[off] = (uint8_t)(val);                                                        \
        uint32_t crc_ = cnerf_crc32(cnerf_crc32(0, copy, 44u), copy + 48, n - 48u);          \
        copy[44] = (uint8_t)crc_, copy[45] = (uint8_t)(crc_ >> 8),                          \
        copy[46] = (uint8_t)(crc_ >> 16), copy[47] = (uint8_t)(crc_ >> 24);                  \
        assert_int_equal(cnerf_open_packed(&dec, copy, n), (st));                           \
    } while (0)
    FORGED(CNERF_OK, 20, 0);                       /* scene 0 stays scene 0 */
    FORGED(CNERF_E_ARG, 20, 1);                    /* a scene the stream lacks */
    FORGED(CNERF_E_IMAGE, 7, image[7] + 1);        /* layer count */
    FORGED(CNERF_E_IMAGE, 28, ws_off + 8u);        /* the workspace moved */
    FORGED(CNERF_E_IMAGE, 32, image[32] + 8);      /* its length */
    FORGED(CNERF_E_IMAGE, 39, 0x7f);               /* the stream past the image's end */
    FORGED(CNERF_E_IMAGE, 35, 0x7f);               /* the workspace past it */
    FORGED(CNERF_E_IMAGE, 50, 3);                  /* layer 0's form out of range */
    FORGED(CNERF_E_IMAGE, 51, 1);                  /* a shift width without shifts */
    FORGED(CNERF_E_IMAGE, 49, image[49] + 1);      /* more live rows than rows (> 255) */
    /* layer 0 claims int64 sums that its latents do not need: the proof disagrees */
    FORGED(CNERF_E_IMAGE, 50, CN_FORM_WIDE);
    /* a latent of layer 0 made so large that its row sum leaves the int32 proof */
    {
        static cnerf_decoder ref;
        void *ws = NULL;
        assert_int_equal(tu_open(&ref, buf, len, &ws), CNERF_OK);
        const cn_state *rs = cn_cstate_of(&ref);
        /* layer 0's first row order entry repeated: not a permutation */
        const size_t rows0 = ws_off + (size_t)((const uint8_t *)rs->rows[0] - (uint8_t *)ws);
        FORGED(CNERF_E_IMAGE, rows0, image[rows0 + 2]);
        FORGED(CNERF_E_IMAGE, rows0 + 1, 0x7f); /* an output past the layer */
        free(ws);
    }
    free(copy), free(image), free(buf);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_set_reads_back),
        cmocka_unit_test(test_renders_as_the_stream),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_forged_contents),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
