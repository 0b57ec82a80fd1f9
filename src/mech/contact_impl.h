/* contact_impl.h - what the files of the contacts share, not a public
 * header:
 *   contact.c             the object, the frame of a state (M, h, the rows),
 *                         the mode's motion (nz_contacts_accel), the events
 *   contact_lcp.c         the bilateral saddle point K and the response of
 *                         the motion to a force; the LCPs of an impact and
 *                         of a new mode, the isotropic cone made exact
 *   contact_share.c       dependent contacts: the carriers (an independent
 *                         subset of the rows held), the forces shared by
 *                         least norm, the check that the motion is unique
 *   contact_transition.c  the transition: the touching contacts, the
 *                         impact, the new mode, its forces, the projection
 *                         and the events' offsets; Zeno */
#ifndef NZ_CONTACT_IMPL_H
#define NZ_CONTACT_IMPL_H

#include <math.h>
#include <gsl/gsl_linalg.h>
#include "core/linalg.h"
#include "mech/contact.h"

/* An isotropic cone in the LCPs: a pyramid of this many generators, turned
 * until the solution lies on one of them (contact_lcp.c). */
#define NZ_CONTACT_FACETS 8
/* The unknowns of one contact in an LCP, at most: its normal one, the
 * generators, and the cone's slack sigma. */
#define NZ_CONTACT_UNKNOWNS (NZ_CONTACT_FACETS + 2)

/* How a row of the mode's motion carries its force (the carriers). */
enum { NZ_CARRY_PLAIN, NZ_CARRY_SLIDE, NZ_CARRY_SLIDE_ISO };

struct nz_contacts {
  int k, nc, nb, n;
  int *orders;                 /* nc */
  nz_contact_def *def;         /* n */
  int *mode;                   /* n: nz_contact_state */
  /* The forces' roles in a mode with dependent rows (contact_share.c):
   * share[j] 1 when contact j shares the load (its normal force free, >= 0),
   * 0 when it rests on the others without one; atcone[j] when its friction
   * is held at its cone mu_s lambda_n along dir (the other contacts keep
   * its slip at zero).  dir (2n) is also a sliding isotropic contact's
   * direction when its mode began. */
  int *share, *atcone;
  double *dir;
  double zeno_speed, rcond_min, rtol, atol;
  /* the offsets of the events (2n): a gap left open at zero, a slip
   * started at zero slip velocity, start the new mode strictly positive */
  double *offset;
  /* Zeno: the times of the last three impacts of each contact, and its velocity scales */
  double *ht, *vmax, *vtmax, *gmax;
  int *nh;
  /* the frame at a state */
  double *M, *h;               /* k k, k */
  double *A, *b;               /* nc x k rows at the acceleration level, nc rests (q'' = 0) */
  double *phi, *vn, *vt;       /* n, n, 2n (an isotropic cone's two components) */
  double *frame_qd;            /* k: the q' of the last frame */
  double *zero;                /* k zeros: q'' for the rows */
  nz_motion mo, mo_row;        /* value and rate of a constraint; rows (jets of another shape) */
  /* the carriers: the rows of the mode's motion (na of them, bilateral
   * first), each with the contact it belongs to (-1) and how its force
   * rides (NZ_CARRY_*: couple[a], coef[a] for Taylor's series) */
  int na, carriers_valid, dependent;
  int iso_rest;                /* an isotropic carrier slid at a zero slip velocity in the last solve */
  int *rows, *couple, *cj, *ckind;
  double *coef;
  /* the mode solve's workspace */
  double *S, *W;               /* X, M's factor, G, G^-1, lambda; the forces' columns (nc x k) */
  double *spd_work;
  nz_lu *lu;
  /* the last mode solve */
  int cvalid;
  double ct, *cy, *cqdd, *clam;   /* 2k, k, nc */
  /* the carriers' independence: each carrier's response K^-1 R^T (nc x k)
   * and the Cholesky factor of their Delassus matrix (nc x nc) */
  double *dep_y, *dep_L;
  int ndep;
  /* the forces shared (contact_share.c): the roles of each contact
   * (part: it shares; tfree: its friction is free within its cone, else it
   * rides on the normal force with the coefficients tcoup (2) on its
   * tangents), the columns (k x 3n), their values, the force shared */
  int *part, *tfree;
  double *tcoup, *share_C, *share_x, *share_F, *share_N, *share_T;
  int share_ok;
  nz_lstsq_ws *ls;
  /* the bilateral saddle point, equilibrated (kscale: 1/max|M|, then 1/|A_r|) */
  gsl_matrix *K;
  gsl_vector *tau, *norm, *kwork, *kb, *kx;
  gsl_permutation *perm;
  double *kscale;              /* 1 + nb */
  double *a0;                  /* k: q'' without contact forces */
  /* the LCPs: up to NZ_CONTACT_UNKNOWNS n unknowns */
  int *var_c, *var_kind, *var_at;  /* var_at: n x 3, the normal unknown, the first generator, sigma (-1) */
  int *ngen;                   /* n: the generators of each contact's cone in the LCP */
  double *gdir;                /* n x 2 NZ_CONTACT_FACETS: each generator's direction (planar: +-1, 0) */
  double *resp, *F, *scr;      /* nv x k responses, k force, 3k scratch */
  double *L, *lq, *lz, *lw, *lwork;
  double *base_n, *base_t;     /* n, 2n: the LCP's normal and tangential rows without forces */
  /* the LCP's solution per contact: normal unknown, friction (2), the
   * cone's slack, the normal row's complement; and the change of the
   * motion it makes (k) */
  double *sol_n, *sol_t, *sol_sig, *sol_w, *sol_dx;
  double *mu_lcp;              /* n: the cone's coefficient of the LCP */
  double *turn;                /* n: the angle of an isotropic cone's first generator */
  int *touch, *sliding, *appr, *mode0, *rest, *cone, *newmode, *share0, *atcone0;   /* n each */
  double *e_eff;               /* n */
  nz_contact_report_failure fail;
  double *fq, *fqd;            /* k each */
};

