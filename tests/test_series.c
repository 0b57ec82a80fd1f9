/* test_series.c - the coefficient kernels (series.c) and jets (jet.c) in C,
 * without Lua, against closed-form Taylor series; and the central-difference
 * Jacobian of constrained_series.c against a closed form; the SPD solve of
 * core/linalg.c against GSL's Cholesky and against an explicit inverse; the
 * seedings of nz_constraint_eval (mech.c) against a constraint's derivatives
 * by hand.  GSL's test functions
 * print one PASS/FAIL line per check (GSL_TEST_VERBOSE style). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <gsl/gsl_linalg.h>
#include <gsl/gsl_math.h>
#include <gsl/gsl_sf_gamma.h>
#include <gsl/gsl_test.h>
#include "core/linalg.h"
#include "core/status.h"
#include "mech/constrained_series.h"
#include "mech/mech.h"
#include "jets/jet.h"
#include "jets/series.h"

/* ------------------------------------------------------------------ */
/* nz_constraint_eval's seedings (mech.h) against hand derivatives      */

/* Phi = t q0 q1' + q0 q2''^2 + q1'''/2 on three coordinates, evaluated on
 * whatever jets the seeding made (the constraint's four default slots). */
static int phi_eval(void *ctx, nz_piece p, int index, const nz_jet *t, nz_jet *const *const *lv, int nl,
                    nz_jet *const *out, const nz_direction *dir)
{
  (void)ctx, (void)index;
  if (p != NZ_PIECE_PHI || nl < 4 || dir) return NZ_EARG;
  int Ko = out[0]->order, D = out[0]->ntan;
  double work[256];
  nz_jet *a = nz_jet_alloc(Ko, D), *b = nz_jet_alloc(Ko, D);
  int st = !a || !b ? NZ_ENOMEM : NZ_OK;
  if (!st) st = nz_jet_mul(a, t, lv[0][0], work);
  if (!st) st = nz_jet_mul(b, a, lv[1][1], work);           /* t q0 q1' */
  if (!st) st = nz_jet_mul(a, lv[2][2], lv[2][2], work);
  if (!st) st = nz_jet_mul(out[0], a, lv[0][0], work);      /* q0 q2''^2 */
  if (!st) st = nz_jet_add(a, out[0], b);
  if (!st) st = nz_jet_scale(b, lv[3][1], 0.5);
  if (!st) st = nz_jet_add(out[0], a, b);
  nz_jet_free(a);
  nz_jet_free(b);
  return st;
}

