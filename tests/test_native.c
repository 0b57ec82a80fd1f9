/* test_native.c - graphs compiled to C (graph_native.c) against the plan
 * interpreter of graph.c, which shares no code with it: the same values bit
 * for bit and the same refusals, on every operation at special values
 * (zeros, infinities, NaN, the edges of the domains), on random graphs that
 * use every operation, and on big graphs; refusals hidden behind a masking
 * node; the cache (a second compile loads the same file without running
 * the compiler; two processes compiling at once); a missing compiler, a
 * failing compiler and an unwritable cache directory give NULL and a reason.
 * Timing lines (not tests) compare the native code with the interpreter and
 * give the compile times.  GSL-style PASS/FAIL lines. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <gsl/gsl_test.h>
#include "graph/graph_native.h"
#include "jets/series.h"
#include "graph/graph_series.h"
#include "graph/native_tables.h"
#include "graph/series_native.h"
#include "graph/native_elf.h"
#include "test_util.h"
#include <fcntl.h>

#if defined(__SANITIZE_ADDRESS__)
#define SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SANITIZED 1
#endif
#endif
#ifndef SANITIZED
#define SANITIZED 0
#endif

static char cache[64];   /* a fresh directory per run: every first compile compiles */
static char why[600];
/* The emitter the checks run on (NZLUA_COMPACT, native_tables.h): every
 * check of the interpreter against machine code runs twice, once on
 * straight-line code, once on compact code. */
static const char *code = "straight-line code";

static uint64_t rng = 0x9E3779B97F4A7C15ULL;
static double urand(void) { return test_urand(&rng); }
static int irand(int n) { return (int)(urand() * n); }

