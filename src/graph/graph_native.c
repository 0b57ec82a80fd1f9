/* graph_native.c - C generated from an expression graph, compiled by the
 * system's C compiler into a shared object, cached on disk, loaded back with
 * dlopen (see graph_native.h).
 *
 * The generated code.  One `const double tN` per computed node, in the
 * graph's (topological) order; inputs read as in[k], constants written as
 * exact hexadecimal literals.  Each formula is the interpreter's (graph_impl.h, graph_plan.c):
 * x^n by the same binary powering unrolled, x^y = exp(y log x), hypot scaled
 * by max(|a|, |b|), |x| as x < 0 ? -x : x, sign(x) as [x > 0] - [x < 0]
 * (so sign(-0) = +0 and sign(NaN) = 0, as the interpreter), cmp as 1.0 or
 * 0.0, select as a choice of values (both branches computed, as the
 * interpreter does), libm for the rest; compiled with
 * -ffp-contract=off and without -ffast-math, so the values are the
 * interpreter's bit for bit.  Also with -fno-builtin: otherwise the compiler
 * rewrites sin(atan(x)) as x / sqrt(x^2 + 1) or pow(x, -1) as 1 / x, which
 * round differently (exact operations are called as __builtin_sqrt, ...).
 *
 * Refusing what the interpreter refuses, cheaply.  Every domain error gives
 * a NaN or an infinity here (log(0) = -inf, sqrt(-1) = NaN, 1/0 = inf; the
 * helpers return NaN where libm would not, as pow(0, y), a comparison with
 * a NaN operand, a select with a NaN condition), so "the interpreter fails"
 * is "some computed node is not finite".  Testing every
 * node would cost about as much as computing it; but most operations are
 * strict (a non-finite operand gives a non-finite result: inf + x, inf * 0,
 * sin(inf), sqrt(-inf)), and a node whose every consumer is strict needs no
 * test of its own: its consumers inherit the failure.  So only nodes with no
 * consumer (outputs) or with a consumer that may mask them (atan, tanh, exp,
 * a denominator, atan2, hypot, sign, non-integer powers, comparisons, the
 * branches of a select: the one not taken is masked, yet the interpreter
 * refuses its failure) are tested, as
 * c += t * 0.0 into four independent sums: t * 0 is +-0 when t is finite and
 * NaN otherwise.  The result is refused when a sum is not zero.
 *
 * Big graphs.  The nodes are cut into functions of a few thousand lines
 * (compilers slow down superlinearly on one huge function); a value needed
 * by a later function goes through a workspace w[].
 *
 * Compiling, caching and loading: native_object.h. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "graph/graph_native.h"
#include "graph/graph_native_gen.h"
#include "graph/native_object.h"

#define GEN_VERSION "nzlua-native 2"
/* Computed nodes per generated function, and the size above which the
 * compiler runs at -O1 (measured: see tests/test_native.c's timing). */
#ifndef CHUNK
#define CHUNK 2000
#endif
/* 1: test every node for finiteness (to measure what the strictness rule
 * saves). */
#ifndef CHECK_EVERY_NODE
#define CHECK_EVERY_NODE 0
#endif
#ifndef BIG_GRAPH
#define BIG_GRAPH 5000
#endif

struct nz_native {
  nz_native_object obj;
  int (*eval)(const double *, double *, double *);
  int nin, nout, nodes, compact;
  double *w;   /* cross-function values (compact code: all values), then a copy of in[] */
  size_t nw;
  nz_compact_data cd;   /* compact code's tables, until the object is loaded */
};

/* ------------------------------------------------------------------ */
/* Generating the source                                                */

static int is_small_integer(double p) { return p == floor(p) && fabs(p) <= 1e9; }
#define unary_op nz_native_unary
#define computed nz_native_computed
/* Operands of a computed node: a; a, b; or a, b and the condition c. */
static int noperands(int op) { return unary_op(op) ? 1 : op == NZ_GOP_SELECT ? 3 : 2; }
static int operand(const nz_gnode *nd, int pos) { return pos == 0 ? nd->a : pos == 1 ? nd->b : nd->c; }

/* Does a non-finite operand `pos` (0: a, 1: b, 2: c), node o, always give a
 * non-finite result?  (see the header comment) */
