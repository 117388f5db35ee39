/* Size breakdown and `cnerf info` output. */
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>

#include "cnerf/tools.h"

#include "cn_report.h"
#include "cn_stream.h"

const char *cn_role_name(unsigned role)
{
    static const char *names[] = {"trunk", "sigma", "feature", "view", "rgb", "output"};
    return role < sizeof names / sizeof names[0] ? names[role] : "?";
}

void cn_breakdown(const cnerf_info *info, cn_totals *t)
{
    *t = (cn_totals){0};
    for (uint32_t l = 0; l < info->n_layers; l++) {
        const cnerf_layer_info *L = &info->layer[l];
        t->payload += L->payload_bytes;
        t->tables += L->table_bytes;
        t->affine += L->affine_bytes;
        t->biases += L->bias_bytes;
        t->layer_hdr += CNERF_CHUNK_OVERHEAD + L->header_bytes;
    }
    t->stream_hdr = (uint64_t)info->signature_bytes + info->head_bytes + info->unit_bytes +
                    info->done_bytes;
    t->ancillary = info->ancillary_bytes;
    t->grid = info->grid_bytes;
    t->shared = info->shared_bytes;
    t->total = t->payload + t->tables + t->affine + t->biases + t->layer_hdr + t->stream_hdr +
               t->ancillary + t->grid + t->shared;
}

static double q16(int32_t v) { return v / 65536.0; }

static void row(FILE *f, const char *what, uint64_t bytes, uint64_t total)
{
    fprintf(f, "  %-26s %10" PRIu64 " bytes  %5.1f%%\n", what, bytes,
            total ? 100.0 * (double)bytes / (double)total : 0.0);
}

/* Several scenes: one line per scene (its own chunks), the shifts' table; returns the bytes
 * of the scenes other than the one described. */
static uint64_t print_scenes(FILE *f, const uint8_t *buf, const cnerf_info *I)
{
    cnerf_info *J = malloc(sizeof *J);
    uint64_t other = 0;
    fprintf(f, "scenes: %u, sharing one topology; this report's layers and render parameters "
               "are scene %u's (--scene)\n", I->n_scenes, I->scene);
    for (unsigned m = 0; J && m < I->n_scenes; m++) {
        if (cnerf_peek_scene(buf, I->file_bytes, m, J) != CNERF_OK)
            continue;
        if (m != I->scene)
            other += J->scene_bytes;
        fprintf(f, "  scene %u: %" PRIu32 " bytes of its own, %.3f bits per latent; %s, "
                   "background #%02x%02x%02x, grid %s\n",
                m, J->scene_bytes, 8.0 * J->scene_bytes / J->n_params,
                J->coord == CNERF_COORD_NDC        ? "NDC"
                : J->coord == CNERF_COORD_CONTRACT ? "contracted"
                                                   : "world",
                J->background[0],
                J->background[1], J->background[2], J->grid_g ? "yes" : "none");
    }
    free(J);
    fprintf(f, "  shared: %" PRIu32 " bytes (SCNS and %u SHFT chunks), %" PRIu32
               " shifts in layers with a shift, %.3f bits per shift\n",
            I->shared_bytes, I->n_layers, I->n_shift_params,
            I->n_shift_params ? 8.0 * I->shared_bytes / I->n_shift_params : 0.0);
    fprintf(f, "\n%-5s %13s %4s %8s %13s\n", "shift", "s range", "prec", "payload", "g");
    for (uint32_t l = 0; l < I->n_layers; l++) {
        const cnerf_shift_info *S = &I->shift[l];
        char range[32];
        snprintf(range, sizeof range, "[%d,%d]", (int)S->smin, (int)S->smax);
        fprintf(f, "%-5u %13s %4u %8u %13.6g\n", l, range, S->prec, S->payload_bytes,
                S->g_m * ldexp(1.0, S->g_e));
    }
    fprintf(f, "\n");
    return other;
}

