/*
 * The decoder's entry points for JavaScript (a WebAssembly module with no imports).
 *
 * The module allocates nothing: the JavaScript side lays its memory out once (the stream, an
 * info record, the decoder, the workspace, the render scratch and a tile's pixels, each at an
 * address it chose above __heap_base) and passes the addresses in. Every function takes and
 * returns plain integers, so the JavaScript never depends on the layout of a C struct:
 * cw_summary copies what a viewer shows of cnerf_info into an array of int32 whose order is
 * CW_FIELDS below (platform/web/js/core.js names them in the same order, and
 * tests/web/conformance.mjs checks the two against cnerf info).
 *
 * Built by platform/web/build.sh: clang --target=wasm32 -msimd128 -ffreestanding -nostdlib,
 * then wasm-ld --no-entry.
 */
#include "cnerf/cnerf.h"

#define CW_EXPORT(name) __attribute__((export_name(#name), visibility("default")))

/* The compiler may turn a loop or a struct copy into these calls; a module without imports
 * defines them itself. */
void *memset(void *d, int c, size_t n);
void *memcpy(void *restrict d, const void *restrict s, size_t n);
void *memmove(void *d, const void *s, size_t n);

void *memset(void *d, int c, size_t n)
{
    volatile unsigned char *p = d; /* volatile: not turned back into a memset call */
    while (n--)
        *p++ = (unsigned char)c;
    return d;
}

void *memcpy(void *restrict d, const void *restrict s, size_t n)
{
    volatile unsigned char *p = d;
    const unsigned char *q = s;
    while (n--)
        *p++ = *q++;
    return d;
}

void *memmove(void *d, const void *s, size_t n)
{
    volatile unsigned char *p = d;
    const unsigned char *q = s;
    if (p < q) {
        while (n--)
            *p++ = *q++;
    } else {
        while (n--)
            p[n] = q[n];
    }
    return d;
}

CW_EXPORT(cw_info_bytes) uint32_t cw_info_bytes(void)
{
    return (uint32_t)sizeof(cnerf_info);
}

CW_EXPORT(cw_decoder_bytes) uint32_t cw_decoder_bytes(void)
{
    return (uint32_t)sizeof(cnerf_decoder);
}

CW_EXPORT(cw_peek) int32_t cw_peek(const uint8_t *buf, uint32_t len, uint32_t scene,
                                   cnerf_info *info)
{
    return cnerf_peek_scene(buf, len, scene, info);
}

CW_EXPORT(cw_workspace_size) uint32_t cw_workspace_size(const cnerf_info *info)
{
    return (uint32_t)cnerf_workspace_size(info);
}

CW_EXPORT(cw_scratch_size) uint32_t cw_scratch_size(const cnerf_info *info)
{
    return (uint32_t)cnerf_render_scratch_size(info);
}

/* The summary's fields, in order. Per network (two of them): depth, width, view_width,
 * units of the last trunk layer... see core.js. */
enum {
    CW_VERSION_MAJOR, CW_VERSION_MINOR, CW_N_SCENES, CW_SCENE, CW_COORD, CW_L_POS, CW_L_DIR,
    CW_NEAR_Q16, CW_FAR_Q16, CW_AABB_Q16, /* six */
    CW_BACKGROUND = CW_AABB_Q16 + 6, /* three */
    CW_N_NETS = CW_BACKGROUND + 3, CW_N_COARSE, CW_N_FINE, CW_N_LAYERS, CW_N_PARAMS, CW_N_BIASES,
    CW_FILE_BYTES, CW_SIGNATURE_BYTES, CW_HEAD_BYTES, CW_ANCILLARY_BYTES, CW_DONE_BYTES,
    CW_LAYER_BYTES, CW_GRID_G, CW_GRID_BYTES, CW_UNIT_BYTES, CW_SCENE_BYTES, CW_SHARED_BYTES,
    CW_META_OFFSET, CW_META_LEN, CW_NET_DEPTH, /* per network from here: two */
    CW_NET_WIDTH = CW_NET_DEPTH + 2, CW_NET_VIEW_WIDTH = CW_NET_WIDTH + 2,
    CW_NET_COLOR = CW_NET_VIEW_WIDTH + 2, CW_WORKSPACE = CW_NET_COLOR + 2, CW_SCRATCH,
    CW_FIELDS
};

