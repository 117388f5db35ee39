/* JPEG input through libjpeg-turbo, with the EXIF orientation read by libexif
 * (cn_image_load.h). */
#include <limits.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jpeglib.h>
#include <jerror.h>
#include <libexif/exif-data.h>

#include "cn_image_load.h"

/* libjpeg reports errors through error_exit, which must not return: the message goes to
 * err with the file's name and control returns to the setjmp below. Warnings (corrupt data,
 * a premature end of the file, which libjpeg would fill with grey) are errors here too: a
 * damaged photo must not train silently. Only extraneous bytes between markers, which some
 * cameras write, leave the picture intact and pass. */
typedef struct cn_jpeg_err {
    struct jpeg_error_mgr mgr;
    jmp_buf jump;
    const char *path;
    char *err;
    size_t errlen;
} cn_jpeg_err;

static void cn_jpeg_fail(j_common_ptr cinfo)
{
    cn_jpeg_err *e = (cn_jpeg_err *)cinfo->err;
    char msg[JMSG_LENGTH_MAX];
    e->mgr.format_message(cinfo, msg);
    snprintf(e->err, e->errlen, "%s: corrupt or truncated JPEG (%s)", e->path, msg);
    longjmp(e->jump, 1);
}

static void cn_jpeg_message(j_common_ptr cinfo, int level)
{
    cn_jpeg_err *e = (cn_jpeg_err *)cinfo->err;
    if (level < 0 && e->mgr.msg_code != JWRN_EXTRANEOUS_DATA)
        cn_jpeg_fail(cinfo);
}

/* The orientation tag of the EXIF block in an APP1 marker; 1 when there is none. */
static int cn_exif_orientation(j_decompress_ptr cinfo)
{
    for (jpeg_saved_marker_ptr m = cinfo->marker_list; m; m = m->next) {
        if (m->marker != JPEG_APP0 + 1 || m->data_length < 6 || memcmp(m->data, "Exif\0\0", 6))
            continue;
        ExifData *ed = exif_data_new_from_data(m->data, m->data_length);
        if (!ed)
            continue;
        int o = 1;
        ExifEntry *en = exif_data_get_entry(ed, EXIF_TAG_ORIENTATION);
        if (en && en->format == EXIF_FORMAT_SHORT && en->components >= 1 && en->size >= 2) {
            const int v = exif_get_short(en->data, exif_data_get_byte_order(ed));
            o = v >= 1 && v <= 8 ? v : 1; /* an invalid value shows the image as stored */
        }
        exif_data_unref(ed);
        return o;
    }
    return 1;
}

typedef struct cn_jpeg_rd {
    struct jpeg_decompress_struct cinfo;
    cn_jpeg_err e;
    JSAMPLE *line;
    float *row;
} cn_jpeg_rd;

static int cn_jpeg_run(cn_jpeg_rd *r, const uint8_t *data, size_t len, cn_load *ld,
                       int header_only)
{
    j_decompress_ptr cinfo = &r->cinfo;
    if (setjmp(r->e.jump))
        return -1;
    jpeg_create_decompress(cinfo);
    jpeg_mem_src(cinfo, data, (unsigned long)len);
    jpeg_save_markers(cinfo, JPEG_APP0 + 1, 0xFFFF);
    jpeg_read_header(cinfo, TRUE);
    if (cinfo->jpeg_color_space == JCS_CMYK || cinfo->jpeg_color_space == JCS_YCCK) {
        snprintf(r->e.err, r->e.errlen, "%s: a CMYK JPEG; cnerf reads grey and colour "
                 "(YCbCr or RGB) JPEGs: convert it to RGB", r->e.path);
        return -1;
    }
    if (cinfo->image_width > INT_MAX || cinfo->image_height > INT_MAX) {
        snprintf(r->e.err, r->e.errlen, "%s: image too large", r->e.path);
        return -1;
    }
    ld->w = (int)cinfo->image_width;
    ld->h = (int)cinfo->image_height;
    ld->c = 3;
    ld->orientation = cn_exif_orientation(cinfo);
    if (header_only)
        return 0;
    char why[160];
    if (cn_load_begin(ld, why, sizeof why)) {
        snprintf(r->e.err, r->e.errlen, "%s: %s", r->e.path, why);
        return -1;
    }
    cinfo->out_color_space = JCS_RGB; /* grey too: libjpeg-turbo repeats it in R, G, B */
    jpeg_start_decompress(cinfo);
    if (cinfo->output_components != 3 || cinfo->output_width != cinfo->image_width) {
        snprintf(r->e.err, r->e.errlen, "%s: unsupported JPEG pixel format", r->e.path);
        return -1;
    }
    r->line = malloc((size_t)ld->w * 3);
    r->row = malloc(sizeof(float) * (size_t)ld->w * 3);
    if (!r->line || !r->row) {
        snprintf(r->e.err, r->e.errlen, "%s: out of memory", r->e.path);
        return -1;
    }
    while (cinfo->output_scanline < cinfo->output_height) {
        JSAMPROW rows[1] = {r->line};
        if (jpeg_read_scanlines(cinfo, rows, 1) != 1) {
            snprintf(r->e.err, r->e.errlen, "%s: truncated JPEG", r->e.path);
            return -1;
        }
        for (size_t i = 0; i < (size_t)ld->w * 3; i++)
            r->row[i] = (float)r->line[i] / 255.0f;
        cn_load_row(ld, r->row);
    }
    jpeg_finish_decompress(cinfo);
    return 0;
}

int cn_jpeg_decode(const char *path, const uint8_t *data, size_t len, cn_load *ld,
                   int header_only, char *err, size_t errlen)
{
    cn_jpeg_rd r;
    memset(&r, 0, sizeof r);
    r.e.path = path;
    r.e.err = err;
    r.e.errlen = errlen;
    r.cinfo.err = jpeg_std_error(&r.e.mgr);
    r.e.mgr.error_exit = cn_jpeg_fail;
    r.e.mgr.emit_message = cn_jpeg_message;
    if (len > ULONG_MAX) {
        snprintf(err, errlen, "%s: file too large", path);
        return -1;
    }
    const int rc = cn_jpeg_run(&r, data, len, ld, header_only);
    jpeg_destroy_decompress(&r.cinfo);
    free(r.line);
    free(r.row);
    return rc;
}
