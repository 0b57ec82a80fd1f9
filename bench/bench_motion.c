/* bench_motion.c - nz_mass_bias through the jets (the path of a system
 * without a recording), with a C evaluator so that the mechanics' own cost
 * shows: F = sum_i (1 + q_i^2) q'_i^2 / 2, k = 2..16.  It makes k + 2
 * evaluations per call, k + 1 of one shape: the motion workspace
 * (mech.h, nz_motion_reset) keeps their jets.  Best of 7 runs of 0.1 s;
 * prints a table, asserts nothing.  M_00 = 1 and M_11 = 1.01 (q_1 = 0.1)
 * are printed as a check that the work was done. */
#include <stdio.h>
#include <time.h>
#include "mech/mech.h"

static double now(void)
{
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* Scratch jets of the evaluator, kept between calls like the workspace. */
static nz_jet *sa, *sb, *sc;
static double work[4096];

static int fit(int K, int D)
{
  if (sa && sa->order == K && sa->ntan == D) return 0;
  nz_jet_free(sa);
  nz_jet_free(sb);
  nz_jet_free(sc);
  sa = nz_jet_alloc(K, D);
  sb = nz_jet_alloc(K, D);
  sc = nz_jet_alloc(K, D);
  return !sa || !sb || !sc;
}

static int eval_f(void *ctx, nz_piece p, int index, const nz_jet *t, nz_jet *const *const *lv,
                  int nl, nz_jet *const *out, const nz_direction *dir)
{
  (void)index; (void)t; (void)nl; (void)dir;
  int k = *(const int *)ctx;
  nz_jet *o = out[0];
  if (p != NZ_PIECE_F) return NZ_EARG;
  if (fit(o->order, o->ntan)) return NZ_ENOMEM;
  nz_jet_init(o, o->order, o->ntan);
  for (int i = 0; i < k; i++) {
    nz_jet_mul(sa, lv[0][i], lv[0][i], work);
    nz_jet_offset(sb, sa, 1.0);
    nz_jet_mul(sa, lv[1][i], lv[1][i], work);
    nz_jet_mul(sc, sa, sb, work);
    nz_jet_scale(sa, sc, 0.5);
    nz_jet_add(sc, o, sa);
    nz_jet_copy(o, sc);
  }
  return NZ_OK;
}

int main(void)
{
  printf("nz_mass_bias on jets with a C evaluator (the mechanics' own cost)\n");
  printf("%4s %14s %8s %8s\n", "k", "per call", "M_00", "M_11");
  for (int k = 2; k <= 16; k *= 2) {
    nz_system s = { 0 };
    s.k = k;
    s.has = 1u << NZ_PIECE_F;
    s.ev.eval = eval_f;
    s.ev.ctx = &k;
    double q[16], qd[16], M[256], h[16], best = 1e30;
    for (int i = 0; i < k; i++) {
      q[i] = 0.1 * i;
      qd[i] = 0.2 - 0.01 * i;
    }
    for (int rep = 0; rep < 7; rep++) {
      int n = 0;
      double t0 = now(), el;
      do {
        for (int r = 0; r < 20; r++)
          if (nz_mass_bias(&s, 0.0, q, qd, M, h)) { fprintf(stderr, "nz_mass_bias failed\n"); return 1; }
        n += 20;
        el = now() - t0;
      } while (el < 0.1);
      if (el / n < best) best = el / n;
    }
    printf("%4d %11.2f us %8.3f %8.3f\n", k, 1e6 * best, M[0], M[k + 1]);
  }
  return 0;
}
