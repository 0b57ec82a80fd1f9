/* contact.h - unilateral contacts, impacts and Coulomb friction
 * (docs/theory.md §13), beside the constrained solve they extend.
 *
 * A contact j has a gap Phi_j(t, q) >= 0 (a constraint of order 0 of the
 * system: one of its constraint functions), Newton's restitution e_j, and
 * optionally Coulomb friction with the sliding and sticking coefficients
 * mu_j <= mu_s_j: planar, along one slip function (a constraint function
 * of order 1 giving the slip velocity v_t, or of order 0 whose derivative
 * is it), or isotropic, along two slip velocities (v_1, v_2) measured on
 * orthonormal tangent directions, with the cone |F_t| <= mu lambda_n in
 * their plane.  Its rows are the constraints' own: J_j = dPhi_j/dq (the
 * normal) and D_j = dv_t/dq' (the tangents), at the acceleration level
 * J q'' + b = Phi'', D q'' + b_t = v_t'.  The system's first nb
 * constraints are bilateral (of order 0 or 1, linear in q'' at the
 * acceleration level) and always held.
 *
 * Signs: lambda_j >= 0 pushes (the force J^T lambda opens the gap); the
 * friction force is D^T lambda_t: while sliding lambda_t = -mu s lambda_n
 * with s = sign(v_t) (planar) or -mu lambda_n v_t/|v_t| (isotropic), and
 * while sticking |lambda_t| <= mu_s lambda_n.  Each contact is in one
 * state (nz_contact_state); the states of all contacts are the mode, and
 * in a mode the motion is smooth:
 *
 *   M q'' + h = A_b^T mu + sum_held W_j^T lambda_j + sum_stick D_j^T lambda_t,j
 *   A_b q'' + b_b = 0,  J_j q'' + b_j = 0 (held),  D_j q'' + b_t,j = 0 (stick)
 *
 * with W_j = J_j - mu_j s_j D_j (planar) or J_j - mu_j u_j . D_j (u_j the
 * slip velocity's direction) for a sliding contact, else J_j.  The rows
 * held may be dependent (a block resting on two corners with friction at
 * both, a table on four legs): the motion is then still unique, the forces
 * are not.  The mode's motion is solved on an independent subset of its
 * rows (the carriers: contact_share.c), and the forces reported are the
 * documented choice of least norm among the admissible ones (normal forces
 * >= 0, friction within the cones); a mode whose sliding contacts are
 * dependent in a way that makes the motion depend on that choice is
 * refused (the rigid model does not determine it).  The mode changes at
 * events (nz_contacts_event): an open contact's gap reaches 0, a held
 * one's normal force reaches 0, a sliding one's slip velocity reaches 0, a
 * sticking one's friction force reaches the cone mu_s lambda_n.  At each
 * event nz_contacts_transition applies the impact, if contacts close with
 * an approach speed, and chooses the new mode:
 *
 *   impact  Lagrange's impulse equations M (q'+ - q'-) = A_b^T P_b + J^T P_n
 *           + D^T P_t, with the bilateral constraints held at the velocity
 *           level and Newton's law per contact, v_n+ + e v_n- >= 0 _|_ P_n
 *           >= 0, friction by the cone, all touching contacts at once: an
 *           LCP at the velocity level (the simultaneous Newton law of
 *           Moreau's method)
 *   mode    the same LCP at the acceleration level for the touching
 *           contacts at rest: which stay closed (lambda_n > 0), which open
 *           (a_n > 0), which stick, which start to slide and which way
 *
 * both solved by Lemke's algorithm (core/lcp.h), the isotropic cone as a
 * pyramid turned until it is exact (contact_lcp.c).  Painleve's paradox (a
 * sliding contact whose normal effective mass J M^-1 W^T is not positive:
 * no consistent mode, or two) is detected and reported, never integrated
 * through.  Zeno: a contact whose impacts come at intervals shrinking
 * geometrically, at an approach speed below zeno_speed times the fastest it
 * has had, or whose rebound would rise less than the run resolves, has its
 * impact made plastic (e = 0) and stays closed: the accumulation of impacts
 * becomes persistent contact (the time it predicts is reported).
 *
 * Plain C: no Lua, no printing; statuses from core/status.h, the details
 * of a failure in nz_contacts_failure.  The workspace is allocated once by
 * nz_contacts_new: nothing is allocated per call. */
