#include "progress.h"

#include <time.h>
#include <unistd.h>

double cli_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

void cli_progress_init(cli_progress *p, long start, long total, long log_every)
{
    p->out = stderr;
    p->tty = isatty(fileno(stderr));
    if (!p->tty)
        p->out = stdout;
    p->start = start;
    p->total = total;
    p->log_every = log_every > 0 ? log_every : 100;
    p->t0 = p->last_draw = cli_now();
}

static void fmt_time(char *buf, size_t n, double s)
{
    long t = (long)(s + 0.5);
    if (t >= 3600)
        snprintf(buf, n, "%ldh%02ldm", t / 3600, t / 60 % 60);
    else
        snprintf(buf, n, "%ldm%02lds", t / 60, t % 60);
}

void cli_progress_update(cli_progress *p, long it, double loss, double psnr, const char *extra)
{
    if (!extra)
        extra = "";
    const double now = cli_now(), el = now - p->t0;
    const long done = it - p->start;
    const double rate = el > 0 ? done / el : 0;
    char eta[32];
    fmt_time(eta, sizeof eta, rate > 0 ? (p->total - it) / rate : 0);
    if (p->tty) {
        if (now - p->last_draw < 0.2 && it != p->total)
            return;
        p->last_draw = now;
        const int width = 24;
        int fill = p->total ? (int)((double)it / p->total * width) : width;
        char bar[32];
        for (int i = 0; i < width; i++)
            bar[i] = i < fill ? '#' : '.';
        bar[width] = 0;
        fprintf(p->out, "\r[%s] %ld/%ld  loss %.5g  psnr %5.2f dB%s  %.2f it/s  ETA %s   ", bar,
                it, p->total, loss, psnr, extra, rate, eta);
        fflush(p->out);
    } else if (it % p->log_every == 0 || it == p->total) {
        fprintf(p->out, "iter %ld/%ld loss %.5g psnr %.2f dB%s %.3f s/it ETA %s\n", it, p->total,
                loss, psnr, extra, rate > 0 ? 1 / rate : 0, eta);
        fflush(p->out);
    }
}

void cli_progress_break(cli_progress *p)
{
    if (p->tty)
        fputc('\n', p->out);
}

void cli_progress_pause(cli_progress *p, double secs) { p->t0 += secs; }

void cli_progress_done(cli_progress *p)
{
    if (p->tty)
        fputc('\n', p->out);
}
