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
 * q, both evaluated by Horner at any time inside the step. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/interrupt.h"
#include "ode/taylor.h"

long nz_taylor_grid_count(const nz_taylor_config *cfg)
{
  double span = cfg->t1 - cfg->t0;
  if (!isfinite(cfg->t0) || !isfinite(cfg->t1) || !(span > 0.0) || !isfinite(cfg->dt) || !(cfg->dt > 0.0))
    return 0;
  /* as the GSL loop (ode_run.c): t0 + i dt, i < n, then t1 */
  double n = ceil(span / cfg->dt - 1e-9);
  if (!(n >= 1.0) || n > 1e9) return 0;
  return (long)n + 1;
}

int nz_taylor_order(double eps)
{
  if (!(eps > 0.0) || eps >= 1.0) return 2;
  int p = (int)ceil(-log(eps) / 2.0 + 1.0);
  return p < 2 ? 2 : p;
}

static double grid_time(const nz_taylor_config *cfg, long i, long npts)
{
  return i == npts - 1 ? cfg->t1 : cfg->t0 + (double)i * cfg->dt;
}

/* q(tau) and q'(tau) from a_0 .. a_P by Horner, two coordinates at a
 * time: each sum is a chain of dependent multiply-adds, and four chains
 * side by side (in registers) keep the processor busy where one would wait
 * on each; the same operations per coordinate, so the same numbers. */
