/*
 * cnerf decoder API: freestanding, allocation-free.
 *
 *   cnerf_info info;
 *   cnerf_peek(buf, len, &info);                 -- parse and validate the structure
 *   size_t n = cnerf_workspace_size(&info);      -- bytes of caller memory needed
 *   cnerf_open(&dec, buf, len, ws, n);           -- decode latents into that memory
 *
 * Nothing is allocated and nothing global is written. The decoder keeps pointers into
 * the caller's workspace; `buf` is not referenced after cnerf_open returns.
 * Includes only <stdint.h>, <stddef.h> (via format.h and here).
 */
#ifndef CNERF_CNERF_H
#define CNERF_CNERF_H

#include <stddef.h>
#include <stdint.h>

#include "cnerf/format.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Status codes: 0 is success, errors are negative and never renumbered. */
typedef enum cnerf_status {
    CNERF_OK = 0,
    CNERF_E_NULL = -1,          /* API misuse: a required pointer is NULL */
    CNERF_E_ARG = -2,           /* API misuse: an argument is out of range */
    CNERF_E_WS_ALIGN = -3,      /* workspace not aligned to CNERF_WS_ALIGN */
    CNERF_E_WS_SMALL = -4,      /* workspace smaller than cnerf_workspace_size() */
    CNERF_E_TRUNCATED = -5,     /* the stream ends before its DONE chunk */
    CNERF_E_MAGIC = -6,         /* not a cnerf stream */
    CNERF_E_VERSION = -7,       /* unsupported major version */
    CNERF_E_CRC = -8,           /* a chunk's CRC-32 does not match */
    CNERF_E_CHUNK_ORDER = -9,   /* HEAD not first, duplicate HEAD, missing or extra layers */
    CNERF_E_UNKNOWN_CHUNK = -10, /* a critical chunk this decoder does not know */
    CNERF_E_LIMIT = -11,        /* a dimension exceeds the format's limits */
    CNERF_E_HEADER = -12,       /* header fields inconsistent (near >= far, bad flags, ...) */
    CNERF_E_LAYER = -13,        /* layer shape or index disagrees with the topology */
    CNERF_E_RANGE = -14,        /* latent range invalid (kmin > kmax, |k| too large) */
    CNERF_E_TABLE = -15,        /* frequency table invalid (precision, zero or excess mass) */
    CNERF_E_PAYLOAD = -16,      /* entropy-coded payload inconsistent with its table */
    CNERF_E_TRAILING = -17,     /* bytes after the DONE chunk */
    CNERF_E_FORMAT = -18,       /* a number-format field out of range (exponent, bit count) */
    CNERF_E_CHUNK = -19,        /* a chunk's length disagrees with its content, or a bad tag */
    CNERF_E_OVERFLOW = -20,     /* a value could overflow the renderer's accumulators */
    CNERF_E_BUF_SMALL = -21,    /* an output buffer is too small */
    /* Packed images (cnerf_open_packed): */
    CNERF_E_IMAGE_ALIGN = -22,   /* the image is not aligned to CNERF_WS_ALIGN */
    CNERF_E_IMAGE_VERSION = -23, /* an image of another decoder version (CNERF_IMAGE_VERSION) */
    CNERF_E_IMAGE_TARGET = -24,  /* an image for other kernels (another core) or byte order */
    CNERF_E_IMAGE_CRC = -25,     /* the image's CRC-32 does not match */
    CNERF_E_IMAGE = -26,         /* the image's contents disagree with its stream or bounds */
    /* Levels (format.h, CNERF_MAX_LEVEL): */
    CNERF_E_LEVEL = -27,        /* the stream's level is above this decoder's, or it has none */
    CNERF_E_LEVEL_EXCEEDED = -28 /* the stream needs more than the level it declares */
} cnerf_status;

/* A decoder for streams of level CNERF_MAX_LEVEL and below (1 .. CNERF_MAX_LEVELS; define it
 * when compiling the decoder): it refuses any other stream with CNERF_E_LEVEL, and a static
 * workspace of CNERF_LEVEL_WORKSPACE(CNERF_MAX_LEVEL) bytes opens every stream it accepts.
 * 0, the default: streams of any level, or none. */
#ifndef CNERF_MAX_LEVEL
#define CNERF_MAX_LEVEL 0
#endif

/* Workspace alignment in bytes. */
#define CNERF_WS_ALIGN 8u

