/* contact_lcp.c - the contacts' linear algebra at a transition (see
 * contact_impl.h): the bilateral saddle point K = [M -A_b^T; A_b 0],
 * factored once per transition (q does not change in one: an impact
 * changes q' only), whose solves give the response of the motion to a
 * force and the accelerations without contact forces; and the LCPs of an
 * impact and of a new mode (docs/theory.md §13), by Lemke (core/lcp.h).
 *
 * The isotropic cone |F_t| <= mu lambda_n is a second-order cone, not a
 * polyhedron, and Lemke takes polyhedra: it enters each LCP as a pyramid of
 * NZ_CONTACT_FACETS generators d_g on the circle (Stewart and Trinkle's
 * formulation: F_t = sum beta_g d_g, d_g . v_t + sigma >= 0 _|_ beta_g,
 * mu lambda_n - sum beta_g >= 0 _|_ sigma), then made exact: where a cone
 * is saturated (it slides) the direction u of its slip is solved for by
 * Newton's method on the angles, F_t = -mu lambda_n u with v_t = alpha u,
 * alpha >= 0 (the other contacts' roles as the pyramid chose them), and the
 * solution is checked against the cones themselves; where the check fails
 * (a sticking force the pyramid cut off, a slip the pyramid pointed wrong)
 * each pyramid is turned until a generator lies along its contact's force
 * and the LCP solved again.  A sticking force inside the pyramid is inside
 * the cone: exact as it is.  (MuJoCo and Chrono solve the cone as a convex
 * problem by iterations; here the pyramid's LCP gives the combinatorics,
 * which contacts open, stick or slide, and Newton the direction.) */
#include <float.h>
#include <math.h>
#include <string.h>
#include "core/lcp.h"
#include "mech/contact_impl.h"

/* ------------------------------------------------------------------ */
/* The bilateral saddle point and the response to a force               */

/* K = [M -A_b^T; A_b 0], equilibrated, by pivoted QR; its condition.  M
 * itself first (Cholesky with its condition: a singular M is said as such,
 * not as dependent constraints). */
int nz_c_factor_bilateral(nz_contacts *c, double t, const double *q, const double *qd)
{
  int k = c->k, nb = c->nb;
  nz_solve_info info;
  double *Mw = c->S, *x = Mw + (size_t)k * (size_t)k;
  memcpy(Mw, c->M, (size_t)k * (size_t)k * sizeof(double));
  if (nz_solve_spd_in(k, Mw, c->h, x, c->rcond_min, &info, c->spd_work)) {
    nz_c_fail_at(c, NZ_CONTACT_MASS, NZ_ESINGULAR, -1, t, q, qd);
    c->fail.value = info.rcond;
    return NZ_ESINGULAR;
  }
  double mmax = nz_c_max_abs(k * k, c->M);
  if (!(mmax > 0.0)) mmax = 1.0;
  c->kscale[0] = 1.0 / mmax;
  gsl_matrix *K = c->K;
  gsl_matrix_set_zero(K);
  for (int i = 0; i < k; i++)
    for (int l = 0; l < k; l++) gsl_matrix_set(K, (size_t)i, (size_t)l, c->M[(size_t)i * k + l] / mmax);
  for (int r = 0; r < nb; r++) {
    const double *A = nz_c_row(c, r);
    double am = nz_c_max_abs(k, A), sig = am > 0.0 ? 1.0 / am : 1.0;
    c->kscale[1 + r] = sig;
    for (int i = 0; i < k; i++) {
      gsl_matrix_set(K, (size_t)i, (size_t)(k + r), -A[i] * sig);
      gsl_matrix_set(K, (size_t)(k + r), (size_t)i, A[i] * sig);
    }
  }
  int signum;
  double rcond = 0.0;
  if (gsl_linalg_QRPT_decomp(K, c->tau, c->perm, &signum, c->norm) != GSL_SUCCESS ||
      gsl_linalg_QRPT_rcond(K, &rcond, c->kwork) != GSL_SUCCESS || !(rcond >= c->rcond_min)) {
    nz_c_fail_at(c, NZ_CONTACT_SINGULAR, NZ_ESINGULAR, -1, t, q, qd);
    c->fail.value = rcond;
    return NZ_ESINGULAR;
  }
  return NZ_OK;
}

/* x (k): the first k entries of K^-1 [f; g] for a force f (k) and the
 * bilateral rows' right-hand side g (nb, NULL: 0). */
