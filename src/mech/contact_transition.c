/* contact_transition.c - what happens at a contact event (see contact.h,
 * docs/theory.md §13), in its steps:
 *
 *   touching  which contacts take part (held, or a gap at zero to the
 *             event's tolerance at their approach speed)
 *   impact    Newton's law for all touching contacts at once, an LCP at the
 *             velocity level (contact_lcp.c), Zeno; the impulses shared
 *   mode      the LCP at the acceleration level for the touching contacts at
 *             rest: which push, open, stick, slide; those resting on the
 *             others without a force (dependent: contact_share.c)
 *   forces    the carriers of the new mode and the roles that make its
 *             shared forces admissible; an event that would change nothing
 *             changes what it was about
 *   state     q and q' put on what the mode holds (one Newton step each)
 *   offsets   the events of a gap left at zero and of a slip started at
 *             zero start strictly positive; the report. */
#include <float.h>
#include <math.h>
#include <string.h>
#include "mech/contact_impl.h"

/* ------------------------------------------------------------------ */
/* Zeno                                                                 */

/* Contact j closes at t with approach speed v.  Its last three impacts and
 * this one give two ratios of intervals; shrinking alike (within 5 %) and
 * slow against its fastest impact, the sequence would accumulate at t + dt
 * r / (1 - r): the impact is made plastic. */
static int zeno(nz_contacts *c, int j, double t, double v, double *tinf)
{
  double *ht = c->ht + 3 * j;
  int n = c->nh[j], hit = 0;
  if (n >= 3) {
    double d1 = ht[1] - ht[0], d2 = ht[2] - ht[1], d3 = t - ht[2];
    double r1 = d1 > 0.0 ? d2 / d1 : 2.0, r2 = d2 > 0.0 ? d3 / d2 : 2.0;
    if (r1 > 0.0 && r1 < 1.0 && r2 > 0.0 && r2 < 1.0 && fabs(r2 - r1) <= 0.05 * r2 && v <= c->zeno_speed * c->vmax[j]) {
      hit = 1;
      *tinf = t + d3 * r2 / (1.0 - r2);
    }
  }
  if (n == 3) {
    ht[0] = ht[1], ht[1] = ht[2];
    n = 2;
  }
  ht[n] = t;
  c->nh[j] = n + 1;
  return hit;
}

/* Zeno by resolution: contact j closing at speed v would rebound at e v
 * against its free normal acceleration a (a0), rising (e v)^2 / (2 |a|):
 * below NZ_CONTACT_RESOLVE of the run's resolution of its gap the
 * integrator cannot follow the flight (a multistep method restarted at
 * order 1 makes up bounces of that size for ever).  Its remaining bounces
 * would last 2 e v / (|a| (1 - e)). */
static int unresolved(nz_contacts *c, int j, double t, const double *q, double v, double *tinf)
{
  const nz_contact_def *d = &c->def[j];
  const double *J = nz_c_row(c, d->gap);
  double a = nz_c_dot(c->k, J, c->a0) + c->b[d->gap], e = d->e;
  double res = c->rtol * nz_c_abs_dot(c->k, J, q);
  for (int i = 0; i < c->k; i++) res += c->atol * fabs(J[i]);   /* sum |J_i| (atol + rtol |q_i|) */
  if (!(a < 0.0) || !(res > 0.0) || !(e > 0.0)) return 0;
  if (!((e * v) * (e * v) / (2.0 * -a) < NZ_CONTACT_RESOLVE * res)) return 0;
  *tinf = t + (e < 1.0 ? 2.0 * e * v / (-a * (1.0 - e)) : INFINITY);
  return 1;
}

/* ------------------------------------------------------------------ */
/* The steps                                                            */

/* Which contacts touch at (t, q): held, or a gap within the event's
 * tolerance at its approach speed (and the trigger's own).  Their
 * gradients must not vanish. */
