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

/* Machine code for the kernels the last successful nz_graph_series_begin
 * on p chose: from cache_dir, or compiled there (compile = 1; with
 * compile = 0, NULL "not in the cache").  NULL with a one-line reason in
 * why (a branch, no compiler, ...). */
nz_series_native *nz_series_native_get(const nz_graph_plan *p, const char *cache_dir, int compile,
                                       char *why, size_t whylen);
/* Make nz_graph_series_next on p run it (for every begin that chooses the
 * same kernels).  Detach with nz_series_native_detach before freeing it. */
void nz_series_native_attach(const nz_series_native *s, nz_graph_plan *p);
void nz_series_native_detach(nz_graph_plan *p);
void nz_series_native_free(nz_series_native *s);   /* NULL is harmless */

/* Seconds it took to generate, compile and load (0: from the cache); the
 * computed slots it evaluates; its shared object's path. */
double nz_series_native_seconds(const nz_series_native *s);
int nz_series_native_slots(const nz_series_native *s);
const char *nz_series_native_path(const nz_series_native *s);

#endif
