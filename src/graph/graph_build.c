/* graph_build.c - expression graphs: building (folding, simplification,
 * hash-consing), forward differentiation on the graph, and plans evaluated on
 * doubles and on jets (see graph.h): this file builds; graph_diff.c
 * differentiates and copies, graph_plan.c plans and evaluates on doubles,
 * graph_jets.c on jets, graph_series.c order by order.
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
 * else the node stays, so that the graph fails where the function fails. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <limits.h>
#include "graph/graph_impl.h"

const char *const nz_gop_names[NZ_GOP_COUNT] = {
  "const", "input", "add", "sub", "mul", "div", "neg", "powc", "pow", "fn", "atan2", "hypot",
  "cmp", "select"
};

nz_status nz_graph_scalar(const nz_gnode *nd, double x, double y, double *z) { return scalar_op(nd, x, y, z); }

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

int nz_graph_is_const(const nz_graph *g, int x, double *v)
{
  if (!valid(g, x) || g->nodes[x].op != NZ_GOP_CONST) return 0;
  if (v) *v = g->nodes[x].v;
  return 1;
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

