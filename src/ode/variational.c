/* variational.c - variational integrators (see variational.h): the
 * composition, the Stormer-Verlet (RATTLE) stage, the stage by Newton
 * (variational_del.c), the state kept to twice the precision, the dense
 * output and the interface's other functions. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/compensated.h"
#include "core/linalg.h"
#include "ode/variational.h"

/* The compositions' step fractions, palindromes written out. */
#define SUZUKI4 0.41449077179437573714
static const double gamma2[] = { 1.0 };
static const double gamma4[] = { SUZUKI4, SUZUKI4, 1.0 - 4.0 * SUZUKI4, SUZUKI4, SUZUKI4 };
static const double gamma6[] = {   /* Kahan-Li s9odr6a */
  0.39216144400731413928, 0.33259913678935943860, -0.70624617255763935981, 0.08221359629355080023,
  0.79854399093482996340,
  0.08221359629355080023, -0.70624617255763935981, 0.33259913678935943860, 0.39216144400731413928
};
static const double gamma8[] = {   /* Kahan-Li s17odr8a */
  0.13020248308889008088, 0.56116298177510838456, -0.38947496264484728641, 0.15884190655515560090,
  -0.39590389413323757734, 0.18453964097831570709, 0.25837438768632204729, 0.29501172360931029887,
  -0.60550853383003451170,
  0.29501172360931029887, 0.25837438768632204729, 0.18453964097831570709, -0.39590389413323757734,
  0.15884190655515560090, -0.38947496264484728641, 0.56116298177510838456, 0.13020248308889008088
};

const double *nz_variational_gammas(int p, int *stages)
{
  switch (p) {
  case 2: *stages = 1; return gamma2;
  case 4: *stages = 5; return gamma4;
  case 6: *stages = 9; return gamma6;
  case 8: *stages = 17; return gamma8;
  default: *stages = 0; return NULL;
  }
}

typedef struct var_stepper {
  nz_stepper base;
  nz_variational_config c;        /* its setup's arrays point into this block   */
  const double *gammas;
  int stages;
  double *frac;                   /* the stages' ends as fractions of h (1 last) */
  nz_motion_setup free_setup;     /* the same without constraints: Verlet's q''  */
  nz_del *del;                    /* the implicit stage's workspace              */
  nz_lu *lu;                      /* nc x nc: RATTLE's constraint forces          */
  /* the state: q + qlo, and the momentum p + plo (Verlet: the velocity) */
  double *q, *qlo, *p, *plo, *w;  /* w: the velocity (the implicit stage's)      */
  double *yend;                   /* the state the last step left (2k)           */
  int valid;                      /* q, p, w are yend's                          */
  double *a, ta;                  /* Verlet: q'' at (ta, q) when a_ok            */
  int a_ok;
  double *dq, *dp, *tmp;          /* k each                                      */
  /* RATTLE: M's Cholesky factor (constant), W = M^-1 G^T, the forces */
  double *Lm, *G, *W, *phi, *phit, *K, *lam, *rhs, *size;
  int have_m;
  double *work;                   /* nz_solve_spd_in's                           */
  /* dense output: the last step's ends */
  double dta, dtb, *ya, *yb;
  int dense_ok;
  /* statistics and the last failure */
  unsigned long steps, nfev, njev;
  nz_variational_failure failure;
  int status;
  double tfail, *yfail;
  nz_del_report rep;
  nz_motion_outcome oc;
  int *involved;
  double *Aout;
} var_stepper;

static var_stepper *as_var(nz_stepper *st) { return (var_stepper *)st; }

static int fail(var_stepper *v, nz_variational_failure kind, int status, double t, const double *q, const double *qd)
{
  int k = v->base.k;
  v->failure = kind;
  v->status = status;
  v->tfail = t;
  memcpy(v->yfail, q, (size_t)k * sizeof(double));
  memcpy(v->yfail + k, qd, (size_t)k * sizeof(double));
  return status ? status : NZ_EARG;
}

/* Verlet's q'' at (t, q) (unconstrained: the constraints' forces are
 * RATTLE's), into v->a. */
static int verlet_accel(var_stepper *v, const nz_system *s, double t, const double *q)
{
  /* the last stage's end, q unchanged since: its time as this stage
   * computes it, or as the loop does (its sum of the steps, rounded: within
   * a few ulps of ours) */
  if (v->a_ok && (t == v->ta || fabs(t - v->ta) <= 8 * 2.220446049250313e-16 * fabs(t))) return NZ_OK;
  double lam;
  v->oc.rep.involved = v->involved;
  v->oc.rep.A = v->Aout;
  int st = nz_motion_accel(s, &v->free_setup, t, q, v->p, NULL, v->a, &lam, &v->oc);
  v->nfev++;
  if (st) return fail(v, NZ_VARIATIONAL_MOTION, st, t, q, v->p);
  v->ta = t;
  v->a_ok = 1;
  return NZ_OK;
}

