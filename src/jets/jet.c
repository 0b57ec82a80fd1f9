/* jet.c - jets: truncated Taylor series with tangent directions (see jet.h).
 *
 * Every operation computes the value series with a kernel of series.c, then
 * each tangent series by the chain rule, itself a series operation: for
 * y = f(x), dy = f'(x) dx, where the series of f'(x) falls out of the value
 * recurrence (cos x for sin x, 1 + tan^2 x for tan x, ...).  That is exact
 * for truncated series and costs one Cauchy product per direction. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "jets/jet.h"
#include "jets/series.h"

const char *const nz_jet_fn_names[NZ_FN_COUNT] = {
  "exp", "log", "sqrt", "sin", "cos", "tan", "asin", "acos", "atan",
  "sinh", "cosh", "tanh", "abs", "sign"
};

size_t nz_jet_bytes(int order, int ntan)
{
  return sizeof(nz_jet) + (size_t)(ntan + 1) * (size_t)(order + 1) * sizeof(double);
}

void nz_jet_init(nz_jet *z, int order, int ntan)
{
  z->order = order;
  z->ntan = ntan;
  memset(z->c, 0, (size_t)(ntan + 1) * (size_t)(order + 1) * sizeof(double));
}

nz_jet *nz_jet_alloc(int order, int ntan)
{
  nz_jet *z = malloc(nz_jet_bytes(order, ntan));
  if (z) nz_jet_init(z, order, ntan);
  return z;
}

void nz_jet_free(nz_jet *z) { free(z); }

void nz_jet_copy(nz_jet *z, const nz_jet *a)
{
  memcpy(z->c, a->c, (size_t)(a->ntan + 1) * (size_t)(a->order + 1) * sizeof(double));
}

size_t nz_jet_work_len(int order) { return 8 * (size_t)(order + 1); }

void nz_jet_result_shape(const nz_jet *a, const nz_jet *b, int *order, int *ntan)
{
  *order = a->order < b->order ? a->order : b->order;
  *ntan = a->ntan > b->ntan ? a->ntan : b->ntan;
}

void nz_jet_set_variable(nz_jet *z, double t0, int seed)
{
  nz_jet_init(z, z->order, z->ntan);
  z->c[0] = t0;
  if (z->order >= 1) z->c[1] = 1.0;
  double *d = seed >= 0 ? nz_jet_tangent(z, seed) : NULL;
  if (d) d[0] = 1.0;
}

void nz_jet_set_constant(nz_jet *z, double v)
{
  nz_jet_init(z, z->order, z->ntan);
  z->c[0] = v;
}

/* An infinite coefficient is an overflow; NaN without one came in with an
 * operand or from inf - inf inside a sum (the binding tells which). */
nz_status nz_jet_check_finite(const nz_jet *x)
{
  size_t n = (size_t)(x->ntan + 1) * (size_t)(x->order + 1);
  int nan = 0;
  for (size_t i = 0; i < n; i++) {
    if (isinf(x->c[i])) return NZ_ERANGE;
    if (isnan(x->c[i])) nan = 1;
  }
  return nan ? NZ_ENAN : NZ_OK;
}

/* Derivatives are asked for when the jet has order >= 1 or tangents. */
static int wants_derivatives(const nz_jet *z) { return z->order >= 1 || z->ntan >= 1; }

static void series_axpy(double *y, double a, const double *x, int K)
{
  for (int k = 0; k <= K; k++) y[k] += a * x[k];
}

/* z = a + s b, coefficientwise, s = +-1. */
static nz_status add_signed(nz_jet *z, const nz_jet *a, const nz_jet *b, double s)
{
  int K = z->order;
  for (int d = -1; d < z->ntan; d++) {
    double *zd = d < 0 ? z->c : nz_jet_tangent(z, d);
    const double *ad = d < 0 ? a->c : nz_jet_tangent(a, d);
    const double *bd = d < 0 ? b->c : nz_jet_tangent(b, d);
    for (int k = 0; k <= K; k++) zd[k] = (ad ? ad[k] : 0.0) + s * (bd ? bd[k] : 0.0);
  }
  return nz_jet_check_finite(z);
}