static int strict(const nz_gnode *nd, int pos, const nz_gnode *o)
{
  switch (nd->op) {
  case NZ_GOP_ADD:
  case NZ_GOP_SUB:
  case NZ_GOP_MUL:
  case NZ_GOP_NEG: return 1;
  case NZ_GOP_DIV: return pos == 0;   /* x / inf = 0 */
  case NZ_GOP_POWC: return nd->v > 0.0 && is_small_integer(nd->v);   /* inf^-1 = 0 */
  case NZ_GOP_FN:
    switch (nd->fn) {
    case NZ_FN_LOG: case NZ_FN_SQRT: case NZ_FN_SIN: case NZ_FN_COS: case NZ_FN_TAN:
    case NZ_FN_ASIN: case NZ_FN_ACOS: case NZ_FN_SINH: case NZ_FN_COSH: case NZ_FN_ABS:
      return 1;
    default: return 0;   /* exp(-inf) = 0, atan(inf), tanh(inf), sign(inf), sign(NaN) finite */
    }
  case NZ_GOP_SELECT:
    /* A branch is not strict: the other one may be taken (and a failing
     * branch not taken must still be refused, as the interpreter does).
     * The condition: select(inf, a, b) = a, but a comparison is never
     * infinite, only NaN, and a NaN condition gives NaN. */
    return pos == 2 && o->op == NZ_GOP_CMP;
  default: return 0;   /* pow, atan2, hypot(NaN, 0) = 0, cmp(inf, 0) = 1 */
  }
}

/* The C function of each nz_jet_fn, or NULL when the native code lacks it. */
const char *nz_native_fn_name(int fn)
{
  switch (fn) {
  case NZ_FN_EXP: return "exp";
  case NZ_FN_LOG: return "log";
  case NZ_FN_SQRT: return "__builtin_sqrt";
  case NZ_FN_SIN: return "sin";
  case NZ_FN_COS: return "cos";
  case NZ_FN_TAN: return "tan";
  case NZ_FN_ASIN: return "asin";
  case NZ_FN_ACOS: return "acos";
  case NZ_FN_ATAN: return "atan";
  case NZ_FN_SINH: return "sinh";
  case NZ_FN_COSH: return "cosh";
  case NZ_FN_TANH: return "tanh";
  case NZ_FN_ABS: return "nzn_abs";
  case NZ_FN_SIGN: return "nzn_sign";
  default: return NULL;
  }
}

static int supported(const nz_gnode *nd)
{
  switch (nd->op) {
  case NZ_GOP_CONST: case NZ_GOP_INPUT: case NZ_GOP_ADD: case NZ_GOP_SUB: case NZ_GOP_MUL:
  case NZ_GOP_DIV: case NZ_GOP_NEG: case NZ_GOP_POWC: case NZ_GOP_POW: case NZ_GOP_ATAN2:
  case NZ_GOP_HYPOT:
    return 1;
  case NZ_GOP_FN: return nz_native_fn_name(nd->fn) != NULL;
  case NZ_GOP_CMP: return nd->fn <= NZ_CMP_NE;
  case NZ_GOP_SELECT: return 1;
  default: return 0;
  }
}

/* The kernels of graph_impl.h that are not one libm call, with NaN for the
 * domain errors that libm would not make non-finite. */
const char nz_native_helpers[] =
  "#include <math.h>\n"
  "#if defined(__GNUC__)\n#define NZN_NOINLINE __attribute__((noinline))\n"
  "#else\n#define NZN_NOINLINE\n#endif\n"
  "static inline double nzn_abs(double x) { return x < 0.0 ? -x : x; }\n"
  /* sign(NaN) = 0 and sign(-0) = +0, as graph_impl.h's d_fn */
  "static inline double nzn_sign(double x) { return (double)((x > 0.0) - (x < 0.0)); }\n"
  /* graph_impl.h's d_cmp: NaN for a NaN operand (the interpreter refuses it) */
  "#define NZN_CMP(name, op) static inline double name(double a, double b)\\\n"
  "{ return a != a || b != b ? NAN : a op b ? 1.0 : 0.0; }\n"
  "NZN_CMP(nzn_lt, <)\nNZN_CMP(nzn_le, <=)\nNZN_CMP(nzn_gt, >)\n"
  "NZN_CMP(nzn_ge, >=)\nNZN_CMP(nzn_eq, ==)\nNZN_CMP(nzn_ne, !=)\n"
  /* graph_plan.c's R_SELECT: a NaN condition fails */
  "static inline double nzn_select(double c, double a, double b)\n"
  "{ return c != c ? NAN : c != 0.0 ? a : b; }\n"
  "static inline double nzn_hypot(double a, double b)\n{\n"
  "  double s = __builtin_fmax(__builtin_fabs(a), __builtin_fabs(b));\n"
  "  if (s == 0.0) return 0.0;\n"
  "  double as = a / s, bs = b / s;\n"
  "  return __builtin_sqrt(as * as + bs * bs) * s;\n}\n"
  "static inline double nzn_pow(double x, double y) { return x > 0.0 ? exp(y * log(x)) : NAN; }\n"
  /* graph_impl.h's d_powi (compact code; straight-line code unrolls it) */
  "static inline double nzn_powi(double x, unsigned n)\n{\n"
  "  double y = 1.0, base = x;\n"
  "  while (n) {\n    if (n & 1u) y = y * base;\n    n >>= 1;\n    if (n) base = base * base;\n  }\n"
  "  return y;\n}\n"
  "static inline double nzn_powc(double x, double p, int integer)\n{\n"
  "  if (x == 0.0) return integer || p < 0.0 ? NAN : 0.0;\n"
  "  if (x < 0.0 && !integer) return NAN;\n"
  "  return pow(x, p);\n}\n";