static int touching(nz_contacts *c, double t, const double *q, const double *qd, int tj, int tfric)
{
  int k = c->k;
  double tscale = NZ_CONTACT_TOUCH_TIME * fmax(1.0, fabs(t));
  for (int j = 0; j < c->n; j++) {
    const double *J = nz_c_row(c, c->def[j].gap);
    double tol = tscale * fmax(0.0, -c->vn[j]) + NZ_CONTACT_ROUND * nz_c_abs_dot(k, J, q);
    double g = nz_c_max_abs(k, J);
    c->gmax[j] = fmax(c->gmax[j], g);
    c->touch[j] = nz_c_held(c->mode[j]) || c->phi[j] <= tol || (j == tj && !tfric);
    if (!c->touch[j]) continue;
    /* A gap whose gradient vanishes where it touches (q^3: a root of
     * multiplicity 3) has no normal there, and its impacts are located
     * only to the cube root of the rounding: zero, or a vanishing fraction
     * of the largest it has had in this run, is refused. */
    if (!(g > NZ_CONTACT_FLAT * c->gmax[j])) {
      nz_c_fail_at(c, NZ_CONTACT_GRADIENT, NZ_EARG, j, t, q, qd);
      c->fail.value = c->gmax[j] > 0.0 ? g / c->gmax[j] : 0.0;
      return NZ_EARG;
    }
    c->vmax[j] = fmax(c->vmax[j], fabs(c->vn[j]));
    if (c->def[j].slip >= 0) c->vtmax[j] = fmax(c->vtmax[j], hypot(c->vt[2 * j], c->vt[2 * j + 1]));
  }
  return NZ_OK;
}

/* The angle of an isotropic cone's first generator before an LCP: along a
 * (the friction expected: against the slip, or the force it had). */
static void turn_along(nz_contacts *c, int j, double a0, double a1)
{
  if (nz_c_iso(&c->def[j]) && (a0 != 0.0 || a1 != 0.0)) c->turn[j] = atan2(a1, a0);
}

/* The report's entries before the transition. */
static void report_before(nz_contacts *c, nz_contact_report *rep)
{
  for (int j = 0; rep->c && j < c->n; j++) {
    nz_contact_change *ch = &rep->c[j];
    memset(ch, 0, sizeof *ch);
    ch->from = c->mode0[j];
    ch->gap = c->phi[j];
    ch->vn_before = c->vn[j];
    ch->vt_before[0] = c->vt[2 * j], ch->vt_before[1] = c->vt[2 * j + 1];
  }
}

/* The impact: every touching contact at once, the approaching ones with
 * Newton's law (plastic where Zeno says so); q' changes by the LCP's
 * solution, and the frame is taken again at the new velocities (M, and so
 * K, stay: q did not change). */
static int impact(nz_contacts *c, const nz_system *s, double t, const double *q, double *qd, int tj,
                  nz_contact_report *rep)
{
  int k = c->k, n = c->n, nappr = 0, st, accel = 0;
  for (int j = 0; j < n; j++) {
    double tol = nz_c_rest_tol(c, c->def[j].gap, qd, c->vmax[j], c->vn[j]), tinf;
    /* an open contact closes with an impact; one held already only drifts
     * (its normal velocity is set back to zero by the projection) */
    c->appr[j] = c->touch[j] && !nz_c_held(c->mode0[j]) && c->vn[j] < -tol;
    c->e_eff[j] = c->def[j].e;
    c->sliding[j] = 0;
    if (!c->appr[j]) continue;
    nappr++;
    if (!accel) nz_c_free_accel(c), accel = 1;   /* (the free normal accelerations, for Zeno by resolution) */
    int z = zeno(c, j, t, -c->vn[j], &tinf) || unresolved(c, j, t, q, -c->vn[j], &tinf);
    if (z) {
      c->e_eff[j] = 0.0;
      rep->zeno_contact = j;
      rep->zeno_time = tinf;
    }
    if (rep->c) rep->c[j].impact = 1, rep->c[j].zeno = z;
  }
  if (!nappr) return NZ_OK;
  for (int j = 0; j < n; j++) {
    c->base_n[j] = c->vn[j] + (c->appr[j] ? c->e_eff[j] * c->vn[j] : 0.0);
    c->base_t[2 * j] = c->vt[2 * j], c->base_t[2 * j + 1] = c->vt[2 * j + 1];
    c->mu_lcp[j] = c->def[j].mu;
    c->cone[j] = 1;
    turn_along(c, j, -c->vt[2 * j], -c->vt[2 * j + 1]);
  }
  if ((st = nz_c_lcp(c, c->touch, c->cone, rep, tj, t, q, qd))) return st;
  double *dx = c->F;
  nz_c_lcp_motion(c, dx);
  for (int i = 0; i < k; i++) qd[i] += dx[i];
  rep->impact = 1;
  nz_c_share_impulses(c, c->touch, rep);
  return nz_c_frame(c, s, t, q, qd);
}

