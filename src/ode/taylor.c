/* taylor.c - Taylor's method with dense output (taylor.h).
 *
 * Order and step size follow A. Jorba and M. Zou, "A software package for
 * the numerical integration of ODEs by means of high-order Taylor methods",
 * Experimental Mathematics 14 (2005), section 3.2, as heyoka does.
 *
 * The state is x = (q, q'), 2k values; its Taylor coefficient of order j is
 * x^[j] = (a_j, (j + 1) a_{j+1}).
 *
 * Tolerance.  GSL's steppers accept a step when every component's error is
 * at most atol + rtol |y_i|.  The series gives no error per component, only
 * the size of its coefficients; so each component of the state x = (q, q')
 * is measured against its own scale
 *   s_i = max(|x_i|, atol / rtol)   (s_i = 1 when rtol = 0),
 * and the tolerance asked of every component is eps = rtol (atol when rtol
 * = 0): the error of x_i is held to about max(atol, rtol |x_i|), within a
 * factor 2 of GSL's atol + rtol |x_i|.  (Jorba and Zou, and heyoka, measure
 * the whole state with one max norm; then a large component, an angle that
 * grows without bound, loosens the tolerance of every small one: Kepler's r
 * lost three digits over 100 orbits that way.)  A component at exactly 0
 * with atol = 0 takes the largest component as its scale.
 *
 * Order.  p = ceil(-ln(eps) / 2 + 1) (Jorba and Zou's eq. 3.5): with the
 * step below, the last term kept is about s e^(-2p) <= s eps e^(-2).
 *
 * Step.  If x_i behaves like a function analytic in a disc of radius rho
 * around t, bounded by about s_i, its coefficients are |x_i^[j]| ~ s_i
 * rho^-j; the two last ones estimate rho, the smallest over the components:
 *   rho = min( (min_i s_i / |x_i^[p-1]|)^(1/(p-1)), (min_i s_i / |x_i^[p]|)^(1/p) )
 * (two, because one may vanish by symmetry: the odd coefficients of an even
 * motion; the minimum over i is taken before the root, which is monotonic,
 * so a step costs two pow calls whatever k), and the step is
 *   h = rho / e^2 * exp(-0.7 / (p - 1)),
 * so that the neglected terms, s_i (h/rho)^(p+1) and smaller, are about s_i
 * e^(-2(p+1)) < s_i eps; exp(-0.7 / (p - 1)) is their safety factor, found
 * by experiment to absorb the tail of the series.  No step is rejected: the
 * error is not measured, only predicted (as in Jorba-Zou and heyoka); the
 * tests compare with closed forms.  A zero coefficient gives no bound (rho
 * infinite): when all vanish the polynomial is exact and the step goes to
 * t1.
 *
 * q is kept to degree p + 1 (a_{p+1} is needed for q''s part of x^[p]
 * anyway), q' to degree p: the dense output's q' is the derivative of its
 * q, both evaluated by Horner at any time inside the step.  Near machine
 * precision (p >= TAYLOR_BROUWER_ORDER: tolerances below 1.3e-14) one
 * degree more, q to p + 2 and q' to p + 1 (the series to order p + 2):
 * the tail that q' of degree p leaves, about s (h/rho)^(p+1), is then
 * within a few units of the rounding of a step, and being systematic it
 * outgrows the rounding's random walk over a long run.  Kepler's energy
 * (e = 0.5, 1e-15) drifted by 2e-17 an orbit that way, 2e-12 after 1e5
 * orbits where Brouwer's law allows 3e-13 (1.3e-13 with the extra
 * degree); the degree costs one more coefficient of the series (9 % of a
 * Kepler step at 1e-15).  Looser tolerances leave a tail far above the
 * rounding, which the degree would shrink 7x for the same 5-10 %: the
 * order the tolerance asks is kept there. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/compensated.h"
#include "ode/stepper.h"
#include "ode/taylor.h"

/* From this order on (tolerances below e^-32 = 1.3e-14) the polynomial
 * has one degree more (see the top of this file); TAYLOR_EXTRA is the most
 * degrees a step's polynomial has above p. */
