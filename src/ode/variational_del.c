/* variational_del.c - the trapezoidal discrete Euler-Lagrange equations
 * solved by Newton's method (see variational_del.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/linalg.h"
#include "mech/constrained.h"
#include "ode/variational_del.h"

struct nz_del {
  int k, nc, nlevels, N;          /* N = k + nc unknowns                      */
  nz_motion mo;                   /* the jets of one evaluation               */
  nz_lu *lu;
  double *J, *z, *dz, *R;         /* N x N, N, N, N                           */
  double *pA, *gA, *pB, *gB;      /* p and g at (t0, q0, v) and (t1, q1, v)   */
  double *dpA, *dgA, *dpB;        /* along one direction                      */
  double *x, *v, *w, *e, *dv;     /* q1, v, the velocity, a unit vector, e/h  */
  double *G0, *G1;                /* nc x k                                   */
  double *phi, *phit, *dphi;      /* nc, nc, nlevels x k                      */
  double *zeros;                  /* the constraints' levels above q: 0       */
  double *lam0;                   /* nc: the last step's l per unit of h:     */
                                  /* Newton's start for the next (l ~ h/2 lambda) */
};

nz_del *nz_del_new(int k, int nc, int nlevels)
{
  if (k < 1 || nc < 0 || nlevels < 1) return NULL;
  nz_del *d = calloc(1, sizeof *d);
  if (!d) return NULL;
  int N = k + nc;
  d->k = k, d->nc = nc, d->nlevels = nlevels, d->N = N;
  size_t n = (size_t)N * N + 3 * (size_t)N + 7 * (size_t)k + 5 * (size_t)k + 2 * (size_t)nc * k + 2 * (size_t)nc +
             2 * (size_t)nlevels * k + (size_t)nc + 1;
  double *b = calloc(n, sizeof(double));
  d->lu = nz_lu_new(N);
  if (!b || !d->lu) {
    free(b);
    nz_lu_free(d->lu);
    free(d);
    return NULL;
  }
  d->J = b, b += (size_t)N * N;
  d->z = b, b += N;
  d->dz = b, b += N;
  d->R = b, b += N;
  d->pA = b, b += k;
  d->gA = b, b += k;
  d->pB = b, b += k;
  d->gB = b, b += k;
  d->dpA = b, b += k;
  d->dgA = b, b += k;
  d->dpB = b, b += k;
  d->x = b, b += k;
  d->v = b, b += k;
  d->w = b, b += k;
  d->e = b, b += k;
  d->dv = b, b += k;
  d->G0 = b, b += (size_t)nc * k;
  d->G1 = b, b += (size_t)nc * k;
  d->phi = b, b += nc;
  d->phit = b, b += nc;
  d->dphi = b, b += (size_t)nlevels * k;
  d->zeros = b, b += (size_t)nlevels * k;
  d->lam0 = b;
  return d;
}

void nz_del_free(nz_del *d)
{
  if (!d) return;
  nz_motion_free(&d->mo);
  nz_lu_free(d->lu);
  free(d->J);
  free(d);
}

/* F, V and Q at (t, q, v): p = dF/dq' and g = dF/dq - dV/dq + Q, and
 * along the direction (dq, dv) when dq is not NULL their derivatives dp,
 * dg.  Each piece on jets of order 0 with 2k tangents (q_i is tangent i,
 * q'_i tangent k + i), the workspace set again for each (an evaluation
 * writes its outputs only).  g, dg may be NULL (p alone). */