void nz_c_solve_bilateral(nz_contacts *c, const double *f, const double *g, double *x)
{
  int k = c->k, nb = c->nb;
  for (int i = 0; i < k; i++) gsl_vector_set(c->kb, (size_t)i, f[i] * c->kscale[0]);
  for (int r = 0; r < nb; r++) gsl_vector_set(c->kb, (size_t)(k + r), g ? g[r] * c->kscale[1 + r] : 0.0);
  gsl_linalg_QRPT_solve(c->K, c->tau, c->perm, c->kb, c->kx);
  for (int i = 0; i < k; i++) x[i] = gsl_vector_get(c->kx, (size_t)i);
}

/* a0: the accelerations under the bilateral constraints alone. */
void nz_c_free_accel(nz_contacts *c)
{
  int k = c->k;
  double *f = c->scr, *g = c->scr + k;   /* (nb <= the scratch's 2k: a bilateral row per coordinate at most) */
  for (int i = 0; i < k; i++) f[i] = -c->h[i];
  for (int r = 0; r < c->nb; r++) g[r] = -c->b[r];
  nz_c_solve_bilateral(c, f, g, c->a0);
}

/* A sliding contact's normal effective mass J M^-1 W^T relative to the
 * frictionless J M^-1 J^T (both with the bilateral constraints held), from
 * the factored K; state: how it slides (its slip velocity in c->vt). */
double nz_c_effective_mass(nz_contacts *c, int j, int state)
{
  int k = c->k;
  const double *J = nz_c_row(c, c->def[j].gap);
  double *W = c->F, *rw = c->scr, *rj = c->scr + k;
  nz_c_slide_force(c, j, state, c->vt + 2 * j, c->frame_qd, W);
  for (int i = 0; i < k; i++) W[i] += J[i];
  nz_c_solve_bilateral(c, W, NULL, rw);
  nz_c_solve_bilateral(c, J, NULL, rj);
  double ref = nz_c_dot(k, J, rj);
  return ref > 0.0 ? nz_c_dot(k, J, rw) / ref : nz_c_dot(k, J, rw);
}

/* The mode's matrix was singular: Painleve's paradox when a sliding contact
 * has lost its effective mass, else dependent contacts or constraints. */
int nz_c_diagnose_singular(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd,
                           double rcond)
{
  nz_c_fail_at(c, NZ_CONTACT_SINGULAR, NZ_ESINGULAR, -1, t, q, qd);
  c->fail.value = rcond;
  if (nz_c_frame(c, s, t, q, qd) || nz_c_factor_bilateral(c, t, q, qd)) {
    nz_c_fail_at(c, NZ_CONTACT_SINGULAR, NZ_ESINGULAR, -1, t, q, qd);
    c->fail.value = rcond;
    return NZ_ESINGULAR;
  }
  nz_c_free_accel(c);
  int worst = -1;
  double wm = INFINITY;
  for (int j = 0; j < c->n; j++) {
    if (!nz_c_slides(c->mode[j])) continue;
    double m = nz_c_effective_mass(c, j, c->mode[j]);
    if (m < wm) wm = m, worst = j;
  }
  if (worst >= 0 && wm <= 1e-6) {
    nz_c_fail_at(c, NZ_CONTACT_PAINLEVE, NZ_ESINGULAR, worst, t, q, qd);
    c->fail.value = wm;
    c->fail.an = nz_c_dot(c->k, nz_c_row(c, c->def[worst].gap), c->a0) + c->b[c->def[worst].gap];
    return NZ_ESINGULAR;
  }
  nz_c_fail_at(c, NZ_CONTACT_SINGULAR, NZ_ESINGULAR, -1, t, q, qd);
  c->fail.value = rcond;
  return NZ_ESINGULAR;
}

/* ------------------------------------------------------------------ */
/* The LCP                                                              */

enum { VAR_N, VAR_GEN, VAR_SIGMA };

/* The generators of contact j's cone: +-1 on its slip (planar), or
 * NZ_CONTACT_FACETS directions on the circle from the angle turn[j]. */
static void generators(nz_contacts *c, int j)
{
  double *g = c->gdir + (size_t)j * 2 * NZ_CONTACT_FACETS;
  if (!nz_c_iso(&c->def[j])) {
    c->ngen[j] = 2;
    g[0] = 1.0, g[1] = 0.0, g[2] = -1.0, g[3] = 0.0;
    return;
  }
  c->ngen[j] = NZ_CONTACT_FACETS;
  for (int i = 0; i < NZ_CONTACT_FACETS; i++) {
    double a = c->turn[j] + 2.0 * M_PI * i / NZ_CONTACT_FACETS;
    g[2 * i] = cos(a), g[2 * i + 1] = sin(a);
  }
}

