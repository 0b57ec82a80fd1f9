/* linalg.c - SPD solves with a diagnosis when they fail (see linalg.h).
 * Cholesky is the right factorization for M = d^2T/dq'^2 (written out
 * below, with its condition estimate: see the note there); when it fails,
 * the eigenvalues of the symmetric matrix (GSL) say how far from positive
 * definite it is, which is what the user needs to see.  SVD and least
 * squares are GSL's. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <gsl/gsl_eigen.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_linalg.h>
#include <gsl/gsl_permutation.h>
#include <gsl/gsl_vector.h>
#include "core/linalg.h"
#include "core/status.h"

static void eigen_range(int k, const double *A, nz_solve_info *info)
{
  double *copy = malloc((size_t)k * (size_t)k * sizeof(double));
  gsl_vector *ev = gsl_vector_alloc((size_t)k);
  gsl_eigen_symm_workspace *w = gsl_eigen_symm_alloc((size_t)k);
  info->eig_min = info->eig_max = NAN;
  if (copy && ev && w) {
    memcpy(copy, A, (size_t)k * (size_t)k * sizeof(double));
    gsl_matrix_view m = gsl_matrix_view_array(copy, (size_t)k, (size_t)k);
    if (gsl_eigen_symm(&m.matrix, ev, w) == GSL_SUCCESS) {
      info->eig_min = gsl_vector_min(ev);
      info->eig_max = gsl_vector_max(ev);
    }
  }
  gsl_eigen_symm_free(w);
  gsl_vector_free(ev);
  free(copy);
}

size_t nz_solve_spd_work_len(int k) { return (size_t)k * (size_t)k + 3 * (size_t)k; }

/* The SPD solve is written out here rather than called from GSL: the
 * matrices are small (a mass matrix, k of 2 to 50), and through GSL's
 * generic BLAS a k = 8 factorization with its condition estimate took
 * ~40,000 instructions, 65 % of a whole right-hand side of the 8-link
 * pendulum; these loops take a tenth of that.  tests/test_series.c checks
 * them against GSL (gsl_linalg_cholesky_decomp1, _solve, _rcond). */

/* A = L L^T in place: L in the lower triangle of A (row-major; the upper
 * triangle is left as it was).  -1 when a pivot is not positive (or NaN):
 * A is not positive definite. */
static int cholesky(int k, double *A)
{
  for (int j = 0; j < k; j++) {
    double *Aj = A + (size_t)j * (size_t)k, d = Aj[j];
    for (int p = 0; p < j; p++) d -= Aj[p] * Aj[p];
    if (!(d > 0.0)) return -1;
    d = sqrt(d);
    Aj[j] = d;
    for (int i = j + 1; i < k; i++) {
      double *Ai = A + (size_t)i * (size_t)k, s = Ai[j];
      for (int p = 0; p < j; p++) s -= Ai[p] * Aj[p];
      Ai[j] = s / d;
    }
  }
  return 0;
}

/* x = (L L^T)^-1 x in place: forward with L, back with L^T. */
static void cholesky_solve(int k, const double *L, double *x)
{
  for (int i = 0; i < k; i++) {
    const double *Li = L + (size_t)i * (size_t)k;
    double s = x[i];
    for (int p = 0; p < i; p++) s -= Li[p] * x[p];
    x[i] = s / Li[i];
  }
  for (int i = k - 1; i >= 0; i--) {
    double s = x[i];
    for (int p = i + 1; p < k; p++) s -= L[(size_t)p * (size_t)k + (size_t)i] * x[p];
    x[i] = s / L[(size_t)i * (size_t)k + (size_t)i];
  }
}

void nz_cholesky_solve(int k, const double *L, double *x) { cholesky_solve(k, L, x); }

static double norm1_vec(int k, const double *x)
{
  double s = 0.0;
  for (int i = 0; i < k; i++) s += fabs(x[i]);
  return s;
}

static int argmax_abs(int k, const double *x)
{
  int j = 0;
  for (int i = 1; i < k; i++)
    if (fabs(x[i]) > fabs(x[j])) j = i;
  return j;
}

/* An estimate of ||A^-1||_1 from the factor L of A = L L^T, by Hager's
 * method with Higham's refinements (the estimator of LAPACK's dlacn2 and
 * GSL's gsl_linalg_invnorm1): at most 5 steps of a gradient ascent of
 * ||A^-1 x||_1 over the unit ball, each two solves, then the alternating
 * vector that guards against the cases where the ascent stops early.  A
 * lower bound of the norm, in practice within a factor 3 of it.  A^-1 is
 * symmetric, so the ascent needs no transposed solves.  work: 3 k. */
