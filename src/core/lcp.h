/* lcp.h - the linear complementarity problem, by Lemke's algorithm.
 *
 * Find z with
 *
 *     w = q + M z,   z >= 0,   w >= 0,   z_i w_i = 0 for every i      (LCP(q, M))
 *
 * for a dense n x n matrix M (row-major) that need not be symmetric.  This
 * is the problem of unilateral contact (docs/theory.md §13): the normal
 * forces against the normal accelerations, the impulses against the
 * velocities after an impact, and with Coulomb friction the friction
 * forces against the slip (Stewart and Trinkle's formulation, whose matrix
 * is not symmetric).
 *
 * Why Lemke's algorithm (C. E. Lemke, Management Science 11 (1965) 681;
 * Cottle, Pang and Stone, The Linear Complementarity Problem, 1992,
 * §4.4): it is a finite pivoting method on the n x (2n + 1) tableau that
 * works for any M, terminates with a solution whenever M is copositive-plus
 * and one exists (every contact problem above but a sliding contact in
 * Painleve's paradox), and reports the problems it cannot solve by a ray,
 * instead of trying 2^n active sets (four unknowns per frictional contact
 * make enumeration 16^contacts).  Ties in the ratio test are broken by the
 * lexicographic rule, which makes it terminate on degenerate problems
 * (a resting contact whose force and acceleration both vanish).
 *
 * Plain C, no allocation: the caller gives a workspace of nz_lcp_work_len(n)
 * doubles.  Statuses from core/status.h. */
#ifndef NZ_LCP_H
#define NZ_LCP_H

#include <stddef.h>
#include "core/status.h"

/* Pivots allowed: Lemke's path visits each basis at most once, and the
 * contact problems here take a few n; beyond this the problem is cycling on
 * rounding and is reported as unsolved. */
#define NZ_LCP_MAX_PIVOTS(n) (50 * (n) + 100)

typedef enum nz_lcp_result {
  NZ_LCP_SOLVED = 0,      /* z, w satisfy the LCP                                  */
  NZ_LCP_RAY,             /* Lemke's path ended on a ray: for a copositive-plus M,  */
                          /* the problem has no solution                           */
  NZ_LCP_PIVOTS           /* the pivots ran out (rounding)                         */
} nz_lcp_result;

typedef struct nz_lcp_info {
  nz_lcp_result result;
  int pivots;             /* pivots taken                                          */
  double residual;        /* max over i of |min(z_i, w_i)| and the negative parts   */
                          /* of z and w, relative to the size of q and M z          */
} nz_lcp_info;

size_t nz_lcp_work_len(int n);

/* Solve LCP(q, M) into z and w (n each).  NZ_OK when solved (info->result
 * NZ_LCP_SOLVED); NZ_EARG when Lemke's path ends on a ray or the pivots run
 * out (info says which; z and w are then zero); NZ_EDOM for n < 1.  Entries
 * of z and w below the rounding of their row are set to 0 exactly, so a
 * caller can read z_i > 0 as "active". */
int nz_lcp_solve(int n, const double *M, const double *q, double *z, double *w, double *work,
                 nz_lcp_info *info);

#endif
