/* cnerf firmware for a Cortex-M0+, M4, M7, M33 or M55 (the board is fw_board.h's): runs a
 * batch of render jobs embedded at build time, one after another. Each decodes its stream
 * (in the flash image) into the one static workspace, renders its tile with its camera and
 * knobs, hashes the tile's pixels (RGB888, w * 3 bytes per row, or RGB565, w * 2, row by
 * row) with MD5 and
 * prints, over ARM semihosting,
 *   fw job / fw render / fw ticks lines   the job's sizes, its work and its SysTick readings
 *   md5 <32 hex>                          the job's tile
 * then, after the last job, the report's fw lines (buffers, the clock, the calibration, the
 * cross-check of the counters over the whole run, the stack high-water mark), and exits with
 * status 0. A decoder error prints `fw: job N: <call>: <status name>` and exits 1; a static
 * buffer smaller than a stream needs exits 2; a fault exits 3 (startup.c).
 *
 * The streams and jobs come from cnerf_fw_embed.h, which fw_embed.c writes at build time
 * (buffers sized for the largest job). CNERF_FW_WORK 1 (CMake's CNERF_FW_WORK): each tile is
 * rendered a second time, untimed, to count its work (cnerf_render_tile_stats); 0 halves the
 * run of a conformance check that needs only the MD5s; with CNERF_FW_WORK_FIRST 1 only the
 * first job's work is counted (a check of the host's count, which stands for the rest).
 *
 * Instructions: SysTick counts the processor clock (CLKSOURCE = 1; FW_CPU_HZ in QEMU: 25 MHz
 * on the AN386, 32 MHz on the AN547) with the 24-bit counter reloading from 2^24 - 1 and an
 * interrupt counting the wraps. Under `qemu-system-arm -icount shift=0` virtual time
 * advances exactly 1 ns per executed instruction, so one SysTick tick is exactly
 * 10^9 / FW_CPU_HZ instructions: 40 on the AN386, 31.25 on the AN547. QEMU makes a device
 * read instruction-exact in icount mode (the translation block ends at the access), so each
 * reading is exact up to the tick quantum: an interval is known to +-1 tick, and includes
 * the ~30 instructions of one reading and those of the wrap interrupt (a few every 2^24
 * ticks). Checked at every run: a loop of known length (two lengths, so that the call
 * overhead cancels) must take that many instructions per tick, and the whole run's SysTick
 * count (wraps included) must agree with a second counter on the same clock that never wraps
 * here (fw_board.h: the MPS2's 32-bit APB timer 0 on the AN386, the SSE-300's system
 * counter on the AN547). The firmware prints raw ticks and FW_CPU_HZ; scripts/firmware.sh
 * checks both and converts. Without -icount the ticks follow host time and mean nothing. */

#include <stddef.h>
#include <stdint.h>

#include "cnerf/cnerf.h"
#include "fw_board.h"
#include "md5.h"
#include "semihost.h"

/* One render of the batch: its stream (in flash) and scene, the host's cnerf_peek status,
 * the tile, the row stride of its pixels, the knobs (if any) and the camera. */
typedef struct {
    const uint8_t *stream;
    uint32_t len, scene;
    int host_peek;
    uint32_t tile[4]; /* x0 y0 w h */
    uint32_t stride;  /* w * 3 rounded up to 4 bytes */
    int have_knobs;
    cnerf_render_opts knobs;
    cnerf_camera camera;
} fw_job;

#include "cnerf_fw_embed.h"

#ifndef CNERF_FW_WORK
#define CNERF_FW_WORK 1
#endif
#ifndef CNERF_FW_PACKED
#define CNERF_FW_PACKED 0 /* 1: the jobs are packed images (fw_embed.c's SET) */
#endif
#ifndef CNERF_FW_WORK_FIRST
#define CNERF_FW_WORK_FIRST 0
#endif
#ifndef CNERF_FW_FAST
#define CNERF_FW_FAST 0 /* 1: the whole workspace given (fw_embed --fast sized it) */
#endif

#define FW_EXIT_DECODER 1
#define FW_EXIT_BUFFERS 2

uint32_t fw_stack_high_water(void); /* startup.c */
void SysTick_Handler(void);
extern uint32_t __stack_limit[], __stack_top[]; /* fw-sections.ld */