static const double *gen_dir(const nz_contacts *c, int j, int i)
{
  return c->gdir + (size_t)j * 2 * NZ_CONTACT_FACETS + 2 * (size_t)i;
}

/* The unknowns for the contacts in set[]: a normal one each, and where
 * cone[j] the cone's generators and sigma.  Returns their number. */
static int lcp_unknowns(nz_contacts *c, const int *set, const int *cone)
{
  int nv = 0;
  for (int j = 0; j < c->n; j++) {
    int *at = c->var_at + 3 * j;
    at[0] = at[1] = at[2] = -1;
    if (!set[j]) continue;
    c->var_c[nv] = j, c->var_kind[nv] = VAR_N, at[0] = nv++;
    if (c->def[j].slip < 0 || !cone[j]) continue;
    generators(c, j);
    at[1] = nv;
    for (int i = 0; i < c->ngen[j]; i++) c->var_c[nv] = j, c->var_kind[nv] = VAR_GEN, nv++;
    c->var_c[nv] = j, c->var_kind[nv] = VAR_SIGMA, at[2] = nv++;
  }
  return nv;
}

/* The force of a unit of tangential force T (1 or 2 components) of contact
 * j into f. */
static void tangent_force(const nz_contacts *c, int j, const double *T, double *f)
{
  const nz_contact_def *d = &c->def[j];
  const double *D = nz_c_row(c, d->slip), *D2 = nz_c_iso(d) ? nz_c_row(c, d->slip2) : NULL;
  for (int i = 0; i < c->k; i++) f[i] = T[0] * D[i] + (D2 ? T[1] * D2[i] : 0.0);
}

/* The normal force's column of contact j: J, with the friction of a
 * sliding one (sliding[j]: +-1 planar, 2 isotropic). */
static void normal_force(nz_contacts *c, int j, double *f)
{
  const double *J = nz_c_row(c, c->def[j].gap);
  int sg = c->sliding[j];
  if (sg) nz_c_slide_force(c, j, sg == 2 ? NZ_CONTACT_SLIP : sg > 0 ? NZ_CONTACT_SLIP_POS : NZ_CONTACT_SLIP_NEG,
                           c->vt + 2 * j, c->frame_qd, f);
  else memset(f, 0, (size_t)c->k * sizeof(double));
  for (int i = 0; i < c->k; i++) f[i] += J[i];
}

/* Each unknown's response of q'' (or q') to a unit of it: K^-1 of its
 * force. */
static void lcp_responses(nz_contacts *c, int nv)
{
  int k = c->k;
  for (int v = 0; v < nv; v++) {
    int j = c->var_c[v], kind = c->var_kind[v];
    double *r = c->resp + (size_t)v * (size_t)k;
    if (kind == VAR_SIGMA) {
      memset(r, 0, (size_t)k * sizeof(double));
      continue;
    }
    if (kind == VAR_N) normal_force(c, j, c->F);
    else tangent_force(c, j, gen_dir(c, j, v - c->var_at[3 * j + 1]), c->F);
    nz_c_solve_bilateral(c, c->F, NULL, r);
  }
}

/* The tangential rows of contact j applied to x: D . x (1 or 2). */
static void tangent_of(const nz_contacts *c, int j, const double *x, double *out)
{
  const nz_contact_def *d = &c->def[j];
  out[0] = nz_c_dot(c->k, nz_c_row(c, d->slip), x);
  out[1] = nz_c_iso(d) ? nz_c_dot(c->k, nz_c_row(c, d->slip2), x) : 0.0;
}

/* The LCP's matrix and vector: row v is the complement of unknown v (a
 * normal row, a generator's d_g . v_t + sigma, the cone's mu lambda_n -
 * sum beta_g). */
