/* mech.h - generalized equations of motion of any order (docs/theory.md §2-§5, §11).
 *
 * Plain C: the mechanics reaches the user's functions only through the
 * evaluator below ("evaluate this piece on these jets"), so that a faster
 * evaluator (an expression graph recorded once and run in C) can replace the
 * Lua callbacks without touching this module.
 *
 * Notation: k coordinates; the state is given as derivative levels,
 * state[j][i] = q_i^(j) (state[0] = q, state[1] = q', state[2] = q'', ...).
 * A jet of q_i of order K holds a_{i,j} = q_i^(j)/j!; the jet of the velocity
 * slot holds b_{i,j} = q_i^(j+1)/j! (docs/theory.md §3).  The function F is the
 * kinetic part, T plus any general Lagrangian pieces; V enters every form
 * through its gradient only, and Q is the non-potential force. */
#ifndef NZ_MECH_H
#define NZ_MECH_H

#include "core/status.h"
#include "jets/jet.h"

#define NZ_MAX_EQ_ORDER 100     /* highest n of (3.1); n! must stay finite */
#define NZ_MAX_LEVELS (NZ_MAX_EQ_ORDER + 2)

/* Statuses: NZ_OK, the jet codes and NZ_EFUNC, NZ_EARG, NZ_ESINGULAR are all
 * in core/status.h. */

typedef enum nz_piece {
  NZ_PIECE_F,     /* F(t, q, q'): T and Lagrangian pieces, one output          */
  NZ_PIECE_T,     /* T alone (energy), one output                               */
  NZ_PIECE_V,     /* V(t, q), one output                                        */
  NZ_PIECE_Q,     /* Q(t, q, q'), k outputs                                     */
  NZ_PIECE_S,     /* S along the motion: receives the q series, one output      */
  NZ_PIECE_PHI,   /* constraint number `index` (0-based), one output            */
  NZ_PIECE_COUNT
} nz_piece;

/* A direction of differentiation with respect to the state (a second,
 * independent infinitesimal eta on top of the jets' own tangents): the
 * arguments move by eta dt (t) and eta dlevels[j][i] (slot j of q_i), and
 * the evaluator adds the eta-part of each output to dout.  This is what the
 * exact Jacobian of the motion needs (mech_jacobian.c). */
typedef struct nz_direction {
  const nz_jet *dt;
  nz_jet *const *const *dlevels;   /* one per level passed to eval */
  nz_jet *const *dout;
} nz_direction;

typedef struct nz_evaluator {
  /* Evaluate `piece` at the jets t and levels[0..nlevels-1] (levels[j][i] is
   * the series of the j-th derivative slot of q_i), adding nothing and
   * writing the outputs into out[0..] (1 jet, or k for NZ_PIECE_Q), whose
   * shape the caller set.  With dir != NULL, also the derivatives of the
   * outputs along dir into dir->dout.  Returns NZ_OK, or NZ_EFUNC with the
   * message kept by the evaluator. */
  int (*eval)(void *ctx, nz_piece piece, int index, const nz_jet *t,
              nz_jet *const *const *levels, int nlevels, nz_jet *const *out,
              const nz_direction *dir);
  void *ctx;
} nz_evaluator;

/* Constraints receive at least this many derivative slots (q, q', q'',
 * q'''), and more when they ask for them (nz_system.levels). */
#define NZ_CONSTRAINT_SLOTS 4

/* The check after a constrained solve differentiates a constraint along one
 * fixed combination of the slots above its order: weight of slot j of q_i, in
 * [0.6, 1.4], irregular so that two real dependences cannot cancel except by
 * accident (constrained.c; the recorded rows use the same, mech_graph.c). */
#include <math.h>
static inline double nz_check_slot_weight(int j, int i, int k) { return 1.0 + 0.4 * sin(1.7 + 2.385 * (j * k + i)); }

struct nz_solve_info;   /* linalg.h */

/* The constraints a series holds (the series hook below): rows[x], x < n,
 * the constraints held, in that order; with couple, the force of row x is
 * that of W = A_rows[x] + coef[x] A_couple[x] (a sliding contact's friction
 * riding on its normal force) where couple[x] >= 0. */
typedef struct nz_series_selection {
  int n;
  const int *rows, *couple;
  const double *coef;
} nz_series_selection;