static double seconds(void)
{
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static nz_native *compile(const nz_graph *g, const int *outs, int n)
{
  nz_native *f = nz_native_compile(g, outs, n, cache, why, sizeof why);
  if (!f) printf("# compile failed: %s\n", why);
  return f;
}

static int same_bits(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

/* Evaluate both ways at in[]; 0 when they agree: both refuse, or both
 * accept with the same bits in every output.  *ok: the interpreter accepted. */
static int agree(nz_graph_plan *p, const nz_native *f, int n, const double *in, int *ok, char *msg, size_t ml)
{
  double a[4096], b[4096];
  nz_status si = nz_graph_eval(p, in, a), sn = nz_native_eval(f, in, b);
  *ok = si == NZ_OK;
  if ((si == NZ_OK) != (sn == NZ_OK)) {
    snprintf(msg, ml, "interpreter status %d, native %d", (int)si, (int)sn);
    return 1;
  }
  if (si == NZ_OK)
    for (int r = 0; r < n; r++)
      if (!same_bits(a[r], b[r])) {
        snprintf(msg, ml, "output %d: interpreter %.17g, native %.17g", r, a[r], b[r]);
        return 1;
      }
  return 0;
}

/* ------------------------------------------------------------------ */
/* Every operation at special values                                    */

static const double specials[] = { 0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.0, -3.0, 1000.0, -1000.0,
                                   1e300, -1e300, 4e-310, INFINITY, -INFINITY, NAN };
#define NSPEC ((int)(sizeof specials / sizeof specials[0]))

/* Operation k of the list below on nodes x, y of g, or -1 past the end;
 * *name describes it.  The selects: on inputs (a NaN condition fails, an
 * infinite branch fails only when taken: inputs are not nodes that fail), on
 * a comparison with a failing branch taken or not (the interpreter refuses
 * both), on a computed condition that may be infinite or NaN. */
static const double powc_exps[] = { 2, 3, 7, 1e9, -1, -2, 0.5, 1.5, -0.5, 1.0 / 3, 2e9 + 1, -4e9 };
#define NPOWC ((int)(sizeof powc_exps / sizeof powc_exps[0]))
static int op_k(nz_graph *g, int k, int x, int y, char *name, size_t nl)
{
  static const nz_gop bin[] = { NZ_GOP_ADD, NZ_GOP_SUB, NZ_GOP_MUL, NZ_GOP_DIV, NZ_GOP_POW,
                                NZ_GOP_ATAN2, NZ_GOP_HYPOT };
  int nb = (int)(sizeof bin / sizeof bin[0]);
  if (k < nb) { snprintf(name, nl, "%s", nz_gop_names[bin[k]]); return nz_graph_op(g, bin[k], x, y); }
  k -= nb;
  if (k == 0) { snprintf(name, nl, "neg"); return nz_graph_op(g, NZ_GOP_NEG, x, -1); }
  k--;
  if (k < NPOWC) { snprintf(name, nl, "x^%g", powc_exps[k]); return nz_graph_powc(g, x, powc_exps[k]); }
  k -= NPOWC;
  if (k < NZ_FN_COUNT) { snprintf(name, nl, "%s", nz_jet_fn_names[k]); return nz_graph_fn(g, (nz_jet_fn)k, x); }
  k -= NZ_FN_COUNT;
  static const char *const cmps[] = { "x < y", "x <= y", "x > y", "x >= y", "x == y", "x ~= y" };
  if (k <= NZ_CMP_NE) { snprintf(name, nl, "%s", cmps[k]); return nz_graph_cmp(g, (nz_cmp)k, x, y); }
  k -= NZ_CMP_NE + 1;
  switch (k) {
  case 0: snprintf(name, nl, "select(x, y, x)"); return nz_graph_select(g, x, y, x);
  case 1:
    snprintf(name, nl, "select(x < y, sqrt(y), log(x))");
    return nz_graph_select(g, nz_graph_cmp(g, NZ_CMP_LT, x, y), nz_graph_fn(g, NZ_FN_SQRT, y),
                           nz_graph_fn(g, NZ_FN_LOG, x));
  case 2:
    snprintf(name, nl, "select(x - y, 1/x, y)");
    return nz_graph_select(g, nz_graph_op(g, NZ_GOP_SUB, x, y),
                           nz_graph_op(g, NZ_GOP_DIV, nz_graph_const(g, 1.0), x), y);
  default: return -1;
  }
}

/* For each operation z = op(x, y): outputs {z}, {atan(z)} (z tested for
 * itself: atan masks inf), {atan(sin(z) + x)} (z passes its failure on
 * through the strict sin and +; sin keeps -x + x from becoming 0), each at
 * every pair of special values. */
static void check_specials(void)
{
  char name[64], msg[200];
  for (int k = 0;; k++) {
    nz_graph *g = nz_graph_new();
    int x = nz_graph_input(g, 0), y = nz_graph_input(g, 1);
    int z = op_k(g, k, x, y, name, sizeof name);
    if (z < 0) { nz_graph_free(g); break; }
    int shapes[3] = { z, nz_graph_fn(g, NZ_FN_ATAN, z),
                      nz_graph_fn(g, NZ_FN_ATAN, nz_graph_op(g, NZ_GOP_ADD, nz_graph_fn(g, NZ_FN_SIN, z), x)) };
    static const char *const how[3] = { "z", "atan(z)", "atan(sin(z) + x)" };
    for (int s = 0; s < 3; s++) {
      nz_graph_plan *p = nz_graph_plan_new(g, &shapes[s], 1);
      nz_native *f = compile(g, &shapes[s], 1);
      int bad = !f || !p, accepted = 0, refused = 0, ok;
      msg[0] = 0;
      for (int i = 0; f && p && i < NSPEC; i++)
        for (int j = 0; j < NSPEC; j++) {
          double in[2] = { specials[i], specials[j] };
          if (agree(p, f, 1, in, &ok, msg, sizeof msg)) {
            if (!bad++) printf("# %s at x = %g, y = %g: %s\n", name, in[0], in[1], msg);
          }
          accepted += ok;
          refused += !ok;
        }
      /* sign is defined at every double (graph.c: sign(NaN) = 0, and an
       * input is never refused for itself): nothing to refuse but through +. */
      int total = !strcmp(name, "sign") && s < 2;
      gsl_test(bad || !accepted || (!refused && !total),
               "%s as %s: %s = interpreter bit for bit at %d pairs of special values (%d accepted, %d refused)",
               name, how[s], code, NSPEC * NSPEC, accepted, refused);
      nz_native_free(f);
      nz_graph_plan_free(p);
    }
    nz_graph_free(g);
  }
}

/* ------------------------------------------------------------------ */
/* Random graphs using every operation                                  */

/* A new node from values in [-1, 1]: one operation chosen at random, its
 * operands kept in its domain, the result brought back into [-1, 1] by
 * tanh or sin when it may leave it.  A select's condition is a comparison,
 * a sign or a value (nonzero but for a rare exact zero). */
static int no_branches;   /* 1: no cmp, select, sign or abs (for the series) */

static int random_node(nz_graph *g, const int *v, int n)
{
  int a = v[n - 1 - irand(n < 8 ? n : 8)], b = v[irand(n)], z;
  int one = nz_graph_const(g, 1.0), onehalf = nz_graph_const(g, 1.5), two = nz_graph_const(g, 2.0);
  static const double pe[] = { 2, 3, 4, 5, 7, 13, 0.5, 1.5, -0.5, -2.5, 1.0 / 3 };
  int k = irand(no_branches ? 20 : 22), bounded = 0;
  switch (k) {
  case 0: z = nz_graph_op(g, NZ_GOP_ADD, a, b); break;
  case 1: z = nz_graph_op(g, NZ_GOP_SUB, a, b); break;
  case 2: z = nz_graph_op(g, NZ_GOP_MUL, a, b); bounded = 1; break;
  case 3: z = nz_graph_op(g, NZ_GOP_DIV, a, nz_graph_op(g, NZ_GOP_ADD, two, b)); break;
  case 4: z = nz_graph_op(g, NZ_GOP_NEG, a, -1); bounded = 1; break;
  case 5: {
    double p = pe[irand((int)(sizeof pe / sizeof pe[0]))];
    z = nz_graph_powc(g, p == floor(p) && p > 0 ? a : nz_graph_op(g, NZ_GOP_ADD, onehalf, a), p);
    break;
  }
  case 6: z = nz_graph_op(g, NZ_GOP_POW, nz_graph_op(g, NZ_GOP_ADD, onehalf, a), b); break;
  case 7: z = nz_graph_op(g, NZ_GOP_ATAN2, a, b); break;
  case 8: z = nz_graph_op(g, NZ_GOP_HYPOT, a, b); break;
  case 20: z = nz_graph_cmp(g, (nz_cmp)irand(NZ_CMP_NE + 1), a, b); bounded = 1; break;
  case 21: {
    int c = v[irand(n)], w = irand(3);
    if (w == 0) c = nz_graph_cmp(g, (nz_cmp)irand(NZ_CMP_NE + 1), c, v[irand(n)]);
    if (w == 1) c = nz_graph_fn(g, NZ_FN_SIGN, c);
    z = nz_graph_select(g, c, a, b);
    bounded = 1;
    break;
  }
  default: {
    nz_jet_fn fn = (nz_jet_fn)(k - 9);   /* 11 functions: exp .. tanh */
    if (!no_branches && irand(4) == 0) fn = irand(2) ? NZ_FN_ABS : NZ_FN_SIGN;
    int x = a;
    if (fn == NZ_FN_LOG) x = nz_graph_op(g, NZ_GOP_ADD, onehalf, a);
    if (fn == NZ_FN_SQRT) x = nz_graph_op(g, NZ_GOP_ADD, one, a);
    if (fn == NZ_FN_ASIN || fn == NZ_FN_ACOS) x = nz_graph_op(g, NZ_GOP_MUL, nz_graph_const(g, 0.99), a);
    z = nz_graph_fn(g, fn, x);
    bounded = fn == NZ_FN_SIN || fn == NZ_FN_COS || fn == NZ_FN_TANH || fn == NZ_FN_ABS || fn == NZ_FN_SIGN;
  }
  }
  if (!bounded) z = nz_graph_fn(g, irand(2) ? NZ_FN_TANH : NZ_FN_SIN, z);
  return z;
}

/* A random graph of about `size` nodes over 8 inputs; v[] receives the
 * value nodes, returns their count. */
static int random_graph(nz_graph *g, int size, int *v, int cap)
{
  int n = 0;
  for (int i = 0; i < 8; i++) v[n++] = nz_graph_input(g, i);
  while (nz_graph_size(g) < size && n < cap) {
    int z = random_node(g, v, n);
    v[n++] = z;
  }
  return n;
}

/* After a disagreement: the first node whose value differs, for the log
 * (with every node an output the compiled code differs, so this may find
 * none: NZLUA_KEEP_CACHE=1 keeps the sources to compare). */
static void first_difference(nz_graph *g, const double *in)
{
  int N = nz_graph_size(g), *all = malloc((size_t)N * sizeof *all), n = 0;
  const nz_gnode *nd = nz_graph_nodes(g);
  for (int id = 0; id < N; id++)
    if (nd[id].op != NZ_GOP_CONST && nd[id].op != NZ_GOP_INPUT) all[n++] = id;
  nz_graph_plan *p = nz_graph_plan_new(g, all, n);
  nz_native *f = compile(g, all, n);
  double *a = malloc((size_t)n * sizeof *a), *b = malloc((size_t)n * sizeof *b);
  nz_status si = p ? nz_graph_eval(p, in, a) : NZ_ENOMEM, sn = f ? nz_native_eval(f, in, b) : NZ_ENOMEM;
  if (si || sn) printf("# every node as an output: statuses %d and %d\n", (int)si, (int)sn);
  else
    for (int r = 0; r < n; r++) {
      if (same_bits(a[r], b[r])) continue;
      const nz_gnode *x = &nd[all[r]];
      printf("# first difference: node %d = %s %s (v %g) of %d and %d: %.17g against %.17g\n", all[r],
             nz_gop_names[x->op], x->op == NZ_GOP_FN ? nz_jet_fn_names[x->fn] : "", x->v, x->a, x->b,
             a[r], b[r]);
      break;
    }
  free(a);
  free(b);
  free(all);
  nz_native_free(f);
  nz_graph_plan_free(p);
}

static void check_random(int size, int nout, int points)
{
  nz_graph *g = nz_graph_new();
  int cap = size + 8, *v = malloc((size_t)cap * sizeof *v), outs[4096];
  int n = random_graph(g, size, v, cap);
  if (nout > n - 8) nout = n - 8;
  for (int r = 0; r < nout; r++) outs[r] = v[n - 1 - r];   /* the latest */
  int used[NZ_GOP_COUNT + NZ_FN_COUNT] = { 0 }, kinds = 0;
  const nz_gnode *nd = nz_graph_nodes(g);
  for (int id = 0; id < nz_graph_size(g); id++)
    used[nd[id].op == NZ_GOP_FN ? NZ_GOP_COUNT + nd[id].fn : nd[id].op] = 1;
  for (int i = 0; i < NZ_GOP_COUNT + NZ_FN_COUNT; i++) kinds += used[i];
  nz_graph_plan *p = nz_graph_plan_new(g, outs, nout);
  double t0 = seconds();
  nz_native *f = compile(g, outs, nout);
  double tc = seconds() - t0;
  int bad = !f || !p, accepted = 0, ok;
  char msg[200] = "";
  for (int k = 0; f && p && k < points; k++) {
    double in[8];
    for (int i = 0; i < 8; i++) in[i] = 2 * urand() - 1;
    if (agree(p, f, nout, in, &ok, msg, sizeof msg) && !bad++) {
      printf("# %s\n", msg);
      for (int i = 0; i < 8; i++) printf("# in[%d] = %a\n", i, in[i]);
      first_difference(g, in);
    }
    accepted += ok;
  }
  /* Every kind of node but fn as such. */
  int want = NZ_GOP_COUNT - 1 + NZ_FN_COUNT;
  gsl_test(bad || accepted < points / 2 || kinds < want,
           "random graph of %d nodes (%d kinds of node of %d), %d outputs: %s = interpreter bit for bit "
           "at %d points (%d accepted; compiled in %.2f s)",
           nz_graph_size(g), kinds, want, nout, code, points, accepted, tc);
  nz_native_free(f);
  nz_graph_plan_free(p);
  nz_graph_free(g);
  free(v);
}

/* Compositions that a C compiler rewrites when it may (sin(atan(x)) as
 * x / sqrt(x^2 + 1), x^-1 as 1 / x, exp(log(x)) as x, ...), which rounds
 * differently: the native code must still be the interpreter's. */
static void check_rewrites(void)
{
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0), outs[12], n = 0;
  nz_jet_fn outer[] = { NZ_FN_SIN, NZ_FN_COS, NZ_FN_TAN, NZ_FN_SIN, NZ_FN_EXP, NZ_FN_TAN, NZ_FN_SINH,
                        NZ_FN_COSH, NZ_FN_SQRT };
  nz_jet_fn inner[] = { NZ_FN_ATAN, NZ_FN_ATAN, NZ_FN_ATAN, NZ_FN_ASIN, NZ_FN_LOG, NZ_FN_ATAN, NZ_FN_ATAN,
                        NZ_FN_ATAN, NZ_FN_EXP };
  for (int i = 0; i < 9; i++) outs[n++] = nz_graph_fn(g, outer[i], nz_graph_fn(g, inner[i], x));
  outs[n++] = nz_graph_powc(g, x, -1.0);
  outs[n++] = nz_graph_powc(g, x, 0.5);
  outs[n++] = nz_graph_op(g, NZ_GOP_POW, x, nz_graph_fn(g, NZ_FN_COS, x));
  nz_graph_plan *p = nz_graph_plan_new(g, outs, n);
  nz_native *f = compile(g, outs, n);
  int bad = !f || !p, accepted = 0, ok;
  char msg[200];
  for (int k = 0; f && p && k < 100000; k++) {
    double in = 0.001 + 0.998 * urand();   /* in (0, 1): every node defined */
    if (agree(p, f, n, &in, &ok, msg, sizeof msg) && !bad++) printf("# x = %.17g: %s\n", in, msg);
    accepted += ok;
  }
  gsl_test(bad || accepted < 100000,
           "sin(atan x), x^-1, exp(log x) and others a compiler may rewrite: %s = interpreter at 1e5 points", code);
  nz_native_free(f);
  nz_graph_plan_free(p);
  nz_graph_free(g);
}

/* ------------------------------------------------------------------ */
/* Refusals written out                                                 */

static void check_refusals(void)
{
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0);
  int lg = nz_graph_fn(g, NZ_FN_LOG, x);
  int inv = nz_graph_op(g, NZ_GOP_DIV, nz_graph_const(g, 1.0), x);
  int ae = nz_graph_fn(g, NZ_FN_ATAN, nz_graph_fn(g, NZ_FN_EXP, x));
  /* graph.h: select does not protect a failing branch. */
  int zero = nz_graph_const(g, 0.0);
  int sq = nz_graph_select(g, nz_graph_cmp(g, NZ_CMP_GT, x, zero), nz_graph_fn(g, NZ_FN_SQRT, x), zero);
  int sn = nz_graph_select(g, x, nz_graph_const(g, 1.0), nz_graph_const(g, 2.0));
  struct { int node; double bad, good, want; const char *what; } c[] = {
    { lg, -1.0, 2.0, log(2.0), "log(-1)" },
    { inv, 0.0, 4.0, 0.25, "1/0" },
    { ae, 1000.0, 1.0, atan(exp(1.0)), "exp(1000) masked by atan" },
    { sq, -1.0, 4.0, 2.0, "select(x > 0, sqrt(x), 0) at x = -1 (the branch not taken fails)" },
    { sn, NAN, 0.0, 2.0, "select(x, 1, 2) at x = NaN" },
  };
  for (int i = 0; i < (int)(sizeof c / sizeof c[0]); i++) {
    nz_native *f = compile(g, &c[i].node, 1);
    double out = 0.0;
    nz_status sb = f ? nz_native_eval(f, &c[i].bad, &out) : NZ_OK;
    nz_status sg = f ? nz_native_eval(f, &c[i].good, &out) : NZ_EDOM;
    gsl_test(!f || sb != NZ_EDOM || sg != NZ_OK || !same_bits(out, c[i].want),
             "%s: %s refuses it (NZ_EDOM), and the same code gives %.17g elsewhere", c[i].what, code, c[i].want);
    nz_native_free(f);
  }
  /* A constant that is not finite: the interpreter refuses every call. */
  int k = nz_graph_op(g, NZ_GOP_ADD, x, nz_graph_const(g, INFINITY));
  nz_native *f = compile(g, &k, 1);
  double in = 1.0, out;
  gsl_test(!f || nz_native_eval(f, &in, &out) != NZ_EDOM, "a graph with an infinite constant is refused (%s)", code);
  nz_native_free(f);
  nz_graph_free(g);
}