typedef nz_native_gen gen;

/* How function `c` reads node id. */
static void ref(const gen *G, int id, int c, char *s, size_t n)
{
  const nz_gnode *nd = &G->nd[id];
  if (nd->op == NZ_GOP_INPUT) snprintf(s, n, "in[%d]", nd->a);
  else if (nd->op == NZ_GOP_CONST) nz_native_literal(s, n, nd->v);
  else if (G->chunk[id] == c) snprintf(s, n, "t%d", id);
  else snprintf(s, n, "w[%d]", G->wslot[id]);
}

/* x^n by the binary powering of graph_impl.h's d_powi, unrolled into
 * statements: the squares tI_k, the product tI_y; e receives the result. */
static void emit_powi(gen *G, int id, const char *x, unsigned n, char *e, size_t en)
{
  char base[64];
  int k = 0, started = 0;
  snprintf(base, sizeof base, "%s", x);
  while (n) {
    if (n & 1u) {
      if (!started) nz_sb_printf(G->b, "  double t%d_y = %s;\n", id, base);   /* 1 * base is base */
      else nz_sb_printf(G->b, "  t%d_y = t%d_y * %s;\n", id, id, base);
      started = 1;
    }
    n >>= 1;
    if (n) {
      nz_sb_printf(G->b, "  const double t%d_%d = %s * %s;\n", id, k, base, base);
      snprintf(base, sizeof base, "t%d_%d", id, k++);
    }
  }
  snprintf(e, en, "t%d_y", id);
}

/* The C function of each nz_cmp (nd->fn checked by supported()). */
const char *nz_native_cmp_name(int op)
{
  static const char *const names[] = { "nzn_lt", "nzn_le", "nzn_gt", "nzn_ge", "nzn_eq", "nzn_ne" };
  return names[op];
}

