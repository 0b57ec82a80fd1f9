/* constrained_series.c - the motion at level p >= 3 (see constrained_series.h).
 *
 * Series are normalized Taylor coefficients along the motion, x[c] =
 * x^(c)/c!, so the c-th derivative of a product is c! sum_j a[j] b[c-j]. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "mech/constrained_series.h"
#include "core/linalg.h"

int nz_series_dim(int k, int nc, int p) { return p * k + (p - 2) * nc; }

/* The Nielsen residual r_i = d/dt dF/dq'_i - dF/dq_i - Q_i + dV/dq_i along
 * the motion, as a series of order K: r[i (K+1) + c].  dF/dq' and dF/dq are
 * the tangents of F with the velocity and position slots seeded as a whole;
 * dF/dq' needs one order more, for its time derivative. */
static int nielsen_series(const nz_system *s, double t, const double *const *levels, int nstate,
                          int K, double *r)
{
  int k = s->k, st = NZ_OK, W = K + 1;
  nz_motion mo = { 0 };
  memset(r, 0, (size_t)k * (size_t)W * sizeof(double));
  if (nz_system_has(s, NZ_PIECE_F)) {
    if ((st = nz_motion_reset(&mo, k, 2, K + 1, 2 * k, t, levels, nstate))) goto done;
    for (int i = 0; i < k; i++) {
      nz_motion_seed_slot(&mo, i, i, 1);
      nz_motion_seed_slot(&mo, i, k + i, 0);
    }
    st = nz_motion_eval(s, NZ_PIECE_F, 0, &mo, NULL);
    for (int i = 0; i < k && !st; i++)
      for (int c = 0; c <= K; c++)
        r[i * W + c] = (c + 1) * nz_jet_tangent(mo.out[0], i)[c + 1] - nz_jet_tangent(mo.out[0], k + i)[c];
    if (st) goto done;
  }
  if (nz_system_has(s, NZ_PIECE_Q)) {
    if ((st = nz_motion_reset(&mo, k, 2, K, 0, t, levels, nstate))) goto done;
    st = nz_motion_eval(s, NZ_PIECE_Q, 0, &mo, NULL);
    for (int i = 0; i < k && !st; i++)
      for (int c = 0; c <= K; c++) r[i * W + c] -= mo.out[i]->c[c];
    if (st) goto done;
  }
  if (nz_system_has(s, NZ_PIECE_V)) {
    if ((st = nz_motion_reset(&mo, k, 2, K, k, t, levels, nstate))) goto done;
    for (int i = 0; i < k; i++) nz_motion_seed_slot(&mo, i, i, 0);
    st = nz_motion_eval(s, NZ_PIECE_V, 0, &mo, NULL);
    for (int i = 0; i < k && !st; i++)
      for (int c = 0; c <= K; c++) r[i * W + c] += nz_jet_tangent(mo.out[0], i)[c];
  }
done:
  nz_motion_free(&mo);
  return st;
}

/* Constraint r along the motion, one evaluation: its series to order Kphi
 * into phi (Kphi >= 0), and the series of its gradient A_r = dPhi/dq^(m) to
 * order Ka into a[i (Ka+1) + c] (Ka >= 0; slot m seeded as a whole). */
static int constraint_series(const nz_system *s, int r, int m, int Kphi, int Ka, double t,
                             const double *const *levels, int nstate, double *phi, double *a)
{
  int k = s->k, Kc = Kphi > Ka ? Kphi : Ka;
  nz_motion mo = { 0 };
  nz_constraint_seeding sd = { .K = Kc, .D = Ka >= 0 ? k : 0, .first = m, .count = Ka >= 0, .by_slot = 1 };
  int st = nz_constraint_eval(s, r, &mo, t, levels, nstate, &sd);
  if (!st) {
    for (int c = 0; c <= Kphi; c++) phi[c] = mo.out[0]->c[c];
    for (int i = 0; i < k && Ka >= 0; i++)
      for (int c = 0; c <= Ka; c++) a[i * (Ka + 1) + c] = nz_jet_tangent(mo.out[0], i)[c];
  }
  nz_motion_free(&mo);
  return st;
}