#ifndef NZ_CONTACT_H
#define NZ_CONTACT_H

#include "core/lcp.h"
#include "mech/mech.h"

typedef enum nz_contact_state {
  NZ_CONTACT_OPEN = 0,     /* no force                                        */
  NZ_CONTACT_CLOSED,       /* held, lambda_n >= 0, without friction           */
  NZ_CONTACT_STICK,        /* held, and its slip velocity held at 0           */
  NZ_CONTACT_SLIP_POS,     /* held, sliding with v_t > 0                      */
  NZ_CONTACT_SLIP_NEG,     /* held, sliding with v_t < 0                      */
  NZ_CONTACT_SLIP          /* held, an isotropic cone sliding against v_t     */
} nz_contact_state;

typedef struct nz_contact_def {
  int gap;                 /* its gap's constraint index (0-based), order 0   */
  int slip;                /* its slip function's constraint index, or -1     */
  int slip2;               /* an isotropic cone's second slip velocity, or -1  */
  int speed;               /* an isotropic cone's |v_t| = hypot(v_1, v_2) (the */
                           /* row its sliding friction rides on in Taylor's    */
                           /* series: nz_contacts_active), or -1               */
  double e;                /* Newton's restitution, 0 <= e <= 1               */
  double mu, mu_s;         /* Coulomb's coefficients, 0 <= mu <= mu_s         */
} nz_contact_def;

/* A contact's rows are dependent on others' when its part orthogonal to them
 * (in the metric of M^-1, the bilateral constraints held) is below this
 * fraction of its own size. */
#define NZ_CONTACT_DEPENDENT 1e-9
/* An isotropic contact sliding has its event where its slip velocity v
 * stops, v . u - NZ_CONTACT_TURN |v| with u its direction when the mode
 * began: a clean crossing where it stops along a direction within 60
 * degrees of u (v . u alone would be flat where the slip turned square to
 * u, as a block sent across a slope stops sliding downhill); and where the
 * slip turns further the event comes first, and the mode begins again
 * along the new direction. */
#define NZ_CONTACT_TURN 0.5
/* Zeno by resolution: an impact whose rebound would rise less than this
 * fraction of the run's absolute resolution of the gap (atol + rtol times
 * the size of its terms) is made plastic: the integrator cannot follow it. */
#define NZ_CONTACT_RESOLVE 1e-3

/* Zeno: an impact slower than this fraction of the contact's fastest, in a
 * geometric sequence, is made plastic. */
#define NZ_CONTACT_ZENO_SPEED 1e-6
/* Contacts that touch together: a gap within this time (relative to
 * max(1, |t|)) of zero at its approach speed is part of the same impact. */
#define NZ_CONTACT_TOUCH_TIME 1e-9
/* Rounding: a gap within this fraction of the size of its terms
 * (sum |J_i q_i|) is zero ... */
#define NZ_CONTACT_ROUND 1e-12
/* ... and a normal or slip velocity within this fraction of the motion's
 * velocity scale (the fastest the contact has had, or |J|_1 max |q'_i|) is
 * zero: an approach that slow is no impact, a slip that slow sticks. */
#define NZ_CONTACT_REST 1e-9
/* A touching contact's gap gradient |dPhi/dq| at or below this fraction of
 * the largest it has had in the run vanishes there (a multiple root). */
#define NZ_CONTACT_FLAT 1e-6

typedef struct nz_contacts_config {
  int nc;                  /* the system's constraints: nb bilateral first    */
  int nb;
  const int *orders;       /* the classification of all nc (copied)           */
  int n;                   /* contacts                                        */
  const nz_contact_def *defs;    /* n (copied)                               */
  double zeno_speed;       /* 0: NZ_CONTACT_ZENO_SPEED                        */
  double rcond_min;        /* singular saddle points below this               */
  double rtol, atol;       /* the run's tolerances (Zeno by resolution; 0: none) */
} nz_contacts_config;