static double inverse_norm1(int k, const double *L, double *work)
{
  double *x = work, *y = work + k, *sgn = work + 2 * k;
  for (int i = 0; i < k; i++) x[i] = 1.0 / k;
  cholesky_solve(k, L, x);
  if (k == 1) return fabs(x[0]);
  double est = norm1_vec(k, x);
  for (int i = 0; i < k; i++) sgn[i] = x[i] >= 0.0 ? 1.0 : -1.0;
  memcpy(x, sgn, (size_t)k * sizeof(double));
  cholesky_solve(k, L, x);
  int j = argmax_abs(k, x);
  for (int iter = 2; iter <= 5; iter++) {
    memset(y, 0, (size_t)k * sizeof(double));
    y[j] = 1.0;
    cholesky_solve(k, L, y);
    double old = est;
    est = norm1_vec(k, y);
    int same = 1;
    for (int i = 0; i < k && same; i++) same = (y[i] >= 0.0 ? 1.0 : -1.0) == sgn[i];
    if (same || est <= old) break;
    for (int i = 0; i < k; i++) sgn[i] = x[i] = y[i] >= 0.0 ? 1.0 : -1.0;
    cholesky_solve(k, L, x);
    int last = j;
    j = argmax_abs(k, x);
    if (fabs(x[last]) == fabs(x[j])) break;
  }
  double alt = 1.0;
  for (int i = 0; i < k; i++) {
    x[i] = alt * (1.0 + (double)i / (double)(k - 1));
    alt = -alt;
  }
  cholesky_solve(k, L, x);
  double temp = 2.0 * norm1_vec(k, x) / (3.0 * k);
  return temp > est ? temp : est;
}

/* An upper bound of ||A^-1||_1 from L (A = L L^T) at the cost of one solve:
 * with C the comparison matrix of L (|l_ii| on the diagonal, -|l_ij| below
 * it), C^-1 >= |L^-1| entrywise (Higham, Accuracy and Stability, 8.2), so
 * ||L^-1||_inf <= max(C^-1 e) and ||L^-T||_inf <= max(C^-T e), e all ones,
 * and ||A^-1||_1 <= ||L^-T||_1 ||L^-1||_1 = ||L^-1||_inf ||L^-T||_inf.
 * Pessimistic for a triangle far from diagonal dominance, tight enough for
 * a mass matrix to certify that it is well conditioned.  work: k. */
static double inverse_norm1_bound(int k, const double *L, double *u)
{
  double a = 0.0, b = 0.0;
  for (int i = 0; i < k; i++) {
    const double *Li = L + (size_t)i * (size_t)k;
    double s = 1.0;
    for (int p = 0; p < i; p++) s += fabs(Li[p]) * u[p];
    u[i] = s / Li[i];
    if (u[i] > a) a = u[i];
  }
  for (int i = k - 1; i >= 0; i--) {
    double s = 1.0;
    for (int p = i + 1; p < k; p++) s += fabs(L[(size_t)p * (size_t)k + (size_t)i]) * u[p];
    u[i] = s / L[(size_t)i * (size_t)k + (size_t)i];
    if (u[i] > b) b = u[i];
  }
  return a * b;
}

int nz_solve_spd_in(int k, double *A, const double *b, double *x, double rcond_min,
                    nz_solve_info *info, double *work)
{
  memset(info, 0, sizeof *info);
  double *orig = work, *rwork = work + (size_t)k * (size_t)k;
  memcpy(orig, A, (size_t)k * (size_t)k * sizeof(double));
  /* ||A||_1, the largest column sum (of the symmetric A: its rows) */
  double anorm = 0.0;
  for (int i = 0; i < k; i++) {
    double s = norm1_vec(k, A + (size_t)i * (size_t)k);
    if (s > anorm) anorm = s;
  }
  if (cholesky(k, A)) {
    info->not_spd = 1;
    eigen_range(k, orig, info);
    return NZ_ESINGULAR;
  }
  /* The estimate costs about 13 solves; a bound that already clears
   * rcond_min costs one (then rcond is that bound: a lower bound of the
   * true value, where the estimate is an upper one). */
  double bound = inverse_norm1_bound(k, A, rwork);
  if (anorm > 0.0 && isfinite(bound) && 1.0 / anorm / bound >= rcond_min) {
    info->rcond = 1.0 / anorm / bound;
  } else {
    double inorm = inverse_norm1(k, A, rwork);
    info->rcond = anorm > 0.0 && inorm > 0.0 ? 1.0 / anorm / inorm : 0.0;
  }
  if (!(info->rcond >= rcond_min)) {
    eigen_range(k, orig, info);
    return NZ_ESINGULAR;
  }
  memmove(x, b, (size_t)k * sizeof(double));
  cholesky_solve(k, A, x);
  return NZ_OK;
}

