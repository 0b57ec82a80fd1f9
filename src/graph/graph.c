/* graph.c - expression graphs: building (folding, simplification,
 * hash-consing), forward differentiation on the graph, and plans evaluated on
 * doubles and on jets (see graph.h).
 *
 * One arithmetic, three places.  Folding a constant node, the double
 * evaluator and the order-0 jet kernels of jet.c must give the same number,
 * or a folded graph would not be the graph it replaces.  The double formulas
 * below are therefore written as the order-0 case of the jet kernels (x^n by
 * the same binary powering as nz_series_powi, x^y as exp(y log x) like
 * nz_jet_pow_jet, hypot scaled like nz_jet_hypot), and folding calls the very
 * functions the double evaluator calls.  They agree as values; only the sign
 * of a zero may differ (a Cauchy sum starts from +0.0).
 *
 * Like terms (graph.h) are gathered when building: exact in real arithmetic,
 * not bit for bit, which is why that is a rule of building and not of
 * folding.
 *
 * Branches: cmp gives 1 or 0 and select picks a whole operand; on doubles a
 * comparison sees values only (a tie is exact equality), on jets it follows
 * the lexicographic branch rule of nz_jet_compare.  Their derivatives and
 * eta-parts are 0 (cmp, sign) and the chosen operand's (select).
 *
 * Zeros: constants are keyed on their bit pattern, so 0.0 and -0.0 are two
 * nodes (atan2(+-0, -1) = +-pi tells them apart).  Both count as zero for
 * the simplifications; x * 0 gives the node +0.0 (not in an exact graph,
 * which keeps the product: its sign is x's).
 *
 * Drops: a simplification that removes an operand (x * 0, x - x, x^0,
 * cmp(x, x), a select's condition or its branch not taken) removes only an
 * operand defined at every finite input (the flag `total` of each node),
 * else the node stays, so that the graph fails where the function fails.
 *
 * Plans number their nodes in slots: inputs, constants, then the computed
 * nodes sorted by level and opcode (see sched_cmp).  Both evaluators run in
 * that order, so "the first failing node" is the same node on doubles and on
 * jets.
 *
 * Series built order by order (nz_graph_series_*, at the end of this file):
 * each computed node keeps its series, and the auxiliary series its kernel
 * needs, in one arena of the plan; begin picks each node's kernel once
 * coefficient 0 is known (the branch a select takes, the sign of abs, a
 * constant factor) and checks domains as the jets of that order would; next
 * runs the coefficient-level kernels of series.c, which are the jets' own
 * recurrences, so both give the same numbers.
 *
 * Jet shapes of a call: an input's jet is used as given (by pointer); a
 * constant is exact to every order (a series c, 0, 0, ... without tangents);
 * a computed node has the lowest order of its non-constant operands and the
 * most tangents of all of them.  The eta-part of a node (din/dout) has the
 * node's order, lowered to that of its operands' eta-parts, and the most
 * tangents of the node and of those.  Outputs are copied into the shape the
 * caller set: missing coefficients and tangents are zero, extra ones are
 * dropped. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <limits.h>
#include "graph/graph.h"
#include "graph/graph_series.h"
#include "jets/series.h"
#include "jets/jet_eta.h"

const char *const nz_gop_names[NZ_GOP_COUNT] = {
  "const", "input", "add", "sub", "mul", "div", "neg", "powc", "pow", "fn", "atan2", "hypot",
  "cmp", "select"
};

struct nz_graph {
  nz_gnode *nodes;
  uint8_t *total;   /* per node: defined at every finite input (nz_graph_total) */
  int n, cap;
  int32_t *table;   /* open addressing, node ids, -1 empty; 2 n <= tcap */
  size_t tcap;      /* a power of two */
  int ninputs;
  int exact;        /* build as IEEE arithmetic would compute (nz_graph_set_exact) */
};

/* ------------------------------------------------------------------ */
/* Scalar kernels: the order-0 jet arithmetic                          */

static int is_small_integer(double p) { return p == floor(p) && fabs(p) <= 1e9; }

/* x^n by binary powering, the order-0 case of nz_series_powi. */
static inline double d_powi(double x, unsigned n)
{
  double y = 1.0, base = x;
  while (n) {
    if (n & 1u) y = y * base;
    n >>= 1;
    if (n) base = base * base;
  }
  return y;
}

/* x^p, p a constant exponent, with nz_jet_pow's cases at order 0. */
static inline nz_status d_powc(double x, double p, double *z)
{
  int integer = is_small_integer(p);
  if (p == 0.0) { *z = 1.0; return NZ_OK; }
  if (integer && p > 0.0) { *z = d_powi(x, (unsigned)p); return NZ_OK; }
  if (x == 0.0) {
    if (integer || p < 0.0) return NZ_EZERODIV;
    *z = 0.0;
    return NZ_OK;
  }
  if (x < 0.0 && !integer) return NZ_EDOM;
  *z = pow(x, p);
  return NZ_OK;
}

/* x^y = exp(y log x), as nz_jet_pow_jet. */
static inline nz_status d_pow(double x, double y, double *z)
{
  if (x < 0.0) return NZ_EDOM;
  if (x == 0.0) return NZ_ESING;
  *z = exp(y * log(x));
  return NZ_OK;
}

/* hypot scaled by max(|a|, |b|), as nz_jet_hypot. */
static inline double d_hypot(double a, double b)
{
  double s = fmax(fabs(a), fabs(b));
  if (s == 0.0) return 0.0;
  double as = a / s, bs = b / s;
  return sqrt(as * as + bs * bs) * s;
}

static inline nz_status d_fn(int fn, double x, double *z)
{
  switch (fn) {
  case NZ_FN_EXP: *z = exp(x); break;
  case NZ_FN_LOG:
    if (!(x > 0.0)) return NZ_EDOM;
    *z = log(x);
    break;
  case NZ_FN_SQRT:
    if (x < 0.0) return NZ_EDOM;
    *z = sqrt(x);
    break;
  case NZ_FN_SIN: *z = sin(x); break;
  case NZ_FN_COS: *z = cos(x); break;
  case NZ_FN_TAN: *z = tan(x); break;
  case NZ_FN_ASIN:
  case NZ_FN_ACOS:
    if (fabs(x) > 1.0) return NZ_EDOM;
    *z = fn == NZ_FN_ASIN ? asin(x) : acos(x);
    break;
  case NZ_FN_ATAN: *z = atan(x); break;
  case NZ_FN_SINH: *z = sinh(x); break;
  case NZ_FN_COSH: *z = cosh(x); break;
  case NZ_FN_TANH: *z = tanh(x); break;
  case NZ_FN_ABS: *z = x < 0.0 ? -x : x; break;
  case NZ_FN_SIGN: *z = (double)((x > 0.0) - (x < 0.0)); break;   /* nz_jet_apply at order 0 */
  default: return NZ_EDOM;
  }
  return NZ_OK;
}

/* a op b on values: nz_jet_compare at order 0 (a tie is exact equality). */
static inline nz_status d_cmp(int op, double x, double y, double *z)
{
  int holds;
  if (isnan(x) || isnan(y)) return NZ_ENAN;
  switch (op) {
  case NZ_CMP_LT: holds = x < y; break;
  case NZ_CMP_LE: holds = x <= y; break;
  case NZ_CMP_GT: holds = x > y; break;
  case NZ_CMP_GE: holds = x >= y; break;
  case NZ_CMP_EQ: holds = x == y; break;
  case NZ_CMP_NE: holds = x != y; break;
  default: return NZ_EDOM;
  }
  *z = holds ? 1.0 : 0.0;
  return NZ_OK;
}

static inline nz_status d_finite(double z)
{
  if (isinf(z)) return NZ_ERANGE;
  if (isnan(z)) return NZ_ENAN;
  return NZ_OK;
}

/* One node on doubles (folding).  x, y: operand values. */
static nz_status scalar_op(const nz_gnode *nd, double x, double y, double *z)
{
  nz_status st = NZ_OK;
  switch (nd->op) {
  case NZ_GOP_ADD: *z = x + y; break;
  case NZ_GOP_SUB: *z = x - y; break;
  case NZ_GOP_MUL: *z = x * y; break;
  case NZ_GOP_DIV:
    if (y == 0.0) return NZ_EZERODIV;
    *z = x / y;
    break;
  case NZ_GOP_NEG: *z = -x; break;
  case NZ_GOP_POWC: st = d_powc(x, nd->v, z); break;
  case NZ_GOP_POW: st = d_pow(x, y, z); break;
  case NZ_GOP_FN: st = d_fn(nd->fn, x, z); break;
  case NZ_GOP_ATAN2: *z = atan2(x, y); break;
  case NZ_GOP_HYPOT: *z = d_hypot(x, y); break;
  case NZ_GOP_CMP: st = d_cmp(nd->fn, x, y, z); break;
  default: return NZ_EDOM;   /* SELECT folds by choosing (nz_graph_select) */
  }
  return st ? st : d_finite(*z);
}

nz_status nz_graph_scalar(const nz_gnode *nd, double x, double y, double *z) { return scalar_op(nd, x, y, z); }

/* ------------------------------------------------------------------ */
/* The graph and hash-consing                                           */

nz_graph *nz_graph_new(void)
{
  nz_graph *g = calloc(1, sizeof *g);
  if (!g) return NULL;
  g->tcap = 64;
  g->table = malloc(g->tcap * sizeof *g->table);
  if (!g->table) { free(g); return NULL; }
  for (size_t i = 0; i < g->tcap; i++) g->table[i] = -1;
  return g;
}

void nz_graph_free(nz_graph *g)
{
  if (!g) return;
  free(g->nodes);
  free(g->total);
  free(g->table);
  free(g);
}

int nz_graph_size(const nz_graph *g) { return g->n; }
const nz_gnode *nz_graph_nodes(const nz_graph *g) { return g->nodes; }
int nz_graph_ninputs(const nz_graph *g) { return g->ninputs; }

static uint64_t mix64(uint64_t h)
{
  h ^= h >> 33;
  h *= 0xff51afd7ed558ccdULL;
  h ^= h >> 33;
  h *= 0xc4ceb9fe1a85ec53ULL;
  h ^= h >> 33;
  return h;
}

static uint64_t node_hash(const nz_gnode *nd)
{
  uint64_t vb;
  memcpy(&vb, &nd->v, sizeof vb);
  uint64_t h = mix64(((uint64_t)nd->op << 8 | nd->fn) ^ 0x9e3779b97f4a7c15ULL);
  h = mix64(h ^ ((uint64_t)(uint32_t)nd->a | (uint64_t)(uint32_t)nd->b << 32));
  h = mix64(h ^ (uint64_t)(uint32_t)nd->c);
  return mix64(h ^ vb);
}

static int same_node(const nz_gnode *x, const nz_gnode *y)
{
  return x->op == y->op && x->fn == y->fn && x->a == y->a && x->b == y->b && x->c == y->c &&
         memcmp(&x->v, &y->v, sizeof x->v) == 0;
}

static size_t probe(const nz_graph *g, const nz_gnode *nd)
{
  size_t mask = g->tcap - 1, i = (size_t)node_hash(nd) & mask;
  while (g->table[i] >= 0 && !same_node(&g->nodes[g->table[i]], nd)) i = (i + 1) & mask;
  return i;
}