nz_status nz_jet_add(nz_jet *z, const nz_jet *a, const nz_jet *b) { return add_signed(z, a, b, 1.0); }
nz_status nz_jet_sub(nz_jet *z, const nz_jet *a, const nz_jet *b) { return add_signed(z, a, b, -1.0); }

nz_status nz_jet_scale(nz_jet *z, const nz_jet *a, double s)
{
  size_t n = (size_t)(z->ntan + 1) * (size_t)(z->order + 1);
  for (size_t i = 0; i < n; i++) z->c[i] = s * a->c[i];
  return nz_jet_check_finite(z);
}

nz_status nz_jet_neg(nz_jet *z, const nz_jet *a) { return nz_jet_scale(z, a, -1.0); }

nz_status nz_jet_offset(nz_jet *z, const nz_jet *a, double s)
{
  nz_jet_copy(z, a);
  z->c[0] += s;
  return nz_jet_check_finite(z);
}

/* d(a b) = da b + a db */
nz_status nz_jet_mul(nz_jet *z, const nz_jet *a, const nz_jet *b, double *w)
{
  int K = z->order;
  nz_series_mul(z->c, a->c, b->c, K);
  for (int d = 0; d < z->ntan; d++) {
    double *zd = nz_jet_tangent(z, d);
    const double *ad = nz_jet_tangent(a, d), *bd = nz_jet_tangent(b, d);
    memset(zd, 0, (size_t)(K + 1) * sizeof(double));
    if (ad) { nz_series_mul(w, ad, b->c, K); series_axpy(zd, 1.0, w, K); }
    if (bd) { nz_series_mul(w, a->c, bd, K); series_axpy(zd, 1.0, w, K); }
  }
  return nz_jet_check_finite(z);
}

/* z = a / b;  dz = (da - z db) / b */
nz_status nz_jet_div(nz_jet *z, const nz_jet *a, const nz_jet *b, double *w)
{
  int K = z->order;
  if (b->c[0] == 0.0) return NZ_EZERODIV;
  nz_series_div(z->c, a->c, b->c, K);
  double *num = w, *zb = w + (K + 1);
  for (int d = 0; d < z->ntan; d++) {
    const double *ad = nz_jet_tangent(a, d), *bd = nz_jet_tangent(b, d);
    for (int k = 0; k <= K; k++) num[k] = ad ? ad[k] : 0.0;
    if (bd) { nz_series_mul(zb, z->c, bd, K); series_axpy(num, -1.0, zb, K); }
    nz_series_div(nz_jet_tangent(z, d), num, b->c, K);
  }
  return nz_jet_check_finite(z);
}

/* Tangents of a unary result y = f(x): dy = g dx (g = f'(x) as a series), or
 * dy = dx / h when f'(x) = 1/h is cheaper as a quotient, times sign s. */
static void tangents_times(nz_jet *z, const nz_jet *x, const double *g, double s)
{
  int K = z->order;
  for (int d = 0; d < z->ntan; d++) {
    double *zd = nz_jet_tangent(z, d);
    const double *xd = nz_jet_tangent(x, d);
    if (!xd) { memset(zd, 0, (size_t)(K + 1) * sizeof(double)); continue; }
    nz_series_mul(zd, g, xd, K);
    if (s != 1.0) for (int k = 0; k <= K; k++) zd[k] *= s;
  }
}

static void tangents_over(nz_jet *z, const nz_jet *x, const double *h, double s, double *tmp)
{
  int K = z->order;
  for (int d = 0; d < z->ntan; d++) {
    double *zd = nz_jet_tangent(z, d);
    const double *xd = nz_jet_tangent(x, d);
    if (!xd) { memset(zd, 0, (size_t)(K + 1) * sizeof(double)); continue; }
    for (int k = 0; k <= K; k++) tmp[k] = s * xd[k];
    nz_series_div(zd, tmp, h, K);
  }
}