/* ------------------------------------------------------------------ */
/* The cache, the compiler, the directory                               */

/* x^3 sin(y) + c: a small graph, a new one for each c. */
static nz_graph *small_graph(double c, int *root)
{
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0), y = nz_graph_input(g, 1);
  *root = nz_graph_op(g, NZ_GOP_ADD, nz_graph_op(g, NZ_GOP_MUL, nz_graph_powc(g, x, 3.0),
                                                 nz_graph_fn(g, NZ_FN_SIN, y)), nz_graph_const(g, c));
  return g;
}

static void check_cache(void)
{
  int root;
  nz_graph *g = small_graph(0.125, &root);
  nz_native *f1 = compile(g, &root, 1), *f2 = compile(g, &root, 1);
  double in[2] = { 0.7, -0.3 }, o1 = 0, o2 = 1, want = 0.7 * 0.7 * 0.7 * sin(-0.3) + 0.125;
  if (f1 && f2) { nz_native_eval(f1, in, &o1); nz_native_eval(f2, in, &o2); }
  gsl_test(!f1 || !f2 || nz_native_compile_seconds(f1) <= 0 || nz_native_compile_seconds(f2) != 0 ||
           strcmp(nz_native_path(f1), nz_native_path(f2)) || !same_bits(o1, o2) || fabs(o1 - want) > 1e-15,
           "the second compile of a graph loads the first one's file without compiling "
           "(%.3f s, then %.3f s)", f1 ? nz_native_compile_seconds(f1) : -1,
           f2 ? nz_native_compile_seconds(f2) : -1);
  int root2;
  nz_graph *g2 = small_graph(0.25, &root2);
  nz_native *f3 = compile(g2, &root2, 1);
  gsl_test(!f3 || !f1 || !strcmp(nz_native_path(f1), nz_native_path(f3)),
           "another graph gets another file");
  /* The source is not kept beside the object (NZLUA_KEEP_C=1 keeps it). */
  char src[600];
  struct stat st;
  if (f1) snprintf(src, sizeof src, "%.*s.c", (int)strlen(nz_native_path(f1)) - 3, nz_native_path(f1));
  gsl_test(!f1 || stat(src, &st) == 0, "the generated source is not kept in the cache");
  int root4;
  nz_graph *g4 = small_graph(0.625, &root4);
  setenv("NZLUA_KEEP_C", "1", 1);
  nz_native *f4 = compile(g4, &root4, 1);
  unsetenv("NZLUA_KEEP_C");
  if (f4) snprintf(src, sizeof src, "%.*s.c", (int)strlen(nz_native_path(f4)) - 3, nz_native_path(f4));
  gsl_test(!f4 || stat(src, &st) || st.st_size == 0, "NZLUA_KEEP_C=1 keeps the generated source beside the object");
  nz_native_free(f4);
  nz_graph_free(g4);
  /* in and out may be the same array. */
  double io[2] = { 0.7, -0.3 };
  if (f1) nz_native_eval(f1, io, io);
  gsl_test(!f1 || !same_bits(io[0], o1), "in and out may overlap");
  nz_native_free(f1);
  nz_native_free(f2);
  nz_native_free(f3);
  nz_graph_free(g);
  nz_graph_free(g2);
}

