/* ode.c - a mechanical system for GSL's odeiv2 (see ode.h).
 *
 * The driver object owns the stepper, the control and the evolve objects;
 * stepping goes through gsl_odeiv2_evolve_apply on those (the multistep
 * methods msadams and msbdf need the driver).  A failure inside a callback
 * is kept in o->failure and reported to GSL as GSL_EBADFUNC, so GSL returns
 * at once and the caller raises the error: nothing unwinds through GSL. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>
#include "core/compensated.h"
#include "core/linalg.h"
#include "mech/constrained_series.h"
#include "mech/contact.h"
#include "mech/mech_jacobian.h"
#include "mech/motion_accel.h"
#include "ode/ode.h"

const char *const nz_ode_methods[] = {
  "rk2", "rk4", "rkf45", "rkck", "rk8pd", "rk1imp", "rk2imp", "rk4imp", "bsimp", "msadams", "msbdf", NULL
};

static const gsl_odeiv2_step_type *step_type(const char *name)
{
  const gsl_odeiv2_step_type *const types[] = {
    gsl_odeiv2_step_rk2, gsl_odeiv2_step_rk4, gsl_odeiv2_step_rkf45, gsl_odeiv2_step_rkck,
    gsl_odeiv2_step_rk8pd, gsl_odeiv2_step_rk1imp, gsl_odeiv2_step_rk2imp, gsl_odeiv2_step_rk4imp,
    gsl_odeiv2_step_bsimp, gsl_odeiv2_step_msadams, gsl_odeiv2_step_msbdf
  };
  for (int i = 0; nz_ode_methods[i]; i++)
    if (!strcmp(nz_ode_methods[i], name)) return types[i];
  return NULL;
}

int nz_ode_is_implicit(const char *m)
{
  return !strcmp(m, "rk1imp") || !strcmp(m, "rk2imp") || !strcmp(m, "rk4imp") ||
         !strcmp(m, "bsimp") || !strcmp(m, "msbdf");
}

/* The multistep methods' start: how many steps after a reset, below which
 * order, and to which factor of the tolerance their steps are held
 * (nz_ode_step). */
#define NZ_ODE_START_STEPS 10
#define NZ_ODE_START_ORDER 3
#define NZ_ODE_START_TIGHTEN 1e-3

static int is_multistep(const char *m) { return !strcmp(m, "msadams") || !strcmp(m, "msbdf"); }

struct nz_ode {
  const char *method;             /* one of nz_ode_methods */
  int k, nc, dim, work, multistep;
  int level;                      /* p >= 3: the state of constrained_series.h; else 0 */
  double work_offset;             /* GSL carries W + work_offset (see nz_ode_alloc) */
  int top;                        /* level p with a constraint nonlinear in q^(p) */
  nz_contacts *contacts;          /* unilateral contacts in their mode, or NULL */
  int nrows;                      /* the constraints whose rows are watched: the bilateral ones */
  const nz_system *s;             /* bound for the current call */
  int *orders, *linear, *involved;
  nz_accel_options accel;
  nz_motion_setup setup;          /* which solve gives q'' (motion_accel.h) */
  double *last;                   /* k + nc: last q'' and lambda, Newton's next start */
  int have_last;
  double *A;                      /* nc x k gradients from the last solve */
  double *Aprev, tprev;           /* the rows of orders 0 and 1 at the last step's end */
  int have_prev;
  int reversed;                   /* the first reversal: 1 + its constraint, and its step */
  double reversed_ta, reversed_tb;
  double *yfail;                  /* the state of the last failure */
  double *wscratch;               /* dim + k + nc: the work row's evaluations */
  gsl_odeiv2_system gsys;
  gsl_odeiv2_driver *driver;
  gsl_odeiv2_control *start;      /* multistep: the control of a start's first steps (nz_ode_step) */
  int since_reset;                /* steps tried since the start or the last reset */
  unsigned long nfev, njev;
  unsigned long steps0, rejected0;  /* counts of the evolve objects reset before */
  double ta, lo_a, tb, lo_b;      /* the last adaptive step's start and end, each t + lo */
  nz_ode_failure failure;
};