static inline double nz_c_dot(int k, const double *a, const double *b)
{
  double s = 0.0;
  for (int i = 0; i < k; i++) s += a[i] * b[i];
  return s;
}

static inline double nz_c_abs_dot(int k, const double *a, const double *b)
{
  double s = 0.0;
  for (int i = 0; i < k; i++) s += fabs(a[i] * b[i]);
  return s;
}

static inline double nz_c_max_abs(int k, const double *a)
{
  double m = 0.0;
  for (int i = 0; i < k; i++) m = fmax(m, fabs(a[i]));
  return m;
}

static inline const double *nz_c_row(const nz_contacts *c, int r) { return c->A + (size_t)r * (size_t)c->k; }
static inline int nz_c_held(int state) { return state != NZ_CONTACT_OPEN; }
static inline int nz_c_slides(int state)
{
  return state == NZ_CONTACT_SLIP_POS || state == NZ_CONTACT_SLIP_NEG || state == NZ_CONTACT_SLIP;
}
static inline int nz_c_slip_sign(int state)
{
  return state == NZ_CONTACT_SLIP_POS ? 1 : state == NZ_CONTACT_SLIP_NEG ? -1 : 0;
}
static inline int nz_c_iso(const nz_contact_def *d) { return d->slip2 >= 0; }
/* The tangent rows of a contact: 0, 1 (planar) or 2 (isotropic). */
static inline int nz_c_ntan(const nz_contact_def *d) { return d->slip < 0 ? 0 : d->slip2 < 0 ? 1 : 2; }
static inline int nz_c_tan_row(const nz_contact_def *d, int i) { return i ? d->slip2 : d->slip; }

/* contact.c */
void nz_c_fail_at(nz_contacts *c, nz_contact_failure kind, int status, int contact, double t, const double *q,
                  const double *qd);