typedef enum nz_contact_failure {
  NZ_CONTACT_OK = 0,
  NZ_CONTACT_SINGULAR,     /* the saddle-point matrix of the mode is singular: */
                           /* dependent contacts (or constraints), or a sliding */
                           /* contact with a zero effective mass (Painleve)     */
  NZ_CONTACT_PAINLEVE,     /* a sliding contact's normal effective mass is not  */
                           /* positive: no consistent mode (none: a_n < 0), or  */
                           /* two (a_n >= 0)                                    */
  NZ_CONTACT_LCP,          /* the LCP has no solution Lemke could find           */
  NZ_CONTACT_GRADIENT,     /* a touching contact's gap has a zero gradient       */
  NZ_CONTACT_EVAL,         /* a function of the system failed (the status)       */
  NZ_CONTACT_MASS,         /* M is singular or not positive definite (value:     */
                           /* its reciprocal condition)                          */
  NZ_CONTACT_INDETERMINATE,/* dependent contacts slide, and how their normal     */
                           /* forces are shared changes the motion (value: the  */
                           /* relative change; contact: one of them)            */
  NZ_CONTACT_CONE,         /* an isotropic cone's problem did not settle on an  */
                           /* exact solution (contact: the one)                 */
  NZ_CONTACT_SERIES        /* a series cannot start: an isotropic cone slides   */
                           /* at a zero slip velocity (contact: the one)        */
} nz_contact_failure;

/* What failed last, where. */
typedef struct nz_contact_report_failure {
  nz_contact_failure kind;
  int status;              /* the nz status returned                           */
  int contact;             /* 0-based, or -1                                   */
  double value;            /* PAINLEVE: the effective mass J M^-1 W^T (over the */
                           /* frictionless J M^-1 J^T); SINGULAR: rcond          */
  double an;               /* PAINLEVE: the normal acceleration without it      */
  double t;
  const double *q, *qd;    /* k each, owned by the contacts                    */
} nz_contact_report_failure;

/* What a transition did to contact j. */
typedef struct nz_contact_change {
  int from, to;            /* nz_contact_state                                  */
  int impact;              /* it closed with an approach speed                  */
  int zeno;                /* that impact was made plastic (Zeno)               */
  int share;               /* it takes part in the impact (an impulse, or at rest  */
                           /* touching)                                         */
  double gap;              /* Phi at the transition                             */
  double vn_before, vn_after;
  double vt_before[2], vt_after[2];   /* the slip velocities (the second: an   */
                                      /* isotropic cone's; 0 otherwise)        */
  double Pn, Pt[2];        /* its impulses (0 without impact), of least norm    */
                           /* among the admissible ones when not unique         */
  double lambda_n, lambda_t[2];   /* its forces in the new mode                 */
} nz_contact_change;

typedef struct nz_contact_report {
  int impact;              /* the velocities jumped                            */
  int changed;             /* some state changed                               */
  int zeno_contact;        /* the contact made persistent by Zeno, or -1       */
  double zeno_time;        /* the accumulation time its impacts predicted       */
  nz_lcp_info lcp;         /* of the last LCP solved                            */
  nz_contact_change *c;    /* the caller's n entries (may be NULL)              */
} nz_contact_report;

typedef struct nz_contacts nz_contacts;

/* NULL on a bad configuration (an index out of range, a gap not of order 0,
 * a slip of order > 1, an isotropic cone's slips or speed not of order 1, a
 * bilateral constraint of order > 1, e outside [0, 1], mu < 0 or mu_s <
 * mu) or no memory.  Every contact starts open. */
nz_contacts *nz_contacts_new(int k, const nz_contacts_config *cfg);
void nz_contacts_free(nz_contacts *c);      /* NULL is harmless */

