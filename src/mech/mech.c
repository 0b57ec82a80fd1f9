/* mech.c - residuals of the generalized equations (see mech.h).
 *
 * Every form is a combination of a few primitives, each one evaluation of a
 * piece on jets with tangent seeds placed as docs/theory.md §3 says:
 *   top_partials(m)   dF^(m)/dq^(m) (and dF^(m-1)/dq^(m-1)): order m jets,
 *                     seeds on q^(m), which moves a_{i,m} by 1/m! and
 *                     b_{i,m-1} by 1/(m-1)! (the same number in both series);
 *                     m = 0 gives dF/dq;
 *   velocity_rate     d/dt(dF/dq'): order 1 jets, the velocity slot seeded
 *                     as a whole, so the tangent series is dF/dq' along the
 *                     motion and its coefficient 1 is the time derivative;
 *   frozen_partial(n) dF_0^(n)/dq^(n) with the velocity slot held constant (§4);
 *   generalized_force Q - dV/dq at the state.
 * Coefficients stay normalized; n! multiplies only the final coefficient. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core/linalg.h"
#include "mech/mech.h"

const char *const nz_form_names[NZ_FORM_COUNT] = {
  "generalized", "lagrange", "difference", "euler", "appell", "extremal", "wassmuth"
};

double nz_factorial(int n)
{
  double f = 1.0;
  for (int i = 2; i <= n; i++) f *= i;
  return f;
}

/* ------------------------------------------------------------------ */
/* Jets of a motion (mech.h)                                            */

void nz_jets_free(nz_jet **v, int k)
{
  if (!v) return;
  for (int i = 0; i < k; i++) nz_jet_free(v[i]);
  free(v);
}

nz_jet **nz_jets_alloc(int k, int K, int D)
{
  nz_jet **v = calloc((size_t)k, sizeof *v);
  if (!v) return NULL;
  for (int i = 0; i < k; i++)
    if (!(v[i] = nz_jet_alloc(K, D))) { nz_jets_free(v, k); return NULL; }
  return v;
}

int nz_constraint_levels(const nz_system *s, int r)
{
  int n = s->levels && r >= 0 && r < s->nlevels ? s->levels[r] : 0;
  return n > NZ_CONSTRAINT_SLOTS ? n : NZ_CONSTRAINT_SLOTS;
}

int nz_constraint_levels_max(const nz_system *s)
{
  int n = NZ_CONSTRAINT_SLOTS;
  for (int r = 0; r < s->nc; r++) if (nz_constraint_levels(s, r) > n) n = nz_constraint_levels(s, r);
  return n;
}

void nz_motion_free(nz_motion *m)
{
  nz_jet_free(m->t);
  nz_jet_free(m->dt);
  for (int j = 0; j < m->nslots; j++) {
    if (m->slot) nz_jets_free(m->slot[j], m->k);
    if (m->dslot) nz_jets_free(m->dslot[j], m->k);
  }
  free(m->slot);
  free(m->dslot);
  nz_jets_free(m->out, m->k);
  nz_jets_free(m->dout, m->k);
  memset(m, 0, sizeof *m);
}

/* *z zeroed with shape (K, D): kept when it has that shape already, else
 * replaced (a caller may have swapped t or out[0] for another shape). */
static int fit_jet(nz_jet **z, int K, int D)
{
  if (*z && (*z)->order == K && (*z)->ntan == D) {
    nz_jet_init(*z, K, D);
    return NZ_OK;
  }
  nz_jet_free(*z);
  *z = nz_jet_alloc(K, D);
  return *z ? NZ_OK : NZ_ENOMEM;
}

/* k jets of shape (K, D) in *v, allocated when *v is NULL, else fitted. */
static int fit_jets(nz_jet ***v, int k, int K, int D)
{
  if (!*v) return (*v = nz_jets_alloc(k, K, D)) ? NZ_OK : NZ_ENOMEM;
  for (int i = 0; i < k; i++)
    if (fit_jet(&(*v)[i], K, D)) return NZ_ENOMEM;
  return NZ_OK;
}

/* The direction moves slot j's coefficient c by d(level j + c)/c!, where
 * only levels 0 (q), 1 (q') and, when dqdd is given, 2 (q'') move: slot 0
 * gets dq and dqd (q's series holds q' as its first coefficient) and
 * dqdd/2, slot 1 gets dqd and dqdd, slot 2 dqdd. */
