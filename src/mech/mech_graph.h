/* mech_graph.h - a system's pieces (T, V, Q, constraints, ...) as recorded
 * expression graphs (graph.h), evaluated in C behind the evaluator interface
 * of mech.h, and the graphs the mechanics derives from them once: the mass
 * matrix and the bias of M q'' + h = 0 (docs/theory.md §11).
 *
 * Inputs of the graph, numbered: 0 is t; 1 .. np the named parameters (in
 * the order the recorder chose); then slot j of q_i is 1 + np + j k + i;
 * last, after the nslots slots, the frozen velocity of q_i, 1 + np + nslots
 * k + i: docs/theory.md §4's T_0 is T with its velocity argument held
 * still while t and q move, which a derivative along the motion can only
 * tell from q' (slot 1) when it is an input of its own (sys:show's R_n; no
 * recorded piece reads it).
 * A parameter is an input, not a constant, so that changing it needs no new
 * recording: the caller writes the current values into nz_recording_params
 * before evaluating.
 *
 * Plain C: never includes lua.h. */
#ifndef NZ_MECH_GRAPH_H
#define NZ_MECH_GRAPH_H

#include "graph/graph.h"
#include "mech/mech.h"

typedef struct nz_recording nz_recording;

/* k coordinates, np parameters, nc constraints, nslots the most derivative
 * slots any piece receives (at least 2).  NULL if out of memory. */
nz_recording *nz_recording_new(int k, int np, int nc, int nslots);
void nz_recording_free(nz_recording *c);   /* NULL is harmless */

nz_graph *nz_recording_graph(nz_recording *c);
static inline int nz_recording_input_param(int p) { return 1 + p; }
int nz_recording_input_slot(const nz_recording *c, int j, int i);
int nz_recording_input_frozen(const nz_recording *c, int i);
int nz_recording_nslots(const nz_recording *c);
int nz_recording_ncoords(const nz_recording *c);
double *nz_recording_params(nz_recording *c);
int nz_recording_nparams(const nz_recording *c);

/* Piece `piece` (constraint number `index`, 0-based) is the n nodes given
 * (1, or k for NZ_PIECE_Q), summed over all the user's functions of the
 * piece by the recorder.  NZ_OK, NZ_ENOMEM or NZ_EARG (bad shape). */
int nz_recording_set_piece(nz_recording *c, nz_piece piece, int index, const int *nodes, int n);
int nz_recording_has(const nz_recording *c, nz_piece piece, int index);
/* Nodes the piece's evaluation visits (0 when not compiled). */
int nz_recording_piece_nodes(const nz_recording *c, nz_piece piece, int index);

/* The evaluator of mech.h on the compiled pieces (ctx is the nz_recording);
 * NZ_EARG for a piece that is not compiled, or a jet status (jet.h) from
 * the node that failed (nz_recording_failure describes it). */
int nz_recording_eval(void *ctx, nz_piece piece, int index, const nz_jet *t,
                     nz_jet *const *const *levels, int nlevels, nz_jet *const *out,
                     const nz_direction *dir);
const char *nz_recording_failure(const nz_recording *c);

/* M (k x k, row-major) and h of M q'' + h = 0 on doubles, from graphs of
 * d2F/dq'dq', d/dt dF/dq' (q'' = 0), dF/dq, dV/dq and Q built by
 * differentiating the recorded ones the first time (a mass_bias hook of
 * nz_system).  NZ_EARG when F, V or Q is not compiled, or when a node
 * fails (a domain error at this state): the caller then takes the jet path,
 * which names the user's function and line. */
int nz_recording_mass_bias(void *ctx, double t, const double *q, const double *qd, double *M,
                          double *h);
/* nz_accel on the same graphs (the accel hook of nz_system): M q'' = -h
 * by Cholesky in a workspace the recording owns; when every entry of M is a
 * constant (Cartesian coordinates), M is factored once and each call costs
 * a product with M^-1.  NZ_EARG as nz_recording_mass_bias, and also when a
 * constant M is too badly conditioned for rcond_min (the jet path then
 * reports it). */
struct nz_solve_info;
int nz_recording_accel(void *ctx, double t, const double *q, const double *qd, double rcond_min,
                      double *qdd, struct nz_solve_info *info);
/* The free_rhs hook of nz_system: f = (q', q'') from y = (q, q') in one
 * call of the machine code of q'' = -M^-1 h, for a constant M without F
 * and V to check; NZ_EARG otherwise (not built yet, interpreted, checked,
 * M too badly conditioned for rcond_min, a state that is not finite, or a
 * refusal at this state), when nz_recording_accel answers. */