static int grow_table(nz_graph *g)
{
  size_t cap = g->tcap * 2;
  int32_t *t = malloc(cap * sizeof *t);
  if (!t) return -1;
  for (size_t i = 0; i < cap; i++) t[i] = -1;
  free(g->table);
  g->table = t;
  g->tcap = cap;
  for (int id = 0; id < g->n; id++) g->table[probe(g, &g->nodes[id])] = id;
  return 0;
}

/* Is an operation of this kind defined at every finite value of its
 * operands, in every evaluator (doubles, jets of any order with tangents)?
 * Not: log, sqrt, division by a node, pow and negative or fractional
 * powers (domain), abs, atan2 and hypot (the jets refuse them at their
 * singular points), exp, sinh and cosh (they overflow for moderate
 * arguments).  Sums and products count as defined: they overflow only
 * beyond 1e154 or so. */
static int op_total(const nz_graph *g, const nz_gnode *nd)
{
  switch (nd->op) {
  case NZ_GOP_CONST: case NZ_GOP_INPUT: case NZ_GOP_ADD: case NZ_GOP_SUB: case NZ_GOP_MUL:
  case NZ_GOP_NEG: case NZ_GOP_CMP: case NZ_GOP_SELECT:
    return 1;
  case NZ_GOP_DIV:
    return g->nodes[nd->b].op == NZ_GOP_CONST && g->nodes[nd->b].v != 0.0;
  case NZ_GOP_POWC:
    return nd->v >= 0.0 && nd->v == floor(nd->v);
  case NZ_GOP_FN:
    return nd->fn == NZ_FN_SIN || nd->fn == NZ_FN_COS || nd->fn == NZ_FN_TAN || nd->fn == NZ_FN_ATAN ||
           nd->fn == NZ_FN_TANH || nd->fn == NZ_FN_SIGN;
  default:
    return 0;
  }
}

static int node_total(const nz_graph *g, const nz_gnode *nd)
{
  return op_total(g, nd) && (nd->a < 0 || nd->op == NZ_GOP_INPUT || g->total[nd->a]) &&
         (nd->b < 0 || g->total[nd->b]) && (nd->c < 0 || g->total[nd->c]);
}

int nz_graph_total(const nz_graph *g, int x) { return x >= 0 && x < g->n && g->total[x]; }

void nz_graph_set_exact(nz_graph *g, int on) { g->exact = on != 0; }

/* The node nd, shared if it exists.  Storage grows before anything changes,
 * so running out of memory leaves g as it was. */
static int intern(nz_graph *g, nz_gnode nd)
{
  size_t i = probe(g, &nd);
  if (g->table[i] >= 0) return g->table[i];
  if (g->n == INT_MAX) return -1;
  if (g->n == g->cap) {
    int cap = g->cap ? (g->cap > INT_MAX / 2 ? INT_MAX : 2 * g->cap) : 64;
    nz_gnode *nn = realloc(g->nodes, (size_t)cap * sizeof *nn);
    if (!nn) return -1;
    g->nodes = nn;
    uint8_t *nt = realloc(g->total, (size_t)cap);
    if (!nt) return -1;
    g->total = nt;
    g->cap = cap;
  }
  if (2 * ((size_t)g->n + 1) > g->tcap) {
    if (grow_table(g)) return -1;
    i = probe(g, &nd);
  }
  g->nodes[g->n] = nd;
  g->total[g->n] = (uint8_t)node_total(g, &nd);
  g->table[i] = g->n;
  if (nd.op == NZ_GOP_INPUT && nd.a >= g->ninputs) g->ninputs = nd.a + 1;
  return g->n++;
}

static nz_gnode mknode(nz_gop op, int fn, int a, int b, double v)
{
  nz_gnode nd;
  memset(&nd, 0, sizeof nd);
  nd.op = (uint8_t)op;
  nd.fn = (uint8_t)fn;
  nd.a = a;
  nd.b = b;
  nd.v = v;
  nd.c = -1;
  return nd;
}

static int imin(int a, int b) { return a < b ? a : b; }
static int imax(int a, int b) { return a > b ? a : b; }
static int valid(const nz_graph *g, int x) { return x >= 0 && x < g->n; }

int nz_graph_is_const(const nz_graph *g, int x, double *v)
{
  if (!valid(g, x) || g->nodes[x].op != NZ_GOP_CONST) return 0;
  if (v) *v = g->nodes[x].v;
  return 1;
}

static int is_const_value(const nz_graph *g, int x, double v)
{
  double c;
  return nz_graph_is_const(g, x, &c) && c == v;
}

int nz_graph_const(nz_graph *g, double v) { return intern(g, mknode(NZ_GOP_CONST, 0, -1, -1, v)); }

int nz_graph_input(nz_graph *g, int input)
{
  if (input < 0) return -1;
  return intern(g, mknode(NZ_GOP_INPUT, 0, input, -1, 0.0));
}

/* Fold nd when its operands are constants and the result is finite and
 * defined; otherwise record it (evaluation will report the error). */
static int fold_or_intern(nz_graph *g, nz_gnode nd)
{
  double x, y = 0.0, z;
  int unary = nd.b < 0;
  if (nz_graph_is_const(g, nd.a, &x) && (unary || nz_graph_is_const(g, nd.b, &y)) &&
      scalar_op(&nd, x, y, &z) == NZ_OK)
    return nz_graph_const(g, z);
  return intern(g, nd);
}

/* Like terms.  x as coef * base: a product with one constant factor, or the
 * negation of one, or of anything (coef -1), or x itself (coef 1). */
static int split_term(const nz_graph *g, int x, double *coef)
{
  const nz_gnode *nd = &g->nodes[x];
  double s = 1.0, c;
  if (nd->op == NZ_GOP_NEG) {
    s = -1.0;
    x = nd->a;
    nd = &g->nodes[x];
  }
  if (nd->op == NZ_GOP_MUL) {
    /* A product of two constants that overflowed stays unfolded: not a term. */
    int ka = nz_graph_is_const(g, nd->a, NULL), kb = nz_graph_is_const(g, nd->b, NULL);
    if (ka != kb) {
      nz_graph_is_const(g, ka ? nd->a : nd->b, &c);
      *coef = s * c;
      return ka ? nd->b : nd->a;
    }
  }
  *coef = s;
  return x;
}

static int build_neg(nz_graph *g, int a);

/* c x for a base x of split_term and a finite c.  0 x is the constant 0
 * only when x is defined everywhere and signed zeros may go (not exact). */
static int scaled(nz_graph *g, double c, int x)
{
  if (c == 0.0 && !g->exact && g->total[x]) return nz_graph_const(g, 0.0);
  if (c == 0.0) {
    int k = nz_graph_const(g, c);
    return k < 0 ? -1 : intern(g, mknode(NZ_GOP_MUL, 0, imin(k, x), imax(k, x), 0.0));
  }
  if (c == 1.0) return x;
  if (c == -1.0) return build_neg(g, x);
  int k = nz_graph_const(g, c);
  if (k < 0) return -1;
  return fold_or_intern(g, mknode(NZ_GOP_MUL, 0, imin(k, x), imax(k, x), 0.0));
}

static int build_neg(nz_graph *g, int a)
{
  const nz_gnode *nd = &g->nodes[a];
  if (nd->op == NZ_GOP_NEG) return nd->a;   /* -(-x) = x */
  if (nd->op == NZ_GOP_MUL) {   /* -(c x) = (-c) x */
    double c;
    int x = split_term(g, a, &c);
    if (x != a) return scaled(g, -c, x);
  }
  return fold_or_intern(g, mknode(NZ_GOP_NEG, 0, a, -1, 0.0));
}

static int is_neg(const nz_graph *g, int x) { return g->nodes[x].op == NZ_GOP_NEG; }

/* a + s b (s = +-1) when both are terms of one base, else -1. */
static int gather(nz_graph *g, int a, int b, double s)
{
  double ca, cb;
  if (g->exact || nz_graph_is_const(g, a, NULL) || nz_graph_is_const(g, b, NULL)) return -1;
  int xa = split_term(g, a, &ca), xb = split_term(g, b, &cb);
  double c = ca + s * cb;
  if (xa != xb || !isfinite(c) || (c == 0.0 && !g->total[xa])) return -1;
  return scaled(g, c, xa);
}

int nz_graph_powc(nz_graph *g, int a, double p)
{
  if (!valid(g, a) || !isfinite(p)) return -1;
  /* as nz_jet_pow: x^0 = 1, once x is known to be defined (not when
   * exact: a constant jet of x's shape in Lua) */
  if (p == 0.0 && g->total[a] && !g->exact) return nz_graph_const(g, 1.0);
  if (p == 1.0) return a;
  return fold_or_intern(g, mknode(NZ_GOP_POWC, 0, a, -1, p));
}

int nz_graph_fn(nz_graph *g, nz_jet_fn fn, int a)
{
  if (!valid(g, a) || (int)fn < 0 || fn >= NZ_FN_COUNT) return -1;
  return fold_or_intern(g, mknode(NZ_GOP_FN, fn, a, -1, 0.0));
}