int nz_motion_set_direction(nz_motion *m, const nz_state_direction *d)
{
  int k = m->k;
  if (!m->dslot && !(m->dslot = calloc((size_t)m->nslots, sizeof *m->dslot))) return NZ_ENOMEM;
  int ok = !fit_jet(&m->dt, m->K, 0) && !fit_jets(&m->dout, k, m->K, m->D);
  for (int j = 0; j < m->nslots && ok; j++) ok = !fit_jets(&m->dslot[j], k, m->K, m->D);
  if (!ok) return NZ_ENOMEM;
  m->dt->c[0] = d->dt;
  for (int i = 0; i < k; i++) {
    m->dslot[0][i]->c[0] = d->dq[i];
    if (m->K >= 1) m->dslot[0][i]->c[1] = d->dqd[i];
    if (m->nslots > 1) m->dslot[1][i]->c[0] = d->dqd[i];
    if (!d->dqdd) continue;
    /* slot j holds q^(j+c)/c!: q'' is coefficient 2 - j of slot j */
    if (m->K >= 2) m->dslot[0][i]->c[2] = d->dqdd[i] / 2.0;
    if (m->nslots > 1 && m->K >= 1) m->dslot[1][i]->c[1] = d->dqdd[i];
    if (m->nslots > 2) m->dslot[2][i]->c[0] = d->dqdd[i];
  }
  m->dir_on = 1;
  return NZ_OK;
}

static double level_value(const double *const *state, int nstate, int j, int i)
{
  return j < nstate && state[j] ? state[j][i] : 0.0;
}

/* The jets of m have shape (k, nslots, K, D) and may be refilled in place:
 * only the shape is compared, the jets t and out are fitted anyway. */
static int same_shape(const nz_motion *m, int k, int nslots, int K, int D)
{
  return m->slot && m->out && m->k == k && m->nslots == nslots && m->K == K && m->D == D;
}

int nz_motion_reset(nz_motion *m, int k, int nslots, int K, int D, double t,
                    const double *const *state, int nstate)
{
  if (nslots < 1 || nslots > NZ_MAX_LEVELS || k < 0 || K < 0 || D < 0) return NZ_EARG;
  if (!same_shape(m, k, nslots, K, D)) {
    nz_motion_free(m);
    m->k = k;
    m->K = K;
    m->D = D;
    m->nslots = nslots;
    if (!(m->slot = calloc((size_t)nslots, sizeof *m->slot))) return NZ_ENOMEM;
  }
  m->dir_on = 0;
  int ok = !fit_jet(&m->t, K, 0) && !fit_jets(&m->out, k, K, D);
  for (int j = 0; j < nslots && ok; j++) ok = !fit_jets(&m->slot[j], k, K, D);
  if (!ok) return NZ_ENOMEM;
  nz_jet_set_variable(m->t, t, -1);
  for (int j = 0; j < nslots; j++)
    for (int i = 0; i < k; i++) {
      double inv = 1.0;
      for (int c = 0; c <= K; c++) {
        if (c > 0) inv /= c;
        m->slot[j][i]->c[c] = level_value(state, nstate, j + c, i) * inv;
      }
    }
  return NZ_OK;
}

int nz_motion_init(nz_motion *m, int k, int nslots, int K, int D, double t,
                   const double *const *state, int nstate)
{
  memset(m, 0, sizeof *m);
  int st = nz_motion_reset(m, k, nslots, K, D, t, state, nstate);
  if (st) nz_motion_free(m);
  return st;
}

/* The same number q^(level) is coefficient level - j of slot j, normalized
 * by (level - j)!: a seed moves all of them together. */
void nz_motion_seed_level(nz_motion *m, int i, int d, int level)
{
  for (int j = 0; j < m->nslots; j++) {
    int c = level - j;
    if (c >= 0 && c <= m->K) nz_jet_tangent(m->slot[j][i], d)[c] += 1.0 / nz_factorial(c);
  }
}

void nz_motion_seed_slot(nz_motion *m, int i, int d, int j) { nz_jet_tangent(m->slot[j][i], d)[0] += 1.0; }

static int piece_levels(const nz_system *s, nz_piece p, int index)
{
  if (p == NZ_PIECE_V || p == NZ_PIECE_S) return 1;
  if (p == NZ_PIECE_PHI) return nz_constraint_levels(s, index);
  return 2;
}

int nz_motion_eval(const nz_system *s, nz_piece p, int index, nz_motion *m, nz_jet **qd)
{
  nz_jet *const *levels[NZ_MAX_LEVELS];
  int nlevels = piece_levels(s, p, index);
  if (nlevels > m->nslots) return NZ_EARG;
  for (int j = 0; j < nlevels; j++) levels[j] = m->slot[j];
  if (qd && nlevels > 1) levels[1] = qd;
  nz_direction dir, *dp = NULL;
  if (m->dir_on) {
    dir.dt = m->dt;
    dir.dlevels = (nz_jet *const *const *)m->dslot;
    dir.dout = m->dout;
    dp = &dir;
  }
  return s->ev.eval(s->ev.ctx, p, index, m->t, levels, nlevels, m->out, dp);
}

