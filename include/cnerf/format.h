/*
 * cnerf bitstream v2: constants shared by the encoder and the decoder.
 * docs/bitstream.md is normative; this header mirrors it.
 * Freestanding-safe: includes only <stdint.h>.
 */
#ifndef CNERF_FORMAT_H
#define CNERF_FORMAT_H

#include <stdint.h>

/* File signature: 4 magic bytes, then u16 major, u16 minor (little-endian). */
#define CNERF_MAGIC_0 0x89u
#define CNERF_MAGIC_1 'C'
#define CNERF_MAGIC_2 'N'
#define CNERF_MAGIC_3 'F'
#define CNERF_SIGNATURE_BYTES 8u
#define CNERF_VERSION_MAJOR 2u
/* The newest minor revision this code knows. Version 2.0 changed the layers' arithmetic
 * (int16 inputs at a per-layer scale, LAYR's f_in) and holds the GRID and UNIT chunks that
 * 1.1 and 1.2 added; 1.x streams are refused (CNERF_E_VERSION). 2.1 adds several scenes in
 * one stream (SCNS, SHFT); 2.2 contracted scenes (HEAD coord 2); 2.3 the occupancy grid
 * coded by blocks (BGRD). A writer stamps the lowest minor whose chunks and values its
 * stream holds. */
#define CNERF_VERSION_MINOR 3u
#define CNERF_VERSION_MINOR_SCENES 1u
#define CNERF_VERSION_MINOR_CONTRACT 2u
#define CNERF_VERSION_MINOR_BLOCKS 3u

/* Chunk framing: tag[4], u32 length, payload[length], u32 CRC-32 of tag+payload. */
#define CNERF_CHUNK_OVERHEAD 12u

/* A tag is four ASCII letters; an upper-case first letter marks a critical chunk. */
#define CNERF_TAG(a, b, c, d)                                                              \
    ((uint32_t)(uint8_t)(a) | ((uint32_t)(uint8_t)(b) << 8) | ((uint32_t)(uint8_t)(c) << 16) | \
     ((uint32_t)(uint8_t)(d) << 24))
#define CNERF_TAG_HEAD CNERF_TAG('H', 'E', 'A', 'D')
#define CNERF_TAG_LAYR CNERF_TAG('L', 'A', 'Y', 'R')
#define CNERF_TAG_DONE CNERF_TAG('D', 'O', 'N', 'E')
#define CNERF_TAG_META CNERF_TAG('m', 'e', 't', 'a')
#define CNERF_TAG_GRID CNERF_TAG('G', 'R', 'I', 'D') /* occupancy grid */
#define CNERF_TAG_BGRD CNERF_TAG('B', 'G', 'R', 'D') /* occupancy grid by blocks (2.3) */
#define CNERF_TAG_UNIT CNERF_TAG('U', 'N', 'I', 'T') /* units per layer */
#define CNERF_TAG_SCNS CNERF_TAG('S', 'C', 'N', 'S') /* scene count (2.1) */
#define CNERF_TAG_SHFT CNERF_TAG('S', 'H', 'F', 'T') /* a layer's shared shift (2.1) */
#define CNERF_TAG_LEVL CNERF_TAG('l', 'e', 'v', 'l') /* the stream's level (2.3, ancillary) */

/* Levels (docs/bitstream.md, levl): what a decoder needs for a stream of level L = 1, 2, 3
 * at most. Each caps the workspace (cnerf_workspace_size) and render scratch
 * (cnerf_render_scratch_size) in bytes, the grid's cells per axis, the samples per ray
 * (coarse + fine) and the multiply-accumulates of one evaluation of a network (the sum of
 * n_in n_out over its layers as the stream stores them). With a Cortex-M4 build's decoder
 * state (5,744 bytes) and 2,048 bytes of stack, level 1 needs at most 85,616 bytes of RAM,
 * 2 223,856 and 3 478,832: a 128, 256 and 512 KB part with 32 KB left for the application.
 * Compile-time constants for static arenas; 0 for any other L. */
#define CNERF_MAX_LEVELS 3u
#define CNERF_LEVEL_WORKSPACE(L)                                                         \
    ((L) == 1 ? 73728u : (L) == 2 ? 209920u : (L) == 3 ? 458752u : 0u)
#define CNERF_LEVEL_SCRATCH(L) ((L) == 1 ? 4096u : (L) == 2 ? 6144u : (L) == 3 ? 12288u : 0u)
#define CNERF_LEVEL_GRID(L) ((L) == 1 ? 64u : (L) == 2 || (L) == 3 ? 128u : 0u)
#define CNERF_LEVEL_SAMPLES(L) ((L) == 1 ? 128u : (L) == 2 ? 256u : (L) == 3 ? 512u : 0u)
#define CNERF_LEVEL_MACS(L)                                                              \
    ((L) == 1 ? 32768u : (L) == 2 ? 131072u : (L) == 3 ? 262144u : 0u)

/* Scenes in one stream: 1 without a SCNS chunk, 1..CNERF_MAX_SCENES with one. */
#define CNERF_MAX_SCENES 255u
/* SHFT: net, index, n_in, n_out, g (m24e8), smin, smax before the table. */
#define CNERF_SHFT_FIXED_BYTES 14u

/* GRID: g^3 cells over the scene bounds, coded bit by bit with binary rANS under
 * CNERF_GRID_CONTEXTS contexts (the left, front and lower neighbours). */
