/* The DTU layout's cameras: cameras.npz of IDR, NeuS, VolSDF and MonoSDF (cn_dtu.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <zip.h>

#include "cn_dtu.h"
#include "cn_loader.h"
#include "cn_file.h"

/* A 4x4 array's .npy file is about 200 bytes; an entry that says more is not one. */
#define CN_DTU_ENTRY_MAX 4096

/* A 3x3 matrix whose determinant is at most this fraction of the product of its rows'
 * lengths (its largest possible value) is singular: float32 leaves a singular matrix about
 * 1e-7 of it, and a camera's K R has at least 0.0001 of it unless its field of view is
 * wider than 179 degrees. */
#define CN_DTU_SINGULAR 1e-6

/* A skew (K[0][1]) up to this fraction of fx is dropped; a larger one is refused. */
#define CN_DTU_SKEW_MAX 0.01

/* i when name is PREFIX<i>.npy with i a decimal number without leading zeros, else -1. */
static long mat_index(const char *name, const char *prefix)
{
    const size_t n = strlen(prefix);
    if (!name || strncmp(name, prefix, n) != 0)
        return -1;
    const char *p = name + n;
    long i = 0;
    int digits = 0;
    for (; *p >= '0' && *p <= '9' && digits < 9; p++, digits++)
        i = 10 * i + (*p - '0');
    if (digits == 0 || (digits > 1 && name[n] == '0') || strcmp(p, ".npy") != 0)
        return -1;
    return i;
}

static int cmp_long(const void *a, const void *b)
{
    const long x = *(const long *)a, y = *(const long *)b;
    return x < y ? -1 : x > y;
}

/* The number of views: world_mat_0 ... world_mat_{n-1}, each present once. */
static int count_views(zip_t *za, const char *file, int *n, char *err, size_t errlen)
{
    const zip_int64_t entries = zip_get_num_entries(za, 0);
    long *idx = malloc(sizeof(long) * (size_t)(entries > 0 ? entries : 1));
    if (!idx)
        return cn_fail(err, errlen, "%s: out of memory", file);
    size_t k = 0;
    for (zip_int64_t e = 0; e < entries; e++) {
        const long i = mat_index(zip_get_name(za, (zip_uint64_t)e, ZIP_FL_ENC_RAW), "world_mat_");
        if (i >= 0)
            idx[k++] = i;
    }
    qsort(idx, k, sizeof *idx, cmp_long);
    int rc = 0;
    for (size_t i = 0; rc == 0 && i < k; i++) {
        if (idx[i] < (long)i)
            rc = cn_fail(err, errlen, "%s: world_mat_%ld is in the archive twice", file, idx[i]);
        else if (idx[i] > (long)i)
            rc = cn_fail(err, errlen, "%s: missing world_mat_%zu (there are world_mat_0 to "
                         "world_mat_%ld, with gaps)", file, i, idx[k - 1]);
    }
    if (rc == 0 && k == 0)
        rc = cn_fail(err, errlen, "%s: missing world_mat_0: no cameras (IDR's and NeuS's camera "
                     "files hold world_mat_0, world_mat_1, ... and scale_mat_0, scale_mat_1, ...)",
                     file);
    if (rc == 0 && k > 1000000)
        rc = cn_fail(err, errlen, "%s: %zu cameras, more than the 1000000 that cnerf loads", file,
                     k);
    *n = (int)k;
    free(idx);
    return rc;
}