int nz_graph_op(nz_graph *g, nz_gop op, int a, int b)
{
  double v = 0.0;
  if (!valid(g, a)) return -1;
  if (op == NZ_GOP_NEG) return build_neg(g, a);
  if (!valid(g, b)) return -1;
  switch (op) {
  case NZ_GOP_ADD:
  case NZ_GOP_SUB: {
    /* x + 0 and 0 + x are x, 0 - x is -x, except for the sign of a zero:
     * exactly, x + (-0) = (-0) + x = x - (+0) = x and (-0) - x = -x */
    if (is_const_value(g, b, 0.0) && (!g->exact || !!signbit(g->nodes[b].v) == (op == NZ_GOP_ADD))) return a;
    if (op == NZ_GOP_ADD && is_const_value(g, a, 0.0) && (!g->exact || signbit(g->nodes[a].v))) return b;
    /* x - x is +0 for a finite x; not when exact, where x - x is a jet
     * whose shape a later function reads (sqrt(q - q) refuses on jets) */
    if (op == NZ_GOP_SUB && a == b && g->total[a] && !g->exact) return nz_graph_const(g, 0.0);
    if (op == NZ_GOP_SUB && is_const_value(g, a, 0.0) && (!g->exact || signbit(g->nodes[a].v)))
      return build_neg(g, b);
    int t = gather(g, a, b, op == NZ_GOP_ADD ? 1.0 : -1.0);
    if (t >= 0) return t;
    /* Negations into the sum, exact: a + (-b) = a - b, (-a) + b = b - a,
     * a - (-b) = a + b (IEEE defines a - b as a + (-b)). */
    if (is_neg(g, b)) return nz_graph_op(g, op == NZ_GOP_ADD ? NZ_GOP_SUB : NZ_GOP_ADD, a, g->nodes[b].a);
    if (op == NZ_GOP_ADD && is_neg(g, a)) return nz_graph_op(g, NZ_GOP_SUB, b, g->nodes[a].a);
    /* A negative coefficient likewise, exact ((-c) y = -(c y)): a + (c y) =
     * a - (|c| y), a - (c y) = a + (|c| y); so sums share their terms. */
    double cb;
    int yb = nz_graph_is_const(g, b, NULL) ? b : split_term(g, b, &cb);
    if (yb != b && cb < 0.0) {
      int t2 = scaled(g, -cb, yb);
      return t2 < 0 ? -1 : nz_graph_op(g, op == NZ_GOP_ADD ? NZ_GOP_SUB : NZ_GOP_ADD, a, t2);
    }
    break;
  }
  case NZ_GOP_MUL:
    if (is_const_value(g, a, 1.0)) return b;
    if (is_const_value(g, b, 1.0)) return a;
    /* x 0 = 0 for a finite x, with the sign of x (kept when exact) */
    if (!g->exact && ((is_const_value(g, a, 0.0) && g->total[b]) || (is_const_value(g, b, 0.0) && g->total[a])))
      return nz_graph_const(g, 0.0);
    if (!nz_graph_is_const(g, a, NULL) && is_const_value(g, b, -1.0)) return build_neg(g, a);
    if (!nz_graph_is_const(g, b, NULL) && is_const_value(g, a, -1.0)) return build_neg(g, b);
    if (!g->exact && nz_graph_is_const(g, a, NULL) != nz_graph_is_const(g, b, NULL)) {   /* c1 (c2 x) */
      int k = nz_graph_is_const(g, a, NULL) ? a : b, y = k == a ? b : a;
      double cy;
      int x = split_term(g, y, &cy);
      nz_graph_is_const(g, k, &v);
      if (x != y && isfinite(v * cy) && (v * cy != 0.0 || v == 0.0 || cy == 0.0)) return scaled(g, v * cy, x);
    }
    /* Constant factors and signs out of a product: (c1 x)(c2 y) = (c1 c2)(x y),
     * (-x) y = -(x y) (exact), (-x)(-y) = x y (exact: all that an exact
     * graph moves). */
    if (!nz_graph_is_const(g, a, NULL) && !nz_graph_is_const(g, b, NULL)) {
      double ca, cb;
      int xa = split_term(g, a, &ca), xb = split_term(g, b, &cb);
      if (g->exact && (fabs(ca) != 1.0 || fabs(cb) != 1.0)) xa = a, xb = b;
      if ((xa != a || xb != b) && isfinite(ca * cb)) {
        int xy = nz_graph_op(g, NZ_GOP_MUL, xa, xb), k = nz_graph_const(g, ca * cb);
        return xy < 0 || k < 0 ? -1 : nz_graph_op(g, NZ_GOP_MUL, k, xy);
      }
    }
    break;
  case NZ_GOP_DIV:   /* x / x is kept: x may be 0 when evaluated */
    if (is_const_value(g, b, 1.0)) return a;
    if (!nz_graph_is_const(g, a, NULL) && is_const_value(g, b, -1.0)) return build_neg(g, a);
    /* (c x) / d = (c / d) x, as c1 (c2 x) above, when c / d is exact: the
     * derivatives of x^2 / 2 and y^3 / 3 are x and y^2, not (2 x) / 2 and
     * (3 y^2) / 3 (two nodes fewer each, in every evaluation and series) */
    if (!g->exact && !nz_graph_is_const(g, a, NULL) && nz_graph_is_const(g, b, &v) && v != 0.0 && isfinite(v)) {
      double ca, qv;
      int xa = split_term(g, a, &ca);
      if (xa != a && isfinite(qv = ca / v) && qv != 0.0 && fma(qv, v, -ca) == 0.0) return scaled(g, qv, xa);
    }
    break;
  case NZ_GOP_POW:
    /* a constant exponent is POWC even for a constant base: (-2)^2 = 4;
     * not when exact: an exponent that is a traced value folded to a
     * constant (q1 - q1) is a jet in Lua, whose x^y needs x > 0 */
    if (!g->exact && nz_graph_is_const(g, b, &v)) return nz_graph_powc(g, a, v);
    break;
  case NZ_GOP_ATAN2:
  case NZ_GOP_HYPOT:
    break;
  default:
    return -1;
  }
  /* commutative operands in a canonical order, so that x y and y x share a
   * node; not a product when exact: on jets a product is a Cauchy sum,
   * whose rounding depends on the order (the jets take it as written) */
  if ((op == NZ_GOP_ADD || (op == NZ_GOP_MUL && !g->exact) || op == NZ_GOP_HYPOT) && a > b) {
    int t = a;
    a = b;
    b = t;
  }
  return fold_or_intern(g, mknode(op, 0, a, b, 0.0));
}

int nz_graph_cmp(nz_graph *g, nz_cmp op, int a, int b)
{
  if (!valid(g, a) || !valid(g, b) || (int)op < 0 || op > NZ_CMP_NE) return -1;
  if (a == b && g->total[a] && !g->exact)   /* the same series: equal in every coefficient */
    return nz_graph_const(g, op == NZ_CMP_LE || op == NZ_CMP_GE || op == NZ_CMP_EQ ? 1.0 : 0.0);
  return fold_or_intern(g, mknode(NZ_GOP_CMP, op, a, b, 0.0));
}

int nz_graph_select(nz_graph *g, int c, int a, int b)
{
  double v;
  if (!valid(g, c) || !valid(g, a) || !valid(g, b)) return -1;
  /* the operand not taken, or the condition, goes only when it cannot
   * fail: in Lua both operands and the condition are computed; when exact,
   * only when it is a constant (in Lua a number branch takes the shape of
   * a jet branch, which a later function reads) */
  if (nz_graph_is_const(g, c, &v) && !isnan(v)) {
    int taken = v != 0.0 ? a : b, other = v != 0.0 ? b : a;
    if (g->total[other] && !(g->exact && !nz_graph_is_const(g, other, NULL))) return taken;
  }
  if (a == b && g->total[c]) return a;
  nz_gnode nd = mknode(NZ_GOP_SELECT, 0, a, b, 0.0);
  nd.c = c;
  return intern(g, nd);
}

/* ------------------------------------------------------------------ */
/* Forward differentiation on the graph                                 */

/* Derivative node ids; DZERO is an exact zero (nothing moves the node). */
#define DZERO (-1)

typedef struct dctx {
  nz_graph *g;
  int oom;   /* a build failed: the whole derivative fails */
} dctx;

/* A value node just built (flag a failure). */
static int V(dctx *c, int id)
{
  if (id < 0) c->oom = 1;
  return id;
}
/* A derivative node just built: constant zero becomes DZERO. */
static int Dk(dctx *c, int id)
{
  if (id < 0) { c->oom = 1; return DZERO; }
  return is_const_value(c->g, id, 0.0) ? DZERO : id;
}
static int d_neg(dctx *c, int x) { return x == DZERO ? DZERO : Dk(c, nz_graph_op(c->g, NZ_GOP_NEG, x, -1)); }
static int d_add(dctx *c, int x, int y)
{
  if (x == DZERO) return y;
  if (y == DZERO) return x;
  return Dk(c, nz_graph_op(c->g, NZ_GOP_ADD, x, y));
}
static int d_sub(dctx *c, int x, int y)
{
  if (y == DZERO) return x;
  if (x == DZERO) return d_neg(c, y);
  return Dk(c, nz_graph_op(c->g, NZ_GOP_SUB, x, y));
}
/* One factor a value node (or a failed build, -1), the other anything. */
static int d_mul(dctx *c, int x, int y)
{
  if (x == DZERO || y == DZERO) return DZERO;
  return Dk(c, nz_graph_op(c->g, NZ_GOP_MUL, x, y));
}
static int d_div(dctx *c, int x, int y)
{
  if (x == DZERO || y < 0) return DZERO;
  return Dk(c, nz_graph_op(c->g, NZ_GOP_DIV, x, y));
}
static int v_const(dctx *c, double v) { return V(c, nz_graph_const(c->g, v)); }
static int v_op(dctx *c, nz_gop op, int a, int b) { return V(c, nz_graph_op(c->g, op, a, b)); }
static int v_fn(dctx *c, nz_jet_fn fn, int a) { return V(c, nz_graph_fn(c->g, fn, a)); }
static int v_sq(dctx *c, int a) { return V(c, nz_graph_powc(c->g, a, 2.0)); }

/* d fn(a) = fn'(a) da, z = fn(a). */
static int d_fn_rule(dctx *c, nz_jet_fn fn, int a, int z, int da)
{
  switch (fn) {
  case NZ_FN_EXP: return d_mul(c, z, da);
  case NZ_FN_LOG: return d_div(c, da, a);
  case NZ_FN_SQRT: return d_div(c, da, v_op(c, NZ_GOP_MUL, v_const(c, 2.0), z));
  case NZ_FN_SIN: return d_mul(c, v_fn(c, NZ_FN_COS, a), da);
  case NZ_FN_COS: return d_neg(c, d_mul(c, v_fn(c, NZ_FN_SIN, a), da));
  case NZ_FN_TAN: return d_mul(c, v_op(c, NZ_GOP_ADD, v_const(c, 1.0), v_sq(c, z)), da);
  case NZ_FN_ASIN:
  case NZ_FN_ACOS: {
    int r = v_fn(c, NZ_FN_SQRT, v_op(c, NZ_GOP_SUB, v_const(c, 1.0), v_sq(c, a)));
    int d = d_div(c, da, r);
    return fn == NZ_FN_ASIN ? d : d_neg(c, d);
  }
  case NZ_FN_ATAN: return d_div(c, da, v_op(c, NZ_GOP_ADD, v_const(c, 1.0), v_sq(c, a)));
  case NZ_FN_SINH: return d_mul(c, v_fn(c, NZ_FN_COSH, a), da);
  case NZ_FN_COSH: return d_mul(c, v_fn(c, NZ_FN_SINH, a), da);
  case NZ_FN_TANH: return d_mul(c, v_op(c, NZ_GOP_SUB, v_const(c, 1.0), v_sq(c, z)), da);
  case NZ_FN_ABS: return d_mul(c, v_op(c, NZ_GOP_DIV, a, z), da);   /* a/|a|: 0/0 at 0 */
  case NZ_FN_SIGN: return DZERO;   /* a step */
  default: c->oom = 1; return DZERO;
  }
}

/* The derivative of node z = nd given its operands' derivatives da, db. */
static int d_rule(dctx *c, const nz_gnode *nd, int z, int da, int db)
{
  int a = nd->a, b = nd->b;
  switch (nd->op) {
  case NZ_GOP_ADD: return d_add(c, da, db);
  case NZ_GOP_SUB: return d_sub(c, da, db);
  case NZ_GOP_NEG: return d_neg(c, da);
  case NZ_GOP_MUL: return d_add(c, d_mul(c, da, b), d_mul(c, a, db));
  case NZ_GOP_DIV:   /* (da - z db) / b */
    return d_div(c, d_sub(c, da, d_mul(c, z, db)), b);
  case NZ_GOP_POWC: {
    double p = nd->v;
    if (p == 1.0) return da;
    if (p == 0.0) return DZERO;   /* x^0 = 1 wherever x is defined */
    return d_mul(c, v_op(c, NZ_GOP_MUL, v_const(c, p), V(c, nz_graph_powc(c->g, a, p - 1.0))), da);
  }
  case NZ_GOP_POW: {   /* z (db log a + b da / a) */
    int t1 = d_mul(c, db, db == DZERO ? DZERO : v_fn(c, NZ_FN_LOG, a));
    int t2 = d_div(c, d_mul(c, b, da), a);
    return d_mul(c, z, d_add(c, t1, t2));
  }
  case NZ_GOP_FN: return d_fn_rule(c, (nz_jet_fn)nd->fn, a, z, da);
  case NZ_GOP_ATAN2: {   /* a = y, b = x: (x dy - y dx) / (x^2 + y^2) */
    int num = d_sub(c, d_mul(c, b, da), d_mul(c, a, db));
    if (num == DZERO) return DZERO;
    return d_div(c, num, v_op(c, NZ_GOP_ADD, v_sq(c, b), v_sq(c, a)));
  }
  case NZ_GOP_HYPOT:   /* (a da + b db) / z */
    return d_div(c, d_add(c, d_mul(c, a, da), d_mul(c, b, db)), z);
  case NZ_GOP_CMP: return DZERO;   /* a step */
  case NZ_GOP_SELECT: {   /* the derivative of the branch taken */
    int x = da == DZERO ? v_const(c, 0.0) : da, y = db == DZERO ? v_const(c, 0.0) : db;
    if (c->oom) return DZERO;
    return Dk(c, nz_graph_select(c->g, nd->c, x, y));
  }
  default: c->oom = 1; return DZERO;
  }
}

