/* ARM semihosting over BKPT 0xAB (Thumb, M profile): operation number in r0, argument (a
 * value or a pointer to a parameter block) in r1, result in r0. Operations used:
 *   0x04 SYS_WRITE0         r1 = NUL-terminated string
 *   0x18 SYS_EXIT           r1 = reason (ADP_Stopped_ApplicationExit = 0x20026 means success;
 *                           AArch32 cannot pass a status with it)
 *   0x20 SYS_EXIT_EXTENDED  r1 = {reason, subcode}: with ApplicationExit the subcode is the
 *                           exit status (semihosting v2; QEMU implements it). */
#include "semihost.h"

#define SYS_WRITE0 0x04u
#define SYS_EXIT 0x18u
#define SYS_EXIT_EXTENDED 0x20u
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u
#define ADP_STOPPED_RUNTIME_ERROR_UNKNOWN 0x20023u

static uint32_t sh_call(uint32_t op, const void *arg)
{
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void sh_puts(const char *s)
{
    (void)sh_call(SYS_WRITE0, s);
}

void sh_putu64(uint64_t v)
{
    /* Digits by restoring long division by 10 (no libgcc: no __aeabi_uldivmod). */
    char buf[21];
    unsigned i = sizeof buf - 1;
    buf[i] = '\0';
    do {
        uint64_t q = 0;
        uint32_t r = 0;
        for (int b = 63; b >= 0; b--) {
            r = (r << 1) | (uint32_t)((v >> b) & 1u);
            q <<= 1;
            if (r >= 10u) {
                r -= 10u;
                q |= 1u;
            }
        }
        buf[--i] = (char)('0' + r);
        v = q;
    } while (v != 0 && i > 0);
    sh_puts(&buf[i]);
}

void sh_puthex32(uint32_t v)
{
    static const char digits[] = "0123456789abcdef";
    char buf[11];
    buf[0] = '0';
    buf[1] = 'x';
    for (int k = 0; k < 8; k++)
        buf[2 + k] = digits[(v >> (28 - 4 * k)) & 0xfu];
    buf[10] = '\0';
    sh_puts(buf);
}

void sh_exit(int status)
{
    const uint32_t block[2] = {ADP_STOPPED_APPLICATION_EXIT, (uint32_t)status};
    (void)sh_call(SYS_EXIT_EXTENDED, block);
    (void)sh_call(SYS_EXIT, (const void *)(uintptr_t)(status == 0
                                                          ? ADP_STOPPED_APPLICATION_EXIT
                                                          : ADP_STOPPED_RUNTIME_ERROR_UNKNOWN));
    for (;;) {
    }
}