static void check_constraint_eval(void)
{
  nz_system s;
  memset(&s, 0, sizeof s);
  s.k = 3;
  s.nc = 1;
  s.has = 1u << NZ_PIECE_PHI;
  s.ev.eval = phi_eval;
  double t = 0.731, q[3] = { 1.385, -0.62, 0.27 }, qd[3] = { 0.41, 2.385, -1.1 }, qdd[3] = { -0.35, 0.92, 1.615 },
         qddd[3] = { 0.8, -0.45, 1.3 };
  const double *state[4] = { q, qd, qdd, qddd };
  double phi = t * q[0] * qd[1] + q[0] * qdd[2] * qdd[2] + 0.5 * qddd[1], e, f;
  nz_motion mo = { 0 };
  nz_jet *o;

  /* every slot as a whole and t: the partial derivatives */
  nz_constraint_seeding partials = { .D = -1, .t_variable = 1, .count = -1, .by_slot = 1 };
  int st = nz_constraint_eval(&s, 0, &mo, t, state, 4, &partials);
  o = mo.out[0];
  double want[13] = { 0 };
  want[0] = t * qd[1] + qdd[2] * qdd[2];
  want[3 + 1] = t * q[0];
  want[6 + 2] = 2 * q[0] * qdd[2];
  want[9 + 1] = 0.5;
  want[12] = q[0] * qd[1];
  e = st ? 1.0 : fabs(o->c[0] - phi);
  for (int d = 0; !st && d < 13; d++) e = fmax(e, fabs(nz_jet_tangent(o, d)[0] - want[d]));
  gsl_test(st || mo.nslots != 4 || o->ntan != 13 || e > 1e-14,
           "constraint eval: slots as a whole and t as a variable give Phi and its 12 + 1 partials (%.3g)", e);

  /* tangents on q'' by level, to order 1: d(Phi')/dq'' = dPhi/dq' + d/dt dPhi/dq'' */
  nz_constraint_seeding row = { .K = 1, .D = 3, .first = 2, .count = 1 };
  st = nz_constraint_eval(&s, 0, &mo, t, state, 4, &row);
  o = mo.out[0];
  double dphi = q[0] * qd[1] + t * qd[0] * qd[1] + t * q[0] * qdd[1] + qd[0] * qdd[2] * qdd[2]
              + 2 * q[0] * qdd[2] * qddd[2];   /* q'''' = 0 */
  double A1[3] = { 0.0, t * q[0], 2 * qd[0] * qdd[2] + 2 * q[0] * qddd[2] };
  e = st ? 1.0 : fmax(fabs(o->c[0] - phi), fabs(o->c[1] - dphi));
  for (int i = 0; !st && i < 3; i++) e = fmax(e, fabs(nz_jet_tangent(o, i)[1] - A1[i]));
  gsl_test(st || e > 1e-14, "constraint eval: q'' seeded by level gives Phi' and its row dPhi'/dq'' (%.3g)", e);

  /* q and q' by level, order 0: the state gradient */
  nz_constraint_seeding grad = { .D = 6, .count = 2 };
  st = nz_constraint_eval(&s, 0, &mo, t, state, 4, &grad);
  o = mo.out[0];
  double g[6] = { t * qd[1] + qdd[2] * qdd[2], 0, 0, 0, t * q[0], 0 };
  e = 0.0;
  for (int d = 0; !st && d < 6; d++) e = fmax(e, fabs(nz_jet_tangent(o, d)[0] - g[d]));
  gsl_test(st || e > 1e-14, "constraint eval: q and q' seeded by level give the state gradient (%.3g)", e);

  /* the series frozen but along v on slot 2: Phi, its slope and half its curvature along v */
  double v[3] = { 0.3, -0.7, 1.1 };
  nz_constraint_seeding curv = { .K = 2, .frozen = 1, .along_slot = 2, .along = v };
  st = nz_constraint_eval(&s, 0, &mo, t, state, 4, &curv);
  o = mo.out[0];
  e = st ? 1.0 : fmax(fabs(o->c[0] - phi), fmax(fabs(o->c[1] - 2 * q[0] * qdd[2] * v[2]), fabs(o->c[2] - q[0] * v[2] * v[2])));
  gsl_test(st || e > 1e-14, "constraint eval: frozen along v on q'' gives Phi, Phi_q'' v, v^T Phi_q''q'' v / 2 (%.3g)", e);

  /* frozen along q''_2 alone, tangents on slot 2: column 2 of the Hessian in q'' */
  nz_constraint_seeding hess = { .K = 1, .D = 3, .frozen = 1, .along_slot = 2, .along_index = 2, .first = 2,
                                 .count = 1, .by_slot = 1 };
  st = nz_constraint_eval(&s, 0, &mo, t, state, 4, &hess);
  o = mo.out[0];
  e = st ? 1.0 : fmax(fmax(fabs(nz_jet_tangent(o, 0)[1]), fabs(nz_jet_tangent(o, 1)[1])),
                      fabs(nz_jet_tangent(o, 2)[1] - 2 * q[0]));
  gsl_test(st || e > 1e-14, "constraint eval: frozen along q''_2 with q'' tangents gives the Hessian's column (%.3g)", e);

  /* the check's tangent along the slots above 1, weighted */
  double sizes[4] = { 1.0, 2.5, 1.75, 3.25 };
  nz_constraint_seeding check = { .nslots = 4, .D = 1, .above = 1, .sizes = sizes };
  st = nz_constraint_eval(&s, 0, &mo, t, state, 4, &check);
  f = nz_check_slot_weight(2, 2, 3) * sizes[2] * 2 * q[0] * qdd[2] + nz_check_slot_weight(3, 1, 3) * sizes[3] * 0.5;
  e = st ? 1.0 : fabs(nz_jet_tangent(mo.out[0], 0)[0] - f);
  gsl_test(st || e > 1e-14 * fabs(f), "constraint eval: the check's tangent is the weighted derivative along q'', q''' (%.3g)", e);

  /* slots the workspace does not have */
  nz_constraint_seeding far = { .K = 2, .frozen = 1, .along_slot = 4, .along = v };
  nz_constraint_seeding wide = { .D = 6, .first = 3, .count = 2, .by_slot = 1 };
  gsl_test(nz_constraint_eval(&s, 0, &mo, t, state, 4, &far) != NZ_EARG
           || nz_constraint_eval(&s, 0, &mo, t, state, 4, &wide) != NZ_EARG,
           "constraint eval: a frozen series along slot 4, or tangents on slots 3 and 4, of 4 slots is NZ_EARG");
  nz_motion_free(&mo);
}

#define K 40
/* Closed-form coefficients below are sums of at most K products of O(1)
 * numbers: a few hundred ulps is the honest rounding bound. */
#define TOL (256 * GSL_DBL_EPSILON)

static double x[K + 1], y[K + 1], z[K + 1], w[8 * (K + 1)];

static void variable(double *s, double t0)
{
  for (int j = 0; j <= K; j++) s[j] = 0.0;
  s[0] = t0;
  s[1] = 1.0;
}

/* |got - want| relative to max(|want|, floor): floor keeps tiny coefficients
 * from demanding more than rounding of O(floor) terms can give. */
static void check_series(const char *what, const double *got, double (*want)(int, double),
                         double p, double floor)
{
  double worst = 0.0;
  int at = 0;
  for (int j = 0; j <= K; j++) {
    double e = fabs(got[j] - want(j, p)) / fmax(fabs(want(j, p)), floor);
    if (e > worst) { worst = e; at = j; }
  }
  gsl_test(!(worst <= TOL), "%s: coefficients 0..%d, worst relative error %.2g at c_%d", what,
           K, worst, at);
}

