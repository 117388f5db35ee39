/*
 * sigstorm [-s INT|TERM|HUP] MARKER INTERVAL_US MAX_MS -- CMD [ARG...]
 *
 * Runs CMD with its standard output through a pipe and copies that output to ours. From the
 * first chunk of output that contains MARKER on, it sends CMD a SIGINT (or the signal that -s
 * names: what a scheduler or a closed terminal sends) every INTERVAL_US
 * microseconds, until CMD exits or MAX_MS milliseconds have passed. It prints the number of
 * signals sent to standard error and exits with CMD's exit status, or with 128 + the number
 * of the signal that ended CMD.
 *
 * This is a user pressing Ctrl-C over and over, very fast: every signal lands somewhere in
 * the middle of the program's work, including inside library code.
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

/* Copies what the child wrote (non-blocking after poll); returns 0 at end of output.
 * *seen becomes 1 once MARKER has appeared (a marker split across two reads is found through
 * the tail kept from the previous read). */
static int pump(int fd, const char *marker, int *seen, char *tail, size_t *tail_len)
{
    char buf[4096 + 256];
    const size_t keep = strlen(marker) - 1;
    memcpy(buf, tail, *tail_len);
    ssize_t n = read(fd, buf + *tail_len, 4096);
    if (n <= 0)
        return n < 0 && errno == EINTR;
    fwrite(buf + *tail_len, 1, (size_t)n, stdout);
    fflush(stdout);
    const size_t len = *tail_len + (size_t)n;
    buf[len] = 0;
    if (!*seen && strstr(buf, marker))
        *seen = 1;
    *tail_len = len < keep ? len : keep;
    memcpy(tail, buf + len - *tail_len, *tail_len);
    return 1;
}

int main(int argc, char **argv)
{
    int sig = SIGINT;
    if (argc > 2 && !strcmp(argv[1], "-s")) {
        sig = !strcmp(argv[2], "INT") ? SIGINT : !strcmp(argv[2], "TERM") ? SIGTERM
            : !strcmp(argv[2], "HUP") ? SIGHUP : 0;
        argc -= 2, argv += 2;
    }
    if (!sig || argc < 6 || strcmp(argv[4], "--") != 0 || !argv[1][0] || strlen(argv[1]) > 200) {
        fprintf(stderr, "usage: sigstorm [-s INT|TERM|HUP] MARKER INTERVAL_US MAX_MS -- CMD [ARG...]\n");
        return 2;
    }
    const char *marker = argv[1];
    const long interval_us = atol(argv[2]);
    const double max_ms = atof(argv[3]);
    if (interval_us < 1 || max_ms <= 0) {
        fprintf(stderr, "sigstorm: INTERVAL_US and MAX_MS must be positive\n");
        return 2;
    }
    int fds[2];
    if (pipe(fds) != 0) {
        perror("sigstorm: pipe");
        return 2;
    }
    const pid_t child = fork();
    if (child < 0) {
        perror("sigstorm: fork");
        return 2;
    }
    if (child == 0) {
        dup2(fds[1], STDOUT_FILENO);
        close(fds[0]);
        close(fds[1]);
        execvp(argv[5], argv + 5);
        perror("sigstorm: exec");
        _exit(127);
    }
    close(fds[1]);
    int seen = 0, open_out = 1;
    char tail[256];
    size_t tail_len = 0;
    long sent = 0;
    double start = 0;
    int status = 0;
    for (;;) {
        const pid_t w = waitpid(child, &status, WNOHANG);
        if (w == child)
            break;
        if (seen) {
            if (now_ms() - start > max_ms) {
                fprintf(stderr, "sigstorm: %s still running after %.0f ms of signals\n",
                        argv[5], max_ms);
                kill(child, SIGKILL);
                waitpid(child, &status, 0);
                break;
            }
            kill(child, sig);
            sent++;
        }
        if (open_out) {
            struct pollfd p = {.fd = fds[0], .events = POLLIN};
            const int timeout_ms = seen ? 0 : 100;
            if (poll(&p, 1, timeout_ms) > 0) {
                const int was = seen;
                open_out = pump(fds[0], marker, &seen, tail, &tail_len);
                if (seen && !was)
                    start = now_ms();
            }
        } else if (!seen) {
            struct timespec nap = {0, 10 * 1000 * 1000};
            nanosleep(&nap, NULL); /* output closed before the marker: wait for the exit */
        }
        if (seen) {
            struct timespec nap = {interval_us / 1000000, (interval_us % 1000000) * 1000};
            nanosleep(&nap, NULL);
        }
    }
    while (open_out) /* what the child wrote last */
        open_out = pump(fds[0], marker, &seen, tail, &tail_len);
    fprintf(stderr, "sigstorm: %ld signals sent\n", sent);
    if (WIFSIGNALED(status)) {
        fprintf(stderr, "sigstorm: %s ended by signal %d\n", argv[5], WTERMSIG(status));
        return 128 + WTERMSIG(status);
    }
    return WEXITSTATUS(status);
}
