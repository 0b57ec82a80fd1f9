/* stepper_gsl.c - GSL's steppers behind the integrator interface
 * (stepper.h): the steps are ode.c's, the dense output the Hermite
 * interpolant of ode_run.h over the step and the one or two steps before
 * it, from q, q', q'' (and y, f for the rest of the state) at their ends.
 *
 * The interpolant's nodes are four slots of (t, y, f) rotated from step to
 * step: the starts of the two steps before (sp, sq: nprev of them joined
 * on), the step's start (sa) and its end (sb).  A step that starts where
 * the last one ended, with the same state, joins it on; one that starts
 * from the last step's start is that step taken again (the loop's error
 * control made a point a step end); any other start (a projection moved
 * the state, or the first step) begins afresh.  f at a node is evaluated
 * only when an interpolant needs it, so that a run without dense output
 * costs nothing here. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "ode/ode.h"
#include "ode/stepper.h"

typedef struct slot { double t; double *y, *f; int f_ok; } slot;

typedef struct gsl_stepper {
  nz_stepper base;
  nz_ode *o;
  double rtol, atol;
  slot slots[4], *sq, *sp, *sa, *sb;
  int nprev, have_sa, have_sb;
  double *coef, z[4];             /* the step's divided differences (dim x 12), its nodes */
  int coef_ok;
} gsl_stepper;

static gsl_stepper *as_gsl(nz_stepper *st) { return (gsl_stepper *)st; }

/* (t, y) is the slot's, bit for bit (a comparison of doubles would take
 * -0 for 0: as good, but this is what "the same state" means here); a loop,
 * not memcmp: dim is small and this runs every step. */
static int same_state(const slot *sl, int dim, double t, const double *y)
{
  if (sl->t != t) return 0;
  for (int i = 0; i < dim; i++) {
    uint64_t a, b;
    memcpy(&a, &sl->y[i], sizeof a);
    memcpy(&b, &y[i], sizeof b);
    if (a != b) return 0;
  }
  return 1;
}

/* The slots for a step from (t, y): joined on, taken again, or afresh. */
static void start_step(gsl_stepper *g, double t, const double *y)
{
  int dim = g->base.dim;
  if (g->have_sb && same_state(g->sb, dim, t, y)) {   /* the last step's end starts this one */
    slot *tmp = g->sq;
    g->sq = g->sp;
    g->sp = g->sa;
    g->sa = g->sb;
    g->sb = tmp;
    g->nprev = g->nprev < 2 ? g->nprev + 1 : 2;
    g->have_sb = 0;
  } else if (!(g->have_sa && same_state(g->sa, dim, t, y))) {   /* not the last step taken again */
    g->sa->t = t;
    memcpy(g->sa->y, y, (size_t)dim * sizeof(double));
    g->sa->f_ok = 0;
    g->nprev = 0;
    g->have_sa = 1;
    g->have_sb = 0;
  }
}

static void end_step(gsl_stepper *g, double t, const double *y)
{
  g->sb->t = t;
  memcpy(g->sb->y, y, (size_t)g->base.dim * sizeof(double));
  g->sb->f_ok = 0;
  g->have_sb = 1;
  g->coef_ok = 0;
}

static int gsl_step(nz_stepper *st, const nz_system *s, double *t, double tlimit, double *h, double *y)
{
  gsl_stepper *g = as_gsl(st);
  start_step(g, *t, y);
  int status = nz_ode_step(g->o, s, t, tlimit, h, y);
  if (!status) end_step(g, *t, y);
  return status;
}

static int gsl_step_fixed(nz_stepper *st, const nz_system *s, double *t, double h, double *y)
{
  gsl_stepper *g = as_gsl(st);
  start_step(g, *t, y);
  int status = nz_ode_step_fixed(g->o, s, t, h, y);
  if (!status) end_step(g, *t, y);
  return status;
}

/* One component's Hermite interpolant in Newton form: ng (<= 4) groups of
 * nodes z[g], each of multiplicity m (2 or 3), with d[3 g + j] the j-th
 * derivative there; c gets the m ng coefficients.  Its last Newton term
 * (what the last node condition adds: the error of the polynomial without
 * it) is the error estimate, on the safe side.  (The terms of a whole last
 * group, the error of the polynomial of one step fewer, were tried: on a
 * pendulum at rtol 1e-12 they made 2487 of 20000 output points step ends,
 * for errors 3x below the run's own at its step ends; the last term makes
 * 40 of them step ends and keeps the points' error at the step ends'
 * (1.4e-11 against 1.2e-11), see tests/simulate_dense_spec.lua.) */