static double exp_coef(int j, double a) { return exp(a) / gsl_sf_fact((unsigned)j); }
/* log(a + s) = log a + sum_{j>=1} (-1)^(j+1) s^j / (j a^j) */
static double log_coef(int j, double a) { return j == 0 ? log(a) : (j % 2 ? 1 : -1) / (j * pow(a, j)); }
/* 1/(a - s) = sum s^j / a^(j+1) */
static double geometric_coef(int j, double a) { return 1.0 / pow(a, j + 1); }
/* (1 + s)^p = sum binomial(p, j) s^j */
static double binomial_coef(int j, double p)
{
  double c = 1.0;
  for (int i = 0; i < j; i++) c *= (p - i) / (i + 1);
  return c;
}
/* atan(s) = sum (-1)^m s^(2m+1) / (2m+1) */
static double atan_coef(int j, double unused)
{
  (void)unused;
  return j % 2 ? ((j / 2) % 2 ? -1.0 : 1.0) / j : 0.0;
}
/* sin(a + s), cos(a + s): derivatives cycle through sin, cos, -sin, -cos */
static double sin_coef(int j, double a)
{
  double d[4] = { sin(a), cos(a), -sin(a), -cos(a) };
  return d[j % 4] / gsl_sf_fact((unsigned)j);
}
static double cosh_coef(int j, double a) { return (j % 2 ? sinh(a) : cosh(a)) / gsl_sf_fact((unsigned)j); }
/* asin(s) = sum (2m)! / (4^m (m!)^2 (2m+1)) s^(2m+1) */
static double asin_coef(int j, double unused)
{
  (void)unused;
  if (j % 2 == 0) return 0.0;
  int m = j / 2;
  return exp(gsl_sf_lnchoose((unsigned)(2 * m), (unsigned)m) - m * log(4.0)) / j;
}

/* f(t, y) = (sin(y0) y1, e^t y0^2, log(y2)) for nz_central_jacobian: its
 * Jacobian is (cos(y0) y1, sin(y0), 0; 2 e^t y0, 0, 0; 0, 0, 1/y2) and
 * dfdt = (0, e^t y0^2, 0). */
static int fd_test_rhs(double t, const double *v, double *f, void *ctx)
{
  (void)ctx;
  f[0] = sin(v[0]) * v[1];
  f[1] = exp(t) * v[0] * v[0];
  f[2] = log(v[2]);
  return 0;
}

static void check_central_jacobian(void)
{
  /* y2 = 1e6: a fixed step of 6e-6 would lose 4 digits to rounding in
   * d log(y2)/dy2 = 1e-6; the step per component keeps all of them. */
  double t = 0.3, v[3] = { 0.7, 2.385, 1e6 }, J[9], dt[3], work[9];
  double want[9] = { cos(0.7) * 2.385, sin(0.7), 0, 2 * exp(t) * 0.7, 0, 0, 0, 0, 1e-6 };
  double want_t[3] = { 0, exp(t) * 0.49, 0 }, worst = 0.0;
  int st = nz_central_jacobian(3, t, v, fd_test_rhs, NULL, J, dt, work);
  for (int i = 0; i < 9; i++) worst = fmax(worst, fabs(J[i] - want[i]) / (want[i] != 0 ? fabs(want[i]) : 1.0));
  for (int i = 0; i < 3; i++) worst = fmax(worst, fabs(dt[i] - want_t[i]) / (want_t[i] != 0 ? fabs(want_t[i]) : 1.0));
  /* h^2 |f'''| / 6 + eps |f| / h with h = 6e-6 (1 + |y|): measured 4.5e-11 relative */
  gsl_test(st || !(worst <= 1e-9), "central-difference Jacobian, step per component (relative error %.2g)", worst);
}

/* Branches (nz_jet_compare, nz_jet_select, NZ_FN_SIGN) against hand-built
 * series: u = t - t0 at t0 is 0 in value and grows, so every comparison with
 * 0 is decided by c_1 (the motion after t0), and a selection is a copy. */
