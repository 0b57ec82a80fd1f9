/* lcp.c - Lemke's complementary pivoting for LCP(q, M) (see lcp.h).
 *
 * The tableau holds w - M z - d z0 = q in the basis's coordinates: n rows,
 * the columns of w (0 .. n-1), of z (n .. 2n-1) and of the artificial
 * variable z0 (2n), and the right-hand side b.  Each row is first scaled
 * by the largest of |q_i| and |M_ij| (w_i scaled with it), so that one
 * pivot tolerance serves rows of accelerations, velocities and friction
 * cones alike; the covering vector d is 1 in the scaled problem.
 *
 * Step 0 brings z0 in at the row of the most negative q_i, which makes
 * b >= 0.  Then the complement of the variable that left enters, the
 * ratio test chooses the row that leaves (b_i / T_ic smallest over the
 * rows with T_ic > 0), and the path ends when z0 leaves (a solution) or
 * no row bounds the entering column (a ray).  Ties in the ratio test go to
 * z0's row first, then by the lexicographic rule on the rows of the basis
 * inverse (the tableau's w columns) divided by T_ic, which keeps every
 * basis lexicographically feasible and so rules out cycling (Cottle, Pang
 * and Stone, §4.9). */
#include <math.h>
#include <string.h>
#include "core/lcp.h"

size_t nz_lcp_work_len(int n)
{
  size_t nn = (size_t)(n > 0 ? n : 1);
  return nn * (2 * nn + 1) + 3 * nn;
}

/* Relative tolerance of the ratio test's ties and of a pivot's size. */
#define TIE 1e-11
#define PIVOT 1e-12

static void pivot(double *T, double *b, int n, int W, int r, int c)
{
  double *row = T + (size_t)r * (size_t)W, p = row[c];
  for (int j = 0; j < W; j++) row[j] /= p;
  row[c] = 1.0;
  b[r] /= p;
  for (int i = 0; i < n; i++) {
    if (i == r) continue;
    double *ti = T + (size_t)i * (size_t)W, f = ti[c];
    if (f == 0.0) continue;
    for (int j = 0; j < W; j++) ti[j] -= f * row[j];
    ti[c] = 0.0;
    b[i] -= f * b[r];
  }
}

/* The row that leaves when column c enters: the minimum ratio, ties to
 * z0's row, then lexicographic; -1 when no entry of the column is positive
 * (a ray). */
static int ratio_test(const double *T, const double *b, const int *bas, int n, int W, int c)
{
  double cmax = 0.0;
  for (int i = 0; i < n; i++) cmax = fmax(cmax, fabs(T[(size_t)i * W + c]));
  double tol = PIVOT * cmax;
  if (!(cmax > 0.0)) return -1;
  int rows[n], nr = 0;
  double best = INFINITY;
  for (int i = 0; i < n; i++) {
    double a = T[(size_t)i * W + c];
    if (a > tol) best = fmin(best, b[i] / a);
  }
  if (best == INFINITY) return -1;
  for (int i = 0; i < n; i++) {
    double a = T[(size_t)i * W + c];
    if (a > tol && b[i] / a <= best + TIE * (1.0 + fabs(best))) rows[nr++] = i;
  }
  for (int x = 0; x < nr; x++)
    if (bas[rows[x]] == 2 * n) return rows[x];   /* z0 leaves: a solution */
  /* lexicographic: the rows of the basis inverse over T_ic, column by column */
  for (int j = 0; j < n && nr > 1; j++) {
    double m = INFINITY;
    for (int x = 0; x < nr; x++) m = fmin(m, T[(size_t)rows[x] * W + j] / T[(size_t)rows[x] * W + c]);
    int keep = 0;
    for (int x = 0; x < nr; x++) {
      double v = T[(size_t)rows[x] * W + j] / T[(size_t)rows[x] * W + c];
      if (v <= m + TIE * (1.0 + fabs(m))) rows[keep++] = rows[x];
    }
    nr = keep;
  }
  return rows[0];
}

int nz_lcp_solve(int n, const double *M, const double *q, double *z, double *w, double *work,
                 nz_lcp_info *info)
{
  if (n < 1) return NZ_EDOM;
  int W = 2 * n + 1;
  double *T = work, *b = T + (size_t)n * (size_t)W, *rs = b + n;
  int basis[n];
  memset(info, 0, sizeof *info);
  memset(z, 0, (size_t)n * sizeof(double));
  int neg = -1;
  for (int i = 0; i < n; i++)
    if (q[i] < 0.0 && (neg < 0 || q[i] < q[neg])) neg = i;
  if (neg < 0) {                                  /* z = 0 solves it */
    memcpy(w, q, (size_t)n * sizeof(double));
    return NZ_OK;
  }
  for (int i = 0; i < n; i++) {
    double m = fabs(q[i]);
    for (int j = 0; j < n; j++) m = fmax(m, fabs(M[(size_t)i * n + j]));
    rs[i] = m > 0.0 ? 1.0 / m : 1.0;
    double *ti = T + (size_t)i * W;
    memset(ti, 0, (size_t)W * sizeof(double));
    ti[i] = 1.0;
    for (int j = 0; j < n; j++) ti[n + j] = -M[(size_t)i * n + j] * rs[i];
    ti[2 * n] = -1.0;
    b[i] = q[i] * rs[i];
    basis[i] = i;
  }
  /* step 0: z0 enters at the most negative scaled q_i */
  int r = 0;
  for (int i = 1; i < n; i++)
    if (b[i] < b[r]) r = i;
  pivot(T, b, n, W, r, 2 * n);
  int leaving = basis[r];
  basis[r] = 2 * n;
  int maxp = NZ_LCP_MAX_PIVOTS(n);
  info->pivots = 1;
  for (;;) {
    int c = leaving < n ? leaving + n : leaving - n;   /* the complement enters */
    r = ratio_test(T, b, basis, n, W, c);
    if (r < 0) {
      info->result = NZ_LCP_RAY;
      break;
    }
    pivot(T, b, n, W, r, c);
    leaving = basis[r];
    basis[r] = c;
    if (++info->pivots > maxp) {
      info->result = NZ_LCP_PIVOTS;
      break;
    }
    if (leaving == 2 * n) break;                  /* z0 left: solved */
  }
  if (info->result != NZ_LCP_SOLVED) {
    memset(w, 0, (size_t)n * sizeof(double));
    return NZ_EARG;
  }
  int wbasic[n];
  memset(wbasic, 0, sizeof wbasic);
  for (int i = 0; i < n; i++) {
    if (basis[i] >= n && basis[i] < 2 * n) z[basis[i] - n] = fmax(b[i], 0.0);
    else if (basis[i] < n) wbasic[basis[i]] = 1;
  }
  /* w from z in the problem's own units; a nonbasic w_i is 0 exactly */
  double res = 0.0;
  for (int i = 0; i < n; i++) {
    double s = q[i], size = fabs(q[i]);
    for (int j = 0; j < n; j++) {
      s += M[(size_t)i * n + j] * z[j];
      size += fabs(M[(size_t)i * n + j] * z[j]);
    }
    res = fmax(res, fmax(-s, 0.0) / (size > 0.0 ? size : 1.0));
    w[i] = wbasic[i] ? fmax(s, 0.0) : 0.0;
    if (!wbasic[i]) res = fmax(res, fabs(s) / (size > 0.0 ? size : 1.0));
  }
  info->residual = res;
  return NZ_OK;
}