int nz_contacts_count(const nz_contacts *c);
int nz_contacts_bilateral(const nz_contacts *c);
/* Two events per contact: 2j its normal one, 2j + 1 its friction one. */
int nz_contacts_nevents(const nz_contacts *c);
void nz_contacts_get_mode(const nz_contacts *c, int *state);
/* Set the mode (n states; a state the contact cannot take, friction on a
 * frictionless contact, SLIP on a planar one or SLIP_POS/NEG on an
 * isotropic one, is NZ_EARG); the history is kept.  Every held row is then
 * taken as independent, and an isotropic contact sliding from rest slides
 * along its first tangent direction. */
int nz_contacts_set_mode(nz_contacts *c, const int *state);

/* The rows the mode's motion holds, for a series built on the saddle point
 * (Taylor's method): na constraint indices rows[a] (bilateral first; an
 * independent subset of the rows held), and per row the index couple[a] of
 * a row added to its force with the coefficient coef[a] (a sliding
 * contact's friction: W = J - mu s D, or J - mu d|v_t|/dq' for an
 * isotropic cone, riding on its speed's row), or -1.  Each array holds nc
 * entries; returns na, or -1 when an isotropic contact slides at a zero
 * slip velocity in the last mode solve (its speed's series is singular
 * there: the series cannot start; the failure says which, NZ_CONTACT_SERIES). */
int nz_contacts_active(nz_contacts *c, int *rows, int *couple, double *coef);

/* q'' (k) and the multipliers lambda (nc: the bilateral ones, then per
 * contact lambda_n at its gap's index and the friction force lambda_t at
 * its slip's index (an isotropic cone's second component at slip2's); 0
 * for an open contact) in the current mode, the forces of dependent
 * contacts shared by least norm (contact_share.c).  The last
 * (t, q, q') is remembered, so the events at the state a step ended on
 * cost nothing more.  NZ_OK, NZ_ESINGULAR (the failure says why), or the
 * status of a failed evaluation. */
int nz_contacts_accel(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                      double *qdd, double *lambda);

/* Event e (0 .. 2n-1) at (t, y = (q, q')) in the current mode, falling
 * through zero where the mode ends: the gap (open), lambda_n (held);
 * +-v_t (sliding; an isotropic cone: v_t . u - NZ_CONTACT_TURN |v_t|, u
 * its direction when it began), mu_s lambda_n - |lambda_t| (sticking); 1 when the event does not
 * apply (a dependent contact resting without a force, one whose friction
 * is held at its cone by the others).  A contact left open at zero gap by a transition (a
 * bounce), or set sliding at zero slip velocity, has its value offset by
 * what it lacked to be positive there plus a rounding, so that it starts
 * above zero and falls through it only where the motion comes back. */
int nz_contacts_event(nz_contacts *c, const nz_system *s, int e, double t, const double *y, double *g);

/* At (t, q, q'): the impact and the new mode.  trigger: the event that
 * brought the run here (e as for nz_contacts_event), or -1 at the start of a
 * run.  qd holds q'- on entry and q'+ on return; q and q'+ are then put on
 * what the mode holds (the gaps of the contacts held, and any touching gap
 * below zero, at zero; their normal velocities, and the slip velocities of
 * those that stick, at zero: changes of the order of the event's
 * tolerance).  NZ_OK; NZ_EARG with the failure (PAINLEVE, LCP, GRADIENT);
 * NZ_ESINGULAR; or an evaluation's status.  The report (rep->c: n entries,
 * or NULL) says what happened. */
int nz_contacts_transition(nz_contacts *c, const nz_system *s, double t, double *q, double *qd,
                           int trigger, nz_contact_report *rep);

/* Each contact's gap, normal velocity, slip velocity (0 without friction;
 * an isotropic cone's |v_t|) and the size of its gap's terms sum |dPhi/dq_i
 * q_i| at (t, q, q'): 4n values. */
int nz_contacts_kinematics(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                           double *out);

const nz_contact_report_failure *nz_contacts_failure(const nz_contacts *c);
/* The failure is cleared by every call that succeeds. */

/* Forget the Zeno history and the velocity scales (a new run). */
void nz_contacts_reset(nz_contacts *c);

#endif