static void lcp_assemble(nz_contacts *c, int nv)
{
  int k = c->k;
  for (int v = 0; v < nv; v++) {
    int j = c->var_c[v], kind = c->var_kind[v], *at = c->var_at + 3 * j;
    double *Lr = c->L + (size_t)v * (size_t)nv;
    memset(Lr, 0, (size_t)nv * sizeof(double));
    if (kind == VAR_N) {
      const double *J = nz_c_row(c, c->def[j].gap);
      c->lq[v] = c->base_n[j];
      for (int u = 0; u < nv; u++) Lr[u] = nz_c_dot(k, J, c->resp + (size_t)u * k);
    } else if (kind == VAR_GEN) {
      const double *g = gen_dir(c, j, v - at[1]), *bt = c->base_t + 2 * j;
      c->lq[v] = g[0] * bt[0] + g[1] * bt[1];
      for (int u = 0; u < nv; u++) {
        double tv[2];
        tangent_of(c, j, c->resp + (size_t)u * k, tv);
        Lr[u] = g[0] * tv[0] + g[1] * tv[1];
      }
      Lr[at[2]] += 1.0;
    } else {
      c->lq[v] = 0.0;
      Lr[at[0]] = c->mu_lcp[j];
      for (int i = 0; i < c->ngen[j]; i++) Lr[at[1] + i] = -1.0;
    }
  }
}

/* The solution per contact (sol_*) and the motion's change from lz.  A
 * cone's slack sigma (a slip's size) below NZ_CONTACT_ROUND of the
 * problem's largest row is zero: Lemke leaves a basic variable at the
 * rounding of its pivots, and a slip of that size is a contact that sticks
 * (a box held on four corners, one of them at its cone). */
static void lcp_extract(nz_contacts *c, int nv)
{
  int k = c->k;
  double scale = nz_c_max_abs(nv, c->lq);
  memset(c->sol_dx, 0, (size_t)k * sizeof(double));
  for (int v = 0; v < nv; v++)
    for (int i = 0; i < k; i++) c->sol_dx[i] += c->resp[(size_t)v * k + i] * c->lz[v];
  for (int j = 0; j < c->n; j++) {
    const int *at = c->var_at + 3 * j;
    c->sol_n[j] = at[0] >= 0 ? c->lz[at[0]] : 0.0;
    c->sol_w[j] = at[0] >= 0 ? c->lw[at[0]] : 0.0;
    c->sol_t[2 * j] = c->sol_t[2 * j + 1] = c->sol_sig[j] = 0.0;
    if (at[1] < 0) continue;
    for (int i = 0; i < c->ngen[j]; i++) {
      const double *g = gen_dir(c, j, i);
      c->sol_t[2 * j] += c->lz[at[1] + i] * g[0];
      c->sol_t[2 * j + 1] += c->lz[at[1] + i] * g[1];
    }
    c->sol_sig[j] = c->lz[at[2]] > NZ_CONTACT_ROUND * scale ? c->lz[at[2]] : 0.0;
  }
}

double nz_c_lcp_normal(const nz_contacts *c, int j) { return c->sol_n[j]; }

double nz_c_lcp_friction(const nz_contacts *c, int j, double *T)
{
  T[0] = c->sol_t[2 * j], T[1] = c->sol_t[2 * j + 1];
  return c->sol_sig[j];
}

void nz_c_lcp_motion(const nz_contacts *c, double *dx) { memcpy(dx, c->sol_dx, (size_t)c->k * sizeof(double)); }

/* ------------------------------------------------------------------ */
/* The isotropic cone made exact                                        */

/* The roles the pyramid's solution gave (fixed for Newton's iterations):
 * which contacts push, which stick, and the friction per unit of normal
 * force of those that slide (ride[2j]; the saturated isotropic ones'
 * replaced by -mu u(th)). */
typedef struct lcp_roles {
  int *push, *stick, *sat, ns;
  double *ride;
} lcp_roles;

/* With the saturated isotropic cones' slip directions at the angles th (one
 * per entry of sat): the normal forces of the contacts pushing and the
 * friction of those that stick solved so that their rows stay at zero
 * (least squares: dependent rows are fine), the saturated ones' friction
 * -mu lambda_n u.  Fills sol_* and sol_dx; the residuals of the saturated
 * ones' directions (v_t along u: the component across it) into r, and
 * their rates along u into alpha. */
