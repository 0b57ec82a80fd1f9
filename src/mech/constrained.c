/* constrained.c - constraint primitives and constrained accelerations (see
 * constrained.h).  Linear algebra on GSL: the saddle-point matrix
 * [M -A^T; A 0] is solved through its SVD, which gives its condition at no
 * extra cost and, when it is singular, the constraints to blame. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_linalg.h>
#include <gsl/gsl_multiroots.h>
#include "mech/constrained.h"
#include "core/linalg.h"

/* ------------------------------------------------------------------ */
/* Primitives                                                           */

int nz_constraint_partials(const nz_system *s, int r, double t, const double *const *state,
                           int nstate, double *value, double *dphi, double *dphidt)
{
  nz_motion mo = { 0 };          /* direction j k + i: slot j of q_i, for the L slots; L k: t */
  nz_constraint_seeding sd = { .D = -1, .t_variable = 1, .count = -1, .by_slot = 1 };
  int st = nz_constraint_eval(s, r, &mo, t, state, nstate, &sd);
  if (!st) {
    int L = mo.nslots, k = mo.k;
    *value = mo.out[0]->c[0];
    for (int d = 0; d < L * k; d++) dphi[d] = nz_jet_tangent(mo.out[0], d)[0];
    *dphidt = nz_jet_tangent(mo.out[0], L * k)[0];
  }
  nz_motion_free(&mo);
  return st;
}

int nz_constraint_state_gradient(const nz_system *s, int r, int level, double t,
                                 const double *const *state, int nstate, double *value,
                                 double *grad)
{
  int k = s->k;
  if (level < 0 || level > 1) return NZ_EARG;
  nz_motion mo = { 0 };                     /* direction i: q_i; k + i: q'_i */
  nz_constraint_seeding sd = { .K = level, .D = 2 * k, .count = 2 };
  int st = nz_constraint_eval(s, r, &mo, t, state, nstate, &sd);
  if (!st) {
    double f = nz_factorial(level);         /* coefficient `level` holds Phi^(level) / level! */
    *value = f * mo.out[0]->c[level];
    for (int d = 0; d < 2 * k; d++) grad[d] = f * nz_jet_tangent(mo.out[0], d)[level];
  }
  nz_motion_free(&mo);
  return st;
}

int nz_constraint_curvature(const nz_system *s, int r, int m, double t, const double *const *state,
                            int nstate, const double *v, double c[3])
{
  nz_motion mo = { 0 };                     /* the series variable moves slot m along v alone */
  nz_constraint_seeding sd = { .K = 2, .frozen = 1, .along_slot = m, .along = v };
  int st = nz_constraint_eval(s, r, &mo, t, state, nstate, &sd);
  if (!st)
    for (int j = 0; j < 3; j++) c[j] = mo.out[0]->c[j];
  nz_motion_free(&mo);
  return st;
}

int nz_constraint_row(const nz_system *s, int r, int m, double t, const double *const *state,
                      int nstate, double *A, double *value)
{
  return nz_constraint_row_stabilized(s, r, m, t, state, nstate, 0.0, 0.0, A, value);
}

int nz_constraint_row_stabilized(const nz_system *s, int r, int m, double t,
                                 const double *const *state, int nstate, double alpha, double beta,
                                 double *A, double *value)
{
  return nz_constraint_row_along(s, r, m, t, state, nstate, alpha, beta, NULL, A, value, NULL, NULL);
}

int nz_constraint_rows_01(const nz_system *s, int nc, const int *orders, double t, const double *q,
                          const double *qd, double *zero, double *rows)
{
  int k = s->k;
  double val;
  memset(zero, 0, (size_t)k * sizeof(double));
  const double *state[3] = { q, qd, zero };
  for (int r = 0; r < nc; r++) {
    double *row = rows + (size_t)r * (size_t)k;
    if (orders[r] > 1) {
      memset(row, 0, (size_t)k * sizeof(double));
      continue;
    }
    int st = nz_constraint_row(s, r, orders[r], t, state, 3, row, &val);
    if (st) return st;
  }
  return NZ_OK;
}

/* A ~ (t - t*) v through the zero, its direction held, so the row comes out
 * reversed; a row that turns (a pendulum's (2x, 2y)) would have to turn by
 * 180 degrees within 0.8 degrees in one step to look the same. */
int nz_constraint_row_reversed(int nc, int k, const int *orders, const double *before, const double *after)
{
  for (int r = 0; r < nc; r++) {
    if (orders[r] > 1) continue;
    const double *a = before + (size_t)r * (size_t)k, *b = after + (size_t)r * (size_t)k;
    double ab = 0.0, aa = 0.0, bb = 0.0;
    for (int i = 0; i < k; i++) ab += a[i] * b[i], aa += a[i] * a[i], bb += b[i] * b[i];
    if (aa > 0.0 && bb > 0.0 && ab < -0.9999 * sqrt(aa * bb)) return r + 1;
  }
  return 0;
}