int nz_recording_free_rhs(void *ctx, double t, const double *y, double rcond_min, double *f);
/* The row of constraint r of order m at the acceleration level (the
 * constraint_row hook of nz_system): D^(2-m) Phi with D the derivative
 * along the motion (t -> 1, slot j -> slot j + 1), built on the graph the
 * first time it is asked for (r, m), and its gradient in q''.  NZ_EARG when
 * the constraint is not compiled, the graph has too few slots, or a node
 * fails: the caller then takes the jets. */
int nz_recording_constraint_row(void *ctx, int r, int m, double t, const double *const *state,
                               int nstate, double alpha, double beta, double *A, double *value,
                               const double *slot_sizes, double *high);
/* Machine code for the plans on doubles (M and h, constraint rows):
 * mode 1 compiles each at its first use and waits for it, 0 never, -1 (the
 * default, or the environment's NZLUA_NATIVE=0/1) in the background once
 * interpreting the plan has cost a sixteenth (NZ_NATIVE_START_FRACTION) of
 * what compiling it would, NZ_NATIVE_BASE + NZ_NATIVE_PER_NODE x its nodes
 * node evaluations (at ~3 ns each: 0.05 s + 0.25 ms per node, the measured
 * cost of compiling), switching to the object when it is ready.  An object
 * already in the cache (by the graph's hash) is loaded at once, except in
 * mode 0. */
#define NZ_NATIVE_BASE 1.7e7
#define NZ_NATIVE_PER_NODE 8e4
#define NZ_NATIVE_START_FRACTION 16.0
/* The same for the series of a plan (Taylor's method), counted in node
 * coefficients at ~4 ns each interpreted: compiling costs about 0.35 s for
 * a small plan (Henon-Heiles: its second-order ODE is written out order by
 * order) and 3 ms per node of a big one. */
#define NZ_SERIES_NATIVE_BASE 1e8
#define NZ_SERIES_NATIVE_PER_NODE 8e5
void nz_recording_set_native(nz_recording *c, int mode);
int nz_recording_native_mode(const nz_recording *c);
/* Plans running natively; seconds spent compiling; why the last attempt
 * failed (NULL if none did). */
int nz_recording_native(const nz_recording *c, double *seconds, const char **why);
/* Of those, the series of plans (Taylor's method) running as machine code. */
int nz_recording_native_series(const nz_recording *c);
/* Compiles under way in the background; seconds runs waited for compiles
 * (native on); wait for every compile under way (a Ctrl-C request stops
 * the wait). */
int nz_recording_native_compiling(const nz_recording *c);
double nz_recording_native_waited(const nz_recording *c);
void nz_recording_native_wait(nz_recording *c);
/* The nz_system hook native_ready: 1 when every plan on doubles and every
 * series evaluated so far runs as machine code, 0 when one is interpreted,
 * -1 when machine code is off. */
int nz_recording_all_native(void *ctx);
/* The Taylor coefficients of the free motion from (t0, q0, qd0): a[n k + i]
 * is coefficient n of q_i(t0 + tau), n = 0 .. p, from M q'' + h = 0 built
 * order by order on the plans of M and h (graph.h's series: coefficient n
 * of every node from coefficients 0 .. n of the inputs, t = t0 + tau, q_i =
 * sum a_n tau^n, q'_i = sum (n + 1) a_{n+1} tau^n).  With a constant M,
 * coefficient n of q'' is that of the plan q'' = -M^-1 h; otherwise M_0 is
 * factored once (Cholesky, its condition checked against NZ_RCOND_MIN) and
 * M_0 q''_n = -(h_n + sum_{m=1..n} M_m q''_{n-m}); then a_{n+2} = q''_n /
 * ((n + 1)(n + 2)).  The check of F and V runs along.  For a system
 * without constraints (the caller checks: constraints are not seen here).
 * NZ_OK; NZ_EARG when M and h are not recorded; a jet status when a node
 * fails (a domain error, a coefficient not finite); NZ_ESINGULAR when M_0
 * is not positive definite or too badly conditioned (nz_recording_failure
 * says which).  The workspace is the recording's: after the first call for
 * a given p nothing is allocated. */
int nz_recording_motion_series(nz_recording *c, double t0, const double *q0, const double *qd0, int p,
                              double *a);
