/* constrained_series.h - the motion under constraints of order 3 and more,
 * integrated at a level p >= 3 (THEORY.md §6).
 *
 * With a constraint linear in q^(m), m >= 3, the accelerations are not a
 * function of (q, q'): q'' is part of the state.  The state grows by the
 * derivatives and multipliers the order requires,
 *
 *     y = (q, q', ..., q^(p-1), lambda, lambda', ..., lambda^(p-3)),
 *
 * and (6.2), G = M q'' + h - A^T lambda = 0, differentiated p - 2 times in
 * time, is solved for q^(p) and lambda^(p-2) together with every constraint
 * differentiated up to level p, Phi_r^(p - m_r) = 0.  Both are affine in the
 * unknowns: by (2.1) the top derivative enters Phi_r^(j) with the
 * coefficient A_r = dPhi_r/dq^(m_r), and it enters G^(p-2) through
 * M q^(p) and, when A_r depends on q'', through lambda_r A_r^(p-2).
 *
 * Closure: A_r^(p-2) involves q^(d_r + p - 2), d_r the highest level A_r
 * depends on; the system closes at level p only when d_r <= 2 for every
 * constraint (always for p = 3 with constraints linear in q^(m), m <= 3, or
 * of order <= 2; for p >= 4, when each A_r depends on q, q', q'' at most).
 * nz_series_closure detects the other cases.
 *
 * Every time series here is read off jets along the motion (mech.h): the
 * Nielsen residual r = d/dt dF/dq' - dF/dq - Q + dV/dq from F with the
 * velocity and position slots seeded as a whole, A_r from Phi_r with slot
 * m_r seeded as a whole; products of series by Cauchy's rule on the
 * normalized coefficients (THEORY.md §3, §11). */
#ifndef NZ_CONSTRAINED_SERIES_H
#define NZ_CONSTRAINED_SERIES_H

#include "constrained.h"

/* The state's size for level p: p k + (p - 2) nc. */
int nz_series_dim(int k, int nc, int p);

/* The equations of level l (0 <= l) at t: res[i] = G_i^(l-2) for i < k
 * (0 when l < 2), res[k + r] = Phi_r^(l - m_r) when m_r <= l (else 0).
 * levels: q .. q^(l) (l + 1 arrays; more are taken as 0); lam: lambda^(j)
 * for j = 0..l-2 at lam[j nc + r] (NULL when l < 2).  A (nc x k, may be
 * NULL): the gradients A_r at t; gscale: 1 + the size of the dynamic terms
 * of the G rows (for relative tests). */
int nz_series_level(const nz_system *s, const int *orders, int l, double t,
                    const double *const *levels, const double *lam, double *res, double *A,
                    double *gscale);

/* The right-hand side of y' = f(t, y) at level p (layout above).  On a
 * singular system rep->failure = NZ_ACCEL_SINGULAR and NZ_ESINGULAR. */
int nz_series_rhs(const nz_system *s, const int *orders, int p, double rcond_min, double t,
                  const double *y, double *f, nz_accel_report *rep);

/* Whether level p closes at this state: *bad = the first constraint whose
 * gradient A_r^(p-2) depends on derivatives above q^(p), or -1.
 * levels: q .. q^(p). */
int nz_series_closure(const nz_system *s, const int *orders, int p, double t,
                      const double *const *levels, int *bad);

/* The worst violation of the equations of levels 0..p-1 at a start state. */
typedef struct nz_series_violation {
  double value;      /* |residual| / scale of the worst row                 */
  int level;         /* the level l of its equations                         */
  int row;           /* < k: (6.2) differentiated l-2 times, coordinate row; */
                     /* else constraint row - k, differentiated l - m times  */
} nz_series_violation;

/* The multipliers lambda^(j), j = 0..p-3, at a start state (levels q ..
 * q^(p-1)), each by least squares from (6.2) differentiated j times, into
 * lam ((p-2) nc), and the worst violation of the equations of each level. */
int nz_series_initial(const nz_system *s, const int *orders, int p, double t,
                      const double *const *levels, double *lam, nz_series_violation *v);

/* Complete a start state: for l = 2..p-1, the smallest change of
 * (q^(l), lambda^(l-2)) that satisfies the equations of level l, by
 * Gauss-Newton steps of minimum norm (one step when they are affine).
 * levels[2..p-1] are updated in place; lam gets (p-2) nc multipliers.
 * NZ_EARG when maxit steps do not bring a level below tol (1 + scale). */
int nz_series_project(const nz_system *s, const int *orders, int p, double t, double *const *levels,
                      double *lam, double tol, int maxit, int *iterations);

#endif
