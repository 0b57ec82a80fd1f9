/* constrained.h - constraints of any order and the motion they allow
 * (docs/theory.md §6-§8).
 *
 * A constraint Phi_r(t, q, q', q'', q''', ...) = 0 has an order m (the highest
 * derivative it depends on) and is linear or not in q^(m); both are found
 * numerically (lua/nz/model/constraints.lua) from the primitives below.  At the
 * acceleration level (§6) a constraint of order m <= 2 is differentiated
 * 2 - m times, which makes it affine in q'' unless m = 2 and it is nonlinear
 * there; then (6.2) and Phi = 0 are solved together by Newton's method. */
#ifndef NZ_CONSTRAINED_H
#define NZ_CONSTRAINED_H

#include "mech/mech.h"

/* Value, partial derivatives with respect to every slot (dphi[j*k + i] =
 * dPhi/dq_i^(j), j = 0..nz_constraint_levels(s, r)-1) and dPhi/dt, at the state. */
int nz_constraint_partials(const nz_system *s, int r, double t, const double *const *state,
                           int nstate, double *value, double *dphi, double *dphidt);

/* The constraint differentiated `level` times along the motion (0: Phi
 * itself, 1: Phi' = Phi_t + Phi_q q' + ...) into *value, and its gradient
 * with respect to the state: grad[i] = d/dq_i, grad[k + i] = d/dq'_i (2k
 * values), exact (tangents on the jets).  These are the rows of the tangent
 * space of the constraints that sys:linearize works in: a holonomic
 * constraint at levels 0 and 1, a first-order one at level 0.  Level 1 of a
 * first-order constraint would read q'' from the state (the gradient is then
 * the partial one, at that q''). */
int nz_constraint_state_gradient(const nz_system *s, int r, int level, double t,
                                 const double *const *state, int nstate, double *value,
                                 double *grad);

/* The constraints of order m <= 1 (orders[r], the classification) along
 * the motion through the state (q, q', q'' in state): values[2r] = Phi_r
 * and, for m = 0, values[2r + 1] = Phi_r' = Phi_t + Phi_q q' (0 for the
 * others).  One evaluation of each on jets of order 1 - m without tangents,
 * in one workspace: how far a state is from the constraints, for about the
 * cost of its rows. */
int nz_constraint_state_values(const nz_system *s, const int *orders, double t, const double *const *state,
                               int nstate, double *values);

/* Phi along q^(m) + s v, as a series in s: c[0] + c[1] s + c[2] s^2.
 * c[2] = v^T H v / 2 vanishes for every v exactly when Phi is affine in q^(m). */
int nz_constraint_curvature(const nz_system *s, int r, int m, double t, const double *const *state,
                            int nstate, const double *v, double c[3]);

/* The rows dPhi_r/dq^(m) of the constraints of order m = 0 and 1 at (t, q,
 * q') into rows (nc x k; the rows of higher orders zero); zero is k doubles
 * of scratch (their q'', which these rows do not read). */
int nz_constraint_rows_01(const nz_system *s, int nc, const int *orders, double t, const double *q,
                          const double *qd, double *zero, double *rows);
/* 1 + the first constraint of order 0 or 1 whose row reversed from before
 * to after (cos < -0.9999), or 0.  A constraint whose gradient passes
 * through zero on the motion (a cone's vertex, Appell's particle at rest
 * on its cone) does not determine the motion there: the multiplier grows
 * without bound and other continuations satisfy the equations too; the
 * steppers go on along the smooth one, and a step across the point ends
 * with the row reversed.  Used on each step's ends by every integrator. */
int nz_constraint_row_reversed(int nc, int k, const int *orders, const double *before, const double *after);

/* The constraint at the acceleration level: Phi^(2-m) at the state's q'' in
 * *value, and its gradient A = d Phi^(2-m) / d q'' (= dPhi/dq^(m) by (2.1)). */
int nz_constraint_row(const nz_system *s, int r, int m, double t, const double *const *state,
                      int nstate, double *A, double *value);
/* The same in the caller's workspace mo (reset here, freed by the caller):
 * a caller that asks for rows again and again (the contacts, at every
 * right-hand side) allocates nothing after the first. */
int nz_constraint_row_in(const nz_system *s, nz_motion *mo, int r, int m, double t, const double *const *state,
                         int nstate, double *A, double *value);
/* The same row with Baumgarte's terms added to the value: for m = 0,
 * Phi'' + 2 alpha Phi' + beta^2 Phi; for m = 1, Phi' + alpha Phi (the
 * lower coefficients of the same jet give Phi and Phi'). */
int nz_constraint_row_stabilized(const nz_system *s, int r, int m, double t,
                                 const double *const *state, int nstate, double alpha, double beta,
                                 double *A, double *value);
