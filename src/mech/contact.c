/* contact.c - unilateral contacts, impacts and Coulomb friction (see
 * contact.h; the equations are docs/theory.md §13).
 *
 * Three solves, each a few lines of linear algebra on the system's M, h and
 * constraint rows (mech.h, constrained.h):
 *   the mode's saddle point (mode_solve), per right-hand side of the
 *   integrator: M's Cholesky factor and Delassus' small matrix (Schur);
 *   the bilateral saddle point K = [M -A_b^T; A_b 0], factored once per
 *   transition, whose solves give the response of the motion to a force
 *   (respond) and the accelerations without any contact force (a0): the
 *   columns of the LCPs (Delassus' operator J M^-1 J^T with the bilateral
 *   constraints held);
 *   the LCPs of the impact and of the new mode (lcp_*), by Lemke. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_linalg.h>
#include "core/linalg.h"
#include "mech/constrained.h"
#include "mech/contact.h"

struct nz_contacts {
  int k, nc, nb, n;
  int *orders;                 /* nc */
  nz_contact_def *def;         /* n */
  int *mode;                   /* n: nz_contact_state */
  double zeno_speed, rcond_min;
  /* the offsets of the events (2n): a gap left open at zero, a slip
   * started at zero slip velocity, start the new mode strictly positive */
  double *offset;
  /* Zeno: the times of the last three impacts of each contact, and its velocity scales */
  double *ht, *vmax, *vtmax, *gmax;
  int *nh;
  /* the frame at a state */
  double *M, *h;               /* k k, k */
  double *A, *b;               /* nc x k rows at the acceleration level, nc rests (q'' = 0) */
  double *phi, *vn, *vt;       /* n each */
  double *zero;                /* k zeros: q'' for the rows */
  nz_motion mo;                /* value and rate of a constraint */
  /* the mode's saddle point */
  int *rows, *couple;
  double *coef;                /* nc each */
  double *S, *rhs;             /* the mode solve's workspace; the bilateral rows' right-hand side */
  double *spd_work;            /* nz_solve_spd_in's */
  /* the last mode solve */
  int cvalid;
  double ct, *cy, *cqdd, *clam;   /* 2k, k, nc */
  /* the bilateral saddle point, equilibrated (kscale: 1/max|M|, then 1/|A_r|) */
  gsl_matrix *K;
  gsl_vector *tau, *norm, *kwork, *kb, *kx;
  gsl_permutation *perm;
  double *kscale;              /* 1 + nb */
  double *a0;                  /* k: q'' without contact forces */
  /* the LCPs: up to 4n unknowns */
  int *var_c, *var_kind, *var_at;   /* 4n; var_at: n x 4, the unknown of each kind (-1) */
  double *resp, *F, *scr;      /* 4n x k responses, k force, 3k scratch */
  double *L, *lq, *lz, *lw, *lwork;
  int *touch, *sliding, *appr, *mode0;   /* n each */
  double *e_eff;               /* n */
  nz_contact_report_failure fail;
  double *fq, *fqd;            /* k each */
};

/* ------------------------------------------------------------------ */
/* Making and configuring                                               */

void nz_contacts_free(nz_contacts *c)
{
  if (!c) return;
  free(c->orders);
  free(c->def);
  free(c->mode);
  free(c->offset);
  free(c->ht);
  free(c->M);
  free(c->rows);
  free(c->S);
  free(c->spd_work);
  free(c->cy);
  free(c->var_c);
  free(c->resp);
  free(c->L);
  free(c->touch);
  free(c->kscale);
  free(c->fq);
  nz_motion_free(&c->mo);
  if (c->K) gsl_matrix_free(c->K);
  if (c->tau) gsl_vector_free(c->tau);
  if (c->norm) gsl_vector_free(c->norm);
  if (c->kwork) gsl_vector_free(c->kwork);
  if (c->kb) gsl_vector_free(c->kb);
  if (c->kx) gsl_vector_free(c->kx);
  if (c->perm) gsl_permutation_free(c->perm);
  free(c);
}