typedef struct nz_system {
  int k;
  int nc;                    /* number of constraints */
  unsigned has;              /* bit (1u << piece) set when the piece exists */
  nz_evaluator ev;
  /* Derivative slots constraint r receives (q .. q^(levels[r]-1)); NULL, or
   * fewer than nlevels entries: NZ_CONSTRAINT_SLOTS. */
  const int *levels;
  int nlevels;
  /* Optional: M and h of nz_mass_bias by a faster path than the jets (the
   * recorded graphs, mech_graph.c); a return of NZ_EARG means "not here,
   * take the jets". */
  int (*mass_bias)(void *ctx, double t, const double *q, const double *qd, double *M, double *h);
  /* Optional: nz_accel's whole solve the same way (same contract). */
  int (*accel)(void *ctx, double t, const double *q, const double *qd, double rcond_min,
               double *qdd, struct nz_solve_info *info);
  /* Optional: a constraint's row at the acceleration level on doubles
   * (constrained.h's nz_constraint_row_stabilized; same contract); with
   * high != NULL also the derivative of Phi along the slots above m, slot j
   * weighted by nz_check_slot_weight and slot_sizes[j] (the check's). */
  int (*constraint_row)(void *ctx, int r, int m, double t, const double *const *state, int nstate,
                        double alpha, double beta, double *A, double *value,
                        const double *slot_sizes, double *high);
  /* Optional: the whole first-order right-hand side f = (q', q'') of a free
   * system at y = (q, q'), when the recording has its fastest form (a
   * constant M's q'' in machine code); NZ_EARG: take accel. */
  int (*free_rhs)(void *ctx, double t, const double *y, double rcond_min, double *f);
  /* Optional: 1 when every plan evaluated so far runs as machine code, 0
   * when one is still interpreted (compiling in the background), -1 when
   * machine code is off: the stepping loop asks after each step until it
   * is 1, to say which evaluator ran which steps. */
  int (*native_ready)(void *ctx);
  /* Optional: the Taylor coefficients a_0 .. a_p (k values each) of the
   * motion q(t0 + tau) from (t0, q0, qd0), for Taylor's method: the free
   * motion's when orders is NULL, else under the constraints classified by
   * orders (of order <= 2), all of them (sel NULL) or those sel holds, from
   * the start's accelerations qdd0 and multipliers lam0 (of the rows held).
   * NZ_EARG: the pieces it needs are not recorded (mech_graph.h). */
  int (*series)(void *ctx, const int *orders, const nz_series_selection *sel, double t0, const double *q0,
                const double *qd0, const double *qdd0, const double *lam0, int p, double *a);
  void *mass_bias_ctx;   /* of all six */
} nz_system;

static inline int nz_system_has(const nz_system *s, nz_piece p) { return (s->has >> p) & 1u; }

/* The slots constraint r receives, and the most any constraint receives. */
int nz_constraint_levels(const nz_system *s, int r);
int nz_constraint_levels_max(const nz_system *s);

/* Jets of a motion: slot j of q_i holds q_i^(j+c)/c!, c = 0..K (slot 0 is
 * q, slot 1 the velocity slot), and t = t0 + (t - t0).  The pieces of the
 * mechanics (this file and constrained.c) are all evaluations of these.
 *
 * A motion is a reusable workspace: start from nz_motion mo = { 0 }, call
 * nz_motion_reset before each evaluation (seed, evaluate, read), and
 * nz_motion_free once at the end.  Reset keeps the jets when the shape
 * (k, nslots, K, D) is the one they have and only zeroes and refills them;
 * it reallocates when the shape changes, and replaces t or an output jet
 * that a caller swapped for one of another shape.  One workspace serves one
 * evaluation at a time: an evaluator that re-enters the mechanics gets its
 * own (each public function of mech.c and constrained.c owns one). */
typedef struct nz_motion {
  int k, K, D, nslots;   /* nslots <= NZ_MAX_LEVELS */
  nz_jet *t;
  nz_jet ***slot;        /* nslots arrays of k jets */
  nz_jet **out;          /* k output jets */
  /* An optional direction (nz_motion_set_direction), kept allocated across
   * resets of the same shape; dir_on says whether it is in use. */
  nz_jet *dt;
  nz_jet ***dslot;
  nz_jet **dout;
  int dir_on;
} nz_motion;

/* A state direction: dt, and dq, dqd, dqdd (k values each; dqdd NULL: q''
 * fixed, as every level above it). */
typedef struct nz_state_direction {
  double dt;
  const double *dq, *dqd;
  const double *dqdd;
} nz_state_direction;

