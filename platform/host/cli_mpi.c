/* cnerf train and encode over MPI (a build with -DCNERF_MPI=ON): every rank runs the same
 * command on the same data, and each training step's batch is shared among the ranks
 * (cn_trainer_share_all): each renders its chunks of rays, and the errors and gradients are
 * summed over all ranks in 128-bit fixed point (cn_xsum.h) by MPI_Iallreduce with an operation
 * of our own, which is exact, so that every rank takes the step one process takes, to the
 * bit, for any number of ranks. Rank 0 alone writes files and prints; the others write
 * nothing (cn_files_discard) and print only what makes them fail. docs/training.md, "Several
 * processes". Without MPI the functions are the one-process ones. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sched.h>

#include "cli.h"
#include "cn_file.h"
#include "cn_train.h"

#if defined(CNERF_MPI)
#include <mpi.h>

static cn_share share;
static MPI_Comm end_comm; /* the end's barrier, apart from the steps' sums */
static MPI_Datatype xsum_type;
static MPI_Op xsum_op;
static int mpi_up;
/* What the sums cost (printed by rank 0 at the end with CNERF_MPI_STATS=1): their count,
 * bytes, and the seconds spent in them (which include waiting for slower ranks). */
static double sum_secs, sum_bytes, run_start;
static long n_sums;

/* inout[i] += in[i] over 16-byte integers (copied: MPI's buffers promise no alignment). */
static void xsum_add(void *in, void *inout, int *len, MPI_Datatype *type)
{
    (void)type;
    unsigned char *a = in, *b = inout;
    for (int i = 0; i < *len; i++) {
        cn_xsum x, y;
        memcpy(&x, a + 16 * (size_t)i, 16);
        memcpy(&y, b + 16 * (size_t)i, 16);
        y = cn_xsum_plus(y, x);
        memcpy(b + 16 * (size_t)i, &y, 16);
    }
}

/* Naming a rank that died or hangs. A rank that never reaches a sum leaves the others
 * waiting in it, and the launcher ends the job without saying more than which process it
 * lost. So the sum is nonblocking, and its wait watches the clock and the stop signal, and
 * answers a watcher's ping (rank 0 watches ranks 1..size-1, rank 1 watches rank 0):
 *  - when the launcher ends a job because a rank died, mpirun and Slurm send the others a
 *    stop signal: a rank that takes one while it waits answers that it is alive (to rank 0;
 *    rank 0 to rank 1), and WAIT_NAME_S later the waiting ranks 0 and 1 name the ranks they
 *    have heard nothing from;
 *  - a rank that waits longer than the limit (CNERF_MPI_WAIT seconds, WAIT_LIMIT_S by
 *    default) pings the ranks it watches; any rank waiting in a sum answers, so one that does
 *    not within PING_S has died or hangs, and the watcher names it and ends the job (a rank
 *    whose watched ranks all answer leaves that to rank 0 for LEAVE_S more, then ends it). */
#define WAIT_NAME_S 0.5
#define WAIT_LIMIT_S 600.0
#define PING_S 1.0
#define LEAVE_S 10.0
#define TAG_ALIVE 1
#define TAG_PING 2
#define TAG_PONG 3
static MPI_Comm watch_comm;
static MPI_Request *alive_req, *pong_req, alive_sent = MPI_REQUEST_NULL;
static long alive_msg, *alive_got, ping_msg, *pong_got;
static double wait_limit = WAIT_LIMIT_S;
static const char *cmd_name = "cnerf";

/* The ranks that rank `me` watches: [lo, hi); the rank that watches it: *by. */
static void watched(int me, int size, int *lo, int *hi, int *by)
{
    *lo = me == 0 ? 1 : 0;
    *hi = me == 0 ? size : me == 1 ? 1 : 0;
    *by = me == 0 ? 1 : 0;
}

/* Prints the watched ranks whose request in req[] has not completed (after `waited` s in
 * sum `seq`); returns how many. */
static int name_missing(MPI_Request *req, long seq, double waited, const char *what,
                        const char *then)
{
    int lo, hi, by, n = 0;
    char list[512] = "";
    size_t k = 0;
    watched(share.rank, share.size, &lo, &hi, &by);
    for (int r = lo; r < hi; r++) {
        int done = 0;
        if (req[r] != MPI_REQUEST_NULL)
            MPI_Test(&req[r], &done, MPI_STATUS_IGNORE);
        if (done || req[r] == MPI_REQUEST_NULL)
            continue;
        if (k < sizeof list)
            k += (size_t)snprintf(list + k, sizeof list - k, "%s%d", n ? ", " : "", r);
        n++;
    }
    if (n)
        fprintf(stderr, "cnerf %s: rank %d has waited %.1f s in the ranks' sum %ld: rank%s %s "
                "of %d %s %s (%s); %s\n", cmd_name, share.rank, waited, seq, n > 1 ? "s" : "",
                list, share.size, n > 1 ? "have" : "has", what,
                n > 1 ? "they have died or hang" : "it has died or hangs", then);
    return n;
}