typedef struct cnerf_net_info {
    uint8_t depth;       /* trunk layers, 1..CNERF_MAX_DEPTH */
    uint8_t skip;        /* trunk layer after which PE(x) is concatenated, or CNERF_NO_SKIP */
    uint16_t width;      /* trunk width, 1..CNERF_MAX_WIDTH */
    uint16_t view_width; /* view-branch width; 0 = no view branch */
    uint8_t n_layers;    /* linear layers of this network */
    uint8_t first_layer; /* index of its first layer in cnerf_info.layer[] */
    /* Units (outputs) of each trunk layer and of the view layer: width and view_width
     * unless the stream's UNIT chunk (minor >= 2) removed some. 0 reads as the full width;
     * cnerf_expand_topology writes the effective values back. */
    uint16_t units[CNERF_MAX_DEPTH];
    uint16_t view_units;
} cnerf_net_info;

typedef struct cnerf_layer_info {
    uint8_t net;   /* 0 = coarse, 1 = fine */
    uint8_t index; /* layer index within the network */
    uint8_t role;  /* enum cnerf_role */
    int8_t f_in;   /* input scale: inputs enter the sums as sat16(round(x 2^f_in)) */
    uint16_t n_in, n_out;
    int32_t a_m, b_m; /* affine decoder W = a*k + b, a = a_m * 2^a_e, b = b_m * 2^b_e */
    int8_t a_e, b_e;
    int8_t bias_e;     /* bias_j = bias_m[j] * 2^bias_e */
    uint8_t bias_bits; /* bits per bias mantissa, 0 = all biases are zero */
    int32_t kmin, kmax; /* latent range; kmin == kmax codes nothing */
    uint8_t prec;       /* frequency-table precision in bits (0 when kmin == kmax) */
    uint8_t eg_order;   /* Exp-Golomb order of the coded table */
    /* Where the layer lives in the stream, and its size breakdown in bytes.
     * chunk_bytes = CNERF_CHUNK_OVERHEAD + header + affine + bias + table + payload. */
    uint32_t chunk_offset, chunk_bytes;
    uint32_t header_bytes, affine_bytes, bias_bytes, table_bytes, payload_bytes;
    uint32_t table_offset, bias_offset, payload_offset; /* absolute offsets in the stream */
} cnerf_layer_info;

/* A layer's shift shared by every scene of a stream (SHFT chunk, several-scene streams):
 * the kernel of each scene gains g s[o][i], g = g_m 2^g_e, with the integer shifts s coded
 * like latents (range smin..smax, table, rANS payload). smin = smax = 0: no shift (always,
 * in a one-scene stream). */
typedef struct cnerf_shift_info {
    int32_t g_m;
    int8_t g_e;
    uint8_t prec, eg_order; /* table precision (0 when smin == smax), Exp-Golomb order */
    int32_t smin, smax;
    uint32_t chunk_offset, chunk_bytes; /* the SHFT chunk, framing included */
    uint32_t table_offset, payload_offset, payload_bytes;
} cnerf_shift_info;

