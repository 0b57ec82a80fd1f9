/* taylor_motion.c - Taylor's method for the motion of a mechanical system
 * (see taylor_motion.h). */
#include <stdlib.h>
#include <string.h>
#include "mech/constrained.h"
#include "mech/contact.h"
#include "ode/taylor_motion.h"

/* The context of the series, accel and check functions: one block, freed
 * with the stepper; it keeps the outcome of the last solve that failed. */
typedef struct motion_ctx {
  nz_motion_setup setup;     /* its arrays point into this block           */
  double *qdd, *lam;         /* the start's, k and nc                        */
  nz_motion_outcome oc;      /* of the last solve                            */
  int failed;                /* the last series or output point failed in a solve */
  double *A, *Aend;          /* nc x k each: the rows at the step's start and at its end */
  double *zero;              /* k zeros: q'' for the rows of orders 0 and 1 */
  int have_start;            /* A holds a step's start                       */
  double t;                  /* where the last solve failed                  */
  double *q, *qd;            /* the state there (k each)                     */
  int *rows, *couple;        /* a contact mode's rows (nz_contacts_active)   */
  double *coef, *lam_sel;
} motion_ctx;

/* q'' and lambda at (t, q, qd) into qdd, lam, A the rows of the solve. */
static int solve(motion_ctx *c, const nz_system *s, double t, const double *q, const double *qd, double *qdd,
                 double *lam)
{
  int st = nz_motion_accel(s, &c->setup, t, q, qd, NULL, qdd, lam, &c->oc);
  c->failed = c->oc.failed != NZ_MOTION_OK;
  if (st) {
    int k = c->setup.k;
    c->t = t;
    memcpy(c->q, q, (size_t)k * sizeof(double));
    memcpy(c->qd, qd, (size_t)k * sizeof(double));
  }
  return st;
}

/* The stepper's look at each step's end: 1 + a constraint whose row
 * reversed since the step's start (the rows of its solve, c->A), or 0. */
static int check_end(void *ctx, const nz_system *s, double t, const double *q, const double *qd)
{
  motion_ctx *c = ctx;
  const nz_motion_setup *a = &c->setup;
  if (!c->have_start) return 0;
  if (nz_constraint_rows_01(s, a->nc, a->orders, t, q, qd, c->zero, c->Aend)) return 0;   /* the next solve says why */
  return nz_constraint_row_reversed(a->nc, a->k, a->orders, c->A, c->Aend);
}

static int motion_series(void *ctx, const nz_system *s, double t0, const double *q0, const double *qd0, int p,
                         double *a)
{
  motion_ctx *c = ctx;
  const nz_motion_setup *m = &c->setup;
  int k = m->k;
  c->failed = 0;
  if (!s->series) return NZ_EARG;
  if (m->nc == 0) return s->series(s->mass_bias_ctx, NULL, NULL, t0, q0, qd0, NULL, NULL, p, a);
  int st = solve(c, s, t0, q0, qd0, c->qdd, c->lam);
  if (st) return st;
  c->have_start = !m->contacts;          /* c->A: the rows at the step's start, for check_end */
  if (p < 2) {
    memcpy(a, q0, (size_t)k * sizeof(double));
    if (p >= 1) memcpy(a + k, qd0, (size_t)k * sizeof(double));
    return NZ_OK;
  }
  if (!m->contacts) return s->series(s->mass_bias_ctx, m->orders, NULL, t0, q0, qd0, c->qdd, c->lam, p, a);
  /* a contact mode: the free motion's series when it holds no row, else the
   * constrained one on the rows it holds, friction riding on the normal
   * forces of the sliding contacts */
  int na = nz_contacts_active(m->contacts, c->rows, c->couple, c->coef);
  if (na < 0) return NZ_EARG;                  /* (the contacts say why) */
  if (na == 0) return s->series(s->mass_bias_ctx, NULL, NULL, t0, q0, qd0, NULL, NULL, p, a);
  for (int x = 0; x < na; x++) c->lam_sel[x] = c->lam[c->rows[x]];
  nz_series_selection sel = { na, c->rows, c->couple, c->coef };
  return s->series(s->mass_bias_ctx, m->orders, &sel, t0, q0, qd0, c->qdd, c->lam_sel, p, a);
}