static int role_solve(nz_contacts *c, const lcp_roles *ro, const double *th, double *r, double *alpha)
{
  int k = c->k, nu = 0;
  int uj[3 * c->n], ui[3 * c->n];           /* each unknown's contact, and what it is: -1 normal, 0/1 tangent */
  double *Y = c->share_C, *E = c->L, *rhs = c->lq, *x = c->lz;
  for (int s = 0; s < ro->ns; s++) {
    int j = ro->sat[s];
    ro->ride[2 * j] = -c->mu_lcp[j] * cos(th[s]);
    ro->ride[2 * j + 1] = -c->mu_lcp[j] * sin(th[s]);
  }
  for (int j = 0; j < c->n; j++) {
    if (!ro->push[j]) continue;
    double *y = Y + (size_t)nu * (size_t)k, *f = c->scr;
    normal_force(c, j, c->F);
    if (c->var_at[3 * j + 1] >= 0 && !ro->stick[j]) {
      tangent_force(c, j, ro->ride + 2 * j, f);
      for (int i = 0; i < k; i++) c->F[i] += f[i];
    }
    nz_c_solve_bilateral(c, c->F, NULL, y);
    uj[nu] = j, ui[nu] = -1, nu++;
    for (int i = 0; ro->stick[j] && i < nz_c_ntan(&c->def[j]); i++) {
      double T[2] = { i == 0, i == 1 };
      tangent_force(c, j, T, c->F);
      nz_c_solve_bilateral(c, c->F, NULL, Y + (size_t)nu * (size_t)k);
      uj[nu] = j, ui[nu] = i, nu++;
    }
  }
  /* the equations: each unknown's row kept at zero (its own row: the
   * normal, or the tangent) */
  for (int e = 0; e < nu; e++) {
    int j = uj[e];
    const double *R = ui[e] < 0 ? nz_c_row(c, c->def[j].gap) : nz_c_row(c, nz_c_tan_row(&c->def[j], ui[e]));
    rhs[e] = -(ui[e] < 0 ? c->base_n[j] : c->base_t[2 * j + ui[e]]);
    for (int u = 0; u < nu; u++) E[(size_t)e * (size_t)nu + (size_t)u] = nz_c_dot(k, R, Y + (size_t)u * k);
  }
  if (nu > 0 && nz_lstsq_in(c->ls, nu, nu, E, rhs, x, 1e-13, NULL)) return NZ_ERANGE;
  memset(c->sol_dx, 0, (size_t)k * sizeof(double));
  for (int u = 0; u < nu; u++)
    for (int i = 0; i < k; i++) c->sol_dx[i] += Y[(size_t)u * k + i] * x[u];
  for (int j = 0; j < c->n; j++) c->sol_n[j] = 0.0;
  for (int u = 0; u < nu; u++) {
    int j = uj[u];
    if (ui[u] < 0) c->sol_n[j] = x[u];
    else c->sol_t[2 * j + ui[u]] = x[u];
  }
  for (int j = 0; j < c->n; j++)
    if (ro->push[j] && c->var_at[3 * j + 1] >= 0 && !ro->stick[j]) {
      c->sol_t[2 * j] = ro->ride[2 * j] * c->sol_n[j];
      c->sol_t[2 * j + 1] = ro->ride[2 * j + 1] * c->sol_n[j];
    }
  for (int s = 0; s < ro->ns; s++) {
    int j = ro->sat[s];
    double w[2];
    tangent_of(c, j, c->sol_dx, w);
    w[0] += c->base_t[2 * j], w[1] += c->base_t[2 * j + 1];
    r[s] = -w[0] * sin(th[s]) + w[1] * cos(th[s]);
    alpha[s] = c->sol_sig[j] = w[0] * cos(th[s]) + w[1] * sin(th[s]);
  }
  return NZ_OK;
}

/* Is the solution in sol_* the cones' and Newton's: normal forces >= 0 with
 * nonnegative complements, sticking forces inside the cones, saturated ones
 * sliding along their friction (alpha > 0)? */
static int solution_holds(nz_contacts *c, const lcp_roles *ro, const double *alpha)
{
  double scale = 0.0;
  for (int j = 0; j < c->n; j++) scale = fmax(scale, fabs(c->sol_n[j]));
  for (int s = 0; s < ro->ns; s++)
    if (!(alpha[s] > 0.0)) return 0;
  for (int j = 0; j < c->n; j++) {
    if (c->var_at[3 * j] < 0) continue;
    double w = c->base_n[j] + nz_c_dot(c->k, nz_c_row(c, c->def[j].gap), c->sol_dx);
    if (c->sol_n[j] < -1e-10 * scale || (!ro->push[j] && w < -1e-10 * fmax(fabs(c->base_n[j]), 1e-300))) return 0;
    if (ro->push[j] && ro->stick[j] &&
        hypot(c->sol_t[2 * j], c->sol_t[2 * j + 1]) > c->mu_lcp[j] * c->sol_n[j] * (1.0 + 1e-12))
      return 0;
  }
  return 1;
}

