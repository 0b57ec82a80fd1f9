/* contact.c - unilateral contacts, impacts and Coulomb friction (see
 * contact.h; the equations are docs/theory.md §13): the object, the frame
 * of a state, the mode's motion and its events.  The transition, the LCPs
 * and the sharing of dependent contacts' forces are in the files
 * contact_impl.h lists.
 *
 * The mode's motion (mode_solve), per right-hand side of the integrator:
 * the saddle point of its carriers (an independent subset of the rows it
 * holds, contact_share.c) by its Schur complement, M's Cholesky factor and
 * Delassus' small matrix by LU; where rows held are dependent, the forces
 * then shared among them by least norm. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <gsl/gsl_errno.h>
#include "mech/constrained.h"
#include "mech/contact_impl.h"

/* ------------------------------------------------------------------ */
/* Making and configuring                                               */

void nz_contacts_free(nz_contacts *c)
{
  if (!c) return;
  free(c->def);
  free(c->mode);
  free(c->M);
  nz_motion_free(&c->mo);
  nz_motion_free(&c->mo_row);
  nz_lu_free(c->lu);
  nz_lstsq_free(c->ls);
  if (c->K) gsl_matrix_free(c->K);
  if (c->tau) gsl_vector_free(c->tau);
  if (c->norm) gsl_vector_free(c->norm);
  if (c->kwork) gsl_vector_free(c->kwork);
  if (c->kb) gsl_vector_free(c->kb);
  if (c->kx) gsl_vector_free(c->kx);
  if (c->perm) gsl_permutation_free(c->perm);
  free(c);
}

/* The next n entries of a block from *at (counting only when base is NULL):
 * nz_contacts_new lays its arrays out twice, once to size the block. */
static double *take_d(double *base, size_t *at, size_t n)
{
  double *p = base ? base + *at : NULL;
  *at += n;
  return p;
}

static int *take_i(int *base, size_t *at, size_t n)
{
  int *p = base ? base + *at : NULL;
  *at += n;
  return p;
}

/* The arrays of c in the blocks d and iw (NULL: only their sizes). */
static void lay_out(nz_contacts *c, double *d, int *iw, size_t *nd, size_t *ni)
{
  size_t K = (size_t)c->k, C = (size_t)c->nc, N = (size_t)c->n, V = NZ_CONTACT_UNKNOWNS * N, T = 3 * N;
  size_t at = 0;
  c->dir = take_d(d, &at, 2 * N), c->offset = take_d(d, &at, 2 * N), c->ht = take_d(d, &at, 3 * N);
  c->vmax = take_d(d, &at, N), c->vtmax = take_d(d, &at, N), c->gmax = take_d(d, &at, N);
  c->phi = take_d(d, &at, N), c->vn = take_d(d, &at, N);
  c->vt = take_d(d, &at, 2 * N), c->e_eff = take_d(d, &at, N), c->base_n = take_d(d, &at, N);
  c->base_t = take_d(d, &at, 2 * N), c->mu_lcp = take_d(d, &at, N), c->turn = take_d(d, &at, N);
  c->sol_n = take_d(d, &at, N), c->sol_t = take_d(d, &at, 2 * N), c->sol_sig = take_d(d, &at, N);
  c->sol_w = take_d(d, &at, N), c->sol_dx = take_d(d, &at, K);
  c->gdir = take_d(d, &at, 2 * NZ_CONTACT_FACETS * N);
  c->h = take_d(d, &at, K), c->zero = take_d(d, &at, K), c->a0 = take_d(d, &at, K);
  c->A = take_d(d, &at, C * K), c->b = take_d(d, &at, C), c->coef = take_d(d, &at, C);
  /* the mode solve: X (k (nc + 1)), M's factor (k k), G and its inverse (nc nc each), lambda (nc) */
  c->S = take_d(d, &at, K * (C + 1) + K * K + 2 * C * C + C), c->W = take_d(d, &at, C * K);
  c->spd_work = take_d(d, &at, nz_solve_spd_work_len(c->k));
  c->cy = take_d(d, &at, 2 * K), c->cqdd = take_d(d, &at, K), c->clam = take_d(d, &at, C);
  c->F = take_d(d, &at, K), c->scr = take_d(d, &at, 3 * K);
  c->share_C = take_d(d, &at, K * T), c->share_x = take_d(d, &at, T), c->share_F = take_d(d, &at, K);
  c->tcoup = take_d(d, &at, 2 * N), c->share_N = take_d(d, &at, N), c->share_T = take_d(d, &at, 2 * N);
  c->dep_y = take_d(d, &at, C * K), c->dep_L = take_d(d, &at, C * C), c->frame_qd = take_d(d, &at, K);
  c->resp = take_d(d, &at, V * K), c->L = take_d(d, &at, V * V), c->lq = take_d(d, &at, V);
  c->lz = take_d(d, &at, V), c->lw = take_d(d, &at, V), c->lwork = take_d(d, &at, nz_lcp_work_len((int)V));
  c->kscale = take_d(d, &at, 1 + (size_t)c->nb), c->fq = take_d(d, &at, 2 * K);
  *nd = at;
  at = 0;
  c->mode = take_i(iw, &at, N), c->share = take_i(iw, &at, N), c->atcone = take_i(iw, &at, N);
  c->nh = take_i(iw, &at, N), c->ngen = take_i(iw, &at, N), c->touch = take_i(iw, &at, N);
  c->sliding = take_i(iw, &at, N), c->appr = take_i(iw, &at, N), c->mode0 = take_i(iw, &at, N);
  c->rest = take_i(iw, &at, N), c->cone = take_i(iw, &at, N), c->newmode = take_i(iw, &at, N);
  c->share0 = take_i(iw, &at, N), c->atcone0 = take_i(iw, &at, N);
  c->part = take_i(iw, &at, N), c->tfree = take_i(iw, &at, N);
  c->rows = take_i(iw, &at, C), c->couple = take_i(iw, &at, C), c->cj = take_i(iw, &at, C);
  c->ckind = take_i(iw, &at, C), c->orders = take_i(iw, &at, C);
  c->var_c = take_i(iw, &at, V), c->var_kind = take_i(iw, &at, V), c->var_at = take_i(iw, &at, 3 * N);
  *ni = at;
}

