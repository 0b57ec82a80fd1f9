/* ode_run.c - the stepping loop of sys:simulate in C (see ode_run.h).
 *
 * Each arithmetic step below mirrors a line of the Lua loop in
 * lua/nz/simulate.lua (run()), in the same order and on the same doubles:
 * change one and the other together, or the two loops stop agreeing to the
 * bit (tests/simulate_loop_spec.lua would say so). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "core/interrupt.h"
#include "mech/constrained.h"
#include "ode/ode_run.h"

struct nz_run {
  nz_ode *o;
  int k, nc, dim;
  nz_run_config c;
  double nout;                    /* output intervals (an integer, as a double) */
  double i;                       /* the interval being stepped, 1 .. nout */
  int started;                    /* the point at t0 is recorded */
  int in_interval;                /* tout (and the fixed steps) of interval i are set */
  double t, h, tout, hfixed, nfixed;
  double *y, *ytry;               /* the state, and the copy a step works on */
  unsigned long nsteps;
  double window_t, advance;       /* stall detection */
  int cap, n;                     /* the output buffer: n of cap points */
  double *bt, *by, *bacc, *broot;
  unsigned char *has_root;
  /* Where a step's work stands, so that a return for an event, a
   * projection or a pause resumes in the middle of it: PH_STEP takes the
   * next step; PH_COUNT counts it (after the projection); PH_GRID records
   * the output points inside it (dense output); PH_EVENTS looks
   * at events ev_next, ev_next + 1, ... of the step just taken. */
  enum { PH_STEP, PH_COUNT, PH_GRID, PH_EVENTS } phase;
  int nev, ev_next;
  int *dirs;                      /* nev directions */
  double *gvals;                  /* nev: each event's value at the last accepted step */
  nz_run_event_fn event_fn;
  void *event_ctx;
  int *orders;                    /* nc, when projecting */
  double ta;                      /* the step's start; its state is ytry once it is taken */
  int ev_e;                       /* the last crossing: event, values */
  double ev_ga, ev_gb;
  nz_run_failure failure;
  /* Dense output (ode_run.h): four slots of (t, y, f) rotated from step
   * to step: the starts of the two steps before (sp, sq: nprev of them
   * joined on), the step's start (sa) and its end (sb); start_ok: sb holds
   * the state the next step starts from (no projection in between). */
  struct slot { double t; double *y, *f; int f_ok; } slots[4], *sq, *sp, *sa, *sb;
  int nprev, start_ok;
  int gridded;                    /* a step failed: the grid sets the steps from there */
  double *yi;                     /* an interpolated state */
  double *coef, z[4];             /* the step's divided differences (dim x 12), its nodes */
  int coef_ok;
  unsigned long ninterp, nforced;
};