static void check_branches(void)
{
  nz_jet *u = nz_jet_alloc(3, 2), *zero = nz_jet_alloc(3, 0), *r = nz_jet_alloc(3, 2);
  nz_jet *v = nz_jet_alloc(5, 1), *d = nz_jet_alloc(0, 1), *dz = nz_jet_alloc(0, 1);
  double ww[8 * 6];
  nz_jet_set_variable(u, 0.7, 1);    /* tangent 2 seeded */
  u->c[0] -= 0.7;                    /* u = t - t0: c = {0, 1, 0, 0} */
  nz_jet_set_constant(zero, 0.0);
  static const struct { nz_cmp op; double want; const char *name; } cases[] = {
    { NZ_CMP_LT, 0, "lt" }, { NZ_CMP_LE, 0, "le" }, { NZ_CMP_GT, 1, "gt" },
    { NZ_CMP_GE, 1, "ge" }, { NZ_CMP_EQ, 0, "eq" }, { NZ_CMP_NE, 1, "ne" },
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    int st = nz_jet_compare(r, cases[i].op, u, zero);
    double rest = 0.0;
    for (int k = 1; k < 12; k++) rest += fabs(r->c[k]);
    gsl_test(st || r->c[0] != cases[i].want || rest != 0.0,
             "compare %s(t - t0, 0) at t0 is %g by c_1, a constant (got %g, rest %g)",
             cases[i].name, cases[i].want, r->c[0], rest);
  }
  /* An order 0 dual number knows only the value: a tie is equality. */
  nz_jet_set_variable(d, 0.0, 0);
  nz_jet *zero0 = nz_jet_alloc(0, 0);
  nz_jet_set_constant(zero0, 0.0);
  gsl_test(nz_jet_compare(dz, NZ_CMP_EQ, d, zero0) || dz->c[0] != 1.0,
           "compare eq(dual 0 + eps, 0) is 1: tangents are not compared");
  /* select: the chosen jet, copied whole into r's shape (order 3 of v's 5,
   * tangent 2 that v lacks is 0); r may be the condition. */
  for (int k = 0; k <= 5; k++) { v->c[k] = 1.0 / (k + 1); nz_jet_tangent(v, 0)[k] = k; }
  nz_jet_set_constant(r, 1.0);
  int st = nz_jet_select(r, r, v, u), bad = 0;
  for (int k = 0; k <= 3; k++)
    bad |= r->c[k] != v->c[k] || nz_jet_tangent(r, 0)[k] != k || nz_jet_tangent(r, 1)[k] != 0.0;
  gsl_test(st || bad, "select(1, v, u) copies v in the shape (3, 2), the missing tangent 0");
  nz_jet_set_constant(r, 0.0);
  st = nz_jet_select(r, r, v, u);
  bad = 0;
  for (int k = 0; k <= 3; k++)
    bad |= r->c[k] != u->c[k] || nz_jet_tangent(r, 1)[k] != nz_jet_tangent(u, 1)[k];
  gsl_test(st || bad, "select(0, v, u) copies u");
  /* sign(t0 - t): decided by c_1 = -1, every derivative 0. */
  nz_jet *m = nz_jet_alloc(3, 2);
  nz_jet_scale(m, u, -1.0);
  st = nz_jet_apply(r, NZ_FN_SIGN, m, ww);
  nz_jet_free(m);
  double rest = 0.0;
  for (int k = 1; k < 12; k++) rest += fabs(r->c[k]);
  gsl_test(st || r->c[0] != -1.0 || rest != 0.0, "sign(t0 - t) at t0 is -1, derivatives 0");
  gsl_test(strcmp(nz_jet_fn_names[NZ_FN_SIGN], "sign") != 0, "NZ_FN_SIGN is named sign");
  /* NaN is a status, never a branch. */
  zero->c[2] = NAN;
  gsl_test(nz_jet_compare(r, NZ_CMP_GT, u, zero) != NZ_OK, "compare decided at c_1 before a NaN c_2");
  zero->c[1] = NAN;
  gsl_test(nz_jet_compare(r, NZ_CMP_GT, u, zero) != NZ_ENAN, "compare meeting a NaN is NZ_ENAN");
  nz_jet_set_constant(dz, NAN);
  gsl_test(nz_jet_select(r, dz, u, u) != NZ_ENAN, "select on a NaN condition is NZ_ENAN");
  nz_jet_free(u); nz_jet_free(zero); nz_jet_free(r); nz_jet_free(v); nz_jet_free(d);
  nz_jet_free(dz); nz_jet_free(zero0);
}

/* The coefficient level of binary powering and of atan2, built order by
 * order, against closed forms and against the whole-series kernels. */
static void check_coefficient_level(void)
{
  enum { NW = 64 };
  double *pw = malloc((size_t)NW * (K + 1) * sizeof *pw), whole[K + 1], s[K + 1], c[K + 1];
  static const unsigned ns[] = { 1, 2, 3, 5, 7, 12, 31 };
  double worst = 0.0;
  int exact = 1, work_ok = 1;
  for (size_t i = 0; i < sizeof ns / sizeof ns[0]; i++) {
    unsigned n = ns[i];
    work_ok = work_ok && nz_series_powi_work(n) <= NW;
    variable(x, 1.0);   /* (1 + t)^n: binomial coefficients */
    for (int k = 0; k <= K; k++) y[k] = nz_series_powi_coef(pw, x, n, k, K);
    for (int k = 0; k <= K; k++)
      worst = fmax(worst, fabs(y[k] - binomial_coef(k, n)) / fmax(fabs(binomial_coef(k, n)), 1.0));
    nz_series_powi(whole, x, n, K, w);
    for (int k = 0; k <= K; k++) exact = exact && whole[k] == y[k];
    variable(x, 0.0);   /* t^n at 0, where the power recurrence cannot go */
    for (int k = 0; k <= K; k++) y[k] = nz_series_powi_coef(pw, x, n, k, K);
    for (int k = 0; k <= K; k++) worst = fmax(worst, fabs(y[k] - (k == (int)n)));
  }
  gsl_test(!work_ok || !(worst <= TOL),
           "x^n coefficient by coefficient, n = 1..31: (1 + t)^n binomial, t^n at 0 (%.2g)", worst);
  gsl_test(!exact, "x^n coefficient by coefficient equals nz_series_powi");
  /* atan2(r sin(a + t), r cos(a + t)) = a + t for a in (-pi, pi) */
  static const double as[] = { 0.3, 2.9, -2.0 };
  worst = 0.0;
  exact = 1;
  for (size_t i = 0; i < sizeof as / sizeof as[0]; i++) {
    variable(x, as[i]);
    nz_series_sincos(s, c, x, K, 0);
    for (int k = 0; k <= K; k++) { s[k] *= 1.7; c[k] *= 1.7; }
    double d[K + 1];
    for (int k = 0; k <= K; k++) {
      d[k] = nz_series_mul_coef(c, c, k) + nz_series_mul_coef(s, s, k);
      z[k] = nz_series_atan2_coef(z, s, c, d, k);
    }
    for (int k = 0; k <= K; k++) worst = fmax(worst, fabs(z[k] - x[k]) / fmax(fabs(x[k]), 1.0));
    nz_series_atan2(whole, s, c, K, w);
    for (int k = 0; k <= K; k++) exact = exact && whole[k] == z[k];
  }
  gsl_test(!(worst <= TOL), "atan2(1.7 sin(a + t), 1.7 cos(a + t)) coefficient by coefficient is a + t (%.2g)",
           worst);
  gsl_test(!exact, "atan2 coefficient by coefficient equals nz_series_atan2");
  free(pw);
}

