/* test_contact.c - Lemke's algorithm (src/core/lcp.c) and the contact
 * mechanics (src/mech/contact.c) against hand derivations, in GSL's
 * PASS/FAIL style: LCPs solved by hand and random ones against an
 * enumeration of every active set (a second path sharing no code); the
 * impact, the new mode and the mode's accelerations of small systems whose
 * M, h and rows are written out here (a ball on a floor with and without
 * friction, a block on a slope, Newton's cradle, a general two-coordinate
 * impact, Painleve's rod); the events; Zeno; every failure.  The systems
 * answer through the hooks on doubles and, for the values of their
 * constraints along the motion, on jets of order <= 1 (mech.h). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_test.h>
#include "core/lcp.h"
#include "mech/contact.h"

/* ------------------------------------------------------------------ */
/* LCPs                                                                 */

static double lcp_work[4096];

/* max over i of the violation of w = q + M z, z >= 0, w >= 0, z w = 0 */
static double lcp_violation(int n, const double *M, const double *q, const double *z, const double *w)
{
  double v = 0.0;
  for (int i = 0; i < n; i++) {
    double s = q[i];
    for (int j = 0; j < n; j++) s += M[i * n + j] * z[j];
    v = fmax(v, fabs(s - w[i]));
    v = fmax(v, fmax(-z[i], -w[i]));
    v = fmax(v, fabs(z[i] * w[i]));
  }
  return v;
}

/* Every active set of a small P-matrix problem: the one whose solve is
 * nonnegative with nonnegative complements (unique for a P-matrix). */
static int lcp_enumerate(int n, const double *M, const double *q, double *z)
{
  for (unsigned set = 0; set < (1u << n); set++) {
    int idx[8], m = 0;
    for (int i = 0; i < n; i++)
      if (set & (1u << i)) idx[m++] = i;
    double A[64], b[8], x[8];
    for (int a = 0; a < m; a++) {
      for (int c = 0; c < m; c++) A[a * m + c] = M[idx[a] * n + idx[c]];
      b[a] = -q[idx[a]];
    }
    /* Gaussian elimination with partial pivoting */
    int ok = 1;
    for (int c = 0; c < m && ok; c++) {
      int p = c;
      for (int r = c + 1; r < m; r++)
        if (fabs(A[r * m + c]) > fabs(A[p * m + c])) p = r;
      if (fabs(A[p * m + c]) < 1e-14) ok = 0;
      for (int x2 = 0; x2 < m && ok; x2++) {
        double tmp = A[c * m + x2];
        A[c * m + x2] = A[p * m + x2];
        A[p * m + x2] = tmp;
      }
      double tb = b[c];
      b[c] = b[p];
      b[p] = tb;
      for (int r = c + 1; r < m && ok; r++) {
        double f = A[r * m + c] / A[c * m + c];
        for (int x2 = c; x2 < m; x2++) A[r * m + x2] -= f * A[c * m + x2];
        b[r] -= f * b[c];
      }
    }
    if (!ok) continue;
    for (int r = m - 1; r >= 0; r--) {
      double s = b[r];
      for (int c = r + 1; c < m; c++) s -= A[r * m + c] * x[c];
      x[r] = s / A[r * m + r];
    }
    double zz[8] = { 0 };
    int good = 1;
    for (int a = 0; a < m; a++) {
      zz[idx[a]] = x[a];
      good &= x[a] >= -1e-12;
    }
    for (int i = 0; i < n && good; i++) {
      double w = q[i];
      for (int j = 0; j < n; j++) w += M[i * n + j] * zz[j];
      good &= w >= -1e-12;
    }
    if (good) {
      memcpy(z, zz, (size_t)n * sizeof(double));
      return 1;
    }
  }
  return 0;
}

static uint64_t seed = 0x2385ULL;
static double urand(void)
{
  seed ^= seed >> 12;
  seed ^= seed << 25;
  seed ^= seed >> 27;
  return (double)((seed * 2685821657736338717ULL) >> 11) / 9007199254740992.0;
}

