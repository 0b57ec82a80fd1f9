/* mech_jacobian.c - exact Jacobian of the motion (see mech_jacobian.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/linalg.h"
#include "mech/mech_jacobian.h"

int nz_ode_jacobian(const nz_system *s, const int *orders, const int *linear,
                    const nz_accel_options *opt, int work, double t, const double *y, double *dfdy,
                    double *dfdt, nz_solve_info *mass, nz_accel_report *rep)
{
  int k = s->k, nc = s->nc, N = k + nc, dim = 2 * k + (work ? 1 : 0), st;
  const double *q = y, *qd = y + k;
  size_t kk = (size_t)k * k, NN = (size_t)N * N;
  double *buf = calloc(2 * kk + NN + 2 * (size_t)nc * k + 8 * (size_t)N + 4 * (size_t)k, sizeof(double));
  int *flags = calloc(3 * (size_t)nc + 1, sizeof(int));
  if (!buf || !flags) { free(buf); free(flags); return NZ_ENOMEM; }
  double *M = buf, *H = M + kk, *J = H + kk, *A = J + NN, *dA = A + (size_t)nc * k;
  double *x = dA + (size_t)nc * k, *rhs = x + N, *dx = rhs + N, *h = dx + N;
  double *r = h + N, *dr = r + N, *e = dr + N, *zero = e + N;
  double *val = zero + N, *dval = val + N;

  /* M and h once; then the motion's accelerations and multipliers (without
   * constraints: M qdd = -h by Cholesky on a copy, J is scratch until below). */
  if ((st = nz_mass_bias(s, t, q, qd, M, h))) goto done;
  if (nc == 0) {
    memcpy(J, M, kk * sizeof(double));
    for (int i = 0; i < k; i++) rhs[i] = -h[i];
    st = nz_solve_spd(k, J, rhs, x, opt->rcond_min, mass);   /* its eigenvalues when singular */
  } else {
    rep->used = flags + nc;
    st = nz_accel_constrained(s, orders, linear, t, q, qd, opt, x, x + k, rep);
    rep->used = NULL;              /* flags is freed below */
    orders = flags + nc;           /* the classification the check settled on here */
    linear = flags + 2 * nc;
  }
  if (st) goto done;
  const double *state[3] = { q, qd, x };

  /* J = [M - sum lambda_r H_r, -A^T; A, 0] at the solution. */
  memset(J, 0, NN * sizeof(double));
  for (int i = 0; i < k; i++)
    for (int j = 0; j < k; j++) J[i * N + j] = M[i * k + j];
  for (int c = 0; c < nc; c++) {
    if ((st = nz_constraint_row_stabilized(s, c, orders[c], t, state, 3, opt->baumgarte_alpha,
                                           opt->baumgarte_beta, A + (size_t)c * k, &val[c]))) goto done;
    if (orders[c] == 2 && !linear[c]) {
      if ((st = nz_constraint_hessian(s, c, t, state, 3, H))) goto done;
      for (int i = 0; i < k; i++)
        for (int j = 0; j < k; j++) J[i * N + j] -= x[k + c] * H[i * k + j];
    }
    for (int i = 0; i < k; i++) {
      J[i * N + k + c] = -A[(size_t)c * k + i];
      J[(k + c) * N + i] = A[(size_t)c * k + i];
    }
  }

  memset(dfdy, 0, (size_t)dim * dim * sizeof(double));
  memset(dfdt, 0, (size_t)dim * sizeof(double));
  for (int i = 0; i < k; i++) dfdy[i * dim + k + i] = 1.0;       /* (q)' = q' */

  /* One direction per state component, and t last: d(a, lambda) = -J^-1 dG. */
  for (int j = 0; j <= 2 * k; j++) {
    memset(e, 0, (size_t)k * sizeof(double));
    memset(zero, 0, (size_t)k * sizeof(double));
    nz_state_direction dir = { j == 2 * k ? 1.0 : 0.0, j < k ? e : zero, (j >= k && j < 2 * k) ? e : zero, NULL };
    if (j < 2 * k) e[j % k] = 1.0;
    if ((st = nz_nielsen_residual_along(s, t, state, &dir, r, dr))) goto done;
    for (int i = 0; i < k; i++) rhs[i] = -dr[i];
    for (int c = 0; c < nc; c++) {
      double v, *Ac = dx;                           /* scratch: dx is overwritten below */
      if ((st = nz_constraint_row_along(s, c, orders[c], t, state, 3, opt->baumgarte_alpha,
                                        opt->baumgarte_beta, &dir, Ac, &v, dA, &dval[c]))) goto done;
      for (int i = 0; i < k; i++) rhs[i] += x[k + c] * dA[i];
      rhs[k + c] = -dval[c];
    }
    double rcond;
    if ((st = nz_solve_svd(N, J, rhs, dx, &rcond))) goto done;
    if (!(rcond >= opt->rcond_min)) {          /* said as the right-hand side says it */
      st = NZ_ESINGULAR;
      /* M's eigenvalues for the message: a threshold no matrix meets makes
       * the SPD solve diagnose it */
      if (nc == 0) nz_solve_spd(k, memcpy(H, M, kk * sizeof(double)), rhs, dx, INFINITY, mass);
      else {
        rep->failure = NZ_ACCEL_SINGULAR;
        rep->rcond = rcond;
        nz_constraint_dependence(nc, k, A, rep);
      }
      goto done;
    }
    for (int i = 0; i < k; i++) {
      if (j < 2 * k) dfdy[(k + i) * dim + j] = dx[i];
      else dfdt[k + i] = dx[i];
    }
  }
done:
  free(buf);
  free(flags);
  return st;
}