/* nz_solve_spd_in (hand-written Cholesky, Hager-Higham estimate) against a
 * second path that shares none of its code: GSL's Cholesky solve, and the
 * exact reciprocal condition number in the 1-norm from GSL's explicit
 * inverse.  Matrices A = Q D Q^T with Q a product of reflections and D of
 * a chosen condition, k = 1 .. 24. */
static void spd_matrix(int k, double cond, unsigned seed, double *A)
{
  double *v = malloc((size_t)k * sizeof *v), *Q = malloc((size_t)k * (size_t)k * sizeof *Q);
  for (int i = 0; i < k * k; i++) Q[i] = i % (k + 1) == 0 ? 1.0 : 0.0;
  for (int r = 0; r < 3; r++) {                 /* Q = H3 H2 H1, H = I - 2 v v^T / v^T v */
    double vv = 0.0;
    for (int i = 0; i < k; i++) {
      seed = seed * 1103515245u + 12345u;
      v[i] = ((seed >> 8) & 0xffff) / 65536.0 - 0.5;
      vv += v[i] * v[i];
    }
    for (int i = 0; i < k; i++) {             /* rows of Q times H */
      double d = 0.0;
      for (int j = 0; j < k; j++) d += Q[i * k + j] * v[j];
      for (int j = 0; j < k; j++) Q[i * k + j] -= 2.0 * d * v[j] / vv;
    }
  }
  for (int i = 0; i < k; i++)
    for (int j = 0; j < k; j++) {
      double s = 0.0;
      for (int m = 0; m < k; m++) {
        double dm = k == 1 ? 1.0 : pow(cond, -(double)m / (k - 1));   /* from 1 down to 1/cond */
        s += Q[i * k + m] * dm * Q[j * k + m];
      }
      A[i * k + j] = s;
    }
  for (int i = 0; i < k; i++)                 /* exactly symmetric */
    for (int j = 0; j < i; j++) A[j * k + i] = A[i * k + j];
  free(v);
  free(Q);
}