/* r = sqrt(1 - x^2), the denominator of asin' and acos'. */
static void one_minus_square_root(double *r, const double *x, int K, double *tmp)
{
  nz_series_mul(tmp, x, x, K);
  for (int k = 0; k <= K; k++) tmp[k] = -tmp[k];
  tmp[0] += 1.0;
  nz_series_sqrt(r, tmp, K);
}

nz_status nz_jet_apply(nz_jet *z, nz_jet_fn f, const nz_jet *x, double *w)
{
  int K = z->order;
  double x0 = x->c[0];
  double *y = z->c, *g = w, *tmp = w + (K + 1), *tmp2 = w + 2 * (K + 1);
  int smooth = wants_derivatives(z);

  switch (f) {
  case NZ_FN_EXP:
    nz_series_exp(y, x->c, K);
    tangents_times(z, x, y, 1.0);
    break;
  case NZ_FN_LOG:
    if (!(x0 > 0.0)) return NZ_EDOM;
    nz_series_log(y, x->c, K);
    tangents_over(z, x, x->c, 1.0, tmp);
    break;
  case NZ_FN_SQRT:
    if (x0 < 0.0) return NZ_EDOM;
    if (x0 == 0.0 && smooth) return NZ_ESING;
    nz_series_sqrt(y, x->c, K);
    for (int k = 0; k <= K; k++) g[k] = 2.0 * y[k];
    if (z->ntan) tangents_over(z, x, g, 1.0, tmp);
    break;
  case NZ_FN_SIN:
  case NZ_FN_SINH:
    nz_series_sincos(y, g, x->c, K, f == NZ_FN_SINH);
    tangents_times(z, x, g, 1.0);
    break;
  case NZ_FN_COS:
  case NZ_FN_COSH:
    nz_series_sincos(g, y, x->c, K, f == NZ_FN_COSH);
    tangents_times(z, x, g, f == NZ_FN_COS ? -1.0 : 1.0);
    break;
  case NZ_FN_TAN:
  case NZ_FN_TANH:
    nz_series_tan(y, g, x->c, K, f == NZ_FN_TANH);
    tangents_times(z, x, g, 1.0);
    break;
  case NZ_FN_ATAN:
    nz_series_mul(g, x->c, x->c, K);
    g[0] += 1.0;
    y[0] = atan(x0);
    nz_series_quadrature(y, x->c, g, 1.0, K);
    tangents_over(z, x, g, 1.0, tmp);
    break;
  case NZ_FN_ASIN:
  case NZ_FN_ACOS: {
    double s = f == NZ_FN_ASIN ? 1.0 : -1.0;
    if (fabs(x0) > 1.0) return NZ_EDOM;
    if (fabs(x0) == 1.0 && smooth) return NZ_ESING;
    one_minus_square_root(g, x->c, K, tmp);
    y[0] = f == NZ_FN_ASIN ? asin(x0) : acos(x0);
    nz_series_quadrature(y, x->c, g, s, K);
    tangents_over(z, x, g, s, tmp2);
    break;
  }
  case NZ_FN_ABS:
    if (x0 == 0.0 && smooth) return NZ_ESING;
    return nz_jet_scale(z, x, x0 < 0.0 ? -1.0 : 1.0);
  case NZ_FN_SIGN: {
    /* sign(x) = [x > 0] - [x < 0] by the branch rule: the sign of the first
     * nonzero coefficient.  A step: its derivatives vanish off the jump. */
    int s = 0;
    for (int k = 0; k <= K && !s; k++) {
      if (isnan(x->c[k])) return NZ_ENAN;
      s = (x->c[k] > 0.0) - (x->c[k] < 0.0);
    }
    nz_jet_set_constant(z, (double)s);
    return NZ_OK;
  }
  default:
    return NZ_EDOM;
  }
  return nz_jet_check_finite(z);
}

static int is_small_integer(double p) { return p == floor(p) && fabs(p) <= 1e9; }

/* x^p for real p.  Integer p >= 0 uses binary powering, valid at x0 = 0;
 * other p use the recurrence of series.h, which needs x0 != 0;
 * dy = p x^(p-1) dx, computed as p y dx / x or, at x0 = 0, from x^(p-1). */