/* The row's value and gradient read from one output jet (the value or its
 * derivative along a direction: the reading is linear). */
static void read_row(const nz_jet *out, int m, int k, double alpha, double beta, double *A, double *value)
{
  int K = 2 - m;
  const double *c = out->c;
  double f = nz_factorial(K);
  *value = f * c[K];
  if (m == 0) *value += 2.0 * alpha * c[1] + beta * beta * c[0];   /* c: Phi, Phi', Phi''/2 */
  if (m == 1) *value += alpha * c[0];
  for (int i = 0; A && i < k; i++) A[i] = f * nz_jet_tangent(out, i)[K];   /* A NULL: the value only */
}

/* nz_constraint_row_along in the workspace mo (reset here; the caller
 * frees it): the Newton solve evaluates the rows again at every iterate. */
static int row_in(const nz_system *s, nz_motion *mo, int r, int m, double t,
                  const double *const *state, int nstate, double alpha, double beta,
                  const nz_state_direction *dir, double *A, double *value, double *dA, double *dvalue)
{
  int k = s->k, K = 2 - m, st;
  if (m < 0 || m > 2) return NZ_EARG;
  if (!dir && s->constraint_row &&
      (st = s->constraint_row(s->mass_bias_ctx, r, m, t, state, nstate, alpha, beta, A, value, NULL, NULL)) !=
        NZ_EARG)
    return st;
  nz_constraint_seeding sd = { .K = K, .D = k, .dir = dir, .first = 2, .count = 1 };   /* tangents on q'' */
  st = nz_constraint_eval(s, r, mo, t, state, nstate, &sd);
  if (!st) {
    read_row(mo->out[0], m, k, alpha, beta, A, value);
    if (dir && dA && dvalue) read_row(mo->dout[0], m, k, alpha, beta, dA, dvalue);  /* derivative outputs given with dir */
  }
  return st;
}

/* The rows of levels m + 1 and 2 of constraint r read as the constraint
 * itself: the row of a constraint "of order 2" is Phi (K = 0), "of order
 * 1" Phi' (K = 1); on doubles through the row hook where there is one. */
int nz_constraint_state_values(const nz_system *s, const int *orders, double t, const double *const *state,
                               int nstate, double *values)
{
  nz_motion mo = { 0 };   /* one workspace for every constraint (the jets' path) */
  int st = NZ_OK;
  for (int r = 0; r < s->nc && !st; r++) {
    int m = orders[r];
    values[2 * r] = values[2 * r + 1] = 0.0;
    if (m > 1) continue;
    st = row_in(s, &mo, r, 2, t, state, nstate, 0.0, 0.0, NULL, NULL, &values[2 * r], NULL, NULL);
    if (!st && m == 0) st = row_in(s, &mo, r, 1, t, state, nstate, 0.0, 0.0, NULL, NULL, &values[2 * r + 1], NULL, NULL);
  }
  nz_motion_free(&mo);
  return st;
}

int nz_constraint_row_in(const nz_system *s, nz_motion *mo, int r, int m, double t, const double *const *state,
                         int nstate, double *A, double *value)
{
  return row_in(s, mo, r, m, t, state, nstate, 0.0, 0.0, NULL, A, value, NULL, NULL);
}

int nz_constraint_row_along(const nz_system *s, int r, int m, double t, const double *const *state,
                            int nstate, double alpha, double beta, const nz_state_direction *dir,
                            double *A, double *value, double *dA, double *dvalue)
{
  nz_motion mo = { 0 };
  int st = row_in(s, &mo, r, m, t, state, nstate, alpha, beta, dir, A, value, dA, dvalue);
  nz_motion_free(&mo);
  return st;
}

/* Column j: q'' + s e_j in the series variable, tangents on q'':
 * the s-coefficient of tangent i is d^2 Phi / dq''_i dq''_j.  The k
 * columns share the workspace mo (reset here; the caller frees it). */
static int hessian_in(const nz_system *s, nz_motion *mo, int r, double t, const double *const *state,
                      int nstate, double *H)
{
  int k = s->k, st = NZ_OK;
  for (int j = 0; j < k && !st; j++) {
    nz_constraint_seeding sd = { .K = 1, .D = k, .frozen = 1, .along_slot = 2, .along_index = j,
                                 .first = 2, .count = 1, .by_slot = 1 };
    st = nz_constraint_eval(s, r, mo, t, state, nstate, &sd);
    if (!st)
      for (int i = 0; i < k; i++) H[i * k + j] = nz_jet_tangent(mo->out[0], i)[1];
  }
  return st;
}