static void check_spd_solve(void)
{
  double worst_x = 0.0, worst_lo = 0.0, worst_hi = 0.0, worst_gsl = 0.0, worst_bound = -1.0;
  int bad = 0, bounded = 0, refactor = 0;
  for (int k = 1; k <= 24; k++)
    for (int c = 0; c < 3; c++) {
      double cond = c == 0 ? 10.0 : c == 1 ? 1e4 : 1e9;
      double *A = malloc((size_t)k * (size_t)k * sizeof *A), *F = malloc((size_t)k * (size_t)k * sizeof *F);
      double *b = malloc((size_t)k * sizeof *b), *sol = malloc((size_t)k * sizeof *sol), x_unused[24];
      double *work = malloc(nz_solve_spd_work_len(k) * sizeof *work);
      spd_matrix(k, cond, 17u * (unsigned)k + (unsigned)c, A);
      for (int i = 0; i < k; i++) b[i] = sin(1.0 + i);
      memcpy(F, A, (size_t)k * (size_t)k * sizeof *F);
      nz_solve_info info, est;
      bad += nz_solve_spd_in(k, F, b, sol, 1e-14, &info, work) != NZ_OK;
      /* the factor left in F solves the same right-hand side again, bit for bit */
      double again[24];
      memcpy(again, b, (size_t)k * sizeof *again);
      nz_cholesky_solve(k, F, again);
      refactor += memcmp(again, sol, (size_t)k * sizeof *again) != 0;
      /* rcond_min = 1 refuses every matrix but 1 x 1 ones after estimating rcond */
      memcpy(F, A, (size_t)k * (size_t)k * sizeof *F);
      nz_solve_spd_in(k, F, b, x_unused, 1.0, &est, work);
      /* GSL: the solution, its estimate, and the exact 1-norm of A^-1 */
      gsl_matrix *G = gsl_matrix_alloc((size_t)k, (size_t)k);
      gsl_vector *gx = gsl_vector_alloc((size_t)k), *gw = gsl_vector_alloc(3 * (size_t)k);
      gsl_vector_view gb = gsl_vector_view_array(b, (size_t)k);
      double anorm = 0.0, inorm = 0.0, grcond;
      for (int i = 0; i < k; i++) {
        double s = 0.0;
        for (int j = 0; j < k; j++) { s += fabs(A[i * k + j]); gsl_matrix_set(G, (size_t)i, (size_t)j, A[i * k + j]); }
        anorm = fmax(anorm, s);
      }
      gsl_linalg_cholesky_decomp1(G);
      gsl_linalg_cholesky_solve(G, &gb.vector, gx);
      gsl_linalg_cholesky_rcond(G, &grcond, gw);
      gsl_linalg_cholesky_invert(G);
      for (int j = 0; j < k; j++) {
        double s = 0.0;
        for (int i = 0; i < k; i++) s += fabs(gsl_matrix_get(G, (size_t)i, (size_t)j));
        inorm = fmax(inorm, s);
      }
      double exact = 1.0 / (anorm * inorm), xn = 0.0, dx = 0.0;
      for (int i = 0; i < k; i++) {
        xn = fmax(xn, fabs(gsl_vector_get(gx, (size_t)i)));
        dx = fmax(dx, fabs(sol[i] - gsl_vector_get(gx, (size_t)i)));
      }
      /* both are backward stable: they differ by about cond * eps */
      worst_x = fmax(worst_x, dx / xn / (cond * GSL_DBL_EPSILON));
      /* the estimate of ||A^-1|| is a lower bound: rcond at least the exact one (which the
       * explicit inverse knows to about cond eps), within a factor 3 */
      worst_lo = fmax(worst_lo, (exact / est.rcond - 1.0) / (cond * GSL_DBL_EPSILON));
      worst_hi = fmax(worst_hi, est.rcond / exact);
      worst_gsl = fmax(worst_gsl, fmax(est.rcond / grcond, grcond / est.rcond));
      /* the bound that spared the estimate is below the exact rcond */
      worst_bound = fmax(worst_bound, (info.rcond / exact - 1.0) / (cond * GSL_DBL_EPSILON));
      if (info.rcond < est.rcond) bounded++;
      gsl_matrix_free(G);
      gsl_vector_free(gx);
      gsl_vector_free(gw);
      free(A); free(F); free(b); free(sol); free(work);
    }
  gsl_test(bad != 0, "SPD solve: every matrix of condition 10, 1e4, 1e9 and k = 1..24 is solved (%d refused)", bad);
  gsl_test(refactor != 0, "SPD solve: nz_cholesky_solve with the factor left in A repeats the solve (%d differ)",
           refactor);
  gsl_test(!(worst_x <= 50.0), "SPD solve: x against GSL's Cholesky within 50 cond eps (worst %.3g)", worst_x);
  gsl_test(!(worst_lo <= 10.0), "SPD solve: rcond is never below the exact 1-norm one by more than 10 cond eps "
           "(worst (exact/estimate - 1) / (cond eps) = %.3g)", worst_lo);
  gsl_test(!(worst_hi <= 3.0), "SPD solve: rcond within a factor 3 of the exact one (worst %.3g)", worst_hi);
  gsl_test(!(worst_gsl <= 3.0), "SPD solve: rcond within a factor 3 of GSL's estimate (worst %.3g)", worst_gsl);
  gsl_test(!(worst_bound <= 10.0) || bounded < 30,
           "SPD solve: the cheap bound that clears rcond_min (%d of 72 matrices) is below the exact rcond "
           "(worst (bound/exact - 1) / (cond eps) = %.3g)", bounded, worst_bound);

  /* refusals: not positive definite (with the eigenvalue range), and too badly conditioned */
  double N[4] = { 1.0, 2.0, 2.0, 1.0 }, bb[2] = { 1.0, 1.0 }, xx[2], ws[2 * 2 + 6];
  nz_solve_info info;
  int st = nz_solve_spd_in(2, N, bb, xx, 1e-14, &info, ws);
  gsl_test(st != NZ_ESINGULAR || !info.not_spd || fabs(info.eig_min + 1.0) > 1e-12 || fabs(info.eig_max - 3.0) > 1e-12,
           "SPD solve: [[1, 2], [2, 1]] is refused as not positive definite, eigenvalues -1 .. 3 (%g .. %g)",
           info.eig_min, info.eig_max);
  double S[4] = { 1.0, 1.0, 1.0, 1.0 + 1e-15 };
  st = nz_solve_spd_in(2, S, bb, xx, 1e-14, &info, ws);
  gsl_test(st != NZ_ESINGULAR || info.not_spd || !(info.rcond < 1e-14),
           "SPD solve: [[1, 1], [1, 1 + 1e-15]] is refused as too badly conditioned (rcond %.3g)", info.rcond);
}

/* nz_series_ode2_coef: x / ((n + 1)(n + 2)) rounded as the division
 * rounds it (the hardware's, correctly rounded) for the orders below
 * NZ_SERIES_ODE2_DIVIDED, and within an ulp above; and, the point of it,
 * without the bias of the rounded reciprocal there: over 20000 x in
 * [1, 2) per order, the mean of the signed error in ulps is near 0 (below
 * 0.05), where the product by the rounded 1/m is off by more than that in
 * the mean for m = 6, 12, 20 (0.17, 0.33, 0.36 ulp: the reciprocal's
 * relative error, the same at every x). */
static void check_ode2_coef(void)
{
  int worst_ulps = 0, mismatches = 0, biased_plain = 0;
  double worst_mean = 0.0;
  unsigned long seed = 12345;
  for (int n = 0; n <= 60; n++) {
    double m = (double)(n + 1) * (double)(n + 2), sum = 0.0, sum_plain = 0.0;
    for (int j = 0; j < 20000; j++) {
      seed = seed * 6364136223846793005UL + 1442695040888963407UL;
      double u = 1.0 + (double)(seed >> 11) / 9007199254740992.0;   /* [1, 2) */
      double want = u / m, got = nz_series_ode2_coef(u, n), ulp = nextafter(want, INFINITY) - want;
      int ulps = (int)fabs((got - want) / ulp);
      if (ulps > worst_ulps) worst_ulps = ulps;
      if (n < NZ_SERIES_ODE2_DIVIDED) {
        mismatches += got != want;
        /* the signed error against the exact u / m: m got - u is exact
         * in one fma (a multiple of ulp(got) below m ulp(got)) */
        sum += -fma(m, got, -u) / m / ulp;
        sum_plain += -fma(m, u * (1.0 / m), -u) / m / ulp;
      }
    }
    if (n < NZ_SERIES_ODE2_DIVIDED) {
      double mean = sum / 20000, mean_plain = sum_plain / 20000;
      if (fabs(mean) > worst_mean) worst_mean = fabs(mean);
      biased_plain += fabs(mean_plain) > 0.05;
    }
  }
  gsl_test(worst_ulps > 1 || mismatches > 0,
           "ode2 coefficient: x / (n + 1)(n + 2) is the division below order %d (%d differ), within 1 ulp above "
           "(worst %d)", NZ_SERIES_ODE2_DIVIDED, mismatches, worst_ulps);
  gsl_test(!(worst_mean < 0.05) || biased_plain < 3,
           "ode2 coefficient: mean signed error %.3g ulp at worst below order %d (the product by the rounded 1/m: "
           "biased by more than 0.05 ulp at %d of those orders)", worst_mean, NZ_SERIES_ODE2_DIVIDED, biased_plain);
}