/* Painleve: every sliding contact at rest must have a positive normal
 * effective mass (the LCP's matrix is then copositive-plus). */
static int painleve(nz_contacts *c, double t, const double *q, const double *qd)
{
  for (int j = 0; j < c->n; j++) {
    if (!c->rest[j] || !c->sliding[j]) continue;
    int state = c->sliding[j] == 2 ? NZ_CONTACT_SLIP : c->sliding[j] > 0 ? NZ_CONTACT_SLIP_POS : NZ_CONTACT_SLIP_NEG;
    double m = nz_c_effective_mass(c, j, state);
    if (m <= 1e-9) {
      nz_c_fail_at(c, NZ_CONTACT_PAINLEVE, NZ_EARG, j, t, q, qd);
      c->fail.value = m;
      c->fail.an = c->base_n[j];
      return NZ_EARG;
    }
  }
  return NZ_OK;
}

/* The LCP of the new mode at the acceleration level, for the touching
 * contacts at rest (normal velocity zero): the accelerations without
 * contact forces a0 and the same operator; the cone with mu_s for those
 * whose slip velocity is zero, the friction riding on the normal force of
 * those that slide. */
static int mode_lcp(nz_contacts *c, double t, const double *q, const double *qd, int tj, nz_contact_report *rep,
                    int *any)
{
  int k = c->k, st;
  *any = 0;
  nz_c_free_accel(c);
  for (int j = 0; j < c->n; j++) {
    const nz_contact_def *d = &c->def[j];
    const double *J = nz_c_row(c, d->gap);
    c->rest[j] = c->touch[j] && c->vn[j] <= nz_c_rest_tol(c, d->gap, qd, c->vmax[j], c->vn[j]);
    c->cone[j] = c->sliding[j] = 0;
    c->newmode[j] = NZ_CONTACT_OPEN;
    if (!c->rest[j]) continue;
    *any = 1;
    c->base_n[j] = nz_c_dot(k, J, c->a0) + c->b[d->gap];
    c->base_t[2 * j] = c->base_t[2 * j + 1] = 0.0;
    c->mu_lcp[j] = d->mu_s;
    for (int i = 0; i < nz_c_ntan(d); i++) {
      int r = nz_c_tan_row(d, i);
      c->base_t[2 * j + i] = nz_c_dot(k, nz_c_row(c, r), c->a0) + c->b[r];
    }
    if (d->slip < 0) continue;
    double speed = hypot(c->vt[2 * j], c->vt[2 * j + 1]);
    if (speed <= nz_c_rest_tol(c, d->slip, qd, c->vtmax[j], c->vt[2 * j])) {
      c->cone[j] = 1;
      if (nz_c_held(c->mode0[j]))         /* the pyramid along the friction it had */
        turn_along(c, j, c->clam[d->slip], nz_c_iso(d) ? c->clam[d->slip2] : 0.0);
      else turn_along(c, j, -c->base_t[2 * j], -c->base_t[2 * j + 1]);
    } else if (nz_c_iso(d)) {
      c->sliding[j] = 2;
      c->dir[2 * j] = c->vt[2 * j] / speed, c->dir[2 * j + 1] = c->vt[2 * j + 1] / speed;
    } else c->sliding[j] = c->vt[2 * j] > 0.0 ? 1 : -1;
  }
  if (!*any) return NZ_OK;
  if ((st = painleve(c, t, q, qd))) return st;
  if ((st = nz_c_lcp(c, c->rest, c->cone, rep, tj, t, q, qd))) {
    int j = -1;
    for (int x = 0; x < c->n && j < 0; x++)
      if (c->rest[x] && c->sliding[x]) j = x;
    if (j >= 0) {
      int state = c->sliding[j] == 2 ? NZ_CONTACT_SLIP : c->sliding[j] > 0 ? NZ_CONTACT_SLIP_POS : NZ_CONTACT_SLIP_NEG;
      nz_c_fail_at(c, NZ_CONTACT_PAINLEVE, st, j, t, q, qd);
      c->fail.value = nz_c_effective_mass(c, j, state), c->fail.an = c->base_n[j];
    }
    return NZ_EARG;
  }
  return NZ_OK;
}

