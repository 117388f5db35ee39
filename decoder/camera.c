/* cnerf_camera_look_at: a camera from integer eye, target and up vectors and a field of
 * view, in integers only (cnerf.h; docs/decoder.md, "Cameras on the device"). */
#include "../common/cn_fixed.h"
#include "cn_internal.h"
#include "cn_tables.h"

#define LOOK_MIN_SIN_Q30 ((int64_t)1 << 23) /* up at least ~0.45 degrees off the view */

/* v / |v| in Q30 per axis (|v_a| < 2^62); 0 when v is zero. The vector is first scaled by a
 * power of two to put its largest axis in [2^29, 2^30): the sum of squares stays below 2^62,
 * and its square root has 29 bits or more. */
static int unit_q30(const int64_t v[3], int32_t u[3])
{
    int64_t w[3];
    uint64_t m = 0;
    for (unsigned a = 0; a < 3; a++) {
        w[a] = v[a];
        m = cn_abs64(v[a]) > m ? cn_abs64(v[a]) : m;
    }
    if (m == 0)
        return 0;
    while (m >= ((uint64_t)1 << 30)) {
        for (unsigned a = 0; a < 3; a++)
            w[a] = cn_asr64(w[a], 1);
        m >>= 1;
    }
    while (m < ((uint64_t)1 << 29)) {
        for (unsigned a = 0; a < 3; a++)
            w[a] *= 2;
        m <<= 1;
    }
    uint64_t ss = 0;
    for (unsigned a = 0; a < 3; a++)
        ss += (uint64_t)(w[a] * w[a]); /* each < 2^60 */
    const uint32_t n = cn_isqrt64(ss); /* >= max |w_a| >= 2^29 */
    for (unsigned a = 0; a < 3; a++)
        u[a] = (int32_t)cn_sdiv_frac(w[a], n, 30); /* |w_a| <= n: within +-2^30 */
    return 1;
}

/* a x b for Q30 vectors, in Q60 (each product below 2^60, each difference below 2^61). */
static void cross_q60(const int32_t a[3], const int32_t b[3], int64_t c[3])
{
    c[0] = (int64_t)a[1] * b[2] - (int64_t)a[2] * b[1];
    c[1] = (int64_t)a[2] * b[0] - (int64_t)a[0] * b[2];
    c[2] = (int64_t)a[0] * b[1] - (int64_t)a[1] * b[0];
}

cnerf_status cnerf_camera_look_at(cnerf_camera *cam, const int32_t eye[3],
                                  const int32_t target[3], const int32_t up[3],
                                  int32_t fov_x_q16, uint16_t width, uint16_t height)
{
    if (!cam || !eye || !target || !up)
        return CNERF_E_NULL;
    if (width == 0 || height == 0 || fov_x_q16 < CNERF_FOV_MIN_Q16 ||
        fov_x_q16 > CNERF_FOV_MAX_Q16)
        return CNERF_E_ARG;
    int64_t fv[3], uv[3];
    for (unsigned a = 0; a < 3; a++) {
        fv[a] = (int64_t)target[a] - eye[a]; /* |.| < 2^32 */
        uv[a] = up[a];
    }
    int32_t f[3], u0[3], r[3], u[3];
    if (!unit_q30(fv, f) || !unit_q30(uv, u0))
        return CNERF_E_ARG; /* eye at the target, or no up */
    int64_t c[3];
    cross_q60(f, u0, c); /* |f x up| = sin of their angle, Q60 */
    uint64_t m = 0;
    for (unsigned a = 0; a < 3; a++)
        m = cn_abs64(c[a]) > m ? cn_abs64(c[a]) : m;
    /* the largest axis of a vector is at least its length over sqrt(3) */
    if (m < (uint64_t)LOOK_MIN_SIN_Q30 << 30)
        return CNERF_E_ARG; /* up along the view */
    if (!unit_q30(c, r))
        return CNERF_E_ARG;
    cross_q60(r, f, c); /* right x forward: the image's up */
    if (!unit_q30(c, u))
        return CNERF_E_ARG;
    for (unsigned a = 0; a < 3; a++) {
        cam->rot[3 * a] = r[a];
        cam->rot[3 * a + 1] = u[a];
        cam->rot[3 * a + 2] = -f[a]; /* the camera looks along its -z */
        cam->pos[a] = (int64_t)eye[a] * 65536;
    }
    /* fx = (width / 2) / tan(fov / 2): half the angle in turns of 2^32 is
     * fov 2^16 / 720 for fov in Q16 degrees */
    const uint32_t half = (uint32_t)cn_udiv_frac((uint64_t)(uint32_t)fov_x_q16 << 16, 720u, 0);
    const uint64_t s = cn_sin_mag_q30(half), co = cn_sin_mag_q30(0x40000000u - half);
    const uint64_t fx = cn_udiv_frac((uint64_t)width * 32768u * co, s, 0); /* Q16 */
    if (fx == 0 || fx > (uint64_t)INT32_MAX)
        return CNERF_E_ARG;
    cam->fx = cam->fy = (int32_t)fx;
    cam->cx = (int32_t)((uint32_t)width * 32768u);
    cam->cy = (int32_t)((uint32_t)height * 32768u);
    cam->width = width;
    cam->height = height;
    return CNERF_OK;
}