/* nz_lu (partial pivoting written out) against GSL's LU on 50 random
 * nonsymmetric systems of 1 to 12 unknowns, whose pivots come from every
 * column; and nz_lstsq_in's least-norm solution of a consistent wide system
 * against its two properties (it solves it; it is orthogonal to the null
 * space: x = A^T y). */
static void check_lu_lstsq(void)
{
  unsigned seed = 2385u;
  double worst = 0.0, worst_ln = 0.0;
  nz_lu *f = nz_lu_new(12);
  nz_lstsq_ws *ws = nz_lstsq_new(12);
  for (int trial = 0; trial < 50; trial++) {
    int n = 1 + trial % 12;
    double A[144], b[12], sol[12], yy[12];
    for (int i = 0; i < n * n; i++) {
      seed = seed * 1103515245u + 12345u;
      A[i] = ((seed >> 8) & 0xffff) / 65536.0 - 0.5;
    }
    for (int i = 0; i < n; i++) b[i] = sol[i] = 0.3 + 0.17 * i;
    gsl_matrix *G = gsl_matrix_alloc((size_t)n, (size_t)n);
    gsl_permutation *p = gsl_permutation_alloc((size_t)n);
    gsl_vector *gx = gsl_vector_alloc((size_t)n);
    int sg;
    memcpy(G->data, A, (size_t)(n * n) * sizeof(double));
    gsl_linalg_LU_decomp(G, p, &sg);
    gsl_vector_const_view gb = gsl_vector_const_view_array(b, (size_t)n);
    gsl_linalg_LU_solve(G, p, &gb.vector, gx);
    if (nz_lu_factor(f, n, A) || nz_lu_solve(f, sol)) worst = INFINITY;
    for (int i = 0; i < n; i++) worst = fmax(worst, fabs(sol[i] - gsl_vector_get(gx, (size_t)i)) / (1.0 + fabs(sol[i])));
    gsl_matrix_free(G);
    gsl_permutation_free(p);
    gsl_vector_free(gx);
    /* the wide system: the first n/2 + 1 rows of A, its right-hand side made consistent */
    int m = n / 2 + 1, rank;
    for (int i = 0; i < m; i++) {
      b[i] = 0.0;
      for (int j = 0; j < n; j++) b[i] += A[i * n + j] * (0.7 - 0.11 * j);
    }
    if (nz_lstsq_in(ws, m, n, A, b, sol, 1e-13, &rank) || rank != (m < n ? m : n)) worst_ln = INFINITY;
    for (int i = 0; i < m; i++) {
      double r = -b[i];
      for (int j = 0; j < n; j++) r += A[i * n + j] * sol[j];
      worst_ln = fmax(worst_ln, fabs(r));
    }
    /* least norm: x in the row space, y = (A A^T)^-1 A x reproduces it */
    double AAt[144], Ax[12];
    for (int i = 0; i < m; i++) {
      Ax[i] = 0.0;
      for (int j = 0; j < n; j++) Ax[i] += A[i * n + j] * sol[j];
      for (int k2 = 0; k2 < m; k2++) {
        AAt[i * m + k2] = 0.0;
        for (int j = 0; j < n; j++) AAt[i * m + k2] += A[i * n + j] * A[k2 * n + j];
      }
    }
    if (nz_lu_factor(f, m, AAt) == NZ_OK) {
      memcpy(yy, Ax, (size_t)m * sizeof(double));
      nz_lu_solve(f, yy);
      for (int j = 0; j < n; j++) {
        double v = 0.0;
        for (int i = 0; i < m; i++) v += A[i * n + j] * yy[i];
        worst_ln = fmax(worst_ln, fabs(v - sol[j]));
      }
    }
  }
  nz_lu_free(f);
  nz_lstsq_free(ws);
  gsl_test(worst > 1e-12, "LU: 50 random systems of 1 to 12 unknowns as GSL solves them (relative difference %.3g)", worst);
  gsl_test(worst_ln > 1e-12, "least squares: the least-norm solution of 50 wide systems solves them, in A's row space "
           "(%.3g)", worst_ln);
}