static int valid_config(int k, const nz_contacts_config *cfg)
{
  int nc = cfg->nc, nb = cfg->nb, n = cfg->n;
  if (k < 1 || n < 1 || nb < 0 || nb > nc || !cfg->orders || !cfg->defs) return 0;
  for (int r = 0; r < nb; r++)
    if (cfg->orders[r] < 0 || cfg->orders[r] > 1) return 0;
  for (int j = 0; j < n; j++) {
    const nz_contact_def *d = &cfg->defs[j];
    if (d->gap < nb || d->gap >= nc || cfg->orders[d->gap] != 0) return 0;
    if (d->slip >= 0 && (d->slip < nb || d->slip >= nc || d->slip == d->gap || cfg->orders[d->slip] > 1)) return 0;
    if (d->slip2 >= 0 || d->speed >= 0) {   /* an isotropic cone: its slips and speed are velocities */
      if (d->slip < 0 || d->slip2 < nb || d->slip2 >= nc || d->speed < nb || d->speed >= nc) return 0;
      if (cfg->orders[d->slip] != 1 || cfg->orders[d->slip2] != 1 || cfg->orders[d->speed] != 1) return 0;
      if (d->slip2 == d->slip || d->slip2 == d->gap || d->speed == d->gap) return 0;
    }
    if (!(d->e >= 0.0 && d->e <= 1.0) || !(d->mu >= 0.0) || !(d->mu_s >= d->mu) || !isfinite(d->mu_s)) return 0;
    if (d->slip < 0 && d->mu > 0.0) return 0;
  }
  return 1;
}