/* A watcher's ping at the limit (below): answered while this rank waits in a sum. */
static void answer_pings(void)
{
    for (;;) {
        int ping = 0;
        MPI_Status st;
        MPI_Iprobe(MPI_ANY_SOURCE, TAG_PING, watch_comm, &ping, &st);
        if (!ping)
            return;
        long v;
        MPI_Recv(&v, 1, MPI_LONG, st.MPI_SOURCE, TAG_PING, watch_comm, MPI_STATUS_IGNORE);
        MPI_Send(&v, 1, MPI_LONG, st.MPI_SOURCE, TAG_PONG, watch_comm);
    }
}

static int mpi_allsum(void *ctx, cn_xsum *v, size_t n)
{
    (void)ctx;
    const double t0 = MPI_Wtime();
    const long seq = ++n_sums;
    sum_bytes += 16.0 * (double)n;
    int lo, hi, by;
    watched(share.rank, share.size, &lo, &hi, &by);
    int named = 0;
    double signal_at = -1, limit_at = -1;
    int limit_named = 0;
    for (size_t done = 0; done < n;) {
        const size_t k = n - done < (1u << 30) ? n - done : (1u << 30);
        MPI_Request req;
        if (MPI_Iallreduce(MPI_IN_PLACE, v + done, (int)k, xsum_type, xsum_op, MPI_COMM_WORLD,
                           &req) != MPI_SUCCESS)
            return -1;
        for (long polls = 0;; polls++) {
            int flag = 0;
            if (MPI_Test(&req, &flag, MPI_STATUS_IGNORE) != MPI_SUCCESS)
                return -1;
            if (flag)
                break;
            if (polls % 1024 != 1023) /* the clock now and then; between, as MPI waits */
                continue;
            sched_yield();
            const double now = MPI_Wtime();
            if (signal_at < 0 && cli_stop_signal()) {
                signal_at = now;
                if (alive_sent == MPI_REQUEST_NULL) {
                    alive_msg = seq;
                    MPI_Isend(&alive_msg, 1, MPI_LONG, by, TAG_ALIVE, watch_comm, &alive_sent);
                }
            }
            if (!named && signal_at >= 0 && now - signal_at >= WAIT_NAME_S)
                named = name_missing(alive_req, seq, now - t0, "not answered the stop signal",
                                     "the job is being stopped");
            answer_pings();
            if (now - t0 > wait_limit && limit_at < 0) {
                /* PING_S more of polls (this rank may itself have been stopped), pinging the
                 * ranks it watches */
                limit_at = now;
                ping_msg = seq;
                for (int r = lo; r < hi; r++) {
                    MPI_Request ping;
                    MPI_Isend(&ping_msg, 1, MPI_LONG, r, TAG_PING, watch_comm, &ping);
                    MPI_Request_free(&ping);
                    MPI_Irecv(&pong_got[r], 1, MPI_LONG, r, TAG_PONG, watch_comm, &pong_req[r]);
                }
            }
            /* Then the watcher names the ranks and ends the job; a rank whose watched ranks
             * all answer leaves that to rank 0 (which watches every rank) for LEAVE_S more. */
            int end = 0, fallback = 0;
            if (limit_at >= 0 && now - limit_at > PING_S && !limit_named) {
                limit_named = 1;
                end = name_missing(pong_req, seq, now - t0, "not answered a ping in 1 s",
                                   "ending every rank");
                fallback = !end && share.rank == 0;
            }
            if (limit_at >= 0 && now - limit_at > PING_S + LEAVE_S)
                fallback = 1;
            if (fallback)
                fprintf(stderr, "cnerf %s: rank %d has waited %.1f s in the ranks' sum %ld, "
                        "which the ranks it watches reached and answer in: another has died "
                        "or hangs; ending every rank\n", cmd_name, share.rank, now - t0, seq);
            if (end || fallback)
                MPI_Abort(MPI_COMM_WORLD, 1);
        }
        done += k;
    }
    sum_secs += MPI_Wtime() - t0;
    return 0;
}

static int mpi_vote(void *ctx)
{
    (void)ctx;
    return cli_stop_signal();
}