typedef struct cnerf_info {
    uint16_t version_major, version_minor;
    /* Scenes in the stream (1..CNERF_MAX_SCENES; SCNS chunk), and the one whose render parameters,
     * grid and layers this struct describes (cnerf_peek_scene). The topology is the same
     * for every scene. */
    uint8_t n_scenes, scene;
    uint8_t coord;      /* CNERF_COORD_WORLD or CNERF_COORD_NDC */
    uint8_t l_pos;      /* position encoding octaves */
    uint8_t l_dir;      /* direction encoding octaves */
    uint8_t pe_flags;   /* CNERF_PE_* */
    int32_t near_q16, far_q16;
    int32_t aabb_q16[6]; /* scene bounds: min x, y, z, max x, y, z */
    uint8_t background[3];
    uint8_t n_nets;     /* 1 (coarse only) or 2 (coarse + fine) */
    uint16_t n_coarse, n_fine;
    uint16_t in_pos, in_dir; /* encoded input widths */
    cnerf_net_info net[CNERF_MAX_NETS];
    uint32_t n_layers;
    uint32_t n_params; /* kernel parameters (latents) in all layers */
    uint32_t n_biases;
    cnerf_layer_info layer[CNERF_MAX_LAYERS];
    /* Size breakdown of the whole stream in bytes. */
    uint32_t file_bytes;      /* bytes up to and including DONE */
    uint32_t signature_bytes; /* magic + version */
    uint32_t head_bytes;      /* HEAD chunk including framing */
    uint32_t ancillary_bytes; /* all ancillary chunks including framing */
    uint32_t done_bytes;      /* DONE chunk */
    uint32_t meta_offset, meta_len; /* first 'meta' chunk's payload (text), 0 if none */
    uint8_t level; /* the level the stream declares (levl chunk, 2.3), 0: none */
    /* Occupancy grid (GRID chunk, minor >= 1, or BGRD, minor >= 3): grid_g^3 cells over the scene bounds, x
     * fastest; a sample in an empty cell has density 0 and is not evaluated. grid_g = 0:
     * no grid (every cell occupied). */
    uint8_t grid_g;
    uint8_t grid_prec;                          /* probability precision in bits */
    uint8_t grid_by_blocks;                     /* 1: a BGRD chunk (2.3), 0: GRID */
    uint16_t grid_blocks; /* BGRD: occupied blocks of CNERF_GRID_BLOCK^3 cells */
    uint16_t grid_f1[CNERF_GRID_CONTEXTS];      /* frequency of "occupied" per context */
    uint16_t grid_fb1[CNERF_GRID_CONTEXTS];     /* BGRD: the same for the blocks */
    uint32_t grid_bytes;                        /* GRID or BGRD chunk including framing */
    uint32_t grid_payload_offset, grid_payload_bytes;
    /* UNIT chunk (minor >= 2) including framing; 0 when every layer has its full width. */
    uint32_t unit_bytes;
    /* Several scenes: this scene's own chunks (HEAD, GRID, LAYR; framing included), and the
     * shared ones (SCNS, SHFT); a one-scene stream has shared_bytes 0. */
    uint32_t scene_bytes, shared_bytes;
    uint32_t n_shift_params; /* shift latents of the layers that have a shift */
    cnerf_shift_info shift[CNERF_MAX_LAYERS];
} cnerf_info;

/* Bytes of cnerf_decoder's opaque part: per layer five pointers and eight bytes, four
 * pointers and eight bytes besides, and room for eight pointers more (a compile-time check
 * in decoder/open.c keeps the state within it). */
#define CNERF_DECODER_OPAQUE_BYTES                                                         \
    ((size_t)CNERF_MAX_LAYERS * (5u * sizeof(void *) + 8u) + 12u * sizeof(void *) + 8u)

/* A decoder: cnerf_open fills it. `info` describes the stream and is for reading. The
 * opaque part holds the decoded layers' addresses in the workspace, the kernels chosen for
 * this CPU and the occupancy grid: it is the decoder's own, its layout is not an interface
 * and changes between versions. Its size is public so that firmware can allocate a
 * cnerf_decoder statically (sizeof(cnerf_decoder), a compile-time constant). */
typedef struct cnerf_decoder {
    cnerf_info info;
    union {
        void *align_pointer;
        uint64_t align_integer;
        unsigned char bytes[CNERF_DECODER_OPAQUE_BYTES];
    } opaque;
} cnerf_decoder;

/* Parses and validates the whole structure (signature, every chunk's CRC, header, layer
 * shapes, ranges and tables, every scene's) without decoding payloads, and describes
 * scene 0. buf may be NULL when len is 0 (an empty stream: CNERF_E_TRUNCATED). */
cnerf_status cnerf_peek(const uint8_t *buf, size_t len, cnerf_info *info);
/* The same, describing scene `scene` (CNERF_E_ARG when the stream has no such scene; then
 * info->n_scenes still tells how many it has). */
cnerf_status cnerf_peek_scene(const uint8_t *buf, size_t len, uint32_t scene,
                              cnerf_info *info);

/* Workspace bytes cnerf_open needs for this stream (0 if info is NULL). */
size_t cnerf_workspace_size(const cnerf_info *info);

/* Workspace bytes with which cnerf_open keeps every latent as int16 (0 if info is NULL):
 * cnerf_workspace_size stores a layer whose latents fit int8 as int8, and on cores whose
 * int8 sums cost more (the DSP extension's: Cortex-M4, M7, M33; Advanced SIMD) a workspace
 * of at least this size buys the int16 sums' speed (docs/decoder.md, Memory). The pixels
 * are the same either way; like cnerf_workspace_size it depends on the stream alone. */
