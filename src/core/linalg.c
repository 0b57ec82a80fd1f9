/* linalg.c - SPD solves with a diagnosis when they fail (see linalg.h).
 * Cholesky (GSL) is the right factorization for M = d^2T/dq'^2; when it
 * fails, the eigenvalues of the symmetric matrix say how far from positive
 * definite it is, which is what the user needs to see. */
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

int nz_solve_spd_in(int k, double *A, const double *b, double *x, double rcond_min,
                    nz_solve_info *info, double *work)
{
  memset(info, 0, sizeof *info);
  double *orig = work, *rwork = work + (size_t)k * (size_t)k;
  memcpy(orig, A, (size_t)k * (size_t)k * sizeof(double));
  gsl_matrix_view m = gsl_matrix_view_array(A, (size_t)k, (size_t)k);
  if (gsl_linalg_cholesky_decomp1(&m.matrix) != GSL_SUCCESS) {
    info->not_spd = 1;
    eigen_range(k, orig, info);
    return NZ_ESINGULAR;
  }
  gsl_vector_view wv = gsl_vector_view_array(rwork, 3 * (size_t)k);
  gsl_linalg_cholesky_rcond(&m.matrix, &info->rcond, &wv.vector);
  if (!(info->rcond >= rcond_min)) {
    eigen_range(k, orig, info);
    return NZ_ESINGULAR;
  }
  gsl_vector_const_view bv = gsl_vector_const_view_array(b, (size_t)k);
  gsl_vector_view xv = gsl_vector_view_array(x, (size_t)k);
  if (gsl_linalg_cholesky_solve(&m.matrix, &bv.vector, &xv.vector) != GSL_SUCCESS) return NZ_ESINGULAR;
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

int nz_lstsq(int m, int n, const double *A, const double *b, double *x)
{
  nz_svd d;
  int transpose = m < n;
  int st = nz_svd_of(&d, m, n, A, transpose);
  if (st) return st;
  /* A = U S V^T (or A^T = U S V^T): x = V S+ U^T b (or U S+ V^T b). */
  int C = transpose ? m : n;
  double smax = gsl_vector_get(d.S, 0), cut = 1e-13 * smax;
  memset(x, 0, (size_t)n * sizeof(double));
  for (int c = 0; c < C; c++) {
    double sc = gsl_vector_get(d.S, (size_t)c);
    if (!(sc > cut)) continue;
    double proj = 0.0;
    if (!transpose) for (int i = 0; i < m; i++) proj += gsl_matrix_get(d.U, (size_t)i, (size_t)c) * b[i];
    else for (int i = 0; i < m; i++) proj += gsl_matrix_get(d.V, (size_t)i, (size_t)c) * b[i];
    proj /= sc;
    if (!transpose) for (int j = 0; j < n; j++) x[j] += gsl_matrix_get(d.V, (size_t)j, (size_t)c) * proj;
    else for (int j = 0; j < n; j++) x[j] += gsl_matrix_get(d.U, (size_t)j, (size_t)c) * proj;
  }
  nz_svd_free(&d);
  return NZ_OK;
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