int nz_constraint_hessian(const nz_system *s, int r, double t, const double *const *state,
                          int nstate, double *H)
{
  nz_motion mo = { 0 };
  int st = hessian_in(s, &mo, r, t, state, nstate, H);
  nz_motion_free(&mo);
  return st;
}

/* Rank of A (nc x k) and the constraints that take part in a dependence:
 * the left singular vectors of A for zero singular values. */
static void diagnose_dependence_at(int nc, int k, const double *A, nz_accel_report *rep, double tol)
{
  nz_svd d;
  /* Decompose A^T, whose V (nc x nc) spans constraint space.  With more
   * constraints than coordinates A is first padded with zero columns to
   * nc x nc (same singular values, and zeros): GSL's thin SVD of A itself
   * would give only k of the nc directions, none of them the dependence, so
   * x, y, x + y on two coordinates were called dependent without naming one. */
  int cols = k < nc ? nc : k;
  double *P = NULL;
  if (cols > k) {
    if (!(P = calloc((size_t)nc * (size_t)cols, sizeof(double)))) return;
    for (int r = 0; r < nc; r++) memcpy(P + (size_t)r * cols, A + (size_t)r * k, (size_t)k * sizeof(double));
  }
  int st = nz_svd_of(&d, nc, cols, P ? P : A, 1);
  free(P);
  if (st) return;
  double smax = gsl_vector_get(d.S, 0);
  rep->rank_A = 0;
  for (int c = 0; c < nc; c++)
    if (gsl_vector_get(d.S, (size_t)c) > tol * smax) rep->rank_A++;
  rep->sigma_ratio = smax > 0.0 ? gsl_vector_get(d.S, (size_t)nc - 1) / smax : 0.0;
  if (rep->involved)
    for (int c = rep->rank_A; c < nc; c++)
      for (int r = 0; r < nc; r++)
        if (fabs(gsl_matrix_get(d.V, (size_t)r, (size_t)c)) > 0.1) rep->involved[r] = 1;
  nz_svd_free(&d);
}

/* Rank below 1e-10 of the largest singular value: dependent. */
static void diagnose_dependence(int nc, int k, const double *A, nz_accel_report *rep)
{
  diagnose_dependence_at(nc, k, A, rep, 1e-10);
}

/* ------------------------------------------------------------------ */
/* Accelerations                                                        */

/* Everything needed to evaluate G(q'', lambda) = (M q'' + h - A^T lambda,
 * Phi rows) and its Jacobian [M - sum lambda_r H_r, -A^T; A, 0]. */
typedef struct kkt {
  const nz_system *s;
  const int *orders, *linear;
  double alpha, beta;                 /* Baumgarte */
  double t;
  const double *q, *qd;
  int k, nc, N;
  double *M, *h, *A, *phi, *H, *x;   /* x: the point of the last evaluation */
  double *d;                          /* the equilibration D of the last solve */
  double knorm, bnorm;                /* ||D J D||_inf, ||D b||_inf of that solve */
  int status;                         /* first failure of a user function  */
  int nonfinite;                      /* Newton: 1, an iterate was not finite; */
                                      /* 2, G was not finite at a finite one   */
  nz_motion mo;                       /* the jets of every evaluation of the solve */
} kkt;

/* Evaluate G (and J if not NULL, N x N row-major) at x. */
static int kkt_eval(kkt *c, const double *x, double *G, double *J)
{
  int k = c->k, nc = c->nc, N = c->N, st;
  memcpy(c->x, x, (size_t)N * sizeof(double));
  const double *state[3] = { c->q, c->qd, c->x };
  for (int r = 0; r < nc; r++)
    if ((st = row_in(c->s, &c->mo, r, c->orders[r], c->t, state, 3, c->alpha, c->beta, NULL,
                     c->A + (size_t)r * k, &c->phi[r], NULL, NULL)))
      return st;
  for (int i = 0; i < k; i++) {
    double g = c->h[i];
    for (int j = 0; j < k; j++) g += c->M[i * k + j] * x[j];
    for (int r = 0; r < nc; r++) g -= c->A[(size_t)r * k + i] * x[k + r];
    G[i] = g;
  }
  for (int r = 0; r < nc; r++) G[k + r] = c->phi[r];
  if (!J) return NZ_OK;
  memset(J, 0, (size_t)N * N * sizeof(double));
  for (int i = 0; i < k; i++)
    for (int j = 0; j < k; j++) J[i * N + j] = c->M[i * k + j];
  for (int r = 0; r < nc; r++) {
    if (c->orders[r] == 2 && !c->linear[r]) {
      if ((st = hessian_in(c->s, &c->mo, r, c->t, state, 3, c->H))) return st;
      for (int i = 0; i < k; i++)
        for (int j = 0; j < k; j++) J[i * N + j] -= x[k + r] * c->H[i * k + j];
    }
    for (int i = 0; i < k; i++) {
      J[i * N + k + r] = -c->A[(size_t)r * k + i];
      J[(k + r) * N + i] = c->A[(size_t)r * k + i];
    }
  }
  return NZ_OK;
}