/* The 4x4 array NAME (the entry NAME.npy) into m: '<f4' or '<f8', C order, finite. */
static int read_mat(zip_t *za, const char *file, const char *name, double m[4][4], char *err,
                    size_t errlen)
{
    char entry[64], what[4200];
    snprintf(entry, sizeof entry, "%s.npy", name);
    snprintf(what, sizeof what, "%s: %s", file, name);
    const zip_int64_t i = zip_name_locate(za, entry, 0);
    if (i < 0)
        return cn_fail(err, errlen, "%s: missing %s", file, name);
    zip_stat_t st;
    if (zip_stat_index(za, (zip_uint64_t)i, 0, &st) != 0 || !(st.valid & ZIP_STAT_SIZE))
        return cn_fail(err, errlen, "%s: cannot read its entry: %s", what, zip_strerror(za));
    if (st.size > CN_DTU_ENTRY_MAX)
        return cn_fail(err, errlen, "%s: %llu bytes, too large for a 4x4 array", what,
                       (unsigned long long)st.size);
    zip_flags_t how = 0;
#ifdef FUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION
    /* fuzzing: a stored entry read raw (its bytes are its data) skips the CRC, so that
     * mutations reach the arrays */
    if ((st.valid & ZIP_STAT_COMP_METHOD) && st.comp_method == ZIP_CM_STORE)
        how = ZIP_FL_COMPRESSED;
#endif
    zip_file_t *zf = zip_fopen_index(za, (zip_uint64_t)i, how);
    if (!zf)
        return cn_fail(err, errlen, "%s: cannot read its entry: %s", what, zip_strerror(za));
    /* Read to the end (one byte more than the entry says), which checks its CRC. */
    uint8_t buf[CN_DTU_ENTRY_MAX + 1];
    zip_int64_t len = 0, got = 0;
    while (len < (zip_int64_t)sizeof buf &&
           (got = zip_fread(zf, buf + len, sizeof buf - (zip_uint64_t)len)) > 0)
        len += got;
    int rc = 0;
    if (got < 0)
        rc = cn_fail(err, errlen, "%s: cannot read its entry: %s", what, zip_file_strerror(zf));
    else if ((zip_uint64_t)len != st.size)
        rc = cn_fail(err, errlen, "%s: the entry holds %lld bytes, the archive's directory says "
                     "%llu", what, (long long)len, (unsigned long long)st.size);
    zip_fclose(zf);
    static const long shape[2] = {4, 4};
    cn_npy a;
    if (rc == 0 && (cn_npy_parse(what, buf, (size_t)len, &a, err, errlen) != 0 ||
                    cn_npy_floats(what, &a, 1, 2, shape, "(4, 4)", err, errlen) != 0))
        rc = -1;
    for (int r = 0; rc == 0 && r < 4; r++)
        for (int c = 0; rc == 0 && c < 4; c++) {
            m[r][c] = cn_npy_at(&a, (size_t)(4 * r + c));
            if (!isfinite(m[r][c]))
                rc = cn_fail(err, errlen, "%s: non-finite value at [%d][%d]", what, r, c);
        }
    return rc;
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static double det3(const double m[3][4])
{
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

/* scale_mat_i: an invertible affine map, the same for every view. */
static int check_scale(const double S[4][4], const double S0[4][4], int i, const char *file,
                       char *err, size_t errlen)
{
    if (S[3][0] != 0 || S[3][1] != 0 || S[3][2] != 0 || S[3][3] != 1)
        return cn_fail(err, errlen, "%s: scale_mat_%d: last row %g %g %g %g, expected 0 0 0 1 "
                       "(an affine map)", file, i, S[3][0], S[3][1], S[3][2], S[3][3]);
    double big = 0, diff = 0;
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++) {
            big = fmax(big, fabs(S0[r][c]));
            diff = fmax(diff, fabs(S[r][c] - S0[r][c]));
        }
    if (diff > 1e-6 * big)
        return cn_fail(err, errlen, "%s: scale_mat_%d differs from scale_mat_0 by up to %g: the "
                       "views must share one normalisation", file, i, diff);
    double m[3][4];
    for (int r = 0; r < 3; r++)
        memcpy(m[r], S[r], sizeof m[r]);
    const double n = sqrt(dot3(m[0], m[0]) * dot3(m[1], m[1]) * dot3(m[2], m[2]));
    if (!(fabs(det3(m)) > CN_DTU_SINGULAR * n))
        return cn_fail(err, errlen, "%s: scale_mat_%d is singular", file, i);
    return 0;
}

/* View i's camera from P = world_mat_i scale_mat_i: its left 3x3 M = K R by an RQ
 * decomposition (Gram-Schmidt from the last row; P negated first when det M < 0, so that
 * R is a rotation and K's diagonal positive), K / K[2][2] the intrinsics, the centre
 * -M^-1 P[:, 3]. The pose is left unscaled. */
static int camera(const double W[4][4], const double S[4][4], int i, const char *file,
                  cn_dtu_cam *cam, char *err, size_t errlen)
{
    double P[3][4];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            P[r][c] = W[r][0] * S[0][c] + W[r][1] * S[1][c] + W[r][2] * S[2][c] + W[r][3] * S[3][c];
    const double det = det3(P);
    const double hadamard = sqrt(dot3(P[0], P[0]) * dot3(P[1], P[1]) * dot3(P[2], P[2]));
    if (!isfinite(det) || !isfinite(hadamard))
        return cn_fail(err, errlen, "%s: world_mat_%d x scale_mat_%d: non-finite (the values "
                       "overflow)", file, i, i);
    if (!(fabs(det) > CN_DTU_SINGULAR * hadamard))
        return cn_fail(err, errlen, "%s: world_mat_%d x scale_mat_%d is singular (its left 3x3 has "
                       "no inverse: not a camera)", file, i, i);
    if (det < 0)
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++)
                P[r][c] = -P[r][c];
    double R[3][3], t[3];
    const double k33 = sqrt(dot3(P[2], P[2]));
    for (int c = 0; c < 3; c++)
        R[2][c] = P[2][c] / k33;
    const double k23 = dot3(P[1], R[2]);
    for (int c = 0; c < 3; c++)
        t[c] = P[1][c] - k23 * R[2][c];
    const double k22 = sqrt(dot3(t, t));
    for (int c = 0; c < 3; c++)
        R[1][c] = t[c] / k22;
    const double k13 = dot3(P[0], R[2]), k12 = dot3(P[0], R[1]);
    for (int c = 0; c < 3; c++)
        t[c] = P[0][c] - k13 * R[2][c] - k12 * R[1][c];
    const double k11 = sqrt(dot3(t, t));
    for (int c = 0; c < 3; c++)
        R[0][c] = t[c] / k11;
    cam->fx = k11 / k33;
    cam->fy = k22 / k33;
    cam->cx = k13 / k33;
    cam->cy = k23 / k33;
    if (fabs(k12 / k33) > CN_DTU_SKEW_MAX * cam->fx)
        return cn_fail(err, errlen, "%s: world_mat_%d: the camera's skew K[0][1] = %g is more than "
                       "%g fx (fx = %g): cnerf's cameras have none", file, i, k12 / k33,
                       CN_DTU_SKEW_MAX, cam->fx);
    /* K y = P[:, 3] by back substitution; the centre is -R^T y */
    double y[3];
    y[2] = P[2][3] / k33;
    y[1] = (P[1][3] - k23 * y[2]) / k22;
    y[0] = (P[0][3] - k12 * y[1] - k13 * y[2]) / k11;
    for (int r = 0; r < 3; r++) {
        cam->c2w[r][0] = R[0][r];
        cam->c2w[r][1] = -R[1][r];
        cam->c2w[r][2] = -R[2][r];
        cam->c2w[r][3] = -(R[0][r] * y[0] + R[1][r] * y[1] + R[2][r] * y[2]);
    }
    int finite = isfinite(cam->fx) && isfinite(cam->fy) && isfinite(cam->cx) && isfinite(cam->cy);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            finite &= isfinite(cam->c2w[r][c]) != 0;
    if (!finite)
        return cn_fail(err, errlen, "%s: world_mat_%d x scale_mat_%d: the camera is not finite",
                       file, i, i);
    return 0;
}

