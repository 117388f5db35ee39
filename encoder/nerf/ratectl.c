/* Rate control's law: lambda moved so that the stream's size follows a planned path
 * (cn_ratectl.h). The size is measured by whoever drives the trainer (compress/rate.c). */
#include <math.h>
#include <string.h>

#include "cn_ratectl.h"

double cn_ratectl_plan(const cn_ratectl *rc, long step)
{
    const double goal = rc->target - rc->reserved;
    const double span = CN_RC_ARRIVE * (double)(rc->iters - rc->start);
    double u = span > 0 ? (double)(step - rc->start) / span : 1;
    u = u < 0 ? 0 : u > 1 ? 1 : u;
    if (rc->first <= 0 || goal <= 0)
        return goal;
    /* Geometric: the same relative decrease per iteration. */
    return exp((1 - u) * log(rc->first) + u * log(goal));
}

/* Gains, per measurement (every rc->every iterations), measured in docs/results.md. */
#define PI_KP 1.0
#define PI_KI 0.2
#define DUAL_STEP 0.02
#define TAIL_GAIN 0.5
/* The prediction: iterations ahead, and the weight of the newest slope in its average. */
#define HORIZON 100
#define HORIZON_MAX 500
#define SLOPE_EMA 0.2
/* lambda's floor and start, in lambda_unit. */
#define LAMBDA_MIN 1e-4
#define LAMBDA_START 1e-3

double cn_ratectl_update(cn_ratectl *rc, long step, double size)
{
    if (rc->first <= 0) {
        rc->first = size;
        rc->lambda = LAMBDA_START * rc->lambda_unit;
        rc->integral = 0;
        rc->slope = 0;
    } else if (rc->size > 0) {
        rc->slope = (1 - SLOPE_EMA) * rc->slope + SLOPE_EMA * log(size / rc->size);
    }
    rc->size = size;
    rc->plan = cn_ratectl_plan(rc, step);
    const double lo = LAMBDA_MIN * rc->lambda_unit;
    if (rc->plan <= 0)
        return rc->lambda;
    /* The size keeps moving for a while after lambda does (the latents follow it over tens
     * to hundreds of iterations, and at a fixed lambda the rate still drifts down as the
     * model trains), and near the end of the run it barely answers lambda any more: both
     * controllers act on where the size is heading at its recent slope, at the end of the run
     * but HORIZON to HORIZON_MAX iterations ahead, against the plan there. */
    long h = rc->iters - step; /* to the end of the run, within [HORIZON, HORIZON_MAX] */
    h = h > HORIZON_MAX ? HORIZON_MAX : h < HORIZON ? HORIZON : h;
    /* No further ahead than the run has been watched: early on, the slope is the model's
     * warm-up (its size grows 7% in the first 20 iterations on Fern), and fifty measurements'
     * worth of it drove lambda to 0.075 units in 50 iterations and the size 26% under the
     * plan, where it stayed with lambda on its floor (tests/unit/test_ratectl.c). */
    if (h > step - rc->start)
        h = step - rc->start > rc->every ? step - rc->start : rc->every;
    const double ahead = cn_ratectl_plan(rc, step + h);
    double e = log(size / ahead) + rc->slope * (double)h / (double)rc->every;
    /* Once the plan has arrived at the goal, a size still above it adds TAIL_GAIN times its
     * excess: the extrapolated decline slows down as the learning rate decays, and without
     * this term the files ended 1.5% to 10% over on a model whose latents follow lambda ten
     * times slower at the end of the run (tests/unit/test_ratectl.c). */
    if (step >= rc->start + (long)(CN_RC_ARRIVE * (double)(rc->iters - rc->start)) &&
        size > rc->plan)
        e += TAIL_GAIN * log(size / rc->plan);
    if (rc->scheme == CN_RC_DUAL) {
        rc->lambda += DUAL_STEP * rc->lambda_unit * (exp(e) - 1);
    } else {
        /* Anti-windup: the integral stops growing while lambda sits on its floor. */
        const double l0 = log(LAMBDA_START * rc->lambda_unit);
        const double next = rc->integral + e;
        if (l0 + PI_KP * e + PI_KI * next > log(lo) || e > 0)
            rc->integral = next;
        rc->lambda = exp(l0 + PI_KP * e + PI_KI * rc->integral);
    }
    if (rc->lambda < lo)
        rc->lambda = lo;
    return rc->lambda;
}