static int has_operand(int op) { return op != NZ_GOP_CONST && op != NZ_GOP_INPUT; }
static int unary_op(int op) { return op == NZ_GOP_NEG || op == NZ_GOP_POWC || op == NZ_GOP_FN; }
static int binary_op(int op) { return has_operand(op) && !unary_op(op); }
static int has_cond(int op) { return op == NZ_GOP_SELECT; }

int nz_graph_derivatives(nz_graph *g, const int *roots, int nroots, const int *dinput, int *droots)
{
  int n = g->n, top = -1;
  if (nroots < 0) return -1;
  for (int r = 0; r < nroots; r++) {
    if (!valid(g, roots[r])) return -1;
    if (roots[r] > top) top = roots[r];
  }
  for (int i = 0; dinput && i < g->ninputs; i++)
    if (dinput[i] != -1 && !valid(g, dinput[i])) return -1;
  char *mark = calloc((size_t)top + 2, 1);
  int *d = malloc(((size_t)top + 2) * sizeof *d);
  dctx c = { g, 0 };
  if (!mark || !d) { free(mark); free(d); return -1; }
  for (int r = 0; r < nroots; r++) mark[roots[r]] = 1;
  int lo = top + 1;
  for (int id = top; id >= 0; id--) {
    if (!mark[id]) continue;
    lo = id;
    const nz_gnode *nd = &g->nodes[id];
    if (has_operand(nd->op)) mark[nd->a] = 1;
    if (binary_op(nd->op)) mark[nd->b] = 1;
  }
  /* Ids above n are the derivative's own nodes: never revisited. */
  for (int id = lo; id <= top && id < n && !c.oom; id++) {
    if (!mark[id]) continue;
    nz_gnode nd = g->nodes[id];   /* a copy: building may move g->nodes */
    if (nd.op == NZ_GOP_CONST) { d[id] = DZERO; continue; }
    if (nd.op == NZ_GOP_INPUT) {
      int di = dinput && nd.a < g->ninputs ? dinput[nd.a] : -1;
      d[id] = di < 0 || is_const_value(g, di, 0.0) ? DZERO : di;
      continue;
    }
    int da = d[nd.a], db = binary_op(nd.op) ? d[nd.b] : DZERO;
    d[id] = da == DZERO && db == DZERO ? DZERO : d_rule(&c, &nd, id, da, db);
  }
  for (int r = 0; r < nroots && !c.oom; r++) {
    int x = d[roots[r]];
    droots[r] = x == DZERO ? v_const(&c, 0.0) : x;
  }
  free(mark);
  free(d);
  return c.oom ? -1 : 0;
}

int nz_graph_derivative(nz_graph *g, int root, const int *dinput)
{
  int dr;
  return nz_graph_derivatives(g, &root, 1, dinput, &dr) ? -1 : dr;
}

/* ------------------------------------------------------------------ */
/* Copies and substitutions                                             */

int nz_graph_copy(nz_graph *dst, const nz_graph *src, const int *roots, int nroots, const int *input_map,
                  int *out)
{
  int top = -1;
  if (nroots < 0) return -1;
  for (int r = 0; r < nroots; r++) {
    if (!valid(src, roots[r])) return -1;
    if (roots[r] > top) top = roots[r];
  }
  for (int i = 0; input_map && i < src->ninputs; i++)
    if (input_map[i] != -1 && !valid(dst, input_map[i])) return -1;
  char *mark = calloc((size_t)top + 2, 1);
  int *to = malloc(((size_t)top + 2) * sizeof *to);
  if (!mark || !to) { free(mark); free(to); return -1; }
  for (int r = 0; r < nroots; r++) mark[roots[r]] = 1;
  int lo = top + 1;
  for (int id = top; id >= 0; id--) {
    if (!mark[id]) continue;
    lo = id;
    const nz_gnode *nd = &src->nodes[id];
    if (has_operand(nd->op)) mark[nd->a] = 1;
    if (binary_op(nd->op)) mark[nd->b] = 1;
    if (has_cond(nd->op)) mark[nd->c] = 1;
  }
  /* With dst == src the new nodes come after top: never read here. */
  int ok = 1;
  for (int id = lo; id <= top && ok; id++) {
    if (!mark[id]) continue;
    nz_gnode nd = src->nodes[id];   /* a copy: building may move src->nodes when dst == src */
    int x;
    switch (nd.op) {
    case NZ_GOP_CONST: x = nz_graph_const(dst, nd.v); break;
    case NZ_GOP_INPUT: {
      int m = input_map && nd.a < src->ninputs ? input_map[nd.a] : -1;
      x = m >= 0 ? m : nz_graph_input(dst, nd.a);
      break;
    }
    case NZ_GOP_NEG: x = nz_graph_op(dst, NZ_GOP_NEG, to[nd.a], -1); break;
    case NZ_GOP_POWC: x = nz_graph_powc(dst, to[nd.a], nd.v); break;
    case NZ_GOP_FN: x = nz_graph_fn(dst, (nz_jet_fn)nd.fn, to[nd.a]); break;
    case NZ_GOP_CMP: x = nz_graph_cmp(dst, (nz_cmp)nd.fn, to[nd.a], to[nd.b]); break;
    case NZ_GOP_SELECT: x = nz_graph_select(dst, to[nd.c], to[nd.a], to[nd.b]); break;
    default: x = nz_graph_op(dst, (nz_gop)nd.op, to[nd.a], to[nd.b]); break;
    }
    if (x < 0) ok = 0;
    to[id] = x;
  }
  for (int r = 0; r < nroots && ok; r++) out[r] = to[roots[r]];
  free(mark);
  free(to);
  return ok ? 0 : -1;
}

/* ------------------------------------------------------------------ */
/* Plans                                                                */

/* The double evaluator's opcodes: the graph's, with POWC and FN split. */
enum {
  R_ADD, R_SUB, R_MUL, R_DIV, R_NEG, R_SQR, R_CUBE, R_POWI, R_POWC, R_POW, R_FN, R_ATAN2,
  R_HYPOT, R_CMP, R_SELECT
};

/* One computed node for the double loop: operand slots (b = a for unary
 * ops, so that reading it is always safe) and an integer parameter (the
 * exponent of R_POWI, the function of R_FN, the nz_cmp of R_CMP, the slot
 * of the condition of R_SELECT). */
typedef struct grec {
  int32_t op, a, b, k;
} grec;

/* A run of computed slots with the same opcode, ending before slot `end`
 * (relative to the first computed slot): one dispatch per run. */
typedef struct grun {
  int32_t op, end;
} grun;

/* The same node for the jet evaluator. */
typedef struct jrec {
  uint8_t op, fn;
  int32_t a, b;   /* slots; b = a for unary ops */
  double v;
  int32_t c;      /* slot of the condition (SELECT), else a */
} jrec;

#define NTEMP 4

struct nz_graph_plan {
  const nz_graph *g;
  int nout, *out_slot;
  int m;          /* slots: inputs, then constants, then computed nodes */
  int nin, ncon, base, nrec;
  int *ids;       /* slot -> node id */
  int *in_num;    /* input slot -> input number */
  grec *recs;
  int nrun;
  grun *runs;
  jrec *jrecs;
  double *pv;     /* exponent of each computed node (R_POWC) */
  double *vals;   /* m doubles: the double workspace */
  /* Jet workspace, laid out per call in one arena. */
  const nz_jet **J, **E;   /* value and eta-part of each slot (E NULL: zero) */
  nz_jet **W, **EW;        /* the writable jets of computed slots */
  int *ord, *ntn, *eord, *entn;
  double *arena;
  size_t arena_len;
  nz_jet *T[NTEMP];
  double *w;
  /* Series built order by order (nz_graph_series_*, at the end of this file). */
  struct srec *srecs;   /* per computed slot */
  int *ser_aux;         /* first auxiliary series of each computed slot */
  int ser_naux;         /* auxiliary series in all; -1 before the first begin */
  int *ser_map;         /* node id -> slot, -1 for nodes outside the plan */
  int ser_top;          /* highest node id of the plan */
  double *ser;          /* (m + ser_naux) series of ser_cap + 1 coefficients */
  int ser_cap;          /* the highest order the storage holds, -1 none */
  int ser_K, ser_k;     /* max_order of this evaluation, last coefficient filled */
  int ser_ties;
  grun *sruns;          /* runs of computed slots with the same series kernel */
  int nsrun;
  double *ser_v;        /* each computed slot's v, for machine code */
  unsigned long ser_sig;   /* the kernels' signature, 0 before a begin */
  nz_series_code ser_code;   /* machine code for next, or NULL */
  void (*const *ser_kfn)(void);
  unsigned long ser_code_sig;   /* the signature it was made for */
  /* Failure of the last evaluation. */
  int bad_const;   /* a non-finite constant slot, or -1 */
  int fail_node;
  nz_gop fail_op;
  nz_jet_fn fail_fn;
  double fail_operand;
};

void nz_graph_plan_free(nz_graph_plan *p)
{
  if (!p) return;
  free(p->out_slot);
  free(p->ids);
  free(p->in_num);
  free(p->recs);
  free(p->runs);
  free(p->jrecs);
  free(p->pv);
  free(p->vals);
  free(p->J);
  free(p->E);
  free(p->W);
  free(p->EW);
  free(p->ord);
  free(p->ntn);
  free(p->eord);
  free(p->entn);
  free(p->arena);
  free(p->srecs);
  free(p->ser_aux);
  free(p->ser_map);
  free(p->ser);
  free(p->sruns);
  free(p->ser_v);
  free(p);
}

int nz_graph_plan_nodes(const nz_graph_plan *p) { return p->m; }
int nz_graph_plan_noutputs(const nz_graph_plan *p) { return p->nout; }

static grec make_grec(const nz_gnode *nd, int a, int b, int c)
{
  grec r = { 0, a, b, 0 };
  switch (nd->op) {
  case NZ_GOP_ADD: r.op = R_ADD; break;
  case NZ_GOP_SUB: r.op = R_SUB; break;
  case NZ_GOP_MUL: r.op = R_MUL; break;
  case NZ_GOP_DIV: r.op = R_DIV; break;
  case NZ_GOP_NEG: r.op = R_NEG; break;
  case NZ_GOP_POW: r.op = R_POW; break;
  case NZ_GOP_ATAN2: r.op = R_ATAN2; break;
  case NZ_GOP_HYPOT: r.op = R_HYPOT; break;
  case NZ_GOP_FN: r.op = R_FN; r.k = nd->fn; break;
  case NZ_GOP_CMP: r.op = R_CMP; r.k = nd->fn; break;
  case NZ_GOP_SELECT: r.op = R_SELECT; r.k = c; break;
  case NZ_GOP_POWC:
    if (nd->v == 2.0) r.op = R_SQR;
    else if (nd->v == 3.0) r.op = R_CUBE;
    else if (nd->v > 0.0 && is_small_integer(nd->v)) { r.op = R_POWI; r.k = (int32_t)nd->v; }
    else r.op = R_POWC;
    break;
  default: break;
  }
  return r;
}

