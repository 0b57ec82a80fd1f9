/* contact_share.c - dependent contacts (see contact_impl.h).
 *
 * The rows a mode holds may be dependent: a block resting on its two
 * corners with friction at both has two equal slip rows, a table on four
 * legs four normal rows on three coordinates.  The motion is still unique
 * (the held rows fix the accelerations along their span, whichever forces
 * do it); the forces are not.  So:
 *
 *   the motion is solved on the carriers, an independent subset of the
 *   rows held (the bilateral ones first, then the contacts' rows from the
 *   most loaded in the LCP's solution, each kept when its part orthogonal
 *   to those before it, in the metric of K^-1, is above
 *   NZ_CONTACT_DEPENDENT of its size: an incremental Cholesky factor of
 *   their Delassus matrix), which is what Taylor's series holds too
 *   (nz_contacts_active);
 *
 *   the forces reported, and those the events watch, are one documented
 *   choice: of the contacts' forces that give the carriers' total force,
 *   the least norm (|lambda|^2 summed over the normal and friction forces
 *   of the contacts sharing the load; least squares of least norm, SVD),
 *   with where that would pull or leave a cone, at a transition, the
 *   contact set to rest without a force (it lies on the others) or its
 *   friction held at its cone (the others keep its slip at zero), and the
 *   rest shared again.  By symmetry this is m g/2 at each corner of a
 *   block at rest and m g/4 at each leg of a table;
 *
 *   where dependent contacts slide, the friction rides on their normal
 *   forces, and sharing those differently may change the motion (a box
 *   spinning while it slides on four corners: the friction's moment about
 *   the vertical depends on how its weight is shared).  Each sliding
 *   contact off the carriers is checked: a unit of normal force moved onto
 *   it from the carriers must not change q''.  Where it does, the rigid
 *   model does not determine the motion and the run stops with the reason
 *   (NZ_CONTACT_INDETERMINATE).  A block or a table translating in the
 *   plane passes: their slip rows are equal, so the friction's total is
 *   the normal forces' total times mu, whatever the shares. */
#include <math.h>
#include <string.h>
#include "mech/contact_impl.h"

/* ------------------------------------------------------------------ */
/* The carriers                                                         */

static void add_carrier(nz_contacts *c, int row, int j, int kind)
{
  int a = c->na++;
  c->rows[a] = row, c->cj[a] = j, c->ckind[a] = kind, c->couple[a] = -1, c->coef[a] = 0.0;
  if (kind == NZ_CARRY_SLIDE) {
    c->couple[a] = c->def[j].slip;
    c->coef[a] = -c->def[j].mu * nz_c_slip_sign(c->mode[j]);
  } else if (kind == NZ_CARRY_SLIDE_ISO) {
    c->couple[a] = c->def[j].speed;
    c->coef[a] = -c->def[j].mu;
  }
}

static int carry_kind(const nz_contacts *c, int j)
{
  int state = c->mode[j];
  return state == NZ_CONTACT_SLIP ? NZ_CARRY_SLIDE_ISO : nz_c_slides(state) ? NZ_CARRY_SLIDE : NZ_CARRY_PLAIN;
}

void nz_c_carriers_all(nz_contacts *c)
{
  c->na = 0;
  for (int r = 0; r < c->nb; r++) add_carrier(c, r, -1, NZ_CARRY_PLAIN);
  for (int j = 0; j < c->n; j++) {
    if (!nz_c_held(c->mode[j])) continue;
    add_carrier(c, c->def[j].gap, j, carry_kind(c, j));
    for (int i = 0; c->mode[j] == NZ_CONTACT_STICK && i < nz_c_ntan(&c->def[j]); i++)
      add_carrier(c, nz_c_tan_row(&c->def[j], i), j, NZ_CARRY_PLAIN);
  }
  c->carriers_valid = 1;
  c->dependent = 0;
  c->ndep = 0;
}

/* Row r's part orthogonal to the carriers chosen so far (dep_y, dep_L: the
 * responses and the Cholesky factor of their Delassus matrix) into l (the
 * new row of the factor) and *d (its pivot); its own R K^-1 R^T into *g. */
static void orthogonal_part(nz_contacts *c, int r, double *y, double *l, double *d, double *g)
{
  int k = c->k, m = c->ndep;
  const double *R = nz_c_row(c, r);
  nz_c_solve_bilateral(c, R, NULL, y);
  for (int a = 0; a < m; a++) {
    double s = nz_c_dot(k, nz_c_row(c, c->rows[c->nb + a]), y);
    for (int b = 0; b < a; b++) s -= c->dep_L[a * c->nc + b] * l[b];
    l[a] = s / c->dep_L[a * c->nc + a];
  }
  *g = nz_c_dot(k, R, y);
  *d = *g;
  for (int a = 0; a < m; a++) *d -= l[a] * l[a];
}

