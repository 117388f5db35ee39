/* cnerf train and encode over MPI (a build with -DCNERF_MPI=ON): every rank runs the same
 * command on the same data, and each training step's batch is shared among the ranks
 * (cn_trainer_share_all): each renders its chunks of rays, and the errors and gradients are
 * summed over all ranks in 128-bit fixed point (cn_xsum.h) by MPI_Allreduce with an operation
 * of our own, which is exact, so that every rank takes the step one process takes, to the
 * bit, for any number of ranks. Rank 0 alone writes files and prints; the others write
 * nothing (cn_files_discard) and print only what makes them fail. docs/training.md, "Several
 * processes". Without MPI the functions are the one-process ones. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

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
 * bytes, and the seconds spent in MPI_Allreduce (which include waiting for slower ranks). */
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

static int mpi_allsum(void *ctx, cn_xsum *v, size_t n)
{
    (void)ctx;
    const double t0 = MPI_Wtime();
    n_sums++;
    sum_bytes += 16.0 * (double)n;
    for (size_t done = 0; done < n;) {
        const size_t k = n - done < (1u << 30) ? n - done : (1u << 30);
        if (MPI_Allreduce(MPI_IN_PLACE, v + done, (int)k, xsum_type, xsum_op, MPI_COMM_WORLD) !=
            MPI_SUCCESS)
            return -1;
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
    if (strcmp(cmd, "train") && strcmp(cmd, "encode")) {
        if (rank == 0)
            fprintf(stderr, "cnerf %s: runs as one process; of the commands, train and encode "
                    "run on several (this is rank 0 of %d)\n", cmd, size);
        return -1;
    }
    MPI_Type_contiguous(16, MPI_BYTE, &xsum_type);
    MPI_Type_commit(&xsum_type);
    MPI_Op_create(xsum_add, 1, &xsum_op);
    MPI_Comm_dup(MPI_COMM_WORLD, &end_comm);
    share = (cn_share){rank, size, mpi_allsum, NULL, mpi_vote};
    cn_trainer_share_all(&share);
    cli_stop_shared(1);
    if (rank > 0) {
        cn_files_discard(1);
        if (!freopen("/dev/null", "w", stdout))
            return -1;
    }
    return 0;
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
        const char *stats = getenv("CNERF_MPI_STATS");
        if (share.rank == 0 && stats && !strcmp(stats, "1"))
            fprintf(stderr, "cnerf: %d ranks: %ld sums of %.1f MB in all, %.2f s in "
                    "MPI_Allreduce of the run's %.2f s (%.1f%%)\n", share.size, n_sums,
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

#endif