int nz_series_level(const nz_system *s, const int *orders, int l, double t,
                    const double *const *levels, const double *lam, double *res, double *A,
                    double *gscale)
{
  int k = s->k, nc = s->nc, K = l - 2, W = K > 0 ? K + 1 : 1, st = NZ_OK;
  memset(res, 0, ((size_t)k + (size_t)nc) * sizeof(double));
  if (A) memset(A, 0, (size_t)nc * (size_t)k * sizeof(double));
  if (gscale) *gscale = 1.0;
  double *buf = calloc((size_t)k * W * (1 + (size_t)nc) + (size_t)l + 2, sizeof(double));
  if (!buf) return NZ_ENOMEM;
  double *rser = buf, *aser = rser + (size_t)k * W, *phi = aser + (size_t)nc * k * W;
  if (K >= 0 && (st = nielsen_series(s, t, levels, l + 1, K, rser))) goto done;
  for (int r = 0; r < nc; r++) {
    int m = orders[r], Kphi = m <= l ? l - m : -1;
    if (Kphi < 0 && K < 0) continue;
    if ((st = constraint_series(s, r, m, Kphi, K, t, levels, l + 1, phi, aser + (size_t)r * k * W))) goto done;
    if (Kphi >= 0) res[k + r] = nz_factorial(Kphi) * phi[Kphi];
  }
  if (K >= 0) {
    /* G^(K) = K! (r[K] - sum_r sum_j lambda_r[j] A_r[K - j]), normalized. */
    double fK = nz_factorial(K), big = 0.0;
    for (int i = 0; i < k; i++) {
      double g = rser[i * W + K];
      big = fmax(big, fabs(fK * g));
      for (int r = 0; r < nc; r++)
        for (int j = 0; j <= K; j++)
          g -= lam[(size_t)j * nc + r] / nz_factorial(j) * aser[((size_t)r * k + i) * W + K - j];
      res[i] = fK * g;
    }
    if (gscale) *gscale = 1.0 + big;
    if (A)
      for (int r = 0; r < nc; r++)
        for (int i = 0; i < k; i++) A[(size_t)r * k + i] = aser[((size_t)r * k + i) * W];
  }
done:
  free(buf);
  return st;
}

/* The matrix of the equations of level l in (q^(l), lambda^(l-2)): columns
 * of q^(l) by probing (the equations are affine in it: the difference is
 * exact up to rounding), columns of lambda^(l-2) = -A^T in the G rows.
 * levels[l] is x, moved and restored; res0 and A at x are given. */
static int level_matrix(const nz_system *s, const int *orders, int l, double t,
                        const double *const *levels, double *x, const double *lam,
                        const double *res0, const double *A, double *J, double *scratch)
{
  int k = s->k, nc = s->nc, N = k + nc, st;
  memset(J, 0, (size_t)N * N * sizeof(double));
  for (int j = 0; j < k; j++) {
    double keep = x[j];
    x[j] = keep + 1.0;
    st = nz_series_level(s, orders, l, t, levels, lam, scratch, NULL, NULL);
    x[j] = keep;
    if (st) return st;
    for (int i = 0; i < N; i++) J[i * N + j] = scratch[i] - res0[i];
  }
  if (l >= 2)
    for (int r = 0; r < nc; r++)
      for (int i = 0; i < k; i++) J[i * N + k + r] = -A[(size_t)r * k + i];
  return NZ_OK;
}