CW_EXPORT(cw_fields) uint32_t cw_fields(void)
{
    return CW_FIELDS;
}

/* Copies the summary of `info` into out[0 .. CW_FIELDS). */
CW_EXPORT(cw_summary) void cw_summary(const cnerf_info *info, int32_t *out)
{
    uint32_t layer_bytes = 0;
    for (uint32_t l = 0; l < info->n_layers && l < CNERF_MAX_LAYERS; l++)
        layer_bytes += info->layer[l].chunk_bytes;
    out[CW_VERSION_MAJOR] = info->version_major;
    out[CW_VERSION_MINOR] = info->version_minor;
    out[CW_N_SCENES] = info->n_scenes;
    out[CW_SCENE] = info->scene;
    out[CW_COORD] = info->coord;
    out[CW_L_POS] = info->l_pos;
    out[CW_L_DIR] = info->l_dir;
    out[CW_NEAR_Q16] = info->near_q16;
    out[CW_FAR_Q16] = info->far_q16;
    for (int a = 0; a < 6; a++)
        out[CW_AABB_Q16 + a] = info->aabb_q16[a];
    for (int c = 0; c < 3; c++)
        out[CW_BACKGROUND + c] = info->background[c];
    out[CW_N_NETS] = info->n_nets;
    out[CW_N_COARSE] = info->n_coarse;
    out[CW_N_FINE] = info->n_fine;
    out[CW_N_LAYERS] = (int32_t)info->n_layers;
    out[CW_N_PARAMS] = (int32_t)info->n_params;
    out[CW_N_BIASES] = (int32_t)info->n_biases;
    out[CW_FILE_BYTES] = (int32_t)info->file_bytes;
    out[CW_SIGNATURE_BYTES] = (int32_t)info->signature_bytes;
    out[CW_HEAD_BYTES] = (int32_t)info->head_bytes;
    out[CW_ANCILLARY_BYTES] = (int32_t)info->ancillary_bytes;
    out[CW_DONE_BYTES] = (int32_t)info->done_bytes;
    out[CW_LAYER_BYTES] = (int32_t)layer_bytes;
    out[CW_GRID_G] = info->grid_g;
    out[CW_GRID_BYTES] = (int32_t)info->grid_bytes;
    out[CW_UNIT_BYTES] = (int32_t)info->unit_bytes;
    out[CW_SCENE_BYTES] = (int32_t)info->scene_bytes;
    out[CW_SHARED_BYTES] = (int32_t)info->shared_bytes;
    out[CW_META_OFFSET] = (int32_t)info->meta_offset;
    out[CW_META_LEN] = (int32_t)info->meta_len;
    for (unsigned n = 0; n < 2; n++) {
        const int has = n < info->n_nets && n < CNERF_MAX_NETS;
        out[CW_NET_DEPTH + n] = has ? info->net[n].depth : 0;
        out[CW_NET_WIDTH + n] = has ? info->net[n].width : 0;
        out[CW_NET_VIEW_WIDTH + n] = has ? info->net[n].view_width : 0;
        out[CW_NET_COLOR + n] = has ? cnerf_net_has_color(info, n) : 0;
    }
    out[CW_WORKSPACE] = (int32_t)cnerf_workspace_size(info);
    out[CW_SCRATCH] = (int32_t)cnerf_render_scratch_size(info);
}

CW_EXPORT(cw_open) int32_t cw_open(cnerf_decoder *dec, const uint8_t *buf, uint32_t len,
                                   uint32_t scene, void *ws, uint32_t ws_size)
{
    return cnerf_open_scene(dec, buf, len, scene, ws, ws_size);
}

/* A camera as 21 int32: rot[9] (Q30), pos[3] (Q32, each as its low then its high word),
 * fx, fy, cx, cy (Q16), width, height. */