/* The plan's arrays (p comes from calloc: on failure those not allocated
 * are NULL, and nz_graph_plan_free frees the others). */
static int plan_alloc(nz_graph_plan *p)
{
  size_t m = (size_t)p->m + 1, nr = (size_t)p->nrec + 1, ni = (size_t)p->nin + 1;
#define ALLOC(f, n) ((p->f = malloc((n) * sizeof *p->f)) != NULL)
  int ok = ALLOC(ids, m) && ALLOC(in_num, ni) && ALLOC(recs, nr) && ALLOC(runs, nr) &&
           ALLOC(jrecs, nr) && ALLOC(pv, nr) && ALLOC(vals, m) && ALLOC(J, m) && ALLOC(E, m) &&
           ALLOC(W, m) && ALLOC(EW, m) && ALLOC(ord, m) && ALLOC(ntn, m) && ALLOC(eord, m) &&
           ALLOC(entn, m);
#undef ALLOC
  return ok ? 0 : -1;
}

/* Scheduling: computed nodes sorted by level (1 + the highest level of
 * their operands), then by opcode, then by id.  Any order by level is
 * topological; within a level, nodes of one opcode come together, so the
 * double loop dispatches once per run of them and the runs' nodes are
 * independent (the processor overlaps them). */
typedef struct sched {
  int level, key, id;
} sched;

static int sched_cmp(const void *x, const void *y)
{
  const sched *u = x, *w = y;
  if (u->level != w->level) return u->level < w->level ? -1 : 1;
  if (u->key != w->key) return u->key < w->key ? -1 : 1;
  return (u->id > w->id) - (u->id < w->id);
}

/* Mark what the outputs need; lev[id] = level + 1 for a needed node, 0 for
 * the others.  Counts the plan's slots. */
static void plan_mark(nz_graph_plan *p, const nz_graph *g, const int *outputs, int n, int top,
                      int *lev)
{
  for (int id = 0; id <= top; id++) lev[id] = 0;
  for (int r = 0; r < n; r++) lev[outputs[r]] = 1;
  for (int id = top; id >= 0; id--) {
    if (!lev[id]) continue;
    const nz_gnode *nd = &g->nodes[id];
    if (has_operand(nd->op)) lev[nd->a] = 1;
    if (binary_op(nd->op)) lev[nd->b] = 1;
    if (has_cond(nd->op)) lev[nd->c] = 1;
    if (nd->op == NZ_GOP_INPUT) p->nin++;
    else if (nd->op == NZ_GOP_CONST) p->ncon++;
    else p->nrec++;
    p->m++;
  }
  for (int id = 0; id <= top; id++) {
    const nz_gnode *nd = &g->nodes[id];
    if (!lev[id] || !has_operand(nd->op)) continue;
    lev[id] = 1 + imax(imax(lev[nd->a], binary_op(nd->op) ? lev[nd->b] : 0),
                       has_cond(nd->op) ? lev[nd->c] : 0);
  }
}

nz_graph_plan *nz_graph_plan_new(const nz_graph *g, const int *outputs, int n)
{
  int top = -1;
  if (n < 0) return NULL;
  for (int r = 0; r < n; r++) {
    if (!valid(g, outputs[r])) return NULL;
    if (outputs[r] > top) top = outputs[r];
  }
  nz_graph_plan *p = calloc(1, sizeof *p);
  int *slot = malloc(((size_t)top + 2) * sizeof *slot);
  if (!p || !slot) { free(p); free(slot); return NULL; }
  p->g = g;
  p->fail_node = -1;
  p->bad_const = -1;
  p->ser_naux = -1;
  p->ser_cap = -1;
  p->ser_k = -1;
  p->nout = n;
  p->out_slot = malloc(((size_t)n + 1) * sizeof *p->out_slot);
  plan_mark(p, g, outputs, n, top, slot);
  p->base = p->nin + p->ncon;
  sched *order = malloc(((size_t)p->nrec + 1) * sizeof *order);
  if (!order || !p->out_slot || plan_alloc(p)) {
    free(order);
    free(slot);
    nz_graph_plan_free(p);
    return NULL;
  }
  /* Slots: inputs and constants in id order, then computed nodes as
   * scheduled (slot[] turns from levels into slots as it goes). */
  int si = 0, sc = p->nin, nr = 0;
  for (int id = 0; id <= top; id++) {
    const nz_gnode *nd = &g->nodes[id];
    if (!slot[id]) continue;
    if (nd->op == NZ_GOP_INPUT) {
      p->in_num[si] = nd->a;
      p->ids[si] = id;
      slot[id] = si++;
    } else if (nd->op == NZ_GOP_CONST) {
      p->vals[sc] = nd->v;
      if (!isfinite(nd->v) && p->bad_const < 0) p->bad_const = sc;
      p->ids[sc] = id;
      slot[id] = sc++;
    } else {
      grec r = make_grec(nd, 0, 0, 0);
      int sub = r.op == R_FN || r.op == R_CMP ? r.k : 0;
      order[nr++] = (sched){ slot[id], r.op * 64 + sub, id };
    }
  }
  qsort(order, (size_t)nr, sizeof *order, sched_cmp);
  for (int i = 0; i < nr; i++) {
    int id = order[i].id, s = p->base + i;
    const nz_gnode *nd = &g->nodes[id];
    int a = slot[nd->a], b = binary_op(nd->op) ? slot[nd->b] : a;
    int cs = has_cond(nd->op) ? slot[nd->c] : a;
    slot[id] = s;
    p->ids[s] = id;
    p->recs[i] = make_grec(nd, a, b, cs);
    p->jrecs[i] = (jrec){ nd->op, nd->fn, a, b, nd->v, cs };
    p->pv[i] = nd->v;
    if (p->nrun == 0 || p->runs[p->nrun - 1].op != p->recs[i].op) p->runs[p->nrun++].op = p->recs[i].op;
    p->runs[p->nrun - 1].end = i + 1;
  }
  for (int r = 0; r < n; r++) p->out_slot[r] = slot[outputs[r]];
  free(order);
  free(slot);
  return p;
}

void nz_graph_plan_failure(const nz_graph_plan *p, int *node, nz_gop *op, nz_jet_fn *fn,
                           double *operand)
{
  if (node) *node = p->fail_node;
  if (op) *op = p->fail_op;
  if (fn) *fn = p->fail_fn;
  if (operand) *operand = p->fail_operand;
}

/* Record the failure of slot s; operand: the value of its first operand. */
static nz_status plan_fail(nz_graph_plan *p, int s, nz_status st, double operand)
{
  p->fail_node = p->ids[s];
  if (s < p->nin) { p->fail_op = NZ_GOP_INPUT; p->fail_fn = 0; }
  else if (s < p->base) { p->fail_op = NZ_GOP_CONST; p->fail_fn = 0; }
  else {
    p->fail_op = (nz_gop)p->jrecs[s - p->base].op;
    p->fail_fn = (nz_jet_fn)p->jrecs[s - p->base].fn;
  }
  p->fail_operand = operand;
  return st;
}

/* ------------------------------------------------------------------ */
/* Evaluation on doubles                                                */

static int all_finite(const double *z, int n)
{
  /* Exponent bits all ones = inf or NaN; integer test so it vectorizes. */
  uint64_t bad = 0;
  for (int i = 0; i < n; i++) {
    uint64_t u;
    memcpy(&u, &z[i], sizeof u);
    bad |= (~u & 0x7ff0000000000000ULL) == 0;
  }
  return !bad;
}

/* The first non-finite computed slot before i, or -1. */
static int first_nonfinite(const double *z, int i)
{
  for (int j = 0; j < i; j++)
    if (!isfinite(z[j])) return j;
  return -1;
}

nz_status nz_graph_eval(nz_graph_plan *p, const double *in, double *out)
{
  double *v = p->vals, *z = v + p->base;
  const grec *r = p->recs;
  const double *pv = p->pv;
  int i, nr = p->nrec;
  nz_status st = NZ_OK;
  p->fail_node = -1;
  if (p->bad_const >= 0) return plan_fail(p, p->bad_const, d_finite(v[p->bad_const]), v[p->bad_const]);
  for (i = 0; i < p->nin; i++) v[i] = in[p->in_num[i]];
  /* The hot loop: one dispatch per run, no finiteness test per node (one
   * pass after it). */
  i = 0;
  for (int q = 0; q < p->nrun; q++) {
    int e = p->runs[q].end;
    switch (p->runs[q].op) {
    case R_ADD: for (; i < e; i++) z[i] = v[r[i].a] + v[r[i].b]; break;
    case R_SUB: for (; i < e; i++) z[i] = v[r[i].a] - v[r[i].b]; break;
    case R_MUL: for (; i < e; i++) z[i] = v[r[i].a] * v[r[i].b]; break;
    case R_DIV:
      for (; i < e; i++) {
        double y = v[r[i].b];
        if (y == 0.0) { st = NZ_EZERODIV; goto failed; }
        z[i] = v[r[i].a] / y;
      }
      break;
    case R_NEG: for (; i < e; i++) z[i] = -v[r[i].a]; break;
    case R_SQR: for (; i < e; i++) { double x = v[r[i].a]; z[i] = x * x; } break;
    case R_CUBE: for (; i < e; i++) { double x = v[r[i].a]; z[i] = x * x * x; } break;
    case R_POWI: for (; i < e; i++) z[i] = d_powi(v[r[i].a], (unsigned)r[i].k); break;
    case R_POWC:
      for (; i < e; i++)
        if ((st = d_powc(v[r[i].a], pv[i], &z[i]))) goto failed;
      break;
    case R_POW:
      for (; i < e; i++)
        if ((st = d_pow(v[r[i].a], v[r[i].b], &z[i]))) goto failed;
      break;
    case R_FN:
      for (; i < e; i++)
        if ((st = d_fn(r[i].k, v[r[i].a], &z[i]))) goto failed;
      break;
    case R_ATAN2: for (; i < e; i++) z[i] = atan2(v[r[i].a], v[r[i].b]); break;
    case R_HYPOT: for (; i < e; i++) z[i] = d_hypot(v[r[i].a], v[r[i].b]); break;
    case R_CMP:
      for (; i < e; i++)
        if ((st = d_cmp(r[i].k, v[r[i].a], v[r[i].b], &z[i]))) goto failed;
      break;
    case R_SELECT:   /* a NaN condition (an input, say) fails as nz_jet_select */
      for (; i < e; i++) {
        double c = v[r[i].k];
        if (isnan(c)) { st = NZ_ENAN; goto failed; }
        z[i] = c != 0.0 ? v[r[i].a] : v[r[i].b];
      }
      break;
    default: st = NZ_EDOM; goto failed;
    }
  }
  if (!all_finite(z, nr)) {
    int j = first_nonfinite(z, nr);
    return plan_fail(p, p->base + j, d_finite(z[j]), v[r[j].a]);
  }
  for (int o = 0; o < p->nout; o++) out[o] = v[p->out_slot[o]];
  return NZ_OK;

failed: {
    /* An earlier node that overflowed or gave NaN failed first. */
    int j = first_nonfinite(z, i);
    if (j >= 0) return plan_fail(p, p->base + j, d_finite(z[j]), v[r[j].a]);
    return plan_fail(p, p->base + i, st, v[r[i].a]);
  }
}

/* ------------------------------------------------------------------ */
/* Evaluation on jets                                                   */