/* Scale [M -A^T; A 0] symmetrically, J <- D J D, and return D in d: q_i
 * by 1/sqrt(M_ii) (at least 1e-8 of the largest entry of the M block, for a
 * singular M), the multiplier of constraint r by 1/a_r, a_r its largest
 * scaled gradient entry, so that every block is of size 1.  Unscaled, a
 * circle of radius R puts entries of size R beside masses of size 1: the
 * solve's residual, a few eps times the largest entry times the solution,
 * is then of size eps R in (6.2), rounding the check would take for a
 * violation; scaled, it is a few eps of the scaled system, whose infinity
 * norm ||D J D|| is returned for the check (check_solution). */
static double equilibrate(const kkt *c, double *J, double *d)
{
  int k = c->k, N = c->N;
  double mu = 0.0, norm = 0.0;
  for (int i = 0; i < k; i++)
    for (int j = 0; j < k; j++) mu = fmax(mu, fabs(J[i * N + j]));
  if (!(mu > 0.0 && isfinite(mu))) mu = 1.0;
  for (int i = 0; i < k; i++) d[i] = 1.0 / sqrt(fmax(fabs(J[i * N + i]), 1e-8 * mu));
  for (int r = 0; r < c->nc; r++) {
    double a = 0.0;
    for (int i = 0; i < k; i++) a = fmax(a, fabs(J[(k + r) * N + i]) * d[i]);
    d[k + r] = a > 0.0 && isfinite(a) ? 1.0 / a : 1.0;
  }
  for (int i = 0; i < N; i++) {
    double row = 0.0;
    for (int j = 0; j < N; j++) row += fabs(J[i * N + j] *= d[i] * d[j]);
    norm = fmax(norm, row);
  }
  return norm;                          /* ||D J D||_inf, for the check */
}

/* GSL multiroot callbacks: a failing user function stops the solver with
 * GSL_EBADFUNC and its status is kept (no Lua error crosses GSL's frames). */
static int gsl_fdf(const gsl_vector *x, void *p, gsl_vector *f, gsl_matrix *J)
{
  kkt *c = p;
  int N = c->N;
  double *G = f ? f->data : NULL, *Jm = NULL, *scratch = NULL;
  for (int i = 0; i < N; i++)          /* the solver diverged: never feed NaN to the user */
    if (!isfinite(gsl_vector_get(x, (size_t)i))) { c->nonfinite = 1; return GSL_EBADFUNC; }
  if (!G) G = scratch = malloc((size_t)N * sizeof(double));
  if (J) Jm = malloc((size_t)N * N * sizeof(double));
  int st = (!G || (J && !Jm)) ? NZ_ENOMEM : kkt_eval(c, x->data, G, Jm);
  if (!st && J)
    for (int i = 0; i < N; i++)
      for (int j = 0; j < N; j++) gsl_matrix_set(J, (size_t)i, (size_t)j, Jm[i * N + j]);
  free(Jm);
  free(scratch);
  if (st) { if (!c->status) c->status = st; return GSL_EBADFUNC; }
  for (int i = 0; f && i < N; i++)
    if (!isfinite(gsl_vector_get(f, (size_t)i))) { c->nonfinite = 2; return GSL_EBADFUNC; }
  return GSL_SUCCESS;
}
static int gsl_f(const gsl_vector *x, void *p, gsl_vector *f) { return gsl_fdf(x, p, f, NULL); }
static int gsl_df(const gsl_vector *x, void *p, gsl_matrix *J) { return gsl_fdf(x, p, NULL, J); }

/* Powell's hybrid method with the exact Jacobian (GSL hybridsj): Newton's
 * step where it works, a trust region where plain Newton would cycle. */