/* The same object loaded again (the loader finds it by its file and keeps
 * the second name as an alias), freed, then other objects loaded: each
 * must be its own (a descriptor name reused while an alias holds it made
 * the loader hand back the first object). */
static void check_loaded_twice(void)
{
  enum { N = 6 };
  nz_graph *g[N];
  int root[N], bad = 0;
  for (int i = 0; i < N; i++) g[i] = small_graph(1.5 + i, &root[i]);
  for (int i = 0; i < N; i++) nz_native_free(compile(g[i], &root[i], 1));   /* in the cache */
  nz_native *keep = compile(g[0], &root[0], 1);
  for (int round = 0; round < 3; round++) {
    nz_native *again = compile(g[0], &root[0], 1);
    nz_native_free(again);
    for (int i = 1; i < N; i++) {
      nz_native *f = nz_native_load(g[i], &root[i], 1, cache, why, sizeof why);
      double in[2] = { 0.5, 0.25 }, out = 0, c = 1.5 + i;
      if (!f || nz_native_eval(f, in, &out) != NZ_OK || out != 0.125 * sin(0.25) + c) {
        printf("# graph %d, round %d: %s\n", i, round, f ? "wrong value" : why);
        bad++;
      }
      nz_native_free(f);
    }
  }
  nz_native_free(keep);
  for (int i = 0; i < N; i++) nz_graph_free(g[i]);
  gsl_test(bad, "objects loaded, loaded again and freed in turn are each their own (%d wrong)", bad);
}

/* Two processes compile the same new graph into the same directory at once. */
static void check_concurrent(void)
{
  int root;
  nz_graph *g = small_graph(0.375, &root);
  pid_t pid[2];
  for (int i = 0; i < 2; i++) {
    pid[i] = fork();
    if (pid[i] == 0) {
      nz_native *f = nz_native_compile(g, &root, 1, cache, why, sizeof why);
      double in[2] = { 0.5, 0.5 }, out = 0;
      int ok = f && nz_native_eval(f, in, &out) == NZ_OK && out == 0.125 * sin(0.5) + 0.375;
      _exit(ok ? 0 : 1);
    }
  }
  int fails = 0;
  for (int i = 0; i < 2; i++) {
    int st = 1;
    if (pid[i] < 0 || waitpid(pid[i], &st, 0) < 0 || !WIFEXITED(st) || WEXITSTATUS(st)) fails++;
  }
  gsl_test(fails, "two processes compiling the same graph at once both get a working object");
  nz_graph_free(g);
}

static void check_failures(void)
{
  int root;
  nz_graph *g = small_graph(0.5, &root);
  const char *old = getenv("CC");
  char saved[256] = "";
  if (old) snprintf(saved, sizeof saved, "%s", old);

  setenv("CC", "/nonexistent/cc", 1);
  why[0] = 0;
  nz_native *f = nz_native_compile(g, &root, 1, cache, why, sizeof why);
  printf("# CC=/nonexistent/cc: %s\n", why);
  gsl_test(f || !strstr(why, "cannot run the C compiler") || !strstr(why, "/nonexistent/cc"),
           "a missing compiler gives NULL and says so");
  nz_native_free(f);

  setenv("CC", "cc -fno-such-option-nzlua", 1);
  why[0] = 0;
  f = nz_native_compile(g, &root, 1, cache, why, sizeof why);
  printf("# CC='cc -fno-such-option-nzlua': %s\n", why);
  gsl_test(f || !strstr(why, "failed") || !strstr(why, "no-such-option"),
           "a compiler that fails gives NULL and its message");
  nz_native_free(f);
  if (old) setenv("CC", saved, 1);
  else unsetenv("CC");

  /* A directory below a file cannot be made, even by root. */
  char file[128], dir[160];
  snprintf(file, sizeof file, "%s/a-file", cache);
  FILE *fp = fopen(file, "w");
  if (fp) fclose(fp);
  snprintf(dir, sizeof dir, "%s/sub", file);
  why[0] = 0;
  f = nz_native_compile(g, &root, 1, dir, why, sizeof why);
  printf("# cache %s: %s\n", dir, why);
  gsl_test(f || !strstr(why, "cache directory"), "an unusable cache directory gives NULL and says so");
  nz_native_free(f);
  unlink(file);
  nz_graph_free(g);
}

static void check_cache_dir(void)
{
  char buf[512], want[512];
  const char *names[4] = { "NZLUA_CACHE", "XDG_CACHE_HOME", "HOME", NULL };
  char saved[3][512];
  int had[3];
  for (int i = 0; i < 3; i++) {
    const char *e = getenv(names[i]);
    had[i] = e != NULL;
    if (e) snprintf(saved[i], sizeof saved[i], "%s", e);
  }
  char why2[400];
  setenv("NZLUA_CACHE", "/x/nz", 1);
  setenv("XDG_CACHE_HOME", "/x/xdg", 1);
  setenv("HOME", "/x/home", 1);
  int bad = strcmp(nz_native_cache_dir(buf, sizeof buf, why2, sizeof why2), "/x/nz");
  setenv("NZLUA_CACHE", "relative/nz", 1);   /* ignored as a relative XDG_CACHE_HOME is */
  bad += strcmp(nz_native_cache_dir(buf, sizeof buf, why2, sizeof why2), "/x/xdg/nzlua") != 0;
  unsetenv("NZLUA_CACHE");
  bad += strcmp(nz_native_cache_dir(buf, sizeof buf, why2, sizeof why2), "/x/xdg/nzlua") != 0;
  setenv("XDG_CACHE_HOME", "relative/xdg", 1);   /* the XDG rule: a relative path is ignored */
  bad += strcmp(nz_native_cache_dir(buf, sizeof buf, why2, sizeof why2), "/x/home/.cache/nzlua") != 0;
  unsetenv("XDG_CACHE_HOME");
  bad += strcmp(nz_native_cache_dir(buf, sizeof buf, why2, sizeof why2), "/x/home/.cache/nzlua") != 0;
  unsetenv("HOME");
  why2[0] = 0;
  /* no fallback under /tmp: anyone could make /tmp/nzlua-<uid> first */
  bad += nz_native_cache_dir(buf, sizeof buf, why2, sizeof why2) != NULL || !strstr(why2, "HOME");
  setenv("HOME", "relative", 1);
  bad += nz_native_cache_dir(buf, sizeof buf, why2, sizeof why2) != NULL;
  setenv("HOME", "/x/home", 1);
  bad += nz_native_cache_dir(buf, 4, why2, sizeof why2) != NULL;
  for (int i = 0; i < 3; i++) {
    if (had[i]) setenv(names[i], saved[i], 1);
    else unsetenv(names[i]);
  }
  (void)want;
  gsl_test(bad, "the cache directory: an absolute $NZLUA_CACHE, an absolute $XDG_CACHE_HOME/nzlua, an absolute "
           "$HOME/.cache/nzlua, else none (no /tmp fallback)");
}