/* W = M^-1 G^T (k x nc, column r = M^-1 G_r) for the constraints G (nc x k). */
static void mass_solve_rows(var_stepper *v, const double *G, double *W)
{
  int k = v->base.k, nc = v->base.nc;
  for (int r = 0; r < nc; r++) {
    memcpy(v->tmp, G + (size_t)r * k, (size_t)k * sizeof(double));
    nz_cholesky_solve(k, v->Lm, v->tmp);
    for (int i = 0; i < k; i++) W[(size_t)i * nc + r] = v->tmp[i];
  }
}

/* M (constant: its value at the first state) factored once, for RATTLE. */
static int mass_factor(var_stepper *v, const nz_system *s, double t)
{
  if (v->have_m) return NZ_OK;
  int k = v->base.k;
  int st = nz_mass_bias(s, t, v->q, v->p, v->Lm, v->tmp);
  if (st) return fail(v, NZ_VARIATIONAL_MOTION, st, t, v->q, v->p);
  memset(&v->oc, 0, sizeof v->oc);
  st = nz_solve_spd_in(k, v->Lm, v->tmp, v->dq, v->c.setup.opt.rcond_min, &v->oc.mass, v->work);
  if (st) return fail(v, NZ_VARIATIONAL_MASS, st, t, v->q, v->p);
  v->have_m = 1;
  return NZ_OK;
}

/* RATTLE's position: the constraint force l (nc) with Phi(t1, q + h (v +
 * h/2 (a - W0 l))) = 0 by Newton, W0 = M^-1 G(t0, q)^T in v->W; into
 * v->lam (its start: the last stage's). */
static int rattle_position(var_stepper *v, const nz_system *s, double t1, double h)
{
  int k = v->base.k, nc = v->base.nc, st;
  double last = INFINITY, *x = v->tmp;
  for (int it = 1;; it++) {
    for (int i = 0; i < k; i++) {
      double f = v->a[i];
      for (int r = 0; r < nc; r++) f -= v->W[(size_t)i * nc + r] * v->lam[r];
      x[i] = v->q[i] + (v->qlo[i] + h * ((v->p[i] + v->plo[i]) + 0.5 * h * f));
    }
    if ((st = nz_del_constraints(v->del, s, t1, x, v->phi, v->G, NULL))) return fail(v, NZ_VARIATIONAL_RATTLE, st, t1, x, v->p);
    for (int r = 0; r < nc; r++) {
      v->size[r] = 0.0;
      for (int j = 0; j < k; j++) v->size[r] += fabs(v->G[(size_t)r * k + j] * x[j]);
    }
    if (nz_del_converged(v->phi, v->size, nc, &last)) return NZ_OK;
    if (it > NZ_DEL_MAXIT) {
      v->rep.what = NZ_DEL_NEWTON, v->rep.iterations = NZ_DEL_MAXIT, v->rep.residual = last;
      return fail(v, NZ_VARIATIONAL_RATTLE, NZ_EARG, t1, x, v->p);
    }
    /* dPhi/dl = -h^2/2 G(x) W0 */
    for (int r = 0; r < nc; r++)
      for (int c = 0; c < nc; c++) {
        double g = 0.0;
        for (int i = 0; i < k; i++) g += v->G[(size_t)r * k + i] * v->W[(size_t)i * nc + c];
        v->K[(size_t)r * nc + c] = -0.5 * h * h * g;
      }
    for (int r = 0; r < nc; r++) v->rhs[r] = -v->phi[r];
    if (nz_lu_factor(v->lu, nc, v->K) || nz_lu_solve(v->lu, v->rhs)) {
      v->rep.what = NZ_DEL_SINGULAR, v->rep.iterations = it;
      return fail(v, NZ_VARIATIONAL_RATTLE, NZ_ESINGULAR, t1, x, v->p);
    }
    for (int r = 0; r < nc; r++) v->lam[r] += v->rhs[r];
  }
}

/* RATTLE's velocity: v + h/2 (a - W1 m) with G1 (that velocity) + Phi_t = 0,
 * linear in m; into v->rhs (m), G1 and W1 in v->G, v->W. */