#define TAYLOR_BROUWER_ORDER 18
#define TAYLOR_EXTRA 2

int nz_taylor_order(double eps)
{
  if (!(eps > 0.0) || eps >= 1.0) return 2;
  int p = (int)ceil(-log(eps) / 2.0 + 1.0);
  return p < 2 ? 2 : p;
}

/* The polynomial's increments over tau: dq = q(tau) - a_0 = sum_{n>=1}
 * a_n tau^n and dqd = q'(tau) - a_1 = sum_{n>=2} n a_n tau^(n-1), by
 * Horner, two coordinates at a time: each sum is a chain of dependent
 * multiply-adds, and four chains side by side (in registers) keep the
 * processor busy where one would wait on each; the same operations per
 * coordinate, so the same numbers.  The increments, not the values: the
 * caller adds them to the state as a double-length sum (see taylor_step). */
void nz_taylor_increments(int k, int P, const double *a, double tau, double *dq, double *dqd)
{
  size_t K = (size_t)k;
  int i = 0;
  for (; i + 1 < k; i += 2) {
    const double *c = a + (size_t)P * K + (size_t)i;
    double v0 = c[0], d0 = P * v0, v1 = c[1], d1 = P * v1;
    for (int n = P - 1; n >= 2; n--) {
      const double *an = a + (size_t)n * K + (size_t)i;
      v0 = v0 * tau + an[0];
      d0 = d0 * tau + n * an[0];
      v1 = v1 * tau + an[1];
      d1 = d1 * tau + n * an[1];
    }
    dq[i] = (v0 * tau + a[K + (size_t)i]) * tau;
    dq[i + 1] = (v1 * tau + a[K + (size_t)i + 1]) * tau;
    dqd[i] = d0 * tau;
    dqd[i + 1] = d1 * tau;
  }
  for (; i < k; i++) {
    double v = a[(size_t)P * K + (size_t)i], d = P * v;
    for (int n = P - 1; n >= 2; n--) {
      double an = a[(size_t)n * K + (size_t)i];
      v = v * tau + an;
      d = d * tau + n * an;
    }
    dq[i] = (v * tau + a[K + (size_t)i]) * tau;
    dqd[i] = d * tau;
  }
}

/* min_i s_i / |x_i^[j]| over the components of x^[j] = (a_j, (j + 1)
 * a_{j+1}), s = (scales of q, scales of q'); INFINITY when all vanish. */
static double coef_ratio(int k, const double *a, int j, const double *s)
{
  const double *aj = a + (size_t)j * (size_t)k, *aj1 = aj + k;
  double m = INFINITY;
  for (int i = 0; i < k; i++) {
    double u = fabs(aj[i]), v = (j + 1) * fabs(aj1[i]);
    if (u > 0.0 && s[i] < m * u) m = s[i] / u;
    if (v > 0.0 && s[k + i] < m * v) m = s[k + i] / v;
  }
  return m;
}

typedef struct taylor_stepper {
  nz_stepper base;
  nz_taylor_config c;
  int pmax;                       /* the highest order (the smaller tolerance's)  */
  double *a;                      /* the last step's polynomial, (pmax + 1 + TAYLOR_EXTRA) x k */
  int P;                          /* its degree (0: no step yet)                  */
  double ta, tlo_a, h;            /* its start (t + tlo) and length               */
  double *scale;                  /* 2k scales                                    */
  double t, tlo;                  /* where the last step ended (t + tlo)          */
  double *yfail;                  /* the state of the last failure (dim)          */
  double *ylo;                    /* the state's low parts: it is y + ylo (dim)   */
  double *yend;                   /* the state the last step left (dim)           */
  double *ylo_a;                  /* the low parts at the last step's start (dim) */
  double *dy;                     /* the increments of a step (dim)               */
  int reversed;                   /* the check's first report, and its step       */
  double reversed_ta, reversed_tb;
  double tfail;
  nz_taylor_failure failure;
  int status;
  unsigned long steps, nseries;
  int order;
  double hmin, hmax, hlast;
} taylor_stepper;

static taylor_stepper *as_taylor(nz_stepper *st) { return (taylor_stepper *)st; }