/* The checks before dlopen (native_elf.h): objects built here by cc with
 * one feature each that runs or loads code when loaded, each refused with
 * its reason; the plain one, and every object nzlua compiled into this
 * run's cache, accepted. */
static int elf_verdict(const char *flags, const char *body, char *reason, size_t n)
{
  char c[256], so[256], cmd[1200];
  snprintf(c, sizeof c, "%s/elf-case.c", cache);
  snprintf(so, sizeof so, "%s/elf-case.so", cache);
  FILE *f = fopen(c, "w");
  if (!f) return -2;
  fprintf(f, "#include <stdio.h>\ndouble nzlua_plain(double x) { return 2 * x; }\n%s\n", body);
  fclose(f);
  snprintf(cmd, sizeof cmd, "cc -fPIC -shared %s -o %s %s -lm 2>/dev/null", flags, so, c);
  if (system(cmd) != 0) return -2;
  int fd = open(so, O_RDONLY);
  struct stat st;
  int r = fd < 0 || fstat(fd, &st) ? -2 : nz_native_elf_inert(fd, (long long)st.st_size, reason, n);
  if (fd >= 0) close(fd);
  unlink(c);
  unlink(so);
  return r;
}

static void check_inert(void)
{
  static const struct { const char *what, *flags, *code, *reason; } cases[] = {
    { "a constructor", "-nostartfiles", "__attribute__((constructor)) static void f(void) { puts(\"x\"); }",
      "constructors (DT_INIT_ARRAY)" },
    { "a destructor", "-nostartfiles", "__attribute__((destructor)) static void f(void) { puts(\"x\"); }",
      "destructors (DT_FINI_ARRAY)" },
    { "gcc's start files", "", "", "an initialisation function (DT_INIT)" },
    { "an IFUNC", "-nostartfiles", "static void g(void) {} static void (*pick(void))(void) { return g; }\n"
      "void h(void) __attribute__((ifunc(\"pick\")));", "IFUNC" },
    { "another library", "-nostartfiles -Wl,--no-as-needed -lgslcblas", "", "needs the library 'libgslcblas" },
    { "an executable stack", "-nostartfiles -Wl,-z,execstack", "", "executable stack (PT_GNU_STACK with PF_X)" },
    { "text relocations", "-nostartfiles -Wl,-z,notext",   /* an absolute address in .text */
      "__asm__(\".text\\n.p2align 3\\nnz_textref: .quad nzlua_plain\\n\");", "text relocations (DT_TEXTREL)" },
  };
  char reason[300];
  int bad = 0, built = 0;
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    reason[0] = 0;
    int r = elf_verdict(cases[i].flags, cases[i].code, reason, sizeof reason);
    if (r == -2) {
      printf("# %s: cc could not build the case here (skipped)\n", cases[i].what);
      continue;
    }
    built++;
    printf("# %s: %s\n", cases[i].what, r ? reason : "accepted");
    if (r == 0 || !strstr(reason, cases[i].reason)) bad++;
  }
  int plain = elf_verdict("-nostartfiles", "", reason, sizeof reason);
  gsl_test(bad || built < 7 || plain != 0,
           "an object with a constructor, destructor, _init, IFUNC, another library, executable stack or text "
           "relocations is refused before dlopen, each with its reason (%d built); a plain one is accepted", built);
  /* every object nzlua compiled in this run: no start files, nothing that runs */
  char cmd[200];
  snprintf(cmd, sizeof cmd, "ls %s/*.so 2>/dev/null", cache);
  FILE *ls = popen(cmd, "r");
  char path[600];
  int objects = 0, refused = 0;
  while (ls && fgets(path, sizeof path, ls)) {
    path[strcspn(path, "\n")] = 0;
    int fd = open(path, O_RDONLY);
    struct stat st;
    if (fd < 0 || fstat(fd, &st)) continue;
    objects++;
    if (nz_native_elf_inert(fd, (long long)st.st_size - 40, reason, sizeof reason)) {   /* without the trailer */
      printf("# %s: %s\n", path, reason);
      refused++;
    }
    close(fd);
  }
  if (ls) pclose(ls);
  gsl_test(objects == 0 || refused, "nzlua's own objects (%d, linked with -nostartfiles) have nothing that runs on load",
           objects);
}

/* ------------------------------------------------------------------ */
/* Timing (not tests)                                                   */

/* The graph of test_graph.c's timing (test_util.h): each node uses one of
 * the 16 latest and a random earlier one, + - * and a sine every tenth node. */
static int wide_graph(nz_graph *g, int size, int sines, int *ids, int cap)
{
  return test_random_graph(g, &rng, size, sines, 16, ids, cap);
}

static double best_ns(nz_graph_plan *p, const nz_native *f, double *in, double *out, int reps)
{
  double best = 1e300;
  for (int rep = 0; rep < 7; rep++) {
    double t0 = seconds();
    for (int r = 0; r < reps; r++) {
      in[0] = 0.5 + 1e-9 * r;
      if (p) nz_graph_eval(p, in, out);
      else nz_native_eval(f, in, out);
    }
    best = fmin(best, (seconds() - t0) * 1e9 / reps);
  }
  return best;
}

/* The k-link planar pendulum (unit masses and lengths): T, then on the
 * graph the mass matrix M = d2T/dqd2 and the bias h = (dT/dqd)' - dT/dq at
 * qdd = 0, the plans the mechanics evaluates.  Inputs q_0..q_k-1 and
 * qd_0..qd_k-1; outs[] receives M (k^2) then h (k); returns their count. */
static int pendulum_mh(nz_graph *g, int k, int *outs)
{
  int q[32], qd[32], xd = -1, yd = -1, T = nz_graph_const(g, 0.0), half = nz_graph_const(g, 0.5);
  int one = nz_graph_const(g, 1.0), n = 0, di[64], p[32];
  for (int i = 0; i < k; i++) {
    q[i] = nz_graph_input(g, i);
    qd[i] = nz_graph_input(g, k + i);
  }
  for (int i = 0; i < k; i++) {   /* velocity of bob i, then its kinetic energy */
    int cx = nz_graph_op(g, NZ_GOP_MUL, nz_graph_fn(g, NZ_FN_COS, q[i]), qd[i]);
    int sy = nz_graph_op(g, NZ_GOP_MUL, nz_graph_fn(g, NZ_FN_SIN, q[i]), qd[i]);
    xd = xd < 0 ? cx : nz_graph_op(g, NZ_GOP_ADD, xd, cx);
    yd = yd < 0 ? sy : nz_graph_op(g, NZ_GOP_ADD, yd, sy);
    int v2 = nz_graph_op(g, NZ_GOP_ADD, nz_graph_powc(g, xd, 2.0), nz_graph_powc(g, yd, 2.0));
    T = nz_graph_op(g, NZ_GOP_ADD, T, nz_graph_op(g, NZ_GOP_MUL, half, v2));
  }
  for (int j = 0; j < k; j++) {   /* p_j = dT/dqd_j */
    for (int i = 0; i < 2 * k; i++) di[i] = i == k + j ? one : -1;
    p[j] = nz_graph_derivative(g, T, di);
  }
  for (int j = 0; j < k; j++) {
    for (int i = 0; i < 2 * k; i++) di[i] = i == k + j ? one : -1;
    nz_graph_derivatives(g, p, k, di, outs + n);   /* column j of M */
    n += k;
  }
  int dp[32], dT[32];
  for (int i = 0; i < 2 * k; i++) di[i] = i < k ? qd[i] : -1;   /* along q' = qd */
  nz_graph_derivatives(g, p, k, di, dp);
  for (int j = 0; j < k; j++) {
    for (int i = 0; i < 2 * k; i++) di[i] = i == j ? one : -1;
    dT[j] = nz_graph_derivative(g, T, di);
    outs[n++] = nz_graph_op(g, NZ_GOP_SUB, dp[j], dT[j]);
  }
  return n;
}