size_t cnerf_workspace_size_fast(const cnerf_info *info);

/* Upper bound of cnerf_workspace_size over all streams whose layers are at most
 * `params` latents and `outputs` biases in total, with at most `layers` layers and an
 * occupancy grid of at most `grid` cells per axis (0: streams without a grid; the grid takes
 * at most 76 bytes per block of 8^3 cells and 24 more, every block counted as occupied);
 * for static arrays (a compile-time constant when the arguments are). */
#define CNERF_WORKSPACE_BOUND(params, outputs, layers, grid)                             \
    ((size_t)(params) * 2u + (size_t)(outputs) * 12u + (size_t)(layers) * 32u +            \
     ((size_t)65536u + 1u) * 4u + 16u +                                                    \
     (((size_t)(grid) + 7u) / 8u) * (((size_t)(grid) + 7u) / 8u) *                         \
         (((size_t)(grid) + 7u) / 8u) * 76u + 24u)

/* The bound for streams of several scenes: one scene's latents and the shared shifts. */
#define CNERF_WORKSPACE_BOUND_SCENES(params, outputs, layers, grid)                      \
    (CNERF_WORKSPACE_BOUND(params, outputs, layers, grid) + (size_t)(params) * 2u +        \
     (size_t)(layers) * 8u)

/* Decodes the stream's scene 0 into `ws` (aligned to CNERF_WS_ALIGN, at least
 * cnerf_workspace_size() bytes). On error `dec` is left zeroed. */
cnerf_status cnerf_open(cnerf_decoder *dec, const uint8_t *buf, size_t len, void *ws,
                        size_t ws_size);
/* The same for scene `scene` (cnerf_workspace_size of cnerf_peek_scene's info): the
 * workspace holds that scene's latents and the shared shifts, never another scene's. */
cnerf_status cnerf_open_scene(cnerf_decoder *dec, const uint8_t *buf, size_t len,
                              uint32_t scene, void *ws, size_t ws_size);

/* Fills info->layer[] shapes and roles and info->net[].n_layers/first_layer, in_pos,
 * in_dir, n_layers, n_params and n_biases from the topology fields.
 * Returns CNERF_E_LIMIT or CNERF_E_HEADER for an invalid topology. */
cnerf_status cnerf_expand_topology(cnerf_info *info);

/* Latent k[o][i] of layer `l` (0 out of range); searches the layer's row order: for tools
 * and tests, not for rendering. */
int32_t cnerf_latent(const cnerf_decoder *dec, uint32_t l, uint32_t o, uint32_t i);
/* Shift s[o][i] of layer `l` (0 out of range or without a shift); as cnerf_latent. */
int32_t cnerf_shift(const cnerf_decoder *dec, uint32_t l, uint32_t o, uint32_t i);
/* Bias mantissa of output `o` of layer `l` (the bias is b 2^bias_e; 0 out of range). */
int32_t cnerf_bias(const cnerf_decoder *dec, uint32_t l, uint32_t o);
/* 1 when the occupancy grid's cell `c` (x fastest, then y, then z) is occupied, 0 when it is
 * empty or out of range; 1 for every cell of a stream without a grid. */
int cnerf_cell_occupied(const cnerf_decoder *dec, uint32_t c);

/* ---- rendering (decoder/render.c; formats and error analysis in docs/fixed-point.md) ---- */

/* A pinhole camera in fixed point. Camera-to-world rotation with OpenGL axes (x right, y up,
 * looking down -z), row-major in Q30 (|entry| <= 2^30); the camera centre in world units in
 * Q32; intrinsics in pixels in Q16. cnerf_camera_from_float (host side, encoder library)
 * builds one from doubles. */
typedef struct cnerf_camera {
    int32_t rot[9];
    int64_t pos[3];
    int32_t fx, fy, cx, cy;
    uint16_t width, height;
} cnerf_camera;

/* A camera at `eye` looking at `target`, turned so that `up` points up in the image (eye,
 * target and up in Q16 scene units), with the horizontal field of view fov_x_q16 (degrees,
 * Q16, from CNERF_FOV_MIN_Q16 to CNERF_FOV_MAX_Q16), square pixels and the principal point at
 * the image's centre, in integers only (the same camera on every core). CNERF_E_ARG for a
 * camera that cannot be made: eye equal to target, a zero up or one within about a degree
 * of the view direction, a zero width or height, a field of view out of range. The
 * renderer also needs the vertical field of view, which follows from the height, within
 * about 127 degrees (cnerf_render_tile refuses the camera otherwise). */