static int point(nz_del *d, const nz_system *s, double t, const double *q, const double *v, const double *dq,
                 const double *dv, double *p, double *g, double *dp, double *dg)
{
  int k = d->k, st;
  const double *state[2] = { q, v };
  nz_motion *mo = &d->mo;
  nz_state_direction dir = { 0.0, dq, dv, NULL };
  const nz_piece pieces[3] = { NZ_PIECE_F, NZ_PIECE_V, NZ_PIECE_Q };
  memset(p, 0, (size_t)k * sizeof(double));
  if (g) memset(g, 0, (size_t)k * sizeof(double));
  if (dp) memset(dp, 0, (size_t)k * sizeof(double));
  if (dg) memset(dg, 0, (size_t)k * sizeof(double));
  for (int n = 0; n < (g ? 3 : 1); n++) {
    nz_piece piece = pieces[n];
    if (!nz_system_has(s, piece)) continue;
    if ((st = nz_motion_reset(mo, k, 2, 0, 2 * k, t, state, 2))) return st;
    for (int i = 0; i < k; i++) {
      nz_motion_seed_slot(mo, i, i, 0);
      nz_motion_seed_slot(mo, i, k + i, 1);
    }
    if (dq && (st = nz_motion_set_direction(mo, &dir))) return st;
    if ((st = nz_motion_eval(s, piece, 0, mo, NULL))) return st;
    for (int i = 0; i < k; i++) {
      if (piece == NZ_PIECE_F) {
        p[i] = nz_jet_tangent(mo->out[0], k + i)[0];
        if (g) g[i] = nz_jet_tangent(mo->out[0], i)[0];
        if (dq) dp[i] = nz_jet_tangent(mo->dout[0], k + i)[0];
        if (dq && dg) dg[i] = nz_jet_tangent(mo->dout[0], i)[0];
      } else if (piece == NZ_PIECE_V) {
        g[i] -= nz_jet_tangent(mo->out[0], i)[0];
        if (dq && dg) dg[i] -= nz_jet_tangent(mo->dout[0], i)[0];
      } else {
        g[i] += mo->out[i]->c[0];
        if (dq && dg) dg[i] += mo->dout[i]->c[0];
      }
    }
  }
  return NZ_OK;
}

int nz_del_momentum(nz_del *d, const nz_system *s, double t, const double *q, const double *w, double *p)
{
  return point(d, s, t, q, w, NULL, NULL, p, NULL, NULL, NULL);
}

int nz_del_constraints(nz_del *d, const nz_system *s, double t, const double *q, double *phi, double *G, double *phit)
{
  int k = d->k, st;
  const double *state[NZ_MAX_LEVELS];
  state[0] = q;
  for (int j = 1; j < d->nlevels; j++) state[j] = d->zeros + (size_t)j * k;
  for (int r = 0; r < d->nc; r++) {
    double value, dt;
    if (nz_constraint_levels(s, r) > d->nlevels) return NZ_EARG;   /* (the workspace's dphi) */
    if ((st = nz_constraint_partials(s, r, t, state, d->nlevels, &value, d->dphi, &dt))) return st;
    memcpy(G + (size_t)r * k, d->dphi, (size_t)k * sizeof(double));
    if (phi) phi[r] = value;
    if (phit) phit[r] = dt;
  }
  return NZ_OK;
}

/* Solve J dz = -R in place (dz), J N x N; NZ_ESINGULAR when a pivot is 0
 * or the correction is not finite. */
static int newton_solve(nz_del *d, int N)
{
  for (int i = 0; i < N; i++) d->dz[i] = -d->R[i];
  if (nz_lu_factor(d->lu, N, d->J) || nz_lu_solve(d->lu, d->dz)) return NZ_ESINGULAR;
  for (int i = 0; i < N; i++)
    if (!isfinite(d->dz[i])) return NZ_ESINGULAR;
  return NZ_OK;
}

/* Whether Newton is done: the equations hold to rounding, |R| below
 * NZ_DEL_TOL of the size of their terms (normwise), or their residual no
 * longer shrinks (quadratic convergence would have halved it at least)
 * while already within 1e-10 of them: the rounding of the terms reached.
 * *last: the previous residual relative to the terms. */
int nz_del_converged(const double *R, const double *size, int N, double *last)
{
  double r = 0.0, z = 0.0;
  for (int i = 0; i < N; i++) r = fmax(r, fabs(R[i])), z = fmax(z, size[i]);
  double rel = z > 0.0 ? r / z : (r > 0.0 ? INFINITY : 0.0);
  int done = rel <= NZ_DEL_TOL || (rel >= 0.5 * *last && rel <= 1e-10);
  *last = rel;
  return done;
}

/* Row i of a residual whose momentum part is f (the sum of its terms'
 * sizes: size), with the multipliers' forces G^T m added (G: nc x k, m
 * the unknowns after the k of q or w in d->z), into d->R and its size into
 * d->dz (nz_del_converged's test). */
static void multiplier_row(nz_del *d, const double *G, int i, double f, double size)
{
  int k = d->k;
  for (int r = 0; r < d->nc; r++) {
    double c = G[(size_t)r * k + i] * d->z[k + r];
    f += c;
    size += fabs(c);
  }
  d->R[i] = f;
  d->dz[i] = size;
}

