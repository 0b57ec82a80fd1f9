/* test_stepper.c - the integrator interface (src/ode/stepper.h) driven the
 * same way for both implementations, GSL's rk8pd (stepper_gsl.c) and
 * Taylor's method (taylor.c), on the harmonic oscillator x'' = -w^2 x with
 * its closed form x = x0 cos w t + v0/w sin w t: the steps to a limit time,
 * the dense output at interior points of the last step, the accelerations,
 * the statistics, and the stepping loop of ode_run.h over each (an output
 * grid read off the dense output, an event located on Taylor's polynomial).
 * GSL's test functions print one PASS/FAIL line per check. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_math.h>
#include <gsl/gsl_test.h>
#include "core/compensated.h"
#include "core/status.h"
#include "ode/ode.h"
#include "ode/ode_run.h"
#include "ode/stepper.h"
#include "ode/taylor.h"
#include "ode/variational.h"

/* The oscillator: high-entropy constants (STYLE.md) */
static const double W = 1.37, X0 = 0.813, V0 = -0.412;

static double x_at(double t) { return X0 * cos(W * t) + V0 / W * sin(W * t); }
static double v_at(double t) { return -X0 * W * sin(W * t) + V0 * cos(W * t); }

/* The system's accel hook on doubles (mech.h): q'' = -w^2 q; the only
 * hook ode.c needs for a free system without the work monitor. */
static int osc_accel(void *ctx, double t, const double *q, const double *qd, double rcond_min, double *qdd,
                     struct nz_solve_info *info)
{
  (void)ctx, (void)t, (void)qd, (void)rcond_min, (void)info;
  qdd[0] = -W * W * q[0];
  return NZ_OK;
}

static nz_system oscillator(void)
{
  nz_system s;
  memset(&s, 0, sizeof s);
  s.k = 1;
  s.accel = osc_accel;
  return s;
}

/* Taylor's series function for it: a_{n+2} = -w^2 a_n / ((n + 1)(n + 2)). */
static int osc_series(void *ctx, const nz_system *s, double t0, const double *q0, const double *qd0, int p,
                      double *a)
{
  int *calls = ctx;
  (void)s, (void)t0;
  ++*calls;
  a[0] = q0[0];
  if (p >= 1) a[1] = qd0[0];
  for (int n = 0; n + 2 <= p; n++) a[n + 2] = -W * W * a[n] / ((n + 1.0) * (n + 2.0));
  return NZ_OK;
}

static int osc_taylor_accel(void *ctx, const nz_system *s, double t, const double *q, const double *qd, double *out)
{
  (void)ctx, (void)s, (void)t, (void)qd;
  out[0] = -W * W * q[0];
  return NZ_OK;
}

static int series_calls;

static nz_stepper *make(const char *name, double tol)
{
  if (!strcmp(name, "taylor")) {
    nz_taylor_config tc = { 1, 0, tol, tol, 0, osc_series, osc_taylor_accel, NULL, &series_calls, NULL };
    return nz_taylor_stepper_new(&tc);
  }
  nz_ode_config oc;
  memset(&oc, 0, sizeof oc);
  oc.method = name;
  oc.rtol = oc.atol = tol;
  oc.h0 = 1e-3;
  oc.accel = (nz_accel_options)NZ_ACCEL_DEFAULTS;
  return nz_stepper_gsl_new(nz_ode_alloc(1, &oc), 1, 0, tol, tol);
}

/* Steps through the interface to t1: the state against the closed form,
 * dense output at interior points of every step, the statistics. */