static void hermite_coef(int m, int ng, const double *z, const double *d, double *c)
{
  static const double fact[] = { 1.0, 1.0, 2.0 };
  int n = m * ng;
  for (int j = 0; j < n; j++) c[j] = d[3 * (j / m)];
  /* Divided differences, a column at a time, in place from the bottom: over
   * nodes of one group (o < m there) they are the derivatives over o!. */
  for (int o = 1; o < n; o++)
    for (int j = n - 1; j >= o; j--)
      c[j] = j / m == (j - o) / m ? d[3 * (j / m) + o] / fact[o] : (c[j] - c[j - 1]) / (z[j / m] - z[(j - o) / m]);
}

/* The interpolant at tau: the Newton form's partial sums over the first
 * 2, 3, ... ng groups are the interpolants of those nodes alone (the
 * coefficients of a node do not depend on the nodes after it), each with
 * its last term as its estimate; out gets the one whose estimate, relative
 * to atol + rtol |value| (and |derivative| when the derivative is an output,
 * deriv), is the smallest.  The highest degree is the most accurate on a
 * smooth motion; a lower one wins where the step ends carry errors (at the
 * tolerance, not smooth from step to step) that a high-degree polynomial
 * amplifies: bsimp, msbdf, msadams. */
static void hermite_eval(int m, int ng, const double *z, const double *c, double tau, double atol, double rtol,
                         int deriv, double out[4])
{
  int n = m * ng;
  double w = 1.0, dw = 0.0, v = 0.0, dv = 0.0, best = HUGE_VAL;
  for (int j = 0; j < n; j++) {
    v += c[j] * w;
    dv += c[j] * dw;
    if (j >= 2 * m - 1 && (j + 1) % m == 0) {  /* the interpolant of the first (j + 1) / m groups */
      double e = c[j] * w, de = c[j] * dw;
      double ratio = fabs(e) / (atol + rtol * fabs(v));
      if (deriv) ratio = fmax(ratio, fabs(de) / (atol + rtol * fabs(dv)));
      if (!(ratio >= best)) {               /* NaN: taken, for the caller to refuse */
        best = ratio;
        out[0] = v;
        out[1] = dv;
        out[2] = e;
        out[3] = de;
      }
    }
    dw = dw * (tau - z[j / m]) + w;
    w *= tau - z[j / m];
  }
}

static int slot_f(gsl_stepper *g, const nz_system *s, slot *sl)
{
  if (sl->f_ok) return NZ_OK;
  int st = nz_ode_rhs(g->o, s, sl->t, sl->y, sl->f);
  sl->f_ok = st == NZ_OK;
  return st;
}

/* The divided differences of the step's interpolant, once per step (12 per
 * component), for every output point and event time inside it. */
static int dense_coef(gsl_stepper *g, const nz_system *s)
{
  if (g->coef_ok) return NZ_OK;
  slot *sl[4] = { g->sa, g->sb, g->sp, g->sq };
  int ng = 2 + g->nprev, k = g->base.k, dim = g->base.dim, st;
  for (int j = 0; j < ng; j++)
    if ((st = slot_f(g, s, sl[j]))) return st;
  double d[12];
  for (int j = 0; j < ng; j++) g->z[j] = sl[j]->t;
  for (int i = 0; i < k; i++) {
    for (int j = 0; j < ng; j++) {
      d[3 * j] = sl[j]->y[i];
      d[3 * j + 1] = sl[j]->y[k + i];
      d[3 * j + 2] = sl[j]->f[k + i];
    }
    hermite_coef(3, ng, g->z, d, g->coef + 12 * i);
  }
  for (int i = 2 * k; i < dim; i++) {
    for (int j = 0; j < ng; j++) {
      d[3 * j] = sl[j]->y[i];
      d[3 * j + 1] = sl[j]->f[i];
    }
    hermite_coef(2, ng, g->z, d, g->coef + 12 * i);
  }
  g->coef_ok = 1;
  return NZ_OK;
}

