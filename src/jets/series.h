/* series.h - coefficient kernels of truncated Taylor series.
 *
 * A series of order K is the array x[0..K] of normalized Taylor coefficients,
 * x[j] = x^(j)(t0) / j!  (docs/theory.md §3, §11).  Every kernel here exists at two
 * levels, as in TaylorSeries.jl: nz_series_<f>_coef fills coefficient k from
 * coefficients 0..k-1 of the result (and 0..k of the arguments), and
 * nz_series_<f> loops over k = 0..K.  The coefficient level is what a Taylor
 * integrator needs to build a solution order by order.
 *
 * Contracts common to all kernels:
 * - outputs never alias inputs unless a comment says they may;
 * - domain checks (log of a non-positive value, ...) are the caller's job
 *   (jet.c), so these kernels never fail: they assume a valid constant term;
 * - coefficients stay normalized: no factorials are ever formed, which is what
 *   keeps orders of 30 and more finite (docs/theory.md §11).
 */
#ifndef NZ_SERIES_H
#define NZ_SERIES_H

/* z = a * b (Cauchy product): z_k = sum_{j=0..k} a_j b_{k-j}. */
double nz_series_mul_coef(const double *a, const double *b, int k);
void nz_series_mul(double *z, const double *a, const double *b, int K);

/* z = a / b without forming 1/b:  z_k = (a_k - sum_{j<k} z_j b_{k-j}) / b_0.
 * Needs b_0 != 0. */
double nz_series_div_coef(const double *z, const double *a, const double *b, int k);
void nz_series_div(double *z, const double *a, const double *b, int K);

/* y = exp(x):  y' = x' y  =>  y_k = (1/k) sum_{j=1..k} j x_j y_{k-j}. */
double nz_series_exp_coef(const double *y, const double *x, int k);
void nz_series_exp(double *y, const double *x, int K);

/* y = log(x):  x y' = x'  =>  y_k = (x_k - (1/k) sum_{j=1..k-1} j y_j x_{k-j}) / x_0.
 * Needs x_0 > 0. */
double nz_series_log_coef(const double *y, const double *x, int k);
void nz_series_log(double *y, const double *x, int K);

/* y = x^a, a real:  x y' = a x' y  =>
 * y_k = (1/(k x_0)) sum_{j=0..k-1} (a (k-j) - j) x_{k-j} y_j.  Needs x_0 != 0. */
double nz_series_pow_coef(const double *y, const double *x, double a, int k);
void nz_series_pow(double *y, const double *x, double a, int K);

/* y = x^n, n >= 0 integer, by binary powering with Cauchy products; valid even
 * when x_0 = 0.  w: workspace of 2 (K+1) doubles. */
void nz_series_powi(double *y, const double *x, unsigned n, int K, double *w);
/* The same at the coefficient level, for a series built order by order: the
 * binary powering's squares and partial products are series of their own,
 * nz_series_powi_work(n) of them, each of K + 1 coefficients, laid one after
 * the other in w and kept between calls.  nz_series_powi_coef fills their
 * coefficient k (each a Cauchy product of series known to k) and returns
 * y_k; call it for k = 0, 1, ... in order (k <= K).  Valid at x_0 = 0.  The
 * first partial product 1 * base is not formed (y is base), so the result
 * equals nz_series_powi's up to the sign of a zero. */
int nz_series_powi_work(unsigned n);
double nz_series_powi_coef(double *w, const double *x, unsigned n, int k, int K);

/* y = sqrt(x):  y^2 = x  =>  y_k = (x_k - sum_{j=1..k-1} y_j y_{k-j}) / (2 y_0).
 * Needs x_0 > 0 when K >= 1. */
double nz_series_sqrt_coef(const double *y, const double *x, int k);
void nz_series_sqrt(double *y, const double *x, int K);

/* s = sin(x), c = cos(x) as a pair:  s' = c x', c' = -s x'  =>
 * s_k = (1/k) sum j x_j c_{k-j},  c_k = -(1/k) sum j x_j s_{k-j}.
 * With hyperbolic = 1: sinh/cosh, c_k = +(1/k) sum j x_j s_{k-j}. */
void nz_series_sincos_coef(double *s, double *c, const double *x, int k, int hyperbolic);
void nz_series_sincos(double *s, double *c, const double *x, int K, int hyperbolic);

/* t = tan(x) with u = 1 + t^2 (t' = u x'), or t = tanh(x) with u = 1 - t^2
 * (hyperbolic = 1):  t_k = (1/k) sum_{j=1..k} j x_j u_{k-j},
 * u_k = +-sum_{j=0..k} t_j t_{k-j}.  u is returned: it is dt/dx. */
void nz_series_tan_coef(double *t, double *u, const double *x, int k, int hyperbolic);
void nz_series_tan(double *t, double *u, const double *x, int K, int hyperbolic);

/* y with y' d = s x', given the series d (d_0 != 0) and a sign s = +-1:
 * k y_k d_0 = s k x_k - sum_{j=1..k-1} j y_j d_{k-j}.  This one recurrence
 * gives atan (d = 1 + x^2), asin (d = sqrt(1 - x^2), s = 1) and
 * acos (same d, s = -1) after the caller sets y_0. */
double nz_series_quadrature_coef(const double *y, const double *x, const double *d,
                                 double s, int k);
void nz_series_quadrature(double *y, const double *x, const double *d, double s, int K);

/* z = atan2(y, x):  z' d = n with d = x^2 + y^2 and n = x y' - y x' =>
 * k z_k d_0 = n_{k-1} - sum_{j=1..k-1} j z_j d_{k-j}.  w: 3 (K+1) doubles;
 * on return w[0..K] holds d. */
void nz_series_atan2(double *z, const double *y, const double *x, int K, double *w);
/* Its coefficient level: z_k from z_0..z_{k-1}, x and y to k, and the series
 * d = x^2 + y^2 to k - 1 (the caller keeps d: d_k = (x x)_k + (y y)_k). */
double nz_series_atan2_coef(const double *z, const double *y, const double *x, const double *d,
                            int k);

/* A second-order ODE's coefficient a_{n+2} = x / ((n + 1)(n + 2)) from
 * q''s coefficient n = x.  A product by the rounded reciprocal has the same
 * relative error at every step (the reciprocal's, fixed for each n): a bias
 * of every polynomial a Taylor step takes, which adds up over a long run
 * into a drift of the energy (Henon-Heiles at 1e-15: 7e-13 after 1e5 time
 * units, growing as t; 3e-14 with the division, whose rounding has no
 * bias).  The division is dearer (its latency is on the path from one
 * order to the next), and a bias matters only as much as its term: a_{n+2}
 * h^{n+2} is about e^(-2(n+2)) of the state at the steps of taylor.c, so
 * the orders from NZ_SERIES_ODE2_DIVIDED on (terms below e^-16 of the
 * state) keep the product.  Written once here, read by the interpreter
 * (mech_graph_series.c) and printed into the machine code (series_native.c), so
 * both give the same numbers. */
#define NZ_SERIES_ODE2_DIVIDED 6
static inline double nz_series_ode2_coef(double x, int n)
{
  double m = (double)(n + 1) * (double)(n + 2);
  return n < NZ_SERIES_ODE2_DIVIDED ? x / m : x * (1.0 / m);
}

#endif