static void check_steps(const char *name, double tol, double bound)
{
  nz_system s = oscillator();
  nz_stepper *st = make(name, tol);
  gsl_test(st == NULL, "%s: made through the interface", name);
  if (!st) return;
  gsl_test(strcmp(st->name, name) != 0, "%s: its name (got '%s')", name, st->name);
  gsl_test(st->k != 1 || st->nc != 0 || st->dim != 2, "%s: k = 1, nc = 0, dim = 2", name);
  series_calls = 0;
  double t = 0.0, t1 = 23.7, h = 1e-3, y[2] = { X0, V0 }, yd[2], worst = 0.0, worst_dense = 0.0;
  int status = NZ_OK, nsteps = 0, dense_ok = 1;
  while (t < t1 && !status) {
    double ta = t;
    status = st->ops->step(st, &s, &t, t1, &h, y);
    if (status) break;
    nsteps++;
    worst = fmax(worst, fmax(fabs(y[0] - x_at(t)), fabs(y[1] - v_at(t))));
    for (int j = 1; j <= 3; j++) {   /* interior points of the step just taken */
      double tau = ta + (t - ta) * (0.2381 * j + 0.0137);
      int ok;
      if (st->ops->dense(st, &s, tau, yd, &ok)) dense_ok = 0;
      if (ok) worst_dense = fmax(worst_dense, fmax(fabs(yd[0] - x_at(tau)), fabs(yd[1] - v_at(tau))));
    }
  }
  gsl_test(status != NZ_OK, "%s: steps to t1 = %g (status %d)", name, t1, status);
  gsl_test(t != t1, "%s: the last step lands on t1 (t = %.17g)", name, t);
  gsl_test(!(worst <= bound), "%s at tol %g: x, x' at the step ends within %g of the closed form (%.3g)", name, tol,
           bound, worst);
  gsl_test(!dense_ok || !(worst_dense <= bound),
           "%s at tol %g: dense output inside the steps within %g of the closed form (%.3g)", name, tol, bound,
           worst_dense);
  int ok;
  gsl_test(st->ops->dense(st, &s, t1 + 1.0, yd, &ok) != NZ_EARG, "%s: dense output refuses a time past the step",
           name);
  double acc[1];
  status = st->ops->accel(st, &s, 0.0, (double[]){ X0, V0 }, acc);
  gsl_test(status || acc[0] != -W * W * X0, "%s: accel gives q'' = -w^2 q (%.17g)", name, acc[0]);
  gsl_test(st->ops->root(st) != NULL, "%s: no root (not a top integrator)", name);
  nz_stepper_stats ss;
  st->ops->stats(st, &ss);
  gsl_test(ss.steps != (unsigned long)nsteps, "%s: stats.steps = the steps taken (%lu, %d)", name, ss.steps, nsteps);
  if (!strcmp(name, "taylor")) {
    int p = nz_taylor_order(tol);
    gsl_test(ss.rejected != 0, "taylor: no rejected step (%lu)", ss.rejected);
    gsl_test(ss.order != p, "taylor: stats.order = ceil(-ln(tol)/2 + 1) = %d (%d)", p, ss.order);
    gsl_test(ss.nfev != ss.steps || series_calls != nsteps,
             "taylor: one series per step (nfev %lu, calls %d, steps %d)", ss.nfev, series_calls, nsteps);
    gsl_test(st->ops->step_fixed != NULL || !st->exact_dense, "taylor: no fixed steps; its dense output is exact");
  } else {
    gsl_test(ss.order != 8, "%s: stats.order = 8 (%d)", name, ss.order);
    /* 13 stages per step */
    gsl_test(!(ss.nfev >= 12 * ss.steps), "%s: about 13 evaluations a step (%lu for %lu steps)", name, ss.nfev,
             ss.steps);
    gsl_test(st->exact_dense || st->ops->step_fixed == NULL, "%s: fixed steps; an interpolant under control", name);
  }
  st->ops->reset(st);
  st->ops->stats(st, &ss);
  gsl_test(ss.steps != (unsigned long)nsteps, "%s: reset keeps the statistics (%lu)", name, ss.steps);
  nz_stepper_free(st);
}

/* The stepping loop over either integrator: an output grid of 201 points
 * read off the dense output (the steps the same as without it), against the
 * closed form; the zero crossings of x located (nz_run_located) at
 * (k pi - phi) / w: with Taylor on the step's polynomial, with rk8pd on its
 * interpolant or, where that misses the tolerance, by the locator (a
 * second rk8pd) integrating the step again. */
static int ev_x(void *ctx, int e, double t, const double *y, double *g)
{
  (void)ctx, (void)e, (void)t;
  *g = y[0];
  return NZ_OK;
}