/* The state at tau from the interpolant of the step from sa to sb (joined
 * with the nprev steps before): *ok when every component's estimate meets
 * atol + rtol |y_i|.  q from (q, q', q''), q' as its derivative, every
 * other component from (y, f). */
static int gsl_dense(nz_stepper *st, const nz_system *s, double tau, double *y, int *ok)
{
  gsl_stepper *g = as_gsl(st);
  *ok = 0;
  if (!g->have_sb || !(tau >= g->sa->t && tau <= g->sb->t)) return NZ_EARG;
  int status = dense_coef(g, s);
  if (status) return status;
  int ng = 2 + g->nprev, k = st->k;
  double out[4], rtol = g->rtol, atol = g->atol;
  *ok = 1;
  for (int i = 0; i < k; i++) {
    hermite_eval(3, ng, g->z, g->coef + 12 * i, tau, atol, rtol, 1, out);
    y[i] = out[0];
    y[k + i] = out[1];
    if (!(fabs(out[2]) <= atol + rtol * fabs(out[0])) || !(fabs(out[3]) <= atol + rtol * fabs(out[1]))) *ok = 0;
  }
  for (int i = 2 * k; i < st->dim; i++) {
    hermite_eval(2, ng, g->z, g->coef + 12 * i, tau, atol, rtol, 0, out);
    y[i] = out[0];
    if (!(fabs(out[2]) <= atol + rtol * fabs(out[0]))) *ok = 0;
  }
  return NZ_OK;
}

static int gsl_accel(nz_stepper *st, const nz_system *s, double t, const double *y, double *out)
{
  return nz_ode_accel(as_gsl(st)->o, s, t, y, out);
}

static const double *gsl_root(const nz_stepper *st) { return nz_ode_root(((const gsl_stepper *)st)->o); }

static void gsl_stats(const nz_stepper *st, nz_stepper_stats *out)
{
  nz_ode_stats os;
  nz_ode_get_stats(((const gsl_stepper *)st)->o, &os);
  out->steps = os.steps;
  out->rejected = os.rejected;
  out->nfev = os.nfev;
  out->njev = os.njev;
  out->order = os.order;
  out->reversed = os.reversed;
  out->reversed_ta = os.reversed_ta;
  out->reversed_tb = os.reversed_tb;
}

static void gsl_reset(nz_stepper *st) { nz_ode_reset(as_gsl(st)->o); }

static void gsl_free(nz_stepper *st)
{
  gsl_stepper *g = as_gsl(st);
  nz_ode_free(g->o);
  free(g->coef);
  for (int j = 0; j < 4; j++) {
    free(g->slots[j].y);
    free(g->slots[j].f);
  }
  free(g);
}

static const nz_stepper_ops gsl_ops = {
  gsl_step, gsl_step_fixed, gsl_dense, gsl_accel, gsl_root, gsl_stats, gsl_reset, gsl_free
};

nz_stepper *nz_stepper_gsl_new(nz_ode *o, int k, int nc, double rtol, double atol)
{
  if (!o) return NULL;
  gsl_stepper *g = calloc(1, sizeof *g);
  if (!g) {
    nz_ode_free(o);
    return NULL;
  }
  g->o = o;
  g->base.ops = &gsl_ops;
  g->base.name = nz_ode_method(o);
  g->base.k = k;
  g->base.nc = nc;
  g->base.dim = nz_ode_dim(o);
  g->rtol = rtol;
  g->atol = atol;
  size_t dim = (size_t)g->base.dim;
  int bad = !(g->coef = malloc(12 * dim * sizeof(double)));
  for (int j = 0; j < 4; j++) {
    g->slots[j].y = malloc(dim * sizeof(double));
    g->slots[j].f = malloc(dim * sizeof(double));
    bad |= !g->slots[j].y || !g->slots[j].f;
  }
  if (bad) {
    gsl_free(&g->base);
    return NULL;
  }
  g->sq = &g->slots[0];
  g->sp = &g->slots[1];
  g->sa = &g->slots[2];
  g->sb = &g->slots[3];
  return &g->base;
}

nz_ode *nz_stepper_gsl_ode(nz_stepper *st) { return as_gsl(st)->o; }
