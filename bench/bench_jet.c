/* bench_jet.c - jet arithmetic directly in C: operations per second for
 * mul, div, sin and exp at orders 1, 4, 16, 64, with 0 and 4 tangents.
 * Prints a table; nothing here is asserted (speed is measured, not tested). */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "jets/jet.h"

static double now(void)
{
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

typedef enum { B_MUL, B_DIV, B_SIN, B_EXP, B_COUNT } bench_op;
static const char *names[B_COUNT] = { "mul", "div", "sin", "exp" };

/* Run op repeatedly for about 0.2 s; return operations per second. */
static double rate(bench_op op, int K, int D)
{
  nz_jet *a = nz_jet_alloc(K, D), *b = nz_jet_alloc(K, D), *z = nz_jet_alloc(K, D);
  double *w = malloc(nz_jet_work_len(K) * sizeof(double));
  nz_jet_set_variable(a, 0.7, D > 0 ? 0 : -1);
  nz_jet_set_variable(b, 1.3, D > 1 ? 1 : -1);
  long n = 0;
  double t0 = now(), t;
  do {
    for (int i = 0; i < 64; i++) {
      switch (op) {
      case B_MUL: nz_jet_mul(z, a, b, w); break;
      case B_DIV: nz_jet_div(z, a, b, w); break;
      case B_SIN: nz_jet_apply(z, NZ_FN_SIN, a, w); break;
      default: nz_jet_apply(z, NZ_FN_EXP, a, w); break;
      }
    }
    n += 64;
    t = now() - t0;
  } while (t < 0.2);
  nz_jet_free(a);
  nz_jet_free(b);
  nz_jet_free(z);
  free(w);
  return n / t;
}

int main(void)
{
  int orders[] = { 1, 4, 16, 64 }, tangents[] = { 0, 4 };
  printf("Jet operations in C (million operations per second)\n");
  printf("%6s %9s", "order", "tangents");
  for (int o = 0; o < B_COUNT; o++) printf(" %9s", names[o]);
  printf("\n");
  for (int i = 0; i < 4; i++)
    for (int j = 0; j < 2; j++) {
      printf("%6d %9d", orders[i], tangents[j]);
      for (int o = 0; o < B_COUNT; o++) printf(" %9.3f", rate(o, orders[i], tangents[j]) / 1e6);
      printf("\n");
    }
  return 0;
}