/* Contact j at rest with no force and a zero normal complement, its normal
 * row kept by the carriers: the state it rests in. */
static void resting_state(nz_contacts *c, int j)
{
  const nz_contact_def *d = &c->def[j];
  int keeps = 1, k = c->k;
  for (int i = 0; i < nz_c_ntan(d); i++) keeps &= nz_c_dependent_on_carriers(c, nz_c_tan_row(d, i));
  if (d->slip < 0) c->mode[j] = NZ_CONTACT_CLOSED;
  else if (c->sliding[j] == 2) c->mode[j] = NZ_CONTACT_SLIP;
  else if (c->sliding[j]) c->mode[j] = c->sliding[j] > 0 ? NZ_CONTACT_SLIP_POS : NZ_CONTACT_SLIP_NEG;
  else if (keeps) c->mode[j] = NZ_CONTACT_STICK;
  else {      /* its slip goes with the motion the others make: it slides along it */
    double w[2] = { c->base_t[2 * j], c->base_t[2 * j + 1] }, dx[k];
    nz_c_lcp_motion(c, dx);
    for (int i = 0; i < nz_c_ntan(d); i++) w[i] += nz_c_dot(k, nz_c_row(c, nz_c_tan_row(d, i)), dx);
    double f = hypot(w[0], w[1]);
    if (!(f > 0.0)) return;    /* no slip either: it stays open */
    if (nz_c_iso(d)) {
      c->mode[j] = NZ_CONTACT_SLIP;
      c->dir[2 * j] = w[0] / f, c->dir[2 * j + 1] = w[1] / f;
    } else c->mode[j] = w[0] > 0.0 ? NZ_CONTACT_SLIP_POS : NZ_CONTACT_SLIP_NEG;
  }
}

/* The new mode from the LCP's solution: a contact pushing is held, and
 * sticks, or slides (on, or from rest against its friction force); one at
 * rest without a force whose rows the held ones keep at zero rests on them
 * (dependent: held, sharing nothing); the others open.  Then its
 * carriers and the roles of its forces. */