/* The first two lines at the increment z = (q1 - q0, l): R and the size
 * of its terms into the workspace (R, dz), and, when jacobian, J; pA, gA,
 * pB, gB at z. */
static int residual(nz_del *d, const nz_system *s, double t0, double h, const double *q0, const double *p0, int jacobian,
                    unsigned long *nfev)
{
  int k = d->k, nc = d->nc, N = d->N, st;
  double t1 = t0 + h;
  for (int i = 0; i < k; i++) {
    d->v[i] = d->z[i] / h;
    d->x[i] = q0[i] + d->z[i];
  }
  if (!jacobian) {
    if ((st = point(d, s, t0, q0, d->v, NULL, NULL, d->pA, d->gA, NULL, NULL))) return st;
    if ((st = point(d, s, t1, d->x, d->v, NULL, NULL, d->pB, d->gB, NULL, NULL))) return st;
    *nfev += 2;
  }
  /* column j: q1 moves by e_j, so v by e_j / h; q0 stays */
  for (int j = 0; jacobian && j < k; j++) {
    memset(d->e, 0, (size_t)k * sizeof(double));
    memset(d->dv, 0, (size_t)k * sizeof(double));
    d->e[j] = 1.0;
    d->dv[j] = 1.0 / h;
    if ((st = point(d, s, t0, q0, d->v, d->zeros, d->dv, d->pA, d->gA, d->dpA, d->dgA))) return st;
    if ((st = point(d, s, t1, d->x, d->v, d->e, d->dv, d->pB, d->gB, d->dpB, NULL))) return st;
    *nfev += 2;
    for (int i = 0; i < k; i++) d->J[(size_t)i * N + j] = 0.5 * (d->dpA[i] + d->dpB[i]) - 0.5 * h * d->dgA[i];
  }
  for (int i = 0; i < k; i++) {
    double f = -p0[i] + 0.5 * (d->pA[i] + d->pB[i]) - 0.5 * h * d->gA[i];
    double size = fabs(p0[i]) + 0.5 * (fabs(d->pA[i]) + fabs(d->pB[i])) + 0.5 * h * fabs(d->gA[i]);
    multiplier_row(d, d->G0, i, f, size);
  }
  if (nc == 0) return NZ_OK;
  if ((st = nz_del_constraints(d, s, t1, d->x, d->phi, d->G1, d->phit))) return st;
  for (int r = 0; r < nc; r++) {
    double size = 0.0;
    for (int j = 0; j < k; j++) size += fabs(d->G1[(size_t)r * k + j] * d->x[j]);
    d->R[k + r] = d->phi[r];
    d->dz[k + r] = size;
    for (int j = 0; jacobian && j < k; j++) {
      d->J[(size_t)(k + r) * N + j] = d->G1[(size_t)r * k + j];
      d->J[(size_t)j * N + k + r] = d->G0[(size_t)r * k + j];
    }
    for (int c = 0; jacobian && c < nc; c++) d->J[(size_t)(k + r) * N + k + c] = 0.0;
  }
  return NZ_OK;
}

/* The last two lines: w1 and m from p(t1, q1, w) + G1^T m = pt (the
 * momentum before the projection), G1 w + Phi_t = 0, Newton from w = v,
 * m = 0; q1 = x, G1 and phit are the workspace's.  Into d->w, and the
 * projection G1^T m into proj. */