static void emit_node(gen *G, int id, int c, int *acc)
{
  const nz_gnode *nd = &G->nd[id];
  char a[64], b[64], k[64], e[256];
  ref(G, nd->a, c, a, sizeof a);
  if (!unary_op(nd->op)) ref(G, nd->b, c, b, sizeof b);
  else b[0] = 0;
  if (nd->op == NZ_GOP_SELECT) ref(G, nd->c, c, k, sizeof k);
  else k[0] = 0;
  switch (nd->op) {
  case NZ_GOP_ADD: snprintf(e, sizeof e, "%s + %s", a, b); break;
  case NZ_GOP_SUB: snprintf(e, sizeof e, "%s - %s", a, b); break;
  case NZ_GOP_MUL: snprintf(e, sizeof e, "%s * %s", a, b); break;
  case NZ_GOP_DIV: snprintf(e, sizeof e, "%s / %s", a, b); break;
  case NZ_GOP_NEG: snprintf(e, sizeof e, "-%s", a); break;
  case NZ_GOP_POW: snprintf(e, sizeof e, "nzn_pow(%s, %s)", a, b); break;
  case NZ_GOP_ATAN2: snprintf(e, sizeof e, "atan2(%s, %s)", a, b); break;
  case NZ_GOP_HYPOT: snprintf(e, sizeof e, "nzn_hypot(%s, %s)", a, b); break;
  case NZ_GOP_FN: snprintf(e, sizeof e, "%s(%s)", nz_native_fn_name(nd->fn), a); break;
  case NZ_GOP_CMP: snprintf(e, sizeof e, "%s(%s, %s)", nz_native_cmp_name(nd->fn), a, b); break;
  case NZ_GOP_SELECT: snprintf(e, sizeof e, "nzn_select(%s, %s, %s)", k, a, b); break;
  case NZ_GOP_POWC: {
    double p = nd->v;
    char pl[64];
    if (p == 0.0) snprintf(e, sizeof e, "1.0");
    else if (p > 0.0 && is_small_integer(p)) emit_powi(G, id, a, (unsigned)p, e, sizeof e);
    else {
      nz_native_literal(pl, sizeof pl, p);
      snprintf(e, sizeof e, "nzn_powc(%s, %s, %d)", a, pl, is_small_integer(p));
    }
    break;
  }
  default: snprintf(e, sizeof e, "NAN"); break;   /* refused before */
  }
  nz_sb_printf(G->b, "  const double t%d = %s;\n", id, e);
  if (G->check[id]) {
    nz_sb_printf(G->b, "  c%d += t%d * 0.0;\n", *acc, id);
    *acc = (*acc + 1) & 3;
  }
  if (G->wslot[id] >= 0) nz_sb_printf(G->b, "  w[%d] = t%d;\n", G->wslot[id], id);
  for (int r = G->out_head[id]; r >= 0; r = G->out_next[r])
    nz_sb_printf(G->b, "  out[%d] = t%d;\n", r, id);
}

/* Mark what the outputs need, refuse what the native code lacks, decide
 * the tests, the functions and the workspace. */
static int analyse(gen *G, const int *outputs, int n, char *why, size_t whylen)
{
  const nz_gnode *nd = G->nd;
  for (int r = n - 1; r >= 0; r--) {
    G->need[outputs[r]] = 1;
    G->out_next[r] = G->out_head[outputs[r]];
    G->out_head[outputs[r]] = r;
  }
  for (int id = G->top; id >= 0; id--) {
    if (!G->need[id]) continue;
    if (!supported(&nd[id])) {
      nz_native_say(why, whylen, "node %d (%s%s%s) is not supported by the native compiler", id,
          nd[id].op < NZ_GOP_COUNT ? nz_gop_names[nd[id].op] : "?", nd[id].op == NZ_GOP_FN ? " " : "",
          nd[id].op == NZ_GOP_FN && nd[id].fn < NZ_FN_COUNT ? nz_jet_fn_names[nd[id].fn] : "");
      return -1;
    }
    if (!computed(nd[id].op)) continue;
    for (int pos = 0; pos < noperands(nd[id].op); pos++) G->need[operand(&nd[id], pos)] = 1;
  }
  int k = 0;
  for (int id = 0; id <= G->top; id++) {
    G->wslot[id] = -1;
    G->last[id] = -1;
    if (!G->need[id]) continue;
    if (nd[id].op == NZ_GOP_INPUT && nd[id].a + 1 > G->maxin) G->maxin = nd[id].a + 1;
    if (nd[id].op == NZ_GOP_CONST && !isfinite(nd[id].v)) G->bad_const = 1;
    if (!computed(nd[id].op)) continue;
    G->chunk[id] = k++ / CHUNK;
    for (int pos = 0; pos < noperands(nd[id].op); pos++) {
      int o = operand(&nd[id], pos);
      if (!computed(nd[o].op)) continue;
      if (!strict(&nd[id], pos, &nd[o])) G->check[o] = 1;
      G->last[o] = G->chunk[id];
    }
  }
  G->nodes = k;
  G->nchunks = (k + CHUNK - 1) / CHUNK;
  for (int id = 0; id <= G->top; id++) {
    if (!G->need[id] || !computed(nd[id].op)) continue;
    if (G->last[id] < 0 || CHECK_EVERY_NODE) G->check[id] = 1;   /* no consumer: an output */
    if (G->last[id] > G->chunk[id]) G->wslot[id] = G->nw++;
    G->ncheck += G->check[id];
  }
  return 0;
}

