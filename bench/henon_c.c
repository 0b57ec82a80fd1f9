/* henon_c.c - the baseline of bench/henon.lua: Henon-Heiles,
 *   H = (px^2 + py^2)/2 + (x^2 + y^2)/2 + x^2 y - y^3/3,
 * integrated from q = (0, 0.1), qd = (0.5, 0) (E = 0.1297 < 1/6) over
 * t = 0..2000 with GSL's rk8pd and a right-hand side written by hand.
 *
 * It drives GSL exactly as nzlua does (src/ode/ode.c, lua/nz/motion/simulate.lua with
 * dt = t1, the lightest output): a standard control with eps_abs = atol,
 * eps_rel = rtol, a_y = 1, a_dydt = 0; first step h0 = min(dt, 1e-3) =
 * 1e-3; gsl_odeiv2_evolve_apply towards t1 until it is reached, the step
 * carried from call to call.  Only the final state is kept.
 *
 * Prints, per tolerance, the median wall time of RUNS runs (clock_gettime;
 * each run allocates and frees its GSL objects, as a simulate call does),
 * the accepted and rejected steps, the right-hand side evaluations and the
 * final state with 17 digits (bench/henon.lua reads these lines); then
 * the same with the accelerations moved by one ulp now and then, to show what a
 * rounding-level difference of the right-hand side does to the steps. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>

#define RUNS_DEFAULT 9
#define T1 2000.0
#define H0 1e-3

typedef struct {
  unsigned long nfev;
  int jitter;              /* move the accelerations by one ulp now and then */
} counter;

static double now(void)
{
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* y = (x, y, xd, yd): x'' = -x - 2 x y, y'' = -y - x^2 + y^2. */
static int rhs(double t, const double y[], double f[], void *params)
{
  (void)t;
  counter *c = params;
  c->nfev++;
  f[0] = y[2];
  f[1] = y[3];
  f[2] = -y[0] - 2.0 * y[0] * y[1];
  f[3] = -y[1] - y[0] * y[0] + y[1] * y[1];
  if (c->jitter) {         /* a fixed pseudo-random third of the calls, each component its own */
    if ((c->nfev * 2654435761u) % 3 == 0) f[2] = nextafter(f[2], 0.0);
    if ((c->nfev * 40503u) % 3 == 1) f[3] = nextafter(f[3], 1.0);
  }
  return GSL_SUCCESS;
}

typedef struct {
  double seconds;
  unsigned long steps, rejected, nfev;
  double y[4];
} result;

/* One run from the start to T1; 0, or GSL's status. */
static int run(double tol, int jitter, result *r)
{
  counter c = { 0, jitter };
  gsl_odeiv2_system sys = { rhs, NULL, 4, &c };
  double t0 = now();
  gsl_odeiv2_driver *d = gsl_odeiv2_driver_alloc_standard_new(&sys, gsl_odeiv2_step_rk8pd, H0, tol, tol, 1.0, 0.0);
  if (!d) return GSL_ENOMEM;
  double t = 0.0, h = H0, y[4] = { 0.0, 0.1, 0.5, 0.0 };
  int st = GSL_SUCCESS;
  while (t < T1 && st == GSL_SUCCESS) st = gsl_odeiv2_evolve_apply(d->e, d->c, d->s, &sys, &t, T1, &h, y);
  r->steps = d->e->count;
  r->rejected = d->e->failed_steps;
  gsl_odeiv2_driver_free(d);
  r->seconds = now() - t0;
  r->nfev = c.nfev;
  for (int i = 0; i < 4; i++) r->y[i] = y[i];
  return st;
}

static int cmp(const void *a, const void *b)
{
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
  int runs = argc > 1 ? atoi(argv[1]) : RUNS_DEFAULT;
  if (runs < 1 || runs > 1000) {
    fprintf(stderr, "henon_c: the number of runs must be 1..1000, got %s\n", argv[1]);
    return 2;
  }
  const double tols[] = { 1e-12, 1e-15 };
  double *times = malloc((size_t)runs * sizeof(double));
  if (!times) return 1;
  printf("GSL rk8pd with a hand-written C right-hand side: Henon-Heiles, t = 0..2000 (median of %d runs)\n", runs);
  printf("%-6s %12s %8s %8s %8s %24s %24s %24s %24s\n", "tol", "seconds", "steps", "rejected", "nfev", "x", "y",
         "xd", "yd");
  for (int i = 0; i < 2; i++) {
    result r;
    for (int j = 0; j < runs; j++) {
      int st = run(tols[i], 0, &r);
      if (st) {
        fprintf(stderr, "henon_c: GSL failed at tol %g: %s\n", tols[i], gsl_strerror(st));
        return 1;
      }
      times[j] = r.seconds;
    }
    qsort(times, (size_t)runs, sizeof(double), cmp);
    printf("%-6.0e %12.6e %8lu %8lu %8lu %24.17g %24.17g %24.17g %24.17g\n", tols[i], times[runs / 2], r.steps,
           r.rejected, r.nfev, r.y[0], r.y[1], r.y[2], r.y[3]);
  }
  /* What rounding alone does: the same runs with each acceleration moved
   * by one ulp in about a third of the calls, the size of the difference
   * between two correct right-hand sides (nzlua's and this one). */
  printf("The same with the accelerations moved by one ulp in a third of the calls, one run each\n");
  for (int i = 0; i < 2; i++) {
    result r;
    int st = run(tols[i], 1, &r);
    if (st) {
      fprintf(stderr, "henon_c: GSL failed at tol %g: %s\n", tols[i], gsl_strerror(st));
      return 1;
    }
    printf("ulp %-6.0e %8lu %8lu %8lu %24.17g %24.17g %24.17g %24.17g\n", tols[i], r.steps, r.rejected, r.nfev,
           r.y[0], r.y[1], r.y[2], r.y[3]);
  }
  free(times);
  return 0;
}