void cn_print_info(FILE *f, const char *name, const uint8_t *buf, const cnerf_info *I)
{
    fprintf(f, "%s: cnerf stream, format version %u.%u, %" PRIu32 " bytes\n", name,
            I->version_major, I->version_minor, I->file_bytes);
    const int set = I->shared_bytes > 0;
    const uint64_t other = set ? print_scenes(f, buf, I) : 0;
    if (set)
        fprintf(f, "scene %u:\n", I->scene);
    fprintf(f, "render: %s",
            I->coord == CNERF_COORD_NDC        ? "NDC (forward-facing)"
            : I->coord == CNERF_COORD_CONTRACT ? "contracted (360, inner half of the bounds in "
                                                 "world space, all beyond in the outer half)"
                                               : "world (360)");
    fprintf(f, ", near %g, far %g, background #%02x%02x%02x\n", q16(I->near_q16), q16(I->far_q16),
            I->background[0], I->background[1], I->background[2]);
    fprintf(f, "bounds: [%g, %g] x [%g, %g] x [%g, %g]\n", q16(I->aabb_q16[0]), q16(I->aabb_q16[3]),
            q16(I->aabb_q16[1]), q16(I->aabb_q16[4]), q16(I->aabb_q16[2]), q16(I->aabb_q16[5]));
    fprintf(f, "encoding: position L=%u (%u inputs), direction L=%u (%u inputs)%s\n", I->l_pos,
            I->in_pos, I->l_dir, I->in_dir,
            (I->pe_flags & CNERF_PE_INCLUDE_INPUT) ? ", raw input included" : "");
    fprintf(f, "samples: %u coarse + %u fine\n", I->n_coarse, I->n_fine);
    for (unsigned n = 0; n < I->n_nets; n++) {
        const cnerf_net_info *N = &I->net[n];
        fprintf(f, "network %u (%s): depth %u, width %u, ", n, n ? "fine" : "coarse", N->depth,
                N->width);
        if (N->skip == CNERF_NO_SKIP)
            fprintf(f, "no skip");
        else
            fprintf(f, "skip into layer %u", N->skip + 1u);
        if (N->view_width)
            fprintf(f, ", view branch width %u", N->view_width);
        else
            fprintf(f, ", no view branch");
        fprintf(f, ", %u linear layers%s\n", N->n_layers,
                cnerf_net_has_color(I, n) ? "" : "; no colour (density only)");
    }
    if (I->unit_bytes) {
        fprintf(f, "units per layer (UNIT chunk, %" PRIu32 " bytes):", I->unit_bytes);
        for (unsigned n = 0; n < I->n_nets; n++) {
            const cnerf_net_info *N = &I->net[n];
            fprintf(f, "%s network %u trunk", n ? ";" : "", n);
            for (unsigned i = 0; i < N->depth; i++)
                fprintf(f, " %u", N->units[i]);
            if (N->view_width)
                fprintf(f, ", view %u", N->view_units);
        }
        fprintf(f, "\n");
    }
    if (I->grid_g) {
        const size_t g = I->grid_g, bytes = (g * g * g + 7) / 8;
        const size_t wsz = cnerf_grid_workspace_size(I);
        uint8_t *bits = malloc(bytes);
        void *ws = aligned_alloc(CNERF_WS_ALIGN, (wsz + CNERF_WS_ALIGN - 1) / CNERF_WS_ALIGN *
                                                    CNERF_WS_ALIGN);
        uint32_t occupied = 0;
        const cnerf_status st = bits && ws ? cnerf_grid_bitmap(buf, I, ws, wsz, bits, &occupied)
                                           : CNERF_E_WS_SMALL;
        free(ws);
        fprintf(f, "occupancy grid: %zu^3 cells, %" PRIu32 " bytes", g, I->grid_bytes);
        if (I->grid_by_blocks)
            fprintf(f, " (by blocks: %u of %zu blocks of 8^3 occupied)", I->grid_blocks,
                    ((g + 7) / 8) * ((g + 7) / 8) * ((g + 7) / 8));
        if (st == CNERF_OK)
            fprintf(f, ", %" PRIu32 " occupied (%.1f%%)\n", occupied,
                    100.0 * occupied / (double)(g * g * g));
        else
            fprintf(f, ", does not decode: %s\n", cnerf_status_str(st));
        free(bits);
    } else {
        fprintf(f, "occupancy grid: none (every sample inside the bounds is evaluated)\n");
    }
    if (I->meta_len)
        fprintf(f, "meta: %.*s\n", (int)I->meta_len, (const char *)buf + I->meta_offset);
    fprintf(f, "\n%-5s %-3s %-7s %11s %8s %13s %4s %6s %8s %6s %5s %7s %4s\n", "layer", "net", "role",
            "in->out", "params", "k range", "prec", "table", "payload", "affine", "bias",
            "bits/p", "f_in");
    for (uint32_t l = 0; l < I->n_layers; l++) {
        const cnerf_layer_info *L = &I->layer[l];
        char shape[32], range[32];
        snprintf(shape, sizeof shape, "%u->%u", L->n_in, L->n_out);
        snprintf(range, sizeof range, "[%d,%d]", (int)L->kmin, (int)L->kmax);
        uint32_t params = (uint32_t)L->n_in * L->n_out;
        double bpp = 8.0 * (double)(L->chunk_bytes) / (double)params;
        fprintf(f, "%-5u %-3u %-7s %11s %8u %13s %4u %6u %8u %6u %5u %7.3f %4d\n", l, L->net,
                cn_role_name(L->role), shape, params, range, L->prec, L->table_bytes,
                L->payload_bytes, L->affine_bytes, L->bias_bytes, bpp, L->f_in);
    }
    cn_totals t;
    cn_breakdown(I, &t);
    t.total += other;
    fprintf(f, "\ntotals (bits/p counts the whole layer chunk):\n");
    row(f, "latent payload", t.payload, t.total);
    row(f, "frequency tables", t.tables, t.total);
    row(f, "affine decoders", t.affine, t.total);
    row(f, "biases", t.biases, t.total);
    row(f, "layer headers + framing", t.layer_hdr, t.total);
    row(f, "stream header", t.stream_hdr, t.total);
    row(f, "ancillary (meta)", t.ancillary, t.total);
    row(f, "occupancy grid", t.grid, t.total);
    if (set) {
        row(f, "shared shifts (SCNS, SHFT)", t.shared, t.total);
        row(f, "the other scenes", other, t.total);
    }
    fprintf(f, "  %-26s %10" PRIu64 " bytes  (file: %" PRIu32 " bytes%s)\n", "total", t.total,
            I->file_bytes, t.total == I->file_bytes ? "" : ", MISMATCH");
    fprintf(f, "parameters: %" PRIu32 " latents, %" PRIu32 " biases\n", I->n_params, I->n_biases);
    if (set) /* the whole file over every scene's latents and the shifts */
        fprintf(f, "bits per parameter: %.3f payload only (this scene), %.3f whole file over "
                   "%u scenes' latents and the shifts (float32: 32)\n",
                8.0 * (double)t.payload / I->n_params,
                8.0 * (double)t.total / ((double)I->n_params * I->n_scenes + I->n_shift_params),
                I->n_scenes);
    else
        fprintf(f, "bits per parameter: %.3f payload only, %.3f whole file (float32: 32)\n",
                8.0 * (double)t.payload / I->n_params, 8.0 * (double)t.total / I->n_params);
    cnerf_info nogrid = *I;
    nogrid.grid_g = 0;
    const size_t ws = cnerf_workspace_size(I), grid = ws - cnerf_workspace_size(&nogrid);
    fprintf(f, "decoder memory: workspace %zu bytes", ws);
    if (grid)
        fprintf(f, " (the grid's %zu)", grid);
    const size_t fast = cnerf_workspace_size_fast(I);
    if (fast > ws)
        fprintf(f, " or %zu with every latent as int16 (faster on DSP cores)", fast);
    fprintf(f, ", render scratch %zu bytes, decoder state %zu bytes (this host)\n",
            cnerf_render_scratch_size(I), sizeof(cnerf_decoder));
    /* the level: the one declared, else the lowest the scene fits */
    cn_level_needs n;
    cn_level_needs_of(I, &n);
    const unsigned L = I->level ? I->level : cn_level_lowest(I);
    if (I->level)
        fprintf(f, "level: %u (declared)", I->level);
    else if (L)
        fprintf(f, "level: none declared; the scene fits level %u", L);
    else
        fprintf(f, "level: none declared, and the scene fits none (level %u's caps exceeded)",
                CNERF_MAX_LEVELS);
    if (L >= 1 && L <= CNERF_MAX_LEVELS)
        fprintf(f, ": workspace %zu of %u bytes, render scratch %zu of %u, grid %u of %u, "
                "%u of %u samples per ray, %u of %u multiply-accumulates per evaluation",
                n.workspace, CNERF_LEVEL_WORKSPACE(L), n.scratch, CNERF_LEVEL_SCRATCH(L), n.grid,
                CNERF_LEVEL_GRID(L), n.samples, CNERF_LEVEL_SAMPLES(L), n.macs,
                CNERF_LEVEL_MACS(L));
    fprintf(f, "\n");
}