/* The Taylor coefficients of a motion under constraints of orders[r] <= 2
 * (the classification: 0 holonomic, 1 on the velocities, 2 on the
 * accelerations), from (t0, q0, qd0) with the accelerations qdd0 and the
 * multipliers lam0 of M q'' + h = A^T lambda solved at the start (by
 * nz_accel_constrained: Newton when a constraint is not linear in q'').
 * Order n >= 1 of q'' and lambda solves the saddle-point system
 *   [M_0 - sum_r lambda0_r H_r  -A_0^T] [q''_n    ]   [-(h_n + sum_{j>=1} M_j q''_{n-j}) + sum_{j>=1} A_j^T lambda_{n-j}]
 *   [A_0                         0    ] [lambda_n ] = [-(coefficient n + 2 - m_r of Phi_r at q''_n = 0) / s_r]
 * (A_r = dPhi_r/dq^(m_r), H_r = dA_r/dq'' for a constraint of order 2,
 * s_r the weight of q''_n in that coefficient), factored once per step:
 * the series of Phi_r vanishes to the order of the method, so the
 * constraints hold along each step up to its truncation error.  a as for
 * nz_recording_motion_series (p >= 2); lambda ((p - 1) x nc, or NULL): the
 * multipliers' coefficients.  NZ_OK; NZ_EARG with the reason in
 * nz_recording_failure (a constraint not recorded, of order > 2, or
 * reading derivatives above its order); NZ_ESINGULAR; a jet status. */
int nz_recording_constrained_series(nz_recording *c, const int *orders, double t0, const double *q0,
                                   const double *qd0, const double *qdd0, const double *lam0, int p, double *a,
                                   double *lambda);
/* The same with only some constraints held (a mode of unilateral contacts,
 * contact.h): rows[x], x < n, the constraints held, in that order (lam0 and
 * lambda follow it); with couple, the force of row x is that of
 * W = A_rows[x] + coef[x] A_couple[x] (a sliding contact's friction riding
 * on its normal force) where couple[x] >= 0, the row couple[x] being of
 * order <= 1.  sel NULL: every constraint, none coupled
 * (nz_series_selection: mech.h). */
int nz_recording_constrained_series_sel(nz_recording *c, const int *orders, const nz_series_selection *sel, double t0,
                                       const double *q0, const double *qd0, const double *qdd0, const double *lam0,
                                       int p, double *a, double *lambda);
/* nz_system's series hook (mech.h) on the recording ctx: the free motion's
 * series when orders is NULL, else the constrained one on sel. */
int nz_recording_series(void *ctx, const int *orders, const nz_series_selection *sel, double t0, const double *q0,
                       const double *qd0, const double *qdd0, const double *lam0, int p, double *a);
/* Branches in the graphs the series of the motion runs on: comparisons,
 * selections, sign and abs whose operands move with the state (-1 when M
 * and h are not recorded).  The series keeps the branch that coefficient 0
 * chose (graph.h), so a Taylor step must not cross a switch; until steps
 * are cut at the switches, a run refuses a system that has any. */
int nz_recording_motion_branches(nz_recording *c);
/* Nodes of the mass-bias plan (0 before its first use). */
int nz_recording_mass_bias_nodes(const nz_recording *c);
/* Reading the equations out of the graph (sys:show, sys:export): the node
 * ids of M (k x k, row-major) and h (k) into out (k k + k), built at the
 * first call (NZ_EARG when they cannot be: a piece not recorded); and the
 * output nodes of a piece into out (at most max of them; returns how many
 * the piece has, 0 when it is not recorded: call with max = 0 to size out). */
int nz_recording_mass_bias_outputs(nz_recording *c, int *out);
int nz_recording_piece_outputs(const nz_recording *c, nz_piece piece, int index, int *out, int max);

/* The first branch of M, h and the recorded pieces whose choice is decided
 * by rounding at the state (t, state[0 .. nstate - 1]: q, q', ...;
 * graph_rounding.h), or whose deciding number lies within tol of its
 * switch: 1 when one is found (*out, *pieces a mask of 1 <<
 * piece for the pieces whose functions hold the number that decides it and,
 * for a constraint, *constraint the first one's index), 0 when none, -1
 * when a node failed or memory ran out.  For a run whose steps collapsed. */
struct nz_rounding_branch;
int nz_recording_rounding_branch(nz_recording *c, double t, const double *const *state, int nstate, double tol,
                                struct nz_rounding_branch *out, unsigned *pieces, int *constraint);


#endif