static int velocity(nz_del *d, const nz_system *s, double t1, const double *pt, double *proj, unsigned long *nfev,
                    unsigned long *njev, nz_del_report *rep)
{
  int k = d->k, nc = d->nc, N = d->N, st;
  double last = INFINITY;
  memset(d->z, 0, (size_t)N * sizeof(double));
  memcpy(d->z, d->v, (size_t)k * sizeof(double));
  for (int it = 1;; it++) {
    for (int j = 0; j < k; j++) {   /* column j of dp/dw, the mass matrix, and p itself */
      memset(d->dv, 0, (size_t)k * sizeof(double));
      d->dv[j] = 1.0;
      if ((st = point(d, s, t1, d->x, d->z, d->zeros, d->dv, d->pB, NULL, d->dpB, NULL))) return st;
      for (int i = 0; i < k; i++) d->J[(size_t)i * N + j] = d->dpB[i];
    }
    *nfev += (unsigned long)k;
    ++*njev;
    for (int i = 0; i < k; i++) {
      multiplier_row(d, d->G1, i, d->pB[i] - pt[i], fabs(d->pB[i]) + fabs(pt[i]));
    }
    for (int r = 0; r < nc; r++) {
      double f = d->phit[r], size = fabs(d->phit[r]);
      for (int j = 0; j < k; j++) {
        double c = d->G1[(size_t)r * k + j] * d->z[j];
        f += c;
        size += fabs(c);
        d->J[(size_t)(k + r) * N + j] = d->G1[(size_t)r * k + j];
        d->J[(size_t)j * N + k + r] = d->G1[(size_t)r * k + j];
      }
      for (int c = 0; c < nc; c++) d->J[(size_t)(k + r) * N + k + c] = 0.0;
      d->R[k + r] = f;
      d->dz[k + r] = size;
    }
    if (nz_del_converged(d->R, d->dz, N, &last)) break;
    if (it > NZ_DEL_MAXIT) {
      rep->what = NZ_DEL_NEWTON, rep->velocity = 1, rep->iterations = NZ_DEL_MAXIT, rep->residual = last;
      return NZ_EARG;
    }
    if ((st = newton_solve(d, N))) {
      rep->what = NZ_DEL_SINGULAR, rep->velocity = 1, rep->iterations = it;
      return st;
    }
    for (int i = 0; i < N; i++) d->z[i] += d->dz[i];
  }
  memcpy(d->w, d->z, (size_t)k * sizeof(double));
  for (int i = 0; i < k; i++) {
    proj[i] = 0.0;
    for (int r = 0; r < nc; r++) proj[i] += d->G1[(size_t)r * k + i] * d->z[k + r];
  }
  return NZ_OK;
}

int nz_del_step(nz_del *d, const nz_system *s, double t0, double h, const double *q0, const double *p0,
                const double *guess, double *dq, double *dp, double *w1, unsigned long *nfev, unsigned long *njev,
                nz_del_report *rep)
{
  int k = d->k, nc = d->nc, N = d->N, st;
  memset(rep, 0, sizeof *rep);
  if (nc > 0 && (st = nz_del_constraints(d, s, t0, q0, NULL, d->G0, NULL))) {
    rep->what = NZ_DEL_EVAL;
    return st;
  }
  memcpy(d->z, guess, (size_t)k * sizeof(double));
  for (int r = 0; r < nc; r++) d->z[k + r] = d->lam0[r] * h;
  double last = INFINITY;
  for (int it = 1;; it++) {
    if ((st = residual(d, s, t0, h, q0, p0, 0, nfev))) {
      rep->what = NZ_DEL_EVAL;
      return st;
    }
    if (nz_del_converged(d->R, d->dz, N, &last)) break;
    if (it > NZ_DEL_MAXIT) {
      rep->what = NZ_DEL_NEWTON, rep->iterations = NZ_DEL_MAXIT, rep->residual = last;
      return NZ_EARG;
    }
    if ((st = residual(d, s, t0, h, q0, p0, 1, nfev))) {
      rep->what = NZ_DEL_EVAL;
      return st;
    }
    ++*njev;
    if ((st = newton_solve(d, N))) {
      rep->what = NZ_DEL_SINGULAR, rep->iterations = it;
      return st;
    }
    for (int i = 0; i < N; i++) d->z[i] += d->dz[i];
  }
  for (int r = 0; r < nc; r++) d->lam0[r] = d->z[k + r] / h;
  /* p1 - p0 before the projection: h/2 (gA + gB) - G0^T l (the first line
   * subtracted from the third) */
  for (int i = 0; i < k; i++) {
    double f = 0.5 * h * (d->gA[i] + d->gB[i]);
    for (int r = 0; r < nc; r++) f -= d->G0[(size_t)r * k + i] * d->z[k + r];
    dq[i] = d->z[i];
    dp[i] = f;
    d->pA[i] = p0[i] + f;     /* the momentum before the projection (pA is free now) */
  }
  if ((st = velocity(d, s, t0 + h, d->pA, d->dgA, nfev, njev, rep))) {
    if (rep->what == NZ_DEL_OK) rep->what = NZ_DEL_EVAL, rep->velocity = 1;
    return st;
  }
  for (int i = 0; i < k; i++) {
    dp[i] -= d->dgA[i];
    w1[i] = d->w[i];
  }
  return NZ_OK;
}