nz_contacts *nz_contacts_new(int k, const nz_contacts_config *cfg)
{
  if (!valid_config(k, cfg)) return NULL;
  nz_contacts *c = calloc(1, sizeof *c);
  if (!c) return NULL;
  c->k = k, c->nc = cfg->nc, c->nb = cfg->nb, c->n = cfg->n;
  c->zeno_speed = cfg->zeno_speed > 0.0 ? cfg->zeno_speed : NZ_CONTACT_ZENO_SPEED;
  c->rcond_min = cfg->rcond_min > 0.0 ? cfg->rcond_min : NZ_RCOND_MIN;
  c->rtol = fmax(cfg->rtol, 0.0), c->atol = fmax(cfg->atol, 0.0);
  size_t nd, ni, NK = (size_t)k + (size_t)c->nb;
  lay_out(c, NULL, NULL, &nd, &ni);
  double *d = calloc(nd + (size_t)k * (size_t)k, sizeof(double));   /* M first, then the laid-out arrays */
  int *iw = calloc(ni, sizeof(int));
  c->def = malloc((size_t)c->n * sizeof *c->def);
  c->M = d;
  c->mode = iw;                              /* (owners of the blocks until lay_out) */
  int lscap = k > 3 * c->n ? k : 3 * c->n;
  c->lu = nz_lu_new(c->nc);
  c->ls = nz_lstsq_new(lscap);
  c->K = gsl_matrix_alloc(NK, NK);
  c->tau = gsl_vector_alloc(NK);
  c->norm = gsl_vector_alloc(NK);
  c->kwork = gsl_vector_alloc(3 * NK);
  c->kb = gsl_vector_alloc(NK);
  c->kx = gsl_vector_alloc(NK);
  c->perm = gsl_permutation_alloc(NK);
  if (!d || !iw || !c->def || !c->lu || !c->ls || !c->K || !c->tau || !c->norm || !c->kwork || !c->kb || !c->kx ||
      !c->perm) {
    nz_contacts_free(c);
    return NULL;
  }
  lay_out(c, d + (size_t)k * (size_t)k, iw, &nd, &ni);
  memcpy(c->orders, cfg->orders, (size_t)c->nc * sizeof(int));
  memcpy(c->def, cfg->defs, (size_t)c->n * sizeof *c->def);
  c->fail.q = c->fq;
  c->fail.qd = c->fq + k;
  for (int j = 0; j < c->n; j++) c->share[j] = 1, c->dir[2 * j] = 1.0;
  nz_c_carriers_all(c);
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
  switch (st) {
  case NZ_CONTACT_OPEN: return 1;
  case NZ_CONTACT_CLOSED: return d->slip < 0;
  case NZ_CONTACT_STICK: return d->slip >= 0;
  case NZ_CONTACT_SLIP_POS:
  case NZ_CONTACT_SLIP_NEG: return d->slip >= 0 && !nz_c_iso(d);
  case NZ_CONTACT_SLIP: return nz_c_iso(d);
  default: return 0;
  }
}