static void check_pendulum(int k)
{
  nz_graph *g = nz_graph_new();
  int outs[32 * 33], n = pendulum_mh(g, k, outs), ok, bad = 0, accepted = 0;
  nz_graph_plan *p = nz_graph_plan_new(g, outs, n);
  nz_native *f = compile(g, outs, n);
  char msg[200];
  for (int t = 0; f && p && t < 100; t++) {
    double in[64];
    for (int i = 0; i < 2 * k; i++) in[i] = 6 * urand() - 3;
    if (agree(p, f, n, in, &ok, msg, sizeof msg) && !bad++) printf("# %s\n", msg);
    accepted += ok;
  }
  gsl_test(!f || !p || bad || accepted < 100,
           "%d-link pendulum, M and h (%d nodes): %s = interpreter bit for bit at 100 states", k,
           f ? nz_native_nodes(f) : 0, code);
  nz_native_free(f);
  nz_graph_plan_free(p);
  nz_graph_free(g);
}

static void time_pendulum(int k)
{
  nz_graph *g = nz_graph_new();
  int outs[32 * 33], n = pendulum_mh(g, k, outs);
  nz_graph_plan *p = nz_graph_plan_new(g, outs, n);
  nz_native *f = compile(g, outs, n);
  double in[64], out[32 * 33];
  for (int i = 0; i < 2 * k; i++) in[i] = 2 * urand() - 1;
  if (f && p) {
    int nodes = nz_native_nodes(f), reps = 1000000 / nodes + 1;
    double ti = best_ns(p, NULL, in, out, reps), tn = best_ns(NULL, f, in, out, reps);
    printf("# timing (not a test): %d-link pendulum M and h, %d computed nodes: compile %.2f s%s; "
           "interpreter %.0f ns (%.2f ns per node), native %.0f ns (%.2f ns per node, %.1fx)\n",
           k, nodes, nz_native_compile_seconds(f), nz_native_compile_seconds(f) > 0 ? "" : " (from the cache)", ti, ti / nodes, tn, tn / nodes, ti / tn);
  }
  nz_native_free(f);
  nz_graph_plan_free(p);
  nz_graph_free(g);
}

static void time_wide(int size, int sines)
{
  nz_graph *g = nz_graph_new();
  int *ids = malloc((size_t)(size + 8) * sizeof *ids), outs[32];
  int n = wide_graph(g, size, sines, ids, size + 8);
  for (int i = 0; i < 32; i++) outs[i] = ids[n - 1 - i];
  nz_graph_plan *p = nz_graph_plan_new(g, outs, 32);
  nz_native *f = compile(g, outs, 32);
  double in[8], out[32];
  for (int i = 0; i < 8; i++) in[i] = 2 * urand() - 1;
  if (f && p) {
    int nodes = nz_native_nodes(f), reps = 2000000 / nodes + 1;
    double ti = best_ns(p, NULL, in, out, reps), tn = best_ns(NULL, f, in, out, reps);
    printf("# timing (not a test): graph of %d nodes (+ - *%s), %d computed: compile %.2f s (%.0f us per node); "
           "interpreter %.2f ns per node, native %.2f ns per node (%.1fx)\n",
           nz_graph_size(g), sines ? " sin" : "", nodes, nz_native_compile_seconds(f),
           1e6 * nz_native_compile_seconds(f) / nodes, ti / nodes, tn / nodes, ti / tn);
  }
  nz_native_free(f);
  nz_graph_plan_free(p);
  nz_graph_free(g);
  free(ids);
}

/* A right-hand side as small as they come: Henon-Heiles, x'' = -x - 2 x y,
 * y'' = -y - x^2 + y^2, written as a graph (what a call costs). */
static void time_henon(void)
{
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0), y = nz_graph_input(g, 1), two = nz_graph_const(g, 2.0);
  int outs[4] = { nz_graph_input(g, 2), nz_graph_input(g, 3) };
  int xy = nz_graph_op(g, NZ_GOP_MUL, x, y);
  outs[2] = nz_graph_op(g, NZ_GOP_SUB, nz_graph_op(g, NZ_GOP_NEG, x, -1), nz_graph_op(g, NZ_GOP_MUL, two, xy));
  outs[3] = nz_graph_op(g, NZ_GOP_ADD, nz_graph_op(g, NZ_GOP_SUB, nz_graph_op(g, NZ_GOP_NEG, y, -1),
                                                   nz_graph_powc(g, x, 2.0)), nz_graph_powc(g, y, 2.0));
  nz_graph_plan *p = nz_graph_plan_new(g, outs, 4);
  nz_native *f = compile(g, outs, 4);
  double in[4] = { 0.1, 0.2, 0.3, 0.4 }, out[4];
  if (f && p) {
    double ti = best_ns(p, NULL, in, out, 1000000), tn = best_ns(NULL, f, in, out, 1000000);
    printf("# timing (not a test): Henon-Heiles right-hand side, %d computed nodes: interpreter %.1f ns, "
           "native %.1f ns per call\n", nz_native_nodes(f), ti, tn);
  }
  nz_native_free(f);
  nz_graph_plan_free(p);
  nz_graph_free(g);
}

static void time_native(void)
{
  time_henon();
  time_pendulum(4);
  time_pendulum(8);
  time_pendulum(16);
  time_wide(5000, 0);
  time_wide(5000, 1);
  time_wide(1000, 1);
  time_wide(10000, 1);
  if (getenv("NZLUA_NATIVE_BIG")) time_wide(50000, 1);
  else printf("# timing: the 50000-node compile is skipped (set NZLUA_NATIVE_BIG=1)\n");
}

/* ------------------------------------------------------------------ */
/* Series built order by order as machine code (series_native.h)        */

/* Coefficients 0..K of the outputs for inputs in[k * 8 + i]: into out[k *
 * nout + r]; the status of the first failing call (and its k in *kfail). */
static nz_status series_run(nz_graph_plan *p, int nout, int K, const double *in, double *out, int *kfail)
{
  nz_status st = nz_graph_series_begin(p, K, in);
  *kfail = 0;
  for (int r = 0; !st && r < nout; r++) out[r] = nz_graph_series_coef(p, r, 0);
  for (int k = 1; !st && k <= K; k++)
    if ((st = nz_graph_series_next(p, k, in + 8 * k, out + (size_t)k * (size_t)nout))) *kfail = k;
  return st;
}