static int new_mode(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd)
{
  int n = c->n, st, resting[n];
  for (int j = 0; j < n; j++) {
    const nz_contact_def *d = &c->def[j];
    resting[j] = 0;
    c->share[j] = 1, c->atcone[j] = 0;
    if (!c->rest[j]) continue;
    double T[2], sig = nz_c_lcp_friction(c, j, T);
    if (!(nz_c_lcp_normal(c, j) > 0.0)) {
      resting[j] = c->sol_w[j] <= 1e-12 * fabs(c->base_n[j]);
      continue;
    }
    if (d->slip < 0) c->newmode[j] = NZ_CONTACT_CLOSED;
    else if (c->sliding[j] == 2) c->newmode[j] = NZ_CONTACT_SLIP;
    else if (c->sliding[j]) c->newmode[j] = c->sliding[j] > 0 ? NZ_CONTACT_SLIP_POS : NZ_CONTACT_SLIP_NEG;
    else if (sig > 0.0 && nz_c_iso(d)) {   /* the cone is saturated: it slides, against the friction force */
      double f = hypot(T[0], T[1]);
      c->newmode[j] = NZ_CONTACT_SLIP;
      c->dir[2 * j] = -T[0] / f, c->dir[2 * j + 1] = -T[1] / f;
    } else if (sig > 0.0) c->newmode[j] = T[0] > 0.0 ? NZ_CONTACT_SLIP_NEG : NZ_CONTACT_SLIP_POS;
    else c->newmode[j] = NZ_CONTACT_STICK;
  }
  memcpy(c->mode, c->newmode, (size_t)n * sizeof(int));
  nz_c_carriers(c, 1);
  /* resting: its normal row kept by the carriers (and, where it would stick,
   * its slip rows too; else it slides as its slip goes, against the slip
   * acceleration the LCP's solution gives it); it shares the load until
   * the sharing would make it pull (nz_c_settle_roles) */
  int more = 0;
  for (int j = 0; j < n; j++) {
    if (!resting[j] || !nz_c_dependent_on_carriers(c, c->def[j].gap)) continue;
    resting_state(c, j);
    more = 1;
  }
  if (more) nz_c_carriers(c, 1);
  if ((st = nz_c_settle_roles(c, s, t, q, qd))) return st;
  return NZ_OK;
}

static int same_mode(const nz_contacts *c)
{
  size_t nb = (size_t)c->n * sizeof(int);
  return !memcmp(c->mode, c->mode0, nb) && !memcmp(c->share, c->share0, nb) && !memcmp(c->atcone, c->atcone0, nb);
}

/* Is row r of contact tj kept by the other held contacts (tj left out of
 * the carriers)? */
static int kept_by_others(nz_contacts *c, int tj, int r)
{
  int state = c->mode[tj], dep;
  c->mode[tj] = NZ_CONTACT_OPEN;
  nz_c_carriers(c, 0);
  dep = nz_c_dependent_on_carriers(c, r);
  c->mode[tj] = state;
  return dep;
}

/* An event must change something: a normal force that reached zero opens
 * its contact (or, where the others keep its gap, sets it to rest on them);
 * a friction force that reached the cone slides (or is held at the cone
 * where the others keep its slip) -- the LCP, at the very state where
 * both are zero, may keep the mode by a rounding. */
static int must_change(nz_contacts *c, const nz_system *s, double t, const double *q, const double *qd, int tj,
                       int tfric)
{
  int st;
  const nz_contact_def *d = &c->def[tj];
  if (!tfric && nz_c_held(c->mode0[tj])) {
    if (c->share[tj] && kept_by_others(c, tj, d->gap)) c->share[tj] = 0;
    else c->mode[tj] = NZ_CONTACT_OPEN;
  } else if (tfric && c->mode0[tj] == NZ_CONTACT_STICK && c->mode[tj] == NZ_CONTACT_STICK) {
    if ((st = nz_contacts_accel(c, s, t, q, qd, NULL, NULL))) return st;
    double T[2] = { c->clam[d->slip], nz_c_iso(d) ? c->clam[d->slip2] : 0.0 }, f = hypot(T[0], T[1]);
    int kept = 1;
    for (int i = 0; i < nz_c_ntan(d); i++) kept &= kept_by_others(c, tj, nz_c_tan_row(d, i));
    if (kept && f > 0.0) {
      c->atcone[tj] = 1;
      c->dir[2 * tj] = T[0] / f, c->dir[2 * tj + 1] = T[1] / f;
    } else if (nz_c_iso(d)) {
      c->mode[tj] = NZ_CONTACT_SLIP;
      c->dir[2 * tj] = f > 0.0 ? -T[0] / f : 1.0, c->dir[2 * tj + 1] = f > 0.0 ? -T[1] / f : 0.0;
    } else c->mode[tj] = T[0] > 0.0 ? NZ_CONTACT_SLIP_NEG : NZ_CONTACT_SLIP_POS;
  } else return NZ_OK;
  nz_c_carriers(c, 0);
  return NZ_OK;
}