int nz_contacts_set_mode(nz_contacts *c, const int *state)
{
  for (int j = 0; j < c->n; j++)
    if (!allowed(&c->def[j], state[j])) return NZ_EARG;
  memcpy(c->mode, state, (size_t)c->n * sizeof(int));
  memset(c->offset, 0, 2 * (size_t)c->n * sizeof(double));
  for (int j = 0; j < c->n; j++) c->share[j] = 1, c->atcone[j] = 0, c->dir[2 * j] = 1.0, c->dir[2 * j + 1] = 0.0;
  nz_c_carriers_all(c);
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

void nz_c_fail_at(nz_contacts *c, nz_contact_failure kind, int status, int contact, double t, const double *q,
                  const double *qd)
{
  c->fail.kind = kind;
  c->fail.status = status;
  c->fail.contact = contact;
  c->fail.t = t;
  memcpy(c->fq, q, (size_t)c->k * sizeof(double));
  memcpy(c->fq + c->k, qd, (size_t)c->k * sizeof(double));
}

void nz_c_clear_failure(nz_contacts *c)
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
 * order 0, the slip velocity.  (Its own workspace: the rows' jets have
 * another shape, and one workspace for both would be made again at every
 * call.) */
static int value_rate(nz_contacts *c, const nz_system *s, int r, double t, const double *q, const double *qd,
                      double out[2])
{
  const double *state[3] = { q, qd, c->zero };
  nz_constraint_seeding sd = { .K = 1 };   /* the series of Phi to order 1, no tangents */
  int st = nz_constraint_eval(s, r, &c->mo, t, state, 3, &sd);
  if (!st) {
    out[0] = c->mo.out[0]->c[0];
    out[1] = c->mo.out[0]->c[1];
  }
  return st;
}

int nz_c_slip_velocities(nz_contacts *c, const nz_system *s, int j, double t, const double *q, const double *qd,
                         double *vt)
{
  const nz_contact_def *d = &c->def[j];
  int st = NZ_OK;
  for (int i = 0; i < nz_c_ntan(d) && !st; i++) {
    double v[2];
    int r = nz_c_tan_row(d, i);
    if (!(st = value_rate(c, s, r, t, q, qd, v))) vt[i] = c->orders[r] == 1 ? v[0] : v[1];
  }
  return st;
}

/* Row r at the acceleration level into A[r], b[r]: A q'' + b = Phi^(2-m). */
int nz_c_row_at(nz_contacts *c, const nz_system *s, int r, double t, const double *q, const double *qd)
{
  const double *state[3] = { q, qd, c->zero };
  return nz_constraint_row_in(s, &c->mo_row, r, c->orders[r], t, state, 3, c->A + (size_t)r * (size_t)c->k,
                              &c->b[r]);
}

/* Everything a transition reads at (t, q, q'): M, h, the bilateral rows,
 * and every contact's gap, normal velocity, slip velocities and rows. */
int nz_c_frame(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd)
{
  memcpy(c->frame_qd, qd, (size_t)c->k * sizeof(double));
  int st = nz_mass_bias(s, t, q, qd, c->M, c->h);
  for (int r = 0; r < c->nb && !st; r++) st = nz_c_row_at(c, s, r, t, q, qd);
  for (int j = 0; j < c->n && !st; j++) {
    double v[2];
    const nz_contact_def *d = &c->def[j];
    if (!(st = value_rate(c, s, d->gap, t, q, qd, v)) && !(st = nz_c_row_at(c, s, d->gap, t, q, qd))) {
      c->phi[j] = v[0];
      c->vn[j] = v[1];
      c->vt[2 * j] = c->vt[2 * j + 1] = 0.0;
      if (!(st = nz_c_slip_velocities(c, s, j, t, q, qd, c->vt + 2 * j)))
        for (int i = 0; i < nz_c_ntan(d) && !st; i++) st = nz_c_row_at(c, s, nz_c_tan_row(d, i), t, q, qd);
    }
  }
  if (st) nz_c_fail_at(c, NZ_CONTACT_EVAL, st, -1, t, q, qd);
  return st;
}

/* Below this a normal or slip velocity v of row r at q' is zero: a
 * fraction NZ_CONTACT_REST of the motion's velocity scale there (the
 * larger of the fastest the contact has had, vmax, and |row|_1 max|q'_i|:
 * what the velocity would be were the motion along it), and rounding of
 * the row's explicit time dependence v - row . q'. */
double nz_c_rest_tol(const nz_contacts *c, int r, const double *qd, double vmax, double v)
{
  const double *A = nz_c_row(c, r);
  double size = 0.0, qmax = 0.0;
  for (int i = 0; i < c->k; i++) size += fabs(A[i]), qmax = fmax(qmax, fabs(qd[i]));
  return NZ_CONTACT_REST * fmax(vmax, size * qmax) + NZ_CONTACT_ROUND * fabs(v - nz_c_dot(c->k, A, qd));
}

void nz_c_slide_dir(const nz_contacts *c, int j, const double *vt, const double *qd, double *u)
{
  const nz_contact_def *d = &c->def[j];
  const double *u0 = c->dir + 2 * j;
  double speed = hypot(vt[0], vt[1]);
  double tol = fmax(nz_c_rest_tol(c, d->slip, qd, c->vtmax[j], vt[0]), nz_c_rest_tol(c, d->slip2, qd, c->vtmax[j], vt[1]));
  if (!(speed > tol)) {
    u[0] = u0[0], u[1] = u0[1];
    return;
  }
  double sg = vt[0] * u0[0] + vt[1] * u0[1] < 0.0 ? -1.0 : 1.0;
  u[0] = sg * vt[0] / speed, u[1] = sg * vt[1] / speed;
}

void nz_c_slide_force(const nz_contacts *c, int j, int state, const double *vt, const double *qd, double *f)
{
  const nz_contact_def *d = &c->def[j];
  int k = c->k;
  const double *D = nz_c_row(c, d->slip);
  if (state != NZ_CONTACT_SLIP) {
    double sg = nz_c_slip_sign(state);
    for (int i = 0; i < k; i++) f[i] = -d->mu * sg * D[i];
    return;
  }
  const double *D2 = nz_c_row(c, d->slip2);
  double u[2];
  nz_c_slide_dir(c, j, vt, qd, u);
  for (int i = 0; i < k; i++) f[i] = -d->mu * (u[0] * D[i] + u[1] * D2[i]);
}

/* ------------------------------------------------------------------ */
/* The mode's motion                                                    */

int nz_contacts_active(nz_contacts *c, int *rows, int *couple, double *coef)
{
  for (int a = 0; a < c->na; a++) {
    rows[a] = c->rows[a];
    couple[a] = c->couple[a];
    coef[a] = c->coef[a];
    if (c->iso_rest && c->ckind[a] == NZ_CARRY_SLIDE_ISO) {
      nz_c_fail_at(c, NZ_CONTACT_SERIES, NZ_EARG, c->cj[a], c->ct, c->cy, c->cy + c->k);
      return -1;
    }
  }
  return c->na;
}

/* The gradient of the mode's row r vanished: the contact it belongs to. */
static int contact_of_row(const nz_contacts *c, int r)
{
  for (int j = 0; j < c->n; j++) {
    const nz_contact_def *d = &c->def[j];
    if (d->gap == r || d->slip == r || d->slip2 == r) return j;
  }
  return -1;
}

/* The carriers' rows and slip velocities at (t, q, q'), and each carrier's
 * force column W_a (c->W): its row, with a sliding contact's friction. */
static int carrier_columns(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd)
{
  int k = c->k, st = NZ_OK;
  c->iso_rest = 0;
  for (int a = 0; a < c->na && !st; a++) {
    int j = c->cj[a];
    double *W = c->W + (size_t)a * (size_t)k;
    if ((st = nz_c_row_at(c, s, c->rows[a], t, q, qd))) break;
    memcpy(W, nz_c_row(c, c->rows[a]), (size_t)k * sizeof(double));
    if (c->ckind[a] == NZ_CARRY_PLAIN) continue;
    const nz_contact_def *d = &c->def[j];
    for (int i = 0; i < nz_c_ntan(d) && !st; i++) st = nz_c_row_at(c, s, nz_c_tan_row(d, i), t, q, qd);
    if (!st && c->ckind[a] == NZ_CARRY_SLIDE_ISO) st = nz_c_slip_velocities(c, s, j, t, q, qd, c->vt + 2 * j);
    if (st) break;
    double *f = c->scr;
    nz_c_slide_force(c, j, c->mode[j], c->vt + 2 * j, qd, f);
    for (int i = 0; i < k; i++) W[i] += f[i];
    if (c->ckind[a] == NZ_CARRY_SLIDE_ISO &&
        !(hypot(c->vt[2 * j], c->vt[2 * j + 1]) > nz_c_rest_tol(c, d->slip, qd, c->vtmax[j], c->vt[2 * j])))
      c->iso_rest = 1;
  }
  return st;
}

/* Delassus' matrix G (na x na) of the carriers from X = M^-1 [h, W^T]
 * (each row scaled by its own effective mass R M^-1 R^T > 0: a plain row's
 * diagonal is then 1, a sliding one's the ratio J M^-1 W^T / J M^-1 J^T
 * that Painleve's paradox makes vanish, so that a lone sliding row whose
 * ratio reaches zero is singular too) and its right-hand side in lam; its
 * reciprocal condition in the 1-norm from the inverse (na is a few), or 0
 * when LU finds a zero pivot. */
static double delassus(nz_contacts *c, const double *X, const double *Mw, double *G, double *Gi, double *lam)
{
  int k = c->k, na = c->na;
  for (int a = 0; a < na; a++) {
    const double *R = nz_c_row(c, c->rows[a]);
    double ref;
    if (c->ckind[a] == NZ_CARRY_PLAIN) ref = nz_c_dot(k, R, X + (size_t)k * (size_t)(a + 1));   /* W_a = R_a */
    else {
      double *y = c->scr;
      memcpy(y, R, (size_t)k * sizeof(double));
      nz_cholesky_solve(k, Mw, y);
      ref = nz_c_dot(k, R, y);
    }
    double sc = ref > 0.0 ? 1.0 / ref : 1.0;
    for (int x = 0; x < na; x++) G[a * na + x] = nz_c_dot(k, R, X + (size_t)k * (size_t)(x + 1)) * sc;
    lam[a] = (nz_c_dot(k, R, X) - c->b[c->rows[a]]) * sc;
  }
  double gnorm = 0.0, inorm = 0.0;
  for (int x = 0; x < na; x++) {
    double col = 0.0;
    for (int a = 0; a < na; a++) col += fabs(G[a * na + x]);
    gnorm = fmax(gnorm, col);
  }
  if (nz_lu_factor(c->lu, na, G)) return 0.0;
  for (int x = 0; x < na; x++) {
    double *e = Gi + (size_t)x * na;
    for (int a = 0; a < na; a++) e[a] = a == x;
    nz_lu_solve(c->lu, e);
    double col = 0.0;
    for (int a = 0; a < na; a++) col += fabs(e[a]);
    inorm = fmax(inorm, col);
  }
  /* against the rows' own size 1, not only the matrix's norm */
  return 1.0 / (fmax(gnorm, 1.0) * inorm);
}

/* The contacts' forces from the carriers' multipliers lam: each normal
 * force at its gap's index, the friction at its slips'. */
static void carrier_forces(nz_contacts *c, const double *lam, const double *qd)
{
  memset(c->clam, 0, (size_t)c->nc * sizeof(double));
  for (int a = 0; a < c->na; a++) {
    int j = c->cj[a];
    c->clam[c->rows[a]] = lam[a];
    if (c->ckind[a] == NZ_CARRY_SLIDE) c->clam[c->def[j].slip] = c->coef[a] * lam[a];
    if (c->ckind[a] == NZ_CARRY_SLIDE_ISO) {
      double u[2];
      nz_c_slide_dir(c, j, c->vt + 2 * j, qd, u);
      c->clam[c->def[j].slip] = -c->def[j].mu * u[0] * lam[a];
      c->clam[c->def[j].slip2] = -c->def[j].mu * u[1] * lam[a];
    }
  }
}

/* The mode's saddle point M q'' + h = W^T lambda, R q'' + b = 0 on its
 * carriers by its Schur complement: with M's Cholesky factor (its condition
 * estimated, core/linalg.h), Delassus' matrix G = R M^-1 W^T and G lambda
 * = R M^-1 h - b, then q'' = M^-1 (W^T lambda - h).  Below rcond_min the
 * mode is singular (Painleve: a sliding contact's J M^-1 W^T reaching zero;
 * or carriers that became dependent).  No allocation: one right-hand side
 * costs a Cholesky of M, na + 1 solves with it and an na x na LU. */
static int mode_solve(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd)
{
  int k = c->k, na = c->na;
  int st = nz_mass_bias(s, t, q, qd, c->M, c->h);
  if (!st) st = carrier_columns(c, s, t, q, qd);
  if (st) {
    nz_c_fail_at(c, NZ_CONTACT_EVAL, st, -1, t, q, qd);
    return st;
  }
  /* X = M^-1 [h, W_1^T, .., W_na^T] from one factorization */
  double *X = c->S, *Mw = X + (size_t)k * (size_t)(na + 1), *G = Mw + (size_t)k * (size_t)k, *Gi = G + (size_t)na * na;
  double *lam = Gi + (size_t)na * na;
  memcpy(Mw, c->M, (size_t)k * (size_t)k * sizeof(double));
  nz_solve_info info;
  if ((st = nz_solve_spd_in(k, Mw, c->h, X, c->rcond_min, &info, c->spd_work))) {
    nz_c_fail_at(c, NZ_CONTACT_MASS, st, -1, t, q, qd);
    c->fail.value = info.rcond;
    return st;
  }
  for (int a = 0; a < na; a++) {
    double *xa = X + (size_t)k * (size_t)(a + 1);
    if (!(nz_c_max_abs(k, nz_c_row(c, c->rows[a])) > 0.0)) {   /* a gap (or a slip, a constraint) without a gradient here */
      nz_c_fail_at(c, NZ_CONTACT_GRADIENT, NZ_EARG, contact_of_row(c, c->rows[a]), t, q, qd);
      return NZ_EARG;
    }
    memcpy(xa, c->W + (size_t)a * (size_t)k, (size_t)k * sizeof(double));
    nz_cholesky_solve(k, Mw, xa);
  }
  if (na > 0) {
    double rcond = delassus(c, X, Mw, G, Gi, lam);
    if (!(rcond >= c->rcond_min)) return nz_c_diagnose_singular(c, s, t, q, qd, rcond);
    nz_lu_solve(c->lu, lam);
  }
  /* q'' = M^-1 (W^T lambda - h) = sum_a lambda_a X_a - X_0 */
  for (int i = 0; i < k; i++) {
    double v = -X[i];
    for (int a = 0; a < na; a++) v += lam[a] * X[(size_t)k * (size_t)(a + 1) + i];
    if (!isfinite(v)) return nz_c_diagnose_singular(c, s, t, q, qd, 0.0);
    c->cqdd[i] = v;
  }
  carrier_forces(c, lam, qd);
  /* dependent rows held: the forces shared by least norm (the carriers'
   * ones kept where the sharing fails: they are admissible as well) */
  if (c->dependent && (st = nz_c_share_forces(c, s, t, q, qd, lam))) {
    nz_c_fail_at(c, NZ_CONTACT_EVAL, st, -1, t, q, qd);
    return st;
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
  nz_c_clear_failure(c);
  if (qdd) memcpy(qdd, c->cqdd, (size_t)c->k * sizeof(double));
  if (lambda) memcpy(lambda, c->clam, (size_t)c->nc * sizeof(double));
  return NZ_OK;
}

/* ------------------------------------------------------------------ */
/* Events                                                               */

/* Contact j's friction force's size |lambda_t| in the last mode solve. */
static double friction_size(const nz_contacts *c, int j)
{
  const nz_contact_def *d = &c->def[j];
  return nz_c_iso(d) ? hypot(c->clam[d->slip], c->clam[d->slip2]) : fabs(c->clam[d->slip]);
}

static int friction_event(nz_contacts *c, const nz_system *s, int j, double t, const double *q, const double *qd,
                          double *g)
{
  const nz_contact_def *d = &c->def[j];
  int state = c->mode[j], st;
  *g = 1.0;
  if (d->slip < 0 || !nz_c_held(state) || state == NZ_CONTACT_CLOSED || !c->share[j]) return NZ_OK;
  if (state == NZ_CONTACT_STICK) {
    if (c->atcone[j]) return NZ_OK;
    if ((st = nz_contacts_accel(c, s, t, q, qd, NULL, NULL))) return st;
    *g = d->mu_s * c->clam[d->gap] - friction_size(c, j);
    return NZ_OK;
  }
  double vt[2] = { 0.0, 0.0 };
  if ((st = nz_c_slip_velocities(c, s, j, t, q, qd, vt))) return st;
  if (state == NZ_CONTACT_SLIP)
    *g = vt[0] * c->dir[2 * j] + vt[1] * c->dir[2 * j + 1] - NZ_CONTACT_TURN * hypot(vt[0], vt[1]);
  else *g = state == NZ_CONTACT_SLIP_POS ? vt[0] : -vt[0];
  *g += c->offset[2 * j + 1];
  return NZ_OK;
}

int nz_contacts_event(nz_contacts *c, const nz_system *s, int e, double t, const double *y, double *g)
{
  int j = e / 2, k = c->k, st;
  if (e < 0 || j >= c->n) return NZ_EARG;
  const nz_contact_def *d = &c->def[j];
  const double *q = y, *qd = y + k;
  if (e % 2) return friction_event(c, s, j, t, q, qd, g);
  if (c->mode[j] == NZ_CONTACT_OPEN) {
    double v[2];
    if ((st = value_rate(c, s, d->gap, t, q, qd, v))) return st;
    *g = v[0] + c->offset[e];
    return NZ_OK;
  }
  if (!c->share[j]) {       /* it rests on the others without a force: they keep its gap */
    *g = 1.0;
    return NZ_OK;
  }
  if ((st = nz_contacts_accel(c, s, t, q, qd, NULL, NULL))) return st;
  *g = c->clam[d->gap];
  return NZ_OK;
}

int nz_contacts_kinematics(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                           double *out)
{
  for (int j = 0; j < c->n; j++) {
    double v[2], vt[2] = { 0.0, 0.0 }, *o = out + 4 * j;
    int st = value_rate(c, s, c->def[j].gap, t, q, qd, v);
    if (!st) st = nz_c_slip_velocities(c, s, j, t, q, qd, vt);
    if (!st) st = nz_c_row_at(c, s, c->def[j].gap, t, q, qd);
    if (st) {
      nz_c_fail_at(c, NZ_CONTACT_EVAL, st, j, t, q, qd);
      return st;
    }
    o[0] = v[0];
    o[1] = v[1];
    o[2] = nz_c_iso(&c->def[j]) ? hypot(vt[0], vt[1]) : vt[0];
    o[3] = nz_c_abs_dot(c->k, nz_c_row(c, c->def[j].gap), q);
  }
  nz_c_clear_failure(c);
  return NZ_OK;
}
