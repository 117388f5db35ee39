/* cnerf firmware for a Cortex-M4 (MPS2 AN386 under QEMU) or a Cortex-M55 (MPS3 AN547; the
 * board is fw_board.h's): decodes the stream embedded in the flash image into a static
 * workspace, renders the embedded tile with the embedded camera and knobs, hashes the tile's
 * pixels (RGB888, w * 3 bytes per row, row by row) with MD5 and prints, over ARM semihosting,
 *   fw ... lines      sizes, the clock, SysTick readings and the stack high-water mark (the
 *                     report)
 *   md5 <32 hex>      the last line
 * then exits with status 0. A decoder error prints `fw: <call>: <status name>` and exits 1; a
 * static buffer smaller than the stream needs exits 2; a fault exits 3 (startup.c).
 *
 * The stream, camera, tile and knobs come from cnerf_fw_embed.h, which fw_embed.c writes at
 * build time.
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
#include "cnerf_fw_embed.h"
#include "fw_board.h"
#include "md5.h"
#include "semihost.h"

#define FW_EXIT_DECODER 1
#define FW_EXIT_BUFFERS 2

uint32_t fw_stack_high_water(void); /* startup.c */
void SysTick_Handler(void);
extern uint32_t __stack_limit[], __stack_top[]; /* fw-sections.ld */

static cnerf_decoder dec;
static uint64_t ws[(CNERF_FW_WS_BYTES + 7u) / 8u];
static uint64_t scratch[(CNERF_FW_SCRATCH_BYTES + 7u) / 8u];
static uint8_t tile[CNERF_FW_TILE_STRIDE * CNERF_FW_TILE_H + 1u];
static const cnerf_camera camera = CNERF_FW_CAMERA_INIT;

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