static void test_lcp(void)
{
  double z[16], w[16];
  nz_lcp_info info;
  {
    /* z = 0: q >= 0 */
    double M[4] = { 2.385, 1.0, 1.0, 2.0 }, q[2] = { 0.5, 0.0 };
    int st = nz_lcp_solve(2, M, q, z, w, lcp_work, &info);
    gsl_test(st || z[0] != 0.0 || z[1] != 0.0 || w[0] != 0.5, "lcp: q >= 0 gives z = 0, w = q");
  }
  {
    /* both active: M z = -q, z = M^-1 (1.3, 0.7) */
    double M[4] = { 2.0, 1.0, 1.0, 3.0 }, q[2] = { -1.3, -0.7 };
    int st = nz_lcp_solve(2, M, q, z, w, lcp_work, &info);
    double det = 5.0, z0 = (3.0 * 1.3 - 0.7) / det, z1 = (2.0 * 0.7 - 1.3) / det;
    gsl_test(st || fabs(z[0] - z0) > 1e-15 || fabs(z[1] - z1) > 1e-15 || w[0] != 0.0 || w[1] != 0.0,
             "lcp: both active, z = M^-1 (-q) = (%.17g, %.17g) (got %.17g, %.17g)", z0, z1, z[0], z[1]);
  }
  {
    /* one active: z1 = 1.3 / 2 and w2 = 0.7 + 1.3 / 2 */
    double M[4] = { 2.0, 1.0, 1.0, 3.0 }, q[2] = { -1.3, 0.7 };
    int st = nz_lcp_solve(2, M, q, z, w, lcp_work, &info);
    gsl_test(st || fabs(z[0] - 0.65) > 1e-15 || z[1] != 0.0 || fabs(w[1] - 1.35) > 1e-15 || w[0] != 0.0,
             "lcp: one active, z = (0.65, 0), w = (0, 1.35) (got z %.17g %.17g, w %.17g %.17g)", z[0], z[1], w[0], w[1]);
  }
  {
    /* degenerate (singular PSD, two equal rows): z = (0, 1) or (1, 0), w = (0, 0) */
    double M[4] = { 1.0, 1.0, 1.0, 1.0 }, q[2] = { -1.0, -1.0 };
    int st = nz_lcp_solve(2, M, q, z, w, lcp_work, &info);
    gsl_test(st || fabs(z[0] + z[1] - 1.0) > 1e-15 || lcp_violation(2, M, q, z, w) > 1e-15,
             "lcp: a singular M with dependent rows: z1 + z2 = 1 (got %.17g, %.17g)", z[0], z[1]);
  }
  {
    /* no solution: w = -1 - z */
    double M[1] = { -1.0 }, q[1] = { -1.0 };
    int st = nz_lcp_solve(1, M, q, z, w, lcp_work, &info);
    gsl_test(st != NZ_EARG || info.result != NZ_LCP_RAY, "lcp: w = -1 - z has no solution: a ray (status %d)", st);
    gsl_test(nz_lcp_solve(0, M, q, z, w, lcp_work, &info) != NZ_EDOM, "lcp: n = 0 refused");
  }
  /* random P-matrices (A A^T + I): against the enumeration of active sets */
  double worst = 0.0, worst_enum = 0.0;
  int mismatch = 0, failed = 0;
  for (int trial = 0; trial < 200; trial++) {
    int n = 1 + trial % 8;
    double A[64], M[64], q[8], ze[8];
    for (int i = 0; i < n * n; i++) A[i] = 2.0 * urand() - 1.0;
    for (int i = 0; i < n; i++) {
      q[i] = 2.0 * urand() - 1.3;
      for (int j = 0; j < n; j++) {
        double s = i == j ? 0.1 : 0.0;
        for (int x = 0; x < n; x++) s += A[i * n + x] * A[j * n + x];
        M[i * n + j] = s;
      }
    }
    if (nz_lcp_solve(n, M, q, z, w, lcp_work, &info)) failed++;
    worst = fmax(worst, lcp_violation(n, M, q, z, w));
    if (!lcp_enumerate(n, M, q, ze)) mismatch++;
    for (int i = 0; i < n; i++) worst_enum = fmax(worst_enum, fabs(ze[i] - z[i]) / (1.0 + fabs(ze[i])));
  }
  gsl_test(failed || worst > 1e-12, "lcp: 200 random P-matrix problems (n = 1..8) solved, violation %.3g", worst);
  gsl_test(mismatch || worst_enum > 1e-10,
           "lcp: the same z as the enumeration of every active set (%d without one), difference %.3g", mismatch,
           worst_enum);
  /* random planar friction problems (Stewart-Trinkle: not symmetric) */
  worst = 0.0;
  failed = 0;
  for (int trial = 0; trial < 200; trial++) {
    /* one contact: unknowns lambda_n, beta+, beta-, sigma; G SPD 2x2 */
    double a = 0.5 + urand(), c = 0.5 + urand(), b = (2.0 * urand() - 1.0) * 0.9 * sqrt(a * c), mu = 1.5 * urand();
    double an = 2.0 * urand() - 1.5, at = 2.0 * urand() - 1.0;
    double M[16] = { a, b, -b, 0, b, c, -c, 1, -b, -c, c, 1, mu, -1, -1, 0 };
    double q[4] = { an, at, -at, 0 };
    if (nz_lcp_solve(4, M, q, z, w, lcp_work, &info)) failed++;
    worst = fmax(worst, lcp_violation(4, M, q, z, w));
  }
  gsl_test(failed || worst > 1e-12, "lcp: 200 random frictional contacts solved (%d failed), violation %.3g", failed,
           worst);
}

/* ------------------------------------------------------------------ */
/* Test systems                                                         */

/* Constraint kinds: a gap or slip w.q + w0 (order 0), a velocity w.q' + w0
 * (order 1), and a rod's lower end (y - l sin th, x' + l sin th th'). */
enum { LIN_Q, LIN_QD, ROD_GAP, ROD_SLIP };

typedef struct tsys {
  int k, nc;
  double M[9], f[3];             /* constant mass matrix and force (h = -f) */
  struct { int kind; double w[3], w0; } con[6];
  double l;                      /* the rod's half length */
} tsys;

static int ts_mass_bias(void *ctx, double t, const double *q, const double *qd, double *M, double *h)
{
  const tsys *s = ctx;
  (void)t, (void)q, (void)qd;
  memcpy(M, s->M, (size_t)(s->k * s->k) * sizeof(double));
  for (int i = 0; i < s->k; i++) h[i] = -s->f[i];
  return NZ_OK;
}