/* Shape the workspace m (zeroed, or used before) and fill it with the
 * state; the direction is switched off.  NZ_EARG for a bad shape, NZ_ENOMEM
 * (m stays freeable either way). */
int nz_motion_reset(nz_motion *m, int k, int nslots, int K, int D, double t,
                    const double *const *state, int nstate);
/* nz_motion_reset on a fresh workspace (m need not be zeroed). */
int nz_motion_init(nz_motion *m, int k, int nslots, int K, int D, double t,
                   const double *const *state, int nstate);
void nz_motion_free(nz_motion *m);
/* Make the next evaluations also differentiate along the state direction
 * (until the next reset). */
int nz_motion_set_direction(nz_motion *m, const nz_state_direction *d);
/* Seed direction d on q_i^(level) wherever it appears (docs/theory.md §3). */
void nz_motion_seed_level(nz_motion *m, int i, int d, int level);
/* Seed direction d on slot j of q_i as a whole: a partial derivative with
 * respect to that argument of the function, along the motion. */
void nz_motion_seed_slot(nz_motion *m, int i, int d, int j);
/* Evaluate a piece (constraint `index`); qd, if given, replaces slot 1.
 * Each piece receives its own slots (F, T, Q: q, q'; V, S: q; constraint r:
 * nz_constraint_levels); NZ_EARG when the motion has fewer. */
int nz_motion_eval(const nz_system *s, nz_piece p, int index, nz_motion *m, nz_jet **qd);
nz_jet **nz_jets_alloc(int k, int K, int D);

/* How constraint r's jets are seeded for one evaluation, as data, so that
 * every primitive of constrained.c is a single call of nz_constraint_eval
 * followed by reading mo->out[0] (and mo->dout[0]).  Zero means "none" for
 * every field but K and D; the seedings are applied in the order listed. */
typedef struct nz_constraint_seeding {
  int nslots;        /* slots of the workspace; 0: nz_constraint_levels(s, r) */
  int K, D;          /* order of the jets, number of tangents (D < 0: count k,
                        and one more for t_variable) */
  int t_variable;    /* t also carries tangent count k (after the ones below) */
  const nz_state_direction *dir;   /* also differentiate along it (mo->dout) */
  /* The series variable frozen: t and every slot constant in it, except
   * slot along_slot, which moves by along[i] on q_i (along NULL: by 1 on
   * q_along_index alone); along_slot outside the slots: NZ_EARG. */
  int frozen, along_slot, along_index;
  const double *along;
  /* count * k tangents: tangent (l - first) k + i on q_i^(l) wherever it
   * appears (nz_motion_seed_level), or with by_slot on slot l of q_i as a
   * whole (nz_motion_seed_slot), first <= l < first + count (count < 0:
   * every slot); a slot not in the workspace: NZ_EARG. */
  int first, count, by_slot;
  /* With sizes: tangent D - 1 along every slot j above `above`, q_i by
   * nz_check_slot_weight(j, i, k) sizes[j] (the check of constrained.c). */
  int above;
  const double *sizes;
} nz_constraint_seeding;

/* Constraint r at (t, state) in the workspace mo (reset here; the caller
 * frees it), its jets seeded as sd says: the output in mo->out[0], and its
 * derivative along sd->dir in mo->dout[0].  Statuses of nz_motion_reset
 * and nz_motion_eval. */
int nz_constraint_eval(const nz_system *s, int r, nz_motion *mo, double t, const double *const *state,
                       int nstate, const nz_constraint_seeding *sd);
void nz_jets_free(nz_jet **v, int k);
double nz_factorial(int n);

/* The forms of the equations; all give the same residual (docs/theory.md). */
typedef enum nz_form {
  NZ_FORM_GENERALIZED,  /* (3.1)  (1/n)(dF^(n)/dq^(n) - (n+1) dF/dq)            */
  NZ_FORM_LAGRANGE,     /*        d/dt dF/dq' - dF/dq                          */
  NZ_FORM_DIFFERENCE,   /* (3.2)  n dF^(n)/dq^(n) - (n+1) dF^(n-1)/dq^(n-1)      */
  NZ_FORM_EULER,        /* (3.3)  n d/dt(dF^(n-1)/dq^(n)) - dF^(n-1)/dq^(n-1)   */
  NZ_FORM_APPELL,       /* (4.2)  dR_n/dq^(n), R_n = (F^(n) - (n+1) F_0^(n))/n  */
  NZ_FORM_EXTREMAL,     /* (4.3)  dK_n/dq^(n), K_n = R_n - sum Q q^(n)          */
  NZ_FORM_WASSMUTH,     /* Wassmuth: dS^(n-2)/dq^(n), particles only, n >= 2   */
  NZ_FORM_COUNT
} nz_form;