/* Newton's method on the saturated isotropic cones' slip angles (from the
 * pyramid's solution): th such that each one's slip v_t is along its u. */
static int newton_angles(nz_contacts *c, const lcp_roles *ro, double *th, double *alpha)
{
  int ns = ro->ns;
  double r[ns], r1[ns], Jn[ns * ns], dth[ns], t1[ns];
  for (int it = 0; it < 40; it++) {
    if (role_solve(c, ro, th, r, alpha)) return 0;
    double step = 0.0;
    for (int a = 0; a < ns; a++) {
      memcpy(t1, th, sizeof t1);
      t1[a] += 1e-7;
      if (role_solve(c, ro, t1, r1, alpha)) return 0;
      for (int b = 0; b < ns; b++) Jn[b * ns + a] = (r1[b] - r[b]) / 1e-7;
    }
    for (int a = 0; a < ns; a++) r[a] = -r[a];
    if (nz_lstsq_in(c->ls, ns, ns, Jn, r, dth, 1e-13, NULL)) return 0;
    for (int a = 0; a < ns; a++) {
      th[a] += fmax(-0.5, fmin(0.5, dth[a]));
      step = fmax(step, fabs(dth[a]));
    }
    if (step <= 1e-14) break;
  }
  return role_solve(c, ro, th, r, alpha) == NZ_OK;
}

/* The pyramids' solution made the cones': Newton on the saturated ones'
 * directions, then the check.  0 when it holds. */
static int exact_cones(nz_contacts *c)
{
  int n = c->n, push[n], stick[n], sat[n], ns = 0;
  double th[n], alpha[n], ride[2 * n];
  for (int j = 0; j < n; j++) {
    int cone = c->var_at[3 * j + 1] >= 0;
    push[j] = c->sol_n[j] > 0.0;
    stick[j] = push[j] && cone && !(c->sol_sig[j] > 0.0);
    ride[2 * j] = push[j] ? c->sol_t[2 * j] / c->sol_n[j] : 0.0;
    ride[2 * j + 1] = push[j] ? c->sol_t[2 * j + 1] / c->sol_n[j] : 0.0;
    if (nz_c_iso(&c->def[j]) && push[j] && cone && !stick[j]) {
      sat[ns] = j;
      th[ns++] = atan2(-c->sol_t[2 * j + 1], -c->sol_t[2 * j]);   /* the slip opposes the friction */
    }
  }
  if (ns == 0) return 0;
  lcp_roles ro = { push, stick, sat, ns, ride };
  if (!newton_angles(c, &ro, th, alpha)) return 1;
  return !solution_holds(c, &ro, alpha);
}

/* Each isotropic cone's pyramid turned so that a generator lies along the
 * friction of the last solution (a sticking force the pyramid cut off fits
 * it then; a slip it pointed wrong is opposed by a generator). */
static void turn_pyramids(nz_contacts *c)
{
  for (int j = 0; j < c->n; j++)
    if (nz_c_iso(&c->def[j]) && hypot(c->sol_t[2 * j], c->sol_t[2 * j + 1]) > 0.0)
      c->turn[j] = atan2(c->sol_t[2 * j + 1], c->sol_t[2 * j]);
}

int nz_c_lcp(nz_contacts *c, const int *set, const int *cone, nz_contact_report *rep, int trigger, double t,
             const double *q, const double *qd)
{
  for (int round = 0; round < 4; round++) {
    int nv = lcp_unknowns(c, set, cone);
    lcp_responses(c, nv);
    lcp_assemble(c, nv);
    nz_lcp_info info;
    int st = nz_lcp_solve(nv, c->L, c->lq, c->lz, c->lw, c->lwork, &info);
    if (rep) rep->lcp = info;
    if (st) {
      nz_c_fail_at(c, NZ_CONTACT_LCP, st, trigger, t, q, qd);
      return st;
    }
    lcp_extract(c, nv);
    if (!exact_cones(c)) return NZ_OK;
    turn_pyramids(c);
  }
  int j = 0;
  for (int x = 0; x < c->n; x++)
    if (nz_c_iso(&c->def[x]) && c->var_at[3 * x + 1] >= 0) j = x;
  nz_c_fail_at(c, NZ_CONTACT_CONE, NZ_EARG, j, t, q, qd);
  return NZ_EARG;
}