static int ts_row(void *ctx, int r, int m, double t, const double *const *state, int nstate, double alpha,
                  double beta, double *A, double *value, const double *sizes, double *high)
{
  const tsys *s = ctx;
  const double *q = state[0], *qd = state[1];
  (void)m, (void)t, (void)nstate, (void)alpha, (void)beta, (void)sizes, (void)high;
  switch (s->con[r].kind) {
  case LIN_Q:
  case LIN_QD:
    for (int i = 0; i < s->k; i++) A[i] = s->con[r].w[i];
    *value = 0.0;
    break;
  case ROD_GAP:
    A[0] = 0.0, A[1] = 1.0, A[2] = -s->l * cos(q[2]);
    *value = s->l * sin(q[2]) * qd[2] * qd[2];
    break;
  case ROD_SLIP:
    A[0] = 1.0, A[1] = 0.0, A[2] = s->l * sin(q[2]);
    *value = s->l * cos(q[2]) * qd[2] * qd[2];
    break;
  }
  return NZ_OK;
}

/* A constraint's value and rate along the motion, on jets of order <= 1
 * without tangents (the only evaluation contact.c makes on jets). */
static int ts_eval(void *ctx, nz_piece p, int index, const nz_jet *t, nz_jet *const *const *lv, int nl,
                   nz_jet *const *out, const nz_direction *dir)
{
  const tsys *s = ctx;
  (void)t, (void)nl;
  if (p != NZ_PIECE_PHI || dir || out[0]->ntan != 0 || out[0]->order > 1) return NZ_EARG;
  double q[3], qd[3];
  for (int i = 0; i < s->k; i++) q[i] = lv[0][i]->c[0], qd[i] = lv[1][i]->c[0];
  double v0 = 0.0, v1 = 0.0;
  switch (s->con[index].kind) {
  case LIN_Q:
    v0 = s->con[index].w0;
    for (int i = 0; i < s->k; i++) v0 += s->con[index].w[i] * q[i], v1 += s->con[index].w[i] * qd[i];
    break;
  case LIN_QD:
    v0 = s->con[index].w0;
    for (int i = 0; i < s->k; i++) v0 += s->con[index].w[i] * qd[i];
    break;
  case ROD_GAP:
    v0 = q[1] - s->l * sin(q[2]);
    v1 = qd[1] - s->l * cos(q[2]) * qd[2];
    break;
  case ROD_SLIP: v0 = qd[0] + s->l * sin(q[2]) * qd[2]; break;
  }
  nz_jet_init(out[0], out[0]->order, 0);
  out[0]->c[0] = v0;
  if (out[0]->order >= 1) out[0]->c[1] = v1;
  return NZ_OK;
}

static nz_system system_of(tsys *ts)
{
  nz_system s;
  memset(&s, 0, sizeof s);
  s.k = ts->k;
  s.nc = ts->nc;
  s.has = (1u << NZ_PIECE_F) | (1u << NZ_PIECE_PHI);
  s.ev.eval = ts_eval;
  s.ev.ctx = ts;
  s.mass_bias = ts_mass_bias;
  s.constraint_row = ts_row;
  s.mass_bias_ctx = ts;
  return s;
}

static int orders_of(const tsys *ts, int *orders)
{
  for (int r = 0; r < ts->nc; r++) orders[r] = ts->con[r].kind == LIN_QD || ts->con[r].kind == ROD_SLIP;
  return ts->nc;
}

static nz_contacts *contacts_of(const tsys *ts, int nb, int n, const nz_contact_def *defs)
{
  int orders[6];
  orders_of(ts, orders);
  nz_contacts_config cfg = { ts->nc, nb, orders, n, defs, 0.0, 0.0, 0.0, 0.0 };
  return nz_contacts_new(ts->k, &cfg);
}

/* A particle in the plane, mass m, weight m g, on the floor y >= 0 (gap
 * y, slip x'). */
static const double MASS = 1.37, G = 9.81;

static tsys particle(void)
{
  tsys ts;
  memset(&ts, 0, sizeof ts);
  ts.k = 2, ts.nc = 2;
  ts.M[0] = ts.M[3] = MASS;
  ts.f[1] = -MASS * G;
  ts.con[0].kind = LIN_Q, ts.con[0].w[1] = 1.0;
  ts.con[1].kind = LIN_QD, ts.con[1].w[0] = 1.0;
  return ts;
}

