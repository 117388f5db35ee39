/* The boards the cnerf firmware runs on, as QEMU 7.2 models them; the build defines one of
 *   CNERF_FW_BOARD_AN386  MPS2 with the AN386 FPGA image: Cortex-M4 (hw/arm/mps2.c,
 *                         machine mps2-an386; memory map in mps2-an386.ld). The Cortex-M0+
 *                         build runs here too: Armv6-M code is a subset of the M4's Armv7E-M
 *                         (QEMU models no M0-class board with the RAM a stream needs)
 *   CNERF_FW_BOARD_AN500  MPS2 with the AN500 FPGA image: Cortex-M7 (hw/arm/mps2.c,
 *                         machine mps2-an500; memory map in mps2-an500.ld)
 *   CNERF_FW_BOARD_AN505  MPS2 with the AN505 FPGA image: Cortex-M33 on the IoT Kit
 *                         subsystem (hw/arm/mps2-tz.c and hw/arm/armsse.c, machine
 *                         mps2-an505; memory map in mps2-an505.ld)
 *   CNERF_FW_BOARD_AN547  MPS3 with the AN547 FPGA image: Cortex-M55 on the SSE-300
 *                         subsystem (hw/arm/mps2-tz.c and hw/arm/armsse.c, machine
 *                         mps3-an547; memory map in mps3-an547.ld)
 * and this header gives startup.c and fw_render.c what differs between them:
 *   FW_CPU_HZ           the processor clock, which SysTick counts with CLKSOURCE = 1
 *   FW_IRQS             external interrupts of the NVIC (vector table entries after the 16
 *                       system exceptions), FW_IRQ_HANDLERS that many Fault_Handler
 *   FW_ARMV8M           1 on an Armv8-M core: vector 7 is SecureFault, and CP10/CP11 (the
 *                       FPU and the M-profile Vector Extension) are enabled at reset
 *   fw_timer2_start()   starts a second counter on the processor clock, independent of
 *   fw_timer2_count()   SysTick, and reads it counting up (32 bits); fw_render.c checks
 *   FW_TIMER2_KEY       SysTick's wrap counting against it over the whole run
 * The firmware runs privileged in the Secure state (the AN547's core resets there, with the
 * SAU off: every access is Secure, whichever alias it uses). */
#ifndef CNERF_FW_BOARD_H
#define CNERF_FW_BOARD_H

#include <stdint.h>

#if defined(CNERF_FW_BOARD_AN386) || defined(CNERF_FW_BOARD_AN500)

/* The MPS2 boards without TrustZone share SYSCLK (25 MHz) and the CMSDK APB timers. */
#define FW_CPU_HZ 25000000u
#define FW_IRQS 32
#define FW_IRQ_HANDLERS FW_HANDLERS_32
#define FW_ARMV8M 0

/* CMSDK APB timer 0 of the MPS2, on the 25 MHz peripheral clock (the processor's). */
#define FW_APB_TIMER0 0x40000000u

#elif defined(CNERF_FW_BOARD_AN505)

/* MAINCLK is 20 MHz; it clocks the core, SysTick and the IoT Kit's timers. */
#define FW_CPU_HZ 20000000u
/* 32 interrupts of the IoT Kit and the AN505's 92 expansion interrupts (room for 128). */
#define FW_IRQS 128
#define FW_IRQ_HANDLERS FW_HANDLERS_32, FW_HANDLERS_32, FW_HANDLERS_32, FW_HANDLERS_32
#define FW_ARMV8M 1

/* The IoT Kit's CMSDK APB timer 0 through its Secure alias (the firmware runs Secure), on
 * MAINCLK. */
#define FW_APB_TIMER0 0x50000000u

#elif defined(CNERF_FW_BOARD_AN547)

/* MAINCLK (SYSCLK) is 32 MHz; it clocks the core, SysTick and the system counter (the APB
 * peripherals run on 25 MHz, and the SSE-300 wires no SysTick reference clock). */
#define FW_CPU_HZ 32000000u
/* 32 interrupts of the SSE-300 and the AN547's 96 expansion interrupts. */
#define FW_IRQS 128
#define FW_IRQ_HANDLERS FW_HANDLERS_32, FW_HANDLERS_32, FW_HANDLERS_32, FW_HANDLERS_32
#define FW_ARMV8M 1

/* The SSE-300's system counter (the timestamp of its system timers): a 64-bit up counter on
 * MAINCLK, enabled by CNTCR.EN in its control frame (Secure only), read from its status
 * frame; the low 32 bits do not wrap within a run. Its scaling (CNTCR.SCEN) stays off:
 * one count per clock. */
#define FW_TIMER2_KEY "syscounter"
#define SYSCNT_CNTCR (*(volatile uint32_t *)0x58100000u)
#define SYSCNT_CNTCV_LO (*(volatile uint32_t *)0x48101000u)

static inline void fw_timer2_start(void)
{
    SYSCNT_CNTCR = 1u; /* EN */
}

static inline uint32_t fw_timer2_count(void)
{
    return SYSCNT_CNTCV_LO;
}

#else
#error "define CNERF_FW_BOARD_AN386, _AN500, _AN505 or _AN547 (CMake: CNERF_FW_BOARD)"
#endif

#if defined(FW_APB_TIMER0)
/* A CMSDK APB timer as the second counter: a 32-bit down counter, started from 2^32 - 1
 * with no interrupt; it does not wrap within a run. */
#define FW_TIMER2_KEY "timer0"
#define TIMER0_CTRL (*(volatile uint32_t *)FW_APB_TIMER0)
#define TIMER0_VALUE (*(volatile uint32_t *)(FW_APB_TIMER0 + 4u))
#define TIMER0_RELOAD (*(volatile uint32_t *)(FW_APB_TIMER0 + 8u))

static inline void fw_timer2_start(void)
{
    TIMER0_CTRL = 0;
    TIMER0_RELOAD = 0xffffffffu;
    TIMER0_VALUE = 0xffffffffu;
    TIMER0_CTRL = 1u; /* enable, no interrupt */
}

static inline uint32_t fw_timer2_count(void)
{
    return 0xffffffffu - TIMER0_VALUE;
}
#endif

#endif
