/* ode_run.c - the stepping loop of sys:simulate (see ode_run.h), over any
 * integrator of the interface of stepper.h: the output grid, the events,
 * the watch on the constraints' drift, the stall and the pauses, in one
 * place for every method. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "core/compensated.h"
#include "core/interrupt.h"
#include "ode/ode_run.h"

struct nz_run {
  nz_stepper *st, *locator;
  int k, nc, dim;
  nz_run_config c;
  nz_run_hooks hooks;
  double nout;                    /* output intervals (an integer, as a double) */
  double i;                       /* the interval being stepped, 1 .. nout */
  int started;                    /* the point at t0 is recorded */
  int in_interval;                /* tout (and the fixed steps) of interval i are set */
  double t, h, tout, hfixed, nfixed;
  double tlo;                     /* fixed steps: the time is t + tlo (one_step) */
  double *y, *ytry;               /* the state, and the copy a step works on */
  unsigned long nsteps;
  long native_from;               /* the first step of machine code throughout (nz_run_native_from) */
  double window_t, advance;       /* stall detection */
  unsigned long window_left;      /* steps to the end of the window (nsteps % window == 0 there) */
  int cap, n;                     /* the output buffer: n of cap points */
  double *bt, *by, *bacc, *broot;
  unsigned char *has_root;
  /* Where a step's work stands, so that a return for an event, a
   * projection or a pause resumes in the middle of it: PH_STEP takes the
   * next step; PH_COUNT counts it (after the projection); PH_EVENTS
   * locates its events; PH_LOCATED hands them over (loc_next, ... of nloc),
   * each after the output points up to it; PH_GRID records the step's
   * other output points (dense output). */
  enum { PH_STEP, PH_COUNT, PH_EVENTS, PH_LOCATED, PH_GRID } phase;
  double *sacc;                   /* 2 (k + nc): accelerations for the step after a jump */
  int nev;
  int *dirs;                      /* nev directions */
  double *gvals;                  /* nev: each event's value at the last accepted step */
  double ta;                      /* the step's start; its state is ytry once it is taken */
  int ev_e;                       /* the event looked at when the hook failed */
  nz_run_failure failure;
  /* Dense output (ode_run.h), from the integrator's dense(); start_ok: the
   * last step is whole and the state its end (no projection since). */
  int start_ok;
  int gridded;                    /* a step failed: the grid sets the steps from there */
  double *yi;                     /* an interpolated state */
  unsigned long ninterp, nforced;
  int exact;                      /* dense output from an exact one, nothing projected: exact_step */
  /* The events located in the last step, in time order. */
  int nloc, loc_next, loc_located;
  double *loc_t, *loc_y;          /* nev times, nev states */
  int *loc_e, *loc_dir;           /* which event, and which way it crossed (1 rising, -1 falling) */
};