static void emit(gen *G, int n, const int *outputs)
{
  nz_sbuf *b = G->b;
  int id = 0;
  for (int c = 0; c < G->nchunks; c++) {
    int acc = 0;
    nz_sb_printf(b, "\nstatic NZN_NOINLINE double nzn_part%d(const double *restrict in, "
                 "double *restrict out, double *restrict w)\n{\n"
                 "  double c0 = 0.0, c1 = 0.0, c2 = 0.0, c3 = 0.0;\n"
                 "  (void)in; (void)out; (void)w;\n", c);
    for (; id <= G->top; id++) {
      if (!G->need[id] || !computed(G->nd[id].op)) continue;
      if (G->chunk[id] != c) break;
      emit_node(G, id, c, &acc);
    }
    nz_sb_printf(b, "  return (c0 + c1) + (c2 + c3);\n}\n");
  }
  nz_sb_printf(b, "\nint nzn_eval(const double *restrict in, double *restrict out, double *restrict w);\n"
               "int nzn_eval(const double *restrict in, double *restrict out, double *restrict w)\n{\n"
               "  double c = 0.0;\n  (void)in; (void)out; (void)w;\n");
  if (G->bad_const) nz_sb_printf(b, "  return 1;   /* a constant is not finite */\n");
  for (int c = 0; c < G->nchunks; c++) nz_sb_printf(b, "  c += nzn_part%d(in, out, w);\n", c);
  for (int r = 0; r < n; r++) {
    char s[64];
    if (computed(G->nd[outputs[r]].op)) continue;
    ref(G, outputs[r], -1, s, sizeof s);
    nz_sb_printf(b, "  out[%d] = %s;\n", r, s);
  }
  nz_sb_printf(b, "  return !(c == 0.0);\n}\n");
}

/* The source for outputs[0..n-1] into *src (malloc'd); -1 with why. */
static int generate(const nz_graph *g, const int *outputs, int n, char **src, gen *info, nz_compact_data *cd,
                    char *why, size_t whylen)
{
  int size = nz_graph_size(g), top = -1;
  for (int r = 0; r < n; r++) {
    if (outputs[r] < 0 || outputs[r] >= size) {
      nz_native_say(why, whylen, "output %d is node %d, not a node of the graph (0..%d)", r + 1, outputs[r], size - 1);
      return -1;
    }
    if (outputs[r] > top) top = outputs[r];
  }
  size_t m = (size_t)top + 2;
  nz_sbuf b = { 0 };
  gen G = { 0 };
  G.nd = nz_graph_nodes(g);
  G.top = top;
  G.b = &b;
  G.need = calloc(m, 1);
  G.check = calloc(m, 1);
  G.chunk = calloc(m, sizeof *G.chunk);
  G.last = calloc(m, sizeof *G.last);
  G.wslot = calloc(m, sizeof *G.wslot);
  G.out_head = malloc(m * sizeof *G.out_head);
  G.out_next = malloc(((size_t)n + 1) * sizeof *G.out_next);
  int rc = -1;
  if (!G.need || !G.check || !G.chunk || !G.last || !G.wslot || !G.out_head || !G.out_next) {
    nz_native_say(why, whylen, "out of memory generating C for %d nodes", size);
    goto done;
  }
  for (size_t i = 0; i < m; i++) G.out_head[i] = -1;
  if (analyse(&G, outputs, n, why, whylen)) goto done;
  info->compact = nz_native_compact(G.nodes, NZ_NATIVE_COMPACT_NODES);
  nz_sb_printf(&b, "/* Generated by nzlua (%s): %d computed nodes, %d outputs, %d tested, %s code. */\n%s",
               GEN_VERSION, G.nodes, n, G.ncheck, info->compact ? "compact" : "straight-line", nz_native_helpers);
  if (info->compact) nz_native_emit_compact(&G, outputs, n, cd);
  else emit(&G, n, outputs);
  if (b.oom) {
    nz_native_say(why, whylen, "out of memory generating C for %d nodes", G.nodes);
    goto done;
  }
  *src = b.s;
  b.s = NULL;
  info->nodes = G.nodes;
  info->nw = G.nw;
  info->maxin = G.maxin;
  rc = 0;
done:
  free(b.s);
  free(G.need);
  free(G.check);
  free(G.chunk);
  free(G.last);
  free(G.wslot);
  free(G.out_head);
  free(G.out_next);
  return rc;
}

/* The object is loaded: its entry, and compact code's index tables
 * written into it.  0, or -1 with why. */
static int loaded(nz_native *f, char *why, size_t whylen)
{
  if (f->compact && nz_ctab_fill(f->obj.dl, &f->cd.tab, why, whylen)) return -1;
  nz_compact_data_free(&f->cd);
  /* POSIX: a data pointer from dlsym converts to a function pointer. */
  memcpy(&f->eval, &f->obj.entry, sizeof f->eval);
  return 0;
}

