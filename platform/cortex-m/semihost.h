/* ARM semihosting (the "bkpt 0xAB" ABI of M-profile cores) for the firmware: text output to
 * the host console and exit with a status. Works under a debugger or QEMU with
 * -semihosting-config enable=on; on a board without a debugger attached, BKPT halts the
 * core (lockup in a fault handler), so these calls are for test firmware only. */
#ifndef CNERF_FW_SEMIHOST_H
#define CNERF_FW_SEMIHOST_H

#include <stdint.h>

/* SYS_WRITE0: writes a NUL-terminated string to the host's debug console. */
void sh_puts(const char *s);

/* Helpers over sh_puts: an unsigned decimal, a 32-bit value as 0x%08x. */
void sh_putu64(uint64_t v);
void sh_puthex32(uint32_t v);

/* SYS_EXIT_EXTENDED (ADP_Stopped_ApplicationExit, status): the host exits with `status`.
 * Falls back to SYS_EXIT (status 0: application exit, else run-time error) if the host
 * returns, and spins if that returns too. */
void sh_exit(int status) __attribute__((noreturn));

#endif
