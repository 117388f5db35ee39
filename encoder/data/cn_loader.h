/*
 * What the dataset loaders share beyond dataset.c (cn_dataset.h), implemented there; internal
 * to the encoder. Host C11.
 */
#ifndef CNERF_ENC_LOADER_H
#define CNERF_ENC_LOADER_H

#include <stddef.h>
#include <stdint.h>

#include "cn_buf.h" /* cn_fail */

/* ---- NumPy .npy arrays of floats, from bytes ---- */

typedef struct cn_npy {
    char descr[16];      /* dtype, e.g. "<f8" */
    int fortran;         /* fortran_order */
    long shape[8];
    int ndim;
    const uint8_t *body; /* the data after the header, body_len bytes */
    size_t body_len;
} cn_npy;

/* The header of a .npy file of version 1.0 or 2.0: magic, version, dictionary. Returns 0,
 * or -1 with "FILE: problem" in err (`file` names the array in messages). */
int cn_npy_parse(const char *file, const uint8_t *d, size_t len, cn_npy *h, char *err,
                 size_t errlen);

/* Checks that a parsed array holds little-endian floats ('<f8', or also '<f4' when f4 is 1)
 * in C order, of `ndim` dimensions with shape[i] == want[i] (want[i] < 0: any size >= 1),
 * and exactly the bytes that shape takes. `expect` describes the shape for the message,
 * e.g. "(N, 17) with N >= 1". Returns 0, or -1 with "FILE: problem" in err. */
int cn_npy_floats(const char *file, const cn_npy *h, int f4, int ndim, const long *want,
                  const char *expect, char *err, size_t errlen);

/* Value i of a checked array, as a double. */
double cn_npy_at(const cn_npy *h, size_t i);

#endif /* CNERF_ENC_LOADER_H */