/* The object for these outputs: from the cache, else obtained as `how`
 * says (native_object.h: look up only, compile and wait, compile in the
 * background). */
static nz_native *native_get(const nz_graph *g, const int *outputs, int n, const char *cache_dir,
                             char *why, size_t whylen, int how)
{
  double t0 = nz_native_now();
  char *src = NULL;
  gen info = { 0 };
  nz_native *f = NULL;
  if (why && whylen) why[0] = 0;
  if (!g || n < 0 || (n > 0 && !outputs) || !cache_dir) {
    nz_native_say(why, whylen, "nz_native_compile: no graph, outputs or cache directory");
    return NULL;
  }
  f = calloc(1, sizeof *f);
  if (!f) {
    nz_native_say(why, whylen, "out of memory");
    return NULL;
  }
  if (generate(g, outputs, n, &src, &info, &f->cd, why, whylen)) goto fail;
  f->nin = info.maxin;
  f->nout = n;
  f->nodes = info.nodes;
  f->compact = info.compact;
  f->nw = info.compact ? f->cd.nwork : (size_t)info.nw;
  f->w = malloc((f->nw + (size_t)f->nin + 1) * sizeof *f->w);
  if (!f->w) {
    nz_native_say(why, whylen, "out of memory");
    goto fail;
  }
  /* compact code's constants stay in its workspace */
  for (int i = 0; i < f->cd.ncon; i++) f->w[f->cd.con_at + i] = f->cd.con[i];
  int got = nz_native_object_get(src, GEN_VERSION, "nzg", "nzn_eval", !info.compact && info.nodes > BIG_GRAPH, how, cache_dir, t0,
                                 &f->obj, why, whylen);
  if (got < 0 || (got == 0 && loaded(f, why, whylen))) goto fail;
  free(src);
  return f;
fail:
  free(src);
  nz_native_free(f);
  return NULL;
}

nz_native *nz_native_compile(const nz_graph *g, const int *outputs, int n, const char *cache_dir,
                             char *why, size_t whylen)
{
  return native_get(g, outputs, n, cache_dir, why, whylen, NZ_NATIVE_WAIT);
}

nz_native *nz_native_load(const nz_graph *g, const int *outputs, int n, const char *cache_dir,
                          char *why, size_t whylen)
{
  return native_get(g, outputs, n, cache_dir, why, whylen, NZ_NATIVE_LOOKUP);
}

nz_native *nz_native_start(const nz_graph *g, const int *outputs, int n, const char *cache_dir,
                           char *why, size_t whylen)
{
  return native_get(g, outputs, n, cache_dir, why, whylen, NZ_NATIVE_BACKGROUND);
}

int nz_native_ready(nz_native *f, int wait, char *why, size_t whylen)
{
  if (f->eval) return 0;
  int r = nz_native_object_ready(&f->obj, wait, why, whylen);
  if (r == 0 && loaded(f, why, whylen)) return -1;
  return r;
}

nz_status nz_native_eval(const nz_native *f, const double *in, double *out)
{
  /* Overlapping in and out: read the inputs from a copy. */
  uintptr_t i0 = (uintptr_t)in, o0 = (uintptr_t)out;
  if (f->nin && f->nout && i0 < o0 + (size_t)f->nout * sizeof *out &&
      o0 < i0 + (size_t)f->nin * sizeof *in) {
    memcpy(f->w + f->nw, in, (size_t)f->nin * sizeof *in);
    in = f->w + f->nw;
  }
  return f->eval(in, out, f->w) ? NZ_EDOM : NZ_OK;
}

nz_native_fn nz_native_entry(const nz_native *f, double **work)
{
  *work = f->w;
  return f->eval;
}

void nz_native_free(nz_native *f)
{
  if (!f) return;
  nz_native_object_close(&f->obj);
  nz_compact_data_free(&f->cd);
  free(f->w);
  free(f);
}

double nz_native_compile_seconds(const nz_native *f) { return f->obj.seconds; }
double nz_native_waited(const nz_native *f) { return f->obj.waited; }
const char *nz_native_path(const nz_native *f) { return f->obj.path; }
int nz_native_nodes(const nz_native *f) { return f->nodes; }
int nz_native_compact_code(const nz_native *f) { return f->compact; }
