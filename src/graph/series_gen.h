/* series_gen.h - what the two emitters of a plan's series share
 * (series_native.c writes straight-line code, series_compact.c compact
 * code): the C of one kernel, on operands given as C expressions, and the
 * generated functions' conventions.  Internal to src/graph.
 *
 * Both write functions nzs_part0 .. nzs_part<n-1>(k, L, S, v, K) that fill
 * coefficient k of their slots and return 0.0, or a NaN when a coefficient
 * tested is not finite or a check of k = 0 failed; series_native.c's
 * nzs_next and nzs_ode2 call them in order. */
#ifndef NZ_SERIES_GEN_H
#define NZ_SERIES_GEN_H

#include "graph/graph_series.h"
#include "graph/native_object.h"
#include "graph/native_tables.h"

/* The kernels the generated code calls through K, in this order. */
enum { K_POWI, K_POW, K_QUAD, K_ATAN2, K_COUNT };

/* One slot's operands as C expressions: its series (z), its operands' (a,
 * b), its auxiliary series (w[0..3]), its constant (v: a factor, divisor
 * or exponent) and the lvalue of its scale (vi, NZ_SK_HYPOT's v[i]); n the
 * exponent of NZ_SK_POWI. */
typedef struct nz_series_ref {
  const char *z, *a, *b, *w[4], *v, *vi;
  unsigned n;
} nz_series_ref;

/* The statements of one kernel at coefficient k (a variable in scope, as
 * are S, l, L, v, K and `bad`), series.c's recurrences. */
void nz_series_emit_kernel(nz_sbuf *b, int kernel, const nz_series_ref *r);

/* Compact code for the slots[0..n) of a plan of nseries series (used[s]:
 * series s is read by a slot, so its failure shows downstream): the parts
 * into b, their count returned, the index tables into *tab. */
int nz_series_emit_compact(nz_sbuf *b, const nz_series_slot *slots, int n, int nseries, const char *used,
                           nz_ctab *tab);

#endif
