/* ode_run.h - the stepping loop of sys:simulate in C (issue 10, item 6),
 * driving any integrator of the interface of stepper.h: GSL's steppers
 * (stepper_gsl.c) and Taylor's method (taylor.c) run here alike.
 *
 * lua/nz/motion/simulate.lua steps a GSL integrator (ode.h) one step at a time, in
 * Lua (run()).  This loop does the same work without returning to Lua per
 * step: the output grid (t0 + i dt, the last point at t1), fixed steps that
 * land on each output time, the accelerations and multipliers recorded at
 * each output point, the stall detection, the polling of the interrupt,
 * and, when asked, the watch for events and for the drift off the
 * constraints.  It performs the same floating-point operations in the same
 * order as the Lua loop, so the two give bit-identical trajectories and
 * statistics (the Lua loop stays the reference; tests/simulate_loop_spec.lua
 * compares them).
 *
 * Events: after every accepted step the loop evaluates event e = 0, 1, ...
 * through a callback (nz_run_set_events: the caller's recorded graphs, so
 * that this layer knows nothing of graphs or Lua) and, when one crosses zero
 * (the rule of crosses() in simulate.lua), returns NZ_RUN_EVENT with the
 * step (nz_run_event); the caller locates and records the event and, unless
 * it stops the run, calls again: the loop goes on with the next event of the
 * same step (with an exact dense output the loop locates them itself: see
 * nz_run_located).  Projection: with project_tol > 0, after every accepted
 * step the loop computes the state's violation of the constraints of order <= 1
 * (nz_state_violation, constrained.h: what the Lua loop's state_violation
 * computes, by the same primitive in the same order) and, above the
 * tolerance, returns NZ_RUN_PROJECT; the caller projects, writes the state
 * back (nz_run_set_state) and calls again.  Locating and projecting stay in
 * Lua: they happen a few times per run, not per step.
 *
 * The loop is resumable: nz_run_advance returns to its caller when it must
 * act (the run is done, it stalled, it was interrupted, a step failed, the
 * output buffer is full, an event crossed, the state drifted, or the caller
 * asked for a pause at a step count or a wall time for its progress bar and
 * long-run notice) and goes on from where it stopped when called again.
 * Output points wait in a buffer of `capacity` points that the caller
 * empties (nz_run_clear), so the loop's own memory stays bounded whatever
 * the grid. */
/* Dense output (cfg.dense, adaptive steps only): the steps go to t1, not to
 * each output time, and an output point inside a step is read from the
 * integrator's dense output, so that the output grid no longer caps the
 * steps.  Taylor's is the step's own polynomial (exact: no point is
 * checked, no step taken again).  GSL's (stepper_gsl.c) is a Hermite
 * interpolant of the step: y = (q, q', ...) and f = (q', q'', ...); for q
 * the nodes carry q, q', q'' (a quintic over the step alone, and up to degree 11 with the
 * starts of the two steps before joined on), q' is the derivative of q's
 * polynomial, and every other component gets the cubic (up to degree 7)
 * from y and f: no evaluation beyond f at the step ends.  The last Newton
 * term of an interpolant (what its last node condition adds) estimates its
 * error; of the interpolants over the step alone and joined with one or two
 * steps before, each component takes the one whose estimate is smallest
 * against atol + rtol |y| (a high degree amplifies the step ends' own
 * errors).  An output point whose estimate exceeds atol + rtol |y| in any
 * component (or, when projecting, whose violation exceeds project_tol) is
 * made a step end instead: the step is taken again from its start, ending
 * there (the integrator reset: GSL's evolve object keeps its last step, a
 * multistep method its history).  A step that fails is taken again towards
 * the next output time, and every step after it: the run reaches a failure
 * as without dense output.  nz_run_dense_stats counts both kinds of point;
 * the caller locates a GSL stepper's events on the interpolant
 * (nz_run_interpolate). */
#ifndef NZ_ODE_RUN_H
#define NZ_ODE_RUN_H

#include "ode/stepper.h"

/* Locating an event by regula falsi (Illinois), a step bisects instead
 * where one end's value is below this fraction of the other's (simulate.lua's
 * M.SECANT_RATIO): the secant would hug that end. */
#define NZ_RUN_SECANT_RATIO 1e-12

