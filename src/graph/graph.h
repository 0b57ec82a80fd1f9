/* graph.h - expression graphs recorded once from the user's functions and
 * evaluated in C.
 *
 * A graph is a list of nodes in topological order: a node refers only to
 * nodes with smaller ids.  Nodes are inputs (numbered by the recorder: t,
 * each derivative slot of each q_i, each named parameter), constants, and
 * the operations the jets support.  Building a node goes through one door
 * (nz_graph_node) that
 *   - folds constants (every operand constant -> a constant node, computed
 *     with the same jet kernels, so folding and evaluation agree bit for bit);
 *   - simplifies the identities that cost nothing to know: x + 0, x - 0,
 *     0 - x, x * 1, x * 0, x / 1, x ^ 1, x ^ 0, -(-x), select(c, a, a) = a,
 *     cmp(x, x);
 *   - gathers like terms, so that the graphs the mechanics differentiates
 *     do not grow with every product rule: with c, c1, c2 constants,
 *       (c1 x) + (c2 x) -> (c1 + c2) x,   x + x -> 2 x,   (c x) + x -> (c + 1) x,
 *       (c1 x) - (c2 x) -> (c1 - c2) x,   c1 (c2 x) -> (c1 c2) x,   -(c x) -> (-c) x,
 *       (c1 x)(c2 y) -> (c1 c2)(x y)   (constants move out of products).
 *     These are exact in real arithmetic, not in floating point: the result
 *     may differ from the unsimplified expression in the last bit (unlike
 *     folding, which is bit for bit).  Signs are normalized exactly (IEEE
 *     negation and a - b = a + (-b) are exact): a + (-b) -> a - b,
 *     (-a) + b -> b - a, a - (-b) -> a + b, a +- (c y) with c < 0 ->
 *     a -+ (|c| y), (-x) y -> -(x y), (-x)(-y) -> x y;
 *   - hash-conses: the same (op, fn, operands, constant) is the same node,
 *     with commutative operands (add, mul, hypot) put in a canonical order
 *     (not a product in an exact graph: see below).
 *
 *   - never drops a part that can fail: x * 0, x - x, x^0, cmp(x, x),
 *     select(c, a, a) and the branch a constant condition does not take go
 *     only when the part dropped is defined at every finite input
 *     (nz_graph_total), so that the graph fails where the function does
 *     (log(q) * 0 at q < 0), and the jets' refusals (abs at 0) stay.
 *
 * An exact graph (nz_graph_set_exact: the recorder turns it on while it runs
 * a user's function) is built as IEEE arithmetic computes the expression,
 * bit for bit, as Lua computes it on jets: no like terms gathered, no
 * constants moved (only the exact sign rules), x + 0, 0 - x and x * 0 kept
 * (the sign of a zero: atan2(-0, -1) = -pi), and a^b with an exponent that
 * folded to a constant stays a^b (the exponent is a jet in Lua, whose x^y
 * needs x > 0).  Derivatives are built without it: the mechanics' M, h and
 * rows are exact in real arithmetic only, as the jets' tangents are.
 *
 * Outputs are node ids the caller keeps; a plan (nz_graph_plan) is the list
 * of nodes some outputs need, with a workspace it owns and reuses: after the
 * first call of a given shape, evaluating allocates nothing.
 *
 * Plain C: never includes lua.h, never prints, never exits.  Functions return
 * an nz_status (jet.h); building returns a node id >= 0, or -1 when memory
 * ran out (the graph stays valid: at most some unused nodes were added). */
#ifndef NZ_GRAPH_H
#define NZ_GRAPH_H

#include <stddef.h>
#include <stdint.h>
#include "core/status.h"
#include "jets/jet.h"