/* Every slot (and t) constant in the series variable. */
static void freeze(nz_motion *mo)
{
  for (int c = 1; c <= mo->K; c++) {
    mo->t->c[c] = 0.0;
    for (int j = 0; j < mo->nslots; j++)
      for (int i = 0; i < mo->k; i++) mo->slot[j][i]->c[c] = 0.0;
  }
}

int nz_constraint_eval(const nz_system *s, int r, nz_motion *mo, double t, const double *const *state,
                       int nstate, const nz_constraint_seeding *sd)
{
  int k = s->k, nslots = sd->nslots > 0 ? sd->nslots : nz_constraint_levels(s, r);
  int count = sd->count < 0 ? nslots : sd->count, D = sd->D < 0 ? count * k + (sd->t_variable != 0) : sd->D;
  int st = nz_motion_reset(mo, k, nslots, sd->K, D, t, state, nstate);
  if (st) return st;
  if (sd->t_variable) {                   /* t's jet gets the tangents' shape */
    if (fit_jet(&mo->t, sd->K, D)) return NZ_ENOMEM;
    nz_jet_set_variable(mo->t, t, count * k);
  }
  if (sd->dir && (st = nz_motion_set_direction(mo, sd->dir))) return st;
  if (sd->frozen) {
    if (sd->along_slot < 0 || sd->along_slot >= nslots) return NZ_EARG;
    freeze(mo);
    if (sd->along)
      for (int i = 0; i < k; i++) mo->slot[sd->along_slot][i]->c[1] = sd->along[i];
    else mo->slot[sd->along_slot][sd->along_index]->c[1] = 1.0;
  }
  if (sd->by_slot && count > 0 && (sd->first < 0 || sd->first + count > nslots)) return NZ_EARG;
  for (int l = sd->first; l < sd->first + count; l++)
    for (int i = 0; i < k; i++) {
      if (sd->by_slot) nz_motion_seed_slot(mo, i, (l - sd->first) * k + i, l);
      else nz_motion_seed_level(mo, i, (l - sd->first) * k + i, l);
    }
  for (int j = sd->above + 1; sd->sizes && j < nslots; j++)
    for (int i = 0; i < k; i++) nz_jet_tangent(mo->slot[j][i], D - 1)[0] += nz_check_slot_weight(j, i, k) * sd->sizes[j];
  return nz_motion_eval(s, NZ_PIECE_PHI, r, mo, NULL);
}

/* ------------------------------------------------------------------ */
/* Primitives                                                           */

/* Each primitive is one evaluation in the caller's workspace mo (reset
 * here, freed by the caller), so that a public function making several
 * evaluations of the same shape (nz_mass_bias: k + 1) allocates once. */

/* dF^(m)/dq^(m) into top (k values) and, if below != NULL,
 * dF^(m-1)/dq^(m-1) into below (m >= 1), from one evaluation. */
static int top_partials_along(const nz_system *s, nz_motion *mo, nz_piece p, int m, double t,
                              const double *const *state, int nstate, double *top, double *below,
                              const nz_state_direction *dir, double *dtop)
{
  int k = s->k, D = below ? 2 * k : k;
  /* m = 0 (dF/dq, dV/dq) on jets of order 1 all the same: the motion's
   * velocity is then in them, so a tie of a branch is decided as in the
   * orders m >= 1 (the rule of jet.h: the first coefficient that differs),
   * and a singular point is refused as there */
  int st = nz_motion_reset(mo, k, 2, m > 0 ? m : 1, D, t, state, nstate);
  if (st) return st;
  if (dir && (st = nz_motion_set_direction(mo, dir))) return st;
  for (int i = 0; i < k; i++) {
    nz_motion_seed_level(mo, i, i, m);
    if (below) nz_motion_seed_level(mo, i, k + i, m - 1);
  }
  st = nz_motion_eval(s, p, 0, mo, NULL);
  if (!st) {
    double fm = nz_factorial(m), fm1 = m >= 1 ? nz_factorial(m - 1) : 1.0;
    for (int i = 0; i < k; i++) {
      top[i] = fm * nz_jet_tangent(mo->out[0], i)[m];
      if (below) below[i] = fm1 * nz_jet_tangent(mo->out[0], k + i)[m - 1];
      if (dir) dtop[i] = fm * nz_jet_tangent(mo->dout[0], i)[m];
    }
  }
  return st;
}