#define CNERF_FOV_MIN_Q16 (1 << 16)
#define CNERF_FOV_MAX_Q16 (120 << 16)
cnerf_status cnerf_camera_look_at(cnerf_camera *cam, const int32_t eye[3],
                                  const int32_t target[3], const int32_t up[3],
                                  int32_t fov_x_q16, uint16_t width, uint16_t height);

/* Speed-versus-error knobs; cnerf_render_defaults gives the quality setting. */
typedef struct cnerf_render_opts {
    uint16_t n_coarse; /* 1 .. the stream's n_coarse */
    uint16_t n_fine;   /* 0 .. the stream's n_fine; 0 renders the coarse network's image
                          (when it carries colour: cnerf_net_has_color) */
    uint32_t t_stop;   /* early ray termination: stop a ray once its transmittance is below
                          t_stop / 2^30 (the rest of the ray shows the background); 0 = never */
    uint32_t flags;    /* CNERF_RENDER_* */
} cnerf_render_opts;

/* Ignore the stream's occupancy grid: evaluate the networks at every sample inside the
 * bounds (the image a decoder without grid support would make; for comparisons only). */
#define CNERF_RENDER_NO_SKIP 1u
/* Examine every sample: rule out no stretch of a ray before marching it (the same image and
 * the same work counted, more instructions; for tests of that exactness). */
#define CNERF_RENDER_EVERY_SAMPLE 2u
/* Output RGB565 instead of RGB888: 2 bytes per pixel, the 16-bit value
 * r5 << 11 | g6 << 5 | b5 stored low byte first, where each field is the RGB888 value c
 * rounded to the nearest of its levels, (c (2^n - 1) + 127) / 255 with n = 5, 6, 5 bits
 * (docs/rendering.md, Output). The pixels are those of the RGB888 image, converted. */
#define CNERF_RENDER_RGB565 4u
/* The same value stored high byte first, as SPI displays take it. Not with
 * CNERF_RENDER_RGB565 (CNERF_E_ARG). */
#define CNERF_RENDER_RGB565_BE 8u

/* Work counters of cnerf_render_tile_stats, added to what the caller's struct holds. */
typedef struct cnerf_render_stats {
    uint64_t rays;      /* rays rendered */
    uint64_t evals;     /* network evaluations, both networks */
    uint64_t in_bounds; /* samples inside the scene bounds and before early termination:
                           the evaluations at the same sample positions without the grid.
                           Counting them costs what ruling out empty stretches of rays saves:
                           time a render without stats */
    uint64_t macs;      /* network multiply-accumulates (latent times activation) over the
                           rows that have a non-zero latent, zeros included: the same for every
                           CPU, whether a layer is summed packed or from lists of its non-zero
                           latents (docs/decoder.md, Zero latents); rows whose latents are all
                           zero and colour branches skipped because the sample adds nothing
                           to the image are not counted */
    uint64_t list_macs; /* of macs, those of the layers that cnerf_open stored as lists of
                           their non-zero latents for this CPU's kernels */
    uint64_t list_nz;   /* the multiplications those layers did: their non-zero latents (the
                           rest of list_macs multiplied zeros and was not done) */
    /* The rest of the work, for cost models (docs/decoder.md, Predicted cost): */
    uint64_t samples;   /* sample positions computed (rays before they end, in stretches not
                           ruled out): each one's point, contraction and grid cell */
    uint64_t layer_values; /* over every layer evaluated, its inputs quantized plus its
                              outputs formed */
    uint64_t exact_rescales; /* of those outputs, the ones rescaled by the exact 64-bit product
                                (the heads, shared shifts, layers whose fast rescale cnerf_open
                                could not prove) */
    uint64_t wide_macs; /* of macs, those summed in int64 (layers and shifts whose int32 bound
                           cnerf_open could not prove) */
    uint64_t s8_macs;   /* of macs, those of packed int32 sums over latents stored as int8
                           (a layer whose latent range fits int8); the other packed ones are
                           over int16 */
} cnerf_render_stats;

/* The default early ray termination, round(0.01 2^30): a ray ends once 1% of its light is
 * left, which changes a colour by at most 1% of the range. Measured by
 * experiments/t_stop.sh (docs/decoder.md, Early ray termination): 9% fewer instructions
 * than 2^30 / 4096 on Lego and a real capture for the same PSNR to 0.01 dB. */
