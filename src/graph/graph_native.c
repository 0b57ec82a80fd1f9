/* graph_native.c - C generated from an expression graph, compiled by the
 * system's C compiler into a shared object, cached on disk, loaded back with
 * dlopen (see graph_native.h).
 *
 * The generated code.  One `const double tN` per computed node, in the
 * graph's (topological) order; inputs read as in[k], constants written as
 * exact hexadecimal literals.  Each formula is the interpreter's (graph.c):
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
 * Files.  The cache holds nzg-<hash>.c and nzg-<hash>.so, hash = 64-bit
 * FNV-1a of the generator version, the compiler command and the source.
 * Both are written under unique temporary names and renamed into place, so
 * two processes compiling the same graph at once both succeed and the
 * files are always whole. */
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <spawn.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include "graph/graph_native.h"

extern char **environ;

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
  void *dl;
  int (*eval)(const double *, double *, double *);
  int nin, nout, nodes;
  double *w;   /* cross-function values, then a copy of in[] */
  size_t nw;
  double seconds;
  char *path;
};

static void say(char *why, size_t n, const char *fmt, ...)
{
  if (!why || !n) return;
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(why, n, fmt, ap);
  va_end(ap);
}

/* ------------------------------------------------------------------ */
/* A growing string                                                     */

typedef struct sbuf {
  char *s;
  size_t len, cap;
  int oom;
} sbuf;

static void sb_printf(sbuf *b, const char *fmt, ...)
{
  if (b->oom) return;
  for (;;) {
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(b->s ? b->s + b->len : NULL, b->s ? b->cap - b->len : 0, fmt, ap);
    va_end(ap);
    if (k < 0) { b->oom = 1; return; }
    if (b->s && b->len + (size_t)k < b->cap) { b->len += (size_t)k; return; }
    size_t cap = b->cap ? b->cap : 1 << 16;
    while (cap < b->len + (size_t)k + 1) cap *= 2;
    char *s = realloc(b->s, cap);
    if (!s) { b->oom = 1; return; }
    b->s = s;
    b->cap = cap;
  }
}

/* ------------------------------------------------------------------ */
/* Generating the source                                                */

static int is_small_integer(double p) { return p == floor(p) && fabs(p) <= 1e9; }
static int unary_op(int op) { return op == NZ_GOP_NEG || op == NZ_GOP_POWC || op == NZ_GOP_FN; }
static int computed(int op) { return op != NZ_GOP_CONST && op != NZ_GOP_INPUT; }
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
static const char *fn_name(int fn)
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
  case NZ_GOP_FN: return fn_name(nd->fn) != NULL;
  case NZ_GOP_CMP: return nd->fn <= NZ_CMP_NE;
  case NZ_GOP_SELECT: return 1;
  default: return 0;
  }
}

/* The kernels of graph.c that are not one libm call, with NaN for the
 * domain errors that libm would not make non-finite. */
static const char helpers[] =
  "#include <math.h>\n"
  "#if defined(__GNUC__)\n#define NZN_NOINLINE __attribute__((noinline))\n"
  "#else\n#define NZN_NOINLINE\n#endif\n"
  "static inline double nzn_abs(double x) { return x < 0.0 ? -x : x; }\n"
  /* sign(NaN) = 0 and sign(-0) = +0, as graph.c's d_fn */
  "static inline double nzn_sign(double x) { return (double)((x > 0.0) - (x < 0.0)); }\n"
  /* graph.c's d_cmp: NaN for a NaN operand (the interpreter refuses it) */
  "#define NZN_CMP(name, op) static inline double name(double a, double b)\\\n"
  "{ return a != a || b != b ? NAN : a op b ? 1.0 : 0.0; }\n"
  "NZN_CMP(nzn_lt, <)\nNZN_CMP(nzn_le, <=)\nNZN_CMP(nzn_gt, >)\n"
  "NZN_CMP(nzn_ge, >=)\nNZN_CMP(nzn_eq, ==)\nNZN_CMP(nzn_ne, !=)\n"
  /* graph.c's R_SELECT: a NaN condition fails */
  "static inline double nzn_select(double c, double a, double b)\n"
  "{ return c != c ? NAN : c != 0.0 ? a : b; }\n"
  "static inline double nzn_hypot(double a, double b)\n{\n"
  "  double s = __builtin_fmax(__builtin_fabs(a), __builtin_fabs(b));\n"
  "  if (s == 0.0) return 0.0;\n"
  "  double as = a / s, bs = b / s;\n"
  "  return __builtin_sqrt(as * as + bs * bs) * s;\n}\n"
  "static inline double nzn_pow(double x, double y) { return x > 0.0 ? exp(y * log(x)) : NAN; }\n"
  "static inline double nzn_powc(double x, double p, int integer)\n{\n"
  "  if (x == 0.0) return integer || p < 0.0 ? NAN : 0.0;\n"
  "  if (x < 0.0 && !integer) return NAN;\n"
  "  return pow(x, p);\n}\n";