int nz_series_rhs(const nz_system *s, const int *orders, int p, double rcond_min, double t,
                  const double *y, double *f, nz_accel_report *rep)
{
  int k = s->k, nc = s->nc, N = k + nc, st;
  const double *levels[NZ_MAX_LEVELS];
  if (p < 3 || p + 1 > NZ_MAX_LEVELS) return NZ_EARG;
  double *buf = calloc((size_t)k + (size_t)(p - 1) * nc + 5 * (size_t)N + (size_t)N * N + (size_t)nc * k,
                       sizeof(double));
  if (!buf) return NZ_ENOMEM;
  double *x = buf, *lam = x + k, *res0 = lam + (size_t)(p - 1) * nc, *scratch = res0 + N;
  double *rhs = scratch + N, *u = rhs + N, *J = u + N + N, *A = J + (size_t)N * N;
  for (int j = 0; j < p; j++) levels[j] = y + (size_t)j * k;
  levels[p] = x;                                      /* q^(p): the unknown, from 0 */
  memcpy(lam, y + (size_t)p * k, (size_t)(p - 2) * nc * sizeof(double));
  if ((st = nz_series_level(s, orders, p, t, levels, lam, res0, A, NULL))) goto done;
  if ((st = level_matrix(s, orders, p, t, levels, x, lam, res0, A, J, scratch))) goto done;
  for (int i = 0; i < N; i++) rhs[i] = -res0[i];
  if ((st = nz_solve_svd(N, J, rhs, u, &rep->rcond))) goto done;
  if (!(rep->rcond >= rcond_min)) {
    rep->failure = NZ_ACCEL_SINGULAR;
    if (rep->A) memcpy(rep->A, A, (size_t)nc * k * sizeof(double));
    nz_constraint_dependence(nc, k, A, rep);
    st = NZ_ESINGULAR;
    goto done;
  }
  memcpy(f, y + k, (size_t)(p - 1) * k * sizeof(double));                 /* q' .. q^(p-1) */
  memcpy(f + (size_t)(p - 1) * k, u, (size_t)k * sizeof(double));        /* q^(p) */
  memcpy(f + (size_t)p * k, y + (size_t)p * k + nc, (size_t)(p - 3) * nc * sizeof(double));
  memcpy(f + (size_t)p * k + (size_t)(p - 3) * nc, u + k, (size_t)nc * sizeof(double));
  if (rep->A) memcpy(rep->A, A, (size_t)nc * k * sizeof(double));
done:
  free(buf);
  return st;
}

int nz_series_closure(const nz_system *s, const int *orders, int p, double t,
                      const double *const *levels, int *bad)
{
  int k = s->k, K = p - 2, W = K + 1, st = NZ_OK;
  const double *more[NZ_MAX_LEVELS];
  *bad = -1;
  if (p + 3 > NZ_MAX_LEVELS) return NZ_EARG;
  double *buf = calloc(2 * (size_t)k * W + 2 * (size_t)k + 1, sizeof(double));
  if (!buf) return NZ_ENOMEM;
  double *a0 = buf, *a1 = a0 + (size_t)k * W, *ones = a1 + (size_t)k * W, phi;
  /* The same series with q^(p+1), q^(p+2) set to 1 instead of 0: a
   * difference means A_r^(p-2) needs them. */
  for (int i = 0; i < 2 * k; i++) ones[i] = 1.0;
  for (int j = 0; j <= p; j++) more[j] = levels[j];
  more[p + 1] = ones;
  more[p + 2] = ones + k;
  for (int r = 0; r < s->nc && *bad < 0; r++) {
    if ((st = constraint_series(s, r, orders[r], -1, K, t, levels, p + 1, &phi, a0))) break;
    if ((st = constraint_series(s, r, orders[r], -1, K, t, more, p + 3, &phi, a1))) break;
    for (int i = 0; i < k * W; i++)
      if (fabs(a1[i] - a0[i]) > 1e-12 * (1.0 + fabs(a0[i]))) { *bad = r; break; }
  }
  free(buf);
  return st;
}

/* max over the rows of level l of |res| / scale (G rows: gscale; constraint
 * rows with m_r <= l: 1), and which row. */
static double worst_row(int k, int nc, const int *orders, int l, const double *res, double gscale,
                        int *row)
{
  double w = 0.0;
  for (int i = 0; i < k + nc; i++) {
    if (i < k && l < 2) continue;
    if (i >= k && orders[i - k] > l) continue;
    double v = fabs(res[i]) / (i < k ? gscale : 1.0);
    if (v > w || *row < 0) { w = v; *row = i; }
  }
  return w;
}