static int solve_nonlinear(kkt *c, double *x, const nz_accel_options *opt, double scale,
                           nz_accel_report *rep)
{
  int N = c->N, st = NZ_OK;
  gsl_multiroot_function_fdf fn = { gsl_f, gsl_df, gsl_fdf, (size_t)N, c };
  gsl_multiroot_fdfsolver *solver = gsl_multiroot_fdfsolver_alloc(gsl_multiroot_fdfsolver_hybridsj, (size_t)N);
  if (!solver) return NZ_ENOMEM;
  gsl_vector_view xv = gsl_vector_view_array(x, (size_t)N);
  c->nonfinite = 0;
  int gs = gsl_multiroot_fdfsolver_set(solver, &fn, &xv.vector), started = gs == GSL_SUCCESS;
  int it = 0;
  while (gs == GSL_SUCCESS) {
    double gmax = 0.0;
    for (int i = 0; i < N; i++) gmax = fmax(gmax, fabs(gsl_vector_get(solver->f, (size_t)i)));
    rep->residual = gmax;
    rep->iterations = it;
    if (gmax <= opt->newton_tol * scale) break;
    if (it >= opt->newton_maxit) { gs = GSL_EMAXITER; break; }
    gs = gsl_multiroot_fdfsolver_iterate(solver);
    it++;
  }
  if (c->status) st = c->status;
  else if (gs != GSL_SUCCESS) {
    /* How it stopped and the worst constraint at the last iterate, for a
     * message that says what happened (ran out of iterations, or could not
     * reduce the residual from where it stood: often no real root). */
    rep->failure = NZ_ACCEL_NEWTON;
    rep->newton_stop = gs == GSL_EMAXITER ? NZ_NEWTON_MAXIT
                     : c->nonfinite == 1 ? NZ_NEWTON_STEP_NOT_FINITE
                     : c->nonfinite == 2 ? NZ_NEWTON_VALUE_NOT_FINITE : NZ_NEWTON_NO_PROGRESS;
    rep->newton_row = -1;
    rep->newton_value = 0.0;
    for (int r = 0; started && r < c->nc; r++) {
      double v = gsl_vector_get(solver->f, (size_t)(c->k + r));
      if (rep->newton_row < 0 || fabs(v) > fabs(rep->newton_value)) { rep->newton_row = r; rep->newton_value = v; }
    }
    st = NZ_EARG;
  }
  else memcpy(x, solver->x->data, (size_t)N * sizeof(double));
  gsl_multiroot_fdfsolver_free(solver);
  return st;
}

/* The solve proper, with the classification in c->orders, c->linear: x
 * (k + nc) on return; G holds G at the point before the last step. */
static int solve(kkt *c, const nz_accel_options *opt, double *x, double *G, double *J, double *Jc,
                 double *dx, nz_accel_report *rep)
{
  int k = c->k, nc = c->nc, N = c->N, st, nonlinear = 0;
  size_t kk = (size_t)k * (size_t)k;
  for (int r = 0; r < nc; r++) {
    if (c->orders[r] > 2) { rep->failure = NZ_ACCEL_ORDER; return NZ_EARG; }
    if (c->orders[r] == 2 && !c->linear[r]) nonlinear = 1;
  }
  memset(x, 0, (size_t)N * sizeof(double));
  rep->iterations = 0;
  rep->residual = 0.0;
  rep->from_guess = 0;
  double scale = 1.0;
  for (int i = 0; i < k; i++) scale = fmax(scale, fabs(c->h[i]));

  if (nonlinear) {
    /* Start from the caller's guess or the unconstrained accelerations. */
    if (opt->guess_qdd) {
      memcpy(x, opt->guess_qdd, (size_t)k * sizeof(double));
      if (opt->guess_lambda) memcpy(x + k, opt->guess_lambda, (size_t)nc * sizeof(double));
      rep->from_guess = 1;
    } else {
      nz_solve_info info;
      memcpy(Jc, c->M, kk * sizeof(double));
      for (int i = 0; i < k; i++) G[i] = -c->h[i];
      if (nz_solve_spd(k, Jc, G, x, opt->rcond_min, &info)) {
        rep->failure = NZ_ACCEL_SINGULAR;
        return NZ_ESINGULAR;
      }
    }
    if ((st = solve_nonlinear(c, x, opt, scale, rep))) return st;
  }
  /* The linear solve (all constraints affine in q'': one step from 0 is
   * exact), and for the nonlinear case a last step at the root, whose
   * matrix tells the condition of the system and the multipliers' quality. */
  if ((st = kkt_eval(c, x, G, J))) return st;
  c->knorm = equilibrate(c, J, c->d);
  /* The step solves J dx = -G(x0), x = x0 + dx: in x, J x = b with b = J x0
   * - G(x0) (b = -G(0) = (-h, -a0) for the linear solve, x0 = 0), whose
   * size in the scaled variables the check measures its residual against. */
  c->bnorm = 0.0;
  for (int i = 0; i < N; i++) {
    double b = Jc[i] = -G[i] * c->d[i];
    for (int j = 0; nonlinear && j < N; j++) b += J[i * N + j] * x[j] / c->d[j];
    c->bnorm = fmax(c->bnorm, fabs(b));
  }
  if ((st = nz_solve_square(N, J, Jc, G, opt->rcond_min, &rep->rcond))) return st;
  for (int i = 0; i < N; i++) dx[i] = c->d[i] * G[i];
  if (!(rep->rcond >= opt->rcond_min)) {
    rep->failure = NZ_ACCEL_SINGULAR;
    diagnose_dependence(nc, k, c->A, rep);
    return NZ_ESINGULAR;
  }
  for (int i = 0; i < N; i++) x[i] += dx[i];
  return NZ_OK;
}