typedef enum nz_gop {
  NZ_GOP_CONST,   /* v                                           */
  NZ_GOP_INPUT,   /* input number a                              */
  NZ_GOP_ADD,     /* a + b                                       */
  NZ_GOP_SUB,     /* a - b                                       */
  NZ_GOP_MUL,     /* a * b                                       */
  NZ_GOP_DIV,     /* a / b                                       */
  NZ_GOP_NEG,     /* -a                                          */
  NZ_GOP_POWC,    /* a ^ v, v a constant exponent                */
  NZ_GOP_POW,     /* a ^ b, b a node                             */
  NZ_GOP_FN,      /* fn(a), fn an nz_jet_fn                      */
  NZ_GOP_ATAN2,   /* atan2(a, b)                                 */
  NZ_GOP_HYPOT,   /* hypot(a, b)                                 */
  NZ_GOP_CMP,     /* 1 where a fn b holds else 0, fn an nz_cmp   */
  NZ_GOP_SELECT,  /* a where c != 0, else b                      */
  NZ_GOP_COUNT
} nz_gop;

extern const char *const nz_gop_names[NZ_GOP_COUNT];

typedef struct nz_gnode {
  uint8_t op;       /* nz_gop                                     */
  uint8_t fn;       /* nz_jet_fn for NZ_GOP_FN, nz_cmp for NZ_GOP_CMP */
  int32_t a, b;     /* operand node ids (-1 when unused); input number for INPUT */
  double v;         /* constant value (CONST) or exponent (POWC)  */
  int32_t c;        /* the condition of NZ_GOP_SELECT, else -1    */
} nz_gnode;

typedef struct nz_graph nz_graph;

nz_graph *nz_graph_new(void);             /* NULL if out of memory */
void nz_graph_free(nz_graph *g);          /* NULL is harmless */
int nz_graph_size(const nz_graph *g);     /* number of nodes */
const nz_gnode *nz_graph_nodes(const nz_graph *g);
/* The highest input number used, plus one. */
int nz_graph_ninputs(const nz_graph *g);

/* Building.  Every function returns the node id, or -1 (out of memory, or
 * an operand id that is not a node of g).  Constant folding that fails
 * (log(-1), 1/0) keeps the node unfolded: evaluation reports the error where
 * it happens, with the state. */
int nz_graph_const(nz_graph *g, double v);
int nz_graph_input(nz_graph *g, int input);
/* op is a binary op (ADD SUB MUL DIV POW ATAN2 HYPOT) or NEG (b ignored). */
int nz_graph_op(nz_graph *g, nz_gop op, int a, int b);
int nz_graph_fn(nz_graph *g, nz_jet_fn fn, int a);
int nz_graph_powc(nz_graph *g, int a, double p);
/* Branches without a Lua `if` (jet.h's nz_jet_compare, nz_jet_select).
 * cmp(op, a, b) is 1 where a op b holds, else 0; its derivative is 0 (a
 * step).  On jets of order >= 1 the comparison follows the branch rule of
 * jet.h (the value series compared lexicographically, so a tie in value is
 * decided by the first coefficient that differs); on doubles, and so in
 * nz_graph_eval, there are only values, and a tie is exact equality.
 * select(c, a, b) is a where c != 0, else b, the whole operand (its
 * derivatives too); with c constant it is that operand itself.  Both
 * operands are evaluated: select does not protect a failing branch
 * (select(x > 0, sqrt(x), 0) fails for x < 0, as nz.ifelse does in Lua).
 * NZ_FN_SIGN (nz_graph_fn) is -1, 0, +1 by the same rule, derivative 0. */
int nz_graph_cmp(nz_graph *g, nz_cmp op, int a, int b);
int nz_graph_select(nz_graph *g, int c, int a, int b);
/* The arithmetic of node nd on doubles, operands x and y (folding's and
 * the plans'; not NZ_GOP_SELECT, which chooses): NZ_OK or a jet status. */
nz_status nz_graph_scalar(const nz_gnode *nd, double x, double y, double *z);
/* Is node x the constant v? (for callers that simplify further) */
int nz_graph_is_const(const nz_graph *g, int x, double *v);
/* Is node x defined at every finite value of the inputs, in every
 * evaluator?  Sums, products, integer powers >= 0, division by a nonzero
 * constant, sin, cos, tan, atan, tanh, sign, cmp, select of such nodes are;
 * log, sqrt, a division by a node, other powers, abs, asin, acos, atan2,
 * hypot (domains and the jets' singular points), exp, sinh and cosh
 * (overflow) are not.  Sums and products overflow only past ~1e154. */
