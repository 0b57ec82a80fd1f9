/* pendulum_c.c - the baseline of bench/accel_scaling.lua: the accelerations
 * of the n-link planar pendulum of bench/mech.lua written by hand in C.
 *
 * The model (bench/mech.lua, chain(k)): k particles, particle i (1-based)
 * of mass m_i = 1 + 0.1 i at
 *   x_i = sum_{j<=i} l sin(th_j),  y_i = -sum_{j<=i} l cos(th_j),  l = 0.5,
 * gravity (0, -g, 0) with g = 9.81; the coordinates th_j are absolute
 * angles from the downward vertical.  With mu_p = sum_{i>=p} m_i (the mass
 * hanging from link p),
 *   T = 1/2 sum_{j,k} M_jk thd_j thd_k,  M_jk = l^2 mu_max(j,k) cos(th_j - th_k),
 *   V = -g l sum_j mu_j cos(th_j),
 * and Lagrange's equations are M thdd + h = 0 with
 *   h_j = l^2 sum_k mu_max(j,k) sin(th_j - th_k) thd_k^2 + g l mu_j sin(th_j).
 * sin and cos of each angle are taken once, the differences by the
 * addition formulas (what one writes by hand); M is factored by a
 * hand-written Cholesky, O(k^3/6).
 *
 * Prints ns per accel (median of SAMPLES samples, each a loop of at least
 * ~10 ms, clock_gettime) for k = 2, 4, 8, 16, 32, then the state and the
 * accelerations at k = 8 with 17 digits (bench/accel_scaling.lua reads
 * them); `pendulum_c accel K...` times the K given (up to KMAX, for
 * bench/scale.lua), `pendulum_c sim K T1 TOL` integrates (below).  The state: th_i = 0.7 sin(1.3 i + 0.5), thd_i = 0.9 cos(0.7 i + 0.2). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>

#define KMAX 128
#define SAMPLES 9
#define LINK 0.5
#define GRAV 9.81

/* Wall time, or this process's processor time when PENDULUM_C_CPU is set
 * (bench/scale.lua: on a shared machine the time a process is not running
 * is not its own). */