nz_contacts *nz_contacts_new(int k, const nz_contacts_config *cfg)
{
  int nc = cfg->nc, nb = cfg->nb, n = cfg->n;
  if (k < 1 || n < 1 || nb < 0 || nb > nc || !cfg->orders || !cfg->defs) return NULL;
  for (int r = 0; r < nb; r++)
    if (cfg->orders[r] < 0 || cfg->orders[r] > 1) return NULL;
  for (int j = 0; j < n; j++) {
    const nz_contact_def *d = &cfg->defs[j];
    if (d->gap < nb || d->gap >= nc || cfg->orders[d->gap] != 0) return NULL;
    if (d->slip >= 0 && (d->slip < nb || d->slip >= nc || d->slip == d->gap || cfg->orders[d->slip] > 1)) return NULL;
    if (!(d->e >= 0.0 && d->e <= 1.0) || !(d->mu >= 0.0) || !(d->mu_s >= d->mu) || !isfinite(d->mu_s)) return NULL;
    if (d->slip < 0 && d->mu > 0.0) return NULL;
  }
  nz_contacts *c = calloc(1, sizeof *c);
  if (!c) return NULL;
  c->k = k, c->nc = nc, c->nb = nb, c->n = n;
  c->zeno_speed = cfg->zeno_speed > 0.0 ? cfg->zeno_speed : NZ_CONTACT_ZENO_SPEED;
  c->rcond_min = cfg->rcond_min > 0.0 ? cfg->rcond_min : NZ_RCOND_MIN;
  size_t K = (size_t)k, C = (size_t)nc, N = (size_t)n, V = 4 * N, D = K + C, NK = K + (size_t)nb;
  c->orders = malloc(C * sizeof(int));
  c->def = malloc(N * sizeof *c->def);
  c->mode = calloc(2 * N, sizeof(int));                 /* mode, nh */
  c->offset = calloc(2 * N, sizeof(double));
  c->ht = calloc(10 * N, sizeof(double));               /* ht (3n), vmax, vtmax, phi, vn, vt, e_eff, gmax */
  c->M = calloc(K * K + 3 * K + C * K + C, sizeof(double));   /* M, h, zero, a0, A, b */
  c->rows = calloc(3 * C + 1, sizeof(int));             /* rows, couple (ints), coef below */
  /* S: the mode solve's X (k (nc + 1)), M's factor (k k), G and its
   * inverse (nc nc each), lambda (nc); then rhs, coef */
  size_t SL = K * (C + 1) + K * K + 2 * C * C + C;
  c->S = calloc(SL + D + C + 1, sizeof(double));
  c->spd_work = calloc(nz_solve_spd_work_len(k) + 1, sizeof(double));
  c->cy = calloc(4 * K + C + 3 * K, sizeof(double));    /* cy, cqdd, clam, F, scr */
  c->var_c = calloc(3 * V + 4 * N, sizeof(int));        /* var_c, var_kind, var_at, then touch.. below */
  c->resp = calloc(V * K + 1, sizeof(double));
  c->L = calloc(V * V + 3 * V + nz_lcp_work_len((int)V), sizeof(double));
  c->touch = calloc(4 * N, sizeof(int));                /* touch, sliding, appr, mode0 */
  c->kscale = calloc(1 + (size_t)nb + 1, sizeof(double));
  c->fq = calloc(2 * K, sizeof(double));
  c->K = gsl_matrix_alloc(NK, NK);
  c->tau = gsl_vector_alloc(NK);
  c->norm = gsl_vector_alloc(NK);
  c->kwork = gsl_vector_alloc(3 * NK);
  c->kb = gsl_vector_alloc(NK);
  c->kx = gsl_vector_alloc(NK);
  c->perm = gsl_permutation_alloc(NK);
  if (!c->orders || !c->def || !c->mode || !c->offset || !c->spd_work || !c->ht || !c->M || !c->rows || !c->S || !c->cy || !c->var_c ||
      !c->resp || !c->L || !c->touch || !c->kscale || !c->fq || !c->K || !c->tau || !c->norm || !c->kwork ||
      !c->kb || !c->kx || !c->perm) {
    nz_contacts_free(c);
    return NULL;
  }
  memcpy(c->orders, cfg->orders, C * sizeof(int));
  memcpy(c->def, cfg->defs, N * sizeof *c->def);
  c->nh = c->mode + N;
  c->vmax = c->ht + 3 * N;
  c->vtmax = c->vmax + N;
  c->phi = c->vtmax + N;
  c->vn = c->phi + N;
  c->vt = c->vn + N;
  c->e_eff = c->vt + N;
  c->gmax = c->e_eff + N;
  c->h = c->M + K * K;
  c->zero = c->h + K;
  c->a0 = c->zero + K;
  c->A = c->a0 + K;
  c->b = c->A + C * K;
  c->couple = c->rows + C;
  c->rhs = c->S + SL;
  c->coef = c->rhs + D;
  c->cqdd = c->cy + 2 * K;
  c->clam = c->cqdd + K;
  c->F = c->clam + C;
  c->scr = c->F + K;
  c->var_kind = c->var_c + V;
  c->var_at = c->var_kind + V;
  c->lq = c->L + V * V;
  c->lz = c->lq + V;
  c->lw = c->lz + V;
  c->lwork = c->lw + V;
  c->sliding = c->touch + N;
  c->appr = c->sliding + N;
  c->mode0 = c->appr + N;
  c->fail.q = c->fq;
  c->fail.qd = c->fq + K;
  gsl_set_error_handler_off();
  return c;
}

int nz_contacts_count(const nz_contacts *c) { return c->n; }
int nz_contacts_bilateral(const nz_contacts *c) { return c->nb; }
int nz_contacts_nevents(const nz_contacts *c) { return 2 * c->n; }
const nz_contact_report_failure *nz_contacts_failure(const nz_contacts *c) { return &c->fail; }

void nz_contacts_get_mode(const nz_contacts *c, int *state) { memcpy(state, c->mode, (size_t)c->n * sizeof(int)); }

static int allowed(const nz_contact_def *d, int st)
{
  if (st == NZ_CONTACT_OPEN) return 1;
  if (st == NZ_CONTACT_CLOSED) return d->slip < 0;
  return d->slip >= 0 && st <= NZ_CONTACT_SLIP_NEG;
}

int nz_contacts_set_mode(nz_contacts *c, const int *state)
{
  for (int j = 0; j < c->n; j++)
    if (!allowed(&c->def[j], state[j])) return NZ_EARG;
  memcpy(c->mode, state, (size_t)c->n * sizeof(int));
  memset(c->offset, 0, 2 * (size_t)c->n * sizeof(double));
  c->cvalid = 0;
  return NZ_OK;
}

void nz_contacts_reset(nz_contacts *c)
{
  size_t N = (size_t)c->n;
  memset(c->nh, 0, N * sizeof(int));
  memset(c->vmax, 0, N * sizeof(double));
  memset(c->vtmax, 0, N * sizeof(double));
  memset(c->gmax, 0, N * sizeof(double));
  memset(c->offset, 0, 2 * N * sizeof(double));
  c->cvalid = 0;
}

static void fail_at(nz_contacts *c, nz_contact_failure kind, int status, int contact, double t, const double *q,
                    const double *qd)
{
  c->fail.kind = kind;
  c->fail.status = status;
  c->fail.contact = contact;
  c->fail.t = t;
  memcpy(c->fq, q, (size_t)c->k * sizeof(double));
  memcpy(c->fq + c->k, qd, (size_t)c->k * sizeof(double));
}

static void clear_failure(nz_contacts *c)
{
  c->fail.kind = NZ_CONTACT_OK;
  c->fail.status = NZ_OK;
  c->fail.contact = -1;
  c->fail.value = c->fail.an = 0.0;
}

/* ------------------------------------------------------------------ */
/* The system's quantities                                              */

/* Constraint r and its first derivative along the motion at (t, q, q')
 * (q'' = 0): the first two coefficients of its jet of order 1.  A gap's
 * value and normal velocity; a slip function's value and, for one of
 * order 0, the slip velocity. */
static int value_rate(nz_contacts *c, const nz_system *s, int r, double t, const double *q, const double *qd,
                      double out[2])
{
  const double *state[3] = { q, qd, c->zero };
  int st = nz_motion_reset(&c->mo, c->k, nz_constraint_levels(s, r), 1, 0, t, state, 3);
  if (!st) st = nz_motion_eval(s, NZ_PIECE_PHI, r, &c->mo, NULL);
  if (!st) {
    out[0] = c->mo.out[0]->c[0];
    out[1] = c->mo.out[0]->c[1];
  }
  return st;
}

/* The slip velocity of contact j at (t, q, q'). */
static int slip_velocity(nz_contacts *c, const nz_system *s, int j, double t, const double *q, const double *qd,
                         double *vt)
{
  double v[2];
  int r = c->def[j].slip, st = value_rate(c, s, r, t, q, qd, v);
  if (!st) *vt = c->orders[r] == 1 ? v[0] : v[1];
  return st;
}

/* Row r at the acceleration level into A[r], b[r]: A q'' + b = Phi^(2-m). */
static int row(nz_contacts *c, const nz_system *s, int r, double t, const double *q, const double *qd)
{
  const double *state[3] = { q, qd, c->zero };
  return nz_constraint_row(s, r, c->orders[r], t, state, 3, c->A + (size_t)r * (size_t)c->k, &c->b[r]);
}

