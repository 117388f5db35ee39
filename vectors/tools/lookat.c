/* Writes the look-at vectors (vectors/lookat.sh): for a fixed list of integer inputs, the
 * camera cnerf_camera_look_at makes, or the status with which it refuses. One line a case:
 *   EYE[3] TARGET[3] UP[3] FOV_Q16 WIDTH HEIGHT STATUS [ROT[9] POS[3] FX FY CX CY W H]
 * (eye, target and up in Q16 scene units, the field of view in Q16 degrees; STATUS a name,
 * the camera's 18 integers after CNERF_OK). Hosted C99, the decoder only. */
#include <stdio.h>

#include "cnerf/cnerf.h"

static void one(const int32_t e[3], const int32_t t[3], const int32_t u[3], int32_t fov,
                uint16_t w, uint16_t h)
{
    cnerf_camera c;
    const cnerf_status st = cnerf_camera_look_at(&c, e, t, u, fov, w, h);
    printf("%ld %ld %ld %ld %ld %ld %ld %ld %ld %ld %u %u %s", (long)e[0], (long)e[1],
           (long)e[2], (long)t[0], (long)t[1], (long)t[2], (long)u[0], (long)u[1], (long)u[2],
           (long)fov, (unsigned)w, (unsigned)h, cnerf_status_str(st));
    if (st == CNERF_OK) {
        for (int i = 0; i < 9; i++)
            printf(" %ld", (long)c.rot[i]);
        for (int i = 0; i < 3; i++)
            printf(" %lld", (long long)c.pos[i]);
        printf(" %ld %ld %ld %ld %u %u", (long)c.fx, (long)c.fy, (long)c.cx, (long)c.cy,
               (unsigned)c.width, (unsigned)c.height);
    }
    printf("\n");
}

int main(void)
{
    const int32_t Q = 65536;
    const int32_t zup[3] = {0, 0, Q}, yup[3] = {0, Q, 0}, o[3] = {0, 0, 0};
    /* orbits around the origin, +z up (Blender's scenes), every octant and elevation */
    for (int k = 0; k < 8; k++) {
        static const int32_t xs[8] = {4, 3, 0, -3, -4, -3, 0, 3}, ys[8] = {0, 3, 4, 3, 0, -3, -4, -3};
        const int32_t eye[3] = {xs[k] * Q, ys[k] * Q, (k - 3) * Q / 2};
        one(eye, o, zup, 40 * Q, 100, 100);
    }
    /* +y up (OpenGL's), non-square images, off-centre targets, tilted up vectors */
    const int32_t e1[3] = {Q / 3, 2 * Q, 5 * Q}, t1[3] = {-Q / 7, Q / 5, Q / 9};
    one(e1, t1, yup, 23 * Q + Q / 2, 160, 90);
    const int32_t tilt[3] = {Q / 5, Q, Q / 3};
    one(e1, t1, tilt, 60 * Q, 33, 200);
    /* the field of view's range: 1 and 120 degrees, odd sizes */
    const int32_t e2[3] = {-3 * Q, Q, 2 * Q};
    one(e2, o, zup, CNERF_FOV_MIN_Q16, 17, 13);
    one(e2, o, zup, CNERF_FOV_MAX_Q16, 640, 480);
    /* far and near: 3000 and 1/4 scene units, and the largest coordinates */
    const int32_t far[3] = {3000 * Q, -1200 * Q, 800 * Q}, near[3] = {Q / 4, 0, Q / 8};
    one(far, o, zup, 10 * Q, 64, 48);
    one(near, o, zup, 90 * Q, 64, 48);
    const int32_t big[3] = {INT32_MAX, INT32_MIN + 1, INT32_MAX / 2}, big_t[3] = {INT32_MIN + 1, INT32_MAX, 0};
    one(big, big_t, zup, 40 * Q, 100, 100);
    /* the refusals: eye at the target, a zero up, up along the view, the field of view out of
     * range, a zero size */
    one(o, o, zup, 40 * Q, 100, 100);
    const int32_t e3[3] = {0, 0, 4 * Q}, zero[3] = {0, 0, 0};
    one(e3, o, zero, 40 * Q, 100, 100);
    one(e3, o, zup, 40 * Q, 100, 100);
    one(e1, t1, yup, CNERF_FOV_MIN_Q16 - 1, 100, 100);
    one(e1, t1, yup, CNERF_FOV_MAX_Q16 + 1, 100, 100);
    one(e1, t1, yup, 40 * Q, 0, 100);
    one(e1, t1, yup, 40 * Q, 100, 0);
    return 0;
}