double nz_run_clock(void)
{
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int finite_positive(double x) { return isfinite(x) && x > 0.0; }

nz_run *nz_run_alloc(nz_stepper *st, const nz_run_config *cfg, const double *y0)
{
  if (!st) return NULL;
  int k = st->k, nc = st->nc;
  if (k < 1 || nc < 0 || cfg->capacity < 1 || !isfinite(cfg->t0) || !(cfg->t1 > cfg->t0) ||
      !isfinite(cfg->t1) || !finite_positive(cfg->dt) || !finite_positive(cfg->h0) ||
      !(cfg->step == 0.0 || finite_positive(cfg->step)) || cfg->stall_window < 1 || cfg->nevents < 0 ||
      (cfg->nevents > 0 && (!cfg->directions || !finite_positive(cfg->event_tol))) ||
      (cfg->step > 0.0 && !st->ops->step_fixed) || (cfg->step == 0.0 && !st->ops->step))
    return NULL;
  nz_run *r = calloc(1, sizeof *r);
  if (!r) return NULL;
  r->st = st;
  r->locator = cfg->locator;
  r->k = k;
  r->nc = nc;
  r->dim = st->dim;
  r->c = *cfg;
  r->cap = cfg->capacity;
  size_t cap = (size_t)r->cap, dim = (size_t)r->dim, kk = (size_t)k, ncc = (size_t)nc, nev = (size_t)cfg->nevents;
  r->y = malloc(dim * sizeof(double));
  r->ytry = malloc(dim * sizeof(double));
  r->bt = malloc(cap * sizeof(double));
  r->by = malloc(cap * dim * sizeof(double));
  r->bacc = malloc(cap * (kk + ncc) * sizeof(double) + 1);
  r->broot = malloc(cap * kk * sizeof(double));
  r->has_root = calloc(cap, 1);
  r->nev = cfg->nevents;
  r->dirs = malloc(nev * sizeof(int) + 1);
  r->gvals = malloc(nev * sizeof(double) + 1);
  r->sacc = malloc(2 * (kk + ncc) * sizeof(double));
  r->yi = malloc(dim * sizeof(double));
  r->loc_t = malloc(nev * sizeof(double) + 1);
  r->loc_y = malloc(nev * dim * sizeof(double) + 1);
  r->loc_e = malloc(nev * sizeof(int) + 1);
  r->loc_dir = malloc(nev * sizeof(int) + 1);
  /* Dense output needs adaptive steps and a tolerance to control it by. */
  r->c.dense = cfg->dense && cfg->step == 0.0 && finite_positive(cfg->rtol + cfg->atol) && cfg->rtol >= 0.0 &&
               cfg->atol >= 0.0;
  r->exact = st->exact_dense && r->c.dense && !(cfg->project_tol > 0.0);
  if (!r->yi || !r->sacc || !r->y || !r->ytry || !r->bt || !r->by || !r->bacc || !r->broot || !r->has_root ||
      !r->dirs || !r->gvals || !r->loc_t || !r->loc_y || !r->loc_e || !r->loc_dir ||
      (r->nev > 0 && !r->exact && !r->locator)) {
    nz_run_free(r);
    return NULL;
  }
  if (r->nev) memcpy(r->dirs, cfg->directions, nev * sizeof(int));
  r->c.directions = NULL;                          /* the caller's array may go */
  memcpy(r->y, y0, dim * sizeof(double));
  r->t = r->ta = cfg->t0;
  r->h = cfg->h0;
  r->window_t = cfg->t0;
  r->window_left = cfg->stall_window;
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
  free(r->sacc);
  free(r->yi);
  free(r->loc_t);
  free(r->loc_y);
  free(r->loc_e);
  free(r->loc_dir);
  free(r);
}

/* record(t, y): the state with q'' and lambda there (and the root of a top
 * integrator), as mech.ode_accel gives them to the Lua loop. */
static int record_at(nz_run *r, const nz_system *s, double t, const double *y)
{
  int n = r->n, k = r->k;
  double *acc = r->bacc + (size_t)n * (size_t)(k + r->nc);
  if (r->c.no_accel) memset(acc, 0, (size_t)(k + r->nc) * sizeof(double));
  else {
    int st = r->st->ops->accel(r->st, s, t, y, acc);
    if (st) return st;
  }
  r->bt[n] = t;
  memcpy(r->by + (size_t)n * (size_t)r->dim, y, (size_t)r->dim * sizeof(double));
  const double *root = r->st->ops->root(r->st);
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
    r->hfixed = ((r->tout - r->t) - r->tlo) / r->nfixed;
  }
  r->in_interval = 1;
}

/* One step from (t, y), committed only when it succeeds (the Lua loop keeps
 * its t, h, y when the step raises).
 *
 * Whoever chooses a step keeps the time it ends at to twice the precision
 * (core/compensated.h): an adaptive integrator its own (taylor.c, ode.c),
 * the loop that of its fixed steps, t + tlo.  The last fixed step of an
 * output interval is the rest to the output time, so that the steps sum to
 * it to the last bit: equal steps of the rounded (tout - t) / n would end
 * n times their rounding away, the same at every interval, and a run of
 * 1e8 steps would label its states with times off by that sum.  t is then
 * the output time itself, the rest's own rounding kept in tlo. */
static int one_step(nz_run *r, const nz_system *s, double tlimit)
{
  double t = r->t, h = r->h, tlo = r->tlo;
  int st;
  memcpy(r->ytry, r->y, (size_t)r->dim * sizeof(double));
  if (r->c.step > 0.0) {
    double hstep = r->nfixed == 1.0 ? (r->tout - r->t) - r->tlo : r->hfixed;
    st = r->st->ops->step_fixed(r->st, s, &t, hstep, r->ytry);
    if (st) return st;
    r->nfixed -= 1.0;
    t = r->t;
    nz_dd_add(&t, &tlo, hstep);
    if (r->nfixed == 0.0) {
      tlo += t - r->tout;
      t = r->tout;
    }
  } else {
    st = r->st->ops->step(r->st, s, &t, tlimit, &h, r->ytry);
    if (st) return st;
  }
  double *swap = r->y;
  r->y = r->ytry;
  r->ytry = swap;
  r->t = t;
  r->tlo = tlo;
  r->h = h;
  return NZ_OK;
}

