/* series.c - coefficient kernels of truncated Taylor series (see series.h for
 * the recurrences and the contracts). */
#include <math.h>
#include <string.h>
#include "jets/series.h"

/* A square (a == b: the same series) takes each cross product once and
 * doubles it: half the work, and every square of a series (x^2, the jets'
 * powers, 1 + x^2 beside atan) goes through here, so the jets, the graph's
 * series and their machine code (graph/series_native.c, which writes the
 * same sums) agree. */
double nz_series_mul_coef(const double *a, const double *b, int k)
{
  double s = 0.0;
  if (a == b) {
    for (int j = 0; 2 * j < k; j++) s += a[j] * a[k - j];
    s += s;
    if (!(k & 1)) s += a[k / 2] * a[k / 2];
    return s;
  }
  /* from the first product, not from +0: the value a_0 b_0 keeps the sign
   * of a zero (-0.5 * 0 is -0, as the doubles and a jet times a number
   * give it; atan2 tells them apart) */
  s = a[0] * b[k];
  for (int j = 1; j <= k; j++) s += a[j] * b[k - j];
  return s;
}

void nz_series_mul(double *z, const double *a, const double *b, int K)
{
  for (int k = 0; k <= K; k++) z[k] = nz_series_mul_coef(a, b, k);
}

double nz_series_div_coef(const double *z, const double *a, const double *b, int k)
{
  double s = a[k];
  for (int j = 0; j < k; j++) s -= z[j] * b[k - j];
  return s / b[0];
}

void nz_series_div(double *z, const double *a, const double *b, int K)
{
  for (int k = 0; k <= K; k++) z[k] = nz_series_div_coef(z, a, b, k);
}

double nz_series_exp_coef(const double *y, const double *x, int k)
{
  if (k == 0) return exp(x[0]);
  double s = 0.0;
  for (int j = 1; j <= k; j++) s += j * x[j] * y[k - j];
  return s / k;
}

void nz_series_exp(double *y, const double *x, int K)
{
  for (int k = 0; k <= K; k++) y[k] = nz_series_exp_coef(y, x, k);
}

double nz_series_log_coef(const double *y, const double *x, int k)
{
  if (k == 0) return log(x[0]);
  double s = 0.0;
  for (int j = 1; j < k; j++) s += j * y[j] * x[k - j];
  return (x[k] - s / k) / x[0];
}

void nz_series_log(double *y, const double *x, int K)
{
  for (int k = 0; k <= K; k++) y[k] = nz_series_log_coef(y, x, k);
}

double nz_series_pow_coef(const double *y, const double *x, double a, int k)
{
  if (k == 0) return pow(x[0], a);
  double s = 0.0;
  for (int j = 0; j < k; j++) s += (a * (k - j) - j) * x[k - j] * y[j];
  return s / (k * x[0]);
}

void nz_series_pow(double *y, const double *x, double a, int K)
{
  for (int k = 0; k <= K; k++) y[k] = nz_series_pow_coef(y, x, a, k);
}

void nz_series_powi(double *y, const double *x, unsigned n, int K, double *w)
{
  double *base = w, *tmp = w + (K + 1);
  size_t bytes = (size_t)(K + 1) * sizeof(double);
  memcpy(base, x, bytes);
  memset(y, 0, bytes);
  y[0] = 1.0;
  while (n) {
    if (n & 1u) {
      nz_series_mul(tmp, y, base, K);
      memcpy(y, tmp, bytes);
    }
    n >>= 1;
    if (n) {
      nz_series_mul(tmp, base, base, K);
      memcpy(base, tmp, bytes);
    }
  }
}

int nz_series_powi_work(unsigned n)
{
  int count = 0, y_is_one = 1;
  while (n) {
    if (n & 1u) {
      count += !y_is_one;
      y_is_one = 0;
    }
    n >>= 1;
    if (n) count++;
  }
  return count;
}