nz_status nz_jet_pow(nz_jet *z, const nz_jet *x, double p, double *w)
{
  int K = z->order;
  double x0 = x->c[0];
  double *y = z->c, *g = w, *tmp = w + (K + 1), *pw = w + 2 * (K + 1);
  int integer = is_small_integer(p);

  if (p == 0.0) {
    nz_jet_set_constant(z, 1.0);
    return NZ_OK;
  }
  if (integer && p > 0.0) {
    unsigned n = (unsigned)p;
    nz_series_powi(y, x->c, n, K, pw);
    if (z->ntan) {
      nz_series_powi(g, x->c, n - 1, K, pw);
      tangents_times(z, x, g, p);
    }
    return nz_jet_check_finite(z);
  }
  if (x0 == 0.0) {
    if (integer || (!wants_derivatives(z) && p < 0.0)) return NZ_EZERODIV;
    if (wants_derivatives(z)) return NZ_ESING;
    nz_jet_set_constant(z, 0.0);   /* 0^p, p > 0 not an integer */
    return NZ_OK;
  }
  if (x0 < 0.0 && !integer) return NZ_EDOM;
  nz_series_pow(y, x->c, p, K);
  if (z->ntan) {
    for (int k = 0; k <= K; k++) g[k] = p * y[k];
    for (int d = 0; d < z->ntan; d++) {
      double *zd = nz_jet_tangent(z, d);
      const double *xd = nz_jet_tangent(x, d);
      if (!xd) { memset(zd, 0, (size_t)(K + 1) * sizeof(double)); continue; }
      nz_series_mul(tmp, g, xd, K);
      nz_series_div(zd, tmp, x->c, K);
    }
  }
  return nz_jet_check_finite(z);
}

/* x^y = exp(y log x), x0 > 0;  d(x^y) = x^y (dy log x + y dx / x). */
nz_status nz_jet_pow_jet(nz_jet *z, const nz_jet *x, const nz_jet *y, double *w)
{
  int K = z->order;
  double x0 = x->c[0];
  if (x0 < 0.0) return NZ_EDOM;
  if (x0 == 0.0) return NZ_ESING;
  double *lx = w, *p = w + (K + 1), *t1 = w + 2 * (K + 1), *t2 = w + 3 * (K + 1);
  nz_series_log(lx, x->c, K);
  nz_series_mul(p, y->c, lx, K);
  nz_series_exp(z->c, p, K);
  for (int d = 0; d < z->ntan; d++) {
    const double *xd = nz_jet_tangent(x, d), *yd = nz_jet_tangent(y, d);
    double *zd = nz_jet_tangent(z, d);
    memset(p, 0, (size_t)(K + 1) * sizeof(double));      /* p: d(y log x) */
    if (yd) { nz_series_mul(t1, yd, lx, K); series_axpy(p, 1.0, t1, K); }
    if (xd) {
      nz_series_div(t1, xd, x->c, K);
      nz_series_mul(t2, y->c, t1, K);
      series_axpy(p, 1.0, t2, K);
    }
    nz_series_mul(zd, z->c, p, K);
  }
  return nz_jet_check_finite(z);
}

/* dz = (x dy - y dx) / (x^2 + y^2) */
nz_status nz_jet_atan2(nz_jet *z, const nz_jet *y, const nz_jet *x, double *w)
{
  int K = z->order;
  if (x->c[0] == 0.0 && y->c[0] == 0.0 && wants_derivatives(z)) return NZ_ESING;
  double *d = w, *num = w + 3 * (K + 1), *t = w + 4 * (K + 1);
  nz_series_atan2(z->c, y->c, x->c, K, w);   /* leaves d = x^2 + y^2 in w */
  for (int dd = 0; dd < z->ntan; dd++) {
    const double *xd = nz_jet_tangent(x, dd), *yd = nz_jet_tangent(y, dd);
    memset(num, 0, (size_t)(K + 1) * sizeof(double));
    if (yd) { nz_series_mul(t, x->c, yd, K); series_axpy(num, 1.0, t, K); }
    if (xd) { nz_series_mul(t, y->c, xd, K); series_axpy(num, -1.0, t, K); }
    nz_series_div(nz_jet_tangent(z, dd), num, d, K);
  }
  return nz_jet_check_finite(z);
}