static double dot(int k, const double *a, const double *b)
{
  double s = 0.0;
  for (int i = 0; i < k; i++) s += a[i] * b[i];
  return s;
}

static double abs_dot(int k, const double *a, const double *b)
{
  double s = 0.0;
  for (int i = 0; i < k; i++) s += fabs(a[i] * b[i]);
  return s;
}

static double max_abs(int k, const double *a)
{
  double m = 0.0;
  for (int i = 0; i < k; i++) m = fmax(m, fabs(a[i]));
  return m;
}

static const double *row_of(const nz_contacts *c, int r) { return c->A + (size_t)r * (size_t)c->k; }

/* Everything a transition reads at (t, q, q'): M, h, the bilateral rows,
 * and every contact's gap, normal velocity, slip velocity and rows. */
static int frame(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd)
{
  int st = nz_mass_bias(s, t, q, qd, c->M, c->h);
  for (int r = 0; r < c->nb && !st; r++) st = row(c, s, r, t, q, qd);
  for (int j = 0; j < c->n && !st; j++) {
    double v[2];
    const nz_contact_def *d = &c->def[j];
    if (!(st = value_rate(c, s, d->gap, t, q, qd, v)) && !(st = row(c, s, d->gap, t, q, qd))) {
      c->phi[j] = v[0];
      c->vn[j] = v[1];
      c->vt[j] = 0.0;
      if (d->slip >= 0 && !(st = slip_velocity(c, s, j, t, q, qd, &c->vt[j]))) st = row(c, s, d->slip, t, q, qd);
    }
  }
  if (st) fail_at(c, NZ_CONTACT_EVAL, st, -1, t, q, qd);
  return st;
}

/* ------------------------------------------------------------------ */
/* The mode's saddle point                                              */

int nz_contacts_active(const nz_contacts *c, int *rows, int *couple, double *coef)
{
  int na = 0;
  for (int r = 0; r < c->nb; r++, na++) rows[na] = r, couple[na] = -1, coef[na] = 0.0;
  for (int j = 0; j < c->n; j++) {
    const nz_contact_def *d = &c->def[j];
    switch (c->mode[j]) {
    case NZ_CONTACT_OPEN: break;
    case NZ_CONTACT_CLOSED: rows[na] = d->gap, couple[na] = -1, coef[na] = 0.0, na++; break;
    case NZ_CONTACT_STICK:
      rows[na] = d->gap, couple[na] = -1, coef[na] = 0.0, na++;
      rows[na] = d->slip, couple[na] = -1, coef[na] = 0.0, na++;
      break;
    case NZ_CONTACT_SLIP_POS:
    case NZ_CONTACT_SLIP_NEG:
      /* the friction force -mu s lambda_n D^T rides on the normal one */
      rows[na] = d->gap, couple[na] = d->slip;
      coef[na] = (c->mode[j] == NZ_CONTACT_SLIP_POS ? -1.0 : 1.0) * d->mu;
      na++;
      break;
    }
  }
  return na;
}

static int diagnose_singular(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                             double rcond);

/* The gradient of the mode's row r vanished: the contact it belongs to. */
static int contact_of_row(const nz_contacts *c, int r)
{
  for (int j = 0; j < c->n; j++)
    if (c->def[j].gap == r || c->def[j].slip == r) return j;
  return -1;
}

/* Gaussian elimination with partial pivoting of the n x n matrix G in
 * place (pivots in piv); 1 when a pivot is zero. */
static int lu_small(int n, double *G, int *piv)
{
  for (int c = 0; c < n; c++) {
    int p = c;
    for (int r = c + 1; r < n; r++)
      if (fabs(G[r * n + c]) > fabs(G[p * n + c])) p = r;
    piv[c] = p;
    if (!(G[p * n + c] != 0.0)) return 1;
    if (p != c)
      for (int x = 0; x < n; x++) {
        double v = G[c * n + x];
        G[c * n + x] = G[p * n + x], G[p * n + x] = v;
      }
    for (int r = c + 1; r < n; r++) {
      double f = G[r * n + c] /= G[c * n + c];
      for (int x = c + 1; x < n; x++) G[r * n + x] -= f * G[c * n + x];
    }
  }
  return 0;
}

static void lu_small_solve(int n, const double *LU, const int *piv, double *b)
{
  for (int c = 0; c < n; c++) {
    double v = b[c];
    b[c] = b[piv[c]], b[piv[c]] = v;
    for (int r = c + 1; r < n; r++) b[r] -= LU[r * n + c] * b[c];
  }
  for (int r = n - 1; r >= 0; r--) {
    for (int x = r + 1; x < n; x++) b[r] -= LU[r * n + x] * b[x];
    b[r] /= LU[r * n + r];
  }
}

/* The mode's saddle point M q'' + h = W^T lambda, R q'' + b = 0 by its
 * Schur complement: with M's Cholesky factor (its condition estimated,
 * core/linalg.h), Delassus' matrix G = R M^-1 W^T and G lambda = R M^-1 h
 * - b, then q'' = M^-1 (W^T lambda - h).  G is na x na (the rows the mode
 * holds: a few), each row scaled by its largest entry, factored by LU with
 * its condition computed from its inverse; below rcond_min the mode is
 * singular (dependent rows, or Painleve: a sliding contact's J M^-1 W^T
 * reaching zero).  No allocation: one right-hand side of the integrator
 * costs a Cholesky of M, na + 1 solves with it and an na x na LU. */