static int fail_at(taylor_stepper *ts, nz_taylor_failure kind, int status, double t, const double *y)
{
  ts->failure = kind;
  ts->status = status;
  ts->tfail = t;
  memcpy(ts->yfail, y, (size_t)ts->base.dim * sizeof(double));
  return status;
}

/* One step from (*t, y = (q, q')) towards tlimit: the series to order
 * p + 1 (p + 2 near machine precision), the step from its last
 * coefficients (the top of this file), the state at the step's end from
 * the polynomial.
 *
 * Sums that lose nothing (core/compensated.h), so that a long run's error
 * is the random walk of its roundings (Brouwer's law, growing as the
 * square root of the steps) and not their sum.  The time is t + tlo: t + h
 * rounds by up to half an ulp of t per step (1e-13 at t ~ 2000), and those
 * roundings would add up into a phase error larger than the tolerance (as
 * in heyoka, which keeps a double-length time for the same reason).  Near
 * machine precision (p >= TAYLOR_BROUWER_ORDER) the state is y + ylo too:
 * the increment of a step, about 1/6 of the state for Kepler at 1e-15, is
 * added to it with its rounding error kept in ylo (Kahan-Babuska-
 * Neumaier), as IAS15 (Rein and Spiegel 2015) does; the series is computed
 * from y alone (ylo is below the half ulp that the series could see).
 * Kepler's energy at e = 0.5, 1e-15: 1.3e-13 after 1e5 orbits instead of
 * 7.8e-13; at looser tolerances the tail of the series is far above the
 * sum's rounding, and the plain sum is kept (the bookkeeping is 7 % of a
 * Henon-Heiles step).  *t is the time's rounded value; a step that starts
 * at another time, or from a component the stepper did not leave there
 * (the first step, a projection, a jump), starts with its low part 0.  *h
 * gets the step taken. */