static int top_partials(const nz_system *s, nz_motion *mo, nz_piece p, int m, double t,
                        const double *const *state, int nstate, double *top, double *below)
{
  return top_partials_along(s, mo, p, m, t, state, nstate, top, below, NULL, NULL);
}

/* d/dt (dF/dq'_i) at t0. */
static int velocity_rate(const nz_system *s, nz_motion *mo, double t, const double *const *state,
                         int nstate, double *out)
{
  int k = s->k;
  int st = nz_motion_reset(mo, k, 2, 1, k, t, state, nstate);
  if (st) return st;
  for (int i = 0; i < k; i++) nz_motion_seed_slot(mo, i, i, 1);
  st = nz_motion_eval(s, NZ_PIECE_F, 0, mo, NULL);
  if (!st)
    for (int i = 0; i < k; i++) out[i] = nz_jet_tangent(mo->out[0], i)[1];
  return st;
}

/* dF_0^(n)/dq^(n): the velocity slot is the constant q'(t0) (§4). */
static int frozen_partial(const nz_system *s, nz_motion *mo, int n, double t,
                          const double *const *state, int nstate, double *out)
{
  int k = s->k;
  int st = nz_motion_reset(mo, k, 2, n, k, t, state, nstate);
  if (st) return st;
  nz_jet **frozen = nz_jets_alloc(k, n, 0);
  if (!frozen) return NZ_ENOMEM;
  for (int i = 0; i < k; i++) {
    frozen[i]->c[0] = mo->slot[1][i]->c[0];
    nz_motion_seed_level(mo, i, i, n);
  }
  st = nz_motion_eval(s, NZ_PIECE_F, 0, mo, frozen);
  if (!st) {
    double fn = nz_factorial(n);
    for (int i = 0; i < k; i++) out[i] = fn * nz_jet_tangent(mo->out[0], i)[n];
  }
  nz_jets_free(frozen, k);
  return st;
}

/* Q - dV/dq at the state (each piece only if present), and with dir its
 * derivative along dir into dforce. */
static int generalized_force_along(const nz_system *s, nz_motion *mo, double t,
                                   const double *const *state, int nstate, double *force,
                                   const nz_state_direction *dir, double *dforce)
{
  int k = s->k, st = NZ_OK;
  memset(force, 0, (size_t)k * sizeof(double));
  if (dir) memset(dforce, 0, (size_t)k * sizeof(double));
  if (nz_system_has(s, NZ_PIECE_Q)) {
    if ((st = nz_motion_reset(mo, k, 2, 0, 0, t, state, nstate))) return st;
    if (dir && (st = nz_motion_set_direction(mo, dir))) return st;
    st = nz_motion_eval(s, NZ_PIECE_Q, 0, mo, NULL);
    if (!st)
      for (int i = 0; i < k; i++) {
        force[i] = mo->out[i]->c[0];
        if (dir) dforce[i] = mo->dout[i]->c[0];
      }
    if (st) return st;
  }
  if (nz_system_has(s, NZ_PIECE_V)) {
    double *dV = malloc(2 * (size_t)k * sizeof(double));
    if (!dV) return NZ_ENOMEM;
    st = top_partials_along(s, mo, NZ_PIECE_V, 0, t, state, nstate, dV, NULL, dir, dV + k);
    if (!st)
      for (int i = 0; i < k; i++) {
        force[i] -= dV[i];
        if (dir) dforce[i] -= dV[k + i];
      }
    free(dV);
  }
  return st;
}

static int generalized_force(const nz_system *s, nz_motion *mo, double t, const double *const *state,
                             int nstate, double *force)
{
  return generalized_force_along(s, mo, t, state, nstate, force, NULL, NULL);
}

int nz_nielsen_residual_along(const nz_system *s, double t, const double *const *state,
                              const nz_state_direction *dir, double *r, double *dr)
{
  int k = s->k, st;
  double *buf = calloc(6 * (size_t)k, sizeof(double));
  if (!buf) return NZ_ENOMEM;
  double *f = buf, *df = f + k, *x = df + k, *dx = x + k, *y = dx + k, *dy = y + k;
  nz_motion mo = { 0 };
  st = generalized_force_along(s, &mo, t, state, 3, f, dir, df);
  if (!st && nz_system_has(s, NZ_PIECE_F)) {
    st = top_partials_along(s, &mo, NZ_PIECE_F, 1, t, state, 3, x, NULL, dir, dx);
    if (!st) st = top_partials_along(s, &mo, NZ_PIECE_F, 0, t, state, 3, y, NULL, dir, dy);
  }
  if (!st)
    for (int i = 0; i < k; i++) {
      r[i] = x[i] - 2.0 * y[i] - f[i];
      dr[i] = dx[i] - 2.0 * dy[i] - df[i];
    }
  nz_motion_free(&mo);
  free(buf);
  return st;
}