static int mode_solve(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd)
{
  int k = c->k, na = nz_contacts_active(c, c->rows, c->couple, c->coef);
  int st = nz_mass_bias(s, t, q, qd, c->M, c->h);
  for (int a = 0; a < na && !st; a++) {
    st = row(c, s, c->rows[a], t, q, qd);
    if (!st && c->couple[a] >= 0) st = row(c, s, c->couple[a], t, q, qd);
  }
  if (st) {
    fail_at(c, NZ_CONTACT_EVAL, st, -1, t, q, qd);
    return st;
  }
  /* X = M^-1 [h, W_1^T, .., W_na^T] from one factorization */
  double *X = c->S, *Mw = X + (size_t)k * (size_t)(na + 1), *G = Mw + (size_t)k * (size_t)k, *Gi = G + (size_t)na * na;
  double *lam = Gi + (size_t)na * na;
  memcpy(Mw, c->M, (size_t)k * (size_t)k * sizeof(double));
  nz_solve_info info;
  if ((st = nz_solve_spd_in(k, Mw, c->h, X, c->rcond_min, &info, c->spd_work))) {
    fail_at(c, NZ_CONTACT_MASS, st, -1, t, q, qd);
    c->fail.value = info.rcond;
    return st;
  }
  for (int a = 0; a < na; a++) {
    const double *R = row_of(c, c->rows[a]), *D = c->couple[a] >= 0 ? row_of(c, c->couple[a]) : NULL;
    double *xa = X + (size_t)k * (size_t)(a + 1);
    if (!(max_abs(k, R) > 0.0)) {            /* a gap (or a slip, a constraint) without a gradient here */
      fail_at(c, NZ_CONTACT_GRADIENT, NZ_EARG, contact_of_row(c, c->rows[a]), t, q, qd);
      return NZ_EARG;
    }
    for (int i = 0; i < k; i++) xa[i] = R[i] + (D ? c->coef[a] * D[i] : 0.0);
    nz_cholesky_solve(k, Mw, xa);
  }
  /* each row scaled by its own effective mass R M^-1 R^T (> 0): a plain
   * row's diagonal is then 1, a sliding one's the ratio J M^-1 W^T / J M^-1
   * J^T that Painleve's paradox makes vanish (a 1 x 1 matrix's condition
   * alone would always be 1) */
  for (int a = 0; a < na; a++) {
    const double *R = row_of(c, c->rows[a]);
    double ref;
    if (c->couple[a] < 0) ref = dot(k, R, X + (size_t)k * (size_t)(a + 1));
    else {
      double *y = c->scr;
      memcpy(y, R, (size_t)k * sizeof(double));
      nz_cholesky_solve(k, Mw, y);
      ref = dot(k, R, y);
    }
    double sc = ref > 0.0 ? 1.0 / ref : 1.0;
    for (int x = 0; x < na; x++) G[a * na + x] = dot(k, R, X + (size_t)k * (size_t)(x + 1)) * sc;
    lam[a] = (dot(k, R, X) - c->b[c->rows[a]]) * sc;
  }
  if (na > 0) {
    /* its condition in the 1-norm, from the inverse (na is a few) */
    double gnorm = 0.0, inorm = 0.0;
    for (int x = 0; x < na; x++) {
      double col = 0.0;
      for (int a = 0; a < na; a++) col += fabs(G[a * na + x]);
      gnorm = fmax(gnorm, col);
    }
    int piv[na];
    if (lu_small(na, G, piv)) return diagnose_singular(c, s, t, q, qd, 0.0);
    for (int x = 0; x < na; x++) {
      double *e = Gi + (size_t)x * na;
      for (int a = 0; a < na; a++) e[a] = a == x;
      lu_small_solve(na, G, piv, e);
      double col = 0.0;
      for (int a = 0; a < na; a++) col += fabs(e[a]);
      inorm = fmax(inorm, col);
    }
    /* against the rows' own size 1, not only the matrix's norm: a sliding
     * contact's lone row whose ratio reaches zero is singular too */
    double rcond = 1.0 / (fmax(gnorm, 1.0) * inorm);
    if (!(rcond >= c->rcond_min)) return diagnose_singular(c, s, t, q, qd, rcond);
    lu_small_solve(na, G, piv, lam);
  }
  /* q'' = M^-1 (W^T lambda - h) = sum_a lambda_a X_a - X_0 */
  for (int i = 0; i < k; i++) {
    double v = -X[i];
    for (int a = 0; a < na; a++) v += lam[a] * X[(size_t)k * (size_t)(a + 1) + i];
    if (!isfinite(v)) return diagnose_singular(c, s, t, q, qd, 0.0);
    c->cqdd[i] = v;
  }
  memset(c->clam, 0, (size_t)c->nc * sizeof(double));
  for (int a = 0; a < na; a++) {
    c->clam[c->rows[a]] = lam[a];
    if (c->couple[a] >= 0) c->clam[c->couple[a]] = c->coef[a] * lam[a];
  }
  c->ct = t;
  memcpy(c->cy, q, (size_t)k * sizeof(double));
  memcpy(c->cy + k, qd, (size_t)k * sizeof(double));
  c->cvalid = 1;
  return NZ_OK;
}

static int cached(const nz_contacts *c, double t, const double *q, const double *qd)
{
  size_t kb = (size_t)c->k * sizeof(double);
  return c->cvalid && c->ct == t && !memcmp(c->cy, q, kb) && !memcmp(c->cy + c->k, qd, kb);
}

int nz_contacts_accel(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                      double *qdd, double *lambda)
{
  if (!cached(c, t, q, qd)) {
    int st = mode_solve(c, s, t, q, qd);
    if (st) return st;
  }
  clear_failure(c);
  if (qdd) memcpy(qdd, c->cqdd, (size_t)c->k * sizeof(double));
  if (lambda) memcpy(lambda, c->clam, (size_t)c->nc * sizeof(double));
  return NZ_OK;
}

/* ------------------------------------------------------------------ */
/* Events                                                               */

int nz_contacts_event(nz_contacts *c, const nz_system *s, int e, double t, const double *y, double *g)
{
  int j = e / 2, friction = e % 2, k = c->k, st;
  if (e < 0 || j >= c->n) return NZ_EARG;
  const nz_contact_def *d = &c->def[j];
  const double *q = y, *qd = y + k;
  int state = c->mode[j];
  if (!friction) {
    if (state == NZ_CONTACT_OPEN) {
      double v[2];
      if ((st = value_rate(c, s, d->gap, t, q, qd, v))) return st;
      *g = v[0] + c->offset[e];
      return NZ_OK;
    }
    if ((st = nz_contacts_accel(c, s, t, q, qd, NULL, NULL))) return st;
    *g = c->clam[d->gap];
    return NZ_OK;
  }
  if (d->slip < 0 || state == NZ_CONTACT_OPEN || state == NZ_CONTACT_CLOSED) {
    *g = 1.0;
    return NZ_OK;
  }
  if (state == NZ_CONTACT_STICK) {
    if ((st = nz_contacts_accel(c, s, t, q, qd, NULL, NULL))) return st;
    *g = d->mu_s * c->clam[d->gap] - fabs(c->clam[d->slip]);
    return NZ_OK;
  }
  double vt;
  if ((st = slip_velocity(c, s, j, t, q, qd, &vt))) return st;
  *g = (state == NZ_CONTACT_SLIP_POS ? vt : -vt) + c->offset[e];
  return NZ_OK;
}