static int taylor_step(nz_stepper *st, const nz_system *s, double *t, double tlimit, double *h, double *y)
{
  taylor_stepper *ts = as_taylor(st);
  const nz_taylor_config *cfg = &ts->c;
  int k = st->k;
  double *q = y, *qd = y + k, *scale = ts->scale, *ylo = ts->ylo;
  ts->failure = NZ_TAYLOR_OK;
  if (*t != ts->t) {
    ts->t = *t;
    ts->tlo = 0.0;
  }
  double tt = ts->t, tlo = ts->tlo;
  /* each component's scale (see the top of this file); the tolerances in
   * locals, which the stores to scale cannot alias */
  double rtol = cfg->rtol, atol = cfg->atol;
  double eps = rtol > 0.0 ? rtol : atol, floor = rtol > 0.0 ? atol / rtol : 1.0;
  double nx = 0.0;
  for (int i = 0; i < k; i++) {   /* (comparisons, not fmax: no call on this path) */
    double u = fabs(q[i]), w = fabs(qd[i]);
    scale[i] = rtol > 0.0 ? (u > floor ? u : floor) : 1.0;
    scale[k + i] = rtol > 0.0 ? (w > floor ? w : floor) : 1.0;
    if (scale[i] > nx) nx = scale[i];
    if (scale[k + i] > nx) nx = scale[k + i];
  }
  if (floor == 0.0)   /* atol = 0: a component at 0 takes the largest scale */
    for (int i = 0; i < 2 * k; i++)
      if (scale[i] == 0.0) scale[i] = nx > 0.0 ? nx : 1.0;
  int p = cfg->order ? cfg->order : nz_taylor_order(eps);
  if (p > ts->pmax) p = ts->pmax;
  double *a = ts->a;
  ts->nseries++;
  int brouwer = p >= TAYLOR_BROUWER_ORDER, P = p + (brouwer ? 2 : 1);
  int status = cfg->series(cfg->ctx, s, tt, q, qd, P, a);
  if (status) {
    ts->P = 0;
    return fail_at(ts, NZ_TAYLOR_SERIES, status, tt, y);
  }
  if (p > ts->order) ts->order = p;
  double m1 = coef_ratio(k, a, p - 1, scale), m2 = coef_ratio(k, a, p, scale);
  /* in logarithms: two log and one exp a step, not two pow and an exp
   * (a tenth of a small system's step) */
  double l1 = isinf(m1) ? INFINITY : log(m1) / (p - 1), l2 = isinf(m2) ? INFINITY : log(m2) / p;
  double lrho = l1 < l2 ? l1 : l2;   /* log rho */
  double hh = isinf(lrho) ? INFINITY : exp(lrho - 2.0 - 0.7 / (p - 1));
  int last = 0;
  double rest = (tlimit - tt) - tlo;
  /* the last step also when t + h would round onto tlimit: the step is then
   * the rest, longer by less than an ulp of tlimit */
  if (isinf(lrho) || hh >= rest || tt + hh >= tlimit) { hh = rest; last = 1; }
  if (last && !(hh > 0.0)) hh = 0.0;   /* t + tlo reached tlimit by rounding: the state is tlimit's */
  if (!isfinite(hh) || (!last && (!(hh > 0.0) || tt + hh == tt))) {
    ts->P = 0;
    return fail_at(ts, NZ_TAYLOR_STEP, NZ_ERANGE, tt, y);
  }
  ts->P = P;
  ts->ta = tt;
  ts->tlo_a = tlo;
  ts->h = hh;
  double *dy = ts->dy, *lo_a = ts->ylo_a, *yend = ts->yend;
  nz_taylor_increments(k, ts->P, a, hh, dy, dy + k);
  if (brouwer)
    for (int i = 0; i < 2 * k; i++) {
      /* the start's low part: 0 for a component the stepper did not leave */
      double lo = y[i] == yend[i] ? ylo[i] : 0.0;
      lo_a[i] = lo;
      nz_dd_add(&y[i], &lo, dy[i]);
      ylo[i] = lo;
      yend[i] = y[i];
    }
  else   /* a rounding of the sum far below the tail the tolerance leaves */
    for (int i = 0; i < 2 * k; i++) y[i] += dy[i];
  if (cfg->check && !ts->reversed) {
    int r = cfg->check(cfg->ctx, s, last ? tlimit : tt + hh, q, qd);
    if (r) ts->reversed = r, ts->reversed_ta = tt, ts->reversed_tb = last ? tlimit : tt + hh;
  }
  if (last) {
    tt = tlimit;
    tlo = 0.0;
  } else
    nz_dd_add(&tt, &tlo, hh);
  ts->t = tt;
  ts->tlo = tlo;
  ts->steps++;
  if (!last) {   /* (comparisons, not fmin/fmax: no call on this path; hh > 0) */
    if (hh < ts->hmin) ts->hmin = hh;
    if (hh > ts->hmax) ts->hmax = hh;
  }
  ts->hlast = hh;
  *t = tt;
  *h = hh;
  return NZ_OK;
}

/* The state at tau on the last step's polynomial (Horner): its start, with
 * its low parts, plus the increments to tau, rounded once. */
static int taylor_dense(nz_stepper *st, const nz_system *s, double tau, double *y, int *ok)
{
  taylor_stepper *ts = as_taylor(st);
  (void)s;
  *ok = 0;
  if (!ts->P) return NZ_EARG;
  /* tau - (ta + tlo_a), as the step measured it; the step's ends as the
   * caller sees them (ta, t rounded) belong to it too */
  double u = (tau - ts->ta) - ts->tlo_a;
  if (!(u >= 0.0 || tau >= ts->ta) || !(u <= ts->h || tau <= ts->t)) return NZ_EARG;
  int k = st->k;
  const double *a = ts->a, *lo = ts->ylo_a;
  nz_taylor_increments(k, ts->P, a, u, y, y + k);
  for (int i = 0; i < k; i++) {
    y[i] = a[i] + (y[i] + lo[i]);
    y[k + i] = a[k + i] + (y[k + i] + lo[k + i]);
  }
  *ok = 1;
  return NZ_OK;
}

static int taylor_accel(nz_stepper *st, const nz_system *s, double t, const double *y, double *out)
{
  taylor_stepper *ts = as_taylor(st);
  int status = ts->c.accel(ts->c.ctx, s, t, y, y + st->k, out);
  return status ? fail_at(ts, NZ_TAYLOR_ACCEL, status, t, y) : NZ_OK;
}