/* sum_j q_j^(n) dQ_j/dq_i^(n): the part of dK_n/dq^(n) that the forces'
 * dependence on q^(n) adds (nonzero for n = 1 with velocity-dependent Q). */
static int force_rate_term(const nz_system *s, nz_motion *mo, int n, double t,
                           const double *const *state, int nstate, double *out)
{
  int k = s->k;
  memset(out, 0, (size_t)k * sizeof(double));
  if (!nz_system_has(s, NZ_PIECE_Q)) return NZ_OK;
  int st = nz_motion_reset(mo, k, 2, n, k, t, state, nstate);
  if (st) return st;
  for (int i = 0; i < k; i++) nz_motion_seed_level(mo, i, i, n);
  st = nz_motion_eval(s, NZ_PIECE_Q, 0, mo, NULL);
  if (!st)
    for (int i = 0; i < k; i++)
      for (int j = 0; j < k; j++)
        out[i] += level_value(state, nstate, n, j) * nz_jet_tangent(mo->out[j], i)[0];
  return st;
}

/* dS^(n-2)/dq^(n): S receives the q series (Wassmuth, §4). */
static int acceleration_energy_partial(const nz_system *s, nz_motion *mo, int n, double t,
                                       const double *const *state, int nstate, double *out)
{
  int k = s->k;
  int st = nz_motion_reset(mo, k, 2, n, k, t, state, nstate);
  if (st) return st;
  /* S is built from r'', two orders below the q series (the next reset
   * puts back an output of the motion's shape). */
  nz_jet_free(mo->out[0]);
  if (!(mo->out[0] = nz_jet_alloc(n - 2, k))) return NZ_ENOMEM;
  for (int i = 0; i < k; i++) nz_motion_seed_level(mo, i, i, n);
  st = nz_motion_eval(s, NZ_PIECE_S, 0, mo, NULL);
  if (!st) {
    double f = nz_factorial(n - 2);
    for (int i = 0; i < k; i++) out[i] = f * nz_jet_tangent(mo->out[0], i)[n - 2];
  }
  return st;
}

/* ------------------------------------------------------------------ */
/* Forms                                                                */

int nz_residual(const nz_system *s, nz_form form, int n, double t, const double *const *state,
                int nstate, double *r, nz_terms *terms)
{
  int k = s->k, st;
  if (n < 1 || n > NZ_MAX_EQ_ORDER) return NZ_EARG;
  if (form == NZ_FORM_WASSMUTH && (n < 2 || !nz_system_has(s, NZ_PIECE_S))) return NZ_EARG;
  double *a = calloc((size_t)(4 * k), sizeof(double));
  if (!a) return NZ_ENOMEM;
  double *force = a, *x = a + k, *y = a + 2 * k, *z = a + 3 * k;
  int hasF = nz_system_has(s, NZ_PIECE_F);
  nz_motion mo = { 0 };

  st = generalized_force(s, &mo, t, state, nstate, force);
  if (st) goto done;
  switch (form) {
  case NZ_FORM_GENERALIZED:   /* x = dF^(n)/dq^(n), y = dF/dq */
    if (hasF && ((st = top_partials(s, &mo, NZ_PIECE_F, n, t, state, nstate, x, NULL)) ||
                 (st = top_partials(s, &mo, NZ_PIECE_F, 0, t, state, nstate, y, NULL)))) goto done;
    for (int i = 0; i < k; i++) r[i] = (x[i] - (n + 1) * y[i]) / n - force[i];
    if (terms) {
      if (terms->dFn) memcpy(terms->dFn, x, (size_t)k * sizeof(double));
      if (terms->dFq) memcpy(terms->dFq, y, (size_t)k * sizeof(double));
    }
    break;
  case NZ_FORM_LAGRANGE:      /* x = d/dt dF/dq', y = dF/dq */
    if (hasF && ((st = velocity_rate(s, &mo, t, state, nstate, x)) ||
                 (st = top_partials(s, &mo, NZ_PIECE_F, 0, t, state, nstate, y, NULL)))) goto done;
    for (int i = 0; i < k; i++) r[i] = x[i] - y[i] - force[i];
    break;
  case NZ_FORM_DIFFERENCE:    /* x = dF^(n)/dq^(n), y = dF^(n-1)/dq^(n-1) */
    if (hasF && (st = top_partials(s, &mo, NZ_PIECE_F, n, t, state, nstate, x, y))) goto done;
    for (int i = 0; i < k; i++) r[i] = n * x[i] - (n + 1) * y[i] - force[i];
    break;
  case NZ_FORM_EULER:         /* x = d/dt dF^(n-1)/dq^(n) = d/dt dF/dq', y = dF^(n-1)/dq^(n-1) */
    if (hasF && ((st = velocity_rate(s, &mo, t, state, nstate, x)) ||
                 (st = top_partials(s, &mo, NZ_PIECE_F, n - 1, t, state, nstate, y, NULL)))) goto done;
    for (int i = 0; i < k; i++) r[i] = n * x[i] - y[i] - force[i];
    break;
  case NZ_FORM_APPELL:
  case NZ_FORM_EXTREMAL:      /* x = dF^(n)/dq^(n), y = dF_0^(n)/dq^(n) */
    if (hasF && ((st = top_partials(s, &mo, NZ_PIECE_F, n, t, state, nstate, x, NULL)) ||
                 (st = frozen_partial(s, &mo, n, t, state, nstate, y)))) goto done;
    if (form == NZ_FORM_EXTREMAL && (st = force_rate_term(s, &mo, n, t, state, nstate, z))) goto done;
    for (int i = 0; i < k; i++) r[i] = (x[i] - (n + 1) * y[i]) / n - force[i] - z[i];
    break;
  case NZ_FORM_WASSMUTH:
    if ((st = acceleration_energy_partial(s, &mo, n, t, state, nstate, x))) goto done;
    for (int i = 0; i < k; i++) r[i] = x[i] - force[i];
    break;
  default:
    st = NZ_EARG;
  }
  if (terms && terms->force) memcpy(terms->force, force, (size_t)k * sizeof(double));
done:
  nz_motion_free(&mo);
  free(a);
  return st;
}