static void test_ball(void)
{
  tsys ts = particle();
  nz_system s = system_of(&ts);
  nz_contact_def d = { 0, -1, -1, -1, 0.7, 0.0, 0.0 };
  nz_contacts *c = contacts_of(&ts, 0, 1, &d);
  gsl_test(c == NULL, "ball: contacts made");
  if (!c) return;
  nz_contact_change ch[1];
  nz_contact_report rep = { .c = ch };
  double q[2] = { 0.3, 0.0 }, qd[2] = { 0.5, -2.1 };
  int st = nz_contacts_transition(c, &s, 0.4, q, qd, -1, &rep), mode;
  nz_contacts_get_mode(c, &mode);
  gsl_test(st || !rep.impact || fabs(qd[1] - 0.7 * 2.1) > 1e-15 || qd[0] != 0.5 || mode != NZ_CONTACT_OPEN,
           "ball, e = 0.7: v+ = e |v-| = %.17g, open (got %.17g, mode %d, status %d)", 0.7 * 2.1, qd[1], mode, st);
  gsl_test(fabs(ch[0].Pn - MASS * 1.7 * 2.1) > 1e-14 || !ch[0].impact || ch[0].zeno,
           "ball: impulse m (1 + e) |v-| = %.17g (got %.17g)", MASS * 1.7 * 2.1, ch[0].Pn);
  double g;
  nz_contacts_event(c, &s, 0, 0.4, (double[]){ 0.3, 0.0, 0.5, 1.47 }, &g);
  gsl_test(!(g > 0.0), "ball: the gap left at zero starts positive at the transition's time (%.3g)", g);
  nz_contacts_event(c, &s, 0, 0.5, (double[]){ 0.3, 0.25, 0.5, 1.0 }, &g);
  gsl_test(!(fabs(g - 0.25) < 1e-300), "ball: the open contact's event is its gap (%.17g)", g);
  /* a bounce located a little below the floor is put on it, and its gap's
   * event starts just above zero, so that the next landing is its first
   * zero (a step may span the whole flight) */
  q[1] = -3.7e-12, qd[0] = 0.5, qd[1] = -2.1;
  nz_contacts_transition(c, &s, 0.9, q, qd, 0, &rep);
  gsl_test(q[1] != 0.0 || fabs(qd[1] - 1.47) > 1e-15, "ball: a bounce located at gap -3.7e-12 starts from the floor (%.3g)",
           q[1]);
  nz_contacts_event(c, &s, 0, 0.9, (double[]){ q[0], q[1], qd[0], qd[1] }, &g);
  gsl_test(!(g > 0.0 && g < 1e-300), "ball: ... with its gap's event just above zero (%.3g)", g);
  nz_contacts_event(c, &s, 1, 0.5, (double[]){ 0.3, 0.25, 0.5, 1.0 }, &g);
  gsl_test(g != 1.0, "ball: a frictionless contact's friction event does not apply (1, got %.17g)", g);
  /* plastic: it stays, lambda_n = m g */
  d.e = 0.0;
  nz_contacts_free(c);
  c = contacts_of(&ts, 0, 1, &d);
  qd[0] = 0.5, qd[1] = -2.1;
  st = nz_contacts_transition(c, &s, 0.4, q, qd, -1, &rep);
  nz_contacts_get_mode(c, &mode);
  double qdd[2], lam[2];
  nz_contacts_accel(c, &s, 0.4, q, qd, qdd, lam);
  gsl_test(st || qd[1] != 0.0 || mode != NZ_CONTACT_CLOSED || fabs(lam[0] - MASS * G) > 1e-13 || qdd[1] != 0.0,
           "ball, e = 0: closed, v+ = 0, lambda_n = m g = %.17g (got mode %d, %.17g, %.17g)", MASS * G, mode, qd[1],
           lam[0]);
  nz_contacts_event(c, &s, 0, 0.5, (double[]){ 0.3, 0.0, 0.5, 0.0 }, &g);
  gsl_test(fabs(g - MASS * G) > 1e-13, "ball: the closed contact's event is lambda_n (%.17g)", g);
  /* pulled up harder than its weight: it opens */
  ts.f[1] = 2.0;
  st = nz_contacts_transition(c, &s, 0.6, q, qd, 0, &rep);
  nz_contacts_get_mode(c, &mode);
  gsl_test(st || mode != NZ_CONTACT_OPEN || rep.impact, "ball: pulled off the floor, the contact opens (mode %d)", mode);
  nz_contacts_free(c);
}

/* Frictional impacts and the block on a slope. */
/* Two contacts on the same gap (y >= 0 twice, dependent rows): the impact
 * and the rest of one contact, the impulse and the weight shared by least
 * norm, half each; and with friction at both (two equal slip rows), a push
 * below mu m g held by halves. */