#define CNERF_T_STOP_DEFAULT 10737418u

/* The stream's sample counts and t_stop = CNERF_T_STOP_DEFAULT. */
void cnerf_render_defaults(const cnerf_info *info, cnerf_render_opts *opts);

/* 1 when network `net` gives colour, 0 when it carries none: its rgb layer's kernel and
 * biases are all zero (kmin = kmax, a kmin + b = 0, no biases, no shift; docs/bitstream.md
 * §5). An encoder writes the coarse network's colour so when the fine network shows every
 * pixel; cnerf_render_tile then refuses n_fine = 0 (CNERF_E_ARG). A network without a view
 * branch always gives colour (its one output layer gives density too). */
int cnerf_net_has_color(const cnerf_info *info, unsigned net);

/* Caller scratch bytes that cnerf_render_tile needs for this stream with any options
 * (8-byte aligned, like the workspace). */
size_t cnerf_render_scratch_size(const cnerf_info *info);

/* Renders the tile x0 <= x < x0 + w, y0 <= y < y0 + h of `cam`'s image into rgb (RGB888,
 * or RGB565 with CNERF_RENDER_RGB565 or _BE in opts->flags; `stride` bytes between rows,
 * at least w * 3, or w * 2, else CNERF_E_BUF_SMALL; the tile's first pixel at rgb[0]).
 * opts NULL = defaults. The result is the same bits on every platform. */
cnerf_status cnerf_render_tile(const cnerf_decoder *dec, const cnerf_camera *cam,
                               const cnerf_render_opts *opts, uint32_t x0, uint32_t y0,
                               uint32_t w, uint32_t h, uint8_t *rgb, size_t stride,
                               void *scratch, size_t scratch_size);

/* cnerf_render_tile that also adds its work to *stats (NULL: not counted). */
cnerf_status cnerf_render_tile_stats(const cnerf_decoder *dec, const cnerf_camera *cam,
                                     const cnerf_render_opts *opts, uint32_t x0, uint32_t y0,
                                     uint32_t w, uint32_t h, uint8_t *rgb, size_t stride,
                                     void *scratch, size_t scratch_size,
                                     cnerf_render_stats *stats);

/* ---- packed images: the workspace decoded ahead of time and read in place ----
 * cnerf_pack (cnerf/tools.h, `cnerf pack`) writes, for one kind of core, the workspace that
 * cnerf_open would build, behind a header and followed by the stream itself
 * (docs/decoder.md, "Rendering from flash"). cnerf_open_packed maps such an image where it
 * lies, for example in memory-mapped flash: the decoder then reads its latents, biases and
 * grid from the image, and needs no workspace. Rendering from it gives the same bytes as
 * rendering from the stream. The image must be aligned to CNERF_WS_ALIGN and must stay in
 * place, unchanged, while `dec` is used. */
#define CNERF_IMAGE_VERSION 2u      /* changes whenever the workspace's layout does */
#define CNERF_IMAGE_HEADER_BYTES 48u

/* Opens the image[0..len) (len may exceed the image, for a flash partition): checks its
 * alignment (CNERF_E_IMAGE_ALIGN), its version (CNERF_E_IMAGE_VERSION), that it was packed
 * for this build's kernels and byte order (CNERF_E_IMAGE_TARGET) and its CRC-32
 * (CNERF_E_IMAGE_CRC); parses the stream inside it (its own statuses); then checks every
 * layer's stored rows and lists against the stream and proves their sums' bounds again from
 * the image's latents (CNERF_E_IMAGE), as cnerf_open does from the stream's. On error `dec`
 * is left zeroed. */
cnerf_status cnerf_open_packed(cnerf_decoder *dec, const uint8_t *image, size_t len);

/* CRC-32 (ISO-HDLC, as zlib and PNG) of `len` bytes, continuing from `crc` (start at 0). */
uint32_t cnerf_crc32(uint32_t crc, const uint8_t *p, size_t len);

#ifndef CNERF_NO_STATUS_STRINGS
/* Name of a status ("CNERF_E_CRC"); define CNERF_NO_STATUS_STRINGS to compile it out. */
const char *cnerf_status_str(cnerf_status s);
#endif

#ifdef __cplusplus
}
#endif

#endif /* CNERF_CNERF_H */