/* q'' and lambda at an output point, by the solve the GSL steppers record with. */
static int accel_at(void *ctx, const nz_system *s, double t, const double *q, const double *qd, double *out)
{
  motion_ctx *c = ctx;
  return solve(c, s, t, q, qd, out, out + c->setup.k);
}

static void ctx_free(void *ctx) { free(ctx); }

/* The block: the context, then its doubles, then its ints. */
static motion_ctx *ctx_new(const nz_motion_setup *m)
{
  size_t k = (size_t)m->k, nc = (size_t)m->nc;
  size_t doubles = 5 * k + 2 * (nc + 1) + 2 * nc * k + 2 * (nc + 1), ints = 5 * (nc + 1);
  motion_ctx *c = calloc(1, sizeof *c + doubles * sizeof(double) + ints * sizeof(int));
  if (!c) return NULL;
  double *d = (double *)(void *)(c + 1);
  int *iw = (int *)(void *)(d + doubles);
  c->setup = *m;
  c->qdd = d, c->q = d + k, c->qd = d + 2 * k, c->zero = d + 3 * k;
  c->lam = d + 4 * k;
  c->A = c->lam + nc + 1;
  c->Aend = c->A + nc * k;
  c->coef = c->Aend + nc * k;
  c->lam_sel = c->coef + nc + 1;
  if (nc > 0) {
    memcpy(iw, m->orders, nc * sizeof(int));
    memcpy(iw + nc + 1, m->linear, nc * sizeof(int));
    c->setup.orders = iw;
    c->setup.linear = iw + nc + 1;
  } else c->setup.orders = c->setup.linear = NULL;
  c->oc.rep.involved = iw + 2 * (nc + 1);   /* read by the error that names dependent constraints */
  c->oc.rep.A = c->A;
  c->rows = iw + 3 * (nc + 1);
  c->couple = iw + 4 * (nc + 1);
  return c;
}

nz_stepper *nz_taylor_motion_new(const nz_taylor_motion_config *cfg)
{
  const nz_motion_setup *m = &cfg->setup;
  if (m->k < 1 || m->nc < 0 || (m->nc > 0 && (!m->orders || !m->linear))) return NULL;
  motion_ctx *c = ctx_new(m);
  if (!c) return NULL;
  nz_taylor_config tc;
  memset(&tc, 0, sizeof tc);
  tc.k = m->k;
  tc.nc = m->nc;
  tc.rtol = cfg->rtol;
  tc.atol = cfg->atol;
  tc.order = cfg->order;
  tc.series = motion_series;
  tc.accel = accel_at;
  /* the rows' check only where there are constraints, and not across the
   * changes of a contact mode (each restarts the step's rows) */
  tc.check = m->nc > 0 && !m->contacts ? check_end : NULL;
  tc.ctx = c;
  tc.ctx_free = ctx_free;
  nz_stepper *st = nz_taylor_stepper_new(&tc);
  if (!st) free(c);
  return st;
}

int nz_taylor_motion_series(nz_stepper *st, const nz_system *s, double t0, const double *q0, const double *qd0, int p,
                            double *a)
{
  return motion_series(nz_taylor_ctx(st), s, t0, q0, qd0, p, a);
}

const nz_motion_outcome *nz_taylor_motion_failure(nz_stepper *st, double *t, const double **q, const double **qd)
{
  motion_ctx *c = nz_taylor_ctx(st);
  if (!c->failed) return NULL;
  *t = c->t;
  *q = c->q;
  *qd = c->qd;
  return &c->oc;
}

const nz_motion_setup *nz_taylor_motion_setup(nz_stepper *st) { return &((motion_ctx *)nz_taylor_ctx(st))->setup; }