int nz_c_dependent_on_carriers(nz_contacts *c, int r)
{
  double l[c->nc + 1], d, g;
  orthogonal_part(c, r, c->scr, l, &d, &g);
  return !(g > 0.0 && d > NZ_CONTACT_DEPENDENT * g);
}

/* Try contact row r as the next carrier: kept when independent. */
static int try_carrier(nz_contacts *c, int r, int j, int kind)
{
  int m = c->ndep, k = c->k;
  double *y = c->dep_y + (size_t)m * (size_t)k, l[c->nc + 1], d, g;
  orthogonal_part(c, r, y, l, &d, &g);
  if (!(g > 0.0 && d > NZ_CONTACT_DEPENDENT * g)) return 0;
  for (int b = 0; b < m; b++) c->dep_L[m * c->nc + b] = l[b];
  c->dep_L[m * c->nc + m] = sqrt(d);
  c->ndep++;
  add_carrier(c, r, j, kind);
  return 1;
}

/* The contacts held in the order their rows are tried: most loaded first
 * in the LCP's solution (lcp), sharing before resting. */
static void carrier_order(const nz_contacts *c, int lcp, int *order)
{
  int n = c->n;
  for (int j = 0; j < n; j++) order[j] = j;
  for (int a = 1; a < n; a++)   /* insertion sort: n is a few */
    for (int b = a; b > 0; b--) {
      int x = order[b], y = order[b - 1];
      double kx = (c->share[x] ? 1e300 : 0.0) + (lcp ? c->sol_n[x] : 0.0);
      double ky = (c->share[y] ? 1e300 : 0.0) + (lcp ? c->sol_n[y] : 0.0);
      if (!(kx > ky)) break;
      order[b] = y, order[b - 1] = x;
    }
}

void nz_c_carriers(nz_contacts *c, int lcp)
{
  int n = c->n, order[n], all = 1;
  c->na = c->ndep = 0;
  for (int r = 0; r < c->nb; r++) add_carrier(c, r, -1, NZ_CARRY_PLAIN);
  carrier_order(c, lcp, order);
  for (int x = 0; x < n; x++) {                /* the normal rows */
    int j = order[x];
    if (nz_c_held(c->mode[j]) && !try_carrier(c, c->def[j].gap, j, carry_kind(c, j))) all = 0;
  }
  for (int x = 0; x < n; x++) {                /* the slip rows of those that stick */
    int j = order[x];
    if (c->mode[j] != NZ_CONTACT_STICK) continue;
    for (int i = 0; i < nz_c_ntan(&c->def[j]); i++)
      if (!try_carrier(c, nz_c_tan_row(&c->def[j], i), j, NZ_CARRY_PLAIN)) all = 0;
  }
  c->dependent = !all;
  for (int j = 0; j < n; j++)
    if (nz_c_held(c->mode[j]) && (!c->share[j] || c->atcone[j])) c->dependent = 1;
  c->carriers_valid = 1;
  c->cvalid = 0;
}

/* ------------------------------------------------------------------ */
/* The forces shared                                                    */

/* The least-norm contact forces (part, tfree, tcoup: the roles) whose
 * total is share_F, into share_N, share_T; share_ok when they give it (to
 * a relative 1e-9). */
