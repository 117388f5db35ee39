/* Size breakdown and human-readable description of a stream. */
#ifndef CNERF_ENC_REPORT_H
#define CNERF_ENC_REPORT_H

#include <stdio.h>

#include "cnerf/cnerf.h"

typedef struct cn_totals {
    uint64_t payload;   /* entropy-coded latents */
    uint64_t tables;    /* latent ranges, precisions and frequency tables */
    uint64_t affine;    /* per-layer affine decoders (a, b) */
    uint64_t biases;    /* bias blocks */
    uint64_t layer_hdr; /* layer chunk framing and layer headers */
    uint64_t stream_hdr; /* signature, HEAD, UNIT and DONE chunks */
    uint64_t ancillary; /* ancillary chunks (metadata) */
    uint64_t grid;      /* occupancy grid chunk, framing included */
    uint64_t shared;    /* several scenes: SCNS and the shared SHFT chunks */
    uint64_t total;     /* sum of the above */
} cn_totals;

/* Adds up the categories of a parsed stream (of the scene it describes, and the shared
 * chunks); total == info->file_bytes for every one-scene stream cnerf_peek accepts, and
 * the file's bytes less the other scenes' for a stream of several. */
void cn_breakdown(const cnerf_info *info, cn_totals *t);

/* Prints the stream's parameters, topology, per-layer table and totals for the scene `info`
 * describes, and for a stream of several scenes each scene's size and the shifts' table.
 * `buf` is the stream (for the metadata text and the other scenes). */
void cn_print_info(FILE *f, const char *name, const uint8_t *buf, const cnerf_info *info);

const char *cn_role_name(unsigned role);

#endif /* CNERF_ENC_REPORT_H */