static double now(void)
{
  static int cpu = -1;
  if (cpu < 0) cpu = getenv("PENDULUM_C_CPU") != NULL;
  struct timespec ts;
  clock_gettime(cpu ? CLOCK_PROCESS_CPUTIME_ID : CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void state(int k, double *q, double *qd)
{
  for (int i = 1; i <= k; i++) {
    q[i - 1] = 0.7 * sin(1.3 * i + 0.5);
    qd[i - 1] = 0.9 * cos(0.7 * i + 0.2);
  }
}

/* qdd = -M^{-1} h at (q, qd); 0, or -1 when M is not positive definite. */
static int accel(int k, const double *q, const double *qd, double *qdd)
{
  double s[KMAX], c[KMAX], mu[KMAX], M[KMAX][KMAX], b[KMAX];
  const double l2 = LINK * LINK;
  double acc = 0.0;
  for (int j = k - 1; j >= 0; j--) {          /* mu_j: the mass at and below link j */
    acc += 1.0 + 0.1 * (j + 1);
    mu[j] = acc;
    s[j] = sin(q[j]);
    c[j] = cos(q[j]);
  }
  for (int j = 0; j < k; j++) {
    double h = GRAV * LINK * mu[j] * s[j];
    for (int i = 0; i < k; i++) {
      double m = l2 * mu[i > j ? i : j];
      if (i <= j) M[j][i] = m * (c[j] * c[i] + s[j] * s[i]);   /* lower triangle */
      h += m * (s[j] * c[i] - c[j] * s[i]) * qd[i] * qd[i];
    }
    b[j] = -h;
  }
  for (int j = 0; j < k; j++) {               /* M = L L^T, L in the lower triangle */
    double d = M[j][j];
    for (int p = 0; p < j; p++) d -= M[j][p] * M[j][p];
    if (!(d > 0.0)) return -1;
    d = sqrt(d);
    M[j][j] = d;
    for (int i = j + 1; i < k; i++) {
      double v = M[i][j];
      for (int p = 0; p < j; p++) v -= M[i][p] * M[j][p];
      M[i][j] = v / d;
    }
  }
  for (int i = 0; i < k; i++) {               /* L z = b */
    double v = b[i];
    for (int p = 0; p < i; p++) v -= M[i][p] * b[p];
    b[i] = v / M[i][i];
  }
  for (int i = k - 1; i >= 0; i--) {          /* L^T qdd = z */
    double v = b[i];
    for (int p = i + 1; p < k; p++) v -= M[p][i] * qdd[p];
    qdd[i] = v / M[i][i];
  }
  return 0;
}

/* Called through a volatile pointer, so that the compiler can neither
 * inline a call nor hoist it out of the timing loop. */
static int (*volatile accel_fn)(int, const double *, const double *, double *) = accel;

static int cmp(const void *a, const void *b)
{
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* Median seconds per accel at k. */
static double time_accel(int k)
{
  double q[KMAX], qd[KMAX], qdd[KMAX], samples[SAMPLES], sink = 0.0;
  state(k, q, qd);
  long n = 1;
  for (;;) {                                  /* a loop of at least 10 ms */
    double t0 = now();
    for (long r = 0; r < n; r++) accel_fn(k, q, qd, qdd);
    if (now() - t0 >= 1e-2) break;
    n *= 2;
  }
  for (int s = 0; s < SAMPLES; s++) {
    double t0 = now();
    for (long r = 0; r < n; r++) {
      accel_fn(k, q, qd, qdd);
      sink += qdd[0];
    }
    samples[s] = (now() - t0) / (double)n;
  }
  if (sink != sink) fprintf(stderr, "pendulum_c: NaN accelerations\n");
  qsort(samples, SAMPLES, sizeof(double), cmp);
  return samples[SAMPLES / 2];
}

static void print_vector(const char *name, int k, const double *v)
{
  printf("%s", name);
  for (int i = 0; i < k; i++) printf(" %.17g", v[i]);
  printf("\n");
}

typedef struct {
  int k;
  unsigned long nfev;
} chain;

static int rhs(double t, const double y[], double f[], void *params)
{
  (void)t;
  chain *c = params;
  c->nfev++;
  memcpy(f, y + c->k, (size_t)c->k * sizeof(double));
  return accel(c->k, y, y + c->k, f + c->k) ? GSL_EBADFUNC : GSL_SUCCESS;
}

/* One run; seconds, or -1 when GSL fails.  y: 2 k, the final state. */
static double simulate(chain *c, double t1, double tol, unsigned long *steps, unsigned long *rejected, double *y)
{
  int k = c->k;
  gsl_odeiv2_system sys = { rhs, NULL, (size_t)(2 * k), c };
  double t0 = now();
  gsl_odeiv2_driver *d = gsl_odeiv2_driver_alloc_standard_new(&sys, gsl_odeiv2_step_rk8pd, 1e-3, tol, tol, 1.0, 0.0);
  if (!d) return -1.0;
  double t = 0.0, h = 1e-3;
  for (int i = 1; i <= k; i++) {
    y[i - 1] = 0.7 * sin(1.3 * i + 0.5);
    y[k + i - 1] = 0.0;
  }
  c->nfev = 0;
  int st = GSL_SUCCESS;
  while (t < t1 && st == GSL_SUCCESS) st = gsl_odeiv2_evolve_apply(d->e, d->c, d->s, &sys, &t, t1, &h, y);
  *steps = d->e->count;
  *rejected = d->e->failed_steps;
  gsl_odeiv2_driver_free(d);
  return st == GSL_SUCCESS ? now() - t0 : -1.0;
}

static int sim_main(int argc, char **argv)
{
  chain c = { argc > 2 ? atoi(argv[2]) : 0, 0 };
  double t1 = argc > 3 ? atof(argv[3]) : 0.0, tol = argc > 4 ? atof(argv[4]) : 0.0;
  if (c.k < 1 || c.k > KMAX || !(t1 > 0.0) || !(tol > 0.0)) {
    fprintf(stderr, "pendulum_c: usage: pendulum_c sim K T1 TOL (K = 1..%d, T1 > 0, TOL > 0)\n", KMAX);
    return 2;
  }
  double y[2 * KMAX], times[SAMPLES];
  unsigned long steps = 0, rejected = 0;
  for (int r = 0; r < SAMPLES; r++) {
    times[r] = simulate(&c, t1, tol, &steps, &rejected, y);
    if (times[r] < 0.0) {
      fprintf(stderr, "pendulum_c: the integration failed\n");
      return 1;
    }
  }
  qsort(times, SAMPLES, sizeof(double), cmp);
  printf("sim %d %g %g %.6e %lu %lu %lu", c.k, t1, tol, times[SAMPLES / 2], steps, rejected, c.nfev);
  for (int i = 0; i < 2 * c.k; i++) printf(" %.17g", y[i]);
  printf("\n");
  return 0;
}

/* "accel K..." (bench/scale.lua): the ns per accel of each K, one line
 * "accel K NS" each. */
static int accel_main(int argc, char **argv)
{
  for (int i = 2; i < argc; i++) {
    int k = atoi(argv[i]);
    if (k < 1 || k > KMAX) {
      fprintf(stderr, "pendulum_c: usage: pendulum_c accel K... (K = 1..%d)\n", KMAX);
      return 2;
    }
    printf("accel %d %.1f\n", k, 1e9 * time_accel(k));
  }
  return 0;
}

int main(int argc, char **argv)
{
  if (argc > 1 && !strcmp(argv[1], "sim")) return sim_main(argc, argv);
  if (argc > 1 && !strcmp(argv[1], "accel")) return accel_main(argc, argv);
  const int ks[] = { 2, 4, 8, 16, 32 };
  printf("Hand-written C accelerations of the n-link pendulum of bench/mech.lua (M, h by formula, Cholesky)\n");
  printf("%4s %12s\n", "k", "ns/accel");
  for (int i = 0; i < 5; i++) printf("%4d %12.1f\n", ks[i], 1e9 * time_accel(ks[i]));
  double q[KMAX], qd[KMAX], qdd[KMAX];
  state(8, q, qd);
  if (accel(8, q, qd, qdd)) {
    fprintf(stderr, "pendulum_c: M not positive definite at k = 8\n");
    return 1;
  }
  print_vector("q8", 8, q);
  print_vector("qd8", 8, qd);
  print_vector("qdd8", 8, qdd);
  return 0;
}