static void share_solve(nz_contacts *c)
{
  int k = c->k, m = 0, col_j[3 * c->n], col_i[3 * c->n];
  double *C = c->share_C;
  for (int j = 0; j < c->n; j++) {
    if (!c->part[j]) continue;
    const nz_contact_def *d = &c->def[j];
    col_j[m] = j, col_i[m++] = -1;
    for (int i = 0; c->tfree[j] && i < nz_c_ntan(d); i++) col_j[m] = j, col_i[m++] = i;
  }
  c->share_ok = 0;
  memset(c->share_N, 0, (size_t)c->n * sizeof(double));
  memset(c->share_T, 0, 2 * (size_t)c->n * sizeof(double));
  if (m == 0) return;
  for (int u = 0; u < m; u++) {
    int j = col_j[u];
    const nz_contact_def *d = &c->def[j];
    const double *R = nz_c_row(c, col_i[u] < 0 ? d->gap : nz_c_tan_row(d, col_i[u]));
    for (int i = 0; i < k; i++) {
      double v = R[i];
      if (col_i[u] < 0 && !c->tfree[j])
        for (int x = 0; x < nz_c_ntan(d); x++) v += c->tcoup[2 * j + x] * nz_c_row(c, nz_c_tan_row(d, x))[i];
      C[(size_t)i * (size_t)m + (size_t)u] = v;
    }
  }
  if (nz_lstsq_in(c->ls, k, m, C, c->share_F, c->share_x, 1e-12, NULL)) return;
  double res = 0.0, size = nz_c_max_abs(k, c->share_F);
  for (int i = 0; i < k; i++) {
    double v = -c->share_F[i];
    for (int u = 0; u < m; u++) v += C[(size_t)i * (size_t)m + (size_t)u] * c->share_x[u];
    res = fmax(res, fabs(v));
  }
  if (!(res <= 1e-9 * size)) return;
  for (int u = 0; u < m; u++) {
    int j = col_j[u];
    if (col_i[u] < 0) c->share_N[j] = c->share_x[u];
    else c->share_T[2 * j + col_i[u]] = c->share_x[u];
  }
  for (int j = 0; j < c->n; j++)
    if (c->part[j] && !c->tfree[j])
      for (int x = 0; x < 2; x++) c->share_T[2 * j + x] = c->tcoup[2 * j + x] * c->share_N[j];
  c->share_ok = 1;
}

/* The roles of the mode's contacts for share_solve: those held and sharing
 * take part; a sliding one's friction rides on its normal force (-mu s, or
 * -mu u at its slip velocity vt and q'), one held at its cone likewise
 * (mu_s along dir); one that sticks freely has its friction free. */
static void mode_roles(nz_contacts *c, const double *qd)
{
  for (int j = 0; j < c->n; j++) {
    const nz_contact_def *d = &c->def[j];
    int state = c->mode[j];
    c->part[j] = nz_c_held(state) && c->share[j];
    c->tfree[j] = state == NZ_CONTACT_STICK && !c->atcone[j];
    c->tcoup[2 * j] = c->tcoup[2 * j + 1] = 0.0;
    if (state == NZ_CONTACT_STICK && c->atcone[j]) {
      c->tcoup[2 * j] = d->mu_s * c->dir[2 * j];
      c->tcoup[2 * j + 1] = d->mu_s * c->dir[2 * j + 1];
    } else if (state == NZ_CONTACT_SLIP_POS || state == NZ_CONTACT_SLIP_NEG) {
      c->tcoup[2 * j] = -d->mu * nz_c_slip_sign(state);
    } else if (state == NZ_CONTACT_SLIP) {
      double u[2];
      nz_c_slide_dir(c, j, c->vt + 2 * j, qd, u);
      c->tcoup[2 * j] = -d->mu * u[0];
      c->tcoup[2 * j + 1] = -d->mu * u[1];
    }
  }
}

int nz_c_share_forces(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                      const double *lam)
{
  int k = c->k, st = NZ_OK;
  /* the rows of every contact sharing (the carriers' are there already) */
  for (int j = 0; j < c->n && !st; j++) {
    if (!nz_c_held(c->mode[j])) continue;
    const nz_contact_def *d = &c->def[j];
    st = nz_c_row_at(c, s, d->gap, t, q, qd);
    for (int i = 0; i < nz_c_ntan(d) && !st; i++) st = nz_c_row_at(c, s, nz_c_tan_row(d, i), t, q, qd);
  }
  for (int j = 0; j < c->n && !st; j++)
    if (c->mode[j] == NZ_CONTACT_SLIP) st = nz_c_slip_velocities(c, s, j, t, q, qd, c->vt + 2 * j);
  if (st) return st;
  /* the carriers' total force from the contacts */
  memset(c->share_F, 0, (size_t)k * sizeof(double));
  for (int a = 0; a < c->na; a++)
    if (c->cj[a] >= 0)
      for (int i = 0; i < k; i++) c->share_F[i] += c->W[(size_t)a * (size_t)k + i] * lam[a];
  mode_roles(c, qd);
  share_solve(c);
  if (!c->share_ok) return NZ_OK;              /* the carriers' forces stay: admissible too */
  for (int j = 0; j < c->n; j++) {
    const nz_contact_def *d = &c->def[j];
    if (!nz_c_held(c->mode[j])) continue;
    c->clam[d->gap] = c->share_N[j];
    for (int i = 0; i < nz_c_ntan(d); i++) c->clam[nz_c_tan_row(d, i)] = c->share_T[2 * j + i];
  }
  return NZ_OK;
}

/* ------------------------------------------------------------------ */
/* The roles at a transition                                            */