static int fail(nz_ode *o, nz_ode_failure_kind kind, int status, double t, const double *y)
{
  if (o->failure.kind == NZ_ODE_FAIL_NONE) {
    o->failure.kind = kind;
    o->failure.status = status;
    o->failure.t = t;
    memcpy(o->yfail, y, (size_t)o->dim * sizeof(double));
    o->failure.y = o->yfail;
  }
  return GSL_EBADFUNC;
}

/* Level p, top: the root (q^(p), lambda) at (t, y) from the last root
 * (which keeps the branch), kept in o->last; f (dim) and lambda (nc) out,
 * each when not NULL. */
static int top_solve(nz_ode *o, double t, const double *y, double *f, double *lambda)
{
  int k = o->k, nc = o->nc;
  nz_accel_report rep;
  memset(&rep, 0, sizeof rep);
  memset(o->involved, 0, (size_t)nc * sizeof(int));
  rep.involved = o->involved;
  rep.A = o->A;
  double *x = o->last + k + nc, *fs = f;
  if (!fs && !(fs = malloc((size_t)o->dim * sizeof(double)))) return NZ_ENOMEM;
  int st = nz_top_rhs(o->s, o->orders, o->linear, o->level, &o->accel, t, y,
                      o->have_last ? o->last : NULL, fs, x, &rep);
  if (fs != f) free(fs);
  if (st == NZ_ESINGULAR || st == NZ_EARG) {
    o->failure.accel = rep;
    fail(o, NZ_ODE_FAIL_CONSTRAINTS, st, t, y);
    return st;
  }
  if (st) return st;
  memcpy(o->last, x, (size_t)(k + nc) * sizeof(double));
  o->have_last = 1;
  if (lambda) memcpy(lambda, x + k, (size_t)nc * sizeof(double));
  return NZ_OK;
}

/* q'' and lambda into out (k + nc), and A; status of the mechanics. */
static int accelerations(nz_ode *o, double t, const double *y, double *out)
{
  int k = o->k;
  if (o->top) {                    /* q'' is in the state, lambda solved with q^(p) */
    memcpy(out, y + 2 * k, (size_t)k * sizeof(double));
    return top_solve(o, t, y, NULL, out + k);
  }
  if (o->level) {                  /* q'' and lambda are in the state */
    memcpy(out, y + 2 * k, (size_t)k * sizeof(double));
    memcpy(out + k, y + (size_t)o->level * k, (size_t)o->nc * sizeof(double));
    return NZ_OK;
  }
  nz_motion_outcome oc;
  oc.rep.involved = o->involved;
  oc.rep.A = o->A;
  int st = nz_motion_accel(o->s, &o->setup, t, y, y + k, o->have_last ? o->last : NULL, out, out + k, &oc);
  switch (oc.failed) {
  case NZ_MOTION_FAILED_CONTACTS: fail(o, NZ_ODE_FAIL_CONTACT, st, t, y); return st;
  case NZ_MOTION_FAILED_MASS:
    o->failure.mass = oc.mass;
    fail(o, NZ_ODE_FAIL_MASS, st, t, y);
    return st;
  case NZ_MOTION_FAILED_CONSTRAINTS:
    o->failure.accel = oc.rep;
    fail(o, NZ_ODE_FAIL_CONSTRAINTS, st, t, y);
    return st;
  case NZ_MOTION_OK: break;
  }
  if (!st && o->nc > 0 && !o->contacts) {   /* Newton's next start */
    memcpy(o->last, out, (size_t)(k + o->nc) * sizeof(double));
    o->have_last = 1;
  }
  return st;
}

/* W' = R_0 of (9.1), d/dt(T1 + 2 T0) - dL/dt + sum_r lambda_r A_r . q', plus
 * the forces' power Q . q' */