static void check_run(const char *name)
{
  nz_system s = oscillator();
  nz_stepper *st = make(name, 1e-12);
  if (!st) return;
  int dirs[1] = { 0 };
  nz_run_config c;
  memset(&c, 0, sizeof c);
  c.t0 = 0.0, c.t1 = 20.0, c.dt = 0.1, c.h0 = 1e-3, c.stall_window = 1000, c.stall_fraction = 1e-10;
  c.capacity = 64, c.dense = 1, c.rtol = c.atol = 1e-12, c.event_tol = 1e-12;
  c.nevents = 1, c.directions = dirs;
  nz_stepper *loc = st->exact_dense ? NULL : make(name, 1e-13);
  c.locator = loc;
  double y0[2] = { X0, V0 };
  nz_run *r = nz_run_alloc(st, &c, y0);
  gsl_test(r == NULL, "%s: a run of the loop over it", name);
  if (!r) {
    nz_stepper_free(st);
    nz_stepper_free(loc);
    return;
  }
  nz_run_hooks hooks = { ev_x, NULL, NULL };
  nz_run_set_hooks(r, &hooks);
  /* x = A cos(w t - phi): zeros at w t = phi + pi/2 + n pi */
  double phi = atan2(V0 / W, X0);
  int npts = 0, nev = 0, located_all = 1, wrong_dir = 0, status;
  double worst = 0.0, worst_ev = 0.0;
  nz_run_status rs;
  while ((rs = nz_run_advance(r, &s, 0, 0.0, &status)) != NZ_RUN_DONE) {
    if (rs == NZ_RUN_EVENT) {
      int e;
      double te;
      const double *ye;
      int dir;
      if (nz_run_located(r, &e, &te, &ye, &dir)) {
        double n = round((W * te - phi - M_PI / 2) / M_PI);
        worst_ev = fmax(worst_ev, fmax(fabs(te - (phi + M_PI / 2 + n * M_PI) / W), fabs(ye[0])));
        /* x' = -A w sin(w t - phi) = -A w (-1)^n there: falling for even n */
        wrong_dir += dir != ((long)n % 2 == 0 ? -1 : 1);
      } else located_all = 0;
      nev++;
      continue;
    }
    if (rs != NZ_RUN_FULL) break;
    for (int i = 0; i < nz_run_count(r); i++, npts++) {
      double t;
      const double *y, *acc, *root;
      nz_run_point(r, i, &t, &y, &acc, &root);
      worst = fmax(worst, fmax(fabs(y[0] - x_at(t)), fabs(acc[0] + W * W * y[0])));
    }
    nz_run_clear(r);
  }
  for (int i = 0; i < nz_run_count(r); i++, npts++) {
    double t;
    const double *y, *acc, *root;
    nz_run_point(r, i, &t, &y, &acc, &root);
    worst = fmax(worst, fmax(fabs(y[0] - x_at(t)), fabs(acc[0] + W * W * y[0])));
  }
  gsl_test(rs != NZ_RUN_DONE, "%s: the run reaches t1 (status %d)", name, (int)rs);
  gsl_test(npts != 201, "%s: 201 output points (%d)", name, npts);
  /* tol 1e-12 over ~4.4 periods: measured 1.3e-14 (taylor), 6.4e-13
   * (rk8pd); bound 100 tolerances */
  gsl_test(!(worst <= 1e-10), "%s: output points within 1e-10 of the closed form (%.3g)", name, worst);
  /* 20 w / pi = 8.7: 9 zeros in [0, 20] */
  gsl_test(nev != 9, "%s: 9 zero crossings reported (%d)", name, nev);
  gsl_test(!located_all || !(worst_ev <= 1e-11),
           "%s: each located within 1e-11 of (n pi + pi/2 + phi) / w (%.3g)", name, worst_ev);
  gsl_test(wrong_dir != 0, "%s: each said rising or falling as x' says (%d wrong)", name, wrong_dir);
  /* a point the interpolant's control made a step end costs a step taken
   * again, which the integrator counts too */
  nz_stepper_stats ss;
  unsigned long interpolated, forced;
  st->ops->stats(st, &ss);
  nz_run_dense_stats(r, &interpolated, &forced);
  gsl_test(nz_run_steps(r) + forced != ss.steps, "%s: the loop's steps and the retaken ones are the integrator's "
           "(%lu + %lu, %lu)", name, nz_run_steps(r), forced, ss.steps);
  if (st->exact_dense) gsl_test(forced != 0, "%s: no point made a step end (%lu)", name, forced);
  nz_run_free(r);
  nz_stepper_free(st);
  nz_stepper_free(loc);
}