void nz_taylor_eval(int k, int P, const double *a, double tau, double *q, double *qd)
{
  size_t K = (size_t)k;
  int i = 0;
  for (; i + 1 < k; i += 2) {
    const double *c = a + (size_t)P * K + (size_t)i;
    double v0 = c[0], d0 = P * v0, v1 = c[1], d1 = P * v1;
    for (int n = P - 1; n >= 1; n--) {
      const double *an = a + (size_t)n * K + (size_t)i;
      v0 = v0 * tau + an[0];
      d0 = d0 * tau + n * an[0];
      v1 = v1 * tau + an[1];
      d1 = d1 * tau + n * an[1];
    }
    q[i] = v0 * tau + a[i];
    q[i + 1] = v1 * tau + a[i + 1];
    qd[i] = P >= 1 ? d0 : 0.0;
    qd[i + 1] = P >= 1 ? d1 : 0.0;
  }
  for (; i < k; i++) {
    double v = a[(size_t)P * K + (size_t)i], d = P * v;
    for (int n = P - 1; n >= 1; n--) {
      double an = a[(size_t)n * K + (size_t)i];
      v = v * tau + an;
      d = d * tau + n * an;
    }
    q[i] = v * tau + a[i];
    qd[i] = P >= 1 ? d : 0.0;
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

int nz_taylor_run(int k, nz_taylor_series_fn series, void *ctx, const nz_taylor_config *cfg,
                  const double *q0, const double *qd0, double *tout, double *qout, double *qdout,
                  long *npoints, nz_taylor_stats *stats, nz_taylor_stop *stop)
{
  long npts = nz_taylor_grid_count(cfg);
  memset(stats, 0, sizeof *stats);
  *npoints = 0;
  *stop = NZ_TAYLOR_DONE;
  stats->t = cfg->t0;
  if (k < 1 || npts < 2 || !(cfg->rtol >= 0.0) || !(cfg->atol >= 0.0) || !(cfg->rtol > 0.0 || cfg->atol > 0.0) ||
      !(cfg->rtol < 1.0) || !(cfg->atol < 1.0) || !isfinite(cfg->atol) || cfg->order == 1 || cfg->order < 0 ||
      cfg->order > 1000)
    return NZ_EDOM;
  /* The highest order the run may use: the smaller positive tolerance's. */
  double emin = cfg->rtol > 0.0 && (cfg->atol == 0.0 || cfg->rtol < cfg->atol) ? cfg->rtol : cfg->atol;
  int pmax = cfg->order ? cfg->order : nz_taylor_order(emin);
  size_t kk = (size_t)k;
  double *a = malloc(((size_t)pmax + 2 + 4) * kk * sizeof(double));
  if (!a) return NZ_ENOMEM;
  double *q = a + ((size_t)pmax + 2) * kk, *qd = q + kk, *scale = qd + kk;
  memcpy(q, q0, kk * sizeof(double));
  memcpy(qd, qd0, kk * sizeof(double));
  tout[0] = cfg->t0;
  memcpy(qout, q, kk * sizeof(double));
  memcpy(qdout, qd, kk * sizeof(double));
  long next = 1;
  /* The time is t + tlo, a sum of two doubles: t + h rounds by up to half
   * an ulp of t per step (1e-13 at t ~ 2000), and those roundings would add
   * up over the steps into a phase error larger than the tolerance (as in
   * heyoka, which keeps a double-length time for the same reason). */
  double t = cfg->t0, tlo = 0.0, t1 = cfg->t1, hmin = INFINITY, hmax = 0.0, hlast = 0.0;
  int st = NZ_OK;
  while (t < t1) {
    if (nz_interrupt_requested()) { *stop = NZ_TAYLOR_INTERRUPTED; break; }
    if (cfg->max_steps && stats->steps >= cfg->max_steps) {
      *stop = NZ_TAYLOR_MAX_STEPS;
      st = NZ_ERANGE;
      break;
    }
    /* each component's scale (see the top of this file) */
    double eps = cfg->rtol > 0.0 ? cfg->rtol : cfg->atol, floor = cfg->rtol > 0.0 ? cfg->atol / cfg->rtol : 1.0;
    double nx = 0.0;
    for (int i = 0; i < k; i++) {   /* (comparisons, not fmax: no call on this path) */
      double u = fabs(q[i]), w = fabs(qd[i]);
      scale[i] = cfg->rtol > 0.0 ? (u > floor ? u : floor) : 1.0;
      scale[k + i] = cfg->rtol > 0.0 ? (w > floor ? w : floor) : 1.0;
      if (scale[i] > nx) nx = scale[i];
      if (scale[k + i] > nx) nx = scale[k + i];
    }
    if (floor == 0.0)   /* atol = 0: a component at 0 takes the largest scale */
      for (int i = 0; i < 2 * k; i++)
        if (scale[i] == 0.0) scale[i] = nx > 0.0 ? nx : 1.0;
    int p = cfg->order ? cfg->order : nz_taylor_order(eps);
    if (p > pmax) p = pmax;
    if (p > stats->order) stats->order = p;
    stats->nseries++;
    if ((st = series(ctx, t, q, qd, p + 1, a))) { *stop = NZ_TAYLOR_SERIES; break; }
    double m1 = coef_ratio(k, a, p - 1, scale), m2 = coef_ratio(k, a, p, scale);
    /* in logarithms: two log and one exp a step, not two pow and an exp
     * (a tenth of a small system's step) */
    double l1 = isinf(m1) ? INFINITY : log(m1) / (p - 1), l2 = isinf(m2) ? INFINITY : log(m2) / p;
    double lrho = l1 < l2 ? l1 : l2;   /* log rho */
    double h = isinf(lrho) ? INFINITY : exp(lrho - 2.0 - 0.7 / (p - 1));
    int last = 0;
    double rest = (t1 - t) - tlo;
    /* the last step also when t + h would round onto t1: the step is then
     * the rest, longer by less than an ulp of t1 */
    if (isinf(lrho) || h >= rest || t + h >= t1) { h = rest; last = 1; }
    if (last && !(h > 0.0)) h = 0.0;   /* t + tlo reached t1 by rounding: the state is t1's */
    if (!isfinite(h) || (!last && (!(h > 0.0) || t + h == t))) {
      *stop = NZ_TAYLOR_STEP;
      st = NZ_ERANGE;
      break;
    }
    int cut = 0;
    if (cfg->on_step) {
      double hc = h;
      if ((st = cfg->on_step(cfg->step_ctx, t + tlo, h, k, p + 1, a, &hc))) { *stop = NZ_TAYLOR_HOOK; break; }
      if (hc < h && hc >= 0.0) { h = hc; cut = 1; last = 0; }
    }
    /* the grid's points inside the step, on its polynomial */
    for (; next < npts; next++) {
      double tg = grid_time(cfg, next, npts), tau = (tg - t) - tlo;
      if ((!last && tau > h) || (cut && tau >= h)) break;
      tout[next] = tg;
      nz_taylor_eval(k, p + 1, a, tau, qout + (size_t)next * kk, qdout + (size_t)next * kk);
    }
    nz_taylor_eval(k, p + 1, a, h, q, qd);
    if (last && next == npts) {   /* t1 itself: the state, exactly */
      memcpy(qout + (size_t)(npts - 1) * kk, q, kk * sizeof(double));
      memcpy(qdout + (size_t)(npts - 1) * kk, qd, kk * sizeof(double));
    }
    if (last) {
      t = t1;
      tlo = 0.0;
    } else {   /* t + tlo + h: Knuth's two-sum, then renormalized */
      double sum = t + h, bp = sum - t, err = (t - (sum - bp)) + (h - bp);
      tlo += err;
      t = sum + tlo;
      tlo -= t - sum;
    }
    stats->steps++;
    if (!last) {
      hmin = fmin(hmin, h);
      hmax = fmax(hmax, h);
    }
    hlast = h;
    if (cut) { *stop = NZ_TAYLOR_CUT; break; }
  }
  if (*stop == NZ_TAYLOR_DONE && next == npts - 1) {
    /* t rounded onto t1 with t + tlo short of it by less than an ulp: the
     * state is t1's */
    tout[next] = t1;
    memcpy(qout + (size_t)next * kk, q, kk * sizeof(double));
    memcpy(qdout + (size_t)next * kk, qd, kk * sizeof(double));
    next++;
    t = t1;
  }
  if (stats->steps > 0 && hmax == 0.0) hmin = hmax = hlast;   /* one step, cut at t1 */
  stats->hmin = stats->steps ? hmin : 0.0;
  stats->hmax = hmax;
  stats->t = t;
  *npoints = next;
  free(a);
  return st;
}