static int reaction_power(nz_ode *o, double t, const double *y, const double *acc, double *R0)
{
  int k = o->k;
  double dLdt = 0.0, T0, T1, rate = 0.0;   /* (set when st is NZ_OK; initialized for the compiler's flow analysis under LTO) */
  int st = nz_lagrangian_time_partial(o->s, t, y, y + k, &dLdt);
  if (!st) st = nz_kinetic_parts(o->s, t, y, y + k, acc, &T0, &T1, &rate);
  if (st) return st;
  /* the forces' power too: W is then the work of everything outside V, and
   * T + V - W is constant along every motion (Q does work on T + V as the
   * moving constraints' reactions do) */
  double PQ = 0.0;
  if ((st = nz_force_power(o->s, t, y, y + k, &PQ))) return st;
  *R0 = rate - dLdt + PQ;
  for (int r = 0; r < o->nc; r++) {
    double p = 0.0;
    for (int i = 0; i < k; i++) p += o->A[(size_t)r * k + i] * y[k + i];
    *R0 += acc[k + r] * p;
  }
  return NZ_OK;
}

/* The right-hand side at level p >= 3 (constrained_series.h). */
static int level_rhs(nz_ode *o, double t, const double *y, double *f)
{
  if (o->top) {
    int st = top_solve(o, t, y, f, NULL);
    return !st ? GSL_SUCCESS : o->failure.kind ? GSL_EBADFUNC : fail(o, NZ_ODE_FAIL_FUNCTION, st, t, y);
  }
  nz_accel_report rep;
  memset(&rep, 0, sizeof rep);
  memset(o->involved, 0, (size_t)o->nc * sizeof(int));
  rep.involved = o->involved;
  rep.A = o->A;
  int st = nz_series_rhs(o->s, o->orders, o->level, o->accel.rcond_min, t, y, f, &rep);
  if (st == NZ_ESINGULAR) {
    o->failure.accel = rep;
    return fail(o, NZ_ODE_FAIL_CONSTRAINTS, st, t, y);
  }
  return st ? fail(o, NZ_ODE_FAIL_FUNCTION, st, t, y) : GSL_SUCCESS;
}

static int rhs(double t, const double y[], double f[], void *params)
{
  nz_ode *o = params;
  int k = o->k;
  o->nfev++;
  /* A free system whose recording has its q'' in machine code: straight to
   * it, into f (it refuses a state that is not finite, for the check below
   * to report).  This is the whole per-call cost of a small system, and
   * each layer between here and the machine code costs as much as its
   * arithmetic: Henon-Heiles' RHS is 16 ns in hand-written C. */
  if (o->nc == 0 && !o->work && o->s->free_rhs &&
      o->s->free_rhs(o->s->mass_bias_ctx, t, y, o->accel.rcond_min, f) == NZ_OK)
    return GSL_SUCCESS;
  for (int i = 0; i < o->dim; i++)
    if (!isfinite(y[i])) return fail(o, NZ_ODE_FAIL_NONFINITE, NZ_ERANGE, t, y);
  if (o->level) return level_rhs(o, t, y, f);
  int st;
  if (o->nc == 0 && !o->work && o->s->accel) {   /* the same through the accel hook */
    st = o->s->accel(o->s->mass_bias_ctx, t, y, y + k, o->accel.rcond_min, f + k, &o->failure.mass);
    if (st != NZ_EARG) {
      if (st) return fail(o, st == NZ_ESINGULAR ? NZ_ODE_FAIL_MASS : NZ_ODE_FAIL_FUNCTION, st, t, y);
      for (int i = 0; i < k; i++) f[i] = y[k + i];
      return GSL_SUCCESS;
    }
  }
  double *acc = o->last + k + o->nc;          /* scratch after the guess */
  st = accelerations(o, t, y, acc);
  if (st) return o->failure.kind ? GSL_EBADFUNC : fail(o, NZ_ODE_FAIL_FUNCTION, st, t, y);
  memcpy(f, y + k, (size_t)k * sizeof(double));
  memcpy(f + k, acc, (size_t)k * sizeof(double));
  if (o->work) {
    st = reaction_power(o, t, y, acc, &f[2 * k]);
    if (st) return fail(o, NZ_ODE_FAIL_FUNCTION, st, t, y);
  }
  return GSL_SUCCESS;
}

/* R_0 at (t, y) with the accelerations solved there. */
static int reaction_power_at(nz_ode *o, double t, const double *y, double *R0)
{
  double *acc = o->wscratch + o->dim;
  int st = accelerations(o, t, y, acc);
  if (!st) st = reaction_power(o, t, y, acc, R0);
  return st;
}