int nz_series_initial(const nz_system *s, const int *orders, int p, double t,
                      const double *const *levels, double *lam, nz_series_violation *v)
{
  int k = s->k, nc = s->nc, N = k + nc, st = NZ_OK;
  v->value = 0.0;
  v->level = -1;
  v->row = -1;
  double *buf = calloc((size_t)(p - 1) * nc + (size_t)N + 2 * (size_t)nc * k + (size_t)nc + 1, sizeof(double));
  if (!buf) return NZ_ENOMEM;
  double *lw = buf, *res = lw + (size_t)(p - 1) * nc, *A = res + N, *At = A + (size_t)nc * k, *w = At + (size_t)nc * k;
  for (int l = 0; l < p && !st; l++) {
    double gscale;
    if ((st = nz_series_level(s, orders, l, t, levels, lw, res, A, &gscale))) break;
    if (l >= 2 && nc > 0) {
      /* lambda^(l-2) enters the G rows as -A^T lambda^(l-2). */
      for (int r = 0; r < nc; r++)
        for (int i = 0; i < k; i++) At[(size_t)i * nc + r] = A[(size_t)r * k + i];
      if ((st = nz_lstsq(k, nc, At, res, w))) break;
      for (int r = 0; r < nc; r++) lw[(size_t)(l - 2) * nc + r] = w[r];
      for (int i = 0; i < k; i++)
        for (int r = 0; r < nc; r++) res[i] -= At[(size_t)i * nc + r] * w[r];
    }
    int row = -1;
    double worst = worst_row(k, nc, orders, l, res, gscale, &row);
    if (row >= 0 && (worst > v->value || v->row < 0)) {
      v->value = worst;
      v->level = l;
      v->row = row;
    }
  }
  if (!st) memcpy(lam, lw, (size_t)(p - 2) * nc * sizeof(double));
  free(buf);
  return st;
}

/* The step of a level whose multipliers are free (nobody chose them): the
 * least change dx of q^(l) alone, the multipliers' change dw whatever the
 * equations then need.  J = [Jx Jw] (N x N, Jw its last nc columns):
 * with P the projector onto the complement of range(Jw), dx = -(P Jx)^+ P
 * res minimizes |dx| over the least-squares solutions of Jx dx + Jw dw =
 * -res, and dw = -Jw^+ (res + Jx dx).  Each Jw^+ is a minimum-norm least
 * squares (nz_lstsq); work holds 2 N k + N nc + 2 N doubles. */
static int step_free_multipliers(int k, int nc, const double *J, const double *res, double *d, double *work)
{
  int N = k + nc, st;
  double *Jx = work, *Jw = Jx + (size_t)N * k, *PJx = Jw + (size_t)N * nc, *v = PJx + (size_t)N * k, *y = v + N;
  for (int i = 0; i < N; i++) {
    for (int j = 0; j < k; j++) Jx[(size_t)i * k + j] = J[(size_t)i * N + j];
    for (int r = 0; r < nc; r++) Jw[(size_t)i * nc + r] = J[(size_t)i * N + k + r];
  }
  /* P u = u - Jw Jw^+ u, column by column of Jx, then for res */
  for (int j = 0; j <= k; j++) {
    for (int i = 0; i < N; i++) v[i] = j < k ? Jx[(size_t)i * k + j] : res[i];
    if ((st = nz_lstsq(N, nc, Jw, v, y))) return st;
    for (int i = 0; i < N; i++) {
      double u = v[i];
      for (int r = 0; r < nc; r++) u -= Jw[(size_t)i * nc + r] * y[r];
      if (j < k) PJx[(size_t)i * k + j] = u;
      else v[i] = -u;
    }
  }
  if ((st = nz_lstsq(N, k, PJx, v, d))) return st;             /* dx */
  for (int i = 0; i < N; i++) {
    double u = -res[i];
    for (int j = 0; j < k; j++) u -= Jx[(size_t)i * k + j] * d[j];
    v[i] = u;
  }
  return nz_lstsq(N, nc, Jw, v, d + k);                        /* dw */
}

