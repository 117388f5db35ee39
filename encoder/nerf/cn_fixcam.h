/* Host-side helper: the decoder's fixed-point camera from a float one. */
#ifndef CNERF_ENC_FIXCAM_H
#define CNERF_ENC_FIXCAM_H

#include "cn_render.h"
#include "cnerf/cnerf.h"

/* Rounds cam to the decoder's formats (rotation Q30, centre Q32, intrinsics Q16).
 * Returns 0, or -1 with a message when a value does not fit (|rotation entry| > 1, centre
 * beyond 2^15 units, focal length not positive, image larger than 65535). */
int cnerf_camera_from_float(const cn_camera *cam, cnerf_camera *out, char *err, size_t errlen);

#endif