/* The row of W' = R_0 (and dR_0/dt): R_0 depends on the state through q, q'
 * and through the accelerations and multipliers solved there, so its exact
 * derivative needs third derivatives of T along the state that the jets'
 * one direction does not carry; central differences of R_0 (each side with
 * its own solve) give it to ~1e-10 relative, which is all an implicit
 * stepper's Newton iteration asks of a Jacobian.  Without this row the
 * iteration sees W' as constant and bsimp rejects ~40% of its steps. */
static int work_row(nz_ode *o, double t, const double *y, double *dfdy, double *dfdt)
{
  int k = o->k, dim = o->dim, w = 2 * k, st;
  double *yp = o->wscratch, Rp, Rm;
  const double step = 6.0554544523933395e-06;   /* cbrt(DBL_EPSILON): h^2 against eps/h */
  for (int j = 0; j <= w; j++) {                 /* j = w: along t */
    double base = j < w ? y[j] : t, h = step * fmax(1.0, fabs(base));
    memcpy(yp, y, (size_t)dim * sizeof(double));
    if (j < w) yp[j] = base + h;
    st = reaction_power_at(o, j < w ? t : t + h, yp, &Rp);
    if (!st) {
      if (j < w) yp[j] = base - h;
      st = reaction_power_at(o, j < w ? t : t - h, yp, &Rm);
    }
    if (st) return o->failure.kind ? GSL_EBADFUNC : fail(o, NZ_ODE_FAIL_FUNCTION, st, t, y);
    if (j < w) dfdy[(size_t)w * dim + j] = (Rp - Rm) / (2.0 * h);
    else dfdt[w] = (Rp - Rm) / (2.0 * h);
  }
  dfdy[(size_t)w * dim + w] = 0.0;               /* nothing depends on W */
  return GSL_SUCCESS;
}

/* Level p >= 3, and contacts: central differences of the right-hand side
 * (no exact Jacobian through the level-p solve yet, constrained_series.h;
 * nor through a contact mode's saddle point, whose friction rows are not
 * those of its constraints). */
static int level_rhs_status(double t, const double *y, double *f, void *ctx)
{
  nz_ode *o = ctx;                 /* rhs() counts the evaluation */
  return rhs(t, y, f, ctx) == GSL_SUCCESS ? NZ_OK : (o->failure.status ? o->failure.status : NZ_EFUNC);
}

static int level_jacobian(nz_ode *o, double t, const double *y, double *dfdy, double *dfdt)
{
  double *work = malloc(3 * (size_t)o->dim * sizeof(double));
  if (!work) return fail(o, NZ_ODE_FAIL_FUNCTION, NZ_ENOMEM, t, y);
  int st = nz_central_jacobian(o->dim, t, y, level_rhs_status, o, dfdy, dfdt, work);
  free(work);
  if (st) return o->failure.kind ? GSL_EBADFUNC : fail(o, NZ_ODE_FAIL_FUNCTION, st, t, y);
  return GSL_SUCCESS;
}

static int jacobian(double t, const double y[], double *dfdy, double dfdt[], void *params)
{
  nz_ode *o = params;
  o->njev++;
  if (o->level || o->contacts) return level_jacobian(o, t, y, dfdy, dfdt);
  nz_accel_options opt = o->accel;
  if (o->have_last) {              /* the same root as the right-hand side */
    opt.guess_qdd = o->last;
    opt.guess_lambda = o->last + o->k;
  }
  /* A failed solve is reported as the right-hand side's (accelerations()):
   * M's eigenvalues, or the constraints' report; the first version filled
   * neither, and a singular M read "eigenvalues from 0 to 0". */
  nz_accel_report rep;
  memset(&rep, 0, sizeof rep);
  if (o->nc > 0) memset(o->involved, 0, (size_t)o->nc * sizeof(int));
  rep.involved = o->involved;           /* (A stays the right-hand side's) */
  int st = nz_ode_jacobian(o->s, o->orders, o->linear, &opt, o->work, t, y, dfdy, dfdt, &o->failure.mass, &rep);
  if (o->nc > 0 && (st == NZ_ESINGULAR || st == NZ_EARG)) {
    o->failure.accel = rep;
    return fail(o, NZ_ODE_FAIL_CONSTRAINTS, st, t, y);
  }
  if (st) return fail(o, st == NZ_ESINGULAR ? NZ_ODE_FAIL_MASS : NZ_ODE_FAIL_FUNCTION, st, t, y);
  return o->work ? work_row(o, t, y, dfdy, dfdt) : GSL_SUCCESS;
}