int nz_contacts_kinematics(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                           double *out)
{
  for (int j = 0; j < c->n; j++) {
    double v[2], *o = out + 4 * j;
    int st = value_rate(c, s, c->def[j].gap, t, q, qd, v);
    o[2] = 0.0;
    if (!st && c->def[j].slip >= 0) st = slip_velocity(c, s, j, t, q, qd, &o[2]);
    if (!st) st = row(c, s, c->def[j].gap, t, q, qd);
    if (st) {
      fail_at(c, NZ_CONTACT_EVAL, st, j, t, q, qd);
      return st;
    }
    o[0] = v[0];
    o[1] = v[1];
    o[3] = abs_dot(c->k, row_of(c, c->def[j].gap), q);
  }
  clear_failure(c);
  return NZ_OK;
}

/* ------------------------------------------------------------------ */
/* The bilateral saddle point and the response to a force               */

/* K = [M -A_b^T; A_b 0], equilibrated, by pivoted QR; its condition.  M
 * itself first (Cholesky with its condition: a singular M is said as such,
 * not as dependent constraints). */
static int factor_bilateral(nz_contacts *c, double t, const double *q, const double *qd)
{
  int k = c->k, nb = c->nb, nk = k + nb;
  nz_solve_info info;
  double *Mw = c->S, *x = Mw + (size_t)k * (size_t)k;
  memcpy(Mw, c->M, (size_t)k * (size_t)k * sizeof(double));
  if (nz_solve_spd_in(k, Mw, c->h, x, c->rcond_min, &info, c->spd_work)) {
    fail_at(c, NZ_CONTACT_MASS, NZ_ESINGULAR, -1, t, q, qd);
    c->fail.value = info.rcond;
    return NZ_ESINGULAR;
  }
  double mmax = max_abs(k * k, c->M);
  if (!(mmax > 0.0)) mmax = 1.0;
  c->kscale[0] = 1.0 / mmax;
  gsl_matrix *K = c->K;                  /* (nk x nk, as allocated) */
  (void)nk;
  gsl_matrix_set_zero(K);
  for (int i = 0; i < k; i++)
    for (int l = 0; l < k; l++) gsl_matrix_set(K, (size_t)i, (size_t)l, c->M[(size_t)i * k + l] / mmax);
  for (int r = 0; r < nb; r++) {
    const double *A = row_of(c, r);
    double am = max_abs(k, A), sig = am > 0.0 ? 1.0 / am : 1.0;
    c->kscale[1 + r] = sig;
    for (int i = 0; i < k; i++) {
      gsl_matrix_set(K, (size_t)i, (size_t)(k + r), -A[i] * sig);
      gsl_matrix_set(K, (size_t)(k + r), (size_t)i, A[i] * sig);
    }
  }
  int signum;
  double rcond = 0.0;
  if (gsl_linalg_QRPT_decomp(K, c->tau, c->perm, &signum, c->norm) != GSL_SUCCESS ||
      gsl_linalg_QRPT_rcond(K, &rcond, c->kwork) != GSL_SUCCESS || !(rcond >= c->rcond_min)) {
    fail_at(c, NZ_CONTACT_SINGULAR, NZ_ESINGULAR, -1, t, q, qd);
    c->fail.value = rcond;
    return NZ_ESINGULAR;
  }
  return NZ_OK;
}

/* x (k): the first k entries of K^-1 [f; g] for a force f (k) and the
 * bilateral rows' right-hand side g (nb, NULL: 0). */
static void solve_bilateral(nz_contacts *c, const double *f, const double *g, double *x)
{
  int k = c->k, nb = c->nb;
  for (int i = 0; i < k; i++) gsl_vector_set(c->kb, (size_t)i, f[i] * c->kscale[0]);
  for (int r = 0; r < nb; r++) gsl_vector_set(c->kb, (size_t)(k + r), g ? g[r] * c->kscale[1 + r] : 0.0);
  gsl_linalg_QRPT_solve(c->K, c->tau, c->perm, c->kb, c->kx);
  for (int i = 0; i < k; i++) x[i] = gsl_vector_get(c->kx, (size_t)i);
}

/* a0: the accelerations under the bilateral constraints alone. */
static void free_accel(nz_contacts *c)
{
  int k = c->k;
  double *f = c->scr;
  for (int i = 0; i < k; i++) f[i] = -c->h[i];
  for (int r = 0; r < c->nb; r++) c->rhs[r] = -c->b[r];   /* (rhs: free between mode solves) */
  solve_bilateral(c, f, c->rhs, c->a0);
}

/* A sliding contact's normal effective mass J M^-1 W^T relative to the
 * frictionless J M^-1 J^T (both with the bilateral constraints held), from
 * the factored K. */
static double effective_mass(nz_contacts *c, int j, int sign)
{
  int k = c->k;
  const double *J = row_of(c, c->def[j].gap), *D = row_of(c, c->def[j].slip);
  double *W = c->F, *rw = c->scr, *rj = c->scr + k;
  for (int i = 0; i < k; i++) W[i] = J[i] - sign * c->def[j].mu * D[i];
  solve_bilateral(c, W, NULL, rw);
  solve_bilateral(c, J, NULL, rj);
  double ref = dot(k, J, rj);
  return ref > 0.0 ? dot(k, J, rw) / ref : dot(k, J, rw);
}

static int slip_sign(int state) { return state == NZ_CONTACT_SLIP_POS ? 1 : state == NZ_CONTACT_SLIP_NEG ? -1 : 0; }

/* The mode's matrix was singular: Painleve's paradox when a sliding contact
 * has lost its effective mass, else dependent contacts or constraints. */
static int diagnose_singular(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                             double rcond)
{
  fail_at(c, NZ_CONTACT_SINGULAR, NZ_ESINGULAR, -1, t, q, qd);
  c->fail.value = rcond;
  if (frame(c, s, t, q, qd) || factor_bilateral(c, t, q, qd)) {
    fail_at(c, NZ_CONTACT_SINGULAR, NZ_ESINGULAR, -1, t, q, qd);
    c->fail.value = rcond;
    return NZ_ESINGULAR;
  }
  free_accel(c);
  int worst = -1;
  double wm = INFINITY;
  for (int j = 0; j < c->n; j++) {
    int sg = slip_sign(c->mode[j]);
    if (!sg) continue;
    double m = effective_mass(c, j, sg);
    if (m < wm) wm = m, worst = j;
  }
  if (worst >= 0 && wm <= 1e-6) {
    fail_at(c, NZ_CONTACT_PAINLEVE, NZ_ESINGULAR, worst, t, q, qd);
    c->fail.value = wm;
    c->fail.an = dot(c->k, row_of(c, c->def[worst].gap), c->a0) + c->b[c->def[worst].gap];
    return NZ_ESINGULAR;
  }
  fail_at(c, NZ_CONTACT_SINGULAR, NZ_ESINGULAR, -1, t, q, qd);
  c->fail.value = rcond;
  return NZ_ESINGULAR;
}