/* ------------------------------------------------------------------ */
/* The check after the solve                                            */

/* Typical size of q^(j) at the state: its largest component, at least 1
 * (a state at rest must not hide a dependence on the velocities).  Slots
 * above q'' are not known at the acceleration level: they take the size
 * of q''. */
static double slot_size(const double *const *state, int k, int j)
{
  double m = 1.0;
  const double *v = state[j < 2 ? j : 2];
  for (int i = 0; i < k; i++) m = fmax(m, fabs(v[i]));
  return m;
}


/* Constraint r at x: its row's value (and for m = 2 its gradient A, as
 * kkt_eval) and, in *high, its derivative along the slots above its order
 * weighted by their sizes: one evaluation.  Below order 2 the row Phi^(2-m)
 * is affine in q'' with A = dPhi/dq^(m) free of q'' as long as Phi does not
 * depend on the slots above m, which *high tests: A from the solve stands,
 * and the evaluation needs a single tangent. */
static int check_row(kkt *c, int r, const double *const *state, double *high)
{
  int k = c->k, m = c->orders[r], D = m == 2 ? k + 1 : 1, st;
  double sizes[NZ_CONSTRAINT_SLOTS];
  for (int j = 0; j < NZ_CONSTRAINT_SLOTS; j++) sizes[j] = slot_size(state, k, j);
  if (c->s->constraint_row) {
    st = c->s->constraint_row(c->s->mass_bias_ctx, r, m, c->t, state, 3, c->alpha, c->beta,
                              m == 2 ? c->A + (size_t)r * k : NULL, &c->phi[r], sizes, high);
    if (st != NZ_EARG) return st;
  }
  /* tangents on q'' for m = 2 (the row), the last along the slots above m */
  nz_constraint_seeding sd = { .nslots = NZ_CONSTRAINT_SLOTS, .K = 2 - m, .D = D, .first = 2,
                               .count = m == 2, .above = m, .sizes = sizes };
  nz_motion *mo = &c->mo;
  st = nz_constraint_eval(c->s, r, mo, c->t, state, 3, &sd);
  if (!st) {
    read_row(mo->out[0], m, k, c->alpha, c->beta, m == 2 ? c->A + (size_t)r * k : NULL, &c->phi[r]);
    *high = nz_jet_tangent(mo->out[0], D - 1)[0];
  }
  return st;
}

/* Check the solution x (see NZ_ACCEL_CHECK_TOL): each constraint's order,
 * and the residual G(x) of (6.2) and of the constraint rows, the rows
 * evaluated again at x by the user's functions (a constraint classified
 * linear that is not shows here), as a normwise backward error of the
 * equilibrated saddle-point system of the last solve,
 *   eta = ||D G(x)||_inf / (||D J D||_inf ||D^-1 x||_inf + ||D b||_inf),
 * the smallest relative change of the system's data that makes x exact
 * (Rigal and Gaches 1967; Higham, "Accuracy and Stability of Numerical
 * Algorithms", 2nd ed., Theorem 7.1).  A backward-stable solve promises
 * only this: a row's residual is small against the whole system, not
 * against its own terms (a loop whose terms are 1e-6 beside multipliers
 * of 1e2 in another carries their rounding).  Returns NZ_OK with *failed
 * = 0 when all pass; otherwise *failed = 1, bad[r] has bit 1 for a
 * constraint of too low an order, 2 for a constraint row that fails, 4
 * when (6.2) fails (every constraint's gradient may have moved), and rep
 * holds the worst row (an order's failure before the backward error's). */