static int fail(const char *call, cnerf_status st)
{
    sh_puts("fw: ");
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

int main(void)
{
    const size_t len = CNERF_FW_STREAM_BYTES;
    ticks_start();

    /* Calibration: two loop lengths; their difference is 2 * (N2 - N1) instructions. */
    const uint32_t n1 = 100000u, n2 = 2100000u;
    const uint64_t c1 = ticks_of_spin(n1), c2 = ticks_of_spin(n2);
    const uint64_t c0 = ticks_now(), c00 = ticks_now(); /* cost of one reading */

    const uint32_t timer2_start = fw_timer2_count();
    const uint64_t t0 = ticks_now();
    cnerf_status st = cnerf_peek_scene(cnerf_fw_stream, len, CNERF_FW_SCENE, &dec.info);
    const uint64_t t1 = ticks_now();
    if (st != CNERF_OK)
        return fail("cnerf_peek", st);
    const size_t ws_need = cnerf_workspace_size(&dec.info);
    const size_t sc_need = cnerf_render_scratch_size(&dec.info);
    if (ws_need > sizeof ws)
        return too_small("workspace", ws_need, sizeof ws);
    if (sc_need > sizeof scratch)
        return too_small("render scratch", sc_need, sizeof scratch);

    const uint64_t t2 = ticks_now();
    st = cnerf_open_scene(&dec, cnerf_fw_stream, len, CNERF_FW_SCENE, ws, sizeof ws);
    const uint64_t t3 = ticks_now();
    if (st != CNERF_OK)
        return fail("cnerf_open", st);

    cnerf_render_opts opts;
    cnerf_render_defaults(&dec.info, &opts);
#if CNERF_FW_HAVE_KNOBS
    {
        static const cnerf_render_opts knobs = CNERF_FW_KNOBS_INIT;
        opts = knobs;
    }
#endif
    const uint64_t t4 = ticks_now();
    st = cnerf_render_tile(&dec, &camera, &opts, CNERF_FW_TILE_X0, CNERF_FW_TILE_Y0,
                           CNERF_FW_TILE_W, CNERF_FW_TILE_H, tile, CNERF_FW_TILE_STRIDE, scratch,
                           sizeof scratch);
    const uint64_t t5 = ticks_now();
    if (st != CNERF_OK)
        return fail("cnerf_render_tile", st);

    /* The visible pixels only: w * 3 bytes of each row, not the stride's padding. */
    fw_md5 md5;
    uint8_t digest[16];
    char hex[33];
    fw_md5_init(&md5);
    for (uint32_t y = 0; y < CNERF_FW_TILE_H; y++)
        fw_md5_update(&md5, tile + (size_t)y * CNERF_FW_TILE_STRIDE, CNERF_FW_TILE_W * 3u);
    fw_md5_final(&md5, digest);
    fw_md5_hex(digest, hex);
    const uint64_t t6 = ticks_now();
    const uint32_t timer2_end = fw_timer2_count();
    /* The work done, counted by a second render, untimed: counting the samples inside the
     * bounds costs what the renderer saves by ruling out stretches of rays unseen. */
    cnerf_render_stats work; /* field by field: no memset in this firmware */
    work.rays = work.evals = work.in_bounds = work.macs = work.list_macs = work.list_nz = 0;
    work.samples = work.layer_values = work.exact_rescales = work.wide_macs = 0;
    st = cnerf_render_tile_stats(&dec, &camera, &opts, CNERF_FW_TILE_X0, CNERF_FW_TILE_Y0,
                                 CNERF_FW_TILE_W, CNERF_FW_TILE_H, tile, CNERF_FW_TILE_STRIDE,
                                 scratch, sizeof scratch, &work);
    if (st != CNERF_OK)
        return fail("cnerf_render_tile_stats", st);

    sh_puts("fw buffers");
    put_kv("stream", len);
    put_kv("workspace_need", ws_need);
    put_kv("workspace", sizeof ws);
    put_kv("scratch_need", sc_need);
    put_kv("scratch", sizeof scratch);
    put_kv("tile_buffer", sizeof tile);
    put_kv("decoder", sizeof dec);
    sh_puts("\nfw render");
    put_kv("x0", CNERF_FW_TILE_X0);
    put_kv("y0", CNERF_FW_TILE_Y0);
    put_kv("w", CNERF_FW_TILE_W);
    put_kv("h", CNERF_FW_TILE_H);
    put_kv("n_coarse", opts.n_coarse);
    put_kv("n_fine", opts.n_fine);
    put_kv("t_stop", opts.t_stop);
    put_kv("flags", opts.flags);
    put_kv("evals", work.evals);
    put_kv("in_bounds", work.in_bounds);
    put_kv("macs", work.macs);
    put_kv("list_macs", work.list_macs);
    put_kv("list_nz", work.list_nz);
    put_kv("samples", work.samples);
    put_kv("layer_values", work.layer_values);
    put_kv("exact_rescales", work.exact_rescales);
    put_kv("wide_macs", work.wide_macs);
    put_kv("ndc", dec.info.coord == CNERF_COORD_NDC);
    put_kv("in_pos", dec.info.in_pos);
    put_kv("samples_per_ray", (uint64_t)opts.n_coarse + (dec.info.n_nets > 1 ? opts.n_fine : 0u));
    put_kv("contract", dec.info.coord == CNERF_COORD_CONTRACT);
    put_kv("grid", dec.info.grid_g);
    sh_puts("\nfw clock");
    put_kv("cpu_hz", FW_CPU_HZ);
    sh_puts("\nfw calib");
    put_kv("insns", 2u * (uint64_t)(n2 - n1));
    put_kv("ticks", c2 - c1);
    put_kv("reading_ticks", c00 - c0);
    sh_puts("\nfw ticks");
    put_kv("peek", t1 - t0);
    put_kv("open", t3 - t2);
    put_kv("render", t5 - t4);
    put_kv("md5", t6 - t5);
    sh_puts("\nfw crosscheck");
    put_kv("systick", t6 - t0);
    put_kv(FW_TIMER2_KEY, timer2_end - timer2_start);
    sh_puts("\nfw stack");
    put_kv("high_water", fw_stack_high_water());
    put_kv("size", (uint64_t)((uintptr_t)__stack_top - (uintptr_t)__stack_limit));
    sh_puts("\nmd5 ");
    sh_puts(hex);
    sh_puts("\n");
    return 0;
}