int nz_solve_spd(int k, double *A, const double *b, double *x, double rcond_min,
                 nz_solve_info *info)
{
  double *work = malloc(nz_solve_spd_work_len(k) * sizeof(double));
  if (!work) return NZ_ENOMEM;
  int st = nz_solve_spd_in(k, A, b, x, rcond_min, info, work);
  free(work);
  return st;
}


void nz_svd_free(nz_svd *d)
{
  gsl_matrix_free(d->U);
  gsl_matrix_free(d->V);
  gsl_vector_free(d->S);
  gsl_vector_free(d->work);
  memset(d, 0, sizeof *d);
}

/* Decompose the row-major rows x cols matrix a (transposed first if it has
 * fewer rows than columns, so that GSL's rows >= cols holds). */
int nz_svd_of(nz_svd *d, int rows, int cols, const double *a, int transpose)
{
  int R = transpose ? cols : rows, C = transpose ? rows : cols;
  memset(d, 0, sizeof *d);
  d->U = gsl_matrix_alloc((size_t)R, (size_t)C);
  d->V = gsl_matrix_alloc((size_t)C, (size_t)C);
  d->S = gsl_vector_alloc((size_t)C);
  d->work = gsl_vector_alloc((size_t)C);
  if (!d->U || !d->V || !d->S || !d->work) { nz_svd_free(d); return NZ_ENOMEM; }
  for (int i = 0; i < rows; i++)
    for (int j = 0; j < cols; j++)
      gsl_matrix_set(d->U, (size_t)(transpose ? j : i), (size_t)(transpose ? i : j), a[i * cols + j]);
  gsl_linalg_SV_decomp(d->U, d->V, d->S, d->work);
  return NZ_OK;
}

struct nz_lstsq_ws {
  int cap;
  gsl_matrix *U, *V;
  gsl_vector *S, *work;
};

nz_lstsq_ws *nz_lstsq_new(int N)
{
  if (N < 1) return NULL;
  nz_lstsq_ws *w = calloc(1, sizeof *w);
  if (!w) return NULL;
  w->cap = N;
  w->U = gsl_matrix_alloc((size_t)N, (size_t)N);
  w->V = gsl_matrix_alloc((size_t)N, (size_t)N);
  w->S = gsl_vector_alloc((size_t)N);
  w->work = gsl_vector_alloc((size_t)N);
  if (!w->U || !w->V || !w->S || !w->work) {
    nz_lstsq_free(w);
    return NULL;
  }
  return w;
}

void nz_lstsq_free(nz_lstsq_ws *w)
{
  if (!w) return;
  if (w->U) gsl_matrix_free(w->U);
  if (w->V) gsl_matrix_free(w->V);
  if (w->S) gsl_vector_free(w->S);
  if (w->work) gsl_vector_free(w->work);
  free(w);
}

int nz_lstsq_in(nz_lstsq_ws *w, int m, int n, const double *A, const double *b, double *x, double cut, int *rank)
{
  if (m < 1 || n < 1 || m > w->cap || n > w->cap) return NZ_EDOM;
  /* GSL decomposes R x C with R >= C: A itself, or A^T when it is wide */
  int transpose = m < n, R = transpose ? n : m, C = transpose ? m : n;
  gsl_matrix_view U = gsl_matrix_submatrix(w->U, 0, 0, (size_t)R, (size_t)C);
  gsl_matrix_view V = gsl_matrix_submatrix(w->V, 0, 0, (size_t)C, (size_t)C);
  gsl_vector_view S = gsl_vector_subvector(w->S, 0, (size_t)C), work = gsl_vector_subvector(w->work, 0, (size_t)C);
  for (int i = 0; i < m; i++)
    for (int j = 0; j < n; j++)
      gsl_matrix_set(&U.matrix, (size_t)(transpose ? j : i), (size_t)(transpose ? i : j), A[(size_t)i * (size_t)n + (size_t)j]);
  gsl_error_handler_t *old = gsl_set_error_handler_off();
  int st = gsl_linalg_SV_decomp(&U.matrix, &V.matrix, &S.vector, &work.vector);
  gsl_set_error_handler(old);
  if (st) return NZ_ERANGE;
  /* A = U S V^T (or A^T = U S V^T): x = V S+ U^T b (or U S+ V^T b). */
  double smax = gsl_vector_get(&S.vector, 0), lim = cut * smax;
  int r = 0;
  memset(x, 0, (size_t)n * sizeof(double));
  for (int c = 0; c < C; c++) {
    double sc = gsl_vector_get(&S.vector, (size_t)c);
    if (!(sc > lim)) continue;
    r++;
    const gsl_matrix *left = transpose ? &V.matrix : &U.matrix, *right = transpose ? &U.matrix : &V.matrix;
    double proj = 0.0;
    for (int i = 0; i < m; i++) proj += gsl_matrix_get(left, (size_t)i, (size_t)c) * b[i];
    proj /= sc;
    for (int j = 0; j < n; j++) x[j] += gsl_matrix_get(right, (size_t)j, (size_t)c) * proj;
  }
  if (rank) *rank = r;
  return NZ_OK;
}