static void check_series_random(int size, int nout, int points, int K)
{
  nz_graph *g = nz_graph_new();
  int cap = size + 8, *v = malloc((size_t)cap * sizeof *v), outs[1024];
  no_branches = 1;
  int n = random_graph(g, size, v, cap);
  no_branches = 0;
  if (nout > n - 8) nout = n - 8;
  for (int r = 0; r < nout; r++) outs[r] = v[n - 1 - r];
  nz_graph_plan *p = nz_graph_plan_new(g, outs, nout);
  size_t len = (size_t)(K + 1) * (size_t)nout;
  double *a = malloc(len * sizeof *a), *b = malloc(len * sizeof *b), *in = malloc((size_t)(K + 1) * 8 * sizeof *in);
  nz_series_native *sn = NULL;
  int bad = 0, same = 0, failed = 0, kinds = 0, seen[NZ_SK_COPY + 1] = { 0 };
  double tc = 0.0;
  for (int pt = 0; p && pt < points; pt++) {
    /* values in [-1, 1], later coefficients shrinking as a series with
     * radius 2; one point in ten with coefficients large enough to overflow
     * somewhere (the refusals must agree too) */
    double scale = pt % 10 == 9 ? 1e60 : 0.5;
    for (int i = 0; i < 8; i++) in[i] = 2 * urand() - 1;
    for (int k = 1; k <= K; k++)
      for (int i = 0; i < 8; i++) in[8 * k + i] = (2 * urand() - 1) * pow(scale, k);
    int ka, kb, na = 0, nb = 0;
    nz_graph_series_use(p, NULL, NULL, 0);
    nz_status sa = series_run(p, nout, K, in, a, &ka);
    nz_graph_plan_failure(p, &na, &(nz_gop){ 0 }, &(nz_jet_fn){ 0 }, &(double){ 0 });
    if (!sn && !sa) {   /* the layout of a begin that succeeded */
      double t0 = seconds();
      sn = nz_series_native_get(p, NULL, cache, 1, why, sizeof why);
      tc = seconds() - t0;
      if (!sn) { printf("# series_native: %s\n", why); bad++; break; }
      int nseries, m = nz_graph_series_layout(p, NULL, &nseries);
      nz_series_slot *sl = m > 0 ? malloc((size_t)m * sizeof *sl) : NULL;
      if (sl) nz_graph_series_layout(p, sl, &nseries);
      for (int i = 0; sl && i < m; i++) seen[sl[i].kernel] = 1;
      free(sl);
    }
    if (!sn) continue;
    nz_series_native_attach(sn, p);
    nz_status sb = series_run(p, nout, K, in, b, &kb);
    nz_graph_plan_failure(p, &nb, &(nz_gop){ 0 }, &(nz_jet_fn){ 0 }, &(double){ 0 });
    failed += sa != NZ_OK;
    int agree_all = sa == sb && ka == kb && (sa == NZ_OK || na == nb);
    size_t upto = sa ? (size_t)ka * (size_t)nout : len;
    for (size_t j = 0; agree_all && j < upto; j++) agree_all = same_bits(a[j], b[j]);
    if (!agree_all && !bad++)
      printf("# point %d: statuses %d/%d at k %d/%d, nodes %d/%d\n", pt, (int)sa, (int)sb, ka, kb, na, nb);
    same += agree_all;
  }
  for (int i = 0; i <= NZ_SK_COPY; i++) kinds += seen[i];
  /* every kernel but the branches' (step, copy of a select) and abs's */
  gsl_test(bad || same != points || failed == 0 || failed == points || kinds < 20,
           "series of a random graph without branches (%d nodes, %d kinds of kernel), %d outputs to order %d: "
           "%s = interpreter bit for bit at %d of %d points (%d refused alike; compiled in %.2f s)",
           nz_graph_size(g), kinds, nout, K, code, same, points, failed, tc);
  if (p) nz_series_native_detach(p);
  nz_series_native_free(sn);
  nz_graph_plan_free(p);
  nz_graph_free(g);
  free(v);
  free(a);
  free(b);
  free(in);
}

/* The fused loop of a second-order ODE (nz_series_native_ode2) against
 * the same recurrence run order by order on the interpreter: q_i = inputs
 * 0, 1, q_i' = inputs 2, 3, t = input 4, q_i'' = outputs 0, 1, the other
 * inputs constant; a_{n+2} = q''_n / ((n + 1)(n + 2)) (nz_series_ode2_coef).  Bit for bit, both
 * below the orders written out (24) and above (the loop). */
static void ode2_reference(nz_graph_plan *p, int N, double *a, nz_status *st)
{
  double in[8];
  *st = NZ_OK;
  for (int n = 0; n <= N && !*st; n++) {
    for (int i = 0; i < 8; i++) in[i] = 0.0;
    in[0] = a[2 * n];
    in[1] = a[2 * n + 1];
    in[2] = (n + 1) * a[2 * (n + 1)];
    in[3] = (n + 1) * a[2 * (n + 1) + 1];
    if (n == 0) {
      in[4] = 0.3;
      for (int i = 5; i < 8; i++) in[i] = 0.1 * i;
      *st = nz_graph_series_begin(p, N, in);
    } else {
      in[4] = n == 1 ? 1.0 : 0.0;
      *st = nz_graph_series_next(p, n, in, NULL);
    }
    if (*st) break;
    a[2 * (n + 2)] = nz_series_ode2_coef(nz_graph_series_coef(p, 0, n), n);
    a[2 * (n + 2) + 1] = nz_series_ode2_coef(nz_graph_series_coef(p, 1, n), n);
  }
}

static void check_series_ode2(void)
{
  nz_graph *g = nz_graph_new();
  int cap = 408, *v = malloc((size_t)cap * sizeof *v), outs[2];
  no_branches = 1;
  int n = random_graph(g, 60, v, cap);
  no_branches = 0;
  outs[0] = v[n - 1];
  outs[1] = v[n - 2];
  nz_graph_plan *p = nz_graph_plan_new(g, outs, 2);
  int pos[2] = { 0, 1 }, vel[2] = { 2, 3 }, acc[2] = { 0, 1 }, bad = 0, runs = 0;
  nz_series_ode2 o = { 2, 4, pos, vel, acc };
  nz_series_native *sn = NULL;
  for (int pt = 0; pt < 20 && p; pt++) {
    int N = pt % 2 ? 30 : 18;   /* the loop, and the orders written out */
    double ref[2 * 34], got[2 * 34];
    for (int i = 0; i < 4; i++) ref[i] = 0.5 * (2 * urand() - 1);
    memcpy(got, ref, 4 * sizeof *ref);
    nz_status st;
    nz_series_native_detach(p);
    ode2_reference(p, N, ref, &st);
    if (st) continue;   /* a point where the graph fails: not this test's */
    if (!sn && !(sn = nz_series_native_get(p, &o, cache, 1, why, sizeof why))) {
      printf("# ode2: %s\n", why);
      bad++;
      break;
    }
    nz_series_native_attach(sn, p);
    double in0[8] = { got[0], got[1], got[2], got[3], 0.3, 0.1 * 5, 0.1 * 6, 0.1 * 7 };   /* ode2_reference's */
    if (nz_graph_series_begin(p, N, in0) || nz_series_native_ode2(sn, p, N, got)) {
      printf("# ode2: refused at point %d\n", pt);
      bad++;
      continue;
    }
    runs++;
    for (int j = 0; j < 2 * (N + 3); j++)
      if (!same_bits(ref[j], got[j])) {
        if (!bad++) printf("# ode2 (N = %d): a[%d] %.17g, order by order %.17g\n", N, j, got[j], ref[j]);
        break;
      }
  }
  gsl_test(bad || runs < 10, "the fused loop of a second-order ODE on a random graph (%s) = the interpreter order by "
                             "order, bit for bit (%d runs to order 18 and 30)", code, runs);
  nz_series_native_detach(p);
  nz_series_native_free(sn);
  nz_graph_plan_free(p);
  nz_graph_free(g);
  free(v);
}

/* Begin's domain checks at the points where coefficient 0 is finite but
 * the series has no derivative (sqrt 0, x^0.5 at 0, asin 1, atan2(0, 0),
 * hypot(0, 0)): the machine code refuses as the interpreter does, with the
 * same status and node; and both agree at a regular point. */