int nz_series_project(const nz_system *s, const int *orders, int p, double t, double *const *levels,
                      double *lam, const int *chosen, double tol, int maxit, int *iterations)
{
  int k = s->k, nc = s->nc, N = k + nc, st = NZ_OK;
  *iterations = 0;
  double *buf = calloc((size_t)(p - 1) * nc + 6 * (size_t)N + (size_t)N * N + (size_t)nc * k
                       + 2 * (size_t)N * k + (size_t)N * nc, sizeof(double));
  if (!buf) return NZ_ENOMEM;
  double *lw = buf, *res = lw + (size_t)(p - 1) * nc, *scratch = res + N, *rhs = scratch + N, *d = rhs + N;
  double *J = d + N, *A = J + (size_t)N * N, *work = A + (size_t)nc * k;
  const double *const *lv = (const double *const *)levels;
  memcpy(lw, lam, (size_t)(p - 2) * nc * sizeof(double));      /* the multipliers' start */
  for (int l = 2; l < p && !st; l++) {
    double *x = levels[l], *w = lw + (size_t)(l - 2) * nc;
    int free_w = !chosen || !chosen[l - 2], fitted = !free_w;
    for (int it = 0;; it++) {
      double gscale;
      int row = -1;
      if ((st = nz_series_level(s, orders, l, t, lv, lw, res, A, &gscale))) break;
      if (worst_row(k, nc, orders, l, res, gscale, &row) <= tol) break;
      if (!fitted) {
        /* Free multipliers: first those that fit q^(l) as it is, by least
         * squares (the equations are affine in them, with -A^T in the rows
         * of (6.2)): a q^(l) that satisfies the level is kept exactly. */
        memset(J, 0, (size_t)N * nc * sizeof(double));
        for (int i = 0; i < k; i++)
          for (int r = 0; r < nc; r++) J[(size_t)i * nc + r] = -A[(size_t)r * k + i];
        for (int i = 0; i < N; i++) rhs[i] = -res[i];
        if ((st = nz_lstsq(N, nc, J, rhs, d))) break;
        for (int r = 0; r < nc; r++) w[r] += d[r];
        fitted = 1;
        it--;
        continue;
      }
      if (it >= maxit) { st = NZ_EARG; break; }
      if ((st = level_matrix(s, orders, l, t, lv, x, lw, res, A, J, scratch))) break;
      if (free_w) {
        if ((st = step_free_multipliers(k, nc, J, res, d, work))) break;
      } else {
        for (int i = 0; i < N; i++) rhs[i] = -res[i];
        if ((st = nz_lstsq(N, N, J, rhs, d))) break;
      }
      for (int i = 0; i < k; i++) x[i] += d[i];
      for (int r = 0; r < nc; r++) w[r] += d[k + r];
      (*iterations)++;
    }
  }
  memcpy(lam, lw, (size_t)(p - 2) * nc * sizeof(double));
  free(buf);
  return st;
}

/* ------------------------------------------------------------------ */
/* A constraint of order p nonlinear in q^(p) (constrained_series.h)    */

/* d^2 Phi_r / dq^(p)^2 (k x k) at the state: column j from Phi along
 * q^(p) + s e_j with t and every other slot frozen, tangents on slot p. */
static int top_hessian(const nz_system *s, int r, int p, double t, const double *const *levels,
                       int nstate, double *H)
{
  int k = s->k, st = NZ_OK;
  nz_motion mo = { 0 };   /* the k columns share its jets */
  for (int j = 0; j < k && !st; j++) {
    nz_constraint_seeding sd = { .K = 1, .D = k, .frozen = 1, .along_slot = p, .along_index = j,
                                 .first = p, .count = 1, .by_slot = 1 };
    st = nz_constraint_eval(s, r, &mo, t, levels, nstate, &sd);
    if (!st)
      for (int i = 0; i < k; i++) H[i * k + j] = nz_jet_tangent(mo.out[0], i)[1];
  }
  nz_motion_free(&mo);
  return st;
}