nz_ode *nz_ode_alloc(int k, const nz_ode_config *cfg)
{
  const gsl_odeiv2_step_type *T = step_type(cfg->method);
  if (!T) return NULL;
  nz_ode *o = calloc(1, sizeof *o);
  if (!o) return NULL;
  o->ta = o->tb = NAN;            /* no step yet: no time carries a low part */
  for (int i = 0; nz_ode_methods[i]; i++)
    if (!strcmp(nz_ode_methods[i], cfg->method)) o->method = nz_ode_methods[i];
  o->k = k;
  o->nc = cfg->nc;
  o->work = cfg->work;
  o->level = cfg->level >= 3 ? cfg->level : 0;
  o->top = o->level && cfg->top;
  o->contacts = cfg->contacts;
  o->nrows = o->contacts ? nz_contacts_bilateral(o->contacts) : cfg->nc;
  o->dim = o->top ? o->level * k : o->level ? nz_series_dim(k, cfg->nc, o->level) : 2 * k + (cfg->work ? 1 : 0);
  o->multistep = is_multistep(cfg->method);
  /* bsimp weighs each component's change by |y_i| (1 when y_i = 0) and
   * rejects a step that changes a component by more than 100 dim times its
   * size: W stays ~1e-26 for a system whose R_0 vanishes on the constraints
   * (a knife edge) and every step was rejected.  It carries W + 1 instead. */
  o->work_offset = cfg->work && !strcmp(cfg->method, "bsimp") ? 1.0 : 0.0;
  o->accel = cfg->accel;
  int nc = cfg->nc;
  o->orders = calloc((size_t)nc + 1, sizeof(int));
  o->linear = calloc((size_t)nc + 1, sizeof(int));
  o->involved = calloc((size_t)nc + 1, sizeof(int));
  o->last = calloc(2 * ((size_t)k + (size_t)nc), sizeof(double));
  o->A = calloc((size_t)nc * (size_t)k + 1, sizeof(double));
  o->Aprev = calloc(2 * (size_t)nc * (size_t)k + 1, sizeof(double));   /* and the rows at the new end */
  o->yfail = calloc((size_t)o->dim, sizeof(double));
  o->wscratch = calloc((size_t)o->dim + (size_t)k + (size_t)nc, sizeof(double));
  if (!o->orders || !o->linear || !o->involved || !o->last || !o->A || !o->Aprev || !o->yfail || !o->wscratch) {
    nz_ode_free(o);
    return NULL;
  }
  for (int r = 0; r < nc; r++) {
    o->orders[r] = cfg->orders[r];
    o->linear[r] = cfg->linear[r];
  }
  o->setup = (nz_motion_setup){ k, nc, o->orders, o->linear, o->contacts, o->accel };
  if (o->top && cfg->guess) {
    memcpy(o->last, cfg->guess, ((size_t)k + (size_t)nc) * sizeof(double));
    o->have_last = 1;
  }
  o->gsys.function = rhs;
  o->gsys.jacobian = jacobian;
  o->gsys.dimension = (size_t)o->dim;
  o->gsys.params = o;
  o->driver = gsl_odeiv2_driver_alloc_standard_new(&o->gsys, T, cfg->h0, cfg->atol, cfg->rtol, 1.0, 0.0);
  if (o->multistep)
    o->start = gsl_odeiv2_control_standard_new(NZ_ODE_START_TIGHTEN * cfg->atol, NZ_ODE_START_TIGHTEN * cfg->rtol,
                                               1.0, 0.0);
  if (!o->driver || (o->multistep && !o->start)) {
    nz_ode_free(o);
    return NULL;
  }
  return o;
}