/* A clock behind the interface, for the loop's fixed steps: its state is
 * the time it was stepped through, summed without loss (y[0] + y[1], a
 * double-length number), whatever steps the loop asks for. */
static int clock_step_fixed(nz_stepper *st, const nz_system *s, double *t, double h, double *y)
{
  (void)st, (void)s;
  nz_dd_add(&y[0], &y[1], h);
  *t += h;
  return NZ_OK;
}
static int clock_accel(nz_stepper *st, const nz_system *s, double t, const double *y, double *out)
{
  (void)st, (void)s, (void)t, (void)y;
  out[0] = 0.0;
  return NZ_OK;
}
static void clock_stats(const nz_stepper *st, nz_stepper_stats *out)
{
  (void)st;
  memset(out, 0, sizeof *out);
  out->order = 1;
}
static const double *clock_root(const nz_stepper *st)
{
  (void)st;
  return NULL;
}
static void clock_nothing(nz_stepper *st) { (void)st; }
static const nz_stepper_ops clock_ops = { NULL, clock_step_fixed, NULL, clock_accel, clock_root, clock_stats,
                                          clock_nothing, clock_nothing };

/* The loop's fixed steps sum to every output time to the last bit: 1/7 of
 * an output interval of 0.1 (neither representable) from t0 = 0.3, over
 * 1e5 intervals (7e5 steps): at each output point the clock's exact sum
 * is t - t0 within an ulp of the step (the rest's rounding, carried to the
 * next interval; measured 0).  Equal steps of the rounded interval / 7
 * ended each interval 7 times their rounding away: 8e-14 after these 1e5
 * intervals. */
static void check_fixed_time(void)
{
  nz_stepper clk = { &clock_ops, "clock", 1, 0, 2, 0 };
  nz_system s = oscillator();
  nz_run_config c;
  memset(&c, 0, sizeof c);
  c.t0 = 0.3, c.dt = 0.1, c.t1 = c.t0 + 1e5 * c.dt, c.step = c.dt / 7, c.h0 = c.step;
  c.stall_window = 1000000, c.capacity = 4096;
  double y0[2] = { 0.0, 0.0 };
  nz_run *r = nz_run_alloc(&clk, &c, y0);
  gsl_test(r == NULL, "fixed steps: a run of the loop over a clock");
  if (!r) return;
  nz_run_hooks hooks = { NULL, NULL, NULL };
  nz_run_set_hooks(r, &hooks);
  double worst = 0.0, tlast = 0.0;
  int npts = 0, status, wrong_t = 0;
  nz_run_status rs;
  do {
    rs = nz_run_advance(r, &s, 0, 0.0, &status);
    for (int i = 0; i < nz_run_count(r); i++, npts++) {
      double t;
      const double *y, *acc, *root;
      nz_run_point(r, i, &t, &y, &acc, &root);
      /* (y0 + y1) - (t - t0), each difference exact in double-length */
      double hi = y[0], lo = y[1];
      nz_dd_add(&hi, &lo, -t);
      nz_dd_add(&hi, &lo, c.t0);
      worst = fmax(worst, fabs(hi + lo));
      wrong_t += npts > 0 && t != (npts == 100000 ? c.t1 : c.t0 + npts * c.dt);
      tlast = t;
    }
    nz_run_clear(r);
  } while (rs == NZ_RUN_FULL);
  gsl_test(rs != NZ_RUN_DONE || npts != 100001 || tlast != c.t1, "fixed steps: 100001 output points to t1 (%d)", npts);
  gsl_test(wrong_t != 0, "fixed steps: every output time is t0 + i dt (%d are not)", wrong_t);
  gsl_test(!(worst <= 2.8e-17), "fixed steps: the steps sum to each output time within an ulp of the step "
           "(2.8e-17), over 7e5 steps (%.3g)", worst);
  nz_run_free(r);
}

