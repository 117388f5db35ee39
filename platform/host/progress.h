/* Progress reporting for long work: a bar on a terminal, periodic lines otherwise. */
#ifndef CNERF_PROGRESS_H
#define CNERF_PROGRESS_H

#include <stdio.h>

typedef struct cli_progress {
    FILE *out;
    int tty;
    long total, start, log_every;
    double t0, last_draw;
} cli_progress;

/* Monotonic seconds. */
double cli_now(void);
void cli_progress_init(cli_progress *p, long start, long total, long log_every);
/* Iteration `it` (1-based, counts from the start of the run) done; `extra` (may be NULL)
 * is appended to the line. */
void cli_progress_update(cli_progress *p, long it, double loss, double psnr, const char *extra);
/* On a terminal, ends the bar's line so that a message line can follow. */
void cli_progress_break(cli_progress *p);
/* Leaves `secs` out of the rate and ETA (time spent on something other than iterations). */
void cli_progress_pause(cli_progress *p, double secs);
void cli_progress_done(cli_progress *p);

#endif