/* ------------------------------------------------------------------ */
/* The LCPs                                                             */

enum { VAR_N, VAR_TPOS, VAR_TNEG, VAR_SIGMA };

/* The unknowns for the contacts in set[] (touching and taking part): a
 * normal one each, and with friction where cone[j] the three of the planar
 * cone (beta+, beta-, sigma).  Returns their number. */
static int lcp_unknowns(nz_contacts *c, const int *set, const int *cone)
{
  int nv = 0;
  for (int j = 0; j < c->n; j++) {
    int *at = c->var_at + 4 * j;
    at[0] = at[1] = at[2] = at[3] = -1;
    if (!set[j]) continue;
    c->var_c[nv] = j, c->var_kind[nv] = VAR_N, at[VAR_N] = nv++;
    if (c->def[j].slip >= 0 && cone[j])
      for (int kind = VAR_TPOS; kind <= VAR_SIGMA; kind++) c->var_c[nv] = j, c->var_kind[nv] = kind, at[kind] = nv++;
  }
  return nv;
}

/* Each unknown's response of q'' (or q') to a unit of it: K^-1 of its
 * force, J (or W for a sliding contact at the acceleration level), +D, -D,
 * none. */
static void lcp_responses(nz_contacts *c, int nv)
{
  int k = c->k;
  for (int v = 0; v < nv; v++) {
    int j = c->var_c[v], kind = c->var_kind[v];
    double *r = c->resp + (size_t)v * (size_t)k;
    if (kind == VAR_SIGMA) {
      memset(r, 0, (size_t)k * sizeof(double));
      continue;
    }
    const double *J = row_of(c, c->def[j].gap), *D = c->def[j].slip >= 0 ? row_of(c, c->def[j].slip) : NULL;
    int sg = kind == VAR_N ? (c->sliding[j]) : 0;
    for (int i = 0; i < k; i++)
      c->F[i] = kind == VAR_N ? J[i] - (sg ? sg * c->def[j].mu * D[i] : 0.0) : kind == VAR_TPOS ? D[i] : -D[i];
    solve_bilateral(c, c->F, NULL, r);
  }
}

/* The LCP's matrix and vector: row v is the complement of unknown v,
 * base_n[j] and base_t[j] the normal and tangential rows without forces
 * (velocities, or accelerations), mu[j] the cone's coefficient. */
static void lcp_assemble(nz_contacts *c, int nv, const double *base_n, const double *base_t, const double *mu)
{
  int k = c->k;
  for (int v = 0; v < nv; v++) {
    int j = c->var_c[v], kind = c->var_kind[v], *at = c->var_at + 4 * j;
    double *Lr = c->L + (size_t)v * (size_t)nv;
    const double *J = row_of(c, c->def[j].gap), *D = c->def[j].slip >= 0 ? row_of(c, c->def[j].slip) : NULL;
    memset(Lr, 0, (size_t)nv * sizeof(double));
    switch (kind) {
    case VAR_N:
      c->lq[v] = base_n[j];
      for (int u = 0; u < nv; u++) Lr[u] = dot(k, J, c->resp + (size_t)u * k);
      break;
    case VAR_TPOS:
    case VAR_TNEG: {
      double sg = kind == VAR_TPOS ? 1.0 : -1.0;
      c->lq[v] = sg * base_t[j];
      for (int u = 0; u < nv; u++) Lr[u] = sg * dot(k, D, c->resp + (size_t)u * k);
      Lr[at[VAR_SIGMA]] += 1.0;
      break;
    }
    case VAR_SIGMA:
      c->lq[v] = 0.0;
      Lr[at[VAR_N]] = mu[j];
      Lr[at[VAR_TPOS]] = -1.0;
      Lr[at[VAR_TNEG]] = -1.0;
      break;
    }
  }
}

static int lcp_run(nz_contacts *c, int nv, nz_contact_report *rep)
{
  nz_lcp_info info;
  int st = nz_lcp_solve(nv, c->L, c->lq, c->lz, c->lw, c->lwork, &info);
  if (rep) rep->lcp = info;
  return st;
}

static double zval(const nz_contacts *c, int j, int kind)
{
  int v = c->var_at[4 * j + kind];
  return v >= 0 ? c->lz[v] : 0.0;
}

/* ------------------------------------------------------------------ */
/* The transition                                                       */

/* Zeno: contact j closes at t with approach speed v.  Its last three
 * impacts and this one give two ratios of intervals; shrinking alike
 * (within 5 %) and slow against its fastest impact, the sequence would
 * accumulate at t + dt r / (1 - r): the impact is made plastic. */
static int zeno(nz_contacts *c, int j, double t, double v, double *tinf)
{
  double *ht = c->ht + 3 * j;
  int n = c->nh[j], hit = 0;
  if (n >= 3) {
    double d1 = ht[1] - ht[0], d2 = ht[2] - ht[1], d3 = t - ht[2];
    double r1 = d1 > 0.0 ? d2 / d1 : 2.0, r2 = d2 > 0.0 ? d3 / d2 : 2.0;
    if (r1 > 0.0 && r1 < 1.0 && r2 > 0.0 && r2 < 1.0 && fabs(r2 - r1) <= 0.05 * r2 && v <= c->zeno_speed * c->vmax[j]) {
      hit = 1;
      *tinf = t + d3 * r2 / (1.0 - r2);
    }
  }
  if (n == 3) {
    ht[0] = ht[1], ht[1] = ht[2];
    n = 2;
  }
  ht[n] = t;
  c->nh[j] = n + 1;
  return hit;
}

static int in_mode(int state) { return state != NZ_CONTACT_OPEN; }

/* Below this a normal or slip velocity v of row r at q' is zero: a
 * fraction NZ_CONTACT_REST of the motion's velocity scale there (the
 * larger of the fastest the contact has had, vmax, and |row|_1 max|q'_i|:
 * what the velocity would be were the motion along it), and rounding of
 * the row's explicit time dependence v - row . q'. */
static double rest_tol(const nz_contacts *c, int r, const double *qd, double vmax, double v)
{
  const double *A = row_of(c, r);
  double size = 0.0, qmax = 0.0;
  for (int i = 0; i < c->k; i++) size += fabs(A[i]), qmax = fmax(qmax, fabs(qd[i]));
  return NZ_CONTACT_REST * fmax(vmax, size * qmax) + NZ_CONTACT_ROUND * fabs(v - dot(c->k, A, qd));
}