/* |x| = sign(x0) x, as nz_jet_apply (whose nz_jet_scale needs equal shapes). */
static nz_status jet_abs(nz_jet *z, const nz_jet *x)
{
  double x0 = x->c[0];
  if (x0 == 0.0 && (z->order >= 1 || z->ntan >= 1)) return NZ_ESING;
  return nz_jet_affine(z, x, x0 < 0.0 ? -1.0 : 1.0, 0.0);
}

static int is_const_slot(const nz_graph_plan *p, int s) { return s >= p->nin && s < p->base; }

/* The value jet of computed record jr into z. */
static nz_status jet_value(nz_graph_plan *p, const jrec *jr, nz_jet *z)
{
  const nz_jet *A = p->J[jr->a], *B = p->J[jr->b];
  int ca = is_const_slot(p, jr->a), cb = is_const_slot(p, jr->b);
  double *w = p->w;
  switch (jr->op) {
  case NZ_GOP_ADD: return nz_jet_add(z, A, B);
  case NZ_GOP_SUB: return nz_jet_sub(z, A, B);
  case NZ_GOP_MUL:
    if (ca) return nz_jet_affine(z, B, p->vals[jr->a], 0.0);
    if (cb) return nz_jet_affine(z, A, p->vals[jr->b], 0.0);
    return nz_jet_mul(z, A, B, w);
  case NZ_GOP_DIV:
    if (cb) return nz_jet_div_const(z, A, p->vals[jr->b]);
    return nz_jet_div(z, A, B, w);
  case NZ_GOP_NEG: return nz_jet_affine(z, A, -1.0, 0.0);
  case NZ_GOP_POWC: return nz_jet_pow(z, A, jr->v, w);
  case NZ_GOP_POW: return nz_jet_pow_jet(z, A, B, w);
  case NZ_GOP_FN:
    if (jr->fn == NZ_FN_ABS) return jet_abs(z, A);
    return nz_jet_apply(z, (nz_jet_fn)jr->fn, A, w);
  case NZ_GOP_ATAN2: return nz_jet_atan2(z, A, B, w);
  case NZ_GOP_HYPOT: return nz_jet_hypot(z, A, B, w);
  case NZ_GOP_CMP: return nz_jet_compare(z, (nz_cmp)jr->fn, A, B);
  case NZ_GOP_SELECT: return nz_jet_select(z, p->J[jr->c], A, B);
  default: return NZ_EDOM;
  }
}

/* The jets' eta rule of each operation (CONST, INPUT and CMP have none). */
static const nz_eta_op gop_eta[NZ_GOP_COUNT] = {
  [NZ_GOP_ADD] = NZ_ETA_ADD, [NZ_GOP_SUB] = NZ_ETA_SUB, [NZ_GOP_MUL] = NZ_ETA_MUL,
  [NZ_GOP_DIV] = NZ_ETA_DIV, [NZ_GOP_NEG] = NZ_ETA_NEG, [NZ_GOP_POWC] = NZ_ETA_POWC,
  [NZ_GOP_POW] = NZ_ETA_POW, [NZ_GOP_FN] = NZ_ETA_FN, [NZ_GOP_ATAN2] = NZ_ETA_ATAN2,
  [NZ_GOP_HYPOT] = NZ_ETA_HYPOT,
};

/* The eta-part of computed slot s into Ez, by the rules of d_rule on jets
 * (jets/jet_eta.c); a constant slot scales or divides by its value. */
static nz_status jet_eta(nz_graph_plan *p, int s, const jrec *jr, nz_jet *Ez)
{
  const nz_jet *dA = p->E[jr->a], *dB = unary_op(jr->op) ? NULL : p->E[jr->b];
  if (jr->op == NZ_GOP_SELECT) {   /* the eta-part of the branch taken (NULL: zero) */
    nz_jet_copy_fit(Ez, p->J[jr->c]->c[0] != 0.0 ? dA : dB);
    return NZ_OK;
  }
  nz_eta_args x = { gop_eta[jr->op], (nz_jet_fn)jr->fn, jr->v, p->J[jr->a], p->J[jr->b], p->J[s],
                    dA, dB, is_const_slot(p, jr->a), is_const_slot(p, jr->b) };
  return nz_jet_eta(Ez, &x, p->T, p->w);
}

static size_t jet_doubles(int order, int ntan)
{
  size_t hdr = (sizeof(nz_jet) + sizeof(double) - 1) / sizeof(double);
  return hdr + ((size_t)order + 1) * ((size_t)ntan + 1);
}

/* Place a jet of this shape at *at (a cursor in the arena). */
static nz_jet *place(double **at, int order, int ntan)
{
  nz_jet *z = (nz_jet *)(void *)*at;
  z->order = order;
  z->ntan = ntan;
  *at += jet_doubles(order, ntan);
  return z;
}


/* Shapes of this call: inputs as given, constants of the highest order with
 * no tangents (exact to every order), a computed node the lowest order of its
 * non-constant operands and the most tangents; the eta-part likewise, over
 * the operands whose eta-part is not zero.  Returns the arena length. */
static size_t plan_shapes(nz_graph_plan *p, int eta, int Kmax, int *Dmax)
{
  size_t len = 0;
  for (int s = p->nin; s < p->base; s++) {
    p->ord[s] = Kmax;
    p->ntn[s] = 0;
    p->eord[s] = -1;
    len += jet_doubles(Kmax, 0);
  }
  for (int i = 0; i < p->nrec; i++) {
    const jrec *jr = &p->jrecs[i];
    int s = p->base + i, a = jr->a, b = jr->b, ka = !is_const_slot(p, a), kb = !is_const_slot(p, b);
    int o = ka && kb ? imin(p->ord[a], p->ord[b]) : ka ? p->ord[a] : kb ? p->ord[b] : Kmax;
    /* A step (cmp, sign) is a constant series with no eta-part; its
     * tangents are zeros in the operands' shape, as the jets make it (the
     * shape says whether a function after it wants derivatives: sqrt of
     * gt(x, 0) at 0 refuses as in Lua). */
    int step = jr->op == NZ_GOP_CMP || (jr->op == NZ_GOP_FN && jr->fn == NZ_FN_SIGN);
    p->ord[s] = o;
    p->ntn[s] = imax(p->ntn[a], p->ntn[b]);
    len += jet_doubles(o, p->ntn[s]);
    p->eord[s] = -1;
    if (!eta || step) continue;
    int ea = p->eord[a] >= 0, eb = !unary_op(jr->op) && p->eord[b] >= 0;
    if (!ea && !eb) continue;
    p->eord[s] = imin(o, imin(ea ? p->eord[a] : o, eb ? p->eord[b] : o));
    p->entn[s] = imax(p->ntn[s], imax(ea ? p->entn[a] : 0, eb ? p->entn[b] : 0));
    len += jet_doubles(p->eord[s], p->entn[s]);
    *Dmax = imax(*Dmax, p->entn[s]);
  }
  return len;
}

nz_status nz_graph_eval_jets(nz_graph_plan *p, const nz_jet *const *in, nz_jet *const *out,
                             const nz_jet *const *din, nz_jet *const *dout)
{
  int eta = din != NULL && dout != NULL, Kmax = -1, Dmax = 0;
  p->fail_node = -1;
  if (p->bad_const >= 0) return plan_fail(p, p->bad_const, d_finite(p->vals[p->bad_const]), p->vals[p->bad_const]);
  for (int s = 0; s < p->nin; s++) {
    const nz_jet *x = in ? in[p->in_num[s]] : NULL;
    if (!x) return plan_fail(p, s, NZ_EDOM, NAN);   /* a used input has no jet */
    p->J[s] = x;
    p->ord[s] = x->order;
    p->ntn[s] = x->ntan;
    Kmax = imax(Kmax, x->order);
    Dmax = imax(Dmax, x->ntan);
    const nz_jet *e = eta ? din[p->in_num[s]] : NULL;
    p->E[s] = e;
    p->eord[s] = e ? e->order : -1;
    if (e) {
      p->entn[s] = e->ntan;
      Dmax = imax(Dmax, e->ntan);
    }
  }
  if (Kmax < 0)   /* no inputs: constant expressions, to the outputs' order */
    for (int r = 0; r < p->nout; r++) Kmax = imax(Kmax, out[r]->order);
  if (Kmax < 0) Kmax = 0;
  size_t len = plan_shapes(p, eta, Kmax, &Dmax);
  len += NTEMP * jet_doubles(Kmax, Dmax) + nz_jet_work_len(Kmax);
  if (len > p->arena_len) {
    free(p->arena);
    p->arena = malloc(len * sizeof(double));
    p->arena_len = p->arena ? len : 0;
    if (!p->arena) return NZ_ENOMEM;
  }
  /* Lay the jets out (no allocation from here on). */
  double *at = p->arena;
  for (int s = p->nin; s < p->base; s++) {
    nz_jet *c = place(&at, Kmax, 0);
    nz_jet_set_constant(c, p->vals[s]);
    p->J[s] = c;
    p->E[s] = NULL;
  }
  for (int s = p->base; s < p->m; s++) {
    p->W[s] = place(&at, p->ord[s], p->ntn[s]);
    p->J[s] = p->W[s];
    p->EW[s] = p->eord[s] >= 0 ? place(&at, p->eord[s], p->entn[s]) : NULL;
    p->E[s] = NULL;   /* set once computed */
  }
  for (int i = 0; i < NTEMP; i++) p->T[i] = place(&at, Kmax, Dmax);
  p->w = at;
  /* Evaluate node by node. */
  for (int i = 0; i < p->nrec; i++) {
    const jrec *jr = &p->jrecs[i];
    int s = p->base + i;
    nz_status st = jet_value(p, jr, p->W[s]);
    if (!st && p->EW[s]) {
      st = jet_eta(p, s, jr, p->EW[s]);
      p->E[s] = p->EW[s];
    }
    if (st) return plan_fail(p, s, st, p->J[jr->a]->c[0]);
  }
  for (int r = 0; r < p->nout; r++) {
    nz_jet_copy_fit(out[r], p->J[p->out_slot[r]]);
    if (eta) nz_jet_copy_fit(dout[r], p->E[p->out_slot[r]]);
  }
  return NZ_OK;
}

/* ------------------------------------------------------------------ */
/* Series built order by order                                          */

/* The series kernels of a computed slot (graph_series.h) are chosen at
 * begin once coefficient 0 is known (a select's branch, the sign of abs, a
 * constant factor). */

/* One computed slot: z = its series, a and b its operands' (b = a for unary
 * ops; a = the chosen operand for NZ_SK_COPY), aux its auxiliary series; v a
 * constant factor (NZ_SK_SCALE: also -1 for neg, +-1 for abs), divisor (NZ_SK_DIVC),
 * exponent (NZ_SK_POWR) or scale (NZ_SK_HYPOT); n the exponent of NZ_SK_POWI. */
typedef struct srec {
  int op;
  unsigned n;
  const double *a, *b;
  double *z, *aux;
  double v;
} srec;

/* Auxiliary series a graph node needs (an upper bound over the kernels
 * begin may choose for it). */