typedef struct gen {
  const nz_gnode *nd;
  int top;
  char *need;       /* node reached from the outputs */
  char *check;      /* node tested for finiteness */
  int *chunk;       /* function of a computed node */
  int *last;        /* last function that reads it */
  int *wslot;       /* its place in w[], or -1 */
  int *out_head, *out_next;   /* outputs of each node, linked */
  int nw, nodes, nchunks, ncheck, maxin, bad_const;
  sbuf *b;
} gen;

static void literal(char *s, size_t n, double v)
{
  if (isnan(v)) snprintf(s, n, "NAN");
  else if (isinf(v)) snprintf(s, n, v < 0 ? "(-HUGE_VAL)" : "HUGE_VAL");
  else snprintf(s, n, "(%a)", v);
}

/* How function `c` reads node id. */
static void ref(const gen *G, int id, int c, char *s, size_t n)
{
  const nz_gnode *nd = &G->nd[id];
  if (nd->op == NZ_GOP_INPUT) snprintf(s, n, "in[%d]", nd->a);
  else if (nd->op == NZ_GOP_CONST) literal(s, n, nd->v);
  else if (G->chunk[id] == c) snprintf(s, n, "t%d", id);
  else snprintf(s, n, "w[%d]", G->wslot[id]);
}

/* x^n by the binary powering of graph.c's d_powi, unrolled into
 * statements: the squares tI_k, the product tI_y; e receives the result. */
static void emit_powi(gen *G, int id, const char *x, unsigned n, char *e, size_t en)
{
  char base[64];
  int k = 0, started = 0;
  snprintf(base, sizeof base, "%s", x);
  while (n) {
    if (n & 1u) {
      if (!started) sb_printf(G->b, "  double t%d_y = %s;\n", id, base);   /* 1 * base is base */
      else sb_printf(G->b, "  t%d_y = t%d_y * %s;\n", id, id, base);
      started = 1;
    }
    n >>= 1;
    if (n) {
      sb_printf(G->b, "  const double t%d_%d = %s * %s;\n", id, k, base, base);
      snprintf(base, sizeof base, "t%d_%d", id, k++);
    }
  }
  snprintf(e, en, "t%d_y", id);
}

