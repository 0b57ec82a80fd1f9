/* graph_impl.h - inside the expression graphs (graph.h): the graph's and
 * the plan's structs and the scalar kernels, shared by the files of
 * src/graph that build (graph_build.c), differentiate and copy (graph_diff.c),
 * plan and evaluate on doubles (graph_plan.c), on jets (graph_jets.c) and
 * order by order (graph_series.c).  Internal to src/graph.
 *
 * One arithmetic, three places: folding a constant node (graph_build.c), the
 * double evaluator (graph_plan.c) and the order-0 jet kernels of jet.c must
 * give the same number, so the scalar kernels below are the order-0 case of
 * the jet kernels, and folding calls the very functions the double
 * evaluator calls (graph_build.c's opening comment says more). */
#ifndef NZ_GRAPH_IMPL_H
#define NZ_GRAPH_IMPL_H

#include <math.h>
#include <stdint.h>
#include "graph/graph.h"
#include "jets/series.h"
#include "jets/jet_eta.h"

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

static inline int is_small_integer(double p) { return p == floor(p) && fabs(p) <= 1e9; }

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
static inline nz_status scalar_op(const nz_gnode *nd, double x, double y, double *z)
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
  /* Series built order by order (graph_series.c). */
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
  /* machine code for next, or NULL: graph_series.h's nz_series_code,
   * spelled out because graph_series.c includes this header */
  int (*ser_code)(int k, int L, double *S, double *v, void (*const *K)(void));
  void (*const *ser_kfn)(void);
  unsigned long ser_code_sig;   /* the signature it was made for */
  /* Failure of the last evaluation. */
  int bad_const;   /* a non-finite constant slot, or -1 */
  int fail_node;
  nz_gop fail_op;
  nz_jet_fn fail_fn;
  double fail_operand;
};

/* Small predicates every file of the graph uses. */
static inline int imin(int a, int b) { return a < b ? a : b; }
static inline int imax(int a, int b) { return a > b ? a : b; }
static inline int valid(const nz_graph *g, int x) { return x >= 0 && x < g->n; }
static inline int has_operand(int op) { return op != NZ_GOP_CONST && op != NZ_GOP_INPUT; }
static inline int unary_op(int op) { return op == NZ_GOP_NEG || op == NZ_GOP_POWC || op == NZ_GOP_FN; }
static inline int binary_op(int op) { return has_operand(op) && !unary_op(op); }
static inline int has_cond(int op) { return op == NZ_GOP_SELECT; }
static inline int is_const_slot(const nz_graph_plan *p, int s) { return s >= p->nin && s < p->base; }

/* x is the constant v (graph_build.c's nz_graph_is_const). */
static inline int is_const_value(const nz_graph *g, int x, double v)
{
  double c;
  return nz_graph_is_const(g, x, &c) && c == v;
}

/* The failure of an evaluation at slot s recorded in the plan (for
 * nz_graph_plan_failure); returns st.  Every evaluator reports through it. */
nz_status nz_graph_plan_fail(nz_graph_plan *p, int s, nz_status st, double operand);

#endif