static int series_aux_count(const jrec *jr)
{
  switch (jr->op) {
  case NZ_GOP_POWC:
    return jr->v > 0.0 && is_small_integer(jr->v) ? nz_series_powi_work((unsigned)jr->v) : 0;
  case NZ_GOP_POW: return 2;      /* log x, y log x */
  case NZ_GOP_ATAN2: return 1;    /* x^2 + y^2 */
  case NZ_GOP_HYPOT: return 4;    /* a/s, b/s, (a/s)^2 + (b/s)^2, its root */
  case NZ_GOP_FN:
    switch (jr->fn) {
    case NZ_FN_SIN: case NZ_FN_COS: case NZ_FN_SINH: case NZ_FN_COSH:
    case NZ_FN_TAN: case NZ_FN_TANH: case NZ_FN_ATAN:
      return 1;                   /* the companion, 1 +- t^2, 1 + x^2 */
    case NZ_FN_ASIN: case NZ_FN_ACOS:
      return 2;                   /* 1 - x^2, its root */
    default: return 0;
    }
  default: return 0;
  }
}

/* The layout (once per plan) and storage for order K (grown, never shrunk). */
static nz_status series_storage(nz_graph_plan *p, int K)
{
  if (p->ser_naux < 0) {
    int top = 0;
    size_t nr = (size_t)p->nrec + 1;
    for (int s = 0; s < p->m; s++) top = imax(top, p->ids[s]);
    p->ser_aux = malloc(nr * sizeof *p->ser_aux);
    p->srecs = malloc(nr * sizeof *p->srecs);
    p->sruns = malloc(nr * sizeof *p->sruns);
    p->ser_map = malloc(((size_t)top + 1) * sizeof *p->ser_map);
    p->ser_v = malloc(nr * sizeof *p->ser_v);
    if (!p->ser_aux || !p->srecs || !p->sruns || !p->ser_map || !p->ser_v) {   /* as if never tried */
      free(p->ser_aux);
      free(p->srecs);
      free(p->sruns);
      free(p->ser_map);
      free(p->ser_v);
      p->ser_aux = NULL;
      p->srecs = NULL;
      p->sruns = NULL;
      p->ser_map = NULL;
      p->ser_v = NULL;
      return NZ_ENOMEM;
    }
    int naux = 0;
    for (int i = 0; i < p->nrec; i++) {
      p->ser_aux[i] = naux;
      naux += series_aux_count(&p->jrecs[i]);
    }
    for (int id = 0; id <= top; id++) p->ser_map[id] = -1;
    for (int s = 0; s < p->m; s++) p->ser_map[p->ids[s]] = s;
    p->ser_top = top;
    p->ser_naux = naux;
  }
  if (K > p->ser_cap) {
    /* at least NZ_SERIES_MIN_ORDER: the same stride for every order up to
     * it, which machine code takes as a constant */
    if (K < NZ_SERIES_MIN_ORDER) K = NZ_SERIES_MIN_ORDER;
    size_t len = ((size_t)p->m + (size_t)p->ser_naux) * ((size_t)K + 1);
    double *ser = malloc((len ? len : 1) * sizeof *ser);
    if (!ser) return NZ_ENOMEM;
    free(p->ser);
    p->ser = ser;
    p->ser_cap = K;
  }
  return NZ_OK;
}

static double *series_of(const nz_graph_plan *p, int s)
{
  return p->ser + (size_t)s * ((size_t)p->ser_cap + 1);
}

/* Coefficient 0 of computed slot s = base + i, with the jets' domain checks
 * for order K (smooth: K >= 1 asks for derivatives), and its kernel. */
static nz_status series_first(nz_graph_plan *p, int i, int K)
{
  const jrec *jr = &p->jrecs[i];
  srec *r = &p->srecs[i];
  int s = p->base + i, smooth = K >= 1;
  double *z = series_of(p, s);
  const double *A = series_of(p, jr->a), *B = series_of(p, jr->b);
  double x = A[0], y = B[0];
  int ca = is_const_slot(p, jr->a), cb = is_const_slot(p, jr->b);
  double *aux = p->ser + ((size_t)p->m + (size_t)p->ser_aux[i]) * ((size_t)p->ser_cap + 1);
  *r = (srec){ NZ_SK_COPY, 0, A, B, z, aux, 0.0 };
  switch (jr->op) {
  case NZ_GOP_ADD: r->op = NZ_SK_ADD; break;
  case NZ_GOP_SUB: r->op = NZ_SK_SUB; break;
  case NZ_GOP_NEG: r->op = NZ_SK_SCALE; r->v = -1.0; break;
  case NZ_GOP_MUL:   /* a constant factor scales, as nz_jet_affine in the jets */
    if (ca || cb) {
      r->op = NZ_SK_SCALE;
      r->v = ca ? x : y;
      r->a = ca ? B : A;
    } else r->op = NZ_SK_MUL;
    break;
  case NZ_GOP_DIV:
    if (y == 0.0) return NZ_EZERODIV;
    r->op = cb ? NZ_SK_DIVC : NZ_SK_DIV;
    r->v = y;
    break;
  case NZ_GOP_POWC: {
    double pw = jr->v;
    int integer = is_small_integer(pw);
    if (pw == 0.0) { r->op = NZ_SK_STEP; z[0] = 1.0; return NZ_OK; }
    if (integer && pw > 0.0) {
      r->n = (unsigned)pw;
      r->op = r->n == 1 ? NZ_SK_COPY : r->n == 2 ? NZ_SK_SQR : NZ_SK_POWI;
      break;
    }
    if (x == 0.0) {   /* nz_jet_pow's order of checks */
      if (integer || (!smooth && pw < 0.0)) return NZ_EZERODIV;
      if (smooth) return NZ_ESING;
      r->op = NZ_SK_STEP;
      z[0] = 0.0;
      return NZ_OK;
    }
    if (x < 0.0 && !integer) return NZ_EDOM;
    r->op = NZ_SK_POWR;
    r->v = pw;
    break;
  }
  case NZ_GOP_POW:
    if (x < 0.0) return NZ_EDOM;
    if (x == 0.0) return NZ_ESING;
    r->op = NZ_SK_POW;
    break;
  case NZ_GOP_ATAN2:
    if (x == 0.0 && y == 0.0 && smooth) return NZ_ESING;
    r->op = NZ_SK_ATAN2;
    break;
  case NZ_GOP_HYPOT:
    r->v = fmax(fabs(x), fabs(y));
    if (r->v == 0.0) {
      if (smooth) return NZ_ESING;
      r->op = NZ_SK_STEP;
      z[0] = 0.0;
      return NZ_OK;
    }
    r->op = NZ_SK_HYPOT;
    break;
  case NZ_GOP_CMP: {
    nz_status st = d_cmp(jr->fn, x, y, &z[0]);
    if (st) return st;
    p->ser_ties += smooth && x == y;
    r->op = NZ_SK_STEP;
    return NZ_OK;
  }
  case NZ_GOP_SELECT: {
    double c = series_of(p, jr->c)[0];
    if (isnan(c)) return NZ_ENAN;
    r->a = c != 0.0 ? A : B;
    r->op = NZ_SK_COPY;
    break;
  }
  case NZ_GOP_FN:
    switch (jr->fn) {
    case NZ_FN_EXP: r->op = NZ_SK_EXP; break;
    case NZ_FN_LOG:
      if (!(x > 0.0)) return NZ_EDOM;
      r->op = NZ_SK_LOG;
      break;
    case NZ_FN_SQRT:
      if (x < 0.0) return NZ_EDOM;
      if (x == 0.0 && smooth) return NZ_ESING;
      r->op = NZ_SK_SQRT;
      break;
    case NZ_FN_SIN: r->op = NZ_SK_SIN; break;
    case NZ_FN_COS: r->op = NZ_SK_COS; break;
    case NZ_FN_SINH: r->op = NZ_SK_SINH; break;
    case NZ_FN_COSH: r->op = NZ_SK_COSH; break;
    case NZ_FN_TAN: r->op = NZ_SK_TAN; break;
    case NZ_FN_TANH: r->op = NZ_SK_TANH; break;
    case NZ_FN_ATAN: r->op = NZ_SK_ATAN; break;
    case NZ_FN_ASIN:
    case NZ_FN_ACOS:
      if (fabs(x) > 1.0) return NZ_EDOM;
      if (fabs(x) == 1.0 && smooth) return NZ_ESING;
      r->op = jr->fn == NZ_FN_ASIN ? NZ_SK_ASIN : NZ_SK_ACOS;
      break;
    case NZ_FN_ABS:
      if (x == 0.0 && smooth) return NZ_ESING;
      r->op = NZ_SK_SCALE;
      r->v = x < 0.0 ? -1.0 : 1.0;
      break;
    case NZ_FN_SIGN:
      if (isnan(x)) return NZ_ENAN;
      z[0] = (double)((x > 0.0) - (x < 0.0));
      p->ser_ties += smooth && x == 0.0;
      r->op = NZ_SK_STEP;
      return NZ_OK;
    default: return NZ_EDOM;
    }
    break;
  default: return NZ_EDOM;
  }
  return NZ_OK;
}

/* Coefficient k of r's series: the recurrences of jet.c, one coefficient at
 * a time (K: the storage's order, the stride of the auxiliary series). */
static inline void series_coef(const srec *r, int op, int k, int K)
{
  const double *a = r->a, *b = r->b;
  double *z = r->z, *w = r->aux, *w1 = w + K + 1, *w2 = w1 + K + 1, *w3 = w2 + K + 1;
  switch (op) {
  case NZ_SK_ADD: z[k] = a[k] + b[k]; break;
  case NZ_SK_SUB: z[k] = a[k] - b[k]; break;
  case NZ_SK_MUL: z[k] = nz_series_mul_coef(a, b, k); break;
  case NZ_SK_SCALE: z[k] = r->v * a[k]; break;
  case NZ_SK_DIV: z[k] = nz_series_div_coef(z, a, b, k); break;
  case NZ_SK_DIVC: z[k] = a[k] / r->v; break;
  case NZ_SK_SQR: z[k] = nz_series_mul_coef(a, a, k); break;
  case NZ_SK_POWI: z[k] = nz_series_powi_coef(w, a, r->n, k, K); break;
  case NZ_SK_POWR: z[k] = nz_series_pow_coef(z, a, r->v, k); break;
  case NZ_SK_POW:   /* exp(y log x) */
    w[k] = nz_series_log_coef(w, a, k);
    w1[k] = nz_series_mul_coef(b, w, k);
    z[k] = nz_series_exp_coef(z, w1, k);
    break;
  case NZ_SK_EXP: z[k] = nz_series_exp_coef(z, a, k); break;
  case NZ_SK_LOG: z[k] = nz_series_log_coef(z, a, k); break;
  case NZ_SK_SQRT: z[k] = nz_series_sqrt_coef(z, a, k); break;
  case NZ_SK_SIN: nz_series_sincos_coef(z, w, a, k, 0); break;
  case NZ_SK_COS: nz_series_sincos_coef(w, z, a, k, 0); break;
  case NZ_SK_SINH: nz_series_sincos_coef(z, w, a, k, 1); break;
  case NZ_SK_COSH: nz_series_sincos_coef(w, z, a, k, 1); break;
  case NZ_SK_TAN: nz_series_tan_coef(z, w, a, k, 0); break;
  case NZ_SK_TANH: nz_series_tan_coef(z, w, a, k, 1); break;
  case NZ_SK_ATAN:   /* y' (1 + x^2) = x' */
    w[k] = nz_series_mul_coef(a, a, k);
    if (k == 0) {
      w[0] += 1.0;
      z[0] = atan(a[0]);
    } else z[k] = nz_series_quadrature_coef(z, a, w, 1.0, k);
    break;
  case NZ_SK_ASIN:
  case NZ_SK_ACOS:   /* y' sqrt(1 - x^2) = +-x' */
    w[k] = -nz_series_mul_coef(a, a, k);
    if (k == 0) w[0] += 1.0;
    w1[k] = nz_series_sqrt_coef(w1, w, k);
    if (k == 0) z[0] = op == NZ_SK_ASIN ? asin(a[0]) : acos(a[0]);
    else z[k] = nz_series_quadrature_coef(z, a, w1, op == NZ_SK_ASIN ? 1.0 : -1.0, k);
    break;
  case NZ_SK_ATAN2:
    w[k] = nz_series_mul_coef(b, b, k) + nz_series_mul_coef(a, a, k);
    z[k] = nz_series_atan2_coef(z, a, b, w, k);
    break;
  case NZ_SK_HYPOT:   /* s sqrt((a/s)^2 + (b/s)^2), s = max(|a_0|, |b_0|) */
    w[k] = a[k] / r->v;
    w1[k] = b[k] / r->v;
    w2[k] = nz_series_mul_coef(w, w, k) + nz_series_mul_coef(w1, w1, k);
    w3[k] = nz_series_sqrt_coef(w3, w2, k);
    z[k] = w3[k] * r->v;
    break;
  case NZ_SK_STEP: if (k > 0) z[k] = 0.0; break;
  case NZ_SK_COPY: z[k] = a[k]; break;
  default: z[k] = NAN; break;
  }
}