/* The C function of each nz_cmp (nd->fn checked by supported()). */
static const char *cmp_name(int op)
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
  case NZ_GOP_FN: snprintf(e, sizeof e, "%s(%s)", fn_name(nd->fn), a); break;
  case NZ_GOP_CMP: snprintf(e, sizeof e, "%s(%s, %s)", cmp_name(nd->fn), a, b); break;
  case NZ_GOP_SELECT: snprintf(e, sizeof e, "nzn_select(%s, %s, %s)", k, a, b); break;
  case NZ_GOP_POWC: {
    double p = nd->v;
    char pl[64];
    if (p == 0.0) snprintf(e, sizeof e, "1.0");
    else if (p > 0.0 && is_small_integer(p)) emit_powi(G, id, a, (unsigned)p, e, sizeof e);
    else {
      literal(pl, sizeof pl, p);
      snprintf(e, sizeof e, "nzn_powc(%s, %s, %d)", a, pl, is_small_integer(p));
    }
    break;
  }
  default: snprintf(e, sizeof e, "NAN"); break;   /* refused before */
  }
  sb_printf(G->b, "  const double t%d = %s;\n", id, e);
  if (G->check[id]) {
    sb_printf(G->b, "  c%d += t%d * 0.0;\n", *acc, id);
    *acc = (*acc + 1) & 3;
  }
  if (G->wslot[id] >= 0) sb_printf(G->b, "  w[%d] = t%d;\n", G->wslot[id], id);
  for (int r = G->out_head[id]; r >= 0; r = G->out_next[r])
    sb_printf(G->b, "  out[%d] = t%d;\n", r, id);
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
      say(why, whylen, "node %d (%s%s%s) is not supported by the native compiler", id,
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
  sbuf *b = G->b;
  int id = 0;
  sb_printf(b, "/* Generated by nzlua (%s): %d computed nodes, %d outputs, %d tested. */\n",
            GEN_VERSION, G->nodes, n, G->ncheck);
  sb_printf(b, "%s", helpers);
  for (int c = 0; c < G->nchunks; c++) {
    int acc = 0;
    sb_printf(b, "\nstatic NZN_NOINLINE double nzn_part%d(const double *restrict in, "
                 "double *restrict out, double *restrict w)\n{\n"
                 "  double c0 = 0.0, c1 = 0.0, c2 = 0.0, c3 = 0.0;\n"
                 "  (void)in; (void)out; (void)w;\n", c);
    for (; id <= G->top; id++) {
      if (!G->need[id] || !computed(G->nd[id].op)) continue;
      if (G->chunk[id] != c) break;
      emit_node(G, id, c, &acc);
    }
    sb_printf(b, "  return (c0 + c1) + (c2 + c3);\n}\n");
  }
  sb_printf(b, "\nint nzn_eval(const double *restrict in, double *restrict out, double *restrict w);\n"
               "int nzn_eval(const double *restrict in, double *restrict out, double *restrict w)\n{\n"
               "  double c = 0.0;\n  (void)in; (void)out; (void)w;\n");
  if (G->bad_const) sb_printf(b, "  return 1;   /* a constant is not finite */\n");
  for (int c = 0; c < G->nchunks; c++) sb_printf(b, "  c += nzn_part%d(in, out, w);\n", c);
  for (int r = 0; r < n; r++) {
    char s[64];
    if (computed(G->nd[outputs[r]].op)) continue;
    ref(G, outputs[r], -1, s, sizeof s);
    sb_printf(b, "  out[%d] = %s;\n", r, s);
  }
  sb_printf(b, "  return !(c == 0.0);\n}\n");
}

