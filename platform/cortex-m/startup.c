/* Start-up code for the cnerf firmware on the boards of fw_board.h (Cortex-M0+, M4, M7, M33,
 * M55): the vector table,
 * Reset_Handler (on Armv8-M first enables CP10/CP11, then copies .data, zeroes .bss, paints
 * the stack, enables the configurable faults, runs main and exits over semihosting with its
 * status) and one handler for every exception the firmware does not expect, which reports
 * the exception and the stacked registers over semihosting and exits with status 3.
 * SysTick_Handler is weak here: fw_render.c defines it. */
#include <stdint.h>

#include "fw_board.h"
#include "semihost.h"

#define FW_EXIT_FAULT 3
#define FW_STACK_PAINT 0xc5ac5ac5u

/* Symbols of fw-sections.ld. */
extern uint32_t __data_load[], __data_start[], __data_end[], __bss_start[], __bss_end[];
extern uint32_t __stack_limit[], __stack_top[];

int main(void);
void Reset_Handler(void) __attribute__((noreturn));
void Fault_Handler(void);
void fw_fault_report(const uint32_t *frame, uint32_t exc_return) __attribute__((noreturn));
void SysTick_Handler(void) __attribute__((weak, alias("Fault_Handler")));
uint32_t fw_stack_high_water(void);

/* System control block registers. */
#define SCB_ICSR (*(volatile uint32_t *)0xe000ed04u)
#define SCB_CCR (*(volatile uint32_t *)0xe000ed14u)
#define SCB_SHCSR (*(volatile uint32_t *)0xe000ed24u)
#define SCB_CFSR (*(volatile uint32_t *)0xe000ed28u)
#define SCB_HFSR (*(volatile uint32_t *)0xe000ed2cu)
#define SCB_MMFAR (*(volatile uint32_t *)0xe000ed34u)
#define SCB_BFAR (*(volatile uint32_t *)0xe000ed38u)
#define SCB_CPACR (*(volatile uint32_t *)0xe000ed88u)

typedef void (*fw_vector)(void);

#define FW_HANDLERS_4 Fault_Handler, Fault_Handler, Fault_Handler, Fault_Handler
#define FW_HANDLERS_32                                                                         \
    FW_HANDLERS_4, FW_HANDLERS_4, FW_HANDLERS_4, FW_HANDLERS_4, FW_HANDLERS_4, FW_HANDLERS_4, \
        FW_HANDLERS_4, FW_HANDLERS_4

#if FW_ARMV8M
#define FW_SECURE_FAULT Fault_Handler
#define FW_EXC7_NAME "SecureFault"
#else
#define FW_SECURE_FAULT 0 /* reserved */
#define FW_EXC7_NAME "reserved"
#endif

/* 16 system exceptions and the board's external interrupts (fw_board.h). Entry 0 is the
 * initial main stack pointer. */
__attribute__((section(".vectors"), used)) static const fw_vector vectors[16 + FW_IRQS] = {
    (fw_vector)(uintptr_t)__stack_top,
    Reset_Handler,
    Fault_Handler,   /* NMI */
    Fault_Handler,   /* HardFault */
    Fault_Handler,   /* MemManage */
    Fault_Handler,   /* BusFault */
    Fault_Handler,   /* UsageFault */
    FW_SECURE_FAULT, /* SecureFault (Armv8-M), else reserved */
    0, 0, 0,         /* reserved */
    Fault_Handler,   /* SVCall */
    Fault_Handler,   /* DebugMonitor */
    0,               /* reserved */
    Fault_Handler,   /* PendSV */
    SysTick_Handler,
    FW_IRQ_HANDLERS,
};