static int rattle_velocity(var_stepper *v, const nz_system *s, double t1, double h)
{
  int k = v->base.k, nc = v->base.nc, st;
  if ((st = nz_del_constraints(v->del, s, t1, v->q, NULL, v->G, v->phit))) return fail(v, NZ_VARIATIONAL_RATTLE, st, t1, v->q, v->p);
  mass_solve_rows(v, v->G, v->W);
  for (int r = 0; r < nc; r++) {
    double f = v->phit[r];
    for (int i = 0; i < k; i++) f += v->G[(size_t)r * k + i] * ((v->p[i] + v->plo[i]) + 0.5 * h * v->a[i]);
    v->rhs[r] = f;
    for (int c = 0; c < nc; c++) {
      double g = 0.0;
      for (int i = 0; i < k; i++) g += v->G[(size_t)r * k + i] * v->W[(size_t)i * nc + c];
      v->K[(size_t)r * nc + c] = 0.5 * h * g;
    }
  }
  if (nz_lu_factor(v->lu, nc, v->K) || nz_lu_solve(v->lu, v->rhs)) {
    v->rep.what = NZ_DEL_SINGULAR, v->rep.velocity = 1;
    return fail(v, NZ_VARIATIONAL_RATTLE, NZ_ESINGULAR, t1, v->q, v->p);
  }
  return NZ_OK;
}

/* One Stormer-Verlet stage of h from t0 to t1 (RATTLE with constraints),
 * on the state q + qlo, v + vlo (v->p, v->plo hold the velocity):
 *   v+ = v + h/2 (a(t0, q) - W0 l),  q1 = q + h v+,  Phi(t1, q1) = 0,
 *   v1 = v+ + h/2 (a(t1, q1) - W1 m),  G1 v1 + Phi_t = 0. */
static int verlet_stage(var_stepper *v, const nz_system *s, double t0, double t1, double h)
{
  int k = v->base.k, nc = v->base.nc, st;
  if ((st = verlet_accel(v, s, t0, v->q))) return st;
  if (nc > 0) {
    if ((st = mass_factor(v, s, t0))) return st;
    if ((st = nz_del_constraints(v->del, s, t0, v->q, NULL, v->G, NULL))) return fail(v, NZ_VARIATIONAL_RATTLE, st, t0, v->q, v->p);
    mass_solve_rows(v, v->G, v->W);
    if ((st = rattle_position(v, s, t1, h))) return st;
  }
  for (int i = 0; i < k; i++) {
    double f = v->a[i];
    for (int r = 0; r < nc; r++) f -= v->W[(size_t)i * nc + r] * v->lam[r];
    nz_dd_add(&v->p[i], &v->plo[i], 0.5 * h * f);
    nz_dd_add(&v->q[i], &v->qlo[i], h * (v->p[i] + v->plo[i]));
  }
  v->a_ok = 0;
  if ((st = verlet_accel(v, s, t1, v->q))) return st;
  if (nc > 0 && (st = rattle_velocity(v, s, t1, h))) return st;
  for (int i = 0; i < k; i++) {
    double f = v->a[i];
    for (int r = 0; r < nc; r++) f -= v->W[(size_t)i * nc + r] * v->rhs[r];
    nz_dd_add(&v->p[i], &v->plo[i], 0.5 * h * f);
    v->w[i] = v->p[i];
  }
  return NZ_OK;
}

/* One stage of the discrete Euler-Lagrange equations by Newton
 * (variational_del.h), from the increment h w. */
static int del_stage(var_stepper *v, const nz_system *s, double t0, double h)
{
  int k = v->base.k;
  for (int i = 0; i < k; i++) v->tmp[i] = h * v->w[i];
  int st = nz_del_step(v->del, s, t0, h, v->q, v->p, v->tmp, v->dq, v->dp, v->w, &v->nfev, &v->njev, &v->rep);
  if (st) return fail(v, NZ_VARIATIONAL_DEL, st, t0, v->q, v->w);
  for (int i = 0; i < k; i++) {
    nz_dd_add(&v->q[i], &v->qlo[i], v->dq[i]);
    nz_dd_add(&v->p[i], &v->plo[i], v->dp[i]);
  }
  return NZ_OK;
}

/* The state from y = (q, q') when it is not the one the last step left: q
 * and the momentum (the velocity for Verlet) with their low parts 0. */