/* The violations of the shared forces: a normal force below zero (kind
 * 1) or a friction outside its cone (2), relative to the largest normal
 * force, into kind[] for the worst and those within a relative 1e-9 of it
 * (twins by symmetry are set together: a box's two back corners reach
 * their cones at once), 0 elsewhere.  0 when the forces are admissible. */
static int violations(nz_contacts *c, int impact, int *kind)
{
  int n = c->n, any = 0;
  double wv = 0.0, scale = 0.0, v[n];
  for (int j = 0; j < n; j++) scale = fmax(scale, fabs(c->share_N[j]));
  if (!(scale > 0.0)) scale = 1.0;
  for (int j = 0; j < n; j++) {
    kind[j] = 0, v[j] = 0.0;
    if (!c->part[j]) continue;
    double vn = -c->share_N[j] / scale, vt = 0.0;
    if (c->tfree[j]) {
      double T = hypot(c->share_T[2 * j], c->share_T[2 * j + 1]);
      vt = (T - (impact ? c->def[j].mu : c->def[j].mu_s) * c->share_N[j]) / scale;
    }
    v[j] = fmax(vn, vt);
    if (v[j] > 1e-12) kind[j] = vn >= vt ? 1 : 2, any = 1;
    wv = fmax(wv, v[j]);
  }
  for (int j = 0; j < n; j++)
    if (kind[j] && v[j] < wv * (1.0 - 1e-9)) kind[j] = 0;
  return any;
}

/* A sliding contact off the carriers: does a unit of normal force moved
 * onto it from the carriers change q''?  The relative change. */
static double motion_change(nz_contacts *c, int j, const double *qd)
{
  int k = c->k, na = c->na, nb = c->nb, m = c->ndep;
  const nz_contact_def *d = &c->def[j];
  double l[c->nc + 1], dd, g, *y = c->scr, coefs[c->nc + 1];
  orthogonal_part(c, d->gap, y, l, &dd, &g);
  for (int a = m - 1; a >= 0; a--) {           /* J_j = sum coefs_a R_a (mod the bilateral rows) */
    double s = l[a];
    for (int b = a + 1; b < m; b++) s -= c->dep_L[b * c->nc + a] * coefs[b];
    coefs[a] = s / c->dep_L[a * c->nc + a];
  }
  double *dF = c->F, *f = c->scr + k;
  nz_c_slide_force(c, j, c->mode[j], c->vt + 2 * j, qd, f);
  const double *J = nz_c_row(c, d->gap);
  for (int i = 0; i < k; i++) dF[i] = J[i] + f[i];
  for (int a = 0; a < m; a++)
    for (int i = 0; i < k; i++) dF[i] -= coefs[a] * c->W[(size_t)(nb + a) * (size_t)k + i];
  /* its response with the carriers held: y - sum mu_b K^-1 W_b, G mu = R y */
  /* (the mode solve's X and G as scratch: room for every carrier, nc of them) */
  double *Y = c->S, *G = c->S + (size_t)k * (size_t)(c->nc + 1) + (size_t)k * (size_t)k, mu[na + 1], *dq = c->scr + 2 * k;
  nz_c_solve_bilateral(c, dF, NULL, dq);
  for (int b = 0; b < na; b++) nz_c_solve_bilateral(c, c->W + (size_t)b * (size_t)k, NULL, Y + (size_t)b * k);
  for (int a = 0; a < na; a++) {
    const double *R = nz_c_row(c, c->rows[a]);
    mu[a] = nz_c_dot(k, R, dq);
    for (int b = 0; b < na; b++) G[a * na + b] = nz_c_dot(k, R, Y + (size_t)b * k);
  }
  if (na > 0 && (nz_lu_factor(c->lu, na, G) || nz_lu_solve(c->lu, mu))) return INFINITY;
  nz_c_solve_bilateral(c, f, NULL, c->F);
  double own = nz_c_max_abs(k, c->F);
  for (int b = 0; b < na; b++)
    for (int i = 0; i < k; i++) dq[i] -= mu[b] * Y[(size_t)b * k + i];
  return own > 0.0 ? nz_c_max_abs(k, dq) / own : 0.0;
}

/* Is contact j's normal row a carrier? */
static int carried(const nz_contacts *c, int j)
{
  for (int a = 0; a < c->na; a++)
    if (c->rows[a] == c->def[j].gap) return 1;
  return 0;
}

