/* Writes the broken-stream table (tests/support/negcases.c) as conformance vectors:
 *   make_invalid INVALID_DIR VALID_DIR
 * INVALID_DIR/NNN-<case>.cnrf for every case that cnerf_open must refuse, and
 * INVALID_DIR/expected.txt with one line per file: name, the status of cnerf_peek, the status
 * of cnerf_open, "scene=N" when the case opens scene N of a set, the case. The cases that must be accepted (a newer minor version, an unknown
 * ancillary chunk) go to VALID_DIR/<case>.cnrf. */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_buf.h"
#include "cn_file.h"
#include "negcases.h"

static void slug(const char *name, char *out, size_t n)
{
    size_t k = 0;
    for (const char *p = name; *p && k + 1 < n; p++) {
        if (isalnum((unsigned char)*p))
            out[k++] = (char)tolower((unsigned char)*p);
        else if (k && out[k - 1] != '-')
            out[k++] = '-';
    }
    while (k && out[k - 1] == '-')
        k--;
    out[k] = 0;
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: make_invalid INVALID_DIR VALID_DIR\n");
        return 2;
    }
    if (neg_base_make(NULL, NULL)) {
        fprintf(stderr, "make_invalid: cannot make the base stream\n");
        return 1;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/expected.txt", argv[1]);
    FILE *list = fopen(path, "w");
    if (!list) {
        perror(path);
        return 1;
    }
    fprintf(list, "# file  status of cnerf_peek  status of cnerf_open  # what is broken\n");
    int rc = 0, n = 0;
    for (size_t i = 0; i < neg_case_count && rc == 0; i++) {
        const neg_case *t = &neg_cases[i];
        cn_buf b;
        char s[128], name[200], err[256];
        if (neg_build(i, &b)) {
            fprintf(stderr, "make_invalid: case %zu\n", i);
            rc = 1;
            break;
        }
        slug(t->name, s, sizeof s);
        if (t->open == CNERF_OK)
            snprintf(name, sizeof name, "%s.cnrf", s);
        else
            snprintf(name, sizeof name, "%03zu-%s.cnrf", i + 1, s);
        snprintf(path, sizeof path, "%s/%s", argv[t->open == CNERF_OK ? 2 : 1], name);
        if (cn_write_file_atomic(path, b.p ? b.p : (const uint8_t *)"", b.n, err, sizeof err)) {
            fprintf(stderr, "make_invalid: %s\n", err);
            rc = 1;
        } else if (t->open != CNERF_OK) {
            if (t->scene)
                fprintf(list, "%s %s %s scene=%u  # %s\n", name, cnerf_status_str(t->peek),
                        cnerf_status_str(t->open), t->scene, t->name);
            else
                fprintf(list, "%s %s %s  # %s\n", name, cnerf_status_str(t->peek),
                        cnerf_status_str(t->open), t->name);
            n++;
        }
        cn_buf_free(&b);
    }
    neg_base_free();
    if (fclose(list) != 0)
        rc = 1;
    if (rc == 0)
        printf("make_invalid: %d broken streams in %s\n", n, argv[1]);
    return rc;
}
