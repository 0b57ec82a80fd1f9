/* series_native.h - the series of a plan built order by order
 * (graph.h's nz_graph_series_next) as machine code.
 *
 * A Taylor integrator spends its time in nz_graph_series_next: coefficient
 * k of every node, for k = 1 .. the order, at every step.  The interpreter
 * dispatches on each node's kernel and checks each coefficient; the
 * machine code is straight-line C for the kernels the plan's begin chose,
 * the same recurrences in the same order (series.c), so its coefficients
 * are the interpreter's bit for bit; it checks them all with one sum (a
 * coefficient that is not finite makes the interpreter redo coefficient k
 * and name the node).  Compiled, cached and loaded as the plans on doubles
 * are (native_object.h).
 *
 * Not for plans with branches (cmp, select, sign, abs): their kernels
 * change with the state at each begin.  (A Taylor run refuses those
 * anyway: its series must not cross a switch.)
 *
 * Plain C: never includes lua.h, never prints. */
#ifndef NZ_SERIES_NATIVE_H
#define NZ_SERIES_NATIVE_H

#include <stddef.h>
#include "graph/graph.h"

typedef struct nz_series_native nz_series_native;

/* A second-order ODE on the plan: its outputs acc[i] are q_i'' (i < k),
 * with q_i the input number pos[i] and q_i' the input vel[i]; t the input
 * `time` (-1: none); every other input the plan reads is constant.  Given
 * it, the object also holds the whole series of a step as one loop
 * (nz_series_native_ode2): no call per order, the inputs of order n
 * written from the coefficients already found. */
typedef struct nz_series_ode2 {
  int k, time;
  const int *pos, *vel, *acc;
} nz_series_ode2;

/* Machine code for the kernels the last successful nz_graph_series_begin
 * on p chose (and for the loop of ode2, which may be NULL): from
 * cache_dir, else as how says: 0 not at all (NULL, "not in the cache"), 1
 * compiled now, 2 compiled in the background (then nz_series_native_ready
 * says when it can be attached).  NULL with a one-line reason in why (a
 * branch, no compiler, an untrusted cache, ...). */
nz_series_native *nz_series_native_get(const nz_graph_plan *p, const nz_series_ode2 *ode2, const char *cache_dir,
                                       int how, char *why, size_t whylen);
/* 0 when s is loaded (attach it), 1 while it compiles (wait = 1: block),
 * -1 when compiling failed (why; free s). */
int nz_series_native_ready(nz_series_native *s, int wait, char *why, size_t whylen);
/* With an object made with ode2, after a begin of p to order N at q0, q'0
 * = a[0 .. 2k): a[(n + 2) k + i] = q_i''s coefficient n / ((n + 1)(n + 2))
 * for n = 0 .. N, the numbers nz_graph_series_next would give order by
 * order.  0; nonzero when it does not apply or a coefficient is not finite
 * (the caller then goes order by order, where the interpreter names the
 * node). */
int nz_series_native_ode2(const nz_series_native *s, nz_graph_plan *p, int N, double *a);
/* Make nz_graph_series_next on p run it (for every begin that chooses the
 * same kernels).  Detach with nz_series_native_detach before freeing it. */
void nz_series_native_attach(const nz_series_native *s, nz_graph_plan *p);
void nz_series_native_detach(nz_graph_plan *p);
void nz_series_native_free(nz_series_native *s);   /* NULL is harmless */

/* Seconds it took to generate, compile and load (0: from the cache); the
 * computed slots it evaluates; its shared object's path. */
double nz_series_native_seconds(const nz_series_native *s);
double nz_series_native_waited(const nz_series_native *s);   /* of which a caller waited */
int nz_series_native_slots(const nz_series_native *s);
/* 1 when s is compact code, 0 straight-line code (graph_native.h). */
int nz_series_native_compact_code(const nz_series_native *s);
const char *nz_series_native_path(const nz_series_native *s);

#endif
