/* constrained_series.h - the motion under constraints of order 3 and more,
 * integrated at a level p >= 3 (docs/theory.md §6).
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
 * normalized coefficients (docs/theory.md §3, §11). */
#ifndef NZ_CONSTRAINED_SERIES_H
#define NZ_CONSTRAINED_SERIES_H

#include "mech/constrained.h"

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

/* Complete a start state: for l = 2..p-1, the smallest change of q^(l)
 * that satisfies the equations of level l, by Gauss-Newton steps of minimum
 * norm (one step when they are affine); a state that satisfies them is
 * left as it is.  The multipliers lambda^(l-2) take whatever the equations
 * need, unless chosen[l-2] is set (chosen NULL: none is): then their
 * change counts too, the least change of (q^(l), lambda^(l-2)) together
 * (the user gave them, or a projection along the motion, where they are
 * part of the state).  levels[2..p-1] are updated in place; lam ((p-2) nc
 * multipliers) holds their start and gets the result.
 * NZ_EARG when maxit steps do not bring a level below tol (1 + scale). */
int nz_series_project(const nz_system *s, const int *orders, int p, double t, double *const *levels,
                      double *lam, const int *chosen, double tol, int maxit, int *iterations);

/* ------------------------------------------------------------------ */
/* A constraint of order p >= 3 NONLINEAR in q^(p)                      */
/*                                                                      */
/* Differentiating (6.2) does not close here: A_r = dPhi_r/dq^(p) depends
 * on q^(p), so (lambda A)^(p-2) involves q^(2p-2).  Instead the state is
 * y = (q, q', ..., q^(p-1)) (no multipliers) and at each time the square
 * system, (6.2) undifferentiated and every constraint at level p,
 *
 *     G = M q'' + h - Q - sum_r lambda_r A_r(t, q, .., q^(m_r)) = 0     (k rows)
 *     Phi_r^(p - m_r) = 0                                              (nc rows)
 *
 * is solved for x = (q^(p), lambda) by Newton's method with the exact
 * Jacobian [-sum_r lambda_r H_r, -A^T; A, 0], H_r = d^2 Phi_r/dq^(p)^2
 * (nonzero only for the constraints of order p nonlinear in q^(p)).  q''
 * is a state here, so G fixes q^(p) only through lambda_r H_r: the system
 * is an index-1 DAE where that Jacobian is nonsingular, which needs
 * lambda_r != 0 (generically).  More than one root can exist: Newton starts
 * from the caller's guess (the previous step's root keeps the branch), else
 * from q^(p) = 0 with lambda by least squares from G. */

/* The equations F (k + nc) at x = (q^(p), lambda), and their Jacobian J
 * ((k + nc)^2, row-major) when J is not NULL.  levels: q .. q^(p-1). */
int nz_top_equations(const nz_system *s, const int *orders, const int *linear, int p, double t,
                     const double *const *levels, const double *x, double *F, double *J);

/* Solve for x = (q^(p), lambda) at the state; guess (k + nc) or NULL.
 * rep: iterations, residual, rcond, from_guess; on failure rep->failure =
 * NZ_ACCEL_TOP_SINGULAR (NZ_ESINGULAR) or NZ_ACCEL_TOP_NEWTON (NZ_EARG). */
int nz_top_solve(const nz_system *s, const int *orders, const int *linear, int p,
                 const nz_accel_options *opt, double t, const double *const *levels,
                 const double *guess, double *x, nz_accel_report *rep);

/* The right-hand side of y' = f(t, y), y = (q, .., q^(p-1)): f = (q', ..,
 * q^(p-1), q^(p)); the root (q^(p), lambda) goes to x. */
int nz_top_rhs(const nz_system *s, const int *orders, const int *linear, int p,
               const nz_accel_options *opt, double t, const double *y, const double *guess,
               double *f, double *x, nz_accel_report *rep);

/* ------------------------------------------------------------------ */
/* The Jacobian of a level-p right-hand side (implicit steppers)         */

/* dfdy (dim x dim, row-major) and dfdt by central differences of f, with
 * the step h_j = cbrt(eps) (1 + |y_j|) chosen per component (and for t),
 * rounded so that y_j + h_j - y_j = h_j exactly.  The truncation error is
 * O(h^2 f''') and the rounding error O(eps |f| / h): about 1e-10 relative
 * for a smooth f.  f returns an nz status; work: 3 dim doubles. */
typedef int (*nz_rhs_fn)(double t, const double *y, double *f, void *ctx);
int nz_central_jacobian(int dim, double t, const double *y, nz_rhs_fn f, void *ctx,
                        double *dfdy, double *dfdt, double *work);

#endif