static void check_series_domains(void)
{
  struct { const char *name; double x, y; } pts[] = {
    { "sqrt x", 0.0, 1.0 }, { "x^0.5", 0.0, 1.0 }, { "asin x", 1.0, 0.0 }, { "acos x", -1.0, 0.0 },
    { "atan2(x, y)", 0.0, 0.0 }, { "hypot(x, y)", 0.0, 0.0 }, { "x / y", 1.0, 0.0 }, { "log x", 0.0, 1.0 },
  };
  int bad = 0, n = (int)(sizeof pts / sizeof pts[0]);
  for (int c = 0; c < n; c++) {
    nz_graph *g = nz_graph_new();
    int x = nz_graph_input(g, 0), y = nz_graph_input(g, 1), z;
    switch (c) {
    case 0: z = nz_graph_fn(g, NZ_FN_SQRT, x); break;
    case 1: z = nz_graph_powc(g, x, 0.5); break;
    case 2: z = nz_graph_fn(g, NZ_FN_ASIN, x); break;
    case 3: z = nz_graph_fn(g, NZ_FN_ACOS, x); break;
    case 4: z = nz_graph_op(g, NZ_GOP_ATAN2, x, y); break;
    case 5: z = nz_graph_op(g, NZ_GOP_HYPOT, x, y); break;
    case 6: z = nz_graph_op(g, NZ_GOP_DIV, x, y); break;
    default: z = nz_graph_fn(g, NZ_FN_LOG, x); break;
    }
    z = nz_graph_op(g, NZ_GOP_MUL, z, y);   /* a later node, as in a real graph */
    nz_graph_plan *p = nz_graph_plan_new(g, &z, 1);
    double in[8 * 4] = { 0.3, 0.7 }, one[8] = { 1.0, 1.0 };
    for (int k = 1; k < 4; k++) memcpy(in + 8 * k, one, sizeof one);
    int kf, na, nb;
    double out_a[4], out_b[4];
    nz_status regular = series_run(p, 1, 3, in, out_a, &kf);
    nz_series_native *sn = regular ? NULL : nz_series_native_get(p, NULL, cache, 1, why, sizeof why);
    if (!sn) { printf("# %s: %s\n", pts[c].name, regular ? "no regular begin" : why); bad++; }
    in[0] = pts[c].x;
    in[1] = pts[c].y;
    nz_status sa = series_run(p, 1, 3, in, out_a, &kf);
    nz_graph_plan_failure(p, &na, &(nz_gop){ 0 }, &(nz_jet_fn){ 0 }, &(double){ 0 });
    if (sn) nz_series_native_attach(sn, p);
    nz_status sb = series_run(p, 1, 3, in, out_b, &kf);
    nz_graph_plan_failure(p, &nb, &(nz_gop){ 0 }, &(nz_jet_fn){ 0 }, &(double){ 0 });
    nz_status sbeg = nz_graph_series_begin(p, 3, in);   /* begin alone refuses too */
    if (sa == NZ_OK || sa != sb || na != nb || sbeg != sa) {
      printf("# %s at (%g, %g): interpreter %d (node %d), machine code %d (node %d), its begin %d\n", pts[c].name,
             pts[c].x, pts[c].y, (int)sa, na, (int)sb, nb, (int)sbeg);
      bad++;
    }
    nz_series_native_detach(p);
    nz_series_native_free(sn);
    nz_graph_plan_free(p);
    nz_graph_free(g);
  }
  gsl_test(bad, "series as %s refuses where begin refuses (sqrt 0, x^0.5 at 0, asin 1, acos -1, "
                "atan2(0, 0), hypot(0, 0), 1/0, log 0): the interpreter's status and node, %d cases", code, n);
}

/* Without NZLUA_COMPACT the emitter follows the size: a plan of more
 * computed nodes than NZ_NATIVE_COMPACT_NODES and a series of more slots
 * than NZ_SERIES_COMPACT_SLOTS get compact code, smaller ones straight-line
 * code; each still the interpreter's bit for bit. */
static void check_compact_by_size(void)
{
  int sizes[2] = { NZ_SERIES_COMPACT_SLOTS / 2, NZ_NATIVE_COMPACT_NODES * 3 }, bad = 0, kinds[2][2] = { { 0 } };
  for (int big = 0; big < 2; big++) {
    nz_graph *g = nz_graph_new();
    int cap = sizes[big] + 8, *v = malloc((size_t)cap * sizeof *v), outs[256];
    no_branches = 1;
    int n = random_graph(g, sizes[big], v, cap), nout = n - 8 < 256 ? n - 8 : 256;
    no_branches = 0;
    for (int r = 0; r < nout; r++) outs[r] = v[n - 1 - (int)((long)r * (n - 8) / nout)];   /* spread: most nodes needed */
    nz_graph_plan *p = nz_graph_plan_new(g, outs, nout);
    nz_native *f = compile(g, outs, nout);
    int ok;
    char msg[200];
    for (int t = 0; f && p && t < 20; t++) {
      double in[8];
      for (int i = 0; i < 8; i++) in[i] = 2 * urand() - 1;
      if (agree(p, f, nout, in, &ok, msg, sizeof msg) && !bad++) printf("# %s\n", msg);
    }
    if (f && (nz_native_nodes(f) > NZ_NATIVE_COMPACT_NODES) != big) {
      printf("# the %s plan has %d computed nodes\n", big ? "big" : "small", nz_native_nodes(f));
      bad++;
    }
    double in0[8 * 4] = { 0 };
    for (int i = 0; i < 8; i++) in0[i] = 0.1 * (i + 1);
    nz_series_native *sn = p && !nz_graph_series_begin(p, 3, in0) ? nz_series_native_get(p, NULL, cache, 1, why, sizeof why) : NULL;
    kinds[big][0] = f ? nz_native_compact_code(f) : -1;
    kinds[big][1] = sn ? nz_series_native_compact_code(sn) : -1;
    nz_series_native_free(sn);
    nz_native_free(f);
    nz_graph_plan_free(p);
    nz_graph_free(g);
    free(v);
  }
  gsl_test(bad || kinds[0][0] != 0 || kinds[0][1] != 0 || kinds[1][0] != 1 || kinds[1][1] != 1,
           "by size: a graph of %d nodes gets straight-line code (%d) and so does its series (%d); one of %d nodes "
           "gets compact code (%d) and so does its series (%d); both the interpreter's at 20 points",
           sizes[0], kinds[0][0], kinds[0][1], sizes[1], kinds[1][0], kinds[1][1]);
}

int main(void)
{
  gsl_test_verbose(1);
  snprintf(cache, sizeof cache, "/tmp/nzlua-test-native-XXXXXX");
  if (!mkdtemp(cache)) { perror("mkdtemp"); return 1; }
  check_cache_dir();
  check_cache();
  check_loaded_twice();
  check_concurrent();
  check_failures();
  for (int compact = 0; compact <= 1; compact++) {
    setenv("NZLUA_COMPACT", compact ? "1" : "0", 1);
    code = compact ? "compact code" : "straight-line code";
    check_specials();
    check_refusals();
    check_random(600, 4096, 200);
    check_rewrites();
    check_random(5000, 64, 50);
    check_pendulum(8);
    check_series_random(300, 100, 40, 24);
    check_series_domains();
    check_series_ode2();
  }
  unsetenv("NZLUA_COMPACT");
  check_compact_by_size();
  check_inert();   /* every object compiled so far, of both emitters */
  if (!SANITIZED) time_native();
  /* Remove the cache of this run. */
  char cmd[128];
  snprintf(cmd, sizeof cmd, "%s", cache);
  pid_t pid = getenv("NZLUA_KEEP_CACHE") ? -1 : fork();   /* keep it to read the sources */
  if (pid == 0) {
    execlp("rm", "rm", "-rf", cmd, (char *)NULL);
    _exit(127);
  }
  if (pid > 0) waitpid(pid, NULL, 0);
  return gsl_test_summary();
}
