/* linalg.h - the dense linear algebra the mechanics needs, on GSL. */
#ifndef NZ_LINALG_H
#define NZ_LINALG_H

#include "core/status.h"

/* Default for NZ: a matrix whose reciprocal condition number (1-norm
 * estimate) is below this is reported singular rather than solved. */
#define NZ_RCOND_MIN 1e-13

typedef struct nz_solve_info {
  double rcond;        /* reciprocal condition number in the 1-norm (0 if not
                        * computed): Hager-Higham's estimate, or a lower bound
                        * when a cheap one already clears rcond_min           */
  double eig_min;      /* smallest and largest eigenvalue, when diagnosed    */
  double eig_max;
  int not_spd;         /* 1 when the Cholesky factorization failed           */
} nz_solve_info;

/* Solve A x = b for symmetric positive definite A (k x k, row-major; A is
 * overwritten).  Returns NZ_OK, or NZ_ESINGULAR with info filled: not_spd and
 * the eigenvalue range of the original matrix when A is not positive
 * definite, or rcond < rcond_min when it is too badly conditioned. */
int nz_solve_spd(int k, double *A, const double *b, double *x, double rcond_min,
                 nz_solve_info *info);
/* The same in the caller's workspace of nz_solve_spd_work_len(k) doubles:
 * nothing is allocated unless the matrix has to be diagnosed. */
size_t nz_solve_spd_work_len(int k);
int nz_solve_spd_in(int k, double *A, const double *b, double *x, double rcond_min,
                    nz_solve_info *info, double *work);
/* After nz_solve_spd_in returned NZ_OK, A holds the Cholesky factor L of
 * the matrix (A = L L^T, L in the lower triangle): further right-hand sides
 * of the same matrix cost two triangular solves, x = (L L^T)^-1 x in place
 * (the Taylor method's orders 1, 2, ... of one step share M_0's factor). */
void nz_cholesky_solve(int k, const double *L, double *x);

#include <gsl/gsl_matrix.h>
#include <gsl/gsl_vector.h>

/* A singular value decomposition a = U S V^T kept for several uses. */
typedef struct nz_svd {
  gsl_matrix *U, *V;
  gsl_vector *S, *work;
} nz_svd;

/* Decompose the row-major rows x cols matrix a (transposed first when
 * transpose is set, so that GSL's rows >= cols holds). */
int nz_svd_of(nz_svd *d, int rows, int cols, const double *a, int transpose);
void nz_svd_free(nz_svd *d);

/* Least squares with the minimum norm (SVD): x minimizes |A x - b| (m x n). */
int nz_lstsq(int m, int n, const double *A, const double *b, double *x);
/* The same in a workspace made once for matrices up to N x N (either
 * shape), for a caller that solves again and again: nothing is allocated
 * per solve.  Singular values at or below cut times the largest count as
 * zero; *rank (may be NULL) gets the number of the others.  NZ_OK, NZ_EDOM
 * (a size beyond the workspace's), NZ_ERANGE (the SVD did not converge). */
typedef struct nz_lstsq_ws nz_lstsq_ws;
nz_lstsq_ws *nz_lstsq_new(int N);
void nz_lstsq_free(nz_lstsq_ws *w);   /* NULL is harmless */
int nz_lstsq_in(nz_lstsq_ws *w, int m, int n, const double *A, const double *b, double *x, double cut, int *rank);

/* Solve the square N x N system J x = rhs through its SVD; *rcond is
 * s_min / s_max (x is left untouched when s_min = 0). */
int nz_solve_svd(int N, const double *J, const double *rhs, double *x, double *rcond);
/* The same decision for less: pivoted QR with GSL's 1-norm estimate of the
 * reciprocal condition; the SVD (as above) when that estimate comes within
 * a factor 1e3 of rcond_min, so that a matrix is declared singular by the
 * SVD's s_min / s_max only. */
int nz_solve_square(int N, const double *J, const double *rhs, double *x, double rcond_min,
                    double *rcond);

/* Eigenvalues (re[i] + i im[i]) and, when vr is not NULL, eigenvectors
 * (column i of the row-major n x n matrices vr, vi) of the row-major real
 * n x n matrix A, by GSL's nonsymmetric solver (Francis QR); unsorted.
 * NZ_OK, NZ_ENOMEM, or NZ_ERANGE when the QR iteration did not converge. */
int nz_eigen(int n, const double *A, double *re, double *im, double *vr, double *vi);

/* An LU factorization (partial pivoting, written out) kept for several right-hand
 * sides: the saddle-point matrix of a constrained Taylor step, factored once
 * per step and solved once per order.  nz_lu_new(N) holds matrices up to N x
 * N; NULL when out of memory. */
typedef struct nz_lu nz_lu;
nz_lu *nz_lu_new(int N);
void nz_lu_free(nz_lu *f);   /* NULL is harmless */
/* Factor the row-major N x N matrix A (N <= the size it was made for).
 * NZ_OK, NZ_EDOM (N too large), or NZ_ESINGULAR when a pivot is 0. */
int nz_lu_factor(nz_lu *f, int N, const double *A);
/* x = A^-1 x in place, for the last factored A. */
int nz_lu_solve(nz_lu *f, double *x);

#endif
