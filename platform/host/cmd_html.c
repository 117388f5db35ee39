/* cnerf html SCENE.cnrf -o scene.html: the viewer, the WebAssembly decoder and the stream in
 * one HTML file that a browser opens from the file system (docs/web.md). The page and the
 * module are built into this program (platform/web/build.sh and embed.cmake, when clang and
 * wasm-ld were found at build time). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "cli_args.h"
#include "cn_buf.h"
#include "cn_file.h"

#define HTML_USAGE "usage: cnerf html SCENE.cnrf -o scene.html"

#ifdef CNERF_WEB_ASSETS
extern const unsigned char cn_web_wasm[], cn_web_bundle[], cn_web_page[];
extern const size_t cn_web_wasm_len, cn_web_bundle_len, cn_web_page_len;

static void puts_(cn_buf *b, const char *s) { cn_buf_put(b, s, strlen(s)); }

/* RFC 4648 base64 of p[0..n). */
static void put_base64(cn_buf *b, const unsigned char *p, size_t n)
{
    static const char abc[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char q[4];
    for (size_t i = 0; i < n; i += 3) {
        const unsigned v = (unsigned)p[i] << 16 | (i + 1 < n ? (unsigned)p[i + 1] << 8 : 0u) |
                           (i + 2 < n ? p[i + 2] : 0u);
        q[0] = abc[v >> 18 & 63];
        q[1] = abc[v >> 12 & 63];
        q[2] = i + 1 < n ? abc[v >> 6 & 63] : '=';
        q[3] = i + 2 < n ? abc[v & 63] : '=';
        cn_buf_put(b, q, 4);
    }
}

/* The page with its module script replaced by the inlined bundle, module and stream. */
static int make_page(cn_buf *b, const unsigned char *stream, size_t len, const char *name)
{
    const char *page = (const char *)cn_web_page;
    const char *open = "<!--CNERF-SCRIPT-->", *close = "<!--/CNERF-SCRIPT-->";
    const char *a = strstr(page, open), *z = a ? strstr(a, close) : NULL;
    if (!a || !z || (size_t)(z - page) > cn_web_page_len)
        return 1;
    z += strlen(close);
    cn_buf_put(b, page, (size_t)(a - page));
    puts_(b, "<script>\n");
    cn_buf_put(b, cn_web_bundle, cn_web_bundle_len);
    puts_(b, "</script>\n<script>\n");
    puts_(b, "const bytes = (s) => Uint8Array.from(atob(s), (c) => c.charCodeAt(0));\n");
    puts_(b, "startViewer({ wasm: bytes('");
    put_base64(b, cn_web_wasm, cn_web_wasm_len);
    puts_(b, "'),\n  stream: bytes('");
    put_base64(b, stream, len);
    puts_(b, "'),\n  name: '");
    for (const char *c = name; *c; c++) /* the file name, as a JavaScript string */
        if (*c != '\'' && *c != '\\' && *c != '<' && (unsigned char)*c >= 32)
            cn_buf_put(b, c, 1);
    puts_(b, "' });\n</script>\n");
    cn_buf_put(b, z, cn_web_page_len - (size_t)(z - page));
    if (b->oom)
        return -1;
    return 0;
}
#endif

int cmd_html(int argc, char **argv)
{
    const char *out = NULL, *pos[1];
    int n_pos;
    const cli_opt opts[] = {{"-o", CLI_STR, &out, 0, 0}};
    if (cli_parse("html", HTML_USAGE, argc, argv, opts, sizeof opts / sizeof opts[0], pos, 1,
                  &n_pos))
        return 2;
    if (n_pos != 1 || !out)
        return cli_usage("html", "need a stream and -o FILE\n%s", HTML_USAGE);
#ifndef CNERF_WEB_ASSETS
    return cli_fail("html", "this cnerf was built without the WebAssembly decoder: clang and "
                            "wasm-ld were not found when it was configured (Debian: apt-get "
                            "install clang lld, then configure and build again)");
#else
    if (cli_check_output("html", out, pos, 1, NULL))
        return 1;
    cli_stream st;
    if (cli_stream_open("html", pos[0], &st, NULL))
        return 1;
    const char *slash = strrchr(pos[0], '/');
    cn_buf b = {0};
    char err[1024];
    int rc = make_page(&b, st.file, st.len, slash ? slash + 1 : pos[0]);
    if (rc > 0)
        rc = cli_fail("html", "the page built into this program has no script marker");
    else if (rc < 0)
        rc = cli_fail("html", "out of memory");
    else if (cn_write_file_atomic(out, b.p, b.n, err, sizeof err))
        rc = cli_fail("html", "%s", err);
    else
        printf("wrote %s: %zu bytes (the stream %zu, the decoder %zu, the viewer %zu, in base64 "
               "where binary)\n", out, b.n, st.len, cn_web_wasm_len, cn_web_bundle_len);
    cn_buf_free(&b);
    cli_stream_free(&st);
    return rc;
#endif
}