double nz_run_clock(void)
{
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int finite_positive(double x) { return isfinite(x) && x > 0.0; }

nz_run *nz_run_alloc(nz_ode *o, int k, int nc, const nz_run_config *cfg, const double *y0)
{
  if (!o || k < 1 || nc < 0 || cfg->capacity < 1 || !isfinite(cfg->t0) || !(cfg->t1 > cfg->t0) ||
      !isfinite(cfg->t1) || !finite_positive(cfg->dt) || !finite_positive(cfg->h0) ||
      !(cfg->step == 0.0 || finite_positive(cfg->step)) || cfg->stall_window < 1 || cfg->nevents < 0 ||
      (cfg->nevents > 0 && !cfg->directions) || (cfg->project_tol > 0.0 && nc > 0 && !cfg->orders))
    return NULL;
  nz_run *r = calloc(1, sizeof *r);
  if (!r) return NULL;
  r->o = o;
  r->k = k;
  r->nc = nc;
  r->dim = nz_ode_dim(o);
  r->c = *cfg;
  r->cap = cfg->capacity;
  size_t cap = (size_t)r->cap, dim = (size_t)r->dim, kk = (size_t)k, ncc = (size_t)nc;
  r->y = malloc(dim * sizeof(double));
  r->ytry = malloc(dim * sizeof(double));
  r->bt = malloc(cap * sizeof(double));
  r->by = malloc(cap * dim * sizeof(double));
  r->bacc = malloc(cap * (kk + ncc) * sizeof(double) + 1);
  r->broot = malloc(cap * kk * sizeof(double));
  r->has_root = calloc(cap, 1);
  r->nev = cfg->nevents;
  r->dirs = malloc((size_t)r->nev * sizeof(int) + 1);
  r->gvals = malloc((size_t)r->nev * sizeof(double) + 1);
  r->orders = malloc(ncc * sizeof(int) + 1);
  r->yi = malloc(dim * sizeof(double));
  r->coef = malloc(12 * dim * sizeof(double));
  if (!r->coef) r->yi = (free(r->yi), NULL);
  for (int j = 0; j < 4; j++) {
    r->slots[j].y = malloc(dim * sizeof(double));
    r->slots[j].f = malloc(dim * sizeof(double));
    if (!r->slots[j].y || !r->slots[j].f) r->yi = (free(r->yi), NULL);
  }
  r->sq = &r->slots[0];
  r->sp = &r->slots[1];
  r->sa = &r->slots[2];
  r->sb = &r->slots[3];
  /* Dense output needs adaptive steps and a tolerance to control it by. */
  r->c.dense = cfg->dense && cfg->step == 0.0 && finite_positive(cfg->rtol + cfg->atol) && cfg->rtol >= 0.0 &&
               cfg->atol >= 0.0;
  if (!r->yi ||
      !r->y || !r->ytry || !r->bt || !r->by || !r->bacc || !r->broot || !r->has_root || !r->dirs || !r->gvals ||
      !r->orders) {
    nz_run_free(r);
    return NULL;
  }
  if (r->nev) memcpy(r->dirs, cfg->directions, (size_t)r->nev * sizeof(int));
  if (cfg->project_tol > 0.0 && nc > 0) memcpy(r->orders, cfg->orders, ncc * sizeof(int));
  r->c.directions = r->c.orders = NULL;          /* the caller's arrays may go */
  memcpy(r->y, y0, dim * sizeof(double));
  r->t = cfg->t0;
  r->h = cfg->h0;
  r->window_t = cfg->t0;
  /* local nout = math.ceil((cfg.t1 - cfg.t0) / cfg.dt - 1e-9) */
  r->nout = ceil((cfg->t1 - cfg->t0) / cfg->dt - 1e-9);
  if (!(r->nout >= 0.0)) r->nout = 0.0;          /* -0 */
  r->i = 1.0;
  return r;
}

void nz_run_free(nz_run *r)
{
  if (!r) return;
  free(r->y);
  free(r->ytry);
  free(r->bt);
  free(r->by);
  free(r->bacc);
  free(r->broot);
  free(r->has_root);
  free(r->dirs);
  free(r->gvals);
  free(r->orders);
  free(r->yi);
  free(r->coef);
  for (int j = 0; j < 4; j++) {
    free(r->slots[j].y);
    free(r->slots[j].f);
  }
  free(r);
}

/* record(t, y): the state with q'' and lambda there (and the root of a top
 * integrator), as mech.ode_accel gives them to the Lua loop. */
static int record_at(nz_run *r, const nz_system *s, double t, const double *y)
{
  int n = r->n, k = r->k;
  double *acc = r->bacc + (size_t)n * (size_t)(k + r->nc);
  int st = nz_ode_accel(r->o, s, t, y, acc);
  if (st) return st;
  r->bt[n] = t;
  memcpy(r->by + (size_t)n * (size_t)r->dim, y, (size_t)r->dim * sizeof(double));
  const double *root = nz_ode_root(r->o);
  r->has_root[n] = root != NULL;
  if (root) memcpy(r->broot + (size_t)n * (size_t)k, root, (size_t)k * sizeof(double));
  r->n = n + 1;
  return NZ_OK;
}

static int record(nz_run *r, const nz_system *s) { return record_at(r, s, r->t, r->y); }

/* Output time j of the grid (the last one is t1 itself). */
static double grid_time(const nz_run *r, double j) { return j == r->nout ? r->c.t1 : r->c.t0 + j * r->c.dt; }

/* The start of interval i: its output time and, for fixed steps, equal
 * steps no longer than `step` that land on it. */
static void begin_interval(nz_run *r)
{
  r->tout = r->i == r->nout ? r->c.t1 : r->c.t0 + r->i * r->c.dt;
  if (r->c.step > 0.0) {
    double n = ceil((r->tout - r->t) / r->c.step - 1e-9);
    r->nfixed = n > 1.0 ? n : 1.0;               /* math.max(1, ...) */
    r->hfixed = (r->tout - r->t) / r->nfixed;
  }
  r->in_interval = 1;
}

/* One step from (t, y), committed only when it succeeds (the Lua loop keeps
 * its t, h, y when the step raises). */
static int one_step(nz_run *r, const nz_system *s, double tlimit)
{
  double t = r->t, h = r->h;
  memcpy(r->ytry, r->y, (size_t)r->dim * sizeof(double));
  int st;
  if (r->c.step > 0.0) {
    st = nz_ode_step_fixed(r->o, s, &t, r->hfixed, r->ytry);
    if (st) return st;
    r->nfixed -= 1.0;
    if (r->nfixed == 0.0) t = r->tout;
  } else {
    st = nz_ode_step(r->o, s, &t, tlimit, &h, r->ytry);
    if (st) return st;
  }
  double *swap = r->y;
  r->y = r->ytry;
  r->ytry = swap;
  r->t = t;
  r->h = h;
  return NZ_OK;
}

/* One component's Hermite interpolant in Newton form: ng (<= 4) groups of
 * nodes z[g], each of multiplicity m (2 or 3), with d[3 g + j] the j-th
 * derivative there; c gets the m ng coefficients.  Its last Newton term
 * (what the last node condition adds: the error of the polynomial without
 * it) is the error estimate, on the safe side.  (The terms of a whole last
 * group, the error of the polynomial of one step fewer, were tried: on a
 * pendulum at rtol 1e-12 they made 2487 of 20000 output points step ends,
 * for errors 3x below the run's own at its step ends; the last term makes
 * 40 of them step ends and keeps the points' error at the step ends'
 * (1.4e-11 against 1.2e-11), see tests/simulate_dense_spec.lua.) */
static void hermite_coef(int m, int ng, const double *z, const double *d, double *c)
{
  static const double fact[] = { 1.0, 1.0, 2.0 };
  int n = m * ng;
  for (int j = 0; j < n; j++) c[j] = d[3 * (j / m)];
  /* Divided differences, a column at a time, in place from the bottom: over
   * nodes of one group (o < m there) they are the derivatives over o!. */
  for (int o = 1; o < n; o++)
    for (int j = n - 1; j >= o; j--)
      c[j] = j / m == (j - o) / m ? d[3 * (j / m) + o] / fact[o] : (c[j] - c[j - 1]) / (z[j / m] - z[(j - o) / m]);
}

/* The interpolant at tau: the Newton form's partial sums over the first
 * 2, 3, ... ng groups are the interpolants of those nodes alone (the
 * coefficients of a node do not depend on the nodes after it), each with
 * its last term as its estimate; out gets the one whose estimate, relative
 * to atol + rtol |value| (and |derivative| when the derivative is an output,
 * deriv), is the smallest.  The highest degree is the most accurate on a
 * smooth motion; a lower one wins where the step ends carry errors (at the
 * tolerance, not smooth from step to step) that a high-degree polynomial
 * amplifies: bsimp, msbdf, msadams. */
static void hermite_eval(int m, int ng, const double *z, const double *c, double tau, double atol, double rtol,
                         int deriv, double out[4])
{
  int n = m * ng;
  double w = 1.0, dw = 0.0, v = 0.0, dv = 0.0, best = HUGE_VAL;
  for (int j = 0; j < n; j++) {
    v += c[j] * w;
    dv += c[j] * dw;
    if (j >= 2 * m - 1 && (j + 1) % m == 0) {  /* the interpolant of the first (j + 1) / m groups */
      double e = c[j] * w, de = c[j] * dw;
      double ratio = fabs(e) / (atol + rtol * fabs(v));
      if (deriv) ratio = fmax(ratio, fabs(de) / (atol + rtol * fabs(dv)));
      if (!(ratio >= best)) {               /* NaN: taken, for the caller to refuse */
        best = ratio;
        out[0] = v;
        out[1] = dv;
        out[2] = e;
        out[3] = de;
      }
    }
    dw = dw * (tau - z[j / m]) + w;
    w *= tau - z[j / m];
  }
}

static int slot_f(nz_run *r, const nz_system *s, struct slot *sl)
{
  if (sl->f_ok) return NZ_OK;
  int st = nz_ode_rhs(r->o, s, sl->t, sl->y, sl->f);
  sl->f_ok = st == NZ_OK;
  return st;
}

/* The divided differences of the step's interpolant, once per step (12 per
 * component), for every output point and event time inside it. */
static int dense_coef(nz_run *r, const nz_system *s)
{
  if (r->coef_ok) return NZ_OK;
  struct slot *sl[4] = { r->sa, r->sb, r->sp, r->sq };
  int ng = 2 + r->nprev, k = r->k, st;
  for (int g = 0; g < ng; g++)
    if ((st = slot_f(r, s, sl[g]))) return st;
  double d[12];
  for (int g = 0; g < ng; g++) r->z[g] = sl[g]->t;
  for (int i = 0; i < k; i++) {
    for (int g = 0; g < ng; g++) {
      d[3 * g] = sl[g]->y[i];
      d[3 * g + 1] = sl[g]->y[k + i];
      d[3 * g + 2] = sl[g]->f[k + i];
    }
    hermite_coef(3, ng, r->z, d, r->coef + 12 * i);
  }
  for (int i = 2 * k; i < r->dim; i++) {
    for (int g = 0; g < ng; g++) {
      d[3 * g] = sl[g]->y[i];
      d[3 * g + 1] = sl[g]->f[i];
    }
    hermite_coef(2, ng, r->z, d, r->coef + 12 * i);
  }
  r->coef_ok = 1;
  return NZ_OK;
}

/* The state at tau from the interpolant of the step from sa to sb (joined
 * with the nprev steps before): *ok when every component's estimate meets
 * atol + rtol |y_i|.  q from (q, q', q''), q' as its derivative, every
 * other component from (y, f). */
static int interpolate(nz_run *r, const nz_system *s, double tau, double *y, int *ok)
{
  int st = dense_coef(r, s);
  if (st) return st;
  int ng = 2 + r->nprev, k = r->k;
  double out[4], rtol = r->c.rtol, atol = r->c.atol;
  *ok = 1;
  for (int i = 0; i < k; i++) {
    hermite_eval(3, ng, r->z, r->coef + 12 * i, tau, atol, rtol, 1, out);
    y[i] = out[0];
    y[k + i] = out[1];
    if (!(fabs(out[2]) <= atol + rtol * fabs(out[0])) || !(fabs(out[3]) <= atol + rtol * fabs(out[1]))) *ok = 0;
  }
  for (int i = 2 * k; i < r->dim; i++) {
    hermite_eval(2, ng, r->z, r->coef + 12 * i, tau, atol, rtol, 0, out);
    y[i] = out[0];
    if (!(fabs(out[2]) <= atol + rtol * fabs(out[0]))) *ok = 0;
  }
  return NZ_OK;
}

/* A step with dense output: towards t1, and taken again from its start,
 * ending at an output point inside it, when the interpolant's estimate
 * there exceeds the tolerance (ode_run.h). */
static int dense_step(nz_run *r, const nz_system *s)
{
  if (r->start_ok) {                 /* the last step's end starts this one */
    struct slot *tmp = r->sq;
    r->sq = r->sp;
    r->sp = r->sa;
    r->sa = r->sb;
    r->sb = tmp;
    r->nprev = r->nprev < 2 ? r->nprev + 1 : 2;
  } else {
    r->sa->t = r->t;
    memcpy(r->sa->y, r->y, (size_t)r->dim * sizeof(double));
    r->sa->f_ok = 0;
    r->nprev = 0;
  }
  r->start_ok = 0;
  double tlimit = r->gridded ? r->tout : r->c.t1, h = r->h;
  for (;;) {
    int st = one_step(r, s, tlimit);
    /* A step that fails (a singular M, a user function's error past some
     * time) is taken again as the grid would take it, and so are the steps
     * after it: the run creeps up to the failure an output interval at a
     * time and keeps what it computed up to there, as without dense output
     * (the step does not commit when it fails). */
    if (st && !r->gridded && tlimit > r->tout && !nz_interrupt_requested()) {
      r->gridded = 1;
      r->h = h;
      nz_ode_reset(r->o);
      tlimit = r->tout;
      continue;
    }
    if (st) return st;
    r->sb->t = r->t;
    memcpy(r->sb->y, r->y, (size_t)r->dim * sizeof(double));
    r->sb->f_ok = 0;
    r->coef_ok = 0;
    double bad = 0.0;
    int found = 0;
    for (double j = r->i; j <= r->nout; j += 1.0) {
      double tj = grid_time(r, j);
      if (!(tj < r->t)) break;
      int ok;
      if ((st = interpolate(r, s, tj, r->yi, &ok))) return st;
      if (ok && r->c.project_tol > 0.0 && r->nc > 0) {
        /* projecting: a point off the constraints by more than project_tol
         * (the interpolant is not on them) is made a step end, which the
         * run then projects */
        double v;
        if ((st = nz_state_violation(s, r->orders, tj, r->yi, r->yi + r->k, &v))) {
          r->failure = NZ_RUN_FAIL_VIOLATION;
          return st;
        }
        ok = v <= r->c.project_tol;
      }
      if (!ok) {
        bad = tj;
        found = 1;
        break;
      }
    }
    if (!found || !(bad > r->ta)) break;
    double *swap = r->y;             /* back to the step's start (ytry holds it) */
    r->y = r->ytry;
    r->ytry = swap;
    r->t = r->ta;
    r->h = h;
    /* GSL's evolve object keeps what its last step left (a one-step method
     * given an earlier state rejects its steps down to nothing) and a
     * multistep method its history: both start again (ode.c keeps the
     * counts). */
    nz_ode_reset(r->o);
    tlimit = bad;
    r->nforced++;
  }
  r->start_ok = 1;
  return NZ_OK;
}

/* watch(): a run whose last window of steps advanced t by less than a
 * fraction of the span stalls. */
static int stalled(nz_run *r)
{
  if (r->nsteps % r->c.stall_window != 0) return 0;
  if (r->t - r->window_t < r->c.stall_fraction * (r->c.t1 - r->c.t0)) {
    r->advance = r->t - r->window_t;
    return 1;
  }
  r->window_t = r->t;
  return 0;
}

static int fail(nz_run *r, nz_run_failure what, int st, int *status)
{
  r->failure = what;
  *status = st;
  return NZ_RUN_FAILED;
}

nz_run_status nz_run_advance(nz_run *r, const nz_system *s, unsigned long pause_step, double pause_wall,
                             int *status)
{
  *status = NZ_OK;
  r->failure = NZ_RUN_FAIL_ODE;
  if (r->nev && !r->event_fn) return fail(r, NZ_RUN_FAIL_EVENT, NZ_EARG, status);
  if (!r->started) {
    if ((*status = record(r, s))) return NZ_RUN_FAILED;
    r->started = 1;
    for (int e = 0; e < r->nev; e++) {   /* gvals[i] = event_value(ev, t, y) */
      int st = r->event_fn(r->event_ctx, e, r->t, r->y, &r->gvals[e]);
      if (st) return fail(r, NZ_RUN_FAIL_EVENT, st, status);
    }
  }
  int projecting = r->c.project_tol > 0.0 && r->nc > 0;
  for (;;) {
    if (r->i > r->nout) return NZ_RUN_DONE;
    if (!r->in_interval) begin_interval(r);
    while (r->phase != PH_STEP || r->t < r->tout) {
      if (r->phase == PH_STEP) {
        if (nz_interrupt_requested()) return NZ_RUN_INTERRUPTED;
        r->ta = r->t;
        if ((*status = r->c.dense ? dense_step(r, s) : one_step(r, s, r->tout))) return NZ_RUN_FAILED;
        r->phase = PH_COUNT;
        if (projecting) {                /* project(t): above the tolerance, the caller projects */
          double v;
          int st = nz_state_violation(s, r->orders, r->t, r->y, r->y + r->k, &v);
          if (st) return fail(r, NZ_RUN_FAIL_VIOLATION, st, status);
          if (!(v <= r->c.project_tol)) return NZ_RUN_PROJECT;   /* NaN too, as project() says */
        }
      }
      if (r->phase == PH_COUNT) {
        r->nsteps++;
        r->phase = r->c.dense ? PH_GRID : PH_EVENTS;
        r->ev_next = 0;
        if (stalled(r)) return NZ_RUN_STALLED;
        if (pause_step && r->nsteps == pause_step) return NZ_RUN_PAUSED;
      }
      while (r->phase == PH_GRID && r->tout < r->t) {   /* the output points inside the step */
        int ok;
        if (r->n == r->cap) return NZ_RUN_FULL;
        if ((*status = interpolate(r, s, r->tout, r->yi, &ok))) return NZ_RUN_FAILED;
        if ((*status = record_at(r, s, r->tout, r->yi))) return NZ_RUN_FAILED;
        r->ninterp++;
        r->i += 1.0;
        begin_interval(r);
      }
      r->phase = r->phase == PH_GRID ? PH_EVENTS : r->phase;
      while (r->ev_next < r->nev) {      /* events e = ev_next .. nev - 1 of this step */
        int e = r->ev_next;
        double g;
        int st = r->event_fn(r->event_ctx, e, r->t, r->y, &g);
        if (st) return fail(r, NZ_RUN_FAIL_EVENT, st, status);
        double ga = r->gvals[e];
        r->gvals[e] = g;
        r->ev_next = e + 1;
        if (nz_event_crosses(r->dirs[e], ga, g)) {
          r->ev_e = e;
          r->ev_ga = ga;
          r->ev_gb = g;
          return NZ_RUN_EVENT;
        }
      }
      r->phase = PH_STEP;
      if (pause_wall > 0.0 && nz_run_clock() >= pause_wall) return NZ_RUN_PAUSED;
    }
    if (r->n == r->cap) return NZ_RUN_FULL;
    if ((*status = record(r, s))) return NZ_RUN_FAILED;
    r->i += 1.0;
    r->in_interval = 0;
  }
}

void nz_run_set_events(nz_run *r, nz_run_event_fn fn, void *ctx)
{
  r->event_fn = fn;
  r->event_ctx = ctx;
}

/* After a step, ytry holds the state it started from (one_step swaps). */
void nz_run_event(const nz_run *r, int *e, double *ta, const double **ya, double *ga, double *tb,
                  double *gb, const double **yb)
{
  *e = r->ev_e;
  *ta = r->ta;
  *ya = r->ytry;
  *ga = r->ev_ga;
  *tb = r->t;
  *gb = r->ev_gb;
  *yb = r->y;
}

/* The step's own end stays in sb for its interpolant; the next step starts
 * from the projected state, without the step before joined on. */
void nz_run_set_state(nz_run *r, const double *y)
{
  memcpy(r->y, y, (size_t)r->dim * sizeof(double));
  r->start_ok = 0;
}

void nz_run_dense_stats(const nz_run *r, unsigned long *interpolated, unsigned long *forced)
{
  *interpolated = r->ninterp;
  *forced = r->nforced;
}

int nz_run_interpolate(nz_run *r, const nz_system *s, double tau, double *y)
{
  if (!r->c.dense || !r->start_ok || !(tau >= r->sa->t && tau <= r->sb->t)) return NZ_EARG;
  int ok, st = interpolate(r, s, tau, y, &ok);
  return st ? st : ok ? NZ_OK : NZ_EARG;
}

nz_run_failure nz_run_failure_of(const nz_run *r) { return r->failure; }

double nz_run_time(const nz_run *r) { return r->t; }
const double *nz_run_state(const nz_run *r) { return r->y; }
unsigned long nz_run_steps(const nz_run *r) { return r->nsteps; }
double nz_run_stall_advance(const nz_run *r) { return r->advance; }
int nz_run_count(const nz_run *r) { return r->n; }

void nz_run_point(const nz_run *r, int i, double *t, const double **y, const double **acc,
                  const double **root)
{
  *t = r->bt[i];
  *y = r->by + (size_t)i * (size_t)r->dim;
  *acc = r->bacc + (size_t)i * (size_t)(r->k + r->nc);
  *root = r->has_root[i] ? r->broot + (size_t)i * (size_t)r->k : NULL;
}

void nz_run_clear(nz_run *r) { r->n = 0; }