/* An adaptive step's end is t0 + h rounded, half an ulp of t each time:
 * from t0 = 2^20 (ulp 2.3e-10) the oscillator's phase, read at the output
 * times, carries the sum of those roundings unless the integrator keeps
 * its time to twice the precision.  rk8pd and Taylor at 1e-13 over t0 ..
 * t0 + 500 (~100 periods), against the closed form in t - t0. */
static void check_adaptive_time(const char *name)
{
  nz_system s = oscillator();
  nz_stepper *st = make(name, 1e-13);
  nz_run_config c;
  memset(&c, 0, sizeof c);
  c.t0 = 1048576.0, c.t1 = c.t0 + 500.0, c.dt = 0.5, c.h0 = 1e-3, c.stall_window = 100000, c.stall_fraction = 1e-12;
  c.capacity = 4096, c.dense = 1, c.rtol = c.atol = 1e-13;
  double y0[2] = { X0, V0 };
  nz_run *r = nz_run_alloc(st, &c, y0);
  gsl_test(r == NULL, "%s: a run from t0 = 2^20", name);
  if (!r) {
    nz_stepper_free(st);
    return;
  }
  nz_run_hooks hooks = { NULL, NULL, NULL };
  nz_run_set_hooks(r, &hooks);
  double worst = 0.0;
  int status;
  nz_run_status rs;
  do {
    rs = nz_run_advance(r, &s, 0, 0.0, &status);
    for (int i = 0; i < nz_run_count(r); i++) {
      double t;
      const double *y, *acc, *root;
      nz_run_point(r, i, &t, &y, &acc, &root);
      worst = fmax(worst, fabs(y[0] - x_at(t - c.t0)));
    }
    nz_run_clear(r);
  } while (rs == NZ_RUN_FULL);
  /* measured 1.4e-10 (rk8pd) and 5.6e-14 (taylor) with the time kept
   * double-length; rk8pd with t0 + h rounded: 3.3e-7.  Bound 1e-9 */
  gsl_test(rs != NZ_RUN_DONE || !(worst <= 1e-9), "%s: from t0 = 2^20, the phase at t0 + 500 within 1e-9 of the "
           "closed form in t - t0 (%.3g)", name, worst);
  nz_run_free(r);
  nz_stepper_free(st);
}

/* The variational integrator's explicit path (verlet = 1) through the
 * interface, on the oscillator x'' = -w^2 x from x' = 0: the trapezoidal
 * discrete Lagrangian's solution is x_n = x0 cos(n theta) with cos(theta)
 * = 1 - (w h)^2 / 2, to rounding; each composition's fractions sum to 1
 * and read the same backwards (symmetric); the loop refuses it adaptive
 * steps. */