static cnerf_decoder dec;
#if CNERF_MAX_LEVEL > 0
/* A decoder of one level: its arenas are the level's, whatever stream comes. */
static uint64_t ws[CNERF_LEVEL_WORKSPACE(CNERF_MAX_LEVEL) / 8u];
static uint64_t scratch[CNERF_LEVEL_SCRATCH(CNERF_MAX_LEVEL) / 8u];
#else
static uint64_t ws[(CNERF_FW_WS_BYTES + 7u) / 8u];
static uint64_t scratch[(CNERF_FW_SCRATCH_BYTES + 7u) / 8u];
#endif
static uint8_t tile[CNERF_FW_TILE_BYTES + 1u];

/* ---- instruction counting: SysTick on the processor clock, wraps counted ---- */

#define SYST_CSR (*(volatile uint32_t *)0xe000e010u)
#define SYST_RVR (*(volatile uint32_t *)0xe000e014u)
#define SYST_CVR (*(volatile uint32_t *)0xe000e018u)
#define SCB_ICSR (*(volatile uint32_t *)0xe000ed04u)
#define SYST_RELOAD 0x00ffffffu
#define ICSR_PENDSTSET (1u << 26)

static volatile uint32_t systick_wraps;

void SysTick_Handler(void)
{
    systick_wraps++;
}

static void ticks_start(void)
{
    SYST_CSR = 0;
    SYST_RVR = SYST_RELOAD;
    SYST_CVR = 0;  /* any write clears the counter */
    SYST_CSR = 5u; /* ENABLE | CLKSOURCE (processor clock), no interrupt yet */
    while (SYST_CVR == 0) {
        /* the counter loads RELOAD on its first tick */
    }
    systick_wraps = 0;
    SYST_CSR = 7u; /* ENABLE | TICKINT | CLKSOURCE */
    fw_timer2_start(); /* the independent check of the wrap counting over the whole run */
}

/* Ticks since an arbitrary origin, 64 bits, with interrupts masked. The counter runs
 * RELOAD, ..., 1, 0 and then reloads; the exception pends when it reaches 0 (so the
 * architecture, and QEMU's model: a ptimer that wraps one period after reaching 0). So
 * n = counted wraps + a pending one is the number of periods completed, except while the
 * counter still reads 0: that is the last tick of period n. PENDSTSET is read on both sides
 * of the counter; if it changed in between, the counter is read again so that it belongs to
 * the same period as n. (ticks_start waits out the 0 that precedes the first reload.) */
static uint64_t ticks_now(void)
{
    __asm__ volatile("cpsid i" ::: "memory");
    const uint32_t w = systick_wraps, p1 = SCB_ICSR & ICSR_PENDSTSET;
    uint32_t v = SYST_CVR;
    const uint32_t p2 = SCB_ICSR & ICSR_PENDSTSET;
    if (p1 != p2)
        v = SYST_CVR;
    __asm__ volatile("cpsie i" ::: "memory");
    const uint64_t n = (uint64_t)w + (p2 ? 1u : 0u);
    return v == 0 ? n * (SYST_RELOAD + 1u) - 1u : n * (SYST_RELOAD + 1u) + (SYST_RELOAD - v);
}

/* Exactly 2 n instructions in the loop (subs, bne), n >= 1. */
__attribute__((noinline)) static void spin(uint32_t n)
{
    /* GCC hands inline assembly to the assembler in divided syntax on Armv6-M */
    __asm__ volatile(".syntax unified\n"
                     "1:\n\t"
                     "subs %0, %0, #1\n\t"
                     "bne 1b\n\t"
                     : "+r"(n)
                     :
                     : "cc");
}

static uint64_t ticks_of_spin(uint32_t n)
{
    const uint64_t t0 = ticks_now();
    spin(n);
    return ticks_now() - t0;
}

/* ---- output ---- */

static void put_kv(const char *key, uint64_t v)
{
    sh_puts(" ");
    sh_puts(key);
    sh_puts(" ");
    sh_putu64(v);
}

static int fail(uint32_t job, const char *call, cnerf_status st)
{
    sh_puts("fw: job ");
    sh_putu64(job);
    sh_puts(": ");
    sh_puts(call);
    sh_puts(": ");
    sh_puts(cnerf_status_str(st));
    sh_puts("\n");
    return FW_EXIT_DECODER;
}