/* x += the least change (in the metric of M, the bilateral constraints
 * held: K^-1) that brings the m rows rows[a] of x to the values target[a]
 * from value[a]: Delassus' matrix G = R K^-1 R^T, G nu = target - value,
 * by least squares (dependent rows are not an error here: the change is
 * the same).  The rows are gap rows (q) or normal and slip rows (q'). */
static void project_rows(nz_contacts *c, int m, const int *rows, const double *value, double *x)
{
  int k = c->k;
  if (m <= 0 || m > 2 * c->n) return;
  for (int a = 0; a < m; a++) solve_bilateral(c, row_of(c, rows[a]), NULL, c->resp + (size_t)a * k);
  for (int a = 0; a < m; a++) {
    for (int b = 0; b < m; b++) c->L[a * m + b] = dot(k, row_of(c, rows[a]), c->resp + (size_t)b * k);
    c->lq[a] = -value[a];
  }
  if (nz_lstsq(m, m, c->L, c->lq, c->lz)) return;
  for (int a = 0; a < m; a++)
    for (int i = 0; i < k; i++) x[i] += c->resp[(size_t)a * k + i] * c->lz[a];
}

/* The state put on what the new mode holds: the gaps of the contacts
 * held, and every touching gap below zero (the event's location leaves a
 * penetration of its tolerance, and a bounce must start at zero, or the
 * next landing is missed or found as deep), to zero; then the normal
 * velocities of the contacts held and the slip velocities of those that
 * stick, to zero.  One Newton step each: the corrections are of the
 * tolerances.  K must be factored at (t, q). */
static int project(nz_contacts *c, const nz_system *s, double t, double *q, double *qd)
{
  int n = c->n, m = 0, rows[2 * n];
  double value[2 * n];
  for (int j = 0; j < n; j++)
    if (in_mode(c->mode[j]) || (c->touch[j] && c->phi[j] < 0.0)) rows[m] = c->def[j].gap, value[m++] = c->phi[j];
  project_rows(c, m, rows, value, q);
  int st = frame(c, s, t, q, qd);
  if (st || (st = factor_bilateral(c, t, q, qd))) return st;
  m = 0;
  for (int j = 0; j < n; j++) {
    if (!in_mode(c->mode[j])) continue;
    rows[m] = c->def[j].gap, value[m++] = c->vn[j];
    if (c->mode[j] == NZ_CONTACT_STICK) rows[m] = c->def[j].slip, value[m++] = c->vt[j];
  }
  project_rows(c, m, rows, value, qd);
  return frame(c, s, t, q, qd);
}