/* z = s sqrt((a/s)^2 + (b/s)^2) with s = max(|a0|, |b0|), so that squares of
 * large values do not overflow;  dz = (a da + b db) / z. */
nz_status nz_jet_hypot(nz_jet *z, const nz_jet *a, const nz_jet *b, double *w)
{
  int K = z->order;
  double s = fmax(fabs(a->c[0]), fabs(b->c[0]));
  if (s == 0.0) {
    if (wants_derivatives(z)) return NZ_ESING;
    nz_jet_set_constant(z, 0.0);
    return NZ_OK;
  }
  double *sq = w, *t = w + (K + 1), *num = w + 2 * (K + 1), *as = w + 3 * (K + 1),
         *bs = w + 4 * (K + 1);
  for (int k = 0; k <= K; k++) { as[k] = a->c[k] / s; bs[k] = b->c[k] / s; }
  nz_series_mul(sq, as, as, K);
  nz_series_mul(t, bs, bs, K);
  series_axpy(sq, 1.0, t, K);
  nz_series_sqrt(z->c, sq, K);
  for (int k = 0; k <= K; k++) z->c[k] *= s;
  for (int d = 0; d < z->ntan; d++) {
    const double *ad = nz_jet_tangent(a, d), *bd = nz_jet_tangent(b, d);
    memset(num, 0, (size_t)(K + 1) * sizeof(double));
    if (ad) { nz_series_mul(t, a->c, ad, K); series_axpy(num, 1.0, t, K); }
    if (bd) { nz_series_mul(t, b->c, bd, K); series_axpy(num, 1.0, t, K); }
    nz_series_div(nz_jet_tangent(z, d), num, z->c, K);
  }
  return nz_jet_check_finite(z);
}

/* -1, 0 or +1 as a is below, equal to or above b for t slightly above t0:
 * the first coefficient (of 0..K) in which the value series differ decides
 * (the branch rule of jet.h).  2 when a compared coefficient is NaN. */
static int compare_series(const double *a, const double *b, int K)
{
  for (int k = 0; k <= K; k++) {
    if (isnan(a[k]) || isnan(b[k])) return 2;
    if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
  }
  return 0;
}

nz_status nz_jet_compare(nz_jet *z, nz_cmp op, const nz_jet *a, const nz_jet *b)
{
  int r = compare_series(a->c, b->c, z->order), holds;
  if (r == 2) return NZ_ENAN;
  switch (op) {
  case NZ_CMP_LT: holds = r < 0; break;
  case NZ_CMP_LE: holds = r <= 0; break;
  case NZ_CMP_GT: holds = r > 0; break;
  case NZ_CMP_GE: holds = r >= 0; break;
  case NZ_CMP_EQ: holds = r == 0; break;
  case NZ_CMP_NE: holds = r != 0; break;
  default: return NZ_EDOM;
  }
  nz_jet_set_constant(z, holds ? 1.0 : 0.0);
  return NZ_OK;
}

/* memmove: z may be the chosen operand itself (same shape, same places). */
nz_status nz_jet_select(nz_jet *z, const nz_jet *c, const nz_jet *a, const nz_jet *b)
{
  double c0 = c->c[0];
  if (isnan(c0)) return NZ_ENAN;
  const nz_jet *x = c0 != 0.0 ? a : b;
  int K = z->order, Kx = x->order < K ? x->order : K;
  size_t n = (size_t)(K + 1) * sizeof(double), nx = (size_t)(Kx + 1) * sizeof(double);
  for (int d = -1; d < z->ntan; d++) {
    double *zd = d < 0 ? z->c : nz_jet_tangent(z, d);
    const double *xd = d < 0 ? x->c : nz_jet_tangent(x, d);
    if (xd) memmove(zd, xd, nx);
    if (!xd || nx < n) memset((char *)zd + (xd ? nx : 0), 0, n - (xd ? nx : 0));
  }
  return nz_jet_check_finite(z);
}