static int too_small(const char *what, size_t need, size_t have)
{
    sh_puts("fw: the static ");
    sh_puts(what);
    sh_puts(" is too small for this stream:");
    put_kv("need", need);
    put_kv("have", have);
    sh_puts(" (rebuild: the build sizes it from the stream)\n");
    return FW_EXIT_BUFFERS;
}

/* Job j: opens its stream, renders its tile (timed), hashes the pixels, renders it again
 * untimed to count the work, and prints its `fw job`, `fw render`, `fw ticks` and `md5`
 * lines. Returns 0 or the exit status. *ws_max and *sc_max gather the largest needs. */
static int run_job(uint32_t j, size_t *ws_max, size_t *sc_max)
{
    const fw_job *job = &cnerf_fw_jobs[j];
#if CNERF_FW_PACKED
    /* The job's packed image, opened where it lies in flash: no peek, no workspace. */
    const uint64_t t0 = ticks_now(), t1 = t0, t2 = ticks_now();
    cnerf_status st = cnerf_open_packed(&dec, job->stream, job->len);
    const uint64_t t3 = ticks_now();
    if (st != CNERF_OK)
        return fail(j, "cnerf_open_packed", st);
    const size_t ws_need = 0, sc_need = cnerf_render_scratch_size(&dec.info);
    if (sc_need > sizeof scratch)
        return too_small("render scratch", sc_need, sizeof scratch);
#else
    const uint64_t t0 = ticks_now();
    cnerf_status st = cnerf_peek_scene(job->stream, job->len, job->scene, &dec.info);
    const uint64_t t1 = ticks_now();
    if (st != CNERF_OK)
        return fail(j, "cnerf_peek", st);
    const size_t ws_need = cnerf_workspace_size(&dec.info);
    const size_t sc_need = cnerf_render_scratch_size(&dec.info);
    if (ws_need > sizeof ws)
        return too_small("workspace", ws_need, sizeof ws);
    if (sc_need > sizeof scratch)
        return too_small("render scratch", sc_need, sizeof scratch);

    const uint64_t t2 = ticks_now();
    /* A device sized for the stream: its workspace is cnerf_workspace_size bytes (the array
     * is the largest job's), or with CNERF_FW_FAST the whole array, at least each stream's
     * cnerf_workspace_size_fast: every latent as int16. */
    st = cnerf_open_scene(&dec, job->stream, job->len, job->scene, ws,
                          CNERF_FW_FAST ? sizeof ws : ws_need);
    const uint64_t t3 = ticks_now();
    if (st != CNERF_OK)
        return fail(j, "cnerf_open", st);
#endif
    *ws_max = ws_need > *ws_max ? ws_need : *ws_max;
    *sc_max = sc_need > *sc_max ? sc_need : *sc_max;

    cnerf_render_opts opts;
    cnerf_render_defaults(&dec.info, &opts);
    if (job->have_knobs) { /* field by field: no memcpy in this firmware */
        opts.n_coarse = job->knobs.n_coarse;
        opts.n_fine = job->knobs.n_fine;
        opts.t_stop = job->knobs.t_stop;
        opts.flags = job->knobs.flags;
    }
    const uint32_t x0 = job->tile[0], y0 = job->tile[1], w = job->tile[2], h = job->tile[3];
    const uint64_t t4 = ticks_now();
    st = cnerf_render_tile(&dec, &job->camera, &opts, x0, y0, w, h, tile, job->stride, scratch,
                           sizeof scratch);
    const uint64_t t5 = ticks_now();
    if (st != CNERF_OK)
        return fail(j, "cnerf_render_tile", st);

    /* The visible pixels only: w * 3 bytes of each row (w * 2 in RGB565), not the stride's
     * padding. */
    const uint32_t row_bytes =
        w * (opts.flags & (CNERF_RENDER_RGB565 | CNERF_RENDER_RGB565_BE) ? 2u : 3u);
    fw_md5 md5;
    uint8_t digest[16];
    char hex[33];
    fw_md5_init(&md5);
    for (uint32_t y = 0; y < h; y++)
        fw_md5_update(&md5, tile + (size_t)y * job->stride, row_bytes);
    fw_md5_final(&md5, digest);
    fw_md5_hex(digest, hex);
    const uint64_t t6 = ticks_now();
    /* The work done, counted by a second render, untimed: counting the samples inside the
     * bounds costs what the renderer saves by ruling out stretches of rays unseen. */
    const int counted = CNERF_FW_WORK && (!CNERF_FW_WORK_FIRST || j == 0);
    cnerf_render_stats work; /* field by field: no memset in this firmware */
    work.rays = work.evals = work.in_bounds = work.macs = work.list_macs = work.list_nz = 0;
    work.samples = work.layer_values = work.exact_rescales = work.wide_macs = work.s8_macs = 0;
    if (counted) {
        st = cnerf_render_tile_stats(&dec, &job->camera, &opts, x0, y0, w, h, tile,
                                     job->stride, scratch, sizeof scratch, &work);
        if (st != CNERF_OK)
            return fail(j, "cnerf_render_tile_stats", st);
    }

    sh_puts("fw job");
    put_kv("index", j);
    put_kv("stream", job->len);
    put_kv("scene", job->scene);
    put_kv("workspace_need", ws_need);
    put_kv("scratch_need", sc_need);
    sh_puts("\nfw render");
    put_kv("x0", x0);
    put_kv("y0", y0);
    put_kv("w", w);
    put_kv("h", h);
    put_kv("n_coarse", opts.n_coarse);
    put_kv("n_fine", opts.n_fine);
    put_kv("t_stop", opts.t_stop);
    put_kv("flags", opts.flags);
    if (counted) {
        put_kv("evals", work.evals);
        put_kv("in_bounds", work.in_bounds);
        put_kv("macs", work.macs);
        put_kv("list_macs", work.list_macs);
        put_kv("list_nz", work.list_nz);
        put_kv("samples", work.samples);
        put_kv("layer_values", work.layer_values);
        put_kv("exact_rescales", work.exact_rescales);
        put_kv("wide_macs", work.wide_macs);
        put_kv("s8_macs", work.s8_macs);
    }
    put_kv("ndc", dec.info.coord == CNERF_COORD_NDC);
    put_kv("in_pos", dec.info.in_pos);
    put_kv("samples_per_ray", (uint64_t)opts.n_coarse + (dec.info.n_nets > 1 ? opts.n_fine : 0u));
    put_kv("contract", dec.info.coord == CNERF_COORD_CONTRACT);
    put_kv("grid", dec.info.grid_g);
    sh_puts("\nfw ticks");
    put_kv("peek", t1 - t0);
    put_kv("open", t3 - t2);
    put_kv("render", t5 - t4);
    put_kv("md5", t6 - t5);
    sh_puts("\nmd5 ");
    sh_puts(hex);
    sh_puts("\n");
    return 0;
}