int nz_top_equations(const nz_system *s, const int *orders, const int *linear, int p, double t,
                     const double *const *levels, const double *x, double *F, double *J)
{
  int k = s->k, nc = s->nc, N = k + nc, st;
  const double *lv[NZ_MAX_LEVELS];
  if (p < 3 || p + 1 > NZ_MAX_LEVELS) return NZ_EARG;
  for (int j = 0; j < p; j++) lv[j] = levels[j];
  lv[p] = x;                                            /* q^(p): the unknown */
  double *buf = calloc(2 * (size_t)k + (size_t)p + 2 + (size_t)k * k, sizeof(double));
  if (!buf) return NZ_ENOMEM;
  double *a = buf, *phi = a + k, *H = phi + p + 2;
  if (J) memset(J, 0, (size_t)N * N * sizeof(double));
  /* M q'' + h - Q: the Nielsen residual at the state's q'' (K = 0). */
  if ((st = nielsen_series(s, t, lv, 3, 0, F))) goto done;
  for (int r = 0; r < nc; r++) {
    int m = orders[r], Kphi = p - m;
    if ((st = constraint_series(s, r, m, Kphi, 0, t, lv, p + 1, phi, a))) goto done;
    F[k + r] = nz_factorial(Kphi) * phi[Kphi];     /* Phi_r^(p - m_r) */
    for (int i = 0; i < k; i++) F[i] -= x[k + r] * a[i];
    if (!J) continue;
    /* By (2.1) q^(p) enters Phi_r^(p - m_r) with the coefficient A_r. */
    for (int i = 0; i < k; i++) {
      J[i * N + k + r] = -a[i];
      J[(k + r) * N + i] = a[i];
    }
    if (m == p && !linear[r]) {                 /* A_r depends on q^(p) */
      if ((st = top_hessian(s, r, p, t, lv, p + 1, H))) goto done;
      for (int i = 0; i < k; i++)
        for (int j = 0; j < k; j++) J[i * N + j] -= x[k + r] * H[i * k + j];
    }
  }
done:
  free(buf);
  return st;
}

static double max_abs(int n, const double *v)
{
  double m = 0.0;
  for (int i = 0; i < n; i++) m = fmax(m, fabs(v[i]));
  return m;
}

/* Newton's start without a guess: q^(p) = 0 and lambda minimizing |G|
 * with the gradients there (G = r - A^T lambda). */
static int top_start(const nz_system *s, const int *orders, const int *linear, int p, double t,
                     const double *const *levels, double *x, double *F, double *J)
{
  int k = s->k, nc = s->nc, N = k + nc, st;
  memset(x, 0, (size_t)N * sizeof(double));
  if ((st = nz_top_equations(s, orders, linear, p, t, levels, x, F, J))) return st;
  double *At = malloc((size_t)k * nc * sizeof(double) + 1);
  if (!At) return NZ_ENOMEM;
  for (int i = 0; i < k; i++)              /* J's lambda columns hold -A^T */
    for (int r = 0; r < nc; r++) At[(size_t)i * nc + r] = -J[i * N + k + r];
  st = nc > 0 ? nz_lstsq(k, nc, At, F, x + k) : NZ_OK;
  free(At);
  return st;
}