static void test_dependent(void)
{
  tsys ts = particle();
  ts.nc = 4;
  ts.con[2] = ts.con[0];
  ts.con[3] = ts.con[1];
  nz_system s = system_of(&ts);
  nz_contact_def d[2] = { { 0, -1, -1, -1, 0.7, 0.0, 0.0 }, { 2, -1, -1, -1, 0.7, 0.0, 0.0 } };
  nz_contacts *c = contacts_of(&ts, 0, 2, d);
  nz_contact_change ch[2];
  nz_contact_report rep = { .c = ch };
  double q[2] = { 0.3, 0.0 }, qd[2] = { 0.5, -2.1 };
  int st = nz_contacts_transition(c, &s, 0.4, q, qd, -1, &rep);
  gsl_test(st || fabs(qd[1] - 0.7 * 2.1) > 1e-15 || fabs(ch[0].Pn - MASS * 1.7 * 2.1 / 2) > 1e-14 ||
           fabs(ch[1].Pn - MASS * 1.7 * 2.1 / 2) > 1e-14,
           "dependent: one gap twice bounces as one, each taking half the impulse %.17g (got %.17g, %.17g, status %d)",
           MASS * 1.7 * 2.1 / 2, ch[0].Pn, ch[1].Pn, st);
  qd[1] = 0.0;
  double lam[4], qdd[2];
  int mode[2];
  st = nz_contacts_transition(c, &s, 0.5, q, qd, 0, &rep);
  nz_contacts_get_mode(c, mode);
  nz_contacts_accel(c, &s, 0.5, q, qd, qdd, lam);
  gsl_test(st || mode[0] != NZ_CONTACT_CLOSED || mode[1] != NZ_CONTACT_CLOSED || fabs(lam[0] - MASS * G / 2) > 1e-13 ||
           fabs(lam[2] - MASS * G / 2) > 1e-13 || qdd[1] != 0.0,
           "dependent: at rest both held with m g/2 each (got %.17g, %.17g, modes %d %d)", lam[0], lam[2], mode[0], mode[1]);
  nz_contacts_free(c);
  /* with friction at both, pushed by 0.3 m g along x */
  ts.f[0] = 0.3 * MASS * G;
  s = system_of(&ts);
  nz_contact_def f[2] = { { 0, 1, -1, -1, 0.0, 0.4, 0.5 }, { 2, 3, -1, -1, 0.0, 0.4, 0.5 } };
  c = contacts_of(&ts, 0, 2, f);
  double q2[2] = { 0.0, 0.0 }, qd2[2] = { 0.0, 0.0 };
  st = nz_contacts_transition(c, &s, 0.0, q2, qd2, -1, &rep);
  nz_contacts_get_mode(c, mode);
  nz_contacts_accel(c, &s, 0.0, q2, qd2, qdd, lam);
  gsl_test(st || mode[0] != NZ_CONTACT_STICK || mode[1] != NZ_CONTACT_STICK || fabs(lam[1] + 0.15 * MASS * G) > 1e-13 ||
           fabs(lam[3] + 0.15 * MASS * G) > 1e-13 || fabs(qdd[0]) > 1e-15,
           "dependent: pushed by 0.3 m g, both stick with -0.15 m g each (got %.17g, %.17g, modes %d %d)", lam[1], lam[3],
           mode[0], mode[1]);
  nz_contacts_free(c);
}

static void test_friction(void)
{
  tsys ts = particle();
  nz_system s = system_of(&ts);
  nz_contact_def d = { 0, 1, -1, -1, 0.0, 0.3, 0.4 };
  nz_contacts *c = contacts_of(&ts, 0, 1, &d);
  nz_contact_change ch[1];
  nz_contact_report rep = { .c = ch };
  double q[2] = { 0.0, 0.0 }, qd[2] = { 0.5, -2.1 };
  int st = nz_contacts_transition(c, &s, 0.0, q, qd, -1, &rep), mode;
  nz_contacts_get_mode(c, &mode);
  /* P_n = m 2.1; stopping x' needs m 0.5 <= mu P_n = 0.63 m: it sticks */
  gsl_test(st || fabs(qd[0]) > 1e-15 || qd[1] != 0.0 || mode != NZ_CONTACT_STICK || fabs(ch[0].Pt[0] + MASS * 0.5) > 1e-14,
           "friction: a plastic impact within the cone sticks, P_t = -m 0.5 (got %.17g, mode %d, P_t %.17g)", qd[0], mode,
           ch[0].Pt);
  nz_contacts_free(c);
  c = contacts_of(&ts, 0, 1, &d);
  qd[0] = 1.0, qd[1] = -2.1;
  st = nz_contacts_transition(c, &s, 0.0, q, qd, -1, &rep);
  nz_contacts_get_mode(c, &mode);
  double qdd[2], lam[2];
  nz_contacts_accel(c, &s, 0.0, q, qd, qdd, lam);
  gsl_test(st || fabs(qd[0] - (1.0 - 0.3 * 2.1)) > 1e-15 || mode != NZ_CONTACT_SLIP_POS,
           "friction: beyond the cone it slides on at x' = 1 - mu 2.1 = %.17g (got %.17g, mode %d)", 1.0 - 0.3 * 2.1,
           qd[0], mode);
  gsl_test(fabs(lam[1] + 0.3 * MASS * G) > 1e-13 || fabs(qdd[0] + 0.3 * G) > 1e-14 || fabs(lam[0] - MASS * G) > 1e-13,
           "friction: sliding, lambda_t = -mu m g, x'' = -mu g (got %.17g, %.17g)", lam[1], qdd[0]);
  double g;
  nz_contacts_event(c, &s, 1, 0.1, (double[]){ 0.0, 0.0, 0.123, 0.0 }, &g);
  gsl_test(!(fabs(g - 0.123) <= 1e-12), "friction: a sliding contact's event is its slip velocity, offset by a "
           "rounding when it began sliding (%.17g)", g);
  nz_contacts_free(c);

  /* a block on a slope of angle alpha: x up the slope, y off it */
  double alpha = 0.3517;
  for (int steep = 0; steep < 2; steep++) {
    double mus = steep ? 0.3 : 0.4, mu = 0.25;   /* tan alpha = 0.3668 */
    ts.f[0] = -MASS * G * sin(alpha), ts.f[1] = -MASS * G * cos(alpha);
    nz_contact_def ds = { 0, 1, -1, -1, 0.0, mu, mus };
    c = contacts_of(&ts, 0, 1, &ds);
    qd[0] = qd[1] = 0.0;
    st = nz_contacts_transition(c, &s, 0.0, q, qd, -1, &rep);
    nz_contacts_get_mode(c, &mode);
    nz_contacts_accel(c, &s, 0.0, q, qd, qdd, lam);
    if (!steep)
      gsl_test(st || mode != NZ_CONTACT_STICK || fabs(lam[1] - MASS * G * sin(alpha)) > 1e-13 ||
                 fabs(lam[0] - MASS * G * cos(alpha)) > 1e-13 || fabs(qdd[0]) > 1e-15,
               "slope, mu_s > tan alpha: it sticks, holding m g sin alpha (mode %d, lambda_t %.17g)", mode, lam[1]);
    else
      gsl_test(st || mode != NZ_CONTACT_SLIP_NEG || fabs(qdd[0] + G * (sin(alpha) - mu * cos(alpha))) > 1e-14 ||
                 fabs(lam[1] - mu * MASS * G * cos(alpha)) > 1e-13,
               "slope, mu_s < tan alpha: it slides down, x'' = -g (sin a - mu cos a) = %.17g (mode %d, %.17g)",
               -G * (sin(alpha) - mu * cos(alpha)), mode, qdd[0]);
    if (!steep) {
      /* the stick event: mu_s lambda_n - |lambda_t| */
      nz_contacts_event(c, &s, 1, 0.1, (double[]){ 0.0, 0.0, 0.0, 0.0 }, &g);
      double want = mus * MASS * G * cos(alpha) - MASS * G * sin(alpha);
      gsl_test(fabs(g - want) > 1e-13, "slope: the sticking contact's event is mu_s lambda_n - |lambda_t| = %.17g (%.17g)",
               want, g);
    }
    nz_contacts_free(c);
  }
}

