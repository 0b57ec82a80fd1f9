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
#include "linalg.h"
#include "mech.h"

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

int nz_solve_spd(int k, double *A, const double *b, double *x, double rcond_min,
                 nz_solve_info *info)
{
  memset(info, 0, sizeof *info);
  double *orig = malloc((size_t)k * (size_t)k * sizeof(double));
  double *work = malloc(3 * (size_t)k * sizeof(double));
  int st = NZ_OK;
  if (!orig || !work) { st = NZ_ENOMEM; goto done; }
  memcpy(orig, A, (size_t)k * (size_t)k * sizeof(double));
  gsl_matrix_view m = gsl_matrix_view_array(A, (size_t)k, (size_t)k);
  if (gsl_linalg_cholesky_decomp1(&m.matrix) != GSL_SUCCESS) {
    info->not_spd = 1;
    eigen_range(k, orig, info);
    st = NZ_ESINGULAR;
    goto done;
  }
  gsl_vector_view wv = gsl_vector_view_array(work, 3 * (size_t)k);
  gsl_linalg_cholesky_rcond(&m.matrix, &info->rcond, &wv.vector);
  if (!(info->rcond >= rcond_min)) {
    eigen_range(k, orig, info);
    st = NZ_ESINGULAR;
    goto done;
  }
  gsl_vector_const_view bv = gsl_vector_const_view_array(b, (size_t)k);
  gsl_vector_view xv = gsl_vector_view_array(x, (size_t)k);
  if (gsl_linalg_cholesky_solve(&m.matrix, &bv.vector, &xv.vector) != GSL_SUCCESS) st = NZ_ESINGULAR;
done:
  free(orig);
  free(work);
  return st;
}