static const double *taylor_root(const nz_stepper *st)
{
  (void)st;
  return NULL;
}

static void taylor_stats(const nz_stepper *st, nz_stepper_stats *out)
{
  const taylor_stepper *ts = (const taylor_stepper *)st;
  out->steps = ts->steps;
  out->rejected = 0;
  out->nfev = ts->nseries;
  out->njev = 0;
  out->order = ts->order;
  out->reversed = ts->reversed;
  out->reversed_ta = ts->reversed_ta;
  out->reversed_tb = ts->reversed_tb;
}

/* Nothing to forget: a step depends on its start alone. */
static void taylor_reset(nz_stepper *st) { (void)st; }

static void taylor_free(nz_stepper *st)
{
  taylor_stepper *ts = as_taylor(st);
  if (ts->c.ctx_free) ts->c.ctx_free(ts->c.ctx);
  free(ts->a);
  free(ts);
}

static const nz_stepper_ops taylor_ops = {
  taylor_step, NULL, taylor_dense, taylor_accel, taylor_root, taylor_stats, taylor_reset, taylor_free
};

nz_stepper *nz_taylor_stepper_new(const nz_taylor_config *cfg)
{
  if (cfg->k < 1 || cfg->nc < 0 || !cfg->series || !cfg->accel || !(cfg->rtol >= 0.0) || !(cfg->atol >= 0.0) ||
      !(cfg->rtol > 0.0 || cfg->atol > 0.0) || !(cfg->rtol < 1.0) || !(cfg->atol < 1.0) || cfg->order == 1 ||
      cfg->order < 0 || cfg->order > 1000)
    return NULL;
  taylor_stepper *ts = calloc(1, sizeof *ts);
  if (!ts) return NULL;
  /* The highest order a run may use: the smaller positive tolerance's. */
  double emin = cfg->rtol > 0.0 && (cfg->atol == 0.0 || cfg->rtol < cfg->atol) ? cfg->rtol : cfg->atol;
  ts->pmax = cfg->order ? cfg->order : nz_taylor_order(emin);
  size_t kk = (size_t)cfg->k, ncoef = (size_t)ts->pmax + 1 + TAYLOR_EXTRA;
  /* the polynomial (ncoef coefficients); the scales, the failure's state,
   * the low parts, the state left, the start's low parts, the increments
   * (2k each) */
  if (!(ts->a = calloc((ncoef + 12) * kk, sizeof(double)))) {
    free(ts);
    return NULL;
  }
  ts->scale = ts->a + ncoef * kk;
  ts->yfail = ts->scale + 2 * kk;
  ts->ylo = ts->yfail + 2 * kk;
  ts->yend = ts->ylo + 2 * kk;
  ts->ylo_a = ts->yend + 2 * kk;
  ts->dy = ts->ylo_a + 2 * kk;
  ts->c = *cfg;
  ts->base.ops = &taylor_ops;
  ts->base.name = "taylor";
  ts->base.k = cfg->k;
  ts->base.nc = cfg->nc;
  ts->base.dim = 2 * cfg->k;
  ts->base.exact_dense = 1;
  ts->t = NAN;
  ts->hmin = INFINITY;
  return &ts->base;
}

nz_taylor_failure nz_taylor_last_failure(const nz_stepper *st, int *status, double *t, const double **y)
{
  const taylor_stepper *ts = (const taylor_stepper *)st;
  if (status) *status = ts->status;
  if (t) *t = ts->tfail;
  if (y) *y = ts->yfail;
  return ts->failure;
}

void nz_taylor_step_sizes(const nz_stepper *st, double *hmin, double *hmax)
{
  const taylor_stepper *ts = (const taylor_stepper *)st;
  double lo = ts->hmin, hi = ts->hmax;
  if (ts->steps > 0 && hi == 0.0) lo = hi = ts->hlast;   /* one step, cut at the end */
  *hmin = ts->steps ? lo : 0.0;
  *hmax = hi;
}

void *nz_taylor_ctx(const nz_stepper *st) { return ((const taylor_stepper *)st)->c.ctx; }