int nz_operator_N(const nz_system *s, int m, double t, const double *const *state, int nstate,
                  double *out)
{
  int k = s->k;
  double *below = malloc((size_t)k * sizeof(double));
  if (!below) return NZ_ENOMEM;
  nz_motion mo = { 0 };
  int st = top_partials(s, &mo, NZ_PIECE_F, m, t, state, nstate, out, below);
  if (!st)
    for (int i = 0; i < k; i++) out[i] -= 2.0 * below[i];
  nz_motion_free(&mo);
  free(below);
  return st;
}

int nz_operator_E(const nz_system *s, int m, double t, const double *const *state, int nstate,
                  double *out)
{
  int k = s->k;
  double *below = malloc((size_t)k * sizeof(double));
  if (!below) return NZ_ENOMEM;
  nz_motion mo = { 0 };
  int st = velocity_rate(s, &mo, t, state, nstate, out);
  if (!st) st = top_partials(s, &mo, NZ_PIECE_F, m - 1, t, state, nstate, below, NULL);
  if (!st)
    for (int i = 0; i < k; i++) out[i] -= below[i];
  nz_motion_free(&mo);
  free(below);
  return st;
}

int nz_partial(const nz_system *s, int m, double t, const double *const *state, int nstate,
               double *out)
{
  nz_motion mo = { 0 };
  int st = top_partials(s, &mo, NZ_PIECE_F, m, t, state, nstate, out, NULL);
  nz_motion_free(&mo);
  return st;
}

int nz_top_coefficient(const nz_system *s, int m, double t, const double *const *state,
                       int nstate, double *out)
{
  nz_motion mo;
  int k = s->k;
  int st = nz_motion_init(&mo, k, 2, m - 1, k, t, state, nstate);
  if (st) return st;
  for (int i = 0; i < k; i++) nz_motion_seed_level(&mo, i, i, m);   /* touches b_{i,m-1} only */
  st = nz_motion_eval(s, NZ_PIECE_F, 0, &mo, NULL);
  if (!st) {
    double f = nz_factorial(m - 1);
    for (int i = 0; i < k; i++) out[i] = f * nz_jet_tangent(mo.out[0], i)[m - 1];
  }
  nz_motion_free(&mo);
  return st;
}

/* Nielsen's form (n = 1) is affine in q'': h = r(0) and M is its derivative
 * along q'' (docs/theory.md §11), on jets.  dF/dq and the force are
 * computed once. */