static int take_state(var_stepper *v, const nz_system *s, double t, const double *y)
{
  int k = v->base.k;
  if (v->valid && !memcmp(y, v->yend, 2 * (size_t)k * sizeof(double))) return NZ_OK;
  memcpy(v->q, y, (size_t)k * sizeof(double));
  memcpy(v->w, y + k, (size_t)k * sizeof(double));
  memset(v->qlo, 0, (size_t)k * sizeof(double));
  memset(v->plo, 0, (size_t)k * sizeof(double));
  v->a_ok = 0;
  memset(v->lam, 0, (size_t)v->base.nc * sizeof(double));
  if (v->c.verlet) {
    memcpy(v->p, y + k, (size_t)k * sizeof(double));
    return NZ_OK;
  }
  int st = nz_del_momentum(v->del, s, t, v->q, v->w, v->p);
  v->nfev++;
  if (st) {
    v->rep.what = NZ_DEL_EVAL;
    return fail(v, NZ_VARIATIONAL_DEL, st, t, v->q, v->w);
  }
  return NZ_OK;
}

/* One step of h: the composition's stages in turn, each from its start
 * time t + (the fractions before it) h. */
static int var_step_fixed(nz_stepper *st, const nz_system *s, double *t, double h, double *y)
{
  var_stepper *v = as_var(st);
  int k = st->k, status;
  v->failure = NZ_VARIATIONAL_OK;
  memset(&v->rep, 0, sizeof v->rep);
  if ((status = take_state(v, s, *t, y))) return status;
  double t0 = *t;
  for (int i = 0; i < v->stages; i++) {
    double ts = i ? t0 + v->frac[i - 1] * h : t0, te = t0 + v->frac[i] * h, hs = v->gammas[i] * h;
    status = v->c.verlet ? verlet_stage(v, s, ts, te, hs) : del_stage(v, s, ts, hs);
    if (status) {
      v->valid = 0;
      v->dense_ok = 0;
      return status;
    }
  }
  memcpy(v->ya, y, 2 * (size_t)k * sizeof(double));
  memcpy(y, v->q, (size_t)k * sizeof(double));
  memcpy(y + k, v->w, (size_t)k * sizeof(double));
  memcpy(v->yend, y, 2 * (size_t)k * sizeof(double));
  memcpy(v->yb, y, 2 * (size_t)k * sizeof(double));
  v->dta = t0;
  v->dtb = t0 + h;
  v->dense_ok = 1;
  v->valid = 1;
  v->steps++;
  *t = t0 + h;
  return NZ_OK;
}

/* The cubic Hermite interpolant of (q, q') over the last step. */
static int var_dense(nz_stepper *st, const nz_system *s, double tau, double *y, int *ok)
{
  var_stepper *v = as_var(st);
  (void)s;
  *ok = 0;
  if (!v->dense_ok || !(tau >= v->dta && tau <= v->dtb)) return NZ_EARG;
  int k = st->k;
  double h = v->dtb - v->dta, x = (tau - v->dta) / h, x2 = x * x, x3 = x2 * x;
  double h00 = 2 * x3 - 3 * x2 + 1, h10 = x3 - 2 * x2 + x, h01 = -2 * x3 + 3 * x2, h11 = x3 - x2;
  double d00 = 6 * x2 - 6 * x, d10 = 3 * x2 - 4 * x + 1, d01 = -6 * x2 + 6 * x, d11 = 3 * x2 - 2 * x;
  for (int i = 0; i < k; i++) {
    double qa = v->ya[i], va = v->ya[k + i], qb = v->yb[i], vb = v->yb[k + i];
    y[i] = h00 * qa + h10 * h * va + h01 * qb + h11 * h * vb;
    y[k + i] = (d00 * qa + d01 * qb) / h + d10 * va + d11 * vb;
  }
  *ok = 1;
  return NZ_OK;
}

/* q'' and lambda at an output point, by the solve every integrator records
 * with (motion_accel.h). */
static int var_accel(nz_stepper *st, const nz_system *s, double t, const double *y, double *out)
{
  var_stepper *v = as_var(st);
  int k = st->k;
  v->oc.rep.involved = v->involved;
  v->oc.rep.A = v->Aout;
  int status = nz_motion_accel(s, &v->c.setup, t, y, y + k, NULL, out, out + k, &v->oc);
  return status ? fail(v, NZ_VARIATIONAL_MOTION, status, t, y, y + k) : NZ_OK;
}

static const double *var_root(const nz_stepper *st)
{
  (void)st;
  return NULL;
}

static void var_stats(const nz_stepper *st, nz_stepper_stats *out)
{
  const var_stepper *v = (const var_stepper *)st;
  memset(out, 0, sizeof *out);
  out->steps = v->steps;
  out->nfev = v->nfev;
  out->njev = v->njev;
  out->order = v->c.order;
}

/* Forget the momentum: the next step takes the state from y. */
static void var_reset(nz_stepper *st)
{
  var_stepper *v = as_var(st);
  v->valid = 0;
  v->a_ok = 0;
  v->dense_ok = 0;
}