int nz_contacts_transition(nz_contacts *c, const nz_system *s, double t, double *q, double *qd,
                           int trigger, nz_contact_report *rep)
{
  int k = c->k, n = c->n, st;
  clear_failure(c);
  nz_contact_report local;
  if (!rep) rep = &local, memset(rep, 0, sizeof local);
  rep->impact = rep->changed = 0;
  rep->zeno_contact = -1;
  rep->zeno_time = 0.0;
  memset(&rep->lcp, 0, sizeof rep->lcp);
  memcpy(c->mode0, c->mode, (size_t)n * sizeof(int));
  int tj = trigger >= 0 ? trigger / 2 : -1, tfric = trigger >= 0 ? trigger % 2 : 0;
  if ((st = frame(c, s, t, q, qd))) return st;
  double tscale = NZ_CONTACT_TOUCH_TIME * fmax(1.0, fabs(t));
  double base_n[n], base_t[n], mu[n];
  for (int j = 0; j < n; j++) {
    const double *J = row_of(c, c->def[j].gap);
    double tol = tscale * fmax(0.0, -c->vn[j]) + NZ_CONTACT_ROUND * abs_dot(k, J, q);
    double g = max_abs(k, J);
    c->gmax[j] = fmax(c->gmax[j], g);
    c->touch[j] = in_mode(c->mode[j]) || c->phi[j] <= tol || (j == tj && !tfric);
    if (!c->touch[j]) continue;
    /* A gap whose gradient vanishes where it touches (q^3: a root of
     * multiplicity 3) has no normal there, and its impacts are located
     * only to the cube root of the rounding: zero, or a vanishing fraction
     * of the largest it has had in this run, is refused. */
    if (!(g > NZ_CONTACT_FLAT * c->gmax[j])) {
      fail_at(c, NZ_CONTACT_GRADIENT, NZ_EARG, j, t, q, qd);
      c->fail.value = c->gmax[j] > 0.0 ? g / c->gmax[j] : 0.0;
      return NZ_EARG;
    }
    c->vmax[j] = fmax(c->vmax[j], fabs(c->vn[j]));
    if (c->def[j].slip >= 0) c->vtmax[j] = fmax(c->vtmax[j], fabs(c->vt[j]));
  }
  if ((st = factor_bilateral(c, t, q, qd))) return st;
  /* the impact: every touching contact at once, the approaching ones with
   * Newton's law (plastic where Zeno says so) */
  int nappr = 0;
  for (int j = 0; j < n; j++) {
    double tol = rest_tol(c, c->def[j].gap, qd, c->vmax[j], c->vn[j]);
    /* an open contact closes with an impact; one held already only drifts
     * (its normal velocity is set back to zero by the projection) */
    c->appr[j] = c->touch[j] && !in_mode(c->mode0[j]) && c->vn[j] < -tol;
    c->e_eff[j] = c->def[j].e;
    c->sliding[j] = 0;
    if (rep->c) {
      memset(&rep->c[j], 0, sizeof rep->c[j]);
      rep->c[j].from = c->mode0[j];
      rep->c[j].gap = c->phi[j];
      rep->c[j].vn_before = c->vn[j];
      rep->c[j].vt_before = c->vt[j];
    }
    if (!c->appr[j]) continue;
    nappr++;
    double tinf;
    if (zeno(c, j, t, -c->vn[j], &tinf)) {
      c->e_eff[j] = 0.0;
      rep->zeno_contact = j;
      rep->zeno_time = tinf;
      if (rep->c) rep->c[j].zeno = 1;
    }
    if (rep->c) rep->c[j].impact = 1;
  }
  if (nappr) {
    int cone[n];
    for (int j = 0; j < n; j++) {
      cone[j] = 1;
      base_n[j] = c->vn[j] + (c->appr[j] ? c->e_eff[j] * c->vn[j] : 0.0);
      base_t[j] = c->vt[j];
      mu[j] = c->def[j].mu;
    }
    int nv = lcp_unknowns(c, c->touch, cone);
    lcp_responses(c, nv);
    lcp_assemble(c, nv, base_n, base_t, mu);
    if ((st = lcp_run(c, nv, rep))) {
      fail_at(c, NZ_CONTACT_LCP, st, tj, t, q, qd);
      return st;
    }
    for (int v = 0; v < nv; v++)
      for (int i = 0; i < k; i++) qd[i] += c->resp[(size_t)v * k + i] * c->lz[v];
    rep->impact = 1;
    for (int j = 0; j < n; j++)
      if (c->touch[j] && rep->c) {
        rep->c[j].Pn = zval(c, j, VAR_N);
        rep->c[j].Pt = zval(c, j, VAR_TPOS) - zval(c, j, VAR_TNEG);
      }
    /* h and the rests at the new velocities (M, and so K, stay) */
    if ((st = frame(c, s, t, q, qd)) || (st = factor_bilateral(c, t, q, qd))) return st;
  }
  free_accel(c);
  /* the new mode: the LCP at the acceleration level for the touching
   * contacts at rest (normal velocity zero) */
  int rest[n], cone[n], any = 0;
  for (int j = 0; j < n; j++) {
    const double *J = row_of(c, c->def[j].gap);
    double tol = rest_tol(c, c->def[j].gap, qd, c->vmax[j], c->vn[j]);
    rest[j] = c->touch[j] && c->vn[j] <= tol;
    cone[j] = 0;
    c->sliding[j] = 0;
    if (!rest[j]) continue;
    any = 1;
    if (c->def[j].slip >= 0) {
      if (fabs(c->vt[j]) <= rest_tol(c, c->def[j].slip, qd, c->vtmax[j], c->vt[j])) cone[j] = 1;
      else c->sliding[j] = c->vt[j] > 0.0 ? 1 : -1;
    }
    base_n[j] = dot(k, J, c->a0) + c->b[c->def[j].gap];
    if (c->def[j].slip >= 0) base_t[j] = dot(k, row_of(c, c->def[j].slip), c->a0) + c->b[c->def[j].slip];
    mu[j] = c->def[j].mu_s;
  }
  int newmode[n];
  for (int j = 0; j < n; j++) newmode[j] = NZ_CONTACT_OPEN;
  if (any) {
    for (int j = 0; j < n; j++) {          /* Painleve: a sliding contact's effective mass */
      if (!rest[j] || !c->sliding[j]) continue;
      double m = effective_mass(c, j, c->sliding[j]);
      if (m <= 1e-9) {
        fail_at(c, NZ_CONTACT_PAINLEVE, NZ_EARG, j, t, q, qd);
        c->fail.value = m;
        c->fail.an = base_n[j];
        return NZ_EARG;
      }
    }
    int nv = lcp_unknowns(c, rest, cone);
    lcp_responses(c, nv);
    lcp_assemble(c, nv, base_n, base_t, mu);
    if ((st = lcp_run(c, nv, rep))) {
      int j = -1;
      for (int x = 0; x < n && j < 0; x++)
        if (rest[x] && c->sliding[x]) j = x;
      fail_at(c, j >= 0 ? NZ_CONTACT_PAINLEVE : NZ_CONTACT_LCP, st, j >= 0 ? j : tj, t, q, qd);
      if (j >= 0) c->fail.value = effective_mass(c, j, c->sliding[j]), c->fail.an = base_n[j];
      return NZ_EARG;
    }
    for (int j = 0; j < n; j++) {
      if (!rest[j] || !(zval(c, j, VAR_N) > 0.0)) continue;
      if (c->def[j].slip < 0) newmode[j] = NZ_CONTACT_CLOSED;
      else if (c->sliding[j]) newmode[j] = c->sliding[j] > 0 ? NZ_CONTACT_SLIP_POS : NZ_CONTACT_SLIP_NEG;
      else if (zval(c, j, VAR_SIGMA) > 0.0)  /* the cone is saturated: it slides, against the friction force */
        newmode[j] = zval(c, j, VAR_TPOS) > zval(c, j, VAR_TNEG) ? NZ_CONTACT_SLIP_NEG : NZ_CONTACT_SLIP_POS;
      else newmode[j] = NZ_CONTACT_STICK;
    }
  }
  memcpy(c->mode, newmode, (size_t)n * sizeof(int));
  c->cvalid = 0;
  /* an event must change something: a force that reached zero opens its
   * contact, a friction force that reached the cone slides (the LCP, at
   * the very state where both are zero, may keep the mode by a rounding) */
  if (!rep->impact && tj >= 0 && !memcmp(c->mode, c->mode0, (size_t)n * sizeof(int))) {
    if (!tfric && in_mode(c->mode0[tj])) c->mode[tj] = NZ_CONTACT_OPEN;
    else if (tfric && c->mode0[tj] == NZ_CONTACT_STICK) {
      if ((st = nz_contacts_accel(c, s, t, q, qd, NULL, NULL))) return st;
      c->mode[tj] = c->clam[c->def[tj].slip] > 0.0 ? NZ_CONTACT_SLIP_NEG : NZ_CONTACT_SLIP_POS;
      c->cvalid = 0;
    }
  }
  if ((st = project(c, s, t, q, qd)) || (st = nz_contacts_accel(c, s, t, q, qd, NULL, NULL))) return st;
  /* The events' offsets (nz_contacts_event): a gap left open at zero (a
   * bounce, a lift-off) starts at least a rounding above zero, and so does
   * the slip velocity of a contact set sliding from rest: shifted by the
   * penetration the event's location left, so that it falls through zero
   * only where the motion comes back, even within one long step. */
  for (int j = 0; j < n; j++) {
    c->offset[2 * j] = c->offset[2 * j + 1] = 0.0;
    if (c->mode[j] == NZ_CONTACT_OPEN && c->touch[j])
      c->offset[2 * j] = fmax(0.0, -c->phi[j]) + 16 * DBL_EPSILON * abs_dot(k, row_of(c, c->def[j].gap), q) + DBL_MIN;
    int sg = slip_sign(c->mode[j]);
    if (sg && sg != slip_sign(c->mode0[j]))
      c->offset[2 * j + 1] = fmax(0.0, -sg * c->vt[j]) +
                             16 * DBL_EPSILON * abs_dot(k, row_of(c, c->def[j].slip), qd) + DBL_MIN;
    if (c->mode[j] != c->mode0[j]) rep->changed = 1;
    if (!in_mode(c->mode[j]) && in_mode(c->mode0[j])) c->nh[j] = 0;   /* lifted off: a new run of impacts */
    if (rep->c) {
      rep->c[j].to = c->mode[j];
      rep->c[j].vn_after = c->vn[j];
      rep->c[j].vt_after = c->vt[j];
      rep->c[j].lambda_n = c->clam[c->def[j].gap];
      rep->c[j].lambda_t = c->def[j].slip >= 0 ? c->clam[c->def[j].slip] : 0.0;
    }
  }
  return NZ_OK;
}
