/* ode_run.h - the stepping loop of sys:simulate in C (issue 10, item 6).
 *
 * lua/nz/simulate.lua steps an integrator (ode.h) one step at a time, in
 * Lua, so that it can locate events and project onto the constraints.  When
 * a run needs neither (and no Lua function is called per step), this loop
 * does the same work without returning to Lua per step: the output grid
 * (t0 + i dt, the last point at t1), fixed steps that land on each output
 * time, the accelerations and multipliers recorded at each output point,
 * the stall detection, and the polling of the interrupt.  It performs the
 * same floating-point operations in the same order as the Lua loop, so the
 * two give bit-identical trajectories and statistics (the Lua loop stays
 * the reference; tests/simulate_loop_spec.lua compares them).
 *
 * The loop is resumable: nz_run_advance returns to its caller when it must
 * act (the run is done, it stalled, it was interrupted, a step failed, the
 * output buffer is full, or the caller asked for a pause at a step count or
 * a wall time for its progress bar and long-run notice) and goes on from
 * where it stopped when called again.  Output points wait in a buffer of
 * `capacity` points that the caller empties (nz_run_clear), so the loop's
 * own memory stays bounded whatever the grid. */
#ifndef NZ_ODE_RUN_H
#define NZ_ODE_RUN_H

#include "ode/ode.h"

typedef struct nz_run_config {
  double t0, t1, dt;         /* the output grid, as simulate.lua makes it        */
  double step;               /* > 0: fixed steps no longer than this; 0: adaptive */
  double h0;                 /* the first adaptive step                           */
  unsigned long stall_window;  /* simulate.lua's M.STALL                          */
  double stall_fraction;
  int capacity;              /* output points buffered (>= 1)                     */
} nz_run_config;

typedef enum nz_run_status {
  NZ_RUN_DONE = 0,           /* t1 reached, its point recorded                    */
  NZ_RUN_PAUSED,             /* the step count or the wall time asked for         */
  NZ_RUN_FULL,               /* the buffer is full: take the points, call again    */
  NZ_RUN_INTERRUPTED,        /* the interrupt was requested before a step          */
  NZ_RUN_STALLED,            /* the last stall_window steps advanced t too little  */
  NZ_RUN_FAILED              /* a step or an output point failed (ode's failure)   */
} nz_run_status;

typedef struct nz_run nz_run;

/* A run of o from (t0, y0) (nz_ode_dim(o) values).  NULL: no memory or a bad
 * configuration (dt, step or span not positive and finite, capacity < 1). */
nz_run *nz_run_alloc(nz_ode *o, int k, int nc, const nz_run_config *cfg, const double *y0);
void nz_run_free(nz_run *r);

/* Step until something needs the caller (see nz_run_status).  pause_step:
 * pause right after the accepted step that makes the count equal to it (0:
 * never); pause_wall: pause after the first step at or past this monotonic
 * time in seconds (0: never).  On NZ_RUN_FAILED, *status holds the nz
 * status of the failing call and nz_ode_last_failure(o) the details. */
nz_run_status nz_run_advance(nz_run *r, const nz_system *s, unsigned long pause_step, double pause_wall,
                             int *status);

/* Where the run is: the time and state of the last accepted step, the steps
 * accepted, and (after NZ_RUN_STALLED) how far the last window advanced. */
double nz_run_time(const nz_run *r);
const double *nz_run_state(const nz_run *r);
unsigned long nz_run_steps(const nz_run *r);
double nz_run_stall_advance(const nz_run *r);

/* The buffered output points, oldest first: t, the state y (dim values),
 * q'' and lambda (k + nc), and the root q^(p) of a top integrator (k values)
 * or NULL when the integrator gave none. */
int nz_run_count(const nz_run *r);
void nz_run_point(const nz_run *r, int i, double *t, const double **y, const double **acc,
                  const double **root);
void nz_run_clear(nz_run *r);

/* The monotonic clock the pauses use (the one of mech.now()). */
double nz_run_clock(void);

#endif