/* x += the least change (in the metric of M, the bilateral constraints
 * held: K^-1) that brings the m rows rows[a] of x to the values target[a]
 * from value[a]: Delassus' matrix G = R K^-1 R^T, G nu = target - value,
 * by least squares (dependent rows are not an error here: the change is
 * the same).  The rows are gap rows (q) or normal and slip rows (q'). */
static void project_rows(nz_contacts *c, int m, const int *rows, const double *value, double *x)
{
  int k = c->k;
  if (m <= 0) return;
  for (int a = 0; a < m; a++) nz_c_solve_bilateral(c, nz_c_row(c, rows[a]), NULL, c->resp + (size_t)a * k);
  for (int a = 0; a < m; a++) {
    for (int b = 0; b < m; b++) c->L[a * m + b] = nz_c_dot(k, nz_c_row(c, rows[a]), c->resp + (size_t)b * k);
    c->lq[a] = -value[a];
  }
  if (nz_lstsq_in(c->ls, m, m, c->L, c->lq, c->lz, 1e-13, NULL)) return;
  for (int a = 0; a < m; a++)
    for (int i = 0; i < k; i++) x[i] += c->resp[(size_t)a * k + i] * c->lz[a];
}

/* The state put on what the new mode holds: the gaps of the contacts
 * held, and every touching gap below zero (the event's location leaves a
 * penetration of its tolerance, and a bounce must start at zero, or the
 * next landing is missed or found as deep), to zero; then the normal
 * velocities of the contacts held and the slip velocities of those that
 * stick, to zero.  One Newton step each: the corrections are of the
 * tolerances.  K must be factored at (t, q). */
static int project(nz_contacts *c, const nz_system *s, double t, double *q, double *qd)
{
  int n = c->n, m = 0, rows[3 * n];
  double value[3 * n];
  for (int j = 0; j < n; j++)
    if (nz_c_held(c->mode[j]) || (c->touch[j] && c->phi[j] < 0.0)) rows[m] = c->def[j].gap, value[m++] = c->phi[j];
  project_rows(c, m, rows, value, q);
  int st = nz_c_frame(c, s, t, q, qd);
  if (st || (st = nz_c_factor_bilateral(c, t, q, qd))) return st;
  m = 0;
  for (int j = 0; j < n; j++) {
    if (!nz_c_held(c->mode[j])) continue;
    rows[m] = c->def[j].gap, value[m++] = c->vn[j];
    for (int i = 0; c->mode[j] == NZ_CONTACT_STICK && i < nz_c_ntan(&c->def[j]); i++)
      rows[m] = nz_c_tan_row(&c->def[j], i), value[m++] = c->vt[2 * j + i];
  }
  project_rows(c, m, rows, value, qd);
  return nz_c_frame(c, s, t, q, qd);
}

/* The events' offsets (nz_contacts_event): a gap left open at zero (a
 * bounce, a lift-off) starts at least a rounding above zero, and so does
 * the slip velocity of a contact set sliding from rest: shifted by the
 * penetration the event's location left, so that it falls through zero
 * only where the motion comes back, even within one long step.  Then the
 * report. */