static void check_variational(void)
{
  for (int p = 2; p <= 8; p += 2) {
    int n;
    const double *g = nz_variational_gammas(p, &n);
    double sum = 0.0, asym = 0.0;
    for (int i = 0; i < n; i++) sum += g[i], asym = fmax(asym, fabs(g[i] - g[n - 1 - i]));
    gsl_test(!g || fabs(sum - 1.0) > 4e-16 || asym != 0.0, "variational order %d: %d fractions, sum 1 (%.17g), symmetric",
             p, n, sum);
  }
  nz_variational_config vc;
  memset(&vc, 0, sizeof vc);
  vc.setup.k = 1;
  vc.setup.opt = (nz_accel_options)NZ_ACCEL_DEFAULTS;
  vc.order = 2;
  vc.verlet = 1;
  nz_stepper *st = nz_variational_new(&vc);
  gsl_test(st == NULL || st->ops->step != NULL || st->ops->step_fixed == NULL,
           "variational: made, with fixed steps only");
  if (!st) return;
  nz_system s = oscillator();
  double y[2] = { X0, 0.0 }, t = 0.0, h = 0.05, worst = 0.0;
  double theta = 2.0 * asin(W * h / 2.0);   /* cos(theta) = 1 - (w h)^2 / 2, well conditioned */
  int status = 0;
  for (int n = 1; n <= 2000 && !status; n++) {
    status = st->ops->step_fixed(st, &s, &t, h, y);
    worst = fmax(worst, fabs(y[0] - X0 * cos(n * theta)));
  }
  nz_stepper_stats ss;
  st->ops->stats(st, &ss);
  /* measured 1.9e-14 (the closed form's cos(n theta) carries ~1e-14 at n theta ~ 140) */
  gsl_test(status || !(worst <= 1e-12), "variational: 2000 steps of the oscillator on x0 cos(n theta), cos(theta) = "
           "1 - (w h)^2 / 2 (%.3g)", worst);
  gsl_test(ss.steps != 2000 || ss.nfev != 2001 || ss.order != 2, "variational: 2000 steps, 2001 evaluations of q'' "
           "(the end of one step serves the next), order 2 (%lu, %lu, %d)", ss.steps, ss.nfev, ss.order);
  /* dense output: the cubic Hermite of the last step's ends, those ends
   * themselves at ta and tb, q' its derivative, NZ_EARG outside */
  double ya[2], yb[2], ym[2], yl[2], yr[2], ta = t - h, tm = t - h / 3, e = 1e-3 * h;
  int ok1, ok2, ok3, ok4, ok5, out;
  int st1 = st->ops->dense(st, &s, ta, ya, &ok1) || st->ops->dense(st, &s, t, yb, &ok2) ||
            st->ops->dense(st, &s, tm, ym, &ok3) || st->ops->dense(st, &s, tm - e, yl, &ok4) ||
            st->ops->dense(st, &s, tm + e, yr, &ok5);
  double fd = (yr[0] - yl[0]) / ((tm + e) - (tm - e));   /* the times as rounded (ulp(t) = 1.4e-14 at t = 100) */
  out = st->ops->dense(st, &s, t + h, ym, &ok1);
  gsl_test(st1 || !(ok2 && ok3 && ok4 && ok5) || yb[0] != y[0] || yb[1] != y[1] || !(fabs(fd - ym[1]) <= 1e-8) ||
           out != NZ_EARG, "variational: dense output ends on the step's end, its q' the derivative of its q "
           "(%.3g), refused past the step", fabs(fd - ym[1]));
  nz_run_config c;
  memset(&c, 0, sizeof c);
  c.t0 = 0.0, c.t1 = 1.0, c.dt = 0.5, c.h0 = 1e-3, c.stall_window = 1000, c.capacity = 4;
  double y0[2] = { X0, V0 };
  nz_run *r = nz_run_alloc(st, &c, y0);
  gsl_test(r != NULL, "the loop refuses adaptive steps for an integrator with fixed steps only");
  nz_run_free(r);
  nz_stepper_free(st);
}

/* What the interface refuses. */
static void check_refusals(void)
{
  nz_taylor_config bad = { 1, 0, 0.0, 0.0, 0, osc_series, osc_taylor_accel, NULL, NULL, NULL };
  gsl_test(nz_taylor_stepper_new(&bad) != NULL, "taylor: refuses rtol = atol = 0");
  nz_stepper *st = make("taylor", 1e-10);
  nz_run_config c;
  memset(&c, 0, sizeof c);
  c.t0 = 0.0, c.t1 = 1.0, c.dt = 0.5, c.h0 = 1e-3, c.stall_window = 1000, c.capacity = 4, c.step = 0.1;
  double y0[2] = { X0, V0 };
  nz_run *r = nz_run_alloc(st, &c, y0);
  gsl_test(r != NULL, "the loop refuses a fixed step for an integrator without fixed steps");
  nz_run_free(r);
  nz_stepper_free(st);
  nz_stepper_free(NULL);
  gsl_test(0, "nz_stepper_free(NULL) is harmless");
}

int main(void)
{
  gsl_test_verbose(1);
  gsl_set_error_handler_off();
  /* tol 1e-12 over 23.7 (~5 periods): measured 1.9e-14 (taylor) and
   * 9.9e-13 (rk8pd, whose dense output is as good as its step ends);
   * bound 100 tolerances; at 1e-6 taylor measured 4.4e-8 */
  check_steps("taylor", 1e-12, 1e-10);
  check_steps("rk8pd", 1e-12, 1e-10);
  check_steps("taylor", 1e-6, 1e-4);
  check_run("taylor");
  check_run("rk8pd");
  check_fixed_time();
  check_variational();
  check_adaptive_time("rk8pd");
  check_adaptive_time("taylor");
  check_refusals();
  return gsl_test_summary();
}
