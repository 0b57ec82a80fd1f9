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
   * next step; PH_COUNT counts it (after the projection); PH_EVENTS looks
   * at events ev_next, ev_next + 1, ... of the step just taken. */
  enum { PH_STEP, PH_COUNT, PH_EVENTS } phase;
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
  if (!r->y || !r->ytry || !r->bt || !r->by || !r->bacc || !r->broot || !r->has_root || !r->dirs || !r->gvals ||
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
  free(r);
}

/* record(t, y): the state with q'' and lambda there (and the root of a top
 * integrator), as mech.ode_accel gives them to the Lua loop. */
static int record(nz_run *r, const nz_system *s)
{
  int n = r->n, k = r->k;
  double *acc = r->bacc + (size_t)n * (size_t)(k + r->nc);
  int st = nz_ode_accel(r->o, s, r->t, r->y, acc);
  if (st) return st;
  r->bt[n] = r->t;
  memcpy(r->by + (size_t)n * (size_t)r->dim, r->y, (size_t)r->dim * sizeof(double));
  const double *root = nz_ode_root(r->o);
  r->has_root[n] = root != NULL;
  if (root) memcpy(r->broot + (size_t)n * (size_t)k, root, (size_t)k * sizeof(double));
  r->n = n + 1;
  return NZ_OK;
}

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
static int one_step(nz_run *r, const nz_system *s)
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
    st = nz_ode_step(r->o, s, &t, r->tout, &h, r->ytry);
    if (st) return st;
  }
  double *swap = r->y;
  r->y = r->ytry;
  r->ytry = swap;
  r->t = t;
  r->h = h;
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
        if ((*status = one_step(r, s))) return NZ_RUN_FAILED;
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
        r->phase = PH_EVENTS;
        r->ev_next = 0;
        if (stalled(r)) return NZ_RUN_STALLED;
        if (pause_step && r->nsteps == pause_step) return NZ_RUN_PAUSED;
      }
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

void nz_run_set_state(nz_run *r, const double *y) { memcpy(r->y, y, (size_t)r->dim * sizeof(double)); }

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