int nz_mass_bias(const nz_system *s, double t, const double *q, const double *qd, double *M,
                 double *h)
{
  int k = s->k, st;
  if (s->mass_bias && (st = s->mass_bias(s->mass_bias_ctx, t, q, qd, M, h)) != NZ_EARG) return st;
  double *buf = calloc((size_t)(5 * k), sizeof(double));
  if (!buf) return NZ_ENOMEM;
  double *force = buf, *dFq = buf + k, *dF1 = buf + 2 * k, *qdd = buf + 3 * k, *ej = buf + 4 * k;
  const double *state[3] = { q, qd, qdd };   /* q'' = 0 */
  nz_motion mo = { 0 };   /* the evaluations of F at order 1 share its jets */
  memset(M, 0, (size_t)k * (size_t)k * sizeof(double));
  if ((st = generalized_force(s, &mo, t, state, 3, force))) goto done;
  if (nz_system_has(s, NZ_PIECE_F)) {
    if ((st = top_partials(s, &mo, NZ_PIECE_F, 0, t, state, 3, dFq, NULL))) goto done;
    if ((st = top_partials(s, &mo, NZ_PIECE_F, 1, t, state, 3, dF1, NULL))) goto done;
  }
  for (int i = 0; i < k; i++) h[i] = dF1[i] - 2.0 * dFq[i] - force[i];
  if (!nz_system_has(s, NZ_PIECE_F)) goto done;
  /* the size of the terms of h, which may cancel in it */
  double tmax = 0.0, mmax = 0.0;
  for (int i = 0; i < k; i++) tmax = fmax(tmax, fmax(fabs(dF1[i]), fmax(fabs(2.0 * dFq[i]), fabs(force[i]))));
  /* Column j of M: the residual is affine in q'', so the residual at
   * q'' = e_j less h, k evaluations as cheap as h's. */
  for (int j = 0; j < k; j++) {
    qdd[j] = 1.0;
    st = top_partials(s, &mo, NZ_PIECE_F, 1, t, state, 3, dF1, NULL);
    qdd[j] = 0.0;
    if (st) goto done;
    for (int i = 0; i < k; i++) M[i * k + j] = (dF1[i] - 2.0 * dFq[i] - force[i]) - h[i];
  }
  /* That difference loses eps times the terms of h, which may cancel
   * (T = q'^2/2 + q'/(-1.5 q): terms of 1/q^2 and h = 0, and M came out 2
   * or 0 for 1 at q = 1e-8, 1e-10): with terms 1e4 times M or more, take
   * each column again as the derivative of dF^(1)/dq' along q''_j, exact,
   * at twice the cost. */
  for (int e = 0; e < k * k; e++) mmax = fmax(mmax, fabs(M[e]));
  if (!(tmax <= 1e4 * mmax))
    for (int j = 0; j < k; j++) {
      ej[j] = 1.0;
      nz_state_direction along = { 0.0, qdd, qdd, ej };   /* qdd: zeros */
      st = top_partials_along(s, &mo, NZ_PIECE_F, 1, t, state, 3, dF1, NULL, &along, dFq);
      ej[j] = 0.0;
      if (st) goto done;
      for (int i = 0; i < k; i++) M[i * k + j] = dFq[i];
    }
done:
  nz_motion_free(&mo);
  free(buf);
  return st;
}

int nz_force_velocity_jacobian(const nz_system *s, double t, const double *q, const double *qd,
                               double *J)
{
  int k = s->k, st;
  const double *state[2] = { q, qd };
  memset(J, 0, (size_t)k * (size_t)k * sizeof(double));
  if (!nz_system_has(s, NZ_PIECE_Q)) return NZ_OK;
  nz_motion mo;
  if ((st = nz_motion_init(&mo, k, 2, 0, k, t, state, 2))) return st;
  for (int j = 0; j < k; j++) nz_motion_seed_slot(&mo, j, j, 1);
  st = nz_motion_eval(s, NZ_PIECE_Q, 0, &mo, NULL);
  if (!st)
    for (int i = 0; i < k; i++)
      for (int j = 0; j < k; j++) J[i * k + j] = nz_jet_tangent(mo.out[i], j)[0];
  nz_motion_free(&mo);
  return st;
}

int nz_force_power(const nz_system *s, double t, const double *q, const double *qd, double *P)
{
  int k = s->k, st;
  const double *state[2] = { q, qd };
  *P = 0.0;
  if (!nz_system_has(s, NZ_PIECE_Q)) return NZ_OK;
  nz_motion mo;
  if ((st = nz_motion_init(&mo, k, 2, 0, 0, t, state, 2))) return st;
  st = nz_motion_eval(s, NZ_PIECE_Q, 0, &mo, NULL);
  if (!st)
    for (int i = 0; i < k; i++) *P += mo.out[i]->c[0] * qd[i];
  nz_motion_free(&mo);
  return st;
}

