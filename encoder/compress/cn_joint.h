/*
 * Several scenes trained jointly (the paper's section 3, "Compressing multiple scenes"):
 * one trainer per scene, each with its own latents, affine decoders, biases, priors and
 * render parameters, and one shared shift model whose latents S_l and scales g_l every
 * scene's kernels add: W_m,l = a_m,l round(k_m,l) + b_m,l + g_l round(S_l). The objective
 * is sum_m (D_m + lambda R_m) + lambda R(S): each scene's rate and distortion as for one
 * scene, and the shifts' rate once.
 *
 * The shifts start at 0 (the single-scene models) and g_l at the layer's initial
 * quantization step, Glorot limit / levels, the kernels' own a; the shifts learn in weight
 * units at the main rate (Adam's step lr / g0_l), g at its own rate (lr_shift_scale, decayed
 * with the main one), their priors at the priors' rate.
 */
#ifndef CNERF_ENC_JOINT_H
#define CNERF_ENC_JOINT_H

#include "cn_ckpt.h"
#include "cn_train.h"

#define CN_JOINT_MAGIC CN_CKPT_JOINT_MAGIC
#define CN_JOINT_VERSION 1u

typedef struct cn_joint {
    unsigned n;       /* scenes */
    cn_trainer *t;    /* one per scene */
    cn_model shift;   /* the shared shifts: latents S, a = g, b = 0 */
    double lr_shift_scale; /* learning rate of the g_l */
    long step;
    double shift_bits; /* the last step's noisy rate estimate of the shifts */
    char err[256];
} cn_joint;

/* Trainers for datasets ds[0..n) with options o (scene m draws its rays from seed o->seed +
 * m), and the shift model; every scene must give the same topology (else -1 and a message
 * naming the first that does not). */
int cn_joint_init(cn_joint *j, const cn_dataset *ds, unsigned n, const cn_train_opts *o,
                  double lr_shift_scale, char *err, size_t errlen);
void cn_joint_free(cn_joint *j);

/* One iteration: a step of every scene (each on its own batch), then the shifts' rate and
 * update. mse[m] gets scene m's fine (or only) MSE, bits[m] its latents' noisy rate (NULL:
 * not wanted). Returns the sum of the scenes' losses, or NaN with a message in j->err. */
double cn_joint_step(cn_joint *j, double *mse, double *bits);

/* The lambda the shifts' rate is weighted with: the scenes' mean (the same for a fixed
 * --lambda; with --quality each scene sets its own at each step). */
double cn_joint_lambda(const cn_joint *j);

/* The joint checkpoint: "CNJT", u32 version, u32 scenes, u64 step, u64 n_params of the shift
 * model, its params, Adam m and v (f32), then per scene a u64 length and that scene's
 * checkpoint (cn_checkpoint_put), and a CRC-32 of everything before it. */
int cn_joint_save(const cn_joint *j, const char *path, char *err, size_t errlen);
/* Restores every scene and the shifts into an initialised cn_joint of the same scenes. */
int cn_joint_resume(cn_joint *j, const char *path, char *err, size_t errlen);

#endif /* CNERF_ENC_JOINT_H */