void nz_ode_free(nz_ode *o)
{
  if (!o) return;
  if (o->driver) gsl_odeiv2_driver_free(o->driver);
  if (o->start) gsl_odeiv2_control_free(o->start);
  free(o->orders);
  free(o->linear);
  free(o->involved);
  free(o->last);
  free(o->A);
  free(o->Aprev);
  free(o->yfail);
  free(o->wscratch);
  free(o);
}

const int *nz_ode_orders(const nz_ode *o) { return o->orders; }
int nz_ode_dim(const nz_ode *o) { return o->dim; }
const char *nz_ode_method(const nz_ode *o) { return o->method; }
int nz_ode_is_multistep(const nz_ode *o) { return o->multistep; }

/* The rows of the constraints of orders 0 and 1 at each step's end,
 * compared with the last step's (nz_constraint_row_reversed says why): the
 * first reversal is recorded for simulate's warning.  Only for systems
 * with constraints; one evaluation of each row per step. */
static void check_gradients(nz_ode *o, double t, const double *y)
{
  int k = o->k, nc = o->nrows;
  if (nc == 0 || o->level || o->top) return;
  double *now = o->Aprev + (size_t)nc * (size_t)k;
  if (nz_constraint_rows_01(o->s, nc, o->orders, t, y, y + k, o->wscratch, now)) return;   /* the next solve says why */
  int r = o->have_prev && !o->reversed ? nz_constraint_row_reversed(nc, k, o->orders, o->Aprev, now) : 0;
  if (r) {
    o->reversed = r;
    o->reversed_ta = o->tprev;
    o->reversed_tb = t;
  }
  memcpy(o->Aprev, now, (size_t)nc * (size_t)k * sizeof(double));
  o->tprev = t;
  o->have_prev = 1;
}

static int finish_step(nz_ode *o, int gs, double t, const double *y)
{
  if (gs == GSL_SUCCESS) {
    for (int i = 0; i < o->dim; i++)
      if (!isfinite(y[i])) { fail(o, NZ_ODE_FAIL_NONFINITE, NZ_ERANGE, t, y); return NZ_ERANGE; }
    check_gradients(o, t, y);
    return NZ_OK;
  }
  if (o->failure.kind == NZ_ODE_FAIL_NONE) fail(o, NZ_ODE_FAIL_STEP, gs, t, y);
  return o->failure.status ? o->failure.status : NZ_EARG;
}

static void shift_work(nz_ode *o, double *y, double by)
{
  if (o->work) y[2 * o->k] += by;
}

/* The time of an adaptive step's end as t + lo (core/compensated.h), as
 * Taylor's method keeps it (taylor.c): GSL puts the end at t0 + h0
 * rounded, up to half an ulp of t a step, and over 1e8 steps those
 * roundings add up to a phase error far above the tolerance.  GSL keeps
 * the step it took (the evolve object's last_step); it is added here to
 * the double-length time of the step's start, and *t is the sum rounded.
 * A step that starts where the last one ended carries its low part, the
 * last step taken again (the loop's dense output) its start's, any other
 * start (the first, a jump) none.  A step that lands on t1 (GSL puts it
 * there exactly) keeps t1, the rest in the low part. */
static void step_time(nz_ode *o, double t0, double t1, double *t)
{
  double lo = t0 == o->tb ? o->lo_b : t0 == o->ta ? o->lo_a : 0.0, hi = t0, l = lo;
  nz_dd_add(&hi, &l, o->driver->e->last_step);
  if (*t == t1 || (hi - t1) * (t1 - t0) > 0.0) {
    l += hi - t1;
    hi = t1;
  }
  o->ta = t0, o->lo_a = lo;
  o->tb = *t = hi, o->lo_b = l;
}