int main(void)
{
    ticks_start();

    /* Calibration: two loop lengths; their difference is 2 * (N2 - N1) instructions. */
    const uint32_t n1 = 100000u, n2 = 2100000u;
    const uint64_t c1 = ticks_of_spin(n1), c2 = ticks_of_spin(n2);
    const uint64_t c0 = ticks_now(), c00 = ticks_now(); /* cost of one reading */

    const uint32_t timer2_start = fw_timer2_count();
    const uint64_t t0 = ticks_now();
    size_t ws_max = 0, sc_max = 0;
    for (uint32_t j = 0; j < CNERF_FW_JOBS; j++) {
        const int rc = run_job(j, &ws_max, &sc_max);
        if (rc)
            return rc;
    }
    const uint64_t t1 = ticks_now();
    const uint32_t timer2_end = fw_timer2_count();

    sh_puts("fw buffers");
    put_kv("stream", CNERF_FW_STREAM_BYTES);
    put_kv("workspace_need", ws_max);
    put_kv("workspace", sizeof ws);
    put_kv("scratch_need", sc_max);
    put_kv("scratch", sizeof scratch);
    put_kv("tile_buffer", sizeof tile);
    put_kv("decoder", sizeof dec);
    sh_puts("\nfw clock");
    put_kv("cpu_hz", FW_CPU_HZ);
    sh_puts("\nfw calib");
    put_kv("insns", 2u * (uint64_t)(n2 - n1));
    put_kv("ticks", c2 - c1);
    put_kv("reading_ticks", c00 - c0);
    sh_puts("\nfw crosscheck");
    put_kv("systick", t1 - t0);
    put_kv(FW_TIMER2_KEY, timer2_end - timer2_start);
    sh_puts("\nfw stack");
    put_kv("high_water", fw_stack_high_water());
    put_kv("size", (uint64_t)((uintptr_t)__stack_top - (uintptr_t)__stack_limit));
    sh_puts("\n");
    return 0;
}