typedef struct nz_run_config {
  double t0, t1, dt;         /* the output grid, as simulate.lua makes it        */
  double step;               /* > 0: fixed steps no longer than this; 0: adaptive */
  double h0;                 /* the first adaptive step                           */
  unsigned long stall_window;  /* simulate.lua's M.STALL                          */
  double stall_fraction;
  int capacity;              /* output points buffered (>= 1)                     */
  int nevents;               /* event functions watched (0: none)                 */
  const int *directions;     /* nevents: 0 any crossing, +1 rising, -1 falling (copied) */
  double project_tol;        /* > 0: NZ_RUN_PROJECT when the violation exceeds it  */
  const int *orders;         /* nc classified orders, for the violation (copied)   */
  int dense;                 /* adaptive steps: output points inside a step from   */
                             /* the step's Hermite interpolant (see below)         */
  double rtol, atol;         /* dense: the interpolant's tolerance per component   */
  double event_tol;          /* events located here (an exact dense output): the   */
                             /* tolerance on their times, relative to max(1, |t|)  */
  int no_accel;              /* output points without q'' and lambda (zeros)       */
  int nchange;               /* the last nchange events change the motion where    */
                             /* they cross (contacts): a step in which one crosses */
                             /* hands its events over before its output points,   */
                             /* which the caller records up to the event's time    */
                             /* (nz_run_record_until) before it jumps (nz_run_jump) */
} nz_run_config;

/* The value g of event e (0-based) at (t, y); NZ_OK, or a status that makes
 * the run fail (NZ_RUN_FAILED, nz_run_failure_of = NZ_RUN_FAIL_EVENT). */
typedef int (*nz_run_event_fn)(void *ctx, int e, double t, const double *y, double *g);

typedef enum nz_run_status {
  NZ_RUN_DONE = 0,           /* t1 reached, its point recorded                    */
  NZ_RUN_PAUSED,             /* the step count or the wall time asked for         */
  NZ_RUN_FULL,               /* the buffer is full: take the points, call again    */
  NZ_RUN_INTERRUPTED,        /* the interrupt was requested before a step          */
  NZ_RUN_STALLED,            /* the last stall_window steps advanced t too little  */
  NZ_RUN_FAILED,             /* a step, an output point, an event or the violation */
                             /* failed (nz_run_failure_of says which)              */
  NZ_RUN_EVENT,              /* an event crossed in the last step (nz_run_event)   */
  NZ_RUN_PROJECT             /* the violation exceeds project_tol (or is NaN):     */
                             /* project, nz_run_set_state, and call again          */
} nz_run_status;

typedef enum nz_run_failure {
  NZ_RUN_FAIL_ODE = 0,       /* the integrator's (see nz_run_advance)              */
  NZ_RUN_FAIL_EVENT,         /* the event callback's status                        */
  NZ_RUN_FAIL_VIOLATION      /* nz_state_violation's (a constraint failed)         */
} nz_run_failure;

typedef struct nz_run nz_run;

/* A run of the integrator st (which stays the caller's) from (t0, y0)
 * (st->dim values).  NULL: no memory or a bad configuration (dt, step or
 * span not positive and finite, capacity < 1, events without directions,
 * project_tol > 0 without orders, a fixed step for an integrator without
 * fixed steps, events on an exact dense output without event_tol). */
nz_run *nz_run_alloc(nz_stepper *st, const nz_run_config *cfg, const double *y0);
void nz_run_free(nz_run *r);

/* Step until something needs the caller (see nz_run_status).  pause_step:
 * pause right after the accepted step that makes the count equal to it (0:
 * never); pause_wall: pause after the first step at or past this monotonic
 * time in seconds (0: never).  On NZ_RUN_FAILED, *status holds the nz
 * status of the failing call and, when nz_run_failure_of says
 * NZ_RUN_FAIL_ODE, the integrator's report the details (nz_ode_last_failure,
 * nz_taylor_last_failure).  The order within a
 * step is the Lua loop's: step, violation (NZ_RUN_PROJECT), count, stall,
 * pause at a step count, events in their order (NZ_RUN_EVENT), pause at a
 * wall time; a call after a return goes on from there. */
nz_run_status nz_run_advance(nz_run *r, const nz_system *s, unsigned long pause_step, double pause_wall,
                             int *status);

/* The event callback (with its context) used by the following calls of
 * nz_run_advance; required when nevents > 0 (set it before every call when
 * its context lives on the caller's stack). */
void nz_run_set_events(nz_run *r, nz_run_event_fn fn, void *ctx);

/* After NZ_RUN_EVENT: event e (0-based) crossed in the step from (ta, ya)
 * to (tb, yb), its values ga before and gb after (the arrays stay valid
 * until the next call of nz_run_advance).  With an integrator whose dense
 * output is exact (Taylor's polynomial), the loop locates the events itself
 * (Illinois' regula falsi, as simulate.lua's locate(), to event_tol) after
 * each step and hands them over in time order, one NZ_RUN_EVENT each:
 * nz_run_located says so and gives the time and state.  An event whose
 * value fails or is not finite there fails the run (NZ_RUN_FAIL_EVENT,
 * nz_run_event's e names it, ta the step's start; ya is not kept then). */