static int check_solution(kkt *c, const double *x, int *bad, int *failed, nz_accel_report *rep)
{
  int k = c->k, nc = c->nc, N = c->N, st;
  const double *state[3] = { c->q, c->qd, x };
  double worst_order = 0.0, worst = 0.0, worst_g = 0.0, xnorm = 0.0;
  int worst_row = -1;
  *failed = 0;
  memcpy(c->x, x, (size_t)N * sizeof(double));
  for (int i = 0; i < N; i++) xnorm = fmax(xnorm, fabs(x[i]) / c->d[i]);
  double size = c->knorm * xnorm + c->bnorm, allowed = NZ_ACCEL_CHECK_TOL * size;
  for (int r = 0; r < nc; r++) {
    double high, grad = 0.0;
    bad[r] = 0;
    if ((st = check_row(c, r, state, &high))) return st;
    for (int i = 0; i < k; i++) grad += fabs(c->A[(size_t)r * k + i]);
    double top = grad * slot_size(state, k, c->orders[r]);
    if (fabs(high) > NZ_ACCEL_CHECK_TOL * top) {
      double rel = top > 0 ? fabs(high) / top : INFINITY;
      bad[r] |= 1;
      if (!*failed || rel > worst_order) {
        worst_order = rel;
        rep->check_row = k + r;
        rep->check_kind = NZ_CHECK_ORDER;
        rep->check_violation = fabs(high);
        rep->check_size = top;
      }
      *failed = 1;
    }
    double e = fabs(c->phi[r]) * c->d[k + r];
    if (!(e <= allowed)) bad[r] |= 2;
    if (!(e <= worst)) { worst = e; worst_row = k + r; }
  }
  for (int i = 0; i < k; i++) {
    double g = c->h[i];
    for (int j = 0; j < k; j++) g += c->M[i * k + j] * x[j];
    for (int r = 0; r < nc; r++) g -= c->A[(size_t)r * k + i] * x[k + r];
    double e = fabs(g) * c->d[i];
    if (!(e <= allowed))
      for (int r = 0; r < nc; r++) bad[r] |= 4;
    if (!(e <= worst)) { worst = e; worst_row = i; worst_g = g; }
  }
  rep->check_backward = size > 0.0 ? worst / size : worst > 0.0 ? INFINITY : 0.0;
  rep->check_forward = fmax(rep->check_backward, DBL_EPSILON) / rep->rcond;
  if (!(rep->check_forward <= NZ_ACCEL_FORWARD_TOL) && !*failed && worst <= allowed) {
    rep->check_row = -1;                /* no row to blame: the whole system */
    rep->check_kind = NZ_CHECK_FORWARD;
    rep->check_size = size;
    *failed = 1;
  }
  if (!(worst <= allowed)) {
    if (!*failed) {                     /* an order's failure is the more specific */
      rep->check_row = worst_row;
      rep->check_kind = NZ_CHECK_BACKWARD;
      rep->check_violation = worst_row < k ? fabs(worst_g) : fabs(c->phi[worst_row - k]);
      rep->check_size = size;
    }
    *failed = 1;
  }
  return NZ_OK;
}

/* Classify the constraints the check blamed again at this state: the order
 * from the partial derivatives at (q, q', x), each slot weighted by its
 * size, as in the check; a second-order constraint is then solved
 * by Newton (which is exact in one step when it is linear after all).
 * Returns 1 when some classification changed, 0 when none did; -1 with
 * rep->check_order set for a constraint of order above 2 here. */
static int reclassify(kkt *c, const double *x, const int *bad, int *orders, int *linear,
                      double *dphi, nz_accel_report *rep, int *status)
{
  int k = c->k, L = NZ_CONSTRAINT_SLOTS, changed = 0;
  const double *state[3] = { c->q, c->qd, x };
  for (int r = 0; r < c->nc; r++) {
    if (!bad[r]) continue;
    int m = orders[r];
    if (bad[r] & 1) {
      double value, dphidt, size[NZ_CONSTRAINT_SLOTS];
      if ((*status = nz_constraint_partials(c->s, r, c->t, state, 3, &value, dphi, &dphidt))) return 0;
      for (int j = 0; j < L; j++) {
        size[j] = 0.0;
        for (int i = 0; i < k; i++) size[j] += fabs(dphi[j * k + i]);
        size[j] *= slot_size(state, k, j);
      }
      /* The check's test slot by slot: its weighted sum over the slots
       * above m exceeded tol x size[m], so one of them exceeds a fraction
       * of that (the weights are at most 1.4, the slots at most 3). */
      for (int j = L - 1; j > m; j--)
        if (size[j] > 0.1 * NZ_ACCEL_CHECK_TOL * size[m]) { m = j; break; }
      if (m > 2) {
        rep->check_row = k + r;
        rep->check_order = m;
        return -1;
      }
    }
    if (m == 2 && (linear[r] || m != orders[r])) {
      orders[r] = 2;
      linear[r] = 0;
      changed = 1;
      rep->reclassified++;
    } else if (m != orders[r]) {
      orders[r] = m;
      changed = 1;
      rep->reclassified++;
    }
  }
  return changed;
}