int cli_mpi_init(int *argc, char ***argv)
{
    int provided = 0;
    if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        fprintf(stderr, "cnerf: MPI_Init_thread failed\n");
        return -1;
    }
    mpi_up = 1;
    run_start = MPI_Wtime();
    int rank = 0, size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if (provided < MPI_THREAD_FUNNELED) { /* OpenMP's threads never call MPI, the main does */
        if (rank == 0)
            fprintf(stderr, "cnerf: this MPI library gives thread level %d, below "
                    "MPI_THREAD_FUNNELED\n", provided);
        return -1;
    }
    if (size == 1)
        return 0;
    const char *cmd = *argc > 1 ? (*argv)[1] : "";
    const int trains = !strcmp(cmd, "train") || !strcmp(cmd, "encode");
    if (!trains && strcmp(cmd, "eval")) {
        if (rank == 0)
            fprintf(stderr, "cnerf %s: runs as one process; of the commands, train, encode and "
                    "eval run on several (this is rank 0 of %d)\n", cmd, size);
        return -1;
    }
    MPI_Type_contiguous(16, MPI_BYTE, &xsum_type);
    MPI_Type_commit(&xsum_type);
    MPI_Op_create(xsum_add, 1, &xsum_op);
    MPI_Comm_dup(MPI_COMM_WORLD, &end_comm);
    MPI_Comm_dup(MPI_COMM_WORLD, &watch_comm);
    alive_req = malloc(sizeof *alive_req * (size_t)size);
    pong_req = malloc(sizeof *pong_req * (size_t)size);
    pong_got = malloc(sizeof *pong_got * (size_t)size);
    alive_got = malloc(sizeof *alive_got * (size_t)size);
    if (!alive_req || !alive_got || !pong_req || !pong_got) {
        fprintf(stderr, "cnerf: out of memory (rank %d of %d)\n", rank, size);
        return -1;
    }
    int lo, hi, by;
    watched(rank, size, &lo, &hi, &by);
    for (int r = 0; r < size; r++) {
        alive_req[r] = pong_req[r] = MPI_REQUEST_NULL;
        if (r >= lo && r < hi) /* open for the whole run: an answer may come at any sum */
            MPI_Irecv(&alive_got[r], 1, MPI_LONG, r, TAG_ALIVE, watch_comm, &alive_req[r]);
    }
    cmd_name = (*argv)[1];
    const char *limit = getenv("CNERF_MPI_WAIT");
    if (limit && *limit) {
        char *end;
        const double w = strtod(limit, &end);
        if (*end || !(w > 0)) {
            if (rank == 0)
                fprintf(stderr, "cnerf: CNERF_MPI_WAIT=%s: give seconds, more than 0\n", limit);
            return -1;
        }
        wait_limit = w;
    }
    share = (cn_share){rank, size, mpi_allsum, NULL, mpi_vote};
    cn_trainer_share_all(&share);
    cli_stop_shared(1);
    if (rank > 0) {
        /* eval's ranks each write the views they render; train's and encode's, nothing */
        if (trains)
            cn_files_discard(1);
        if (!freopen("/dev/null", "w", stdout))
            return -1;
    }
    return 0;
}

const cn_share *cli_mpi_share(void) { return share.size > 1 ? &share : NULL; }

int cli_mpi_agree(int rc)
{
    if (share.size <= 1)
        return rc;
    cn_xsum x = cn_xsum_of(rc != 0);
    if (mpi_allsum(NULL, &x, 1))
        return 1;
    return cn_xsum_value(x) != 0 ? (rc ? rc : 1) : 0;
}

int cli_mpi_end(int rc)
{
    if (!mpi_up)
        return rc;
    if (share.size > 1) {
        /* Every rank meets here at the end. A command that fails fails on every rank alike
         * (the same data, the same steps), and they all arrive; a rank that failed alone (its
         * write, its memory) would wait for ranks that wait for it in a step's sum: after a
         * minute it ends them all. */
        MPI_Request req;
        MPI_Ibarrier(end_comm, &req);
        int done = 0;
        for (long ms = 0; !done; ms += 10) {
            MPI_Test(&req, &done, MPI_STATUS_IGNORE);
            if (!done && rc != 0 && ms >= 60000) {
                fprintf(stderr, "cnerf: rank %d of %d failed (exit status %d) and the other "
                        "ranks did not end with it within 60 s: ending every rank\n",
                        share.rank, share.size, rc);
                MPI_Abort(MPI_COMM_WORLD, rc);
            }
            if (!done) {
                const struct timespec t = {0, 10000000};
                nanosleep(&t, NULL);
            }
        }
        MPI_Comm_free(&end_comm);
        /* The stop answers: the ones sent were received (every rank's answer goes to a
         * receive open all run); the receives that got none are cancelled. */
        MPI_Wait(&alive_sent, MPI_STATUS_IGNORE);
        for (int r = 0; r < share.size; r++)
            if (alive_req[r] != MPI_REQUEST_NULL) {
                int got = 0;
                MPI_Test(&alive_req[r], &got, MPI_STATUS_IGNORE);
                if (!got) {
                    MPI_Cancel(&alive_req[r]);
                    MPI_Wait(&alive_req[r], MPI_STATUS_IGNORE);
                }
            }
        MPI_Comm_free(&watch_comm);
        free(alive_req);
        free(pong_req);
        free(pong_got);
        free(alive_got);
        const char *stats = getenv("CNERF_MPI_STATS");
        if (share.rank == 0 && stats && !strcmp(stats, "1"))
            fprintf(stderr, "cnerf: %d ranks: %ld sums of %.1f MB in all, %.2f s in "
                    "the sums, of the run's %.2f s (%.1f%%)\n", share.size, n_sums,
                    sum_bytes / 1e6, sum_secs, MPI_Wtime() - run_start,
                    100.0 * sum_secs / (MPI_Wtime() - run_start));
    }
    MPI_Finalize();
    return rc;
}

#else

int cli_mpi_init(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    return 0;
}

int cli_mpi_end(int rc) { return rc; }

const cn_share *cli_mpi_share(void) { return NULL; }

int cli_mpi_agree(int rc) { return rc; }

#endif