/* Newton's cradle, three balls in a row: the simultaneous Newton law with
 * e = 1 gives (-1/3, 2/3, 2/3) v (docs/theory.md §13). */
static void test_cradle(void)
{
  tsys ts;
  memset(&ts, 0, sizeof ts);
  ts.k = 3, ts.nc = 2;
  ts.M[0] = ts.M[4] = ts.M[8] = MASS;
  ts.con[0].kind = LIN_Q, ts.con[0].w[0] = -1.0, ts.con[0].w[1] = 1.0, ts.con[0].w0 = -0.2;
  ts.con[1].kind = LIN_Q, ts.con[1].w[1] = -1.0, ts.con[1].w[2] = 1.0, ts.con[1].w0 = -0.2;
  nz_system s = system_of(&ts);
  nz_contact_def d[2] = { { 0, -1, -1, -1, 1.0, 0.0, 0.0 }, { 1, -1, -1, -1, 1.0, 0.0, 0.0 } };
  nz_contacts *c = contacts_of(&ts, 0, 2, d);
  double v = 1.913, q[3] = { 0.0, 0.2, 0.4 }, qd[3] = { v, 0.0, 0.0 };
  nz_contact_change ch[2];
  nz_contact_report rep = { .c = ch };
  int st = nz_contacts_transition(c, &s, 0.0, q, qd, 0, &rep);
  gsl_test(st || fabs(qd[0] + v / 3) > 1e-14 || fabs(qd[1] - 2 * v / 3) > 1e-14 || fabs(qd[2] - 2 * v / 3) > 1e-14,
           "cradle: both contacts at once, v+ = (-1/3, 2/3, 2/3) v (got %.6g %.6g %.6g)", qd[0] / v, qd[1] / v, qd[2] / v);
  gsl_test(fabs(ch[0].Pn - 4 * MASS * v / 3) > 1e-13 || fabs(ch[1].Pn - 2 * MASS * v / 3) > 1e-13,
           "cradle: impulses 4/3 m v and 2/3 m v (got %.17g, %.17g)", ch[0].Pn, ch[1].Pn);
  double ke = 0.5 * MASS * (qd[0] * qd[0] + qd[1] * qd[1] + qd[2] * qd[2]);
  gsl_test(fabs(ke - 0.5 * MASS * v * v) > 1e-13, "cradle: e = 1 keeps the kinetic energy (%.17g)", ke);
  nz_contacts_free(c);
}

/* A general two-coordinate impact: M not diagonal, the gap w.q + w0: the
 * impulse P = -(1 + e) v / (w M^-1 w^T) along M^-1 w^T. */
static void test_general_impact(void)
{
  tsys ts;
  memset(&ts, 0, sizeof ts);
  ts.k = 2, ts.nc = 1;
  double a = 2.385, b = 0.731, cc = 1.113, w0 = 0.417, w1 = -1.29, e = 0.613;
  ts.M[0] = a, ts.M[1] = ts.M[2] = b, ts.M[3] = cc;
  ts.con[0].kind = LIN_Q, ts.con[0].w[0] = w0, ts.con[0].w[1] = w1;
  nz_system s = system_of(&ts);
  nz_contact_def d = { 0, -1, -1, -1, e, 0.0, 0.0 };
  nz_contacts *c = contacts_of(&ts, 0, 1, &d);
  double q[2] = { 0.0, 0.0 }, qd[2] = { 0.83, 0.61 }, qd0[2] = { 0.83, 0.61 };
  double det = a * cc - b * b, Mi[4] = { cc / det, -b / det, -b / det, a / det };
  double mw[2] = { Mi[0] * w0 + Mi[1] * w1, Mi[2] * w0 + Mi[3] * w1 }, g = w0 * mw[0] + w1 * mw[1];
  double v = w0 * qd[0] + w1 * qd[1], P = -(1 + e) * v / g;
  int st = nz_contacts_transition(c, &s, 0.0, q, qd, 0, NULL);
  double want0 = qd0[0] + mw[0] * P, want1 = qd0[1] + mw[1] * P;
  gsl_test(st || fabs(qd[0] - want0) > 1e-14 || fabs(qd[1] - want1) > 1e-14 ||
             fabs(w0 * qd[0] + w1 * qd[1] + e * v) > 1e-14,
           "impulse equations: q'+ = q'- + M^-1 w^T P, w q'+ = -e w q'- (got %.17g %.17g, want %.17g %.17g)", qd[0],
           qd[1], want0, want1);
  nz_contacts_free(c);
}