/* Every camera of the archive, normalised: the mean camera distance becomes 4. */
static int cameras(zip_t *za, const char *file, cn_dtu_cam **cams, int *n, char *err,
                   size_t errlen)
{
    if (count_views(za, file, n, err, errlen) != 0)
        return -1;
    if (!(*cams = malloc(sizeof **cams * (size_t)*n)))
        return cn_fail(err, errlen, "%s: out of memory", file);
    double S0[4][4] = {{0}}, dist = 0;
    int rc = 0;
    for (int i = 0; rc == 0 && i < *n; i++) {
        char name[2][32];
        double W[4][4], S[4][4];
        snprintf(name[0], sizeof name[0], "world_mat_%d", i);
        snprintf(name[1], sizeof name[1], "scale_mat_%d", i);
        rc = read_mat(za, file, name[0], W, err, errlen);
        if (rc == 0)
            rc = read_mat(za, file, name[1], S, err, errlen);
        if (rc == 0 && i == 0)
            memcpy(S0, S, sizeof S0);
        if (rc == 0)
            rc = check_scale(S, S0, i, file, err, errlen);
        if (rc == 0)
            rc = camera(W, S, i, file, &(*cams)[i], err, errlen);
        if (rc == 0) {
            const double(*m)[4] = (*cams)[i].c2w;
            dist += sqrt(m[0][3] * m[0][3] + m[1][3] * m[1][3] + m[2][3] * m[2][3]) / *n;
        }
    }
    const double s = 4 / dist;
    if (rc == 0 && !(isfinite(s) && s > 0))
        rc = cn_fail(err, errlen, "%s: the cameras' mean distance from the centre of the "
                     "normalised space is %g: cannot scale it to 4", file, dist);
    for (int i = 0; rc == 0 && i < *n; i++)
        for (int r = 0; r < 3; r++)
            (*cams)[i].c2w[r][3] *= s;
    if (rc != 0) {
        free(*cams);
        *cams = NULL;
    }
    return rc;
}

int cn_dtu_parse(const char *file, const uint8_t *data, size_t len, cn_dtu_cam **cams, int *n,
                 char *err, size_t errlen)
{
    *cams = NULL;
    *n = 0;
    zip_error_t ze;
    zip_error_init(&ze);
    zip_source_t *src = zip_source_buffer_create(len ? data : NULL, len, 0, &ze);
    zip_t *za = src ? zip_open_from_source(src, ZIP_RDONLY | ZIP_CHECKCONS, &ze) : NULL;
    int rc = 0;
    if (!za && zip_error_code_zip(&ze) == ZIP_ER_NOZIP)
        rc = cn_fail(err, errlen, "%s: not a zip archive (np.savez writes .npz files as zip "
                     "archives)", file);
    else if (!za)
        rc = cn_fail(err, errlen, "%s: broken zip archive: %s", file, zip_error_strerror(&ze));
    if (!za && src)
        zip_source_free(src);
    zip_error_fini(&ze);
    if (rc == 0) {
        rc = cameras(za, file, cams, n, err, errlen);
        zip_discard(za);
    }
    if (rc != 0)
        *n = 0;
    return rc;
}

int cn_dtu_read(const char *file, cn_dtu_cam **cams, int *n, char *err, size_t errlen)
{
    uint8_t *data;
    size_t len;
    *cams = NULL;
    *n = 0;
    if (cn_read_file(file, &data, &len, err, errlen) != 0)
        return -1;
    if (cn_input_add(file, "a camera file of the dataset")) {
        free(data);
        return cn_fail(err, errlen, "%s: out of memory", file);
    }
    const int rc = cn_dtu_parse(file, data, len, cams, n, err, errlen);
    free(data);
    return rc;
}