int nz_lstsq(int m, int n, const double *A, const double *b, double *x)
{
  nz_lstsq_ws *w = nz_lstsq_new(m > n ? m : n);
  if (!w) return NZ_ENOMEM;
  int st = nz_lstsq_in(w, m, n, A, b, x, 1e-13, NULL);
  nz_lstsq_free(w);
  return st;
}

/* Solve the N x N system J x = rhs by SVD; rcond = s_min / s_max. */
int nz_solve_svd(int N, const double *J, const double *rhs, double *x, double *rcond)
{
  nz_svd d;
  int st = nz_svd_of(&d, N, N, J, 0);
  if (st) return st;
  double smax = gsl_vector_get(d.S, 0), smin = gsl_vector_get(d.S, (size_t)(N - 1));
  *rcond = smax > 0 ? smin / smax : 0.0;
  gsl_vector_const_view bv = gsl_vector_const_view_array(rhs, (size_t)N);
  gsl_vector_view xv = gsl_vector_view_array(x, (size_t)N);
  if (smin > 0) gsl_linalg_SV_solve(d.U, d.V, d.S, &bv.vector, &xv.vector);
  nz_svd_free(&d);
  return NZ_OK;
}

/* Pivoted QR first (about a tenth of the SVD's work at N ~ 13); the SVD
 * only when the QR's estimate is within a factor NZ_SOLVE_SVD_MARGIN of the
 * threshold, where the decision must be the SVD's. */
#define NZ_SOLVE_SVD_MARGIN 1e3

int nz_solve_square(int N, const double *J, const double *rhs, double *x, double rcond_min,
                    double *rcond)
{
  size_t n = (size_t)N;
  gsl_matrix *QR = gsl_matrix_alloc(n, n);
  gsl_vector *tau = gsl_vector_alloc(n), *norm = gsl_vector_alloc(n), *work = gsl_vector_alloc(3 * n);
  gsl_permutation *perm = gsl_permutation_alloc(n);
  int signum, st = NZ_ENOMEM, fast = 0;
  if (QR && tau && norm && work && perm) {
    st = NZ_OK;
    memcpy(QR->data, J, n * n * sizeof(double));          /* row-major, tda = n */
    double r = 0.0;
    if (gsl_linalg_QRPT_decomp(QR, tau, perm, &signum, norm) == GSL_SUCCESS &&
        gsl_linalg_QRPT_rcond(QR, &r, work) == GSL_SUCCESS && r >= NZ_SOLVE_SVD_MARGIN * rcond_min) {
      gsl_vector_const_view bv = gsl_vector_const_view_array(rhs, n);
      gsl_vector_view xv = gsl_vector_view_array(x, n);
      if (gsl_linalg_QRPT_solve(QR, tau, perm, &bv.vector, &xv.vector) == GSL_SUCCESS) {
        *rcond = r;
        fast = 1;
      }
    }
  }
  gsl_matrix_free(QR);
  gsl_vector_free(tau);
  gsl_vector_free(norm);
  gsl_vector_free(work);
  gsl_permutation_free(perm);
  if (st || fast) return st;
  return nz_solve_svd(N, J, rhs, x, rcond);
}

/* LU with partial pivoting written out, as the Cholesky above: the
 * matrices are small (a contact mode's Delassus matrix of a few rows, at
 * every right-hand side; a Taylor step's saddle point), where GSL's
 * generic path (views, BLAS calls, its error handler switched per call)
 * cost the contact bench's belt 7 % of its time. */
struct nz_lu {
  int cap, N;
  double *LU;                  /* cap x cap, row-major: L below the diagonal (unit), U on and above */
  int *piv;                    /* the row swapped with row c at column c */
};