static void camera_from_words(cnerf_camera *cam, const int32_t *w)
{
    for (int i = 0; i < 9; i++)
        cam->rot[i] = w[i];
    for (int a = 0; a < 3; a++)
        cam->pos[a] = (int64_t)(((uint64_t)(uint32_t)w[10 + 2 * a] << 32) |
                                (uint64_t)(uint32_t)w[9 + 2 * a]);
    cam->fx = w[15];
    cam->fy = w[16];
    cam->cx = w[17];
    cam->cy = w[18];
    cam->width = (uint16_t)w[19];
    cam->height = (uint16_t)w[20];
}

/* cnerf_camera_look_at into 21 words (the layout above); eye, target and up in Q16. */
CW_EXPORT(cw_look_at) int32_t cw_look_at(int32_t *out, const int32_t *eye,
                                         const int32_t *target, const int32_t *up,
                                         int32_t fov_x_q16, uint32_t width, uint32_t height)
{
    cnerf_camera cam;
    if (width > 0xffffu || height > 0xffffu)
        return CNERF_E_ARG;
    cnerf_status s = cnerf_camera_look_at(&cam, eye, target, up, fov_x_q16, (uint16_t)width,
                                          (uint16_t)height);
    if (s != CNERF_OK)
        return s;
    for (int i = 0; i < 9; i++)
        out[i] = cam.rot[i];
    for (int a = 0; a < 3; a++) {
        out[9 + 2 * a] = (int32_t)(uint32_t)((uint64_t)cam.pos[a] & 0xffffffffu);
        out[10 + 2 * a] = (int32_t)(uint32_t)((uint64_t)cam.pos[a] >> 32);
    }
    out[15] = cam.fx;
    out[16] = cam.fy;
    out[17] = cam.cx;
    out[18] = cam.cy;
    out[19] = cam.width;
    out[20] = cam.height;
    return CNERF_OK;
}

/* Renders a tile of the camera `cam_words` (the layout above) into rgb, with the stream's
 * defaults where n_coarse is 0, else with n_coarse, n_fine, t_stop and flags. stats, when not
 * NULL, gets the work as four uint32: rays, evaluations, and the MACs' low and high words. */
CW_EXPORT(cw_render) int32_t cw_render(const cnerf_decoder *dec, const int32_t *cam_words,
                                       uint32_t n_coarse, uint32_t n_fine, uint32_t t_stop,
                                       uint32_t flags, uint32_t x0, uint32_t y0, uint32_t w,
                                       uint32_t h, uint8_t *rgb, uint32_t stride, void *scratch,
                                       uint32_t scratch_size, uint32_t *stats)
{
    cnerf_camera cam;
    cnerf_render_opts opts;
    cnerf_render_stats st;
    if (!dec || !cam_words)
        return CNERF_E_NULL;
    camera_from_words(&cam, cam_words);
    cnerf_render_defaults(&dec->info, &opts);
    if (n_coarse) {
        opts.n_coarse = (uint16_t)(n_coarse > 0xffffu ? 0xffffu : n_coarse);
        opts.n_fine = (uint16_t)(n_fine > 0xffffu ? 0xffffu : n_fine);
        opts.t_stop = t_stop;
        opts.flags = flags;
    }
    st.rays = st.evals = st.in_bounds = st.macs = st.list_macs = st.list_nz = 0;
    st.samples = st.layer_values = st.exact_rescales = st.wide_macs = st.s8_macs = 0;
    cnerf_status s = cnerf_render_tile_stats(dec, &cam, &opts, x0, y0, w, h, rgb, stride,
                                             scratch, scratch_size, stats ? &st : NULL);
    if (stats) {
        stats[0] = (uint32_t)st.rays;
        stats[1] = (uint32_t)st.evals;
        stats[2] = (uint32_t)(st.macs & 0xffffffffu);
        stats[3] = (uint32_t)(st.macs >> 32);
    }
    return s;
}

/* The status's name, NUL-terminated, at the returned address. */
CW_EXPORT(cw_status_name) const char *cw_status_name(int32_t s)
{
    return cnerf_status_str((cnerf_status)s);
}