void Reset_Handler(void)
{
#if FW_ARMV8M
    /* Full access to CP10 and CP11, the FPU and the M-profile Vector Extension (Helium), before
     * any code that might use them: with the access off, their instructions raise a NOCP
     * UsageFault. */
    SCB_CPACR |= 0xfu << 20;
    __asm__ volatile("dsb\n\tisb" ::: "memory");
#endif
    /* volatile: keeps GCC from turning the loops into memcpy/memset calls (no libc). */
    volatile uint32_t *dst = __data_start;
    const uint32_t *src = __data_load;
    while (dst < __data_end)
        *dst++ = *src++;
    for (dst = __bss_start; dst < __bss_end;)
        *dst++ = 0;

    /* Paint the stack below this frame, for fw_stack_high_water (nothing lives below sp:
     * the AAPCS has no red zone, and interrupts are not enabled yet). */
    uintptr_t sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    for (dst = __stack_limit; (uintptr_t)dst < sp;)
        *dst++ = FW_STACK_PAINT;

    /* Separate MemManage, BusFault and UsageFault handlers (else they escalate to HardFault;
     * on Armv8-M SecureFault too), and trap integer division by zero. */
    SCB_SHCSR |= (1u << 16) | (1u << 17) | (1u << 18) | (FW_ARMV8M ? 1u << 19 : 0u);
    SCB_CCR |= 1u << 4;
    __asm__ volatile("dsb\n\tisb" ::: "memory");

    sh_exit(main());
}

uint32_t fw_stack_high_water(void)
{
    const volatile uint32_t *p = __stack_limit;
    while (p < __stack_top && *p == FW_STACK_PAINT)
        p++;
    return (uint32_t)((uintptr_t)__stack_top - (uintptr_t)p);
}

/* Finds the stacked exception frame (MSP or PSP, by bit 2 of EXC_RETURN) and reports. */
__attribute__((naked)) void Fault_Handler(void)
{
#if defined(__ARM_ARCH_6M__)
    /* Armv6-M: no IT blocks, and B reaches only +-2 KB (GCC hands inline assembly to the
     * assembler in divided syntax there) */
    __asm__ volatile(".syntax unified\n\t"
                     "movs r0, #4\n\t"
                     "mov r1, lr\n\t"
                     "tst r0, r1\n\t"
                     "bne 1f\n\t"
                     "mrs r0, msp\n\t"
                     "b 2f\n"
                     "1:\n\t"
                     "mrs r0, psp\n"
                     "2:\n\t"
                     "ldr r2, =fw_fault_report\n\t"
                     "bx r2\n\t"
                     ".ltorg\n\t");
#else
    __asm__ volatile("tst lr, #4\n\t"
                     "ite eq\n\t"
                     "mrseq r0, msp\n\t"
                     "mrsne r0, psp\n\t"
                     "mov r1, lr\n\t"
                     "b fw_fault_report\n\t");
#endif
}

void fw_fault_report(const uint32_t *frame, uint32_t exc_return)
{
    static const char *const names[16] = {
        "thread",     "reset",    "NMI",      "HardFault", "MemManage", "BusFault",
        "UsageFault", FW_EXC7_NAME, "reserved", "reserved", "reserved", "SVCall",
        "DebugMonitor", "reserved", "PendSV",  "SysTick"};
    const uint32_t exc = SCB_ICSR & 0x1ffu; /* VECTACTIVE */
    sh_puts("fw: unexpected exception ");
    if (exc < 16u) {
        sh_puts(names[exc]);
    } else {
        sh_puts("IRQ ");
        sh_putu64(exc - 16u);
    }
    sh_puts("\nfw:   pc ");
    sh_puthex32(frame[6]);
    sh_puts(" lr ");
    sh_puthex32(frame[5]);
    sh_puts(" xpsr ");
    sh_puthex32(frame[7]);
    sh_puts(" sp ");
    sh_puthex32((uint32_t)(uintptr_t)frame);
    sh_puts(" exc_return ");
    sh_puthex32(exc_return);
    sh_puts("\nfw:   cfsr ");
    sh_puthex32(SCB_CFSR);
    sh_puts(" hfsr ");
    sh_puthex32(SCB_HFSR);
    sh_puts(" mmfar ");
    sh_puthex32(SCB_MMFAR);
    sh_puts(" bfar ");
    sh_puthex32(SCB_BFAR);
    sh_puts("\n");
    sh_exit(FW_EXIT_FAULT);
}
