/* graph_native.h - expression graphs compiled to machine code.
 *
 * The plan interpreter of graph_plan.c costs a few nanoseconds per node; the same
 * formulas written in C cost a fraction of one.  This module writes C for the
 * double evaluation of some outputs of a graph (straight-line code, one local
 * per node, the scalar kernels of graph_impl.h copied in so that the results are
 * the interpreter's bit for bit), compiles it with the system's C compiler
 * into a shared object, and loads it back with dlopen.  The object is cached
 * in a cache on disk (native_object.h has its rules: trust, integrity, the
 * compiler in a background worker, the size bound): the same graph compiled
 * again, by this process or another, is loaded from the cache without
 * running the compiler.
 *
 * The compiler is $CC if set (words split on blanks, e.g. "ccache gcc"),
 * else "cc", run with -O2 (-O1 above 5000 nodes: half the compile time, the
 * same speed; $NZLUA_COPT overrides), -fPIC -shared
 * -ffp-contract=off -fno-builtin (a fused multiply-add, or sin(atan(x))
 * rewritten as x / sqrt(1 + x^2), would round differently from the
 * interpreter); never -ffast-math.  When there is no compiler, the caller
 * keeps the interpreter: nz_native_compile says why it could not.
 *
 * Failures.  nz_native_eval refuses (NZ_EDOM) exactly when nz_graph_eval
 * fails: some node left its domain or gave an infinity or a NaN, even if a
 * later node masks it (atan(inf) is finite) or is the branch a select does
 * not take (both branches are computed).  It does not say which node:
 * the caller re-runs nz_graph_eval to name it.
 *
 * Plain C: never includes lua.h, never prints, never exits. */
#ifndef NZ_GRAPH_NATIVE_H
#define NZ_GRAPH_NATIVE_H

#include <stddef.h>
#include "graph/graph.h"
#include "graph/native_cache.h"

typedef struct nz_native nz_native;

/* Generate C for outputs[0..n-1] of g, compile it into a shared object in
 * cache_dir (created if missing), or load it from there if it is present.
 * NULL on any failure (unsupported node, no compiler, compile error, dlopen
 * failure, unwritable cache), with a one-line reason in why[whylen] (why may
 * be NULL).  g may change or be freed afterwards: the object keeps nothing
 * of it. */
nz_native *nz_native_compile(const nz_graph *g, const int *outputs, int n, const char *cache_dir,
                             char *why, size_t whylen);

/* Evaluate: in[] as nz_graph_eval's (indexed by input number), out[n].
 * NZ_OK, or NZ_EDOM when some node left its domain or was not finite (out
 * is then unspecified).  in and out may overlap.  One nz_native holds a
 * workspace: two threads must not evaluate the same one at once. */
/* The same object if it is already in the cache, else NULL without compiling
 * (the cost of generating the source and hashing it: microseconds per node). */
nz_native *nz_native_load(const nz_graph *g, const int *outputs, int n, const char *cache_dir,
                          char *why, size_t whylen);
/* The same object if it is in the cache, else one whose compile has started
 * in the background (NULL, with why, when neither can be had: no compiler,
 * an untrusted cache, ...).  Before nz_native_eval, nz_native_ready must
 * have returned 0. */
nz_native *nz_native_start(const nz_graph *g, const int *outputs, int n, const char *cache_dir,
                           char *why, size_t whylen);
/* 0 when f is loaded, 1 while it compiles (wait = 1: block until done, or
 * until a Ctrl-C request), -1 when compiling failed (why says why; free f). */
int nz_native_ready(nz_native *f, int wait, char *why, size_t whylen);

nz_status nz_native_eval(const nz_native *f, const double *in, double *out);
/* The machine code itself, for a caller on a hot path whose in and out
 * never overlap: fn(in, out, work) returns nonzero where nz_native_eval
 * gives NZ_EDOM. */
typedef int (*nz_native_fn)(const double *in, double *out, double *work);
nz_native_fn nz_native_entry(const nz_native *f, double **work);

void nz_native_free(nz_native *f);   /* NULL is harmless */

/* Seconds the compile took (generation, compiler, loading: wall time, in
 * the background or not); 0 when the object came from the cache.  Of
 * those, the seconds a caller waited for it (nz_native_compile). */
double nz_native_compile_seconds(const nz_native *f);
double nz_native_waited(const nz_native *f);
/* The shared object's path, and the number of computed nodes it evaluates. */
const char *nz_native_path(const nz_native *f);
int nz_native_nodes(const nz_native *f);
/* 1 when f is compact code, 0 straight-line code (see above). */
int nz_native_compact_code(const nz_native *f);

#endif
