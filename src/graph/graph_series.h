/* graph_series.h - what the series of a plan (graph.h's nz_graph_series_*)
 * looks like inside, for the code generator that writes it as machine code
 * (series_native.c).  Internal to src/graph.
 *
 * A plan keeps one arena of series, each of L = max_order + 1
 * coefficients: series s is the L doubles from S + s L (the plan's slots:
 * inputs, constants, computed nodes; then the auxiliary series some
 * kernels need: the cosine beside a sine, 1 + x^2 beside atan, ...).
 * nz_graph_series_begin fills coefficient 0 and chooses, for every computed
 * slot, the kernel below that computes its later coefficients; from then on
 * a kernel reads coefficients 0..k of its operands and 0..k-1 of its own
 * series to make coefficient k (the recurrences of series.c). */
#ifndef NZ_GRAPH_SERIES_H
#define NZ_GRAPH_SERIES_H

#include "graph/graph.h"

/* The arena holds at least this order (its stride L at least this + 1),
 * so that L is the same for every series up to it: the machine code of a
 * small plan (series_native.c) is written for that L. */
#define NZ_SERIES_MIN_ORDER 24

typedef enum nz_series_kernel {
  NZ_SK_ADD, NZ_SK_SUB, NZ_SK_MUL, NZ_SK_SCALE, NZ_SK_DIV, NZ_SK_DIVC, NZ_SK_SQR, NZ_SK_POWI,
  NZ_SK_POWR, NZ_SK_POW, NZ_SK_EXP, NZ_SK_LOG, NZ_SK_SQRT, NZ_SK_SIN, NZ_SK_COS, NZ_SK_SINH,
  NZ_SK_COSH, NZ_SK_TAN, NZ_SK_TANH, NZ_SK_ATAN, NZ_SK_ASIN, NZ_SK_ACOS, NZ_SK_ATAN2,
  NZ_SK_HYPOT, NZ_SK_STEP, NZ_SK_COPY
} nz_series_kernel;

/* One computed slot as the last begin set it up: its kernel, the graph
 * node's op and function, the series of the slot (z), of its operands (a;
 * b = a for unary ops; a = the chosen operand for NZ_SK_COPY) and its
 * first auxiliary series (aux, aux + 1, ...); v the constant factor
 * (NZ_SK_SCALE), divisor (NZ_SK_DIVC), exponent (NZ_SK_POWR) or scale
 * (NZ_SK_HYPOT: max(|a_0|, |b_0|), which changes with the state); n the
 * exponent of NZ_SK_POWI. */
typedef struct nz_series_slot {
  int kernel, gop, fn;
  int z, a, b, aux;
  unsigned n;
  double v;
} nz_series_slot;

/* The computed slots in evaluation order into slots[] (NULL: only count)
 * and the number of series in the arena; returns how many computed slots,
 * or -1 before a successful begin. */
int nz_graph_series_layout(const nz_graph_plan *p, nz_series_slot *slots, int *nseries);

/* A signature of the kernels the last begin chose (equal signatures: the
 * same kernel for every slot), 0 before a successful begin. */
unsigned long nz_graph_series_signature(const nz_graph_plan *p);

/* Machine code for coefficient k of every computed slot: S the arena, L
 * its stride, v[i] the v of computed slot i (k = 0 sets NZ_SK_HYPOT's,
 * which changes with the state), K the kernels it calls rather than
 * inlines (series_native.c's table).  k = 0 is begin's coefficient 0 with
 * begin's domain checks for an order >= 1.  Returns nonzero when a
 * coefficient it made is not finite or a check fails: the interpreter then
 * does the work again and names the node. */
typedef int (*nz_series_code)(int k, int L, double *S, double *v, void (*const *K)(void));

/* The input slots of the plan (series 0 .. nin - 1): in_num[s] = the
 * input number of slot s (in_num may be NULL: only count); returns nin, or
 * -1 before a successful begin.  And the series of output r. */
int nz_graph_series_input_slots(const nz_graph_plan *p, int *in_num);
int nz_graph_series_output(const nz_graph_plan *p, int r);

/* Machine code that fills coefficients 1 .. N of every slot itself, the
 * inputs' included (a fused loop: series_native.c's second-order ODE);
 * `a` is the caller's.  Returns 0, or nonzero when it refused. */
typedef int (*nz_series_loop)(int N, int L, double *S, double *v, void (*const *K)(void), double *a);
/* After a begin to order >= N whose kernels have signature sig: run loop
 * on the arena; when it returns 0 the plan holds coefficients 0 .. N (as
 * after nz_graph_series_next up to N).  Returns loop's value, or -1 when it
 * does not apply (then nothing was run). */
int nz_graph_series_loop(nz_graph_plan *p, nz_series_loop loop, void (*const *K)(void), unsigned long sig, int N,
                         double *a);

/* Let nz_graph_series_next run code (NULL: the interpreter again) for
 * every begin whose signature is sig; K stays the caller's. */
void nz_graph_series_use(nz_graph_plan *p, nz_series_code code, void (*const *K)(void), unsigned long sig);

#endif