void nz_c_clear_failure(nz_contacts *c);
int nz_c_frame(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd);
int nz_c_row_at(nz_contacts *c, const nz_system *s, int r, double t, const double *q, const double *qd);
/* The slip velocities of contact j at (t, q, q') into vt (1 or 2). */
int nz_c_slip_velocities(nz_contacts *c, const nz_system *s, int j, double t, const double *q, const double *qd,
                         double *vt);
/* The friction a sliding contact's normal force carries, per unit of it,
 * into f (k): -mu s D (planar), or -mu u . D (isotropic), u the direction
 * of its slip velocity vt (2), turned back when it points against dir (the
 * direction when the mode began: past the stop the motion continues with
 * the friction it had, so that the event's crossing is smooth), dir itself
 * where the slip velocity is zero to the rest tolerance at q'. */
void nz_c_slide_force(const nz_contacts *c, int j, int state, const double *vt, const double *qd, double *f);
/* The direction u (2) of that friction's -mu u for an isotropic contact. */
void nz_c_slide_dir(const nz_contacts *c, int j, const double *vt, const double *qd, double *u);
/* Below this a velocity v of row r at q' is zero (contact.c). */
double nz_c_rest_tol(const nz_contacts *c, int r, const double *qd, double vmax, double v);

/* contact_lcp.c */
int nz_c_factor_bilateral(nz_contacts *c, double t, const double *q, const double *qd);
void nz_c_solve_bilateral(nz_contacts *c, const double *f, const double *g, double *x);
void nz_c_free_accel(nz_contacts *c);
double nz_c_effective_mass(nz_contacts *c, int j, int state);
int nz_c_diagnose_singular(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                           double rcond);
/* The LCP of an impact (velocity: base_n, base_t the velocities without
 * impulses) or of a new mode (acceleration), over the contacts in set[],
 * each with its cone where cone[j]; mu_lcp[j] the cone's coefficient.  The
 * isotropic cones are made exact (their pyramids turned until the
 * solution is the cone's).  NZ_OK with the solution in lz (var_at maps it);
 * else the failure is set. */
int nz_c_lcp(nz_contacts *c, const int *set, const int *cone, nz_contact_report *rep, int trigger, double t,
             const double *q, const double *qd);
/* Contact j's normal unknown, and its friction (planar: T[0]; isotropic:
 * T[0], T[1]) and cone's slack in the last LCP's solution. */
double nz_c_lcp_normal(const nz_contacts *c, int j);
double nz_c_lcp_friction(const nz_contacts *c, int j, double *T);
/* The change of q' (impact) or q'' (mode) the last LCP's solution makes. */
void nz_c_lcp_motion(const nz_contacts *c, double *dx);

/* contact_share.c */
/* The carriers for the mode (the contacts' states and share): the rows
 * held, most loaded first, kept where independent.  K must be factored at
 * the state and the frame be there; the LCP's solution ranks them when
 * lcp is set. */
void nz_c_carriers(nz_contacts *c, int lcp);
/* The default carriers of the mode: every row held (nz_contacts_set_mode). */
void nz_c_carriers_all(nz_contacts *c);
/* Is contact j's row (its normal one, or tangent i >= 0) dependent on the
 * carriers? */
int nz_c_dependent_on_carriers(nz_contacts *c, int r);
/* The forces of the mode solved at (t, q, q') (the carriers' multipliers
 * lam) shared among the held contacts by least norm: c->clam rewritten,
 * share_ok set when the sharing gives the carriers' force (else clam keeps
 * the carriers' forces).  NZ_OK or an evaluation's status. */
int nz_c_share_forces(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                      const double *lam);
/* At a transition: the roles that make the shared forces admissible
 * (normal forces >= 0, friction within the cones), and the check that the
 * motion does not depend on them.  The mode solve must have been done. */
int nz_c_settle_roles(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd);
/* The impulses of an impact shared by least norm among the contacts that
 * take part (set[]: those that end at rest with their complement zero),
 * from the LCP's solution, into the report's Pn, Pt and share (the LCP's
 * own where the least-norm ones are not admissible). */
void nz_c_share_impulses(nz_contacts *c, const int *set, nz_contact_report *rep);

#endif