/* Painleve's rod: a uniform rod of length 2l leaning at th on a rough floor,
 * its lower end sliding: J M^-1 W^T = (1 + 3 cos^2 th + 3 mu s sin th cos th)
 * / m, negative for mu > 4/3 at tan th = 2 sliding with s = -1. */
static void test_painleve(void)
{
  tsys ts;
  memset(&ts, 0, sizeof ts);
  double l = 0.5, th = atan(2.0);
  ts.k = 3, ts.nc = 2, ts.l = l;
  ts.M[0] = ts.M[4] = MASS, ts.M[8] = MASS * l * l / 3.0;
  ts.f[1] = -MASS * G;
  ts.con[0].kind = ROD_GAP;
  ts.con[1].kind = ROD_SLIP;
  nz_system s = system_of(&ts);
  for (int spin = 0; spin < 2; spin++) {
    nz_contact_def d = { 0, 1, -1, -1, 0.0, 1.5, 1.5 };
    nz_contacts *c = contacts_of(&ts, 0, 1, &d);
    /* the lower end at y = 0, sliding left at 1 m/s; spinning fast enough
     * (l sin th th'^2 > g) it would lift off by itself */
    double thd = spin ? 6.0 : 0.0;
    double q[3] = { 0.0, l * sin(th), th }, qd[3] = { -1.0 - l * sin(th) * thd, l * cos(th) * thd, thd };
    int st = nz_contacts_transition(c, &s, 0.25, q, qd, -1, NULL);
    const nz_contact_report_failure *f = nz_contacts_failure(c);
    double want = (1 + 3 * cos(th) * cos(th) - 3 * 1.5 * sin(th) * cos(th)) / (1 + 3 * cos(th) * cos(th));
    gsl_test(st != NZ_EARG || f->kind != NZ_CONTACT_PAINLEVE || f->contact != 0 || fabs(f->value - want) > 1e-12 ||
               f->t != 0.25 || f->q[2] != th,
             "painleve (%s): reported with the contact, the state and the effective mass ratio %.6g (got %.6g, kind %d)",
             spin ? "a_n > 0: two modes" : "a_n < 0: no mode", want, f->value, f->kind);
    gsl_test(spin ? !(f->an > 0.0) : !(fabs(f->an + G) < 1e-12), "painleve: the free normal acceleration %.6g", f->an);
    nz_contacts_free(c);
  }
  /* sliding at mu = 4/3 exactly at tan th = 2: the effective mass is zero,
   * the mode's saddle point singular: Painleve again, from the integrator's
   * solve (where a slide turns into the paradox) */
  {
    nz_contact_def d = { 0, 1, -1, -1, 0.0, 4.0 / 3.0, 4.0 / 3.0 };
    nz_contacts *c = contacts_of(&ts, 0, 1, &d);
    int slide = NZ_CONTACT_SLIP_NEG;
    nz_contacts_set_mode(c, &slide);
    double q[3] = { 0.0, l * sin(th), th }, qd[3] = { -1.0, 0.0, 0.0 }, qdd[3], lam[2];
    int st = nz_contacts_accel(c, &s, 0.5, q, qd, qdd, lam);
    const nz_contact_report_failure *f = nz_contacts_failure(c);
    gsl_test(st != NZ_ESINGULAR || f->kind != NZ_CONTACT_PAINLEVE || f->contact != 0 || fabs(f->value) > 1e-12,
             "painleve: a slide whose effective mass reaches zero is singular and named (status %d, kind %d, %.3g)", st,
             f->kind, f->value);
    nz_contacts_free(c);
  }
  /* mu = 1 < 4/3: consistent, it slides */
  nz_contact_def d = { 0, 1, -1, -1, 0.0, 1.0, 1.0 };
  nz_contacts *c = contacts_of(&ts, 0, 1, &d);
  double q[3] = { 0.0, l * sin(th), th }, qd[3] = { -1.0, 0.0, 0.0 };
  int mode, st = nz_contacts_transition(c, &s, 0.0, q, qd, -1, NULL);
  nz_contacts_get_mode(c, &mode);
  gsl_test(st || mode != NZ_CONTACT_SLIP_NEG, "painleve: with mu = 1 < 4/3 the rod slides (mode %d, status %d)", mode, st);
  nz_contacts_free(c);
}

/* Zeno: a ball bouncing at the closed-form times and speeds; the impact at
 * a speed below the threshold is made plastic and the accumulation time
 * t1 (1 + e) / (1 - e) predicted. */