int nz_graph_total(const nz_graph *g, int x);
/* Build nodes as IEEE arithmetic computes them (on), or simplified (off,
 * the default; see above). */
void nz_graph_set_exact(nz_graph *g, int on);

/* Forward-mode differentiation that builds nodes in g: the derivative of
 * node `root` when each input i moves along dinput[i] (a node id, or -1 for
 * an input that does not move; dinput has nz_graph_ninputs(g) entries).
 * Returns the node of the derivative (a constant 0 node when nothing moves
 * it).  Builds through nz_graph_node, so the result is folded and shared.
 * d|x| is sign(x) dx (abs is differentiable away from 0, where the jets
 * refuse it too); d cmp = d sign = 0; d select(c, a, b) = select(c, da, db). */
int nz_graph_derivative(nz_graph *g, int root, const int *dinput);
/* The same for several roots at once, sharing the work: droots[r] receives
 * the derivative of roots[r].  0 or -1. */
int nz_graph_derivatives(nz_graph *g, const int *roots, int nroots, const int *dinput,
                         int *droots);

/* The nodes under roots[0..nroots-1] of src built again in dst, each input
 * i of src replaced by node input_map[i] of dst (input_map has
 * nz_graph_ninputs(src) entries; -1, or input_map NULL: the input of the
 * same number in dst): out[r] receives the copy of roots[r].  dst may be
 * src, which substitutes nodes for inputs (sys:show holds the velocity of
 * T still while q moves: docs/theory.md §4's T_0).  Built through dst's
 * door, so folded and simplified as dst's exact mode says: the same
 * expression, not always the same nodes.  0, or -1 (out of memory, a root
 * or a map entry that is not a node). */
int nz_graph_copy(nz_graph *dst, const nz_graph *src, const int *roots, int nroots, const int *input_map,
                  int *out);

/* ------------------------------------------------------------------ */
/* Evaluation                                                           */

/* A plan: the nodes that outputs[0..n-1] need, in order, with a workspace.
 * The graph must outlive the plan and must not grow while the plan is used
 * (a plan made before new nodes were added stays valid: ids do not move). */
typedef struct nz_graph_plan nz_graph_plan;

nz_graph_plan *nz_graph_plan_new(const nz_graph *g, const int *outputs, int n);
void nz_graph_plan_free(nz_graph_plan *p);
int nz_graph_plan_nodes(const nz_graph_plan *p);   /* nodes it evaluates */
int nz_graph_plan_noutputs(const nz_graph_plan *p);

/* On doubles: in[i] is input i (nz_graph_ninputs entries), out[r] output r.
 * Returns NZ_OK, or the first failing node's status (a NaN or an infinity
 * from a node is NZ_ENAN / NZ_ERANGE, as the jets say; the node is kept for
 * nz_graph_plan_failure). */
nz_status nz_graph_eval(nz_graph_plan *p, const double *in, double *out);

/* On jets: in[i] is the jet of input i (NULL for an input the outputs do
 * not use; a plan never reads an input its nodes do not use), out[r] are
 * jets whose shape the caller set: order <= the inputs' lowest order, any
 * number of tangents (a missing tangent is zero).  Constants are exact to
 * every order.  With din != NULL, also the derivative along a second,
 * independent infinitesimal eta on top of the jets' own tangents: input i
 * moves by eta din[i] (NULL: it does not move), and dout[r] receives the
 * eta-part of output r (the state direction of the exact Jacobian; see
 * mech.h's nz_direction).  Returns NZ_OK or the first failing node's status. */
nz_status nz_graph_eval_jets(nz_graph_plan *p, const nz_jet *const *in, nz_jet *const *out,
                             const nz_jet *const *din, nz_jet *const *dout);

