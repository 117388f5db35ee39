#include "cn_fixcam.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

int cnerf_camera_from_float(const cn_camera *cam, cnerf_camera *out, char *err, size_t errlen)
{
    memset(out, 0, sizeof *out);
    if (cam->w < 1 || cam->h < 1 || cam->w > 65535 || cam->h > 65535) {
        snprintf(err, errlen, "image size %dx%d out of range (1..65535)", cam->w, cam->h);
        return -1;
    }
    if (!(cam->fx > 0 && cam->fy > 0 && cam->fx < 32768 && cam->fy < 32768 &&
          fabs(cam->cx) < 32768 && fabs(cam->cy) < 32768)) {
        snprintf(err, errlen,
                 "intrinsics fx %g fy %g cx %g cy %g out of range: the decoder's camera takes "
                 "focal lengths in (0, 32768) and principal points within 32768 pixels (Q16); "
                 "render a smaller image or a wider field of view",
                 cam->fx, cam->fy, cam->cx, cam->cy);
        return -1;
    }
    for (int a = 0; a < 3; a++) {
        for (int b = 0; b < 3; b++) {
            const double r = cam->c2w[a][b];
            if (!(fabs(r) <= 1.0)) {
                snprintf(err, errlen, "rotation entry %g is not within [-1, 1]", r);
                return -1;
            }
            out->rot[3 * a + b] = (int32_t)llround(r * 1073741824.0);
        }
        const double t = cam->c2w[a][3];
        if (!(fabs(t) < 32768.0)) {
            snprintf(err, errlen, "camera centre coordinate %g is beyond +-32768", t);
            return -1;
        }
        out->pos[a] = llround(t * 4294967296.0);
    }
    out->fx = (int32_t)llround(cam->fx * 65536.0);
    out->fy = (int32_t)llround(cam->fy * 65536.0);
    out->cx = (int32_t)llround(cam->cx * 65536.0);
    out->cy = (int32_t)llround(cam->cy * 65536.0);
    out->width = (uint16_t)cam->w;
    out->height = (uint16_t)cam->h;
    return 0;
}