/* The same, with the derivatives dA and dvalue along a state direction. */
int nz_constraint_row_along(const nz_system *s, int r, int m, double t, const double *const *state,
                            int nstate, double alpha, double beta, const nz_state_direction *dir,
                            double *A, double *value, double *dA, double *dvalue);

/* d^2 Phi / dq''^2 (k x k, row-major) of a second-order constraint. */
int nz_constraint_hessian(const nz_system *s, int r, double t, const double *const *state,
                          int nstate, double *H);

typedef struct nz_accel_options {
  double rcond_min;         /* below this reciprocal condition: singular   */
  double newton_tol;        /* |G| <= tol (1 + |h|) ends Newton             */
  int newton_maxit;
  const double *guess_qdd;  /* Newton's start, or NULL: unconstrained qdd   */
  const double *guess_lambda;
  double baumgarte_alpha;   /* Baumgarte stabilization (0, 0: none):           */
  double baumgarte_beta;    /* Phi'' + 2 alpha Phi' + beta^2 Phi = 0 (holonomic), */
                            /* Phi' + alpha Phi = 0 (first order)               */
  int skip_check;           /* 1: trust the solve (only to measure the check's */
                            /* cost); 0, the default, checks every solution    */
} nz_accel_options;

#define NZ_ACCEL_DEFAULTS { 1e-13, 1e-12, 50, NULL, NULL, 0.0, 0.0, 0 }

/* The check after every solve (constrained.c, check_solution):
 * - the solution x = (q'', lambda) must be a solution of the equilibrated
 *   saddle-point system [M -A^T; A 0] x = b it was solved from, with the
 *   constraint rows evaluated again at x by the user's functions: its
 *   normwise backward error ||D G(x)|| / (||D J D|| ||D^-1 x|| + ||D b||)
 *   (infinity norms, D the equilibration of the solve) must not exceed
 *   NZ_ACCEL_CHECK_TOL.  A backward-stable solve (pivoted QR) leaves a few N
 *   eps (N = k + nc; at most 1.8e-16 measured along the motion of
 *   Andrews' squeezer, tests/squeezer_spec.lua), Newton
 *   stops at 1e-12 of the forces before its last exact step, and a
 *   constraint classified linear that is not here, or a solve near a rank
 *   loss of A, leaves 1e-6 and more.  1e-10 keeps five orders above
 *   rounding and matches the integrators' default rtol: a backward error
 *   the check lets pass changes the equations less than the integration
 *   does.
 * - a constraint classified of order m fails when its derivative along the
 *   slots above m, weighted by their typical sizes, exceeds
 *   NZ_ACCEL_CHECK_TOL x the size of its q^(m) terms. */
#define NZ_ACCEL_CHECK_TOL 1e-10

/* and the relative error of the solution that the backward error and the
 * condition of the equilibrated system allow, max(eta, eps) / rcond, must
 * not exceed NZ_ACCEL_FORWARD_TOL.  Near a configuration where the
 * constraints' gradients lose rank (two surfaces meeting tangentially:
 * Viviani's double point) the motion is not determined: the multipliers
 * grow like 1/sigma and the condition like 1/sigma^2, sigma A's smallest
 * singular value relative to its largest, and a backward-stable solve
 * still has a tiny backward error while its accelerations lose every
 * digit.  1e-6 is reached at sigma ~ 1e-5 (rcond ~ 2e-10), where q'' still
 * has six digits; the mechanisms of the tests keep rcond above 1e-3. */
#define NZ_ACCEL_FORWARD_TOL 1e-6

/* A check that fails names the constraints whose gradients are nearly
 * dependent: A's smallest singular value below this of its largest (where
 * the forward bound above fails by a rank loss, sigma ~ 1e-5). */
#define NZ_NEAR_DEPENDENCE 1e-4

typedef enum nz_accel_failure {
  NZ_ACCEL_OK = 0,
  NZ_ACCEL_SINGULAR,        /* [M A^T; A 0] singular or badly conditioned     */
  NZ_ACCEL_NEWTON,          /* Newton did not converge                        */
  NZ_ACCEL_ORDER,           /* a constraint of order > 2                      */
  NZ_ACCEL_CHECK,           /* the solution fails the check, also after the    */
                            /* constraints were classified again at the state  */
  NZ_ACCEL_TOP_SINGULAR,    /* level p, a constraint nonlinear in q^(p): the  */
                            /* Jacobian in (q^(p), lambda) is singular        */
  NZ_ACCEL_TOP_NEWTON       /* level p: Newton on (6.2) and the constraints   */
                            /* for (q^(p), lambda) did not converge           */
} nz_accel_failure;