/* The loop of nz_series_powi, each product into the next series of w. */
double nz_series_powi_coef(double *w, const double *x, unsigned n, int k, int K)
{
  const double *base = x, *y = NULL;
  size_t stride = (size_t)K + 1;
  if (n == 0) return k == 0 ? 1.0 : 0.0;
  while (n) {
    if (n & 1u) {
      if (y) {
        w[k] = nz_series_mul_coef(y, base, k);
        y = w;
        w += stride;
      } else y = base;
    }
    n >>= 1;
    if (n) {
      w[k] = nz_series_mul_coef(base, base, k);
      base = w;
      w += stride;
    }
  }
  return y[k];
}

double nz_series_sqrt_coef(const double *y, const double *x, int k)
{
  if (k == 0) return sqrt(x[0]);
  double s = 0.0;
  for (int j = 1; j < k; j++) s += y[j] * y[k - j];
  return (x[k] - s) / (2.0 * y[0]);
}

void nz_series_sqrt(double *y, const double *x, int K)
{
  for (int k = 0; k <= K; k++) y[k] = nz_series_sqrt_coef(y, x, k);
}

void nz_series_sincos_coef(double *s, double *c, const double *x, int k, int hyperbolic)
{
  if (k == 0) {
    s[0] = hyperbolic ? sinh(x[0]) : sin(x[0]);
    c[0] = hyperbolic ? cosh(x[0]) : cos(x[0]);
    return;
  }
  double ss = 0.0, cc = 0.0;
  for (int j = 1; j <= k; j++) {
    ss += j * x[j] * c[k - j];
    cc += j * x[j] * s[k - j];
  }
  s[k] = ss / k;
  c[k] = (hyperbolic ? cc : -cc) / k;
}

void nz_series_sincos(double *s, double *c, const double *x, int K, int hyperbolic)
{
  for (int k = 0; k <= K; k++) nz_series_sincos_coef(s, c, x, k, hyperbolic);
}

void nz_series_tan_coef(double *t, double *u, const double *x, int k, int hyperbolic)
{
  double sign = hyperbolic ? -1.0 : 1.0;
  if (k == 0) {
    t[0] = hyperbolic ? tanh(x[0]) : tan(x[0]);
    u[0] = 1.0 + sign * t[0] * t[0];
    return;
  }
  double s = 0.0;
  for (int j = 1; j <= k; j++) s += j * x[j] * u[k - j];
  t[k] = s / k;
  u[k] = sign * nz_series_mul_coef(t, t, k);
}

void nz_series_tan(double *t, double *u, const double *x, int K, int hyperbolic)
{
  for (int k = 0; k <= K; k++) nz_series_tan_coef(t, u, x, k, hyperbolic);
}

double nz_series_quadrature_coef(const double *y, const double *x, const double *d,
                                 double s, int k)
{
  double acc = s * k * x[k];
  for (int j = 1; j < k; j++) acc -= j * y[j] * d[k - j];
  return acc / (k * d[0]);
}

void nz_series_quadrature(double *y, const double *x, const double *d, double s, int K)
{
  for (int k = 1; k <= K; k++) y[k] = nz_series_quadrature_coef(y, x, d, s, k);
}

double nz_series_atan2_coef(const double *z, const double *y, const double *x, const double *d,
                            int k)
{
  if (k == 0) return atan2(y[0], x[0]);
  /* n_{k-1} = sum_{j=0..k-1} x_j (k-j) y_{k-j} - y_j (k-j) x_{k-j} */
  double n = 0.0;
  for (int j = 0; j < k; j++) n += (k - j) * (x[j] * y[k - j] - y[j] * x[k - j]);
  double acc = n;
  for (int j = 1; j < k; j++) acc -= j * z[j] * d[k - j];
  return acc / (k * d[0]);
}

void nz_series_atan2(double *z, const double *y, const double *x, int K, double *w)
{
  double *d = w, *xx = w + (K + 1), *yy = w + 2 * (K + 1);
  nz_series_mul(xx, x, x, K);
  nz_series_mul(yy, y, y, K);
  for (int k = 0; k <= K; k++) d[k] = xx[k] + yy[k];
  for (int k = 0; k <= K; k++) z[k] = nz_series_atan2_coef(z, y, x, d, k);
}
