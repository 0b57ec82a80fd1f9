/* ode_run.h - the stepping loop of sys:simulate, in C: the only one.  It
 * drives any integrator of the interface of stepper.h (GSL's steppers,
 * stepper_gsl.c; Taylor's method, taylor.c) over the output grid and hands
 * lua/nz/motion/simulate.lua the output points, the located events, the
 * projections and the pauses it asks for.
 *
 * The loop: the output grid (t0 + i dt, the last point at t1), fixed steps
 * that land on each output time (to the last bit: the loop keeps their sum
 * to twice the precision and makes an interval's last step the rest to its
 * output time; see one_step), the accelerations and multipliers recorded
 * at each output point, the stall detection, the polling of the interrupt,
 * and, when asked, the watch for events and for the drift off the
 * constraints.  What the loop cannot know it asks of hooks
 * (nz_run_set_hooks): an event's value (the caller's recorded graph, a
 * contact's gap, or the user's Lua function) and the state's violation of
 * the constraints (computed in C for constraints of order <= 2, in Lua
 * above), so that this layer knows nothing of graphs, contacts or Lua.
 *
 * Events: after every accepted step the loop evaluates event e = 0, 1, ...
 * at the step's end; each that crossed zero (nz_event_crosses) is located
 * by Illinois' regula falsi on the state inside the step (the integrator's
 * dense output where it meets the tolerance there, else the step integrated
 * again from its start by the locator, an integrator of the caller's at a
 * tight tolerance) to event_tol, and the step's events are handed over one
 * NZ_RUN_EVENT each, in time order (nz_run_located).  Before each, the
 * output points of the step up to its time are recorded, and the rest of
 * the step's points after the last: a caller that stops the run at an event
 * or makes the motion jump there (nz_run_jump: an impact, a contact that
 * opens or closes) finds exactly the points before it.  Projection: with
 * project_tol > 0, after every accepted step the loop asks the violation
 * hook and, above the tolerance, returns NZ_RUN_PROJECT; the caller
 * projects, writes the state back (nz_run_set_state) and calls again.
 *
 * The loop is resumable: nz_run_advance returns to its caller when it must
 * act (the run is done, it stalled, it was interrupted, a step failed, the
 * output buffer is full, an event was located, the state drifted, or the
 * caller asked for a pause at a step count or a wall time for its progress
 * bar and long-run notice) and goes on from where it stopped when called
 * again.  Output points wait in a buffer of `capacity` points that the
 * caller empties (nz_run_clear), so the loop's own memory stays bounded
 * whatever the grid. */
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
 * as without dense output.  nz_run_dense_stats counts both kinds of
 * point. */
#ifndef NZ_ODE_RUN_H
#define NZ_ODE_RUN_H

#include "ode/stepper.h"

/* Locating an event by regula falsi (Illinois), a step bisects instead
 * where one end's value is below this fraction of the other's: the secant
 * would hug that end. */
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
  double event_tol;          /* the tolerance on the events' times, relative to   */
                             /* max(1, |t|)                                        */
  nz_stepper *locator;       /* the caller's: integrates a step again where the   */
                             /* dense output misses the tolerance at a point an   */
                             /* event is looked for (required with events, unless */
                             /* the dense output is exact)                        */
  double project_tol;        /* > 0: NZ_RUN_PROJECT when the violation exceeds it  */
  int dense;                 /* adaptive steps: output points inside a step from   */
                             /* the step's dense output (see above)                */
  double rtol, atol;         /* dense: the interpolant's tolerance per component   */
  int no_accel;              /* output points without q'' and lambda (zeros)       */
} nz_run_config;

/* What the loop asks of its caller, each with ctx: event e's value g
 * (0-based) at (t, y), and the violation v of the constraints at (t, y)
 * (when project_tol > 0).  NZ_OK, or a status that makes the run fail
 * (nz_run_failure_of says which hook). */
typedef struct nz_run_hooks {
  int (*event)(void *ctx, int e, double t, const double *y, double *g);
  int (*violation)(void *ctx, double t, const double *y, double *v);
  void *ctx;
} nz_run_hooks;

typedef enum nz_run_status {
  NZ_RUN_DONE = 0,           /* t1 reached, its point recorded                    */
  NZ_RUN_PAUSED,             /* the step count or the wall time asked for         */
  NZ_RUN_FULL,               /* the buffer is full: take the points, call again    */
  NZ_RUN_INTERRUPTED,        /* the interrupt was requested before a step          */
  NZ_RUN_STALLED,            /* the last stall_window steps advanced t too little  */
  NZ_RUN_FAILED,             /* a step, an output point, an event or the violation */
                             /* failed (nz_run_failure_of says which)              */
  NZ_RUN_EVENT,              /* an event was located in the last step            */
                             /* (nz_run_located)                                  */
  NZ_RUN_PROJECT             /* the violation exceeds project_tol (or is NaN):     */
                             /* project, nz_run_set_state, and call again          */
} nz_run_status;