int nz_top_solve(const nz_system *s, const int *orders, const int *linear, int p,
                 const nz_accel_options *opt, double t, const double *const *levels,
                 const double *guess, double *x, nz_accel_report *rep)
{
  int k = s->k, nc = s->nc, N = k + nc, st = NZ_OK;
  rep->failure = NZ_ACCEL_OK;
  rep->iterations = 0;
  rep->residual = 0.0;
  rep->rank_A = nc;
  rep->from_guess = guess != NULL;
  double *buf = calloc(4 * (size_t)N + (size_t)N * N, sizeof(double));
  if (!buf) return NZ_ENOMEM;
  double *F = buf, *dx = F + N, *xt = dx + N, *Ft = xt + N, *J = Ft + N;
  if (guess) memcpy(x, guess, (size_t)N * sizeof(double));
  else if ((st = top_start(s, orders, linear, p, t, levels, x, F, J))) goto done;
  /* Damped Newton: halve the step until |F| decreases.  The scale of the
   * test: the dynamic terms of (6.2) and the size of the unknowns. */
  for (int it = 0;; it++) {
    if ((st = nz_top_equations(s, orders, linear, p, t, levels, x, F, J))) goto done;
    double norm = max_abs(N, F);
    rep->residual = norm;
    rep->iterations = it;
    if (norm <= opt->newton_tol * (1.0 + max_abs(N, x) + max_abs(k, F))) break;
    if (it >= opt->newton_maxit || !isfinite(norm)) {
      rep->failure = NZ_ACCEL_TOP_NEWTON;
      rep->newton_stop = isfinite(norm) ? NZ_NEWTON_MAXIT : NZ_NEWTON_VALUE_NOT_FINITE;
      st = NZ_EARG;
      goto done;
    }
    for (int i = 0; i < N; i++) F[i] = -F[i];
    /* A singular Jacobian at an iterate (the start from q^(p) = 0 often
     * has one) is not yet a verdict on the root: take the least-squares
     * step, and give up only when it does not move. */
    if ((st = nz_solve_svd(N, J, F, dx, &rep->rcond))) goto done;
    if (!(rep->rcond >= opt->rcond_min) && (st = nz_lstsq(N, N, J, F, dx))) goto done;
    if (!(max_abs(N, dx) > 0.0)) {          /* stuck: said as such, not "did not converge" */
      rep->failure = NZ_ACCEL_TOP_NEWTON;
      rep->newton_stop = NZ_NEWTON_NO_PROGRESS;
      st = NZ_EARG;
      goto done;
    }
    double step = 1.0;
    for (int half = 0; half < 30; half++, step *= 0.5) {
      for (int i = 0; i < N; i++) xt[i] = x[i] + step * dx[i];
      if ((st = nz_top_equations(s, orders, linear, p, t, levels, xt, Ft, NULL))) goto done;
      if (max_abs(N, Ft) < norm) break;
    }
    memcpy(x, xt, (size_t)N * sizeof(double));
  }
  /* At the root: the condition of the Jacobian (a singular one means that
   * the root is not isolated: q^(p) is not determined, e.g. lambda = 0),
   * and one more Newton step, which polishes the root. */
  for (int i = 0; i < N; i++) F[i] = -F[i];
  if ((st = nz_solve_svd(N, J, F, dx, &rep->rcond))) goto done;
  if (!(rep->rcond >= opt->rcond_min)) { rep->failure = NZ_ACCEL_TOP_SINGULAR; st = NZ_ESINGULAR; goto done; }
  for (int i = 0; i < N; i++) x[i] += dx[i];
  if (rep->A)                                     /* the gradients at the root */
    for (int r = 0; r < nc; r++) memcpy(rep->A + (size_t)r * k, J + (size_t)(k + r) * N, (size_t)k * sizeof(double));
done:
  free(buf);
  return st;
}

int nz_top_rhs(const nz_system *s, const int *orders, const int *linear, int p,
               const nz_accel_options *opt, double t, const double *y, const double *guess,
               double *f, double *x, nz_accel_report *rep)
{
  int k = s->k;
  const double *levels[NZ_MAX_LEVELS];
  if (p < 3 || p + 1 > NZ_MAX_LEVELS) return NZ_EARG;
  for (int j = 0; j < p; j++) levels[j] = y + (size_t)j * k;
  int st = nz_top_solve(s, orders, linear, p, opt, t, levels, guess, x, rep);
  if (st) return st;
  memcpy(f, y + k, (size_t)(p - 1) * k * sizeof(double));          /* q' .. q^(p-1) */
  memcpy(f + (size_t)(p - 1) * k, x, (size_t)k * sizeof(double));  /* q^(p) */
  return NZ_OK;
}

/* ------------------------------------------------------------------ */
/* Central differences of a right-hand side                              */

int nz_central_jacobian(int dim, double t, const double *y, nz_rhs_fn f, void *ctx,
                        double *dfdy, double *dfdt, double *work)
{
  const double c = cbrt(DBL_EPSILON);
  double *yy = work, *fa = yy + dim, *fb = fa + dim;
  int st = NZ_OK;
  memcpy(yy, y, (size_t)dim * sizeof(double));
  for (int j = 0; j < dim && !st; j++) {
    volatile double up = y[j] + c * (1.0 + fabs(y[j]));
    double hj = up - y[j];                      /* exactly representable */
    yy[j] = y[j] + hj;
    if (!(st = f(t, yy, fa, ctx))) {
      yy[j] = y[j] - hj;
      st = f(t, yy, fb, ctx);
    }
    yy[j] = y[j];
    for (int i = 0; i < dim && !st; i++) dfdy[(size_t)i * dim + j] = (fa[i] - fb[i]) / (2.0 * hj);
  }
  if (!st) {
    volatile double up = t + c * (1.0 + fabs(t));
    double ht = up - t;
    if (!(st = f(t + ht, y, fa, ctx)) && !(st = f(t - ht, y, fb, ctx)))
      for (int i = 0; i < dim; i++) dfdt[i] = (fa[i] - fb[i]) / (2.0 * ht);
  }
  return st;
}