#define CNERF_MAX_GRID 128u
#define CNERF_GRID_CONTEXTS 8u
#define CNERF_GRID_FIXED_BYTES (2u + 2u * CNERF_GRID_CONTEXTS)
/* BGRD (2.3): the same cells, grouped in blocks of CNERF_GRID_BLOCK^3: first one bit per
 * block (any cell occupied), then the cells of the occupied blocks only, each level with
 * its own CNERF_GRID_CONTEXTS frequencies. Fixed fields: g, prec, u16 occupied blocks, the
 * blocks' and the cells' frequencies. */
#define CNERF_GRID_BLOCK 8u
#define CNERF_BGRD_FIXED_BYTES (4u + 4u * CNERF_GRID_CONTEXTS)

/* HEAD payload size in bytes (fixed layout, see docs/bitstream.md). */
#define CNERF_HEAD_FIXED_BYTES 44u
#define CNERF_HEAD_NET_BYTES 6u

/* Coordinate systems. */
#define CNERF_COORD_WORLD 0u /* 360-degree scene, rays in world space between near and far */
#define CNERF_COORD_NDC 1u   /* forward-facing scene, rays in normalized device coordinates */
#define CNERF_COORD_CONTRACT 2u /* 360-degree scene with a background: the inner half of the
                                   bounds as in world space, all space beyond it contracted
                                   into the outer half (format 2.2, docs/rendering.md) */
/* Contracted scenes: rays are sampled in s in [0, 2 - 2^-CONTRACT_SHIFT]; t = near + s L on
 * [0, 1] and near + L / (2 - s) beyond (L = far - near), so the last sample lies at
 * near + 2^CONTRACT_SHIFT L. */
#define CNERF_CONTRACT_SHIFT 6u

/* Positional-encoding flags. */
#define CNERF_PE_INCLUDE_INPUT 0x01u

/* Skip field value meaning "no skip connection". */
#define CNERF_NO_SKIP 0xFFu

/* Limits, checked before any size is computed. */
#define CNERF_MAX_NETS 2u
#define CNERF_MAX_DEPTH 16u
#define CNERF_MAX_WIDTH 1024u
#define CNERF_MAX_VIEW_WIDTH 1024u
#define CNERF_MAX_L_POS 16u
#define CNERF_MAX_L_DIR 8u
#define CNERF_MAX_SAMPLES 1024u
#define CNERF_MAX_LAYERS_PER_NET (CNERF_MAX_DEPTH + 4u)
#define CNERF_MAX_LAYERS (CNERF_MAX_NETS * CNERF_MAX_LAYERS_PER_NET)
#define CNERF_MAX_IN_POS (3u + 6u * CNERF_MAX_L_POS)
#define CNERF_MAX_IN_DIR (3u + 6u * CNERF_MAX_L_DIR)
/* Widest layer input: trunk width plus the skip's encoded position. */
#define CNERF_MAX_LAYER_IN (CNERF_MAX_WIDTH + CNERF_MAX_IN_POS)
#define CNERF_MAX_LAYER_PARAMS ((uint32_t)CNERF_MAX_LAYER_IN * CNERF_MAX_WIDTH)

/* Integer latents k satisfy |k| <= CNERF_MAX_ABS_K. */
#define CNERF_MAX_ABS_K 32767
/* Frequency tables sum to 2^prec with 1 <= prec <= CNERF_MAX_PREC. */
#define CNERF_MAX_PREC 16u
/* Exp-Golomb order of a frequency table: 0 .. CNERF_MAX_EG_ORDER. */
#define CNERF_MAX_EG_ORDER 15u

/* m24e8 scalars (affine decoder a, b): value = m * 2^e, |m| < 2^23, e in [EXP_MIN, EXP_MAX]. */
#define CNERF_M24_ABS_MAX 8388607
#define CNERF_EXP_MIN (-64)
#define CNERF_EXP_MAX 63
/* A layer's input scale: its inputs enter the sums as int16 x_q = sat16(round(x 2^f_in)),
 * CNERF_F_MIN <= f_in <= CNERF_F_MAX (docs/fixed-point.md). */
#define CNERF_F_MIN (-15)
#define CNERF_F_MAX 16
/* Bias blocks: nbits-bit two's-complement mantissas with one shared exponent. */
#define CNERF_MAX_BIAS_BITS 24u

/* rANS: 32-bit state, byte-wise renormalisation, lower bound of the normalised interval. */
#define CNERF_RANS_L (1u << 23)

/* Coordinates (near, far, bounding box) are Q16.16 signed. */
#define CNERF_Q16_ONE 65536

/* Layer roles, in the order the layers of one network appear in the stream. */
enum cnerf_role {
    CNERF_ROLE_TRUNK = 0,   /* ReLU(W x + b), x = previous output (or [PE(x), h] after the skip) */
    CNERF_ROLE_SIGMA = 1,   /* density: W h + b, one output; ReLU applied by the renderer */
    CNERF_ROLE_FEATURE = 2, /* feature: W h + b, no activation */
    CNERF_ROLE_VIEW = 3,    /* ReLU(W [feature, PE(d)] + b) */
    CNERF_ROLE_RGB = 4,     /* sigmoid(W v + b), three outputs */
    CNERF_ROLE_OUTPUT = 5   /* without a view branch: W h + b -> (r, g, b, sigma) */
};

#endif /* CNERF_FORMAT_H */