typedef enum nz_run_failure {
  NZ_RUN_FAIL_ODE = 0,       /* the integrator's (see nz_run_advance)              */
  NZ_RUN_FAIL_EVENT,         /* the event hook's status, or a value not finite     */
  NZ_RUN_FAIL_VIOLATION,     /* the violation hook's status                        */
  NZ_RUN_FAIL_LOCATOR        /* the locator's step (its own report says why)       */
} nz_run_failure;

typedef struct nz_run nz_run;

/* A run of the integrator st (which stays the caller's, as the locator)
 * from (t0, y0) (st->dim values).  NULL: no memory or a bad configuration
 * (dt, step or span not positive and finite, capacity < 1, events without
 * directions or event_tol or, unless the dense output is exact, without a
 * locator, a fixed step for an integrator without fixed steps). */
nz_run *nz_run_alloc(nz_stepper *st, const nz_run_config *cfg, const double *y0);
void nz_run_free(nz_run *r);

/* The hooks (with their context) used by the following calls of
 * nz_run_advance and nz_run_jump; the event hook is required when nevents >
 * 0, the violation hook when project_tol > 0 (set them before every call
 * when their context lives on the caller's stack). */
void nz_run_set_hooks(nz_run *r, const nz_run_hooks *h);

/* Step until something needs the caller (see nz_run_status).  pause_step:
 * pause right after the accepted step that makes the count equal to it (0:
 * never); pause_wall: pause after the first step at or past this monotonic
 * time in seconds (0: never).  On NZ_RUN_FAILED, *status holds the nz
 * status of the failing call and, when nz_run_failure_of says
 * NZ_RUN_FAIL_ODE (or _LOCATOR), the integrator's (the locator's) report
 * the details (nz_ode_last_failure, nz_taylor_last_failure).  The order
 * within a step: the step, the violation (NZ_RUN_PROJECT), the count, the
 * stall, the pause at a step count, the events located (NZ_RUN_EVENT each,
 * after the output points up to it), the step's other output points, the
 * pause at a wall time; a call after a return goes on from there. */
nz_run_status nz_run_advance(nz_run *r, const nz_system *s, unsigned long pause_step, double pause_wall,
                             int *status);

/* After NZ_RUN_EVENT: event e (0-based) at te, state ye (valid until the
 * next call), *dir (unless dir is NULL) 1 when its value rose through zero
 * and -1 when it fell.  Returns 0 when no event is being handed over. */
int nz_run_located(const nz_run *r, int *e, double *te, const double **ye, int *dir);
/* After NZ_RUN_FAILED with NZ_RUN_FAIL_EVENT: the event that failed and
 * the start of the step in which it was looked at. */
void nz_run_failed_event(const nz_run *r, int *e, double *ta);

/* Replace the state of the last accepted step (dim values: the projected
 * state after NZ_RUN_PROJECT); the next step starts afresh from it. */
void nz_run_set_state(nz_run *r, const double *y);

/* The motion jumps at te (an event's time, inside or at the end of the
 * last step) to the state y (dim values): an impact, or equations that
 * change there (a contact opening or closing, contact.h).  The run goes on
 * from (te, y) as from a new start: the integrator forgets its history, the
 * events left in the last step and its output points after te are dropped
 * (those up to te are recorded), each event's value is taken at (te, y)
 * through the hook, and an adaptive step starts with Hairer, Norsett and
 * Wanner's estimate at (te, y) (two evaluations of the accelerations), not
 * the step before.  NZ_OK, NZ_EARG (te outside the last step, no event
 * hook with events), or the hook's status. */
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
 * 1: rising, -1: falling)?  A sign change, or a step that lands on the zero. */
static inline int nz_event_crosses(int dir, double ga, double gb)
{
  if (ga == 0.0 || (gb != 0.0 && (ga > 0.0) == (gb > 0.0))) return 0;
  return dir == 0 || (dir > 0 && gb > ga) || (dir < 0 && gb < ga);
}

/* Dense output: the output points read from an interpolant, and those
 * that its error control made step ends (each also cost a step taken again). */
void nz_run_dense_stats(const nz_run *r, unsigned long *interpolated, unsigned long *forced);

/* The monotonic clock the pauses use (the one of mech.now()). */
double nz_run_clock(void);

#endif