extern const char *const nz_form_names[NZ_FORM_COUNT];

/* Terms of (3.1) for printing, each k values (any pointer may be NULL). */
typedef struct nz_terms {
  double *dFn;     /* dF^(n)/dq^(n)                         */
  double *dFq;     /* dF/dq                                 */
  double *force;   /* Q - dV/dq: the whole generalized force */
} nz_terms;

/* Residual of order n of the chosen form: r = lhs - (Q - dV/dq), k values.
 * state has nstate levels (at least 3: q, q', q''); levels the jets need
 * beyond those are taken as 0 (the result does not depend on them). */
int nz_residual(const nz_system *s, nz_form form, int n, double t, const double *const *state,
                int nstate, double *r, nz_terms *terms);

/* The operators of §5 on F:  N^m = dF^(m)/dq^(m) - 2 dF^(m-1)/dq^(m-1) and
 * E^m = d/dt(dF^(m-1)/dq^(m)) - dF^(m-1)/dq^(m-1), k values each. */
int nz_operator_N(const nz_system *s, int m, double t, const double *const *state, int nstate,
                  double *out);
int nz_operator_E(const nz_system *s, int m, double t, const double *const *state, int nstate,
                  double *out);
/* dF^(m)/dq^(m) (m >= 0; m = 0 gives dF/dq), by seeding q^(m) (§3). */
int nz_partial(const nz_system *s, int m, double t, const double *const *state, int nstate,
               double *out);
/* dF^(m-1)/dq^(m) at t0, computed by seeding q^(m) (the coefficient of the top
 * derivative of F^(m-1): docs/theory.md §3 says it is dF/dq'). */
int nz_top_coefficient(const nz_system *s, int m, double t, const double *const *state,
                       int nstate, double *out);

/* M and h of M q'' + h = 0, where h = r(q'' = 0) includes -Q + dV/dq
 * (docs/theory.md §11): M is k x k row-major. */
int nz_mass_bias(const nz_system *s, double t, const double *q, const double *qd, double *M,
                 double *h);

/* dQ_i/dq'_j (k x k, row-major): whether the forces depend on velocities. */
int nz_force_velocity_jacobian(const nz_system *s, double t, const double *q, const double *qd,
                               double *J);

/* The power of the forces Q, sum_i Q_i q'_i (0 without Q): with the
 * reactions' R_0 (§9), the rate of T + V along the motion. */
int nz_force_power(const nz_system *s, double t, const double *q, const double *qd, double *P);

/* dL/dt with q and q' held (L = F - V): the explicit time dependence (§9). */
int nz_lagrangian_time_partial(const nz_system *s, double t, const double *q, const double *qd,
                               double *dLdt);

/* T = T2 + T1 + T0 by degree in q' (§9; T is the T piece, or F without one):
 * T0, T1 at the state and d/dt (T1 + 2 T0) along the motion with q''.
 * T(t, q, s q') is evaluated at s = 0 with a tangent along s. */
int nz_kinetic_parts(const nz_system *s, double t, const double *q, const double *qd,
                     const double *qdd, double *T0, double *T1, double *rate);

/* Accelerations of an unconstrained system: M qdd = -h by Cholesky (linalg.h);
 * NZ_ESINGULAR with info filled when M is not positive definite or its
 * reciprocal condition is below rcond_min. */
struct nz_solve_info;
int nz_accel(const nz_system *s, double t, const double *q, const double *qd, double rcond_min,
             double *qdd, struct nz_solve_info *info);

/* Nielsen's residual r (n = 1) at state (q, q', q'') and its derivative dr
 * along the state direction (q'' held): the heart of the Jacobian. */
int nz_nielsen_residual_along(const nz_system *s, double t, const double *const *state,
                              const nz_state_direction *dir, double *r, double *dr);

/* Energies: T (NaN when there is no T piece), V (0 without V), F, and the
 * generalized energy H = sum q' dL/dq' - L with L = F - V. */
int nz_energy(const nz_system *s, double t, const double *q, const double *qd, double *T,
              double *V, double *F, double *H);

#endif
