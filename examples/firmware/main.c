/* Renders one view of the stream in flash with the cnerf decoder and streams it out row by
 * row, the way a device without a framebuffer feeds a display: one row buffer, no frame.
 * Here each row goes to view.ppm on the debug host over semihosting, and the camera's 18
 * integers are printed so that a host render of the same camera can be compared.
 * Everything is static: the workspace and scratch are sized for the streams this device
 * takes, and the decoder says at run time whether a stream fits. */
#include <stdint.h>

#include "cnerf/cnerf.h"

#define WORKSPACE_BYTES (256u * 1024u) /* cnerf_workspace_size of the largest stream taken */
#define SCRATCH_BYTES (16u * 1024u)    /* cnerf_render_scratch_size of the same */

#define STR_(x) #x
#define STR(x) STR_(x)

extern const uint8_t scene_stream[], scene_stream_end[]; /* stream.S */
void semihost_exit(int status);

static cnerf_decoder dec;
static uint64_t workspace[WORKSPACE_BYTES / 8];
static uint64_t scratch[SCRATCH_BYTES / 8];
static uint8_t row[SCENE_W * 3];

/* ---- ARM semihosting: the debug host's console and files ---- */
static uint32_t semihost(uint32_t op, const void *arg)
{
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}
static void say(const char *s) { (void)semihost(0x04u, s); } /* SYS_WRITE0 */
static uint32_t length(const char *s)
{
    uint32_t n = 0;
    while (s[n])
        n++;
    return n;
}
static int file_open(const char *name) /* SYS_OPEN, mode "wb" */
{
    const uint32_t block[3] = {(uint32_t)(uintptr_t)name, 5u, length(name)};
    return (int)semihost(0x01u, block);
}
static int file_write(int fd, const void *p, uint32_t n) /* SYS_WRITE: 0 when all written */
{
    const uint32_t block[3] = {(uint32_t)fd, (uint32_t)(uintptr_t)p, n};
    return semihost(0x05u, block) == 0 ? 0 : -1;
}
static void file_close(int fd) { (void)semihost(0x02u, &fd); } /* SYS_CLOSE */
void semihost_exit(int status)
{
    const uint32_t block[2] = {0x20026u, (uint32_t)status}; /* ApplicationExit, status */
    (void)semihost(0x20u, block);                            /* SYS_EXIT_EXTENDED */
    for (;;) {
    }
}

/* A decimal number, for the report; no division helpers needed. */
static void say_int(int64_t v)
{
    char buf[24];
    int i = 23;
    uint64_t u = v < 0 ? 0u - (uint64_t)v : (uint64_t)v;
    buf[i] = 0;
    do {
        uint64_t q = 0, r = 0; /* u / 10 by shifts and subtractions */
        for (int b = 63; b >= 0; b--) {
            r = (r << 1) | ((u >> b) & 1u);
            q <<= 1;
            if (r >= 10u)
                r -= 10u, q |= 1u;
        }
        buf[--i] = (char)('0' + r);
        u = q;
    } while (u);
    if (v < 0)
        buf[--i] = '-';
    say(buf + i);
}

static int failed(const char *what, cnerf_status st)
{
    say(what);
    say(": ");
    say(cnerf_status_str(st));
    say("\n");
    return 1;
}

int main(void)
{
    const size_t len = (size_t)(scene_stream_end - scene_stream);
    cnerf_status st = cnerf_peek(scene_stream, len, &dec.info);
    if (st != CNERF_OK)
        return failed("cnerf_peek", st);
    if (cnerf_workspace_size(&dec.info) > sizeof workspace ||
        cnerf_render_scratch_size(&dec.info) > sizeof scratch) {
        say("this stream needs more memory than the firmware has reserved\n");
        return 2;
    }
    st = cnerf_open(&dec, scene_stream, len, workspace, sizeof workspace);
    if (st != CNERF_OK)
        return failed("cnerf_open", st);

    static const int32_t eye[3] = {SCENE_EYE}, target[3] = {SCENE_TARGET};
    static const int32_t up[3] = {0, 0, 65536}; /* +z up, as Blender scenes have it */
    cnerf_camera cam;
    st = cnerf_camera_look_at(&cam, eye, target, up, SCENE_FOV << 16, SCENE_W, SCENE_H);
    if (st != CNERF_OK)
        return failed("cnerf_camera_look_at", st);
    say("camera");
    for (int i = 0; i < 9; i++)
        say(" "), say_int(cam.rot[i]);
    for (int i = 0; i < 3; i++)
        say(" "), say_int(cam.pos[i]);
    say(" "), say_int(cam.fx), say(" "), say_int(cam.fy), say(" "), say_int(cam.cx);
    say(" "), say_int(cam.cy), say(" "), say_int(cam.width), say(" "), say_int(cam.height);
    say("\n");

    cnerf_render_opts opts;
    cnerf_render_defaults(&dec.info, &opts);
    const int fd = file_open("view.ppm");
    if (fd < 0) {
        say("cannot open view.ppm on the host\n");
        return 1;
    }
    static const char header[] = "P6\n" STR(SCENE_W) " " STR(SCENE_H) "\n255\n";
    int bad = file_write(fd, header, sizeof header - 1);
    for (uint32_t y = 0; y < SCENE_H && !bad; y++) {
        st = cnerf_render_tile(&dec, &cam, &opts, 0, y, SCENE_W, 1, row, sizeof row, scratch,
                               sizeof scratch);
        if (st != CNERF_OK) {
            file_close(fd);
            return failed("cnerf_render_tile", st);
        }
        bad = file_write(fd, row, sizeof row); /* a display driver takes the row here */
    }
    file_close(fd);
    if (bad) {
        say("writing view.ppm failed\n");
        return 1;
    }
    say("view.ppm written, ");
    say_int(SCENE_W);
    say("x");
    say_int(SCENE_H);
    say("\n");
    return 0;
}