static void test_zeno(void)
{
  tsys ts = particle();
  nz_system s = system_of(&ts);
  double e = 0.5, v1 = 4.43, t1 = v1 / G;
  nz_contact_def d = { 0, -1, -1, -1, e, 0.0, 0.0 };
  nz_contacts *c = contacts_of(&ts, 0, 1, &d);
  nz_contact_report rep = { 0 };
  int bounce = 0, mode = NZ_CONTACT_OPEN, st = 0;
  double tk = t1, vk = v1;
  for (bounce = 1; bounce < 100 && mode == NZ_CONTACT_OPEN && !st; bounce++) {
    double q[2] = { 0.0, 0.0 }, qd[2] = { 0.0, -vk };
    st = nz_contacts_transition(c, &s, tk, q, qd, 0, &rep);
    nz_contacts_get_mode(c, &mode);
    if (mode == NZ_CONTACT_OPEN) {
      tk += 2 * e * vk / G;
      vk *= e;
    }
  }
  bounce--;
  double tinf = t1 * (1 + e) / (1 - e);
  /* the first bounce slower than 1e-6 v1: e^(k-1) <= 1e-6 */
  int want = 1 + (int)ceil(log(NZ_CONTACT_ZENO_SPEED) / log(e));
  gsl_test(st || mode != NZ_CONTACT_CLOSED || rep.zeno_contact != 0 || bounce != want,
           "zeno: the impact at bounce %d (speed below %g of the first) is plastic and persists (bounce %d, mode %d)",
           want, NZ_CONTACT_ZENO_SPEED, bounce, mode);
  gsl_test(fabs(rep.zeno_time - tinf) > 1e-12 * tinf, "zeno: the accumulation time t1 (1 + e)/(1 - e) = %.15g (%.15g)",
           tinf, rep.zeno_time);
  nz_contacts_free(c);
}

/* Bad configurations and failures. */
static void test_errors(void)
{
  tsys ts = particle();
  nz_system s = system_of(&ts);
  int orders[2] = { 0, 1 };
  nz_contact_def bad[] = {
    { 0, -1, -1, -1, 1.2, 0.0, 0.0 },   /* e > 1 */
    { 0, -1, -1, -1, -0.1, 0.0, 0.0 },  /* e < 0 */
    { 0, 1, -1, -1, 0.5, -0.3, 0.0 },   /* mu < 0 */
    { 0, 1, -1, -1, 0.5, 0.4, 0.3 },    /* mu_s < mu */
    { 1, -1, -1, -1, 0.5, 0.0, 0.0 },   /* a gap of order 1 */
    { 0, 3, -1, -1, 0.5, 0.3, 0.3 },    /* no such slip */
    { 0, -1, -1, -1, 0.5, 0.3, 0.3 },   /* friction without a slip function */
  };
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
    nz_contacts_config cfg = { 2, 0, orders, 1, &bad[i], 0.0, 0.0, 0.0, 0.0 };
    nz_contacts *c = nz_contacts_new(2, &cfg);
    gsl_test(c != NULL, "errors: bad contact %zu refused", i + 1);
    nz_contacts_free(c);
  }
  nz_contacts_free(NULL);
  /* a touching contact without a normal */
  ts.con[0].w[1] = 0.0;
  nz_contact_def d = { 0, -1, -1, -1, 0.5, 0.0, 0.0 };
  nz_contacts *c = contacts_of(&ts, 0, 1, &d);
  double q[2] = { 0.0, 0.0 }, qd[2] = { 0.0, 0.0 };
  int st = nz_contacts_transition(c, &s, 0.0, q, qd, -1, NULL);
  gsl_test(st != NZ_EARG || nz_contacts_failure(c)->kind != NZ_CONTACT_GRADIENT || nz_contacts_failure(c)->contact != 0,
           "errors: a touching gap with a zero gradient is named (kind %d)", nz_contacts_failure(c)->kind);
  int m = NZ_CONTACT_STICK;
  gsl_test(nz_contacts_set_mode(c, &m) != NZ_EARG, "errors: a frictionless contact cannot stick");
  nz_contacts_free(c);
  /* two identical gaps set held by hand (nz_contacts_set_mode takes every row held as a carrier): singular */
  ts = particle();
  ts.con[1] = ts.con[0];
  s = system_of(&ts);
  orders[1] = 0;
  nz_contact_def two[2] = { { 0, -1, -1, -1, 0.0, 0.0, 0.0 }, { 1, -1, -1, -1, 0.0, 0.0, 0.0 } };
  nz_contacts_config cfg = { 2, 0, orders, 2, two, 0.0, 0.0, 0.0, 0.0 };
  c = nz_contacts_new(2, &cfg);
  int closed[2] = { NZ_CONTACT_CLOSED, NZ_CONTACT_CLOSED };
  nz_contacts_set_mode(c, closed);
  double qdd[2], lam[2];
  st = nz_contacts_accel(c, &s, 0.0, q, qd, qdd, lam);
  gsl_test(st != NZ_ESINGULAR || nz_contacts_failure(c)->kind != NZ_CONTACT_SINGULAR,
           "errors: two dependent contacts set held by hand make the mode singular (status %d)", st);
  nz_contacts_free(c);
}

int main(void)
{
  gsl_set_error_handler_off();
  gsl_test_verbose(1);
  test_lcp();
  test_ball();
  test_dependent();
  test_friction();
  test_cradle();
  test_general_impact();
  test_painleve();
  test_zeno();
  test_errors();
  return gsl_test_summary();
}