/* The state at tau inside the last step from the integrator's dense
 * output: *ok when it meets the integrator's tolerance there. */
static int interpolate(nz_run *r, const nz_system *s, double tau, double *y, int *ok)
{
  return r->st->ops->dense(r->st, s, tau, y, ok);
}

/* A step with dense output: towards t1, and taken again from its start,
 * ending at an output point inside it, when the interpolant's estimate
 * there exceeds the tolerance (ode_run.h). */
static int dense_step(nz_run *r, const nz_system *s)
{
  r->start_ok = 0;
  int projecting = r->c.project_tol > 0.0;
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
      r->st->ops->reset(r->st);
      tlimit = r->tout;
      continue;
    }
    if (st) return st;
    double bad = 0.0;
    int found = 0;
    for (double j = r->i; j <= r->nout; j += 1.0) {
      double tj = grid_time(r, j);
      if (!(tj < r->t)) break;
      int ok;
      if ((st = interpolate(r, s, tj, r->yi, &ok))) return st;
      if (ok && projecting) {
        /* projecting: a point off the constraints by more than project_tol
         * (the interpolant is not on them) is made a step end, which the
         * run then projects */
        double v;
        if ((st = r->hooks.violation(r->hooks.ctx, tj, r->yi, &v))) {
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
    r->st->ops->reset(r->st);
    tlimit = bad;
    r->nforced++;
  }
  r->start_ok = 1;
  return NZ_OK;
}

/* A step with an exact dense output (Taylor's polynomial: it meets the
 * tolerance everywhere in the step, so no point is checked and no step is
 * taken again for one), towards t1, on y in place (the integrator leaves it
 * as it was when the step fails, and no event needs the step's start).  A
 * step that fails is taken again towards the next output time, as in
 * dense_step, and so are the steps after it. */
static int exact_step(nz_run *r, const nz_system *s)
{
  double t = r->t, h = r->h, tlimit = r->gridded ? r->tout : r->c.t1;
  r->start_ok = 0;
  int st = r->st->ops->step(r->st, s, &t, tlimit, &h, r->y);
  if (st && !r->gridded && tlimit > r->tout && !nz_interrupt_requested()) {
    r->gridded = 1;
    t = r->t;
    h = r->h;
    st = r->st->ops->step(r->st, s, &t, r->tout, &h, r->y);
  }
  if (st) return st;
  r->t = t;
  r->h = h;
  r->start_ok = 1;
  return NZ_OK;
}

/* watch(): a run whose last window of steps advanced t by less than a
 * fraction of the span stalls. */
static int stalled(nz_run *r)
{
  if (--r->window_left != 0) return 0;   /* nsteps % stall_window != 0, without a division per step */
  r->window_left = r->c.stall_window;
  if (r->t - r->window_t < r->c.stall_fraction * (r->c.t1 - r->c.t0)) {
    r->advance = r->t - r->window_t;
    return 1;
  }
  r->window_t = r->t;
  return 0;
}

/* The state at tau inside the last step: the dense output where it meets
 * the tolerance there, else the step integrated again from its start (ta,
 * ytry) by the locator at its own tolerance (ode_run.h). */
static int state_at(nz_run *r, const nz_system *s, double tau, double *y)
{
  if (r->c.dense && r->start_ok) {
    int ok, st = interpolate(r, s, tau, y, &ok);
    if (st || ok) return st;
  }
  nz_stepper *loc = r->locator;
  loc->ops->reset(loc);
  double t = r->ta, h = fmax(tau - r->ta, 1e-12);
  memcpy(y, r->ytry, (size_t)r->dim * sizeof(double));
  while (t < tau) {
    int st = loc->ops->step(loc, s, &t, tau, &h, y);
    if (st) {
      r->failure = NZ_RUN_FAIL_LOCATOR;
      return st;
    }
  }
  return NZ_OK;
}

/* Event e's value at (t, y) through the hook; a value that is not finite
 * has no sign to follow and fails the run. */
static int event_value(nz_run *r, int e, double t, const double *y, double *g)
{
  r->ev_e = e;
  int st = r->hooks.event(r->hooks.ctx, e, t, y, g);
  if (!st && !isfinite(*g)) st = NZ_EDOM;
  if (st) r->failure = NZ_RUN_FAIL_EVENT;
  return st;
}

/* Illinois' variant of regula falsi on [ta, tb] for event e, from ga to
 * gb, on the offsets from ta (the secant's ta gb - tb ga loses the digits
 * that ta and tb share): the time te and the state ye (the step's end
 * itself when the root is there). */
static int locate(nz_run *r, const nz_system *s, int e, double ga, double gb, double *te, double *ye)
{
  int st;
  double ta = r->ta, tb = r->t, a = 0.0, b = tb - ta;
  if (gb != 0.0) {
    double tol = r->c.event_tol * fmax(1.0, fabs(tb)), gm;
    int side = 0;
    for (int it = 0; it < 100 && b - a > tol; it++) {
      double m = (a * gb - b * ga) / (gb - ga);
      /* an end whose value is negligible against the other's (an event
       * that starts at zero: a bounce) pins the secant to it, and Illinois'
       * halvings would take hundreds of steps to leave it: bisect */
      if (!(m > a && m < b) || fabs(ga) < NZ_RUN_SECANT_RATIO * fabs(gb) || fabs(gb) < NZ_RUN_SECANT_RATIO * fabs(ga))
        m = 0.5 * (a + b);
      if ((st = state_at(r, s, ta + m, ye)) || (st = event_value(r, e, ta + m, ye, &gm))) return st;
      if (gm == 0.0) {
        a = b = m;
        break;
      }
      if ((gm > 0.0) == (ga > 0.0)) {
        a = m, ga = gm;
        if (side == -1) gb /= 2;
        side = -1;
      } else {
        b = m, gb = gm;
        if (side == 1) ga /= 2;
        side = 1;
      }
    }
  }
  if (b == tb - ta) {
    *te = tb;
    memcpy(ye, r->y, (size_t)r->dim * sizeof(double));
    return NZ_OK;
  }
  *te = ta + b;
  return state_at(r, s, *te, ye);
}

/* Every event of the step just taken, at its end; those that crossed
 * located and sorted by time (stable: event order for equal times), for
 * PH_LOCATED to hand over. */
static int locate_events(nz_run *r, const nz_system *s)
{
  size_t dim = (size_t)r->dim;
  r->nloc = r->loc_next = 0;
  for (int e = 0; e < r->nev; e++) {
    double g;
    int st = event_value(r, e, r->t, r->y, &g);
    if (st) return st;
    double ga = r->gvals[e];
    r->gvals[e] = g;
    if (!nz_event_crosses(r->dirs[e], ga, g)) continue;
    int n = r->nloc;
    if ((st = locate(r, s, e, ga, g, &r->loc_t[n], r->loc_y + (size_t)n * dim))) return st;
    r->loc_e[n] = e;
    r->loc_dir[n] = g > ga ? 1 : -1;
    for (; n > 0 && r->loc_t[n] < r->loc_t[n - 1]; n--) {
      double tt = r->loc_t[n];
      r->loc_t[n] = r->loc_t[n - 1];
      r->loc_t[n - 1] = tt;
      int ee = r->loc_e[n];
      r->loc_e[n] = r->loc_e[n - 1];
      r->loc_e[n - 1] = ee;
      int dd = r->loc_dir[n];
      r->loc_dir[n] = r->loc_dir[n - 1];
      r->loc_dir[n - 1] = dd;
      double *a = r->loc_y + (size_t)n * dim, *b = a - dim;
      for (size_t i = 0; i < dim; i++) {
        double v = a[i];
        a[i] = b[i];
        b[i] = v;
      }
    }
    r->nloc++;
  }
  return NZ_OK;
}

/* Before a step: does every plan the run has used run as machine code now
 * (a compile in the background may have finished)?  Asked until it does. */
static void native_check(nz_run *r, const nz_system *s)
{
  int v = s->native_ready ? s->native_ready(s->mass_bias_ctx) : -1;
  if (v) r->native_from = v > 0 ? (long)r->nsteps + 1 : -1;
}

long nz_run_native_from(const nz_run *r) { return r->native_from; }

/* The output points inside the last step up to tlast (inclusive) from its
 * dense output: NZ_RUN_FULL when the buffer fills first, NZ_RUN_FAILED with
 * *status, or NZ_RUN_DONE. */
static nz_run_status record_grid(nz_run *r, const nz_system *s, double tlast, int *status)
{
  while (r->c.dense && r->i <= r->nout && r->tout <= tlast && r->tout < r->t) {
    if (r->n == r->cap) return NZ_RUN_FULL;
    int ok;
    if ((*status = interpolate(r, s, r->tout, r->yi, &ok)) || (*status = record_at(r, s, r->tout, r->yi)))
      return NZ_RUN_FAILED;
    r->ninterp++;
    r->i += 1.0;
    begin_interval(r);
  }
  return NZ_RUN_DONE;
}

static int fail(nz_run *r, nz_run_failure what, int st, int *status)
{
  r->failure = what;
  *status = st;
  return NZ_RUN_FAILED;
}

/* The run's first call: the point at t0, and each event's value there. */
static nz_run_status start(nz_run *r, const nz_system *s, int *status)
{
  if ((*status = record(r, s))) return NZ_RUN_FAILED;
  r->started = 1;
  for (int e = 0; e < r->nev; e++)
    if ((*status = event_value(r, e, r->t, r->y, &r->gvals[e]))) return NZ_RUN_FAILED;
  return NZ_RUN_DONE;
}

/* The step from PH_STEP: taken, then the violation watched (NZ_RUN_PROJECT).
 * Here and in start and record_grid, NZ_RUN_DONE means "go on". */
static nz_run_status take_step(nz_run *r, const nz_system *s, int *status)
{
  if (nz_interrupt_requested()) return NZ_RUN_INTERRUPTED;
  if (r->native_from == 0) native_check(r, s);
  r->ta = r->t;
  if ((*status = r->exact ? exact_step(r, s) : r->c.dense ? dense_step(r, s) : one_step(r, s, r->tout)))
    return NZ_RUN_FAILED;
  r->phase = PH_COUNT;
  if (r->c.project_tol > 0.0) {        /* above the tolerance, the caller projects */
    double v;
    int st = r->hooks.violation(r->hooks.ctx, r->t, r->y, &v);
    if (st) return fail(r, NZ_RUN_FAIL_VIOLATION, st, status);
    if (!(v <= r->c.project_tol)) return NZ_RUN_PROJECT;   /* NaN too */
  }
  return NZ_RUN_DONE;
}

nz_run_status nz_run_advance(nz_run *r, const nz_system *s, unsigned long pause_step, double pause_wall,
                             int *status)
{
  nz_run_status rs;
  *status = NZ_OK;
  r->failure = NZ_RUN_FAIL_ODE;
  if ((r->nev && !r->hooks.event) || (r->c.project_tol > 0.0 && !r->hooks.violation))
    return fail(r, NZ_RUN_FAIL_EVENT, NZ_EARG, status);
  if (!r->started && (rs = start(r, s, status)) != NZ_RUN_DONE) return rs;
  for (;;) {
    if (r->i > r->nout) return NZ_RUN_DONE;
    if (!r->in_interval) begin_interval(r);
    while (r->phase != PH_STEP || r->t < r->tout) {
      if (r->phase == PH_STEP && (rs = take_step(r, s, status)) != NZ_RUN_DONE) return rs;
      if (r->phase == PH_COUNT) {
        r->nsteps++;
        r->phase = PH_EVENTS;
        if (stalled(r)) return NZ_RUN_STALLED;
        if (pause_step && r->nsteps == pause_step) return NZ_RUN_PAUSED;
      }
      if (r->phase == PH_EVENTS) {
        if ((*status = locate_events(r, s))) return NZ_RUN_FAILED;
        r->phase = PH_LOCATED;
      }
      if (r->phase == PH_LOCATED && r->loc_next < r->nloc) {   /* the points before it, then the event */
        if ((rs = record_grid(r, s, r->loc_t[r->loc_next], status)) != NZ_RUN_DONE) return rs;
        r->loc_located = r->loc_next++;
        return NZ_RUN_EVENT;
      }
      r->phase = PH_GRID;
      if ((rs = record_grid(r, s, r->t, status)) != NZ_RUN_DONE) return rs;
      r->phase = PH_STEP;
      if (pause_wall > 0.0 && nz_run_clock() >= pause_wall) return NZ_RUN_PAUSED;
    }
    if (r->n == r->cap) return NZ_RUN_FULL;
    if ((*status = record(r, s))) return NZ_RUN_FAILED;
    r->i += 1.0;
    r->in_interval = 0;
  }
}

void nz_run_set_hooks(nz_run *r, const nz_run_hooks *h)
{
  if (h) r->hooks = *h;
  else memset(&r->hooks, 0, sizeof r->hooks);
}

void nz_run_failed_event(const nz_run *r, int *e, double *ta)
{
  *e = r->ev_e;
  *ta = r->ta;
}

/* The first step from (t, y) after a jump, by Hairer, Norsett and Wanner's
 * estimate (Solving ODEs I, II.4): the step that an explicit Euler step's
 * change of f allows at the run's tolerance for a method of order p.  The
 * step the run had before the jump belongs to other equations (a block that
 * stuck for a second, then slips): trying it cost about five rejected steps
 * per event. */
static int starting_step(nz_run *r, const nz_system *s, double *h)
{
  int k = r->k, n = 2 * k, st;
  double *a0 = r->sacc, *a1 = r->sacc + k + r->nc, *y1 = r->yi;
  nz_stepper_stats ss;
  r->st->ops->stats(r->st, &ss);
  if ((st = r->st->ops->accel(r->st, s, r->t, r->y, a0))) return st;
  double d0 = 0.0, d1 = 0.0, d2 = 0.0;
  for (int i = 0; i < n; i++) {
    double sc = r->c.atol + r->c.rtol * fabs(r->y[i]), f = i < k ? r->y[k + i] : a0[i - k];
    d0 += (r->y[i] / sc) * (r->y[i] / sc);
    d1 += (f / sc) * (f / sc);
  }
  d0 = sqrt(d0 / n), d1 = sqrt(d1 / n);
  double h0 = d0 < 1e-5 || d1 < 1e-5 ? 1e-6 : 0.01 * d0 / d1;
  memcpy(y1, r->y, (size_t)r->dim * sizeof(double));
  for (int i = 0; i < k; i++) y1[i] += h0 * r->y[k + i], y1[k + i] += h0 * a0[i];
  if ((st = r->st->ops->accel(r->st, s, r->t + h0, y1, a1))) return st;
  for (int i = 0; i < n; i++) {
    double sc = r->c.atol + r->c.rtol * fabs(r->y[i]);
    double df = i < k ? y1[k + i] - r->y[k + i] : a1[i - k] - a0[i - k];
    d2 += (df / sc) * (df / sc);
  }
  d2 = sqrt(d2 / n) / h0;
  double dm = fmax(d1, d2), p = ss.order > 0 ? ss.order : 4;
  double h1 = dm <= 1e-15 ? fmax(1e-6, 1e-3 * h0) : pow(0.01 / dm, 1.0 / (p + 1.0));
  *h = fmin(100.0 * h0, h1);
  return NZ_OK;
}

int nz_run_jump(nz_run *r, const nz_system *s, double te, const double *y)
{
  if (!(te >= r->ta && te <= r->t) || (r->nev && !r->hooks.event)) return NZ_EARG;
  memcpy(r->y, y, (size_t)r->dim * sizeof(double));
  r->t = r->ta = te;
  r->tlo = 0.0;
  r->st->ops->reset(r->st);
  if (!r->st->exact_dense && r->c.step == 0.0 && finite_positive(r->c.rtol + r->c.atol)) {
    double h;
    int st = starting_step(r, s, &h);
    if (st) return st;
    if (finite_positive(h)) r->h = h;
  }
  r->start_ok = 0;
  r->phase = PH_STEP;
  r->nloc = r->loc_next = 0;
  /* the output points up to te are recorded (PH_LOCATED); the grid goes on
   * from the first after te */
  r->in_interval = 0;
  for (int e = 0; e < r->nev; e++) {
    int st = event_value(r, e, r->t, r->y, &r->gvals[e]);
    if (st) return st;
  }
  return NZ_OK;
}

/* The step's own end stays in sb for its interpolant; the next step starts
 * from the projected state, without the step before joined on. */
void nz_run_set_state(nz_run *r, const double *y)
{
  memcpy(r->y, y, (size_t)r->dim * sizeof(double));
  r->start_ok = 0;
}

int nz_run_located(const nz_run *r, int *e, double *te, const double **ye, int *dir)
{
  if (r->phase != PH_LOCATED || r->loc_next == 0) return 0;
  int i = r->loc_located;
  *e = r->loc_e[i];
  if (dir) *dir = r->loc_dir[i];
  *te = r->loc_t[i];
  *ye = r->loc_y + (size_t)i * (size_t)r->dim;
  return 1;
}

void nz_run_dense_stats(const nz_run *r, unsigned long *interpolated, unsigned long *forced)
{
  *interpolated = r->ninterp;
  *forced = r->nforced;
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

nz_stepper *nz_run_stepper(const nz_run *r) { return r->st; }