int nz_c_settle_roles(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd)
{
  int st, solved = 0;
  /* a held row off the carriers is dependent on them (they were chosen so) */
  for (int j = 0; j < c->n; j++) {
    if (!nz_c_held(c->mode[j]) || !nz_c_slides(c->mode[j]) || carried(c, j)) continue;
    if (!solved) {           /* the carriers' columns at the state */
      c->cvalid = 0;
      if ((st = nz_contacts_accel(c, s, t, q, qd, NULL, NULL))) return st;
      solved = 1;
    }
    double change = motion_change(c, j, qd);
    if (change > 1e-8) {
      nz_c_fail_at(c, NZ_CONTACT_INDETERMINATE, NZ_EARG, j, t, q, qd);
      c->fail.value = change;
      return NZ_EARG;
    }
  }
  for (int round = 0; c->dependent && round <= 3 * c->n; round++) {
    c->cvalid = 0;
    if ((st = nz_contacts_accel(c, s, t, q, qd, NULL, NULL))) return st;
    if (!c->share_ok) break;
    int kind[c->n];
    if (!violations(c, 0, kind)) return NZ_OK;
    for (int j = 0; j < c->n; j++) {
      if (kind[j] == 1) c->share[j] = 0;          /* it lies on the others, without a force */
      if (kind[j] == 2) {                         /* its friction held at its cone; the others keep its slip */
        double T = hypot(c->share_T[2 * j], c->share_T[2 * j + 1]);
        c->atcone[j] = 1;
        c->dir[2 * j] = c->share_T[2 * j] / T;
        c->dir[2 * j + 1] = c->share_T[2 * j + 1] / T;
      }
    }
  }
  /* not settled: the carriers' own forces (the LCP's, admissible) */
  for (int j = 0; j < c->n; j++) c->share[j] = 1, c->atcone[j] = 0;
  c->dependent = 0;
  c->cvalid = 0;
  return nz_contacts_accel(c, s, t, q, qd, NULL, NULL);
}

/* ------------------------------------------------------------------ */
/* The impulses shared                                                  */

void nz_c_share_impulses(nz_contacts *c, const int *set, nz_contact_report *rep)
{
  int k = c->k;
  memset(c->share_F, 0, (size_t)k * sizeof(double));
  for (int j = 0; j < c->n; j++) {
    const nz_contact_def *d = &c->def[j];
    int sticks = c->var_at[3 * j + 1] >= 0 && !(c->sol_sig[j] > 0.0);
    /* it takes part where it ends at rest (its complement zero) */
    c->part[j] = set[j] && c->var_at[3 * j] >= 0 && c->sol_w[j] <= 1e-12 * fabs(c->base_n[j]);
    c->tfree[j] = c->part[j] && sticks;
    c->tcoup[2 * j] = c->tcoup[2 * j + 1] = 0.0;
    if (c->part[j] && !sticks && c->sol_n[j] > 0.0) {
      c->tcoup[2 * j] = c->sol_t[2 * j] / c->sol_n[j];
      c->tcoup[2 * j + 1] = c->sol_t[2 * j + 1] / c->sol_n[j];
    }
    const double *J = nz_c_row(c, d->gap);
    for (int i = 0; i < k; i++) {
      double v = J[i] * c->sol_n[j];
      for (int x = 0; x < nz_c_ntan(d); x++) v += nz_c_row(c, nz_c_tan_row(d, x))[i] * c->sol_t[2 * j + x];
      c->share_F[i] += v;
    }
  }
  /* where the least norm would pull or leave a cone, the contact leaves
   * the sharing or its friction is held at the cone, as for the forces (one
   * contact alone has its impulse: nothing to share) */
  int ok = 0, kind[c->n], parts = 0;
  for (int j = 0; j < c->n; j++) parts += c->part[j];
  for (int round = 0; parts > 1 && round <= 3 * c->n; round++) {
    share_solve(c);
    if (!c->share_ok || !violations(c, 1, kind)) {
      ok = c->share_ok;
      break;
    }
    for (int j = 0; j < c->n; j++) {
      if (kind[j] == 1) c->part[j] = 0;
      if (kind[j] == 2) {
        double T = hypot(c->share_T[2 * j], c->share_T[2 * j + 1]);
        c->tfree[j] = 0;
        c->tcoup[2 * j] = c->def[j].mu * c->share_T[2 * j] / T;
        c->tcoup[2 * j + 1] = c->def[j].mu * c->share_T[2 * j + 1] / T;
      }
    }
  }
  for (int j = 0; rep->c && j < c->n; j++) {
    nz_contact_change *ch = &rep->c[j];
    ch->share = c->part[j];
    ch->Pn = ok ? c->share_N[j] : c->sol_n[j];
    for (int x = 0; x < 2; x++) ch->Pt[x] = ok ? c->share_T[2 * j + x] : c->sol_t[2 * j + x];
  }
}
