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
    uint64_t total;     /* sum of the above */
} cn_totals;

/* Adds up the categories of a parsed stream; total == info->file_bytes for every
 * stream cnerf_peek accepts. */
void cn_breakdown(const cnerf_info *info, cn_totals *t);

/* Prints the stream's parameters, topology, per-layer table and totals. `buf` is the
 * stream (for the metadata text). */
void cn_print_info(FILE *f, const char *name, const uint8_t *buf, const cnerf_info *info);

const char *cn_role_name(unsigned role);

#endif /* CNERF_ENC_REPORT_H */