static void var_free(nz_stepper *st)
{
  var_stepper *v = as_var(st);
  nz_del_free(v->del);
  nz_lu_free(v->lu);
  free(v);
}

static const nz_stepper_ops var_ops = {
  NULL, var_step_fixed, var_dense, var_accel, var_root, var_stats, var_reset, var_free
};

/* The block: the stepper, its doubles, its ints. */
static var_stepper *var_alloc(const nz_variational_config *cfg)
{
  size_t k = (size_t)cfg->setup.k, nc = (size_t)cfg->setup.nc;
  size_t doubles = 17 + 17 * k + k * k + 3 * nc * k + 5 * nc + nc * nc + nz_solve_spd_work_len((int)k);
  size_t ints = 3 * (nc + 1);
  var_stepper *v = calloc(1, sizeof *v + doubles * sizeof(double) + ints * sizeof(int));
  if (!v) return NULL;
  double *d = (double *)(void *)(v + 1);
  v->frac = d, d += 17;
  v->q = d, d += k;
  v->qlo = d, d += k;
  v->p = d, d += k;
  v->plo = d, d += k;
  v->w = d, d += k;
  v->a = d, d += k;
  v->dq = d, d += k;
  v->dp = d, d += k;
  v->tmp = d, d += k;
  v->yend = d, d += 2 * k;
  v->ya = d, d += 2 * k;
  v->yb = d, d += 2 * k;
  v->yfail = d, d += 2 * k;
  v->Lm = d, d += k * k;
  v->G = d, d += nc * k;
  v->W = d, d += nc * k;
  v->Aout = d, d += nc * k;
  v->phi = d, d += nc;
  v->phit = d, d += nc;
  v->lam = d, d += nc;
  v->rhs = d, d += nc;
  v->size = d, d += nc;
  v->K = d, d += nc * nc;
  v->work = d, d += nz_solve_spd_work_len((int)k);
  int *iw = (int *)(void *)d;
  v->c = *cfg;
  if (nc > 0) {
    memcpy(iw, cfg->setup.orders, nc * sizeof(int));
    memcpy(iw + nc + 1, cfg->setup.linear, nc * sizeof(int));
    v->c.setup.orders = iw;
    v->c.setup.linear = iw + nc + 1;
  } else v->c.setup.orders = v->c.setup.linear = NULL;
  v->involved = iw + 2 * (nc + 1);
  return v;
}

nz_stepper *nz_variational_new(const nz_variational_config *cfg)
{
  const nz_motion_setup *m = &cfg->setup;
  int stages;
  const double *g = nz_variational_gammas(cfg->order, &stages);
  if (m->k < 1 || m->nc < 0 || !g || m->contacts || (m->nc > 0 && (!m->orders || !m->linear))) return NULL;
  for (int r = 0; r < m->nc; r++)
    if (m->orders[r] != 0) return NULL;
  var_stepper *v = var_alloc(cfg);
  if (!v) return NULL;
  v->del = nz_del_new(m->k, m->nc, cfg->nlevels > 0 ? cfg->nlevels : NZ_CONSTRAINT_SLOTS);
  v->lu = nz_lu_new(m->nc > 0 ? m->nc : 1);
  if (!v->del || !v->lu) {
    var_free(&v->base);
    return NULL;
  }
  v->gammas = g;
  v->stages = stages;
  double sum = 0.0;
  for (int i = 0; i < stages; i++) v->frac[i] = (sum += g[i]);
  v->frac[stages - 1] = 1.0;
  v->free_setup = v->c.setup;
  v->free_setup.nc = 0;
  v->free_setup.orders = v->free_setup.linear = NULL;
  /* dense output: a Hermite cubic, not the method's own solution */
  v->base = (nz_stepper){ .ops = &var_ops, .name = "variational", .k = m->k, .nc = m->nc, .dim = 2 * m->k,
                          .exact_dense = 0 };
  return &v->base;
}

nz_variational_failure nz_variational_last_failure(const nz_stepper *st, int *status, double *t, const double **y,
                                                   const nz_del_report **del, const nz_motion_outcome **oc)
{
  const var_stepper *v = (const var_stepper *)st;
  if (status) *status = v->status;
  if (t) *t = v->tfail;
  if (y) *y = v->yfail;
  if (del) *del = &v->rep;
  if (oc) *oc = &v->oc;
  return v->failure;
}

const nz_motion_setup *nz_variational_setup(const nz_stepper *st)
{
  return st->ops == &var_ops ? &((const var_stepper *)st)->c.setup : NULL;
}