/* The source for outputs[0..n-1] into *src (malloc'd); -1 with why. */
static int generate(const nz_graph *g, const int *outputs, int n, char **src, gen *info, char *why,
                    size_t whylen)
{
  int size = nz_graph_size(g), top = -1;
  for (int r = 0; r < n; r++) {
    if (outputs[r] < 0 || outputs[r] >= size) {
      say(why, whylen, "output %d is node %d, not a node of the graph (0..%d)", r + 1, outputs[r], size - 1);
      return -1;
    }
    if (outputs[r] > top) top = outputs[r];
  }
  size_t m = (size_t)top + 2;
  sbuf b = { 0 };
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
    say(why, whylen, "out of memory generating C for %d nodes", size);
    goto done;
  }
  for (size_t i = 0; i < m; i++) G.out_head[i] = -1;
  if (analyse(&G, outputs, n, why, whylen)) goto done;
  emit(&G, n, outputs);
  if (b.oom) {
    say(why, whylen, "out of memory generating C for %d nodes", G.nodes);
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

/* ------------------------------------------------------------------ */
/* The compiler                                                         */

#define MAXWORDS 48

/* $CC split into words, then the flags: argv ready but for the last four
 * slots (-o out src -lm NULL).  Returns the count, or -1. */
static int compiler_argv(char *buf, size_t n, char **argv, const char *opt)
{
  const char *cc = getenv("CC");
  if (!cc || !*cc) cc = "cc";
  if (strlen(cc) >= n) return -1;
  strcpy(buf, cc);
  int k = 0;
  char *save = NULL;
  for (char *s = strtok_r(buf, " \t", &save); s; s = strtok_r(NULL, " \t", &save)) {
    if (k == MAXWORDS - 12) return -1;
    argv[k++] = s;
  }
  if (!k) return -1;
  static const char *const flags[] = { "-fPIC", "-shared", "-ffp-contract=off", "-fno-builtin", "-fno-math-errno", "-g0", "-w" };
  const char *o = getenv("NZLUA_COPT");   /* e.g. -O1, to measure */
  argv[k++] = (char *)(o && *o ? o : opt);
  for (size_t i = 0; i < sizeof flags / sizeof flags[0]; i++) argv[k++] = (char *)flags[i];
  return k;
}

static uint64_t fnv(uint64_t h, const char *s)
{
  for (; *s; s++) {
    h ^= (unsigned char)*s;
    h *= 0x100000001b3ULL;
  }
  return h;
}

static double now(void)
{
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* mkdir -p, 0700 for what it creates. */
static int make_dirs(const char *dir, char *why, size_t whylen)
{
  char p[4096];
  if (!*dir || strlen(dir) >= sizeof p) {
    say(why, whylen, "cache directory '%s': empty or too long a path", dir);
    return -1;
  }
  strcpy(p, dir);
  for (char *s = p + 1;; s++) {
    if (*s != '/' && *s) continue;
    char c = *s;
    *s = 0;
    if (mkdir(p, 0700) && errno != EEXIST) {
      say(why, whylen, "cannot create the cache directory '%s': %s (set NZLUA_CACHE to a writable directory)",
          p, strerror(errno));
      return -1;
    }
    *s = c;
    if (!c) break;
  }
  struct stat st;
  if (stat(dir, &st) || !S_ISDIR(st.st_mode)) {
    say(why, whylen, "cache directory '%s' is not a directory (set NZLUA_CACHE to a writable directory)", dir);
    return -1;
  }
  return 0;
}

static int write_all(int fd, const char *s, size_t n)
{
  while (n) {
    ssize_t k = write(fd, s, n);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return -1;
    s += k;
    n -= (size_t)k;
  }
  return 0;
}

/* The first line of the compiler's messages that says "error" (or the
 * first line), for why[]. */
static void compiler_message(const char *log, char *msg, size_t n)
{
  FILE *f = fopen(log, "r");
  char line[512], first[512] = "";
  msg[0] = 0;
  if (!f) return;
  while (fgets(line, sizeof line, f)) {
    line[strcspn(line, "\n")] = 0;
    if (!first[0]) snprintf(first, sizeof first, "%s", line);
    if (strstr(line, "error")) { snprintf(msg, n, "%s", line); break; }
  }
  if (!msg[0]) snprintf(msg, n, "%s", first);
  fclose(f);
}

/* Run argv with stdout and stderr into log; 0 when it exited 0. */
static int run_compiler(char **argv, const char *log, char *why, size_t whylen)
{
  posix_spawn_file_actions_t fa;
  pid_t pid;
  int st = 0, rc;
  if (posix_spawn_file_actions_init(&fa)) {
    say(why, whylen, "cannot run the C compiler: out of memory");
    return -1;
  }
  posix_spawn_file_actions_addopen(&fa, 1, log, O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  rc = posix_spawnp(&pid, argv[0], &fa, NULL, argv, environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc) {
    say(why, whylen, "cannot run the C compiler '%s': %s (set CC to a C compiler; the interpreter is used meanwhile)",
        argv[0], strerror(rc));
    return -1;
  }
  while (waitpid(pid, &st, 0) < 0) {
    if (errno == EINTR) continue;
    say(why, whylen, "waiting for the C compiler '%s': %s", argv[0], strerror(errno));
    return -1;
  }
  if (WIFEXITED(st) && WEXITSTATUS(st) == 0) return 0;
  if (WIFEXITED(st) && WEXITSTATUS(st) == 127) {
    say(why, whylen, "cannot run the C compiler '%s': not found (set CC to a C compiler; the interpreter is used meanwhile)",
        argv[0]);
    return -1;
  }
  char msg[600];
  compiler_message(log, msg, sizeof msg);
  if (WIFEXITED(st))
    say(why, whylen, "the C compiler '%s' failed (exit status %d): %s", argv[0], WEXITSTATUS(st), msg);
  else
    say(why, whylen, "the C compiler '%s' was killed by signal %d", argv[0], WIFSIGNALED(st) ? WTERMSIG(st) : 0);
  return -1;
}

/* Load so_path; check that it is the object of this hash. */
static int load(nz_native *f, const char *so_path, const char *hash, char *why, size_t whylen)
{
  void *dl = dlopen(so_path, RTLD_NOW | RTLD_LOCAL);
  if (!dl) {
    const char *e = dlerror();
    say(why, whylen, "cannot load '%s': %s", so_path, e ? e : "dlopen failed");
    return -1;
  }
  const char *id = dlsym(dl, "nzn_id");
  void *ev = dlsym(dl, "nzn_eval");
  if (!id || !ev || strcmp(id, hash) != 0) {
    say(why, whylen, "'%s' is not the object it is named after", so_path);
    dlclose(dl);
    return -1;
  }
  f->dl = dl;
  /* POSIX: a data pointer from dlsym converts to a function pointer. */
  memcpy(&f->eval, &ev, sizeof ev);
  return 0;
}

/* Write src under a temporary name, compile it, rename both into place. */
static int compile_into(const char *dir, const char *base, const char *src, char **argv, int k,
                        char *why, size_t whylen)
{
  size_t L = strlen(dir) + strlen(base) + 32;
  char *tc = malloc(L), *tso = malloc(L), *tlog = malloc(L), *fc = malloc(L), *fso = malloc(L);
  int rc = -1, fd = -1;
  if (!tc || !tso || !tlog || !fc || !fso) {
    say(why, whylen, "out of memory");
    goto done;
  }
  snprintf(tc, L, "%s/%s-XXXXXX.c", dir, base);
  fd = mkstemps(tc, 2);
  if (fd < 0) {
    say(why, whylen, "cannot write in the cache directory '%s': %s (set NZLUA_CACHE to a writable directory)",
        dir, strerror(errno));
    tc[0] = 0;
    goto done;
  }
  if (write_all(fd, src, strlen(src)) || close(fd)) {
    fd = -1;
    say(why, whylen, "cannot write '%s': %s", tc, strerror(errno));
    goto done;
  }
  fd = -1;
  size_t tl = strlen(tc);
  snprintf(tso, L, "%.*s.so", (int)(tl - 2), tc);
  snprintf(tlog, L, "%.*s.log", (int)(tl - 2), tc);
  snprintf(fc, L, "%s/%s.c", dir, base);
  snprintf(fso, L, "%s/%s.so", dir, base);
  argv[k] = "-o";
  argv[k + 1] = tso;
  argv[k + 2] = tc;
  argv[k + 3] = "-lm";
  argv[k + 4] = NULL;
  if (run_compiler(argv, tlog, why, whylen)) goto done;
  if (rename(tso, fso)) {
    say(why, whylen, "cannot rename '%s' to '%s': %s", tso, fso, strerror(errno));
    goto done;
  }
  if (rename(tc, fc) == 0) tc[0] = 0;   /* the source stays beside the object */
  rc = 0;
done:
  if (fd >= 0) close(fd);
  if (tc && tc[0]) unlink(tc);
  if (tso && tso[0]) unlink(tso);
  if (tlog && tlog[0]) unlink(tlog);
  free(tc);
  free(tso);
  free(tlog);
  free(fc);
  free(fso);
  return rc;
}

/* The object for these outputs: from the cache, else compiled (compile = 1)
 * or NULL (compile = 0). */
static nz_native *native_get(const nz_graph *g, const int *outputs, int n, const char *cache_dir,
                             char *why, size_t whylen, int compile)
{
  double t0 = now();
  char *src = NULL, ccbuf[2048], *argv[MAXWORDS], hash[17], base[32], *so = NULL;
  gen info = { 0 };
  nz_native *f = NULL;
  if (why && whylen) why[0] = 0;
  if (!g || n < 0 || (n > 0 && !outputs) || !cache_dir) {
    say(why, whylen, "nz_native_compile: no graph, outputs or cache directory");
    return NULL;
  }
  if (generate(g, outputs, n, &src, &info, why, whylen)) return NULL;
  int k = compiler_argv(ccbuf, sizeof ccbuf, argv, info.nodes > BIG_GRAPH ? "-O1" : "-O2");
  if (k < 0) {
    say(why, whylen, "CC is empty or too long a command");
    goto fail;
  }
  /* The machine too: a cache shared between machines (a network home)
   * keeps one object per architecture. */
  struct utsname u;
  uint64_t h = fnv(0xcbf29ce484222325ULL, GEN_VERSION "\n");
  if (uname(&u) == 0) h = fnv(fnv(h, u.sysname), u.machine);
  for (int i = 0; i < k; i++) h = fnv(fnv(h, argv[i]), " ");
  h = fnv(h, src);
  snprintf(hash, sizeof hash, "%016llx", (unsigned long long)h);
  snprintf(base, sizeof base, "nzg-%s", hash);
  /* The object names itself, so that loading can check it. */
  sbuf b = { src, strlen(src), strlen(src) + 1, 0 };
  sb_printf(&b, "const char nzn_id[] = \"%s\";\n", hash);
  src = b.s;
  if (b.oom) {
    say(why, whylen, "out of memory");
    goto fail;
  }
  if (make_dirs(cache_dir, why, whylen)) goto fail;
  f = calloc(1, sizeof *f);
  so = malloc(strlen(cache_dir) + strlen(base) + 8);
  if (!f || !so) {
    say(why, whylen, "out of memory");
    goto fail;
  }
  sprintf(so, "%s/%s.so", cache_dir, base);
  f->path = so;
  so = NULL;
  f->nin = info.maxin;
  f->nout = n;
  f->nodes = info.nodes;
  f->nw = (size_t)info.nw;
  f->w = malloc((f->nw + (size_t)f->nin + 1) * sizeof *f->w);
  if (!f->w) {
    say(why, whylen, "out of memory");
    goto fail;
  }
  int cached = access(f->path, R_OK) == 0 && load(f, f->path, hash, NULL, 0) == 0;
  if (!cached && !compile) {
    say(why, whylen, "not in the cache");
    goto fail;
  }
  if (!cached) {
    if (compile_into(cache_dir, base, src, argv, k, why, whylen)) goto fail;
    if (load(f, f->path, hash, why, whylen)) goto fail;
  }
  f->seconds = cached ? 0.0 : now() - t0;
  free(src);
  return f;
fail:
  free(src);
  free(so);
  nz_native_free(f);
  return NULL;
}

nz_native *nz_native_compile(const nz_graph *g, const int *outputs, int n, const char *cache_dir,
                             char *why, size_t whylen)
{
  return native_get(g, outputs, n, cache_dir, why, whylen, 1);
}

nz_native *nz_native_load(const nz_graph *g, const int *outputs, int n, const char *cache_dir,
                          char *why, size_t whylen)
{
  return native_get(g, outputs, n, cache_dir, why, whylen, 0);
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
  if (f->dl) dlclose(f->dl);
  free(f->w);
  free(f->path);
  free(f);
}

double nz_native_compile_seconds(const nz_native *f) { return f->seconds; }
const char *nz_native_path(const nz_native *f) { return f->path; }
int nz_native_nodes(const nz_native *f) { return f->nodes; }

const char *nz_native_cache_dir(char *buf, size_t n)
{
  const char *e;
  int k;
  if ((e = getenv("NZLUA_CACHE")) && *e) k = snprintf(buf, n, "%s", e);
  else if ((e = getenv("XDG_CACHE_HOME")) && *e) k = snprintf(buf, n, "%s/nzlua", e);
  else if ((e = getenv("HOME")) && *e) k = snprintf(buf, n, "%s/.cache/nzlua", e);
  else k = snprintf(buf, n, "/tmp/nzlua-%lu", (unsigned long)getuid());
  return k < 0 || (size_t)k >= n ? NULL : buf;
}