int nz_accel_constrained(const nz_system *s, const int *orders, const int *linear, double t,
                         const double *q, const double *qd, const nz_accel_options *opt,
                         double *qdd, double *lambda, nz_accel_report *rep)
{
  int k = s->k, nc = s->nc, N = k + nc, st = NZ_OK;
  rep->failure = NZ_ACCEL_OK;
  rep->iterations = 0;
  rep->residual = 0.0;
  rep->rank_A = nc;
  rep->from_guess = 0;
  rep->reclassified = 0;
  rep->check_row = -1;
  rep->check_order = -1;
  rep->check_kind = NZ_CHECK_BACKWARD;
  rep->check_violation = rep->check_size = rep->check_backward = rep->check_forward = 0.0;
  size_t kk = (size_t)k * (size_t)k, NN = (size_t)N * (size_t)N;
  double *buf = calloc(2 * kk + 2 * NN + (size_t)nc * (size_t)k + 6 * (size_t)N + (size_t)k
                       + (size_t)NZ_CONSTRAINT_SLOTS * (size_t)k, sizeof(double));
  int *flags = calloc(3 * (size_t)nc + 1, sizeof(int));
  if (!buf || !flags) { free(buf); free(flags); return NZ_ENOMEM; }
  int *ord = flags, *lin = flags + nc, *bad = flags + 2 * nc;
  memcpy(ord, orders, (size_t)nc * sizeof(int));
  memcpy(lin, linear, (size_t)nc * sizeof(int));
  kkt c = { s, ord, lin, opt->baumgarte_alpha, opt->baumgarte_beta, t, q, qd, k, nc, N,
            NULL, NULL, NULL, NULL, NULL, NULL, NULL, 0.0, 0.0, NZ_OK, 0, { 0 } };
  c.M = buf;
  c.H = c.M + kk;
  double *J = c.H + kk, *Jc = J + NN;
  c.A = Jc + NN;
  double *G = c.A + (size_t)nc * k, *x = G + N, *dx = x + N;
  c.phi = dx + N;
  c.x = c.phi + N;
  c.h = c.x + N;
  c.d = c.h + k;
  double *dphi = c.d + N;

  if ((st = nz_mass_bias(s, t, q, qd, c.M, c.h))) goto done;
  if ((st = solve(&c, opt, x, G, J, Jc, dx, rep))) goto done;
  if (!opt->skip_check) {
    /* Check; when it fails, classify the blamed constraints again here and
     * solve once more; a second failure is the caller's error. */
    for (int pass = 0; pass < 2; pass++) {
      int failed, changed;
      if ((st = check_solution(&c, x, bad, &failed, rep)) || !failed) break;
      changed = pass == 0 ? reclassify(&c, x, bad, ord, lin, dphi, rep, &st) : 0;
      if (st) break;
      if (changed <= 0) {
        rep->failure = NZ_ACCEL_CHECK;
        st = NZ_EARG;
        /* a solve that misses its own check is often one near a rank
         * loss of the gradients (two surfaces meeting tangentially): the
         * message names the constraints when they are nearly dependent */
        if (nc > 1) diagnose_dependence_at(nc, k, c.A, rep, NZ_NEAR_DEPENDENCE);
        break;
      }
      if ((st = solve(&c, opt, x, G, J, Jc, dx, rep))) break;
    }
    if (st) goto done;
  }
  memcpy(qdd, x, (size_t)k * sizeof(double));
  memcpy(lambda, x + k, (size_t)nc * sizeof(double));
  if (rep->A) memcpy(rep->A, c.A, (size_t)nc * (size_t)k * sizeof(double));
  if (rep->used) memcpy(rep->used, flags, 2 * (size_t)nc * sizeof(int));
done:
  nz_motion_free(&c.mo);
  free(buf);
  free(flags);
  return st;
}

void nz_constraint_dependence(int nc, int k, const double *A, nz_accel_report *rep)
{
  diagnose_dependence(nc, k, A, rep);
}

int nz_state_violation(const nz_system *s, const int *orders, double t, const double *q,
                       const double *qd, double *worst)
{
  int k = s->k, st = NZ_OK;
  const double *state[2] = { q, qd };
  double w = 0.0, *dphi = malloc((size_t)nz_constraint_levels_max(s) * (size_t)k * sizeof(double) + 1);
  if (!dphi) return NZ_ENOMEM;
  for (int r = 0; r < s->nc && !st; r++) {
    if (orders[r] > 1) continue;
    double v, dt;
    if ((st = nz_constraint_partials(s, r, t, state, 2, &v, dphi, &dt))) break;
    if (fabs(v) > w) w = fabs(v);
    if (orders[r] == 0) {               /* Phi' = Phi_t + Phi_q q', summed as constraints.lua does */
      double d = dt;
      for (int j = 0; j < k; j++) d = d + dphi[j] * qd[j];
      if (fabs(d) > w) w = fabs(d);
    }
  }
  free(dphi);
  *worst = w;
  return st;
}