int nz_lagrangian_time_partial(const nz_system *s, double t, const double *q, const double *qd,
                               double *dLdt)
{
  int k = s->k, st = NZ_OK;
  const double *state[2] = { q, qd };
  nz_motion mo;
  *dLdt = 0.0;
  if ((st = nz_motion_init(&mo, k, 2, 0, 1, t, state, 2))) return st;
  nz_jet_free(mo.t);
  if (!(mo.t = nz_jet_alloc(0, 1))) { nz_motion_free(&mo); return NZ_ENOMEM; }
  nz_jet_set_variable(mo.t, t, 0);
  if (nz_system_has(s, NZ_PIECE_F)) {
    if ((st = nz_motion_eval(s, NZ_PIECE_F, 0, &mo, NULL))) goto done;
    *dLdt += nz_jet_tangent(mo.out[0], 0)[0];
  }
  if (nz_system_has(s, NZ_PIECE_V)) {
    if ((st = nz_motion_eval(s, NZ_PIECE_V, 0, &mo, NULL))) goto done;
    *dLdt -= nz_jet_tangent(mo.out[0], 0)[0];
  }
done:
  nz_motion_free(&mo);
  return st;
}

int nz_kinetic_parts(const nz_system *s, double t, const double *q, const double *qd,
                     const double *qdd, double *T0, double *T1, double *rate)
{
  int k = s->k, st;
  const double *state[3] = { q, qd, qdd };
  nz_piece p = nz_system_has(s, NZ_PIECE_T) ? NZ_PIECE_T : NZ_PIECE_F;
  nz_motion mo;
  if ((st = nz_motion_init(&mo, k, 2, 1, 1, t, state, 3))) return st;
  nz_jet **scaled = nz_jets_alloc(k, 1, 1);     /* s q'(t) at s = 0, tangent along s */
  if (!scaled) { nz_motion_free(&mo); return NZ_ENOMEM; }
  for (int i = 0; i < k; i++) {
    nz_jet_tangent(scaled[i], 0)[0] = qd[i];
    nz_jet_tangent(scaled[i], 0)[1] = qdd[i];
  }
  st = nz_motion_eval(s, p, 0, &mo, scaled);
  if (!st) {
    const nz_jet *T = mo.out[0];
    *T0 = T->c[0];
    *T1 = nz_jet_tangent(T, 0)[0];
    *rate = nz_jet_tangent(T, 0)[1] + 2.0 * T->c[1];
  }
  nz_jets_free(scaled, k);
  nz_motion_free(&mo);
  return st;
}

int nz_accel(const nz_system *s, double t, const double *q, const double *qd, double rcond_min,
             double *qdd, nz_solve_info *info)
{
  int k = s->k, fast;
  if (s->accel && (fast = s->accel(s->mass_bias_ctx, t, q, qd, rcond_min, qdd, info)) != NZ_EARG)
    return fast;
  double *buf = malloc(((size_t)k * (size_t)k + 2 * (size_t)k) * sizeof(double));
  if (!buf) return NZ_ENOMEM;
  double *M = buf, *h = M + (size_t)k * k, *rhs = h + k;
  int st = nz_mass_bias(s, t, q, qd, M, h);
  if (!st) {
    for (int i = 0; i < k; i++) rhs[i] = -h[i];
    st = nz_solve_spd(k, M, rhs, qdd, rcond_min, info);
  }
  free(buf);
  return st;
}

int nz_energy(const nz_system *s, double t, const double *q, const double *qd, double *T,
              double *V, double *F, double *H)
{
  int k = s->k, st = NZ_OK;
  const double *state[2] = { q, qd };
  nz_motion mo;
  *T = NAN;
  *V = 0.0;
  *F = 0.0;
  *H = 0.0;
  if ((st = nz_motion_init(&mo, k, 2, 0, k, t, state, 2))) return st;
  if (nz_system_has(s, NZ_PIECE_T)) {
    if ((st = nz_motion_eval(s, NZ_PIECE_T, 0, &mo, NULL))) goto done;
    *T = mo.out[0]->c[0];
  }
  if (nz_system_has(s, NZ_PIECE_V)) {
    if ((st = nz_motion_eval(s, NZ_PIECE_V, 0, &mo, NULL))) goto done;
    *V = mo.out[0]->c[0];
  }
  if (nz_system_has(s, NZ_PIECE_F)) {
    for (int i = 0; i < k; i++) nz_motion_seed_slot(&mo, i, i, 1);
    if ((st = nz_motion_eval(s, NZ_PIECE_F, 0, &mo, NULL))) goto done;
    *F = mo.out[0]->c[0];
    for (int i = 0; i < k; i++) *H += qd[i] * nz_jet_tangent(mo.out[0], i)[0];
  }
  *H += *V - *F;    /* H = sum q' dL/dq' - L, L = F - V */
done:
  nz_motion_free(&mo);
  return st;
}