/* What the check after the solve found wrong (nz_accel_report). */
typedef enum nz_check_kind {
  NZ_CHECK_BACKWARD = 0,    /* the backward error exceeds NZ_ACCEL_CHECK_TOL   */
  NZ_CHECK_ORDER,           /* a constraint depends on slots above its order  */
  NZ_CHECK_FORWARD          /* the solution's error bound exceeds             */
                            /* NZ_ACCEL_FORWARD_TOL (a rank loss of A nears)   */
} nz_check_kind;

typedef struct nz_accel_report {
  nz_accel_failure failure;
  int iterations;           /* Newton iterations; 0 for one linear solve      */
  double residual;          /* max |G| of (6.2) and the constraints at the end */
  double rcond;             /* of the last (equilibrated) matrix: pivoted QR's  */
                            /* 1-norm estimate, or sigma_min / sigma_max near   */
                            /* the threshold (nz_solve_square)                 */
  int rank_A;               /* rank of A (constraint gradients)               */
  double sigma_ratio;       /* A's smallest singular value over its largest,  */
                            /* when its rank was looked at                     */
  int *involved;            /* caller's nc ints: 1 for constraints in a dependence */
  int from_guess;           /* Newton started from the caller's guess         */
  double *A;                /* caller's nc x k, or NULL: the gradients A at the end */
  int reclassified;         /* constraints classified again at this state     */
  int *used;                /* caller's 2 nc ints, or NULL: the orders, then   */
                            /* the linear flags, the solution was found with   */
  /* NZ_ACCEL_CHECK: the row that failed (0..k-1: (6.2) for q_i; k + r:
   * constraint r) and its violation |G|, with check_backward the backward
   * error it makes and check_size the system's size it is measured
   * against (||D J D|| ||D^-1 x|| + ||D b||); or a constraint of too low an
   * order: the violation and size are those of its terms above and at its
   * classified order, and with check_order >= 0 constraint r depends on
   * q^(check_order) here, above the order 2 an acceleration-level solve can
   * impose. */
  int check_row, check_order;
  nz_check_kind check_kind; /* which test failed                               */
  double check_violation, check_size;
  double check_backward;    /* the backward error of the last check (every   */
                            /* solve that was checked), see NZ_ACCEL_CHECK_TOL */
  double check_forward;     /* its bound on the solution's relative error,     */
                            /* max(backward error, eps) / rcond                */
  /* NZ_ACCEL_NEWTON, NZ_ACCEL_TOP_NEWTON: how it stopped (nz_newton_stop),
   * and (NZ_ACCEL_NEWTON) the constraint farthest from zero at the last
   * iterate (newton_row, 0-based, -1 for none) with its value. */
  int newton_stop, newton_row;
  double newton_value;
} nz_accel_report;

/* How Newton's method stopped without a root: the iterations ran out; its
 * steps stopped reducing the residual; its step was not finite (the
 * Jacobian is singular there: GSL's hybrid step divides by its zero pivot);
 * the equations were not finite at an iterate. */
typedef enum nz_newton_stop {
  NZ_NEWTON_MAXIT = 0,
  NZ_NEWTON_NO_PROGRESS,
  NZ_NEWTON_STEP_NOT_FINITE,
  NZ_NEWTON_VALUE_NOT_FINITE
} nz_newton_stop;

/* Rank of the gradients A (nc x k) into rep->rank_A, and rep->involved[r]
 * set for the constraints that take part in a dependence. */
void nz_constraint_dependence(int nc, int k, const double *A, nz_accel_report *rep);

/* Accelerations and multipliers of M q'' + h = A^T lambda with the
 * constraints closed at the acceleration level.  orders[r] and linear[r]
 * come from the classification.  Every solution is checked (see
 * NZ_ACCEL_CHECK_TOL); when the check fails, the constraints it blames are
 * classified again at this state (order, and linearity in q'') and the
 * system is solved again, by Newton where a constraint is nonlinear here.
 * Returns NZ_OK, NZ_ESINGULAR (report says why), or NZ_EARG
 * (report.failure = NZ_ACCEL_NEWTON / NZ_ACCEL_ORDER / NZ_ACCEL_CHECK). */
int nz_accel_constrained(const nz_system *s, const int *orders, const int *linear, double t,
                         const double *q, const double *qd, const nz_accel_options *opt,
                         double *qdd, double *lambda, nz_accel_report *rep);

/* How far a state (t, q, qd) is from the constraints: the largest |value| of
 * the constraints of order <= 1 (orders[r], the classification) at position
 * level and velocity level (a holonomic one at both: Phi and Phi' = Phi_t +
 * Phi_q q'), into *worst.  The same numbers as lua/nz/model/constraints.lua's
 * M.violation, by the same primitive (nz_constraint_partials) and the same
 * operations in the same order, so that the stepping loop in C
 * (ode/ode_run.c) decides to project exactly where the Lua loop does. */
int nz_state_violation(const nz_system *s, const int *orders, double t, const double *q,
                       const double *qd, double *worst);

#endif