static void offsets_and_report(nz_contacts *c, const double *q, const double *qd, nz_contact_report *rep)
{
  int k = c->k;
  for (int j = 0; j < c->n; j++) {
    const nz_contact_def *d = &c->def[j];
    int state = c->mode[j];
    c->offset[2 * j] = c->offset[2 * j + 1] = 0.0;
    if (state == NZ_CONTACT_OPEN && c->touch[j])
      c->offset[2 * j] = fmax(0.0, -c->phi[j]) + 16 * DBL_EPSILON * nz_c_abs_dot(k, nz_c_row(c, d->gap), q) + DBL_MIN;
    int started = nz_c_slides(state) && (state != c->mode0[j] || (state == NZ_CONTACT_SLIP && !c->sliding[j]));
    if (started) {
      const double *v = c->vt + 2 * j, *u = c->dir + 2 * j;
      double g = state == NZ_CONTACT_SLIP ? v[0] * u[0] + v[1] * u[1] - NZ_CONTACT_TURN * hypot(v[0], v[1])
                                          : nz_c_slip_sign(state) * v[0];
      double size = nz_c_abs_dot(k, nz_c_row(c, d->slip), qd) + (nz_c_iso(d) ? nz_c_abs_dot(k, nz_c_row(c, d->slip2), qd) : 0.0);
      c->offset[2 * j + 1] = fmax(0.0, -g) + 16 * DBL_EPSILON * size + DBL_MIN;
    }
    if (state != c->mode0[j]) rep->changed = 1;
    if (!nz_c_held(state) && nz_c_held(c->mode0[j])) c->nh[j] = 0;   /* lifted off: a new run of impacts */
    if (!rep->c) continue;
    nz_contact_change *ch = &rep->c[j];
    ch->to = state;
    ch->vn_after = c->vn[j];
    ch->lambda_n = c->clam[d->gap];
    for (int i = 0; i < nz_c_ntan(d); i++) {
      ch->vt_after[i] = c->vt[2 * j + i];
      ch->lambda_t[i] = c->clam[nz_c_tan_row(d, i)];
    }
  }
}

int nz_contacts_transition(nz_contacts *c, const nz_system *s, double t, double *q, double *qd,
                           int trigger, nz_contact_report *rep)
{
  int n = c->n, st, any;
  nz_c_clear_failure(c);
  nz_contact_report local;
  if (!rep) rep = &local, memset(rep, 0, sizeof local);
  rep->impact = rep->changed = 0;
  rep->zeno_contact = -1;
  rep->zeno_time = 0.0;
  memset(&rep->lcp, 0, sizeof rep->lcp);
  memcpy(c->mode0, c->mode, (size_t)n * sizeof(int));
  memcpy(c->share0, c->share, (size_t)n * sizeof(int));
  memcpy(c->atcone0, c->atcone, (size_t)n * sizeof(int));
  int tj = trigger >= 0 ? trigger / 2 : -1, tfric = trigger >= 0 ? trigger % 2 : 0;
  if ((st = nz_c_frame(c, s, t, q, qd))) return st;
  report_before(c, rep);
  if ((st = touching(c, t, q, qd, tj, tfric))) return st;
  if ((st = nz_c_factor_bilateral(c, t, q, qd))) return st;
  if ((st = impact(c, s, t, q, qd, tj, rep))) return st;
  if ((st = mode_lcp(c, t, q, qd, tj, rep, &any))) return st;
  if (any) {
    if ((st = new_mode(c, s, t, q, qd))) return st;
  } else {
    memcpy(c->mode, c->newmode, (size_t)n * sizeof(int));
    nz_c_carriers_all(c);
  }
  c->cvalid = 0;
  if (!rep->impact && tj >= 0 && same_mode(c) && (st = must_change(c, s, t, q, qd, tj, tfric))) return st;
  c->cvalid = 0;
  if ((st = project(c, s, t, q, qd)) || (st = nz_contacts_accel(c, s, t, q, qd, NULL, NULL))) return st;
  offsets_and_report(c, q, qd, rep);
  return NZ_OK;
}