int main(void)
{
  check_central_jacobian();
  gsl_test_verbose(1);
  check_constraint_eval();
  check_ode2_coef();
  check_lu_lstsq();
  check_branches();
  check_coefficient_level();
  check_spd_solve();
  double one[K + 1];
  variable(x, 0.0);

  variable(x, 0.385);
  nz_series_exp(y, x, K);
  check_series("exp(0.385 + t)", y, exp_coef, 0.385, 1e-300);

  variable(x, 2.385);
  nz_series_log(y, x, K);
  check_series("log(2.385 + t)", y, log_coef, 2.385, 1e-300);

  for (int j = 0; j <= K; j++) one[j] = j == 0;
  variable(x, 1.385);
  for (int j = 0; j <= K; j++) x[j] = -x[j];
  x[0] += 2 * 1.385;                 /* x = 1.385 - t */
  nz_series_div(y, one, x, K);
  check_series("1 / (1.385 - t) by division", y, geometric_coef, 1.385, 1e-300);

  variable(x, 1.0);
  nz_series_pow(y, x, 0.5, K);
  check_series("(1 + t)^0.5 by the power recurrence", y, binomial_coef, 0.5, 1e-300);
  nz_series_sqrt(z, x, K);
  check_series("sqrt(1 + t)", z, binomial_coef, 0.5, 1e-300);
  nz_series_pow(y, x, -2.75, K);
  check_series("(1 + t)^-2.75", y, binomial_coef, -2.75, 1e-300);
  nz_series_powi(y, x, 7, K, w);
  check_series("(1 + t)^7 by binary powering", y, binomial_coef, 7.0, 1.0);

  variable(x, 0.0);
  y[0] = 0.0;
  for (int j = 0; j <= K; j++) z[j] = j == 0 ? 1.0 : 0.0;
  nz_series_mul(z, x, x, K);
  z[0] += 1.0;                       /* z = 1 + t^2 */
  nz_series_quadrature(y, x, z, 1.0, K);
  check_series("atan(t) by quadrature with d = 1 + t^2", y, atan_coef, 0.0, 1.0);

  variable(x, 0.385);
  nz_series_sincos(y, z, x, K, 0);
  check_series("sin(0.385 + t)", y, sin_coef, 0.385, 1e-300);
  nz_series_sincos(y, z, x, K, 1);
  check_series("cosh(0.385 + t)", z, cosh_coef, 0.385, 1e-300);

  {
    /* asin through the jet layer (it builds sqrt(1 - x^2) itself). */
    nz_jet *a = nz_jet_alloc(K, 1), *b = nz_jet_alloc(K, 1);
    double *ww = malloc(nz_jet_work_len(K) * sizeof(double));
    nz_jet_set_variable(a, 0.0, 0);
    int st = nz_jet_apply(b, NZ_FN_ASIN, a, ww);
    gsl_test(st != NZ_OK, "asin(t) through nz_jet_apply returns NZ_OK");
    check_series("asin(t)", b->c, asin_coef, 0.0, 1.0);
    /* Its tangent (seeded as d/dt0) is the derivative series: (j+1) c_{j+1}. */
    double worst = 0.0;
    for (int j = 0; j < K; j++)
      worst = fmax(worst, fabs(nz_jet_tangent(b, 0)[j] - (j + 1) * b->c[j + 1]) /
                              fmax(1.0, fabs((j + 1) * b->c[j + 1])));
    gsl_test(!(worst <= TOL), "asin(t): tangent d/dt0 equals the shifted series, error %.2g", worst);

    /* Domain errors are statuses, never NaN. */
    nz_jet_set_constant(a, -1.5);
    gsl_test(nz_jet_apply(b, NZ_FN_LOG, a, ww) != NZ_EDOM, "log(-1.5) is NZ_EDOM");
    nz_jet_set_variable(a, 0.0, -1);
    gsl_test(nz_jet_apply(b, NZ_FN_SQRT, a, ww) != NZ_ESING, "sqrt at 0 with order 40 is NZ_ESING");
    gsl_test(nz_jet_div(b, a, a, ww) != NZ_EZERODIV, "t / t is NZ_EZERODIV (zero constant term)");
    nz_jet_set_constant(a, 800.0);
    gsl_test(nz_jet_apply(b, NZ_FN_EXP, a, ww) != NZ_ERANGE, "exp(800) is NZ_ERANGE, not inf");
    /* NaN is told from overflow: a NaN operand, or inf - inf inside a
     * coefficient of finite operands, gives NZ_ENAN; any inf, NZ_ERANGE. */
    nz_jet_set_constant(a, NAN);
    gsl_test(nz_jet_check_finite(a) != NZ_ENAN, "a NaN constant term is NZ_ENAN");
    gsl_test(nz_jet_apply(b, NZ_FN_SIN, a, ww) != NZ_ENAN, "sin(NaN) is NZ_ENAN, not an overflow");
    nz_jet_tangent(a, 0)[3] = INFINITY;
    gsl_test(nz_jet_check_finite(a) != NZ_ERANGE, "an inf tangent coefficient is NZ_ERANGE");
    {
      /* (10 - 1e300 s)(1e300 + 1e308 s): c_1 = 10 * 1e308 - 1e300 * 1e300 = inf - inf */
      nz_jet *u = nz_jet_alloc(1, 0), *v = nz_jet_alloc(1, 0), *p = nz_jet_alloc(1, 0);
      u->c[0] = 10.0; u->c[1] = -1e300;
      v->c[0] = 1e300; v->c[1] = 1e308;
      gsl_test(nz_jet_mul(p, u, v, ww) != NZ_ENAN, "inf - inf in a product of finite jets is NZ_ENAN");
      nz_jet_free(u);
      nz_jet_free(v);
      nz_jet_free(p);
    }
    nz_jet_free(a);
    nz_jet_free(b);
    nz_jet_free(NULL);               /* harmless, as GSL's _free(NULL) */
    free(ww);
  }
  return gsl_test_summary();
}
