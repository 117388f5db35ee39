/* The table of broken streams: one row per case, each an edit of one valid base stream
 * with the status cnerf_peek and cnerf_open must return. Shared by tests/unit/test_negative.c
 * and the conformance vectors' generator (tools/make_invalid.c). */
#ifndef CNERF_NEGCASES_H
#define CNERF_NEGCASES_H

#include "cn_buf.h"
#include "cnerf/cnerf.h"

typedef struct chunks chunks;

typedef struct neg_case {
    const char *name;
    void (*edit)(chunks *);
    void (*raw)(cn_buf *);
    cnerf_status peek, open;
    int set;        /* 1: an edit of the two-scene base stream */
    unsigned scene; /* the scene cnerf_peek_scene and cnerf_open_scene are asked for */
} neg_case;

extern const neg_case neg_cases[];
extern const size_t neg_case_count;

/* Makes the base stream (a copy into *out and its info when not NULL); 0 or -1. */
int neg_base_make(cn_buf *out, cnerf_info *info);
void neg_base_free(void);
/* Case i applied to the base stream, into *out (the caller frees it); 0 or -1. */
int neg_build(size_t i, cn_buf *out);

#endif