int nz_ode_step(nz_ode *o, const nz_system *s, double *t, double t1, double *h, double *y)
{
  gsl_odeiv2_driver *d = o->driver;
  o->s = s;
  o->failure.kind = NZ_ODE_FAIL_NONE;
  if (!o->have_prev) check_gradients(o, *t, y);   /* the rows at the run's start */
  double t0 = *t;
  shift_work(o, y, o->work_offset);
  /* msadams and msbdf start (and restart after every reset: each contact
   * transition) at order 1, and the first steps of a start committed
   * several times the tolerance: a free fall from rest at rtol 1e-10 ended
   * 4.4e-10 off after 1 s under msadams, all of it before the order rose
   * (orders >= 2 are exact on it), and a bouncing ball's 20th bounce was
   * 1.4e-8 s off its closed form.  The first NZ_ODE_START_STEPS steps after
   * a reset, while the order is below NZ_ODE_START_ORDER, are held to the
   * tolerance times NZ_ODE_START_TIGHTEN (the driver's control swapped:
   * the multistep methods read it through the driver); the 20th bounce is
   * then 7e-12 s off, in about as many steps. */
  gsl_odeiv2_control *c = d->c;
  if (o->start && o->since_reset < NZ_ODE_START_STEPS && (int)gsl_odeiv2_step_order(d->s) < NZ_ODE_START_ORDER)
    d->c = o->start;
  o->since_reset++;
  int gs = gsl_odeiv2_evolve_apply(d->e, d->c, d->s, &o->gsys, t, t1, h, y);
  d->c = c;
  shift_work(o, y, -o->work_offset);
  if (gs == GSL_SUCCESS) step_time(o, t0, t1, t);
  return finish_step(o, gs, *t, y);
}

int nz_ode_step_fixed(nz_ode *o, const nz_system *s, double *t, double h, double *y)
{
  gsl_odeiv2_driver *d = o->driver;
  o->s = s;
  o->failure.kind = NZ_ODE_FAIL_NONE;
  if (!o->have_prev) check_gradients(o, *t, y);
  /* Explicit and implicit one-step methods take the step as it is; the
   * multistep methods read their control through the driver. */
  shift_work(o, y, o->work_offset);
  int gs = gsl_odeiv2_evolve_apply_fixed_step(d->e, o->multistep ? d->c : NULL, d->s, &o->gsys, t, h, y);
  shift_work(o, y, -o->work_offset);
  return finish_step(o, gs, *t, y);
}

void nz_ode_reset(nz_ode *o)
{
  /* GSL's reset zeroes the evolve object's counts: keep them here, so that
   * a run's statistics cover all of it. */
  o->steps0 += o->driver->e->count;
  o->rejected0 += o->driver->e->failed_steps;
  gsl_odeiv2_driver_reset(o->driver);
  o->since_reset = 0;
  if (!o->top) o->have_last = 0;  /* top: the root's branch survives a reset */
}

const double *nz_ode_root(const nz_ode *o) { return o->top && o->have_last ? o->last : NULL; }

int nz_ode_rhs(nz_ode *o, const nz_system *s, double t, const double *y, double *f)
{
  o->s = s;
  o->failure.kind = NZ_ODE_FAIL_NONE;
  int gs = rhs(t, y, f, o);
  return gs == GSL_SUCCESS ? NZ_OK : (o->failure.status ? o->failure.status : NZ_EFUNC);
}

int nz_ode_accel(nz_ode *o, const nz_system *s, double t, const double *y, double *out)
{
  o->s = s;
  o->failure.kind = NZ_ODE_FAIL_NONE;
  int st = accelerations(o, t, y, out);
  if (st && o->failure.kind == NZ_ODE_FAIL_NONE) fail(o, NZ_ODE_FAIL_FUNCTION, st, t, y);
  return st;
}

int nz_ode_jacobian_at(nz_ode *o, const nz_system *s, double t, const double *y, double *dfdy,
                       double *dfdt)
{
  o->s = s;
  o->failure.kind = NZ_ODE_FAIL_NONE;
  int gs = jacobian(t, y, dfdy, dfdt, o);
  return gs == GSL_SUCCESS ? NZ_OK : (o->failure.status ? o->failure.status : NZ_EFUNC);
}

void nz_ode_get_stats(const nz_ode *o, nz_ode_stats *st)
{
  st->steps = o->steps0 + o->driver->e->count;
  st->rejected = o->rejected0 + o->driver->e->failed_steps;
  st->nfev = o->nfev;
  st->njev = o->njev;
  st->order = (int)gsl_odeiv2_step_order(o->driver->s);
  st->reversed = o->reversed;
  st->reversed_ta = o->reversed_ta;
  st->reversed_tb = o->reversed_tb;
}

const nz_ode_failure *nz_ode_last_failure(const nz_ode *o) { return &o->failure; }