/* Coefficient k of the inputs (NULL in: a used input without a value). */
static nz_status series_inputs(nz_graph_plan *p, const double *in, int k)
{
  for (int s = 0; s < p->nin; s++) {
    if (!in) return plan_fail(p, s, NZ_EDOM, NAN);
    series_of(p, s)[k] = in[p->in_num[s]];
  }
  return NZ_OK;
}

void nz_graph_series_inputs(nz_graph_plan *p, double **ptr, int n)
{
  for (int i = 0; i < n; i++) ptr[i] = NULL;
  if (p->ser_k < 0) return;
  for (int s = 0; s < p->nin; s++)
    if (p->in_num[s] < n) ptr[p->in_num[s]] = series_of(p, s);
}

/* Begin's work after the inputs and constants: each computed slot's
 * kernel and coefficient 0, with the jets' domain checks for order K. */
static nz_status series_first_all(nz_graph_plan *p, int K)
{
  nz_status st;
  for (int i = 0; i < p->nrec; i++) {
    int s = p->base + i;
    double *z = series_of(p, s);
    st = series_first(p, i, K);
    if (!st && p->srecs[i].op != NZ_SK_STEP) {
      series_coef(&p->srecs[i], p->srecs[i].op, 0, p->ser_cap);
      st = d_finite(z[0]);
    }
    if (st) return plan_fail(p, s, st, series_of(p, p->jrecs[i].a)[0]);
  }
  /* Runs of one kernel (the plan's schedule groups a level's nodes by
   * opcode): one dispatch per run in nz_graph_series_next.  The signature
   * (FNV-1a of the kernels) tells machine code made for another choice of
   * kernels (a select's other branch) from the one for this begin. */
  p->nsrun = 0;
  unsigned long sig = 0xcbf29ce484222325UL;
  for (int i = 0; i < p->nrec; i++) {
    if (p->nsrun == 0 || p->sruns[p->nsrun - 1].op != p->srecs[i].op)
      p->sruns[p->nsrun++].op = p->srecs[i].op;
    p->sruns[p->nsrun - 1].end = i + 1;
    p->ser_v[i] = p->srecs[i].v;
    sig = (sig ^ (unsigned long)p->srecs[i].op) * 0x100000001b3UL;
  }
  p->ser_sig = sig | 1;   /* never 0 */
  p->ser_k = 0;
  return NZ_OK;
}

/* Machine code applies: attached, made for the kernels of the last
 * interpreted begin, and that begin's kernels (and their pointers into
 * the storage) still stand.  Only for series of order >= 1: with order 0
 * a begin may choose other kernels (x^p at x = 0 is then a constant). */
static int series_code_ok(const nz_graph_plan *p)
{
  return p->ser_code && p->ser_code_sig == p->ser_sig && p->ser_K >= 1;
}

nz_status nz_graph_series_begin(nz_graph_plan *p, int max_order, const double *in0)
{
  nz_status st;
  p->fail_node = -1;
  p->ser_k = -1;
  p->ser_ties = 0;
  if (max_order < 0 || max_order > NZ_JET_MAX_ORDER) return NZ_EDOM;
  if (p->bad_const >= 0)
    return plan_fail(p, p->bad_const, d_finite(p->vals[p->bad_const]), p->vals[p->bad_const]);
  const double *old = p->ser;
  if ((st = series_storage(p, max_order))) return st;
  if (p->ser != old) p->ser_sig = 0;   /* the kernels point into the old storage */
  p->ser_K = max_order;
  if ((st = series_inputs(p, in0, 0))) return st;
  for (int s = p->nin; s < p->base; s++) {   /* constants: exact to every order */
    double *c = series_of(p, s);
    c[0] = p->vals[s];
    for (int k = 1; k <= max_order; k++) c[k] = 0.0;
  }
  /* Machine code makes coefficient 0 with the same checks (series_native.c);
   * on a refusal the interpreter begins again and says why. */
  if (series_code_ok(p) && p->ser_code(0, p->ser_cap + 1, p->ser, p->ser_v, p->ser_kfn) == 0) {
    p->ser_k = 0;
    return NZ_OK;
  }
  return series_first_all(p, max_order);
}

/* Coefficient k of every computed slot by the interpreter, the inputs'
 * coefficient k in place. */
static nz_status series_next_interp(nz_graph_plan *p, int k)
{
  int K = p->ser_cap, i = 0;
  const srec *R = p->srecs;
  /* One dispatch per run; series_coef is inlined with a constant kernel. */
#define RUN(OP) case OP: for (; i < e; i++) series_coef(&R[i], OP, k, K); break;
  for (int q = 0; q < p->nsrun; q++) {
    int e = p->sruns[q].end;
    switch (p->sruns[q].op) {
      RUN(NZ_SK_ADD) RUN(NZ_SK_SUB) RUN(NZ_SK_MUL) RUN(NZ_SK_SCALE) RUN(NZ_SK_DIV) RUN(NZ_SK_DIVC) RUN(NZ_SK_SQR)
      RUN(NZ_SK_POWI) RUN(NZ_SK_POWR) RUN(NZ_SK_POW) RUN(NZ_SK_EXP) RUN(NZ_SK_LOG) RUN(NZ_SK_SQRT) RUN(NZ_SK_SIN)
      RUN(NZ_SK_COS) RUN(NZ_SK_SINH) RUN(NZ_SK_COSH) RUN(NZ_SK_TAN) RUN(NZ_SK_TANH) RUN(NZ_SK_ATAN) RUN(NZ_SK_ASIN)
      RUN(NZ_SK_ACOS) RUN(NZ_SK_ATAN2) RUN(NZ_SK_HYPOT) RUN(NZ_SK_STEP) RUN(NZ_SK_COPY)
    default: for (; i < e; i++) R[i].z[k] = NAN; break;
    }
  }
#undef RUN
  /* The first non-finite coefficient in slot order: where it appeared (a
   * NaN or an infinity flows into the later nodes). */
  for (i = 0; i < p->nrec; i++)
    if (!isfinite(R[i].z[k]))
      return plan_fail(p, p->base + i, d_finite(R[i].z[k]), series_of(p, p->jrecs[i].a)[0]);
  p->ser_k = k;
  return NZ_OK;
}

nz_status nz_graph_series_next(nz_graph_plan *p, int k, const double *in_k, double *out_k)
{
  nz_status st;
  p->fail_node = -1;
  if (p->ser_k < 0 || k < 1 || k > p->ser_k + 1 || k > p->ser_K) return NZ_EDOM;
  p->ser_k = k - 1;   /* coefficient k, if it was filled, is being replaced */
  if (in_k && (st = series_inputs(p, in_k, k))) return st;
  if (series_code_ok(p)) {
    /* Machine code for these kernels: when every coefficient it made is
     * finite, they are the interpreter's.  Otherwise the interpreter
     * begins again from the inputs in place and redoes coefficients 1..k
     * (its begin may have been the machine code's), to name the node. */
    if (p->ser_code(k, p->ser_cap + 1, p->ser, p->ser_v, p->ser_kfn) == 0) {
      p->ser_k = k;
      goto done;
    }
    if ((st = series_first_all(p, p->ser_K))) return st;
    for (int j = 1; j < k; j++)
      if ((st = series_next_interp(p, j))) return st;
  }
  if ((st = series_next_interp(p, k))) return st;
done:
  if (out_k)
    for (int o = 0; o < p->nout; o++) out_k[o] = series_of(p, p->out_slot[o])[k];
  return NZ_OK;
}

int nz_graph_series_order(const nz_graph_plan *p) { return p->ser_k; }

int nz_graph_series_ties(const nz_graph_plan *p) { return p->ser_ties; }

double nz_graph_series_coef(const nz_graph_plan *p, int r, int j)
{
  if (r < 0 || r >= p->nout || j < 0 || j > p->ser_k) return NAN;
  return series_of(p, p->out_slot[r])[j];
}

const double *nz_graph_series_node(const nz_graph_plan *p, int node)
{
  if (p->ser_k < 0 || node < 0 || node > p->ser_top) return NULL;
  int s = p->ser_map[node];
  return s < 0 ? NULL : series_of(p, s);
}

int nz_graph_series_layout(const nz_graph_plan *p, nz_series_slot *slots, int *nseries)
{
  if (p->ser_k < 0 || !p->srecs) return -1;
  size_t L = (size_t)p->ser_cap + 1;
  *nseries = p->m + p->ser_naux;
  if (slots)
    for (int i = 0; i < p->nrec; i++) {
      const srec *r = &p->srecs[i];
      const jrec *jr = &p->jrecs[i];
      slots[i] = (nz_series_slot){
        .kernel = r->op, .gop = jr->op, .fn = jr->fn,
        .z = (int)((size_t)(r->z - p->ser) / L), .a = (int)((size_t)(r->a - p->ser) / L),
        .b = (int)((size_t)(r->b - p->ser) / L),
        .aux = p->m + p->ser_aux[i],
        .n = r->n, .v = r->v };
    }
  return p->nrec;
}

unsigned long nz_graph_series_signature(const nz_graph_plan *p) { return p->ser_k < 0 ? 0 : p->ser_sig; }

void nz_graph_series_use(nz_graph_plan *p, nz_series_code code, void (*const *K)(void), unsigned long sig)
{
  p->ser_code = code;
  p->ser_kfn = K;
  p->ser_code_sig = code ? sig : 0;
}

int nz_graph_series_input_slots(const nz_graph_plan *p, int *in_num)
{
  if (p->ser_k < 0) return -1;
  if (in_num)
    for (int s = 0; s < p->nin; s++) in_num[s] = p->in_num[s];
  return p->nin;
}

int nz_graph_series_output(const nz_graph_plan *p, int r) { return r >= 0 && r < p->nout ? p->out_slot[r] : -1; }

int nz_graph_series_loop(nz_graph_plan *p, nz_series_loop loop, void (*const *K)(void), unsigned long sig, int N,
                         double *a)
{
  if (p->ser_k < 0 || N < 0 || N > p->ser_K || sig != p->ser_sig || p->ser_K < 1) return -1;
  p->fail_node = -1;
  int rc = loop(N, p->ser_cap + 1, p->ser, p->ser_v, K, a);
  p->ser_k = rc ? 0 : N;   /* refused: coefficient 0 (begin's) still stands */
  return rc;
}