/* Series built order by order (the Taylor integrator's way: docs/theory.md §11).
 * A Taylor integrator for x' = f(t, x) knows x_0..x_k and needs coefficient
 * k of f(t, x(t)) (then x_{k+1} = f_k / (k + 1)), without recomputing lower
 * orders.  The plan keeps a series of max_order + 1 coefficients per node
 * (and per auxiliary series some kernels need: the cosine beside a sine,
 * 1 + x^2 beside atan, the partial powers of x^n, ...), allocated at the
 * first nz_graph_series_begin and reused while max_order does not grow.
 * Every node fills coefficient k with the coefficient-level kernels of
 * series.h (nz_series_<f>_coef), from coefficients 0..k of its operands and
 * 0..k-1 of itself: the very recurrences the jets run, so the coefficients
 * equal those of nz_graph_eval_jets on jets of order max_order without
 * tangents (up to the sign of a zero).
 *
 * Failures are the jets' statuses, found where they appear: domain checks
 * (log of a series with c_0 <= 0: NZ_EDOM; sqrt, asin, acos, abs, x^p, x^y,
 * atan2, hypot at their singular points: NZ_ESING when max_order >= 1, as
 * the jets of order >= 1; division by c_0 = 0: NZ_EZERODIV) at begin, an
 * infinite or NaN coefficient (NZ_ERANGE, NZ_ENAN) at the coefficient where
 * it appears.  The failing node is kept for nz_graph_plan_failure.  (The
 * jets compute each node to the full order before the next, so when two
 * nodes fail at different orders the jets may name the other one.)
 *
 * Branches are decided once, at begin, from coefficient 0, as nz_graph_eval
 * decides them on doubles: cmp and sign compare values (a tie is exact
 * equality), select keeps the operand its condition's c_0 chose for every
 * later coefficient.  The jets break a tie in value by the later
 * coefficients (the lexicographic rule of jet.h), which a series built
 * order by order does not know yet when coefficient 0 is needed; so the two
 * agree except at an exact tie, and nz_graph_series_ties says how many
 * comparisons met one (an integrator can step off the tie and restart). */

/* Start: coefficient 0 of every node from the inputs' values in0[i] (by
 * input number, as nz_graph_eval), for series up to max_order (0..
 * NZ_JET_MAX_ORDER; else NZ_EDOM).  NZ_ENOMEM if the storage cannot grow. */
nz_status nz_graph_series_begin(nz_graph_plan *p, int max_order, const double *in0);
/* Given coefficient k of every input (in_k[i], i by input number; NULL:
 * already written in place, see nz_graph_series_inputs), fill
 * coefficient k of every node and return the outputs' coefficient k in
 * out_k (NULL: not wanted).  k runs 1, 2, ... in order; 1 <= k <= the last
 * coefficient filled + 1 and k <= max_order, else NZ_EDOM (a k already
 * filled is filled again from the new in_k, and later ones are dropped). */
nz_status nz_graph_series_next(nz_graph_plan *p, int k, const double *in_k, double *out_k);
/* After a successful begin: ptr[i] = the series of input number i (i <
 * n), NULL for an input the plan does not read.  A caller that writes
 * coefficient k of every used input there may pass in_k = NULL to
 * nz_graph_series_next (no array to fill and copy).  The pointers hold
 * until a begin with a higher max_order. */
void nz_graph_series_inputs(nz_graph_plan *p, double **ptr, int n);
/* The last coefficient filled (0 after begin), -1 before a successful begin. */
int nz_graph_series_order(const nz_graph_plan *p);
/* Coefficient j (0..nz_graph_series_order) of output r; NAN outside. */
double nz_graph_series_coef(const nz_graph_plan *p, int r, int j);
/* The series of node id `node` (coefficients 0..nz_graph_series_order), or
 * NULL for a node the plan does not evaluate or before begin. */
const double *nz_graph_series_node(const nz_graph_plan *p, int node);
/* The number of cmp and sign nodes whose operands tied in value at the last
 * begin with max_order >= 1 (see above: where series and jets may differ). */
int nz_graph_series_ties(const nz_graph_plan *p);

/* The node that failed in the last evaluation, its operation and the value
 * of its first operand (for messages). */
void nz_graph_plan_failure(const nz_graph_plan *p, int *node, nz_gop *op, nz_jet_fn *fn,
                           double *operand);

#endif
