/* The encoder's occupancy grid (encoder/compress/grid.c): cells from a density lattice, the
 * evaluation estimate, and the grid a model's density puts in the stream. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cn_export.h"
#include "cn_grid.h"
#include "cn_occ.h"
#include "cn_render.h"
#include "cn_train.h"
#include "testutil.h"

/* A cell is occupied exactly when a lattice point of its closed box is above the threshold:
 * a point on a face between cells marks both, a corner point all eight around it. */
static void test_from_lattice(void **state)
{
    (void)state;
    enum { M = 8, N1 = M + 1 };
    static float lat[N1 * N1 * N1];
    uint8_t occ[4 * 4 * 4];
    memset(lat, 0, sizeof lat);
    assert_int_equal(cn_grid_from_lattice(lat, M, 4, 0.5f, occ), 0);
    /* the lattice point (4, 4, 4): the centre, a corner of eight cells of a 4^3 grid */
    lat[(4 * N1 + 4) * N1 + 4] = 1.0f;
    assert_int_equal(cn_grid_from_lattice(lat, M, 4, 0.5f, occ), 8);
    for (int z = 0; z < 4; z++)
        for (int y = 0; y < 4; y++)
            for (int x = 0; x < 4; x++)
                assert_int_equal(occ[(z * 4 + y) * 4 + x],
                                 (x == 1 || x == 2) && (y == 1 || y == 2) && (z == 1 || z == 2));
    /* at the threshold itself: empty (occupied means above) */
    assert_int_equal(cn_grid_from_lattice(lat, M, 4, 1.0f, occ), 0);
    /* an interior point of a 2^3 grid's cell (lattice index 1): that cell only */
    lat[(4 * N1 + 4) * N1 + 4] = 0.0f;
    lat[(1 * N1 + 1) * N1 + 1] = 2.0f;
    assert_int_equal(cn_grid_from_lattice(lat, M, 2, 0.5f, occ), 1);
    assert_int_equal(occ[0], 1);
    /* g = M: each cell has its 8 corners */
    uint8_t fine[M * M * M];
    assert_int_equal(cn_grid_from_lattice(lat, M, M, 0.5f, fine), 8);
}

/* One step of dilation raises each point to the maximum of its 3x3x3 box, clipped at the
 * lattice's faces, and leaves its input alone. */
static void test_dilate(void **state)
{
    (void)state;
    enum { M = 6, N1 = M + 1 };
    static float lat[N1 * N1 * N1];
    memset(lat, 0, sizeof lat);
    lat[(3 * N1 + 3) * N1 + 3] = 2.0f; /* an interior point */
    lat[(0 * N1 + 0) * N1 + 6] = 1.0f; /* a corner of the lattice */
    float *d = cn_grid_dilate(lat, M);
    assert_non_null(d);
    int n2 = 0, n1 = 0;
    for (int k = 0; k < N1; k++)
        for (int j = 0; j < N1; j++)
            for (int i = 0; i < N1; i++) {
                const float v = d[(k * N1 + j) * N1 + i];
                const int near_c = abs(i - 3) <= 1 && abs(j - 3) <= 1 && abs(k - 3) <= 1;
                const int near_k = i >= 5 && j <= 1 && k <= 1;
                assert_true(v == (near_c ? 2.0f : near_k ? 1.0f : 0.0f));
                n2 += v == 2.0f, n1 += v == 1.0f;
            }
    assert_int_equal(n2, 27);
    assert_int_equal(n1, 8);
    assert_true(lat[(3 * N1 + 3) * N1 + 4] == 0.0f);
    /* dilated, a 2^3 grid's cell next to the point is occupied; undilated it is not */
    uint8_t occ[2 * 2 * 2];
    memset(lat, 0, sizeof lat);
    lat[(1 * N1 + 1) * N1 + 4] = 2.0f; /* x = 4, in the cell x >= 3 only */
    assert_int_equal(cn_grid_from_lattice(lat, M, 2, 0.5f, occ), 1);
    assert_int_equal(occ[1], 1);
    free(d);
    d = cn_grid_dilate(lat, M);
    assert_non_null(d);
    assert_int_equal(cn_grid_from_lattice(d, M, 2, 0.5f, occ), 2);
    assert_int_equal(occ[0], 1);
    free(d);
}

/* The estimate of evaluations left: 0 with an empty grid, 1 with a full one, in between
 * with half the box. */
static void test_eval_fraction(void **state)
{
    (void)state;
    cnerf_info hdr;
    tu_small_header(&hdr, 2, 8, 1);
    assert_int_equal(cnerf_expand_topology(&hdr), CNERF_OK);
    cn_view v;
    memset(&v, 0, sizeof v);
    /* a camera on the +x axis looking at the origin */
    const double pos[3] = {4, 0, 0}, back[3] = {1, 0, 0}, right[3] = {0, 1, 0}, up[3] = {0, 0, 1};
    for (int a = 0; a < 3; a++) {
        v.c2w[a][0] = right[a];
        v.c2w[a][1] = up[a];
        v.c2w[a][2] = back[a];
        v.c2w[a][3] = pos[a];
    }
    v.w = v.h = 16;
    v.fx = v.fy = 20;
    v.cx = v.cy = 8;
    enum { G = 8 };
    uint8_t occ[G * G * G];
    memset(occ, 0, sizeof occ);
    assert_true(cn_grid_eval_fraction(&hdr, G, occ, &v, 1, 0, 256) == 0.0);
    memset(occ, 1, sizeof occ);
    assert_true(cn_grid_eval_fraction(&hdr, G, occ, &v, 1, 0, 256) == 1.0);
    for (int i = 0; i < G * G * G; i++)
        occ[i] = i % G < G / 2; /* the half x < centre: the far half from the camera */
    const double f = cn_grid_eval_fraction(&hdr, G, occ, &v, 1, 0, 256);
    printf("half the box: %.3f of the in-bounds samples\n", f);
    assert_true(f > 0.3 && f < 0.7);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_from_lattice),
        cmocka_unit_test(test_dilate),
        cmocka_unit_test(test_eval_fraction),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