void nz_run_event(const nz_run *r, int *e, double *ta, const double **ya, double *ga, double *tb,
                  double *gb, const double **yb);
/* After NZ_RUN_EVENT: 1 when the loop located it (event e at te, state ye,
 * valid until the next call; *dir, unless dir is NULL, 1 when its value
 * rose through zero and -1 when it fell), 0 when the caller locates it. */
int nz_run_located(const nz_run *r, int *e, double *te, const double **ye, int *dir);

/* Replace the state of the last accepted step (dim values: the projected
 * state after NZ_RUN_PROJECT); the next step starts afresh from it. */
void nz_run_set_state(nz_run *r, const double *y);

/* The output points of the last step up to te (inclusive) from its dense
 * output, when its events came first (nz_run_config's nchange): before a
 * jump at te, in the motion before it.  NZ_RUN_DONE, NZ_RUN_FULL (take the
 * points, call again), or NZ_RUN_FAILED with *status. */
nz_run_status nz_run_record_until(nz_run *r, const nz_system *s, double te, int *status);

/* The motion jumps at te, inside or at the end of the last step, to the
 * state y (dim values): an impact, or equations that change there (a
 * contact opening or closing, contact.h).  The run goes on from (te, y) as
 * from a new start: the integrator forgets its history, the events left in
 * the last step are dropped, each event's value is taken at (te, y)
 * through the callback (set it first: nz_run_set_events), and the output
 * grid goes back to its first time after te (with dense output the step
 * recorded the points inside it; the caller drops those after te, the
 * buffer being handed over at every return).  A point at te itself keeps
 * the state before the jump if it was recorded, else it gets y.  An
 * adaptive step starts with Hairer, Norsett and Wanner's estimate at (te,
 * y) (two evaluations of the accelerations), not the step before.  NZ_OK,
 * NZ_EARG (te outside the last step, no callback with events), or the
 * callback's status. */
int nz_run_jump(nz_run *r, const nz_system *s, double te, const double *y);

/* After NZ_RUN_FAILED: what failed. */
nz_run_failure nz_run_failure_of(const nz_run *r);

/* The integrator: its statistics (stats), its failures. */
nz_stepper *nz_run_stepper(const nz_run *r);

/* Where the run is: the time and state of the last accepted step, the steps
 * accepted, and (after NZ_RUN_STALLED) how far the last window advanced. */
double nz_run_time(const nz_run *r);
const double *nz_run_state(const nz_run *r);
unsigned long nz_run_steps(const nz_run *r);
double nz_run_stall_advance(const nz_run *r);
/* Which evaluator ran the steps (nz_system's native_ready hook, asked
 * before each step until it says yes): n >= 1 when every plan the run used
 * ran as machine code from step n on (1: throughout), 0 when some stayed
 * interpreted to the end, -1 when the system has no machine code (not
 * recorded, or native = false). */
long nz_run_native_from(const nz_run *r);

/* The buffered output points, oldest first: t, the state y (dim values),
 * q'' and lambda (k + nc), and the root q^(p) of a top integrator (k values)
 * or NULL when the integrator gave none. */
int nz_run_count(const nz_run *r);
void nz_run_point(const nz_run *r, int i, double *t, const double **y, const double **acc,
                  const double **root);
void nz_run_clear(nz_run *r);

/* Does event g cross over a step from ga to gb, in direction dir (0: either,
 * 1: rising, -1: falling)?  A sign change, or a step that lands on the zero;
 * the rule of simulate.lua's crosses(), shared by this loop and the Taylor
 * runs (src/lua/lua_taylor.c). */
static inline int nz_event_crosses(int dir, double ga, double gb)
{
  if (ga == 0.0 || (gb != 0.0 && (ga > 0.0) == (gb > 0.0))) return 0;
  return dir == 0 || (dir > 0 && gb > ga) || (dir < 0 && gb < ga);
}

/* Dense output: the output points read from an interpolant, and those
 * that its error control made step ends (each also cost a step taken again). */
void nz_run_dense_stats(const nz_run *r, unsigned long *interpolated, unsigned long *forced);

/* The state at tau in [ta, tb] of the last step (after NZ_RUN_EVENT), from
 * its interpolant: NZ_OK with y (dim values) when the error estimate meets
 * the tolerance, NZ_EARG when dense output is off or it does not (locate by
 * integrating again), or the status of a failed evaluation of f. */
int nz_run_interpolate(nz_run *r, const nz_system *s, double tau, double *y);

/* The monotonic clock the pauses use (the one of mech.now()). */
double nz_run_clock(void);

#endif