nz_lu *nz_lu_new(int N)
{
  if (N < 1) return NULL;
  nz_lu *f = calloc(1, sizeof *f);
  if (!f) return NULL;
  f->cap = N;
  f->LU = malloc((size_t)N * (size_t)N * sizeof(double));
  f->piv = malloc((size_t)N * sizeof(int));
  if (!f->LU || !f->piv) {
    nz_lu_free(f);
    return NULL;
  }
  return f;
}

void nz_lu_free(nz_lu *f)
{
  if (!f) return;
  free(f->LU);
  free(f->piv);
  free(f);
}

int nz_lu_factor(nz_lu *f, int N, const double *A)
{
  if (N < 1 || N > f->cap) return NZ_EDOM;
  f->N = N;
  double *G = f->LU;
  memcpy(G, A, (size_t)N * (size_t)N * sizeof(double));
  for (int c = 0; c < N; c++) {
    int p = c;
    for (int r = c + 1; r < N; r++)
      if (fabs(G[r * N + c]) > fabs(G[p * N + c])) p = r;
    f->piv[c] = p;
    if (!(G[p * N + c] != 0.0)) return NZ_ESINGULAR;
    if (p != c)
      for (int x = 0; x < N; x++) {
        double v = G[c * N + x];
        G[c * N + x] = G[p * N + x], G[p * N + x] = v;
      }
    for (int r = c + 1; r < N; r++) {
      double m = G[r * N + c] /= G[c * N + c];
      if (m != 0.0)
        for (int x = c + 1; x < N; x++) G[r * N + x] -= m * G[c * N + x];
    }
  }
  return NZ_OK;
}

int nz_lu_solve(nz_lu *f, double *x)
{
  int N = f->N;
  const double *G = f->LU;
  /* P x (the factor swapped whole rows, its multipliers with them), then L, then U */
  for (int c = 0; c < N; c++) {
    double v = x[c];
    x[c] = x[f->piv[c]], x[f->piv[c]] = v;
  }
  for (int c = 0; c < N; c++)
    for (int r = c + 1; r < N; r++) x[r] -= G[r * N + c] * x[c];
  for (int r = N - 1; r >= 0; r--) {
    for (int c = r + 1; c < N; c++) x[r] -= G[r * N + c] * x[c];
    x[r] /= G[r * N + r];
  }
  return NZ_OK;
}

int nz_eigen(int n, const double *A, double *re, double *im, double *vr, double *vi)
{
  gsl_matrix *a = gsl_matrix_alloc((size_t)n, (size_t)n);
  gsl_vector_complex *eval = gsl_vector_complex_alloc((size_t)n);
  gsl_matrix_complex *evec = vr ? gsl_matrix_complex_alloc((size_t)n, (size_t)n) : NULL;
  gsl_eigen_nonsymmv_workspace *wv = vr ? gsl_eigen_nonsymmv_alloc((size_t)n) : NULL;
  gsl_eigen_nonsymm_workspace *w = vr ? NULL : gsl_eigen_nonsymm_alloc((size_t)n);
  int st = NZ_ENOMEM;
  if (!a || !eval || (vr && (!evec || !wv)) || (!vr && !w)) goto done;
  for (int i = 0; i < n; i++)
    for (int j = 0; j < n; j++) gsl_matrix_set(a, (size_t)i, (size_t)j, A[(size_t)i * (size_t)n + (size_t)j]);
  gsl_error_handler_t *old = gsl_set_error_handler_off();
  int rc = vr ? gsl_eigen_nonsymmv(a, eval, evec, wv) : gsl_eigen_nonsymm(a, eval, w);
  gsl_set_error_handler(old);
  if (rc) { st = NZ_ERANGE; goto done; }
  for (int i = 0; i < n; i++) {
    gsl_complex z = gsl_vector_complex_get(eval, (size_t)i);
    re[i] = GSL_REAL(z);
    im[i] = GSL_IMAG(z);
    for (int r = 0; vr && r < n; r++) {
      gsl_complex v = gsl_matrix_complex_get(evec, (size_t)r, (size_t)i);
      vr[(size_t)r * (size_t)n + (size_t)i] = GSL_REAL(v);
      vi[(size_t)r * (size_t)n + (size_t)i] = GSL_IMAG(v);
    }
  }
  st = NZ_OK;
done:
  if (a) gsl_matrix_free(a);
  if (eval) gsl_vector_complex_free(eval);
  if (evec) gsl_matrix_complex_free(evec);
  if (wv) gsl_eigen_nonsymmv_free(wv);
  if (w) gsl_eigen_nonsymm_free(w);
  return st;
}
