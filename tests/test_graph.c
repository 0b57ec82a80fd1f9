/* test_graph.c - expression graphs (graph.c) in C, without Lua: folding,
 * sharing and simplification; evaluation on doubles against plain C
 * formulas (libm) and against the order-0 jets; evaluation on jets against
 * the same expressions computed directly with nz_jet_* calls; derivatives
 * built on the graph against central differences and hand derivatives; the
 * eta-part of nz_graph_eval_jets against the derivative graph; failures;
 * exact graphs against the IEEE arithmetic they stand for, drops that keep
 * what can fail, and the guards of a plan (ties, singular points).
 * GSL-style PASS/FAIL lines. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <gsl/gsl_math.h>
#include <gsl/gsl_sf_gamma.h>
#include <gsl/gsl_sf_zeta.h>
#include <gsl/gsl_test.h>
#include "graph/graph.h"
#include "graph/graph_guard.h"
#include "graph/graph_rounding.h"
#include "test_util.h"

/* ------------------------------------------------------------------ */
/* One expression, three independent evaluations                        */

/* Each test expression is written once against this small interface and
 * run in three modes: recording a graph (M_GRAPH), computing directly with
 * nz_jet_* on jets of one shape (M_JET), and plain C with libm (M_C). */
enum { M_GRAPH, M_JET, M_C };
static int M;
static nz_graph *G;

#define JK 12
#define JD 2
#define NIN 4
#define POOL 512
static nz_jet *jin[NIN], *pool[POOL];
static int npool, jet_failures;
static double cin[NIN], jw[8 * (JK + 1)];

typedef struct val {
  int id;
  nz_jet *j;
  double d;
} val;

static nz_jet *fresh(void)
{
  if (npool == POOL) { jet_failures++; npool = 0; }
  if (!pool[npool]) pool[npool] = nz_jet_alloc(JK, JD);
  return pool[npool++];
}
static val jet_result(nz_jet *z, nz_status st)
{
  if (st) jet_failures++;
  return (val){ -1, z, 0.0 };
}

static val vin(int i)
{
  if (M == M_GRAPH) return (val){ nz_graph_input(G, i), NULL, 0.0 };
  if (M == M_JET) return (val){ -1, jin[i], 0.0 };
  return (val){ -1, NULL, cin[i] };
}
static val vc(double c)
{
  if (M == M_GRAPH) return (val){ nz_graph_const(G, c), NULL, 0.0 };
  if (M == M_JET) {
    nz_jet *z = fresh();
    nz_jet_set_constant(z, c);
    return (val){ -1, z, 0.0 };
  }
  return (val){ -1, NULL, c };
}

#define BIN(name, gop, jcall, cexpr)                                          \
  static val name(val a, val b)                                               \
  {                                                                           \
    if (M == M_GRAPH) return (val){ nz_graph_op(G, gop, a.id, b.id), NULL, 0 }; \
    if (M == M_JET) {                                                         \
      nz_jet *z = fresh();                                                    \
      return jet_result(z, jcall);                                            \
    }                                                                         \
    return (val){ -1, NULL, cexpr };                                          \
  }
BIN(vadd, NZ_GOP_ADD, nz_jet_add(z, a.j, b.j), a.d + b.d)
BIN(vsub, NZ_GOP_SUB, nz_jet_sub(z, a.j, b.j), a.d - b.d)
BIN(vmul, NZ_GOP_MUL, nz_jet_mul(z, a.j, b.j, jw), a.d * b.d)
BIN(vdiv, NZ_GOP_DIV, nz_jet_div(z, a.j, b.j, jw), a.d / b.d)
BIN(vpow, NZ_GOP_POW, nz_jet_pow_jet(z, a.j, b.j, jw), pow(a.d, b.d))
BIN(vatan2, NZ_GOP_ATAN2, nz_jet_atan2(z, a.j, b.j, jw), atan2(a.d, b.d))
BIN(vhypot, NZ_GOP_HYPOT, nz_jet_hypot(z, a.j, b.j, jw), hypot(a.d, b.d))

static val vneg(val a)
{
  if (M == M_GRAPH) return (val){ nz_graph_op(G, NZ_GOP_NEG, a.id, -1), NULL, 0 };
  if (M == M_JET) { nz_jet *z = fresh(); return jet_result(z, nz_jet_neg(z, a.j)); }
  return (val){ -1, NULL, -a.d };
}
static val vpowc(val a, double p)
{
  if (M == M_GRAPH) return (val){ nz_graph_powc(G, a.id, p), NULL, 0 };
  if (M == M_JET) { nz_jet *z = fresh(); return jet_result(z, nz_jet_pow(z, a.j, p, jw)); }
  return (val){ -1, NULL, pow(a.d, p) };
}
static double cfn(nz_jet_fn f, double x)
{
  switch (f) {
  case NZ_FN_EXP: return exp(x);
  case NZ_FN_LOG: return log(x);
  case NZ_FN_SQRT: return sqrt(x);
  case NZ_FN_SIN: return sin(x);
  case NZ_FN_COS: return cos(x);
  case NZ_FN_TAN: return tan(x);
  case NZ_FN_ASIN: return asin(x);
  case NZ_FN_ACOS: return acos(x);
  case NZ_FN_ATAN: return atan(x);
  case NZ_FN_SINH: return sinh(x);
  case NZ_FN_COSH: return cosh(x);
  case NZ_FN_TANH: return tanh(x);
  case NZ_FN_ABS: return fabs(x);
  case NZ_FN_SIGN: return x > 0 ? 1.0 : x < 0 ? -1.0 : 0.0;
  default: return NAN;
  }
}
static val vfn(nz_jet_fn f, val a)
{
  if (M == M_GRAPH) return (val){ nz_graph_fn(G, f, a.id), NULL, 0 };
  if (M == M_JET) { nz_jet *z = fresh(); return jet_result(z, nz_jet_apply(z, f, a.j, jw)); }
  return (val){ -1, NULL, cfn(f, a.d) };
}
static double ccmp(nz_cmp op, double a, double b)
{
  switch (op) {
  case NZ_CMP_LT: return a < b;
  case NZ_CMP_LE: return a <= b;
  case NZ_CMP_GT: return a > b;
  case NZ_CMP_GE: return a >= b;
  case NZ_CMP_EQ: return a == b;
  default: return a != b;
  }
}
static val vcmp(nz_cmp op, val a, val b)
{
  if (M == M_GRAPH) return (val){ nz_graph_cmp(G, op, a.id, b.id), NULL, 0 };
  if (M == M_JET) { nz_jet *z = fresh(); return jet_result(z, nz_jet_compare(z, op, a.j, b.j)); }
  return (val){ -1, NULL, ccmp(op, a.d, b.d) };
}
static val vsel(val c, val a, val b)
{
  if (M == M_GRAPH) return (val){ nz_graph_select(G, c.id, a.id, b.id), NULL, 0 };
  if (M == M_JET) { nz_jet *z = fresh(); return jet_result(z, nz_jet_select(z, c.j, a.j, b.j)); }
  return (val){ -1, NULL, c.d != 0.0 ? a.d : b.d };
}
#define SIN(a) vfn(NZ_FN_SIN, a)
#define COS(a) vfn(NZ_FN_COS, a)
#define EXP(a) vfn(NZ_FN_EXP, a)

/* Inputs x, y in (0.2, 0.7) (t: inputs 2 and 3 in the pendulum). */
static val e_rational(void)   /* sin(x) exp(y) / (1 + x^2) */
{
  val x = vin(0), y = vin(1);
  return vdiv(vmul(SIN(x), EXP(y)), vadd(vc(1.0), vpowc(x, 2.0)));
}
static val e_logs(void)   /* log(y) + sqrt(x) - cos(x y) */
{
  val x = vin(0), y = vin(1);
  return vsub(vadd(vfn(NZ_FN_LOG, y), vfn(NZ_FN_SQRT, x)), COS(vmul(x, y)));
}
static val e_trig(void)   /* tan(x) asin(x) - acos(y) / atan(x + y) */
{
  val x = vin(0), y = vin(1);
  return vsub(vmul(vfn(NZ_FN_TAN, x), vfn(NZ_FN_ASIN, x)),
              vdiv(vfn(NZ_FN_ACOS, y), vfn(NZ_FN_ATAN, vadd(x, y))));
}
static val e_hyper(void)   /* sinh(x) cosh(y) + tanh(x - y) + |x - y| (-y) */
{
  val x = vin(0), y = vin(1);
  return vadd(vadd(vmul(vfn(NZ_FN_SINH, x), vfn(NZ_FN_COSH, y)), vfn(NZ_FN_TANH, vsub(x, y))),
              vmul(vfn(NZ_FN_ABS, vsub(x, y)), vneg(y)));
}
static val e_powers(void)   /* x^y + x^3.5 + hypot(x, y) - atan2(y, x) + x^-2 + y^3 */
{
  val x = vin(0), y = vin(1);
  val s = vadd(vadd(vpow(x, y), vpowc(x, 3.5)), vhypot(x, y));
  return vadd(vadd(vsub(s, vatan2(y, x)), vpowc(x, -2.0)), vpowc(y, 3.0));
}
static val e_henon(void)   /* Henon-Heiles: (x^2 + y^2)/2 + x^2 y - y^3/3 */
{
  val x = vin(0), y = vin(1);
  val r2 = vmul(vadd(vpowc(x, 2.0), vpowc(y, 2.0)), vc(0.5));
  return vsub(vadd(r2, vmul(vpowc(x, 2.0), y)), vdiv(vpowc(y, 3.0), vc(3.0)));
}
/* Double pendulum kinetic energy, angles a1 = x, a2 = y, rates w1, w2:
 * (m1 + m2)/2 l1^2 w1^2 + m2 l1 l2 w1 w2 cos(a1 - a2) + m2/2 l2^2 w2^2. */
static val e_pendulum(void)
{
  val a1 = vin(0), a2 = vin(1), w1 = vin(2), w2 = vin(3);
  val m1 = vc(1.3), m2 = vc(0.7), l1 = vc(1.1), l2 = vc(0.9), half = vc(0.5);
  val t1 = vmul(vmul(vmul(half, vadd(m1, m2)), vpowc(l1, 2.0)), vpowc(w1, 2.0));
  val t2 = vmul(vmul(vmul(vmul(m2, l1), l2), vmul(w1, w2)), COS(vsub(a1, a2)));
  val t3 = vmul(vmul(vmul(half, m2), vpowc(l2, 2.0)), vpowc(w2, 2.0));
  return vadd(vadd(t1, t2), t3);
}

/* Branches: ifelse(x > y, sin(x) y, x^2 - y) + sign(x - y) x
 *           + ifelse(x <= 0.45, exp(y), x y) + max(x, y) + 0.5 [x < y]
 * (inputs in (0.2, 0.7): both sides of every condition are sampled). */
static val e_branch(void)
{
  val x = vin(0), y = vin(1);
  val s1 = vsel(vcmp(NZ_CMP_GT, x, y), vmul(SIN(x), y), vsub(vpowc(x, 2.0), y));
  val s2 = vmul(vfn(NZ_FN_SIGN, vsub(x, y)), x);
  val s3 = vsel(vcmp(NZ_CMP_LE, x, vc(0.45)), EXP(y), vmul(x, y));
  val s4 = vsel(vcmp(NZ_CMP_GE, x, y), x, y);
  val s5 = vmul(vc(0.5), vcmp(NZ_CMP_LT, x, y));
  return vadd(vadd(vadd(s1, s2), vadd(s3, s4)), s5);
}

typedef val (*expr_fn)(void);
static const struct {
  const char *name;
  expr_fn f;
} exprs[] = {
  { "sin(x) exp(y) / (1 + x^2)", e_rational },
  { "log(y) + sqrt(x) - cos(x y)", e_logs },
  { "tan(x) asin(x) - acos(y) / atan(x + y)", e_trig },
  { "sinh(x) cosh(y) + tanh(x - y) - |x - y| y", e_hyper },
  { "x^y + x^3.5 + hypot(x, y) - atan2(y, x) + x^-2 + y^3", e_powers },
  { "Henon-Heiles potential", e_henon },
  { "double pendulum kinetic energy", e_pendulum },
  { "branches (select, cmp, sign)", e_branch },
};
#define NEXPR ((int)(sizeof exprs / sizeof exprs[0]))
#define E_PENDULUM 6   /* exprs[6], e_pendulum: four inputs */

static uint64_t rng = 0x2545F4914F6CDD1DULL;
static double urand(void) { return test_urand(&rng); }
static void random_point(double *x)
{
  for (int i = 0; i < NIN; i++) x[i] = 0.2 + 0.5 * urand();
}
/* Random jets around x: value series x + 0.3 t + ..., random tangents, the
 * coefficient of t^k scaled by 0.3^k so that series of functions with a
 * singularity 0.2 away (sqrt(0.2 + ...)) keep coefficients of order 1. */
static void random_jets(nz_jet **j, const double *x)
{
  for (int i = 0; i < NIN; i++) {
    int K1 = j[i]->order + 1;
    for (int d = 0; d <= j[i]->ntan; d++)
      for (int k = 0; k < K1; k++) j[i]->c[d * K1 + k] = 0.2 * (urand() - 0.5) * pow(0.3, k);
    j[i]->c[0] = x[i];
    if (K1 > 1) j[i]->c[1] = 0.3;
  }
}

static double rel(double got, double want) { return fabs(got - want) / fmax(fabs(want), 1e-300); }
/* max |a - b| over the coefficients of b's shape, relative to max |b| */
static double jet_diff(const nz_jet *a, const nz_jet *b)
{
  int n = (b->ntan + 1) * (b->order + 1);
  double d = 0.0, s = 0.0;
  for (int k = 0; k < n; k++) {
    d = fmax(d, fabs(a->c[k] - b->c[k]));
    s = fmax(s, fabs(b->c[k]));
  }
  return s > 0 ? d / s : d;
}

static int record(int e)
{
  M = M_GRAPH;
  return exprs[e].f().id;
}
static double eval1(int root, const double *x, nz_status *st)
{
  nz_graph_plan *p = nz_graph_plan_new(G, &root, 1);
  double out = NAN;
  *st = p ? nz_graph_eval(p, x, &out) : NZ_ENOMEM;
  nz_graph_plan_free(p);
  return out;
}

/* ------------------------------------------------------------------ */
/* Building                                                             */

static void check_folding(void)
{
  nz_graph *g = nz_graph_new();
  double v = 0.0;
  int c1 = nz_graph_const(g, 0.3), c2 = nz_graph_const(g, 1.2);
  int s = nz_graph_fn(g, NZ_FN_SIN, c1), e = nz_graph_fn(g, NZ_FN_EXP, c2);
  int q = nz_graph_op(g, NZ_GOP_ADD, nz_graph_const(g, 1.0), nz_graph_powc(g, c1, 2.0));
  int r = nz_graph_op(g, NZ_GOP_DIV, nz_graph_op(g, NZ_GOP_MUL, s, e), q);
  gsl_test(!nz_graph_is_const(g, r, &v) || v != sin(0.3) * exp(1.2) / (1.0 + 0.3 * 0.3),
           "folding: sin(0.3) exp(1.2) / (1 + 0.3^2) is the C double (%.17g)", v);
  int h = nz_graph_op(g, NZ_GOP_HYPOT, c1, c2);
  gsl_test(!nz_graph_is_const(g, h, &v) || rel(v, hypot(0.3, 1.2)) > 2 * GSL_DBL_EPSILON,
           "folding: hypot(0.3, 1.2) within 2 ulp of libm's hypot");
  int a2 = nz_graph_op(g, NZ_GOP_ATAN2, c1, nz_graph_const(g, -2.0));
  gsl_test(!nz_graph_is_const(g, a2, &v) || v != atan2(0.3, -2.0), "folding: atan2(0.3, -2)");
  int pw = nz_graph_op(g, NZ_GOP_POW, c2, c1);
  gsl_test(!nz_graph_is_const(g, pw, &v) || v != pow(1.2, 0.3), "folding: 1.2^0.3 is libm's pow");
  int big = nz_graph_op(g, NZ_GOP_POW, nz_graph_const(g, 2.5), nz_graph_const(g, 1.7));
  gsl_test(!nz_graph_is_const(g, big, &v) || v != pow(2.5, 1.7),
           "folding: 2.5^1.7 is libm's pow (%.17g)", v);
  int sq = nz_graph_op(g, NZ_GOP_POW, nz_graph_const(g, -2.0), nz_graph_const(g, 2.0));
  gsl_test(!nz_graph_is_const(g, sq, &v) || v != 4.0, "folding: (-2)^2 = 4 (a constant exponent is POWC)");
  /* Zeros: 0.0 and -0.0 are distinct constants (atan2 tells them apart). */
  int pz = nz_graph_const(g, 0.0), nz = nz_graph_const(g, -0.0);
  int m1 = nz_graph_const(g, -1.0);
  double ap, an;
  nz_graph_is_const(g, nz_graph_op(g, NZ_GOP_ATAN2, pz, m1), &ap);
  nz_graph_is_const(g, nz_graph_op(g, NZ_GOP_ATAN2, nz, m1), &an);
  gsl_test(pz == nz || ap != M_PI || an != -M_PI,
           "folding: 0.0 and -0.0 are distinct nodes, atan2(+-0, -1) = +-pi");
  /* Folding that fails keeps the node (evaluation reports it). */
  int lg = nz_graph_fn(g, NZ_FN_LOG, m1);
  int dz = nz_graph_op(g, NZ_GOP_DIV, c1, pz);
  int ov = nz_graph_fn(g, NZ_FN_EXP, nz_graph_const(g, 800.0));
  gsl_test(nz_graph_is_const(g, lg, NULL) || nz_graph_nodes(g)[lg].op != NZ_GOP_FN,
           "folding: log(-1) stays a node");
  gsl_test(nz_graph_is_const(g, dz, NULL) || nz_graph_nodes(g)[dz].op != NZ_GOP_DIV,
           "folding: 0.3 / 0 stays a node");
  gsl_test(nz_graph_is_const(g, ov, NULL), "folding: exp(800) (overflow) stays a node");
  nz_status st;
  nz_graph *keep = G;
  G = g;
  eval1(lg, NULL, &st);
  gsl_test(st != NZ_EDOM, "an unfolded log(-1) evaluates to NZ_EDOM");
  eval1(dz, NULL, &st);
  gsl_test(st != NZ_EZERODIV, "an unfolded 0.3 / 0 evaluates to NZ_EZERODIV");
  G = keep;
  nz_graph_free(g);
}

static void check_sharing(void)
{
  nz_graph *keep = G;
  G = nz_graph_new();
  int n0 = 0, same = 1;
  for (int e = 0; e < NEXPR; e++) {
    int id = record(e);
    n0 = nz_graph_size(G);
    same = same && record(e) == id && nz_graph_size(G) == n0;
  }
  gsl_test(!same, "hash-consing: recording each expression twice gives the same node, no growth");
  gsl_test(nz_graph_ninputs(G) != 4, "ninputs = highest input number + 1 (%d)", nz_graph_ninputs(G));
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0), y = nz_graph_input(g, 1);
  int n1 = nz_graph_size(g);
  gsl_test(nz_graph_op(g, NZ_GOP_ADD, x, y) != nz_graph_op(g, NZ_GOP_ADD, y, x) ||
               nz_graph_op(g, NZ_GOP_MUL, x, y) != nz_graph_op(g, NZ_GOP_MUL, y, x) ||
               nz_graph_op(g, NZ_GOP_HYPOT, x, y) != nz_graph_op(g, NZ_GOP_HYPOT, y, x) ||
               nz_graph_op(g, NZ_GOP_SUB, x, y) == nz_graph_op(g, NZ_GOP_SUB, y, x),
           "hash-consing: x+y = y+x, xy = yx, hypot symmetric; x-y != y-x");
  gsl_test(nz_graph_size(g) != n1 + 5, "hash-consing: those built %d nodes (want 5)",
           nz_graph_size(g) - n1);
  gsl_test(nz_graph_input(g, 0) != x, "one node per input number");
  nz_graph_free(g);
  /* A big graph grows its table many times and still finds every node. */
  int ids[3000], found = 1;
  for (int i = 0; i < 3000; i++) ids[i] = nz_graph_const(G, i + 0.5);
  for (int i = 0; i < 3000; i++) found = found && nz_graph_const(G, i + 0.5) == ids[i];
  gsl_test(!found, "hash-consing: 3000 constants found again after the table grew");
  gsl_test(nz_graph_input(G, -1) != -1 || nz_graph_op(G, NZ_GOP_ADD, x, 1 << 30) != -1 ||
               nz_graph_fn(G, NZ_FN_COUNT, x) != -1 || nz_graph_powc(G, x, NAN) != -1,
           "bad operands (input -1, unknown node, unknown fn, NaN exponent) return -1");
  nz_graph_free(G);
  G = keep;
}

static void check_simplify(void)
{
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0), y = nz_graph_input(g, 1);
  int zero = nz_graph_const(g, 0.0), one = nz_graph_const(g, 1.0);
  const nz_gnode *nd;
  gsl_test(nz_graph_op(g, NZ_GOP_ADD, x, zero) != x || nz_graph_op(g, NZ_GOP_ADD, zero, x) != x,
           "simplify: x + 0 = 0 + x = x");
  gsl_test(nz_graph_op(g, NZ_GOP_SUB, x, zero) != x, "simplify: x - 0 = x");
  int nx = nz_graph_op(g, NZ_GOP_SUB, zero, x);
  nd = nz_graph_nodes(g);
  gsl_test(nd[nx].op != NZ_GOP_NEG || nd[nx].a != x, "simplify: 0 - x = neg x");
  gsl_test(nz_graph_op(g, NZ_GOP_NEG, nx, -1) != x, "simplify: -(-x) = x");
  gsl_test(nz_graph_op(g, NZ_GOP_MUL, x, one) != x || nz_graph_op(g, NZ_GOP_MUL, one, x) != x,
           "simplify: x 1 = 1 x = x");
  gsl_test(nz_graph_op(g, NZ_GOP_MUL, x, zero) != zero || nz_graph_op(g, NZ_GOP_MUL, zero, y) != zero,
           "simplify: x 0 = 0 y = 0");
  gsl_test(nz_graph_op(g, NZ_GOP_DIV, x, one) != x, "simplify: x / 1 = x");
  gsl_test(nz_graph_powc(g, x, 1.0) != x || nz_graph_powc(g, x, 0.0) != one,
           "simplify: x^1 = x, x^0 = 1");
  gsl_test(nz_graph_op(g, NZ_GOP_SUB, y, y) != zero, "simplify: y - y = 0");
  int xx = nz_graph_op(g, NZ_GOP_DIV, x, x);
  nd = nz_graph_nodes(g);
  gsl_test(nd[xx].op != NZ_GOP_DIV, "simplify: x / x is kept (x may be 0)");
  int p2 = nz_graph_op(g, NZ_GOP_POW, x, nz_graph_const(g, 2.0));
  nd = nz_graph_nodes(g);
  gsl_test(nd[p2].op != NZ_GOP_POWC || nd[p2].v != 2.0 || p2 != nz_graph_powc(g, x, 2.0),
           "simplify: x ^ (constant 2) is the node x^2 (POWC)");
  nz_graph_free(g);
}

/* Is node z the product c x (the constant c times node x)? */
static int is_scaled(nz_graph *g, int z, double c, int x)
{
  const nz_gnode *nd = nz_graph_nodes(g);
  double v;
  if (nd[z].op != NZ_GOP_MUL) return 0;
  int k = nz_graph_is_const(g, nd[z].a, NULL) ? nd[z].a : nd[z].b, y = k == nd[z].a ? nd[z].b : nd[z].a;
  return nz_graph_is_const(g, k, &v) && v == c && y == x;
}

/* Like terms gathered when building (graph.h), each by hand. */
static void check_like_terms(void)
{
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0), y = nz_graph_input(g, 1);
#define K(v) nz_graph_const(g, v)
#define OP(o, a, b) nz_graph_op(g, NZ_GOP_##o, a, b)
  int x2 = OP(MUL, K(2.0), x), x3 = OP(MUL, x, K(3.0)), x5 = OP(MUL, K(5.0), x);
  gsl_test(!is_scaled(g, OP(ADD, x2, x3), 5.0, x) || OP(ADD, x3, x2) != x5,
           "like terms: 2x + x3 = 5x, the node 5x");
  gsl_test(!is_scaled(g, OP(ADD, x, x), 2.0, x) || OP(ADD, x, x) != x2, "like terms: x + x = 2x");
  gsl_test(!is_scaled(g, OP(ADD, x2, x), 3.0, x) || OP(ADD, x, x2) != x3, "like terms: 2x + x = x + 2x = 3x");
  gsl_test(!is_scaled(g, OP(MUL, K(2.0), x3), 6.0, x) || !is_scaled(g, OP(MUL, x3, K(-2.0)), -6.0, x),
           "like terms: 2 (3x) = 6x, (3x) (-2) = -6x");
  int n2 = OP(NEG, x2, -1);
  gsl_test(!is_scaled(g, n2, -2.0, x), "like terms: -(2x) = (-2)x");
  gsl_test(!is_scaled(g, OP(SUB, x5, x3), 2.0, x) || OP(SUB, x5, x3) != x2, "like terms: 5x - 3x = 2x");
  gsl_test(OP(SUB, x2, x) != x, "like terms: 2x - x = x");
  int mx = OP(SUB, x2, x3);
  gsl_test(nz_graph_nodes(g)[mx].op != NZ_GOP_NEG || nz_graph_nodes(g)[mx].a != x, "like terms: 2x - 3x = -x");
  gsl_test(OP(SUB, x, OP(NEG, x, -1)) != x2, "like terms: x - (-x) = 2x");
  gsl_test(!nz_graph_is_const(g, OP(ADD, x2, n2), NULL), "like terms: 2x + (-2)x = 0");
  gsl_test(!is_scaled(g, OP(MUL, K(3.0), OP(NEG, x, -1)), -3.0, x), "like terms: 3 (-x) = (-3)x");
  int xy = OP(MUL, x, y), nxy = OP(NEG, xy, -1);
  gsl_test(nz_graph_nodes(g)[nxy].op != NZ_GOP_NEG, "like terms: -(x y) stays a negation (no constant)");
  gsl_test(!is_scaled(g, OP(ADD, xy, OP(MUL, xy, K(4.0))), 5.0, xy), "like terms: x y + 4 (x y) = 5 (x y)");
  gsl_test(nz_graph_nodes(g)[OP(ADD, x2, y)].op != NZ_GOP_ADD, "like terms: 2x + y is kept");
  int y3 = OP(MUL, K(3.0), y), nx = OP(NEG, x, -1), ny = OP(NEG, y, -1);
  gsl_test(!is_scaled(g, OP(MUL, x2, y3), 6.0, xy) || !is_scaled(g, OP(MUL, x, y3), 3.0, xy),
           "constants out of products: (2x)(3y) = 6 (x y), x (3y) = 3 (x y)");
  gsl_test(OP(MUL, nx, y) != nxy || OP(MUL, x, ny) != nxy || OP(MUL, nx, ny) != xy,
           "signs out of products: (-x) y = x (-y) = -(x y), (-x)(-y) = x y");
  int d = OP(SUB, x, y), s2 = OP(ADD, x, y);
  gsl_test(nz_graph_nodes(g)[d].op != NZ_GOP_SUB || OP(ADD, x, ny) != d || OP(ADD, ny, x) != d ||
           OP(SUB, x, ny) != s2, "signs into sums: x + (-y) = (-y) + x = x - y, x - (-y) = x + y");
  int y2 = OP(MUL, K(2.0), y), ym2 = OP(MUL, K(-2.0), y);
  gsl_test(OP(ADD, x, ym2) != OP(SUB, x, y2) || OP(SUB, x, ym2) != OP(ADD, x, y2),
           "signs into sums: x + (-2y) = x - 2y, x - (-2y) = x + 2y");
  int big = OP(MUL, K(1e308), x), sum = OP(ADD, big, big);
  gsl_test(nz_graph_nodes(g)[sum].op != NZ_GOP_ADD, "like terms: 1e308 x + 1e308 x is kept (the coefficient would overflow)");
  /* A sum of c_l P over l = 1..10 is the one node 55 P. */
  int P = OP(MUL, nz_graph_fn(g, NZ_FN_COS, x), nz_graph_fn(g, NZ_FN_SIN, y)), acc = OP(MUL, K(1.0), P);
  for (int l = 2; l <= 10; l++) acc = OP(ADD, acc, OP(MUL, K((double)l), P));
  gsl_test(!is_scaled(g, acc, 55.0, P), "like terms: sum of l P over l = 1..10 is 55 P");
  /* Exact in real arithmetic, not bit for bit: (0.1 x) + (0.2 x) is (0.1 + 0.2) x. */
  int t = OP(ADD, OP(MUL, K(0.1), x), OP(MUL, K(0.2), x));
  nz_graph_plan *p = nz_graph_plan_new(g, &t, 1);
  double worst = 0.0, out;
  int ok = p && is_scaled(g, t, 0.1 + 0.2, x);
  for (int trial = 0; trial < 100 && ok; trial++) {
    double in[2] = { 20 * urand() - 10, 0.0 };
    ok = nz_graph_eval(p, in, &out) == NZ_OK;
    worst = fmax(worst, rel(out, 0.1 * in[0] + 0.2 * in[0]));
  }
  gsl_test(!ok || !(worst <= 2 * GSL_DBL_EPSILON),
           "like terms: 0.1 x + 0.2 x = (0.1 + 0.2) x, within 2 eps of the unsimplified sum (%.2g)", worst);
  nz_graph_plan_free(p);
#undef K
#undef OP
  nz_graph_free(g);
}

/* cmp, select, sign: folding, sharing, the tie rule, hand derivatives. */
static void check_branches(void)
{
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0), y = nz_graph_input(g, 1);
  int two = nz_graph_const(g, 2.0), three = nz_graph_const(g, 3.0), zero = nz_graph_const(g, 0.0);
  double v;
  int ok = 1;
  for (int op = NZ_CMP_LT; op <= NZ_CMP_NE; op++) {
    int f = nz_graph_cmp(g, (nz_cmp)op, two, three), s = nz_graph_cmp(g, (nz_cmp)op, x, x);
    ok = ok && nz_graph_is_const(g, f, &v) && v == ccmp((nz_cmp)op, 2.0, 3.0);
    ok = ok && nz_graph_is_const(g, s, &v) && v == ccmp((nz_cmp)op, 1.0, 1.0);
  }
  gsl_test(!ok, "cmp: constants fold, cmp(x, x) folds to x op x (every comparison kind)");
  gsl_test(nz_graph_select(g, nz_graph_const(g, -0.5), x, y) != x ||
           nz_graph_select(g, zero, x, y) != y || nz_graph_select(g, y, x, x) != x,
           "select: a constant condition chooses the operand itself; select(c, x, x) = x");
  int c = nz_graph_cmp(g, NZ_CMP_GT, x, y), s1 = nz_graph_select(g, c, x, y);
  int c2 = nz_graph_cmp(g, NZ_CMP_GE, x, y);
  gsl_test(s1 != nz_graph_select(g, c, x, y) || s1 == nz_graph_select(g, c, y, x) ||
           s1 == nz_graph_select(g, c2, x, y) || c == c2,
           "select and cmp are shared by condition, operands and kind");
  gsl_test(!nz_graph_is_const(g, nz_graph_fn(g, NZ_FN_SIGN, nz_graph_const(g, -3.0)), &v) || v != -1.0,
           "sign(-3) folds to -1");
  /* The tie rule: at x = 0 the doubles see a tie (x > 0 false, sign 0); on
   * jets x = 0 + t grows, so x > 0 holds and sign is +1; x = 0 - t: false, -1. */
  int gt = nz_graph_cmp(g, NZ_CMP_GT, x, zero), sg = nz_graph_fn(g, NZ_FN_SIGN, x);
  int sel = nz_graph_select(g, gt, nz_graph_powc(g, x, 2.0), nz_graph_op(g, NZ_GOP_NEG, x, -1));
  int outs[3] = { gt, sg, sel };
  nz_graph_plan *p = nz_graph_plan_new(g, outs, 3);
  double in[2] = { 0.0, 0.0 }, d[3];
  gsl_test(nz_graph_eval(p, in, d) != NZ_OK || d[0] != 0.0 || d[1] != 0.0 || d[2] != 0.0,
           "tie on doubles: [0 > 0] = 0, sign(0) = 0, select picks -x = 0");
  nz_jet *xj = nz_jet_alloc(2, 1), *yj = nz_jet_alloc(2, 1), *o[3];
  for (int i = 0; i < 3; i++) o[i] = nz_jet_alloc(2, 1);
  const nz_jet *jj[2] = { xj, yj };
  for (int dir = 1; dir >= -1; dir -= 2) {
    nz_jet_set_variable(xj, 0.0, 0);   /* 0 + t, tangent 1 */
    for (int k = 0; k < 6; k++) xj->c[k] *= dir;
    nz_jet_set_constant(yj, 0.0);
    int st = nz_graph_eval_jets(p, jj, o, NULL, NULL);
    /* x > 0: x^2 = t^2, tangent 2t; else -x = -dir t = t, tangent -dir */
    double want[3] = { 0.0, dir > 0 ? 0.0 : 1.0, dir > 0 ? 1.0 : 0.0 };
    int good = st == NZ_OK && o[0]->c[0] == (dir > 0) && o[1]->c[0] == dir &&
               o[0]->c[1] == 0.0 && o[1]->c[1] == 0.0;
    for (int k = 0; k < 3; k++) good = good && o[2]->c[k] == want[k];
    double *tn = nz_jet_tangent(o[2], 0);
    good = good && (dir > 0 ? tn[0] == 0 && tn[1] == 2 * dir && tn[2] == 0 : tn[0] == -dir && tn[1] == 0);
    gsl_test(!good, "tie on jets: x = 0 %s t gives [x > 0] = %d, sign %+d, and that branch with its tangent",
             dir > 0 ? "+" : "-", dir > 0, dir);
  }
  nz_graph_plan_free(p);
  /* Hand derivatives of f = select(x > y, x^3 y, y^2) + sign(x) + [x < y]:
   * f_x = [x > y] 3 x^2 y, f_y = [x > y] x^3 + [x <= y] 2 y. */
  int f = nz_graph_op(g, NZ_GOP_ADD,
                      nz_graph_select(g, c, nz_graph_op(g, NZ_GOP_MUL, nz_graph_powc(g, x, 3.0), y),
                                      nz_graph_powc(g, y, 2.0)),
                      nz_graph_op(g, NZ_GOP_ADD, sg, nz_graph_cmp(g, NZ_CMP_LT, x, y)));
  int one = nz_graph_const(g, 1.0), dx[2] = { one, -1 }, dy[2] = { -1, one };
  int fd[2] = { nz_graph_derivative(g, f, dx), nz_graph_derivative(g, f, dy) };
  p = nz_graph_plan_new(g, fd, 2);
  double worst = 0.0;
  ok = p != NULL;
  for (int trial = 0; trial < 40 && ok; trial++) {
    double a = 4 * urand() - 2, b = 4 * urand() - 2, xy[2] = { a, b };
    double want[2] = { a > b ? 3 * a * a * b : 0.0, a > b ? a * a * a : 2 * b };
    ok = nz_graph_eval(p, xy, d) == NZ_OK;
    for (int i = 0; i < 2; i++) worst = fmax(worst, fabs(d[i] - want[i]) / fmax(1.0, fabs(want[i])));
  }
  gsl_test(!ok || !(worst <= 4 * GSL_DBL_EPSILON),
           "d select(x > y, x^3 y, y^2) + sign(x) + [x < y]: f_x, f_y by hand on both sides (%.2g)", worst);
  int nothing[2] = { -1, -1 };
  int ds = nz_graph_derivative(g, nz_graph_op(g, NZ_GOP_ADD, sg, c), dx);
  gsl_test(!nz_graph_is_const(g, ds, &v) || v != 0.0 || nz_graph_derivative(g, s1, nothing) < 0,
           "d (sign(x) + [x > y]) is the constant 0");
  nz_graph_plan_free(p);
  /* Both branches are evaluated: select(x > 0, sqrt(x), 0) fails at x = -1. */
  int sq = nz_graph_fn(g, NZ_FN_SQRT, x), guarded = nz_graph_select(g, gt, sq, zero);
  p = nz_graph_plan_new(g, &guarded, 1);
  in[0] = -1.0;
  int node;
  gsl_test(nz_graph_eval(p, in, d) != NZ_EDOM || (nz_graph_plan_failure(p, &node, NULL, NULL, NULL), node != sq),
           "select evaluates both operands: select(x > 0, sqrt(x), 0) at x = -1 is NZ_EDOM at sqrt");
  nz_graph_plan_free(p);
  /* A NaN condition fails, on doubles and on jets. */
  int nsel = nz_graph_select(g, nz_graph_const(g, NAN), x, y);
  p = nz_graph_plan_new(g, &nsel, 1);
  in[0] = 0.5;
  nz_jet_set_constant(xj, 0.5);
  gsl_test(nz_graph_eval(p, in, d) != NZ_ENAN || nz_graph_eval_jets(p, jj, o, NULL, NULL) != NZ_ENAN,
           "select with a NaN condition is NZ_ENAN on doubles and jets");
  nz_graph_plan_free(p);
  int isel = nz_graph_select(g, y, x, zero);   /* the condition an input that is NaN */
  p = nz_graph_plan_new(g, &isel, 1);
  in[1] = NAN;
  nz_jet_set_constant(yj, NAN);
  gsl_test(nz_graph_eval(p, in, d) != NZ_ENAN || nz_graph_eval_jets(p, jj, o, NULL, NULL) != NZ_ENAN ||
           (nz_graph_plan_failure(p, &node, NULL, NULL, NULL), node != isel),
           "select on an input condition that is NaN is NZ_ENAN at the select, on doubles and jets");
  nz_graph_plan_free(p);
  nz_jet_free(xj);
  nz_jet_free(yj);
  for (int i = 0; i < 3; i++) nz_jet_free(o[i]);
  nz_graph_free(g);
}

/* ------------------------------------------------------------------ */
/* Evaluation                                                           */

static void check_doubles(void)
{
  double worst_c = 0.0, x[NIN], xs[NIN];
  int exact = 1, ok = 1;
  for (int e = 0; e < NEXPR; e++) {
    int root = record(e);
    /* A plan over every node so far: each node against its order-0 jet. */
    int n = nz_graph_size(G), *all = calloc((size_t)n, sizeof *all);
    for (int i = 0; i < n; i++) all[i] = i;
    nz_graph_plan *p = nz_graph_plan_new(G, all, n);
    double *dv = malloc((size_t)n * sizeof *dv);
    nz_jet **jo = malloc((size_t)n * sizeof *jo), *j0[NIN];
    for (int i = 0; i < n; i++) jo[i] = nz_jet_alloc(0, 0);
    for (int i = 0; i < NIN; i++) j0[i] = nz_jet_alloc(0, 0);
    for (int trial = 0; trial < 20; trial++) {
      random_point(x);
      for (int i = 0; i < NIN; i++) j0[i]->c[0] = x[i];
      ok = ok && nz_graph_eval(p, x, dv) == NZ_OK &&
           nz_graph_eval_jets(p, (const nz_jet *const *)j0, jo, NULL, NULL) == NZ_OK;
      for (int i = 0; i < n; i++) exact = exact && dv[i] == jo[i]->c[0];
      memcpy(cin, x, sizeof cin);
      memcpy(xs, x, sizeof xs);
      M = M_C;
      double want = exprs[e].f().d;
      nz_status st;
      double got = eval1(root, xs, &st);
      ok = ok && st == NZ_OK;
      worst_c = fmax(worst_c, rel(got, want));
    }
    gsl_test(!ok || !exact, "%s: every node on doubles equals its order-0 jet exactly", exprs[e].name);
    for (int i = 0; i < n; i++) nz_jet_free(jo[i]);
    for (int i = 0; i < NIN; i++) nz_jet_free(j0[i]);
    free(jo);
    free(dv);
    free(all);
    nz_graph_plan_free(p);
  }
  /* libm's pow and hypot against exp(y log x) and the scaled hypot: a few ulps */
  gsl_test(!(worst_c <= 1e-14), "%d expressions on doubles equal plain C with libm (worst %.2g)", NEXPR,
           worst_c);
}

static void check_jets(void)
{
  nz_jet *out[3];
  out[0] = nz_jet_alloc(JK, JD);
  out[1] = nz_jet_alloc(JK, JD + 1);   /* one tangent more: zero */
  out[2] = nz_jet_alloc(JK - 4, 1);    /* lower order, one tangent: truncated */
  double x[NIN];
  for (int i = 0; i < NIN; i++) jin[i] = nz_jet_alloc(JK, JD);
  for (int e = 0; e < NEXPR; e++) {
    int root = record(e), roots[3] = { root, root, root };
    nz_graph_plan *p = nz_graph_plan_new(G, roots, 3);
    double worst = 0.0, extra = 0.0, trunc = 0.0, scale = 0.0;
    int ok = 1;
    for (int trial = 0; trial < 5; trial++) {
      random_point(x);
      random_jets(jin, x);
      ok = ok && nz_graph_eval_jets(p, (const nz_jet *const *)jin, out, NULL, NULL) == NZ_OK;
      M = M_JET;
      npool = 0;
      jet_failures = 0;
      nz_jet *want = exprs[e].f().j;
      ok = ok && jet_failures == 0;
      worst = fmax(worst, jet_diff(out[0], want));
      for (int k = 0; k <= JK; k++) extra = fmax(extra, fabs(nz_jet_tangent(out[1], JD)[k]));
      for (int k = 0; k <= JK; k++) scale = fmax(scale, fabs(want->c[k]));
      for (int k = 0; k <= JK - 4; k++) {
        trunc = fmax(trunc, fabs(out[2]->c[k] - want->c[k]));
        trunc = fmax(trunc, fabs(nz_jet_tangent(out[2], 0)[k] - nz_jet_tangent(want, 0)[k]));
      }
    }
    gsl_test(!ok || !(worst <= 1e-14),
             "%s: jets of order %d with %d tangents equal direct nz_jet_* calls (%.2g)",
             exprs[e].name, JK, JD, worst);
    gsl_test(extra != 0.0 || !(trunc <= 1e-14 * scale),
             "%s: outputs of other shapes (an extra tangent is zero, order %d truncates)",
             exprs[e].name, JK - 4);
    nz_graph_plan_free(p);
  }
  for (int i = 0; i < 3; i++) nz_jet_free(out[i]);
}

/* Inputs of different shapes: a truncated series is known to the lowest
 * order, so with y of order 8 and one tangent the result must be the order-12,
 * two-tangent result cut to order 8 (tangent 1 then only comes from x).  The
 * same for the eta-part with a direction of order 8 without tangents. */
static void check_mixed_shapes(void)
{
  double x[NIN];
  nz_jet *full[NIN], *mixed[NIN], *dfull[NIN], *dmixed[NIN], *o12 = nz_jet_alloc(JK, JD),
         *o8 = nz_jet_alloc(8, JD), *d12 = nz_jet_alloc(JK, JD), *d8 = nz_jet_alloc(8, JD);
  for (int i = 0; i < NIN; i++) {
    full[i] = nz_jet_alloc(JK, JD);
    dfull[i] = nz_jet_alloc(JK, JD);
    mixed[i] = i == 1 ? nz_jet_alloc(8, 1) : full[i];
    dmixed[i] = i == 1 ? nz_jet_alloc(8, 0) : dfull[i];
  }
  random_point(x);
  random_jets(full, x);
  random_point(x);
  random_jets(dfull, x);
  /* y's tangent 1 and its direction's tangents are zero in the full jets */
  for (int k = 0; k <= JK; k++) {
    nz_jet_tangent(full[1], 1)[k] = 0.0;
    nz_jet_tangent(dfull[1], 0)[k] = nz_jet_tangent(dfull[1], 1)[k] = 0.0;
  }
  for (int d = 0; d <= 1; d++)
    for (int k = 0; k <= 8; k++) {
      mixed[1]->c[d * 9 + k] = full[1]->c[d * (JK + 1) + k];
      if (d == 0) dmixed[1]->c[k] = dfull[1]->c[k];
    }
  double worst = 0.0;
  int ok = 1;
  for (int e = 0; e < NEXPR; e++) {
    int root = record(e);
    nz_graph_plan *p = nz_graph_plan_new(G, &root, 1);
    ok = ok && nz_graph_eval_jets(p, (const nz_jet *const *)full, &o12, (const nz_jet *const *)dfull, &d12) == NZ_OK &&
         nz_graph_eval_jets(p, (const nz_jet *const *)mixed, &o8, (const nz_jet *const *)dmixed, &d8) == NZ_OK;
    for (int d = 0; d <= JD; d++)
      for (int k = 0; k <= 8; k++) {
        worst = fmax(worst, rel(o8->c[d * 9 + k], o12->c[d * (JK + 1) + k]) * (o12->c[d * (JK + 1) + k] != 0));
        worst = fmax(worst, rel(d8->c[d * 9 + k], d12->c[d * (JK + 1) + k]) * (d12->c[d * (JK + 1) + k] != 0));
        if (o12->c[d * (JK + 1) + k] == 0) worst = fmax(worst, fabs(o8->c[d * 9 + k]));
        if (d12->c[d * (JK + 1) + k] == 0) worst = fmax(worst, fabs(d8->c[d * 9 + k]));
      }
    nz_graph_plan_free(p);
  }
  gsl_test(!ok || !(worst <= 1e-15),
           "inputs of orders 12 and 8 with 2 and 1 tangents: the order-12 results cut to order 8 (%.2g)",
           worst);
  for (int i = 0; i < NIN; i++) {
    if (mixed[i] != full[i]) nz_jet_free(mixed[i]);
    if (dmixed[i] != dfull[i]) nz_jet_free(dmixed[i]);
    nz_jet_free(full[i]);
    nz_jet_free(dfull[i]);
  }
  nz_jet_free(o12);
  nz_jet_free(o8);
  nz_jet_free(d12);
  nz_jet_free(d8);
}

/* ------------------------------------------------------------------ */
/* Copies and substitutions                                             */

/* nz_graph_copy: every expression copied into a new graph computes what it
 * computes in G, and substituting a node for an input computes the
 * expression at that node's value (the input given its value directly). */
static void check_copies(void)
{
  int roots[NEXPR];
  for (int e = 0; e < NEXPR; e++) roots[e] = record(e);
  nz_graph *h = nz_graph_new();
  int copy[NEXPR];
  gsl_test(nz_graph_copy(h, G, roots, NEXPR, NULL, copy) != 0, "nz_graph_copy into a new graph returns 0");
  /* G's own nodes, built again: the same graph where they were alone */
  int n0 = nz_graph_size(G), again[NEXPR], same = 1;
  gsl_test(nz_graph_copy(G, G, roots, NEXPR, NULL, again) != 0, "nz_graph_copy of G into itself returns 0");
  for (int e = 0; e < NEXPR; e++) same = same && again[e] == roots[e];
  gsl_test(!same || nz_graph_size(G) != n0, "a copy into the same graph without substitution is the same nodes");
  /* x -> y / 2 + 1/4 in G */
  int ni = nz_graph_ninputs(G), *map = malloc((size_t)ni * sizeof *map);
  for (int i = 0; i < ni; i++) map[i] = -1;
  map[0] = nz_graph_op(G, NZ_GOP_ADD, nz_graph_op(G, NZ_GOP_MUL, nz_graph_input(G, 1), nz_graph_const(G, 0.5)),
                       nz_graph_const(G, 0.25));
  int sub[NEXPR];
  gsl_test(nz_graph_copy(G, G, roots, NEXPR, map, sub) != 0, "nz_graph_copy substituting in G returns 0");
  for (int e = 0; e < NEXPR; e++) {
    double worst_copy = 0.0, worst_sub = 0.0, x[NIN], xs[NIN];
    int ok = 1;
    for (int trial = 0; trial < 10 && ok; trial++) {
      nz_status s1, s2, s3, s4;
      random_point(x);
      memcpy(xs, x, sizeof x);
      xs[0] = x[1] * 0.5 + 0.25;
      double want = eval1(roots[e], x, &s1), at = eval1(sub[e], x, &s2), want_at = eval1(roots[e], xs, &s3);
      nz_graph *keep = G;
      G = h;
      double got = eval1(copy[e], x, &s4);
      G = keep;
      ok = !s1 && !s2 && !s3 && !s4;
      worst_copy = fmax(worst_copy, rel(got, want));
      worst_sub = fmax(worst_sub, rel(at, want_at));
    }
    gsl_test(!ok || worst_copy != 0.0, "%s: its copy in another graph gives the same doubles (%.2g)", exprs[e].name,
             worst_copy);
    gsl_test(!ok || !(worst_sub <= 4 * GSL_DBL_EPSILON), "%s: x replaced by the node y/2 + 1/4 gives f(y/2 + 1/4, y) (%.2g)",
             exprs[e].name, worst_sub);
  }
  /* refused: a root or a map entry that is not a node */
  int bad = nz_graph_size(G) + 5, out;
  gsl_test(nz_graph_copy(h, G, &bad, 1, NULL, &out) != -1, "nz_graph_copy refuses a root that is not a node");
  map[0] = nz_graph_size(h) + 7;
  gsl_test(nz_graph_copy(h, G, roots, 1, map, &out) != -1, "nz_graph_copy refuses a map entry that is not a node of dst");
  free(map);
  nz_graph_free(h);
}

/* ------------------------------------------------------------------ */
/* Derivatives                                                          */

static void check_derivatives(void)
{
  int roots[NEXPR];
  for (int e = 0; e < NEXPR; e++) roots[e] = record(e);
  int ni = nz_graph_ninputs(G), one = nz_graph_const(G, 1.0);
  int *dinput = malloc((size_t)ni * sizeof *dinput);
  double x[NIN], xp[NIN], xm[NIN];
  for (int e = 0; e < NEXPR; e++) {
    int nvar = exprs[e].f == e_pendulum ? 4 : 2, ok = 1;
    double worst = 0.0;
    for (int i = 0; i < nvar; i++) {
      for (int k = 0; k < ni; k++) dinput[k] = k == i ? one : -1;
      int d = nz_graph_derivative(G, roots[e], dinput);
      ok = ok && d >= 0;
      for (int trial = 0; trial < 10 && ok; trial++) {
        nz_status s1, s2, s3;
        random_point(x);
        double h = 1e-5 * (1 + fabs(x[i]));
        memcpy(xp, x, sizeof x);
        memcpy(xm, x, sizeof x);
        xp[i] += h;
        xm[i] -= h;
        double fd = (eval1(roots[e], xp, &s1) - eval1(roots[e], xm, &s2)) / (xp[i] - xm[i]);
        double got = eval1(d, x, &s3);
        ok = !s1 && !s2 && !s3;
        worst = fmax(worst, fabs(got - fd) / fmax(1.0, fabs(fd)));
      }
    }
    /* central differences: h^2 f''' / 6 + eps f / h, about 1e-10 here */
    gsl_test(!ok || !(worst <= 1e-7), "%s: graph derivatives agree with central differences (%.2g)",
             exprs[e].name, worst);
  }
  /* Several roots at once share the work: the same nodes as one by one. */
  for (int k = 0; k < ni; k++) dinput[k] = k == 0 ? one : -1;
  int dr[NEXPR], same = 1, n0;
  gsl_test(nz_graph_derivatives(G, roots, NEXPR, dinput, dr) != 0, "nz_graph_derivatives returns 0");
  n0 = nz_graph_size(G);
  for (int e = 0; e < NEXPR; e++) same = same && nz_graph_derivative(G, roots[e], dinput) == dr[e];
  gsl_test(!same || nz_graph_size(G) != n0,
           "nz_graph_derivatives gives the nodes of one-by-one derivatives, nothing new built");
  /* Nothing moves it: the constant 0. */
  for (int k = 0; k < ni; k++) dinput[k] = -1;
  double v;
  int d0 = nz_graph_derivative(G, roots[0], dinput);
  gsl_test(!nz_graph_is_const(G, d0, &v) || v != 0.0, "derivative with nothing moving is the constant 0");
  free(dinput);

  /* Hand derivatives, exact: f = x^3 y. */
  nz_graph *g = nz_graph_new();
  int xi = nz_graph_input(g, 0), yi = nz_graph_input(g, 1), c1 = nz_graph_const(g, 1.0);
  int f = nz_graph_op(g, NZ_GOP_MUL, nz_graph_powc(g, xi, 3.0), yi);
  int dx[2] = { c1, -1 }, dy[2] = { -1, c1 };
  int fx = nz_graph_derivative(g, f, dx), fxx = nz_graph_derivative(g, fx, dx);
  int fxy = nz_graph_derivative(g, fx, dy), fxxx = nz_graph_derivative(g, fxx, dx);
  int fyy = nz_graph_derivative(g, nz_graph_derivative(g, f, dy), dy);
  int outs[4] = { fx, fxx, fxy, fxxx };
  nz_graph_plan *p = nz_graph_plan_new(g, outs, 4);
  double worst = 0.0, got[4];
  int ok = p != NULL;
  for (int trial = 0; trial < 20 && ok; trial++) {
    double a = 4 * urand() - 2, b = 4 * urand() - 2, in[2] = { a, b };
    double want[4] = { 3 * a * a * b, 6 * a * b, 3 * a * a, 6 * b };
    ok = nz_graph_eval(p, in, got) == NZ_OK;
    for (int k = 0; k < 4; k++) worst = fmax(worst, rel(got[k], want[k]));
  }
  gsl_test(!ok || !(worst <= 4 * GSL_DBL_EPSILON),
           "x^3 y: f_x = 3x^2 y, f_xx = 6xy, f_xy = 3x^2, f_xxx = 6y to rounding (%.2g)", worst);
  gsl_test(!nz_graph_is_const(g, fyy, &v) || v != 0.0, "x^3 y: f_yy is the constant 0");
  nz_graph_plan_free(p);
  /* d/dx sin(x) exp(y) = cos(x) exp(y), the same double as C. */
  int sx = nz_graph_op(g, NZ_GOP_MUL, nz_graph_fn(g, NZ_FN_SIN, xi), nz_graph_fn(g, NZ_FN_EXP, yi));
  int dsx = nz_graph_derivative(g, sx, dx);
  nz_graph *keep = G;
  G = g;
  nz_status st;
  double in2[2] = { 0.7, -0.4 };
  double r = eval1(dsx, in2, &st);
  G = keep;
  gsl_test(st || r != cos(0.7) * exp(-0.4), "d/dx sin(x) exp(y) = cos(x) exp(y) exactly");
  nz_graph_free(g);
}

/* The eta-part of nz_graph_eval_jets against the derivative graph evaluated
 * on jets (a different path: nodes built by nz_graph_derivative, evaluated
 * without din), and against central differences on jets. */
static void check_eta(void)
{
  int roots[NEXPR];
  for (int e = 0; e < NEXPR; e++) roots[e] = record(e);
  int dirs[NIN];
  for (int i = 0; i < NIN; i++) dirs[i] = nz_graph_input(G, NIN + i);
  int ni = nz_graph_ninputs(G);
  int *dinput = malloc((size_t)ni * sizeof *dinput);
  nz_jet *all[2 * NIN], *dj[NIN], *out[1], *dout[1], *ref[1], *lo[1], *hi[1], *xp[NIN], *xm[NIN];
  for (int i = 0; i < NIN; i++) {
    jin[i] = all[i] = jin[i] ? jin[i] : nz_jet_alloc(JK, JD);
    dj[i] = all[NIN + i] = nz_jet_alloc(JK, JD);
    xp[i] = nz_jet_alloc(JK, JD);
    xm[i] = nz_jet_alloc(JK, JD);
  }
  out[0] = nz_jet_alloc(JK, JD);
  dout[0] = nz_jet_alloc(JK, JD);
  ref[0] = nz_jet_alloc(JK, JD);
  lo[0] = nz_jet_alloc(JK, JD);
  hi[0] = nz_jet_alloc(JK, JD);
  double x[NIN];
  for (int e = 0; e < NEXPR; e++) {
    for (int still = -1; still < 2; still++) {   /* input `still` does not move */
      for (int k = 0; k < ni; k++) dinput[k] = k < NIN && k != still ? dirs[k] : -1;
      int d = nz_graph_derivative(G, roots[e], dinput);
      nz_graph_plan *pf = nz_graph_plan_new(G, &roots[e], 1), *pd = nz_graph_plan_new(G, &d, 1);
      const nz_jet *din[NIN];
      double worst = 0.0, worst_fd = 0.0;
      int ok = pf && pd;
      for (int trial = 0; trial < 3 && ok; trial++) {
        random_point(x);
        random_jets(jin, x);
        random_point(x);
        random_jets(dj, x);
        for (int i = 0; i < NIN; i++) din[i] = i == still ? NULL : dj[i];
        ok = nz_graph_eval_jets(pf, (const nz_jet *const *)jin, out, din, dout) == NZ_OK &&
             nz_graph_eval_jets(pd, (const nz_jet *const *)all, ref, NULL, NULL) == NZ_OK;
        worst = fmax(worst, jet_diff(dout[0], ref[0]));
        /* central difference along the direction, coefficientwise */
        double h = 1e-5;
        int n = (JD + 1) * (JK + 1);
        for (int i = 0; i < NIN; i++)
          for (int k = 0; k < n; k++) {
            double s = din[i] ? h * din[i]->c[k] : 0.0;
            xp[i]->c[k] = jin[i]->c[k] + s;
            xm[i]->c[k] = jin[i]->c[k] - s;
          }
        ok = ok && nz_graph_eval_jets(pf, (const nz_jet *const *)xp, hi, NULL, NULL) == NZ_OK &&
             nz_graph_eval_jets(pf, (const nz_jet *const *)xm, lo, NULL, NULL) == NZ_OK;
        for (int k = 0; k < n; k++) lo[0]->c[k] = (hi[0]->c[k] - lo[0]->c[k]) / (2 * h);
        worst_fd = fmax(worst_fd, jet_diff(dout[0], lo[0]));
      }
      char which[32] = "every input moves";
      if (still >= 0) snprintf(which, sizeof which, "input %d still", still);
      gsl_test(!ok || !(worst <= 1e-13),
               "%s, %s: eta-part equals the derivative graph on jets (%.2g)", exprs[e].name,
               which, worst);
      gsl_test(!ok || !(worst_fd <= 1e-7),
               "%s, %s: eta-part equals central differences on jets (%.2g)", exprs[e].name,
               which, worst_fd);
      nz_graph_plan_free(pf);
      nz_graph_plan_free(pd);
    }
  }
  for (int i = 0; i < NIN; i++) {
    nz_jet_free(dj[i]);
    nz_jet_free(xp[i]);
    nz_jet_free(xm[i]);
  }
  nz_jet_free(out[0]);
  nz_jet_free(dout[0]);
  nz_jet_free(ref[0]);
  nz_jet_free(lo[0]);
  nz_jet_free(hi[0]);
  free(dinput);
}

/* ------------------------------------------------------------------ */
/* Series built order by order                                          */

#define SK 20

/* Coefficients 1..K of the inputs, the jets' own: in[k][i] = ji[i]->c[k]. */
static void series_run(nz_graph_plan *p, nz_jet *const *ji, int nin, int K, nz_status *st_begin,
                       nz_status *st_next, int *failed_at)
{
  double in[NIN + 1];
  for (int i = 0; i < nin; i++) in[i] = ji[i]->c[0];
  *st_next = NZ_OK;
  *failed_at = -1;
  *st_begin = nz_graph_series_begin(p, K, in);
  if (*st_begin) { *failed_at = 0; return; }
  for (int k = 1; k <= K; k++) {
    for (int i = 0; i < nin; i++) in[i] = ji[i]->c[k];
    if ((*st_next = nz_graph_series_next(p, k, in, NULL))) { *failed_at = k; return; }
  }
}

/* Every node of the graph so far, built coefficient by coefficient, against
 * nz_graph_eval_jets on jets of the same order without tangents: the same
 * recurrences, run order by order instead of node by node. */
static double series_against_jets(nz_graph *g, nz_jet **ji, int K, int *ok)
{
  int n = nz_graph_size(g), *all = calloc((size_t)n, sizeof *all);
  for (int i = 0; i < n; i++) all[i] = i;
  nz_graph_plan *p = nz_graph_plan_new(g, all, n);
  nz_jet **jo = malloc((size_t)n * sizeof *jo);
  for (int i = 0; i < n; i++) jo[i] = nz_jet_alloc(K, 0);
  nz_status sb, sn;
  int at;
  double worst = 0.0;
  *ok = *ok && nz_graph_eval_jets(p, (const nz_jet *const *)ji, jo, NULL, NULL) == NZ_OK;
  series_run(p, ji, NIN, K, &sb, &sn, &at);
  *ok = *ok && sb == NZ_OK && sn == NZ_OK && nz_graph_series_order(p) == K &&
        nz_graph_series_ties(p) == 0;
  for (int r = 0; r < n; r++) {
    const double *sr = nz_graph_series_node(p, all[r]);
    for (int k = 0; k <= K; k++) {
      double got = nz_graph_series_coef(p, r, k), want = jo[r]->c[k];
      *ok = *ok && sr && sr[k] == got;
      worst = fmax(worst, want == 0.0 ? fabs(got) : rel(got, want));
    }
  }
  *ok = *ok && isnan(nz_graph_series_coef(p, 0, K + 1)) && isnan(nz_graph_series_coef(p, n, 0));
  for (int i = 0; i < n; i++) nz_jet_free(jo[i]);
  free(jo);
  free(all);
  nz_graph_plan_free(p);
  return worst;
}

static void check_series_jets(void)
{
  nz_jet *ji[NIN];
  double x[NIN];
  for (int i = 0; i < NIN; i++) ji[i] = nz_jet_alloc(SK, 0);
  for (int e = 0; e < NEXPR; e++) {
    double worst = 0.0;
    int ok = 1;
    nz_graph *keep = G;   /* a graph of this expression alone */
    G = nz_graph_new();
    record(e);
    for (int trial = 0; trial < 5; trial++) {
      random_point(x);
      random_jets(ji, x);
      worst = fmax(worst, series_against_jets(G, ji, SK, &ok));
    }
    nz_graph_free(G);
    G = keep;
    gsl_test(!ok || !(worst <= 1e-14),
             "%s: every node built coefficient by coefficient to order %d equals the jets (%.2g)",
             exprs[e].name, SK, worst);
  }
  /* Integer powers where the power recurrence cannot go (x_0 = 0: binary
   * powering), real and negative exponents, and x^y, atan2, hypot, abs and
   * sign of a negative argument, at order 20. */
  nz_graph *g = nz_graph_new();
  int xi = nz_graph_input(g, 0), yi = nz_graph_input(g, 1), terms[12], t = 0;
  static const double pw[] = { 2, 3, 5, 7, 12, 31 };
  for (int i = 0; i < 6; i++) terms[t++] = nz_graph_powc(g, xi, pw[i]);
  terms[t++] = nz_graph_powc(g, yi, -3.0);
  terms[t++] = nz_graph_powc(g, yi, 2.5);
  terms[t++] = nz_graph_op(g, NZ_GOP_POW, yi, nz_graph_op(g, NZ_GOP_ADD, xi, yi));
  terms[t++] = nz_graph_op(g, NZ_GOP_ATAN2, xi, nz_graph_op(g, NZ_GOP_NEG, yi, -1));
  terms[t++] = nz_graph_op(g, NZ_GOP_HYPOT, xi, yi);
  terms[t++] = nz_graph_op(g, NZ_GOP_MUL, nz_graph_fn(g, NZ_FN_ABS, nz_graph_op(g, NZ_GOP_SUB, xi, yi)),
                           nz_graph_fn(g, NZ_FN_SIGN, nz_graph_op(g, NZ_GOP_SUB, xi, yi)));
  double worst = 0.0;
  int ok = 1;
  for (int trial = 0; trial < 5; trial++) {
    random_point(x);
    random_jets(ji, x);
    ji[0]->c[0] = 0.0;   /* x_0 = 0 */
    worst = fmax(worst, series_against_jets(g, ji, SK, &ok));
  }
  gsl_test(!ok || !(worst <= 1e-14),
           "x^n (n to 31) at x_0 = 0, y^-3, y^2.5, y^(x+y), atan2, hypot, |x-y| sign(x-y): coefficient by coefficient equals the jets (%.2g)",
           worst);
  /* Storage: grown once, reused for lower orders; a coefficient filled again. */
  int root = terms[t - 1];
  nz_graph_plan *p = nz_graph_plan_new(g, &root, 1);
  double in[2] = { 0.3, 0.6 }, one[2] = { 1.0, 0.5 }, o1, o2;
  nz_graph_series_begin(p, 20, in);
  const double *s20 = nz_graph_series_node(p, root);
  nz_graph_series_begin(p, 8, in);
  const double *s8 = nz_graph_series_node(p, root);
  nz_status st1 = nz_graph_series_next(p, 1, one, &o1), st2 = nz_graph_series_next(p, 1, one, &o2);
  gsl_test(s20 != s8 || st1 || st2 || o1 != o2 || nz_graph_series_order(p) != 1,
           "series storage is reused for a lower order; coefficient 1 filled twice is the same");
  gsl_test(nz_graph_series_next(p, 3, one, &o1) != NZ_EDOM || nz_graph_series_next(p, 0, one, &o1) != NZ_EDOM ||
               nz_graph_series_begin(p, -1, in) != NZ_EDOM || nz_graph_series_next(p, 1, one, &o1) != NZ_EDOM ||
               nz_graph_series_node(p, root) != NULL,
           "series: a coefficient out of turn, or next without a begin, is NZ_EDOM");
  nz_graph_series_begin(p, 2, in);
  gsl_test(nz_graph_series_next(p, 1, one, &o1) || nz_graph_series_next(p, 2, one, &o1) ||
               nz_graph_series_next(p, 3, one, &o1) != NZ_EDOM,
           "series: a coefficient beyond max_order is NZ_EDOM");
  nz_graph_plan_free(p);
  /* Ties: sign(x) at x_0 = 0 with x_1 = 1.  The jets break the tie by x_1
   * (sign 1); the series decides at coefficient 0 (sign 0) and counts it. */
  int sg = nz_graph_fn(g, NZ_FN_SIGN, xi), gt = nz_graph_cmp(g, NZ_CMP_GT, xi, yi);
  int outs[2] = { sg, gt };
  p = nz_graph_plan_new(g, outs, 2);
  double tie[2] = { 0.0, 0.0 }, off[2] = { 0.25, 0.0 };
  nz_status sb = nz_graph_series_begin(p, 3, tie);
  int ties = nz_graph_series_ties(p);
  double s0 = nz_graph_series_coef(p, 0, 0), c0 = nz_graph_series_coef(p, 1, 0);
  nz_graph_series_begin(p, 0, tie);
  int ties0 = nz_graph_series_ties(p);
  nz_graph_series_begin(p, 3, off);
  gsl_test(sb || ties != 2 || s0 != 0.0 || c0 != 0.0 || ties0 != 0 || nz_graph_series_ties(p) != 0 ||
               nz_graph_series_coef(p, 0, 0) != 1.0,
           "series: sign(x), x > y at a tie in value decide by coefficient 0 and are counted (%d ties)", ties);
  nz_graph_plan_free(p);
  nz_graph_free(g);
  for (int i = 0; i < NIN; i++) nz_jet_free(ji[i]);
}

/* Failures: the jets' status at the jets' node.  One input x with x_0 =
 * x0, x_1 = x1, x_k = 0.1 beyond, order 3. */
static void series_failure(nz_graph *g, int root, double x0, double x1, nz_status want, const char *what)
{
  nz_graph_plan *p = nz_graph_plan_new(g, &root, 1);
  nz_jet *j = nz_jet_alloc(3, 0), *o = nz_jet_alloc(3, 0);
  j->c[0] = x0;
  j->c[1] = x1;
  j->c[2] = j->c[3] = 0.1;
  nz_jet *ji[1] = { j };
  int jnode, snode, at;
  nz_status sj = nz_graph_eval_jets(p, (const nz_jet *const *)ji, &o, NULL, NULL), sb, sn;
  nz_graph_plan_failure(p, &jnode, NULL, NULL, NULL);
  series_run(p, ji, 1, 3, &sb, &sn, &at);
  nz_graph_plan_failure(p, &snode, NULL, NULL, NULL);
  nz_status ss = sb ? sb : sn;
  gsl_test(sj != want || ss != want || jnode != snode,
           "series: %s is status %d at node %d (at coefficient %d), as the jets (%d at node %d)", what, ss,
           snode, at, sj, jnode);
  nz_jet_free(j);
  nz_jet_free(o);
  nz_graph_plan_free(p);
}

static void check_series_failures(void)
{
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0), one = nz_graph_const(g, 1.0);
  int sx = nz_graph_fn(g, NZ_FN_SIN, x);
  series_failure(g, nz_graph_op(g, NZ_GOP_ADD, sx, nz_graph_fn(g, NZ_FN_LOG, x)), -1.0, 1.0, NZ_EDOM, "sin(x) + log(x), x_0 = -1");
  series_failure(g, nz_graph_fn(g, NZ_FN_LOG, x), 0.0, 1.0, NZ_EDOM, "log(x), x_0 = 0");
  series_failure(g, nz_graph_fn(g, NZ_FN_SQRT, x), 0.0, 1.0, NZ_ESING, "sqrt(x), x_0 = 0");
  series_failure(g, nz_graph_fn(g, NZ_FN_SQRT, x), -0.5, 1.0, NZ_EDOM, "sqrt(x), x_0 = -0.5");
  series_failure(g, nz_graph_op(g, NZ_GOP_DIV, one, x), 0.0, 1.0, NZ_EZERODIV, "1/x, x_0 = 0");
  series_failure(g, nz_graph_fn(g, NZ_FN_ASIN, x), 1.0, -1.0, NZ_ESING, "asin(x), x_0 = 1");
  series_failure(g, nz_graph_fn(g, NZ_FN_ACOS, x), 1.5, 0.0, NZ_EDOM, "acos(x), x_0 = 1.5");
  series_failure(g, nz_graph_fn(g, NZ_FN_ABS, x), 0.0, 1.0, NZ_ESING, "|x|, x_0 = 0");
  series_failure(g, nz_graph_powc(g, x, 2.5), 0.0, 1.0, NZ_ESING, "x^2.5, x_0 = 0");
  series_failure(g, nz_graph_powc(g, x, 2.5), -1.0, 1.0, NZ_EDOM, "x^2.5, x_0 = -1");
  series_failure(g, nz_graph_powc(g, x, -2.0), 0.0, 1.0, NZ_EZERODIV, "x^-2, x_0 = 0");
  series_failure(g, nz_graph_op(g, NZ_GOP_POW, x, x), 0.0, 1.0, NZ_ESING, "x^x, x_0 = 0");
  series_failure(g, nz_graph_op(g, NZ_GOP_POW, x, x), -2.0, 1.0, NZ_EDOM, "x^x, x_0 = -2");
  series_failure(g, nz_graph_op(g, NZ_GOP_ATAN2, x, x), 0.0, 1.0, NZ_ESING, "atan2(x, x), x_0 = 0");
  series_failure(g, nz_graph_op(g, NZ_GOP_HYPOT, x, sx), 0.0, 1.0, NZ_ESING, "hypot(x, sin x), x_0 = 0");
  series_failure(g, nz_graph_fn(g, NZ_FN_EXP, x), 700.0, 1e10, NZ_ERANGE, "exp(x), x_0 = 700, x_1 = 1e10");
  series_failure(g, nz_graph_op(g, NZ_GOP_MUL, sx, x), 0.5, NAN, NZ_ENAN, "sin(x) x, x_1 = NaN");
  series_failure(g, nz_graph_cmp(g, NZ_CMP_GT, x, one), NAN, 0.0, NZ_ENAN, "x > 1, x_0 = NaN");
  nz_graph_free(g);
}

/* The Taylor series of the solution of x' = f(t, x), x(t0) = x0, as the
 * integrator of the next issue will build it: inputs t (0) and x_i (1 + i),
 * outputs f_i; x_{k+1} = f_k / (k + 1) from coefficient k of f, which
 * nz_graph_series_next fills from x_0..x_k.  xs[i (K + 1) + k]. */
static nz_status taylor(nz_graph *g, const int *f, int n, double t0, const double *x0, int K, double *xs)
{
  nz_graph_plan *p = nz_graph_plan_new(g, f, n);
  double in[8], fk[8];
  nz_status st = NZ_OK;
  in[0] = t0;
  for (int i = 0; i < n; i++) in[1 + i] = xs[i * (K + 1)] = x0[i];
  for (int k = 0; k < K && !st; k++) {
    st = k == 0 ? nz_graph_series_begin(p, K - 1, in) : nz_graph_series_next(p, k, in, fk);
    for (int i = 0; i < n && !st; i++) {
      double fi = k == 0 ? nz_graph_series_coef(p, i, 0) : fk[i];
      in[1 + i] = xs[i * (K + 1) + k + 1] = fi / (k + 1);
    }
    in[0] = k == 0 ? 1.0 : 0.0;   /* t = t0 + (t - t0) */
  }
  nz_graph_plan_free(p);
  return st;
}

static double ode_cos(int k) { double d[4] = { cos(0.3), -sin(0.3), -cos(0.3), sin(0.3) }; return d[k % 4] / gsl_sf_fact((unsigned)k); }
static double ode_log1p(int k) { return k == 0 ? 0.0 : (k % 2 ? 1.0 : -1.0) / k; }
static double ode_exp_t2(int k) { return k % 2 ? 0.0 : 1.0 / gsl_sf_fact((unsigned)(k / 2)); }
static double ode_square(int k) { return k == 0 || k == 1 ? 1.0 : k == 2 ? 0.25 : 0.0; }
static double ode_pow(int k) { return (k + 1) / pow(2.0, k); }
/* tan t = sum_{m>=1} 2 (4^m - 1) zeta(2m) / pi^(2m) t^(2m-1) (Bernoulli numbers through zeta) */
static double ode_tan(int k) { return k % 2 == 0 ? 0.0 : 2.0 * (pow(4.0, (k + 1) / 2) - 1.0) * gsl_sf_zeta_int(k + 1) / pow(M_PI, k + 1); }

static void check_series_taylor(void)
{
  enum { TK = 30 };
  nz_graph *g = nz_graph_new();
  int t = nz_graph_input(g, 0), x = nz_graph_input(g, 1), v = nz_graph_input(g, 2);
  int one = nz_graph_const(g, 1.0), two = nz_graph_const(g, 2.0);
  struct { const char *what; int f[2], n; double x0[2]; double (*want)(int); } odes[] = {
    { "x' = v, v' = -x, x(0) = cos 0.3, v(0) = -sin 0.3: cos(0.3 + t)",
      { v, nz_graph_op(g, NZ_GOP_NEG, x, -1) }, 2, { cos(0.3), -sin(0.3) }, ode_cos },
    { "x' = exp(-x), x(0) = 0: log(1 + t)", { nz_graph_fn(g, NZ_FN_EXP, nz_graph_op(g, NZ_GOP_NEG, x, -1)) }, 1, { 0.0 }, ode_log1p },
    { "x' = 1 / (1 + t), x(0) = 0: log(1 + t)", { nz_graph_op(g, NZ_GOP_DIV, one, nz_graph_op(g, NZ_GOP_ADD, one, t)) }, 1, { 0.0 }, ode_log1p },
    { "x' = 2 t x, x(0) = 1: exp(t^2)", { nz_graph_op(g, NZ_GOP_MUL, nz_graph_op(g, NZ_GOP_MUL, two, t), x) }, 1, { 1.0 }, ode_exp_t2 },
    { "x' = sqrt(x), x(0) = 1: (1 + t/2)^2", { nz_graph_fn(g, NZ_FN_SQRT, x) }, 1, { 1.0 }, ode_square },
    { "x' = x^1.5, x(0) = 1: (1 - t/2)^-2", { nz_graph_powc(g, x, 1.5) }, 1, { 1.0 }, ode_pow },
    { "x' = 1 + x^2, x(0) = 0: tan t", { nz_graph_op(g, NZ_GOP_ADD, one, nz_graph_powc(g, x, 2.0)) }, 1, { 0.0 }, ode_tan },
  };
  double xs[2 * (TK + 1)];
  for (size_t e = 0; e < sizeof odes / sizeof odes[0]; e++) {
    nz_status st = taylor(g, odes[e].f, odes[e].n, 0.0, odes[e].x0, TK, xs);
    double worst = 0.0;
    for (int k = 0; k <= TK; k++) {
      double want = odes[e].want(k);
      worst = fmax(worst, want == 0.0 ? fabs(xs[k]) : rel(xs[k], want));
    }
    /* each x_k passes through k recurrences of O(k) terms: a few hundred ulps */
    gsl_test(st || !(worst <= 1e-13), "Taylor series to order %d by nz_graph_series_next, %s (%.2g)", TK,
             odes[e].what, worst);
  }
  /* x' = -x^2 + sin t, x(0) = 0.5 (no closed form): against Picard's
   * iteration on whole jets, x <- x(0) + integral of f(t, x), each pass
   * exact to one order more (nz_graph_eval_jets, no series_next). */
  int fs = nz_graph_op(g, NZ_GOP_SUB, nz_graph_fn(g, NZ_FN_SIN, t), nz_graph_powc(g, x, 2.0));
  nz_status st = taylor(g, &fs, 1, 0.0, (double[]){ 0.5 }, TK, xs);
  nz_graph_plan *p = nz_graph_plan_new(g, &fs, 1);
  nz_jet *jt = nz_jet_alloc(TK, 0), *jx = nz_jet_alloc(TK, 0), *jf = nz_jet_alloc(TK, 0);
  const nz_jet *jin3[3] = { jt, jx, NULL };
  nz_jet_set_variable(jt, 0.0, -1);
  nz_jet_set_constant(jx, 0.5);
  for (int pass = 0; pass <= TK && !st; pass++) {
    st = nz_graph_eval_jets(p, jin3, &jf, NULL, NULL);
    for (int k = 0; k < TK; k++) jx->c[k + 1] = jf->c[k] / (k + 1);
  }
  double worst = 0.0;
  for (int k = 0; k <= TK; k++) worst = fmax(worst, jx->c[k] == 0.0 ? fabs(xs[k]) : rel(xs[k], jx->c[k]));
  gsl_test(st || !(worst <= 1e-14),
           "Taylor series to order %d by nz_graph_series_next, x' = -x^2 + sin t, x(0) = 0.5: Picard's iteration on jets (%.2g)",
           TK, worst);
  nz_jet_free(jt);
  nz_jet_free(jx);
  nz_jet_free(jf);
  nz_graph_plan_free(p);
  nz_graph_free(g);
}

/* ns per node per coefficient: a wide 50-node plan of + - * and sin, series
 * to order 20 built coefficient by coefficient, against the same plan on
 * jets of order 20 (which recompute every order). */
static void time_series(void)
{
  nz_graph *g = nz_graph_new();
  int ids[64], n = 0, half = nz_graph_const(g, 0.5), outs[4];
  for (int i = 0; i < 4; i++) ids[n++] = nz_graph_input(g, i);
  nz_graph_plan *p = NULL;
  while (!p || nz_graph_plan_nodes(p) < 50) {
    int a = ids[n - 1 - (int)(urand() * (n < 8 ? n : 8))], b = ids[(int)(urand() * n)], k = (int)(urand() * 10), z;
    if (k >= 8) z = nz_graph_fn(g, NZ_FN_SIN, nz_graph_op(g, NZ_GOP_ADD, a, b));
    else if (k < 4) z = nz_graph_op(g, NZ_GOP_MUL, a, b);
    else if (k < 6) z = nz_graph_op(g, NZ_GOP_MUL, nz_graph_op(g, NZ_GOP_ADD, a, b), half);
    else z = nz_graph_op(g, NZ_GOP_MUL, nz_graph_op(g, NZ_GOP_SUB, a, b), half);
    ids[n++] = z;
    for (int r = 0; r < 4; r++) outs[r] = ids[n - 1 - r];
    nz_graph_plan_free(p);
    p = nz_graph_plan_new(g, outs, 4);
  }
  enum { TO = 20 };
  double in[4], ink[4], out[4], sink = 0.0, best = 1e300, bestj = 1e300;
  nz_jet *ji[4], *jo[4];
  for (int i = 0; i < 4; i++) {
    ji[i] = nz_jet_alloc(TO, 0);
    jo[i] = nz_jet_alloc(TO, 0);
    for (int k = 0; k <= TO; k++) ji[i]->c[k] = (2 * urand() - 1) * pow(0.5, k);
    in[i] = ji[i]->c[0];
  }
  struct timespec t0, t1;
  for (int rep = 0; rep < 10; rep++) {
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (int r = 0; r < 200; r++) {
      nz_graph_series_begin(p, TO, in);
      for (int k = 1; k <= TO; k++) {
        for (int i = 0; i < 4; i++) ink[i] = ji[i]->c[k];
        nz_graph_series_next(p, k, ink, out);
      }
      sink += out[0];
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    best = fmin(best, ((double)(t1.tv_sec - t0.tv_sec) * 1e9 + (double)(t1.tv_nsec - t0.tv_nsec)) / 200);
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (int r = 0; r < 200; r++) nz_graph_eval_jets(p, (const nz_jet *const *)ji, jo, NULL, NULL);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    bestj = fmin(bestj, ((double)(t1.tv_sec - t0.tv_sec) * 1e9 + (double)(t1.tv_nsec - t0.tv_nsec)) / 200);
  }
  int m = nz_graph_plan_nodes(p);
  printf("# timing (not a test): %d-node plan (+ - * sin), series to order %d coefficient by coefficient: "
         "%.0f ns, %.2f ns per node per coefficient; the same plan on jets of order %d: %.0f ns%s\n",
         m, TO, best, best / (m * (TO + 1.0)), TO, bestj, isfinite(sink) ? "" : " (!)");
  for (int i = 0; i < 4; i++) {
    nz_jet_free(ji[i]);
    nz_jet_free(jo[i]);
  }
  nz_graph_plan_free(p);
  nz_graph_free(g);
}

/* ------------------------------------------------------------------ */
/* Failures                                                             */

static void expect_failure(nz_graph *g, int root, double xin, double good, nz_status want,
                           int want_node, nz_gop want_op, double want_operand, const char *what)
{
  nz_graph_plan *p = nz_graph_plan_new(g, &root, 1);
  double in[1] = { xin }, out[1];
  nz_jet *j = nz_jet_alloc(3, 1), *o = nz_jet_alloc(3, 1);
  nz_jet_set_variable(j, xin, 0);
  int node;
  nz_gop op;
  nz_jet_fn fn;
  double operand;
  nz_status st = nz_graph_eval(p, in, out);
  nz_graph_plan_failure(p, &node, &op, &fn, &operand);
  gsl_test(st != want || node != want_node || op != want_op ||
               !(operand == want_operand || (isnan(operand) && isnan(want_operand))),
           "%s on doubles: status %d, node %d (%s), operand %g", what, st, node, nz_gop_names[op], operand);
  const nz_jet *jin1[1] = { j };
  st = nz_graph_eval_jets(p, jin1, &o, NULL, NULL);
  nz_graph_plan_failure(p, &node, &op, &fn, &operand);
  gsl_test(st != want || node != want_node || op != want_op,
           "%s on jets of order 3: status %d, node %d (%s)", what, st, node, nz_gop_names[op]);
  /* A later good evaluation clears the failure. */
  in[0] = good;
  st = nz_graph_eval(p, in, out);
  nz_graph_plan_failure(p, &node, NULL, NULL, NULL);
  gsl_test(st != NZ_OK || node != -1, "%s: then x = %g evaluates, no failure kept", what, good);
  nz_jet_free(j);
  nz_jet_free(o);
  nz_graph_plan_free(p);
}

static void st_check(nz_status on_doubles, nz_status on_jets)
{
  gsl_test(on_doubles != NZ_ENAN || on_jets != NZ_ENAN,
           "an output that is a NaN constant is NZ_ENAN on doubles and jets (%d, %d)", on_doubles,
           on_jets);
}

static void check_failures(void)
{
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0);
  int lg = nz_graph_fn(g, NZ_FN_LOG, x);
  int f1 = nz_graph_op(g, NZ_GOP_ADD, nz_graph_fn(g, NZ_FN_SIN, x), lg);
  expect_failure(g, f1, -1.0, 0.5, NZ_EDOM, lg, NZ_GOP_FN, -1.0, "sin(x) + log(x) at x = -1 is NZ_EDOM at log");
  int inv = nz_graph_op(g, NZ_GOP_DIV, nz_graph_const(g, 1.0), x);
  expect_failure(g, inv, 0.0, 0.5, NZ_EZERODIV, inv, NZ_GOP_DIV, 1.0, "1/x at x = 0 is NZ_EZERODIV");
  int ex = nz_graph_fn(g, NZ_FN_EXP, x);
  int f2 = nz_graph_fn(g, NZ_FN_LOG, nz_graph_op(g, NZ_GOP_SUB, nz_graph_const(g, 1.0), ex));
  expect_failure(g, f2, 800.0, -0.5, NZ_ERANGE, ex, NZ_GOP_FN, 800.0,
                 "log(1 - exp(x)) at x = 800 fails first at exp (NZ_ERANGE), not at log");
  int sn = nz_graph_fn(g, NZ_FN_SIN, x);
  int f3 = nz_graph_op(g, NZ_GOP_MUL, sn, x);
  expect_failure(g, f3, NAN, 0.5, NZ_ENAN, sn, NZ_GOP_FN, NAN, "sin(x) x at x = NaN is NZ_ENAN at sin");
  int sq = nz_graph_fn(g, NZ_FN_SQRT, x);
  expect_failure(g, sq, -2.0, 0.5, NZ_EDOM, sq, NZ_GOP_FN, -2.0, "sqrt(-2) is NZ_EDOM");
  int as = nz_graph_fn(g, NZ_FN_ASIN, x);
  expect_failure(g, as, 1.5, 0.5, NZ_EDOM, as, NZ_GOP_FN, 1.5, "asin(1.5) is NZ_EDOM");
  /* sqrt at 0: a value on doubles, singular on jets of order >= 1 (as the jets). */
  nz_graph_plan *p = nz_graph_plan_new(g, &sq, 1);
  double in[1] = { 0.0 }, out[1];
  nz_jet *j = nz_jet_alloc(2, 0), *o = nz_jet_alloc(2, 0);
  nz_jet_set_variable(j, 0.0, -1);
  const nz_jet *jj[1] = { j };
  gsl_test(nz_graph_eval(p, in, out) != NZ_OK || out[0] != 0.0, "sqrt(0) = 0 on doubles");
  gsl_test(nz_graph_eval_jets(p, jj, &o, NULL, NULL) != NZ_ESING, "sqrt(0 + t) is NZ_ESING on jets");
  jj[0] = NULL;
  gsl_test(nz_graph_eval_jets(p, jj, &o, NULL, NULL) != NZ_EDOM, "a used input without a jet is NZ_EDOM");
  /* A non-finite constant (from a Lua upvalue, say) is reported, not returned. */
  int nanc = nz_graph_const(g, NAN);
  nz_graph_plan *pn = nz_graph_plan_new(g, &nanc, 1);
  int node;
  nz_gop op;
  st_check(nz_graph_eval(pn, in, out), nz_graph_eval_jets(pn, jj, &o, NULL, NULL));
  nz_graph_plan_failure(pn, &node, &op, NULL, NULL);
  gsl_test(node != nanc || op != NZ_GOP_CONST, "the failure names the constant node");
  nz_graph_plan_free(pn);
  nz_jet_free(j);
  nz_jet_free(o);
  nz_graph_plan_free(p);
  nz_graph_free(g);
}

/* ------------------------------------------------------------------ */
/* Plans over part of a graph; timing                                   */

/* A random graph of about 1000 nodes (test_util.h). */
static int chain_graph(nz_graph *g, int sines, int spread, int *ids, int cap)
{
  return test_random_graph(g, &rng, 1000, sines, spread, ids, cap);
}

static void time_plan(nz_graph *g, const int *ids, int n, const char *what)
{
  int outs[32];
  for (int i = 0; i < 32; i++) outs[i] = ids[n - 1 - i];   /* the 32 latest */
  nz_graph_plan *p = nz_graph_plan_new(g, outs, 32);
  double in[8], out[32], sink = 0.0, best = 1e300;
  int reps = 20000;
  struct timespec t0, t1;
  for (int i = 0; i < 8; i++) in[i] = 2 * urand() - 1;
  for (int rep = 0; rep < 10; rep++) {   /* best of 10: the machine is shared */
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (int r = 0; r < reps / 10; r++) {
      in[0] = 0.5 + 1e-9 * r;
      nz_graph_eval(p, in, out);
      sink += out[0];
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double ns = ((double)(t1.tv_sec - t0.tv_sec) * 1e9 + (double)(t1.tv_nsec - t0.tv_nsec)) / (reps / 10);
    best = fmin(best, ns);
  }
  printf("# timing (not a test): %s, %d-node plan on doubles: %.0f ns per evaluation, %.2f ns per node%s\n",
         what, nz_graph_plan_nodes(p), best, best / nz_graph_plan_nodes(p), isfinite(sink) ? "" : " (!)");
  nz_graph_plan_free(p);
}

static void check_plans_and_time(void)
{
  nz_graph *g = nz_graph_new();
  int ids[1000], n = chain_graph(g, 1, 1, ids, 1000);
  int last = ids[n - 1], early = ids[20], outs[2] = { last, early };
  nz_graph_plan *small = nz_graph_plan_new(g, &early, 1);
  nz_graph_plan *p2 = nz_graph_plan_new(g, outs, 2);
  gsl_test(!small || nz_graph_plan_nodes(small) > early + 1 || nz_graph_plan_noutputs(p2) != 2,
           "a plan holds only the nodes its outputs need (%d of %d)", nz_graph_plan_nodes(small),
           nz_graph_size(g));
  double in[8], out[2], ref = 0;
  for (int i = 0; i < 8; i++) in[i] = 2 * urand() - 1;
  nz_status st = nz_graph_eval(p2, in, out);
  nz_graph_eval(small, in, &ref);
  gsl_test(st || out[1] != ref, "two plans over one graph agree on a shared node");
  nz_graph_plan_free(small);
  nz_graph_plan_free(p2);
  nz_graph_free(g);
  static const struct { int sines, spread; const char *what; } shapes[] = {
    { 0, 1, "a chain of + - * (each node waits for the previous)" },
    { 0, 16, "a wide graph of + - *" },
    { 1, 16, "a wide graph of + - * and sin" },
  };
  for (int k = 0; k < 3; k++) {
    g = nz_graph_new();
    n = chain_graph(g, shapes[k].sines, shapes[k].spread, ids, 1000);
    time_plan(g, ids, n, shapes[k].what);
    nz_graph_free(g);
  }
  /* Jets: the double pendulum's T at order 12 with 2 tangents, with and
   * without a state direction. */
  int root = record(E_PENDULUM);
  nz_graph_plan *p = nz_graph_plan_new(G, &root, 1);
  nz_jet *j[NIN], *dj[NIN], *o = nz_jet_alloc(JK, JD), *d = nz_jet_alloc(JK, JD);
  double x[NIN];
  for (int i = 0; i < NIN; i++) {
    j[i] = nz_jet_alloc(JK, JD);
    dj[i] = nz_jet_alloc(JK, JD);
  }
  random_point(x);
  random_jets(j, x);
  random_jets(dj, x);
  for (int with = 0; with < 2; with++) {
    double best = 1e300;
    struct timespec t0, t1;
    for (int rep = 0; rep < 10; rep++) {
      clock_gettime(CLOCK_MONOTONIC, &t0);
      for (int r = 0; r < 200; r++)
        nz_graph_eval_jets(p, (const nz_jet *const *)j, &o, with ? (const nz_jet *const *)dj : NULL, &d);
      clock_gettime(CLOCK_MONOTONIC, &t1);
      best = fmin(best, ((double)(t1.tv_sec - t0.tv_sec) * 1e9 + (double)(t1.tv_nsec - t0.tv_nsec)) / 200);
    }
    printf("# timing (not a test): double pendulum T (%d nodes) on jets of order %d with %d tangents%s: %.0f ns\n",
           nz_graph_plan_nodes(p), JK, JD, with ? " and a state direction" : "", best);
  }
  for (int i = 0; i < NIN; i++) {
    nz_jet_free(j[i]);
    nz_jet_free(dj[i]);
  }
  nz_jet_free(o);
  nz_jet_free(d);
  nz_graph_plan_free(p);
}

/* The value of node x on doubles at inputs in[] (NAN when it fails). */
static double value_at(nz_graph *g, int x, const double *in)
{
  double v = NAN;
  nz_graph_plan *p = nz_graph_plan_new(g, &x, 1);
  if (p && nz_graph_eval(p, in, &v) != NZ_OK) v = NAN;
  nz_graph_plan_free(p);
  return v;
}

static int same_bits(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

/* An exact graph computes what IEEE arithmetic computes, zeros with their
 * signs; x^y with a folded exponent keeps x^y's domain. */
static void check_exact(void)
{
  nz_graph *g = nz_graph_new();
  nz_graph_set_exact(g, 1);
  int x = nz_graph_input(g, 0), y = nz_graph_input(g, 1);
  int pz = nz_graph_const(g, 0.0), mz = nz_graph_const(g, -0.0), m1 = nz_graph_const(g, -1.0);
  int xp = nz_graph_op(g, NZ_GOP_MUL, x, pz), xm = nz_graph_op(g, NZ_GOP_MUL, x, mz);
  int a1 = nz_graph_op(g, NZ_GOP_ATAN2, xp, m1), a2 = nz_graph_op(g, NZ_GOP_ATAN2, xm, m1);
  int s0 = nz_graph_op(g, NZ_GOP_ADD, xm, pz), n0 = nz_graph_op(g, NZ_GOP_SUB, pz, y);
  int z0 = nz_graph_op(g, NZ_GOP_ADD, pz, xm);
  int ok = 1;
  static const double xs[] = { 1.3, -1.3, 0.0, -0.0 };
  for (int i = 0; i < 4; i++)
    for (int j = 0; j < 4; j++) {
      double in[2] = { xs[i], xs[j] }, X = xs[i], Y = xs[j];
      volatile double zero = 0.0, mzero = -0.0;
      ok = ok && same_bits(value_at(g, a1, in), atan2(X * zero, -1.0)) &&
           same_bits(value_at(g, a2, in), atan2(X * mzero, -1.0)) &&
           same_bits(value_at(g, s0, in), X * mzero + zero) && same_bits(value_at(g, n0, in), zero - Y) &&
           same_bits(value_at(g, z0, in), zero + X * mzero);
    }
  gsl_test(!ok, "exact: x * 0, x * (-0), x*(-0) + 0, 0 - y and their atan2 as IEEE computes them, zeros' signs too");
  gsl_test(nz_graph_op(g, NZ_GOP_ADD, x, mz) != x || nz_graph_op(g, NZ_GOP_SUB, x, pz) != x ||
           nz_graph_nodes(g)[nz_graph_op(g, NZ_GOP_SUB, mz, x)].op != NZ_GOP_NEG,
           "exact: x + (-0) = x - 0 = x and (-0) - x = -x, which IEEE computes exactly");
  /* no like terms: x - 0.3 x - 0.7 x is the rounding of its three steps */
  int t3 = nz_graph_op(g, NZ_GOP_SUB, nz_graph_op(g, NZ_GOP_SUB, x, nz_graph_op(g, NZ_GOP_MUL, nz_graph_const(g, 0.3), x)),
                       nz_graph_op(g, NZ_GOP_MUL, nz_graph_const(g, 0.7), x));
  double in13[2] = { 1.3, 2.0 };
  volatile double X = 1.3;
  gsl_test(!same_bits(value_at(g, t3, in13), X - 0.3 * X - 0.7 * X) || value_at(g, t3, in13) == 0.0,
           "exact: x - 0.3 x - 0.7 x at x = 1.3 is %.3g, as computed step by step (not 0)", value_at(g, t3, in13));
  /* a traced exponent folded to a constant keeps x^y: a negative base fails */
  int e = nz_graph_op(g, NZ_GOP_POW, y, nz_graph_op(g, NZ_GOP_SUB, x, x));
  double neg[2] = { 0.5, -1.0 };
  gsl_test(nz_graph_nodes(g)[e].op != NZ_GOP_POW || !isnan(value_at(g, e, neg)),
           "exact: y^(x - x) stays y^y' and fails at y = -1, as x^y on jets does");
  nz_graph_free(g);
}

/* A simplification drops only what is defined everywhere: log(y) * 0,
 * log(y) - log(y), cmp(l, l), select with a constant condition or equal
 * branches, l^0 keep the log, which fails at y = -1. */
static void check_drops(void)
{
  nz_graph *g = nz_graph_new();
  int x = nz_graph_input(g, 0), y = nz_graph_input(g, 1), l = nz_graph_fn(g, NZ_FN_LOG, y);
  int zero = nz_graph_const(g, 0.0), one = nz_graph_const(g, 1.0), k2 = nz_graph_const(g, 2.0);
  int c = nz_graph_cmp(g, NZ_CMP_GT, x, zero);
  int kept[] = {
    nz_graph_op(g, NZ_GOP_MUL, l, zero), nz_graph_op(g, NZ_GOP_SUB, l, l), nz_graph_cmp(g, NZ_CMP_GE, l, l),
    nz_graph_select(g, one, x, l), nz_graph_select(g, zero, l, x), nz_graph_powc(g, l, 0.0),
    nz_graph_op(g, NZ_GOP_SUB, nz_graph_op(g, NZ_GOP_MUL, k2, l), nz_graph_op(g, NZ_GOP_MUL, k2, l)),
    nz_graph_select(g, nz_graph_cmp(g, NZ_CMP_GT, l, zero), x, x),
  };
  double bad[2] = { 0.5, -1.0 }, good[2] = { 0.5, 2.0 };
  int ok = 1;
  for (size_t i = 0; i < sizeof kept / sizeof kept[0]; i++)
    ok = ok && !nz_graph_is_const(g, kept[i], NULL) && isnan(value_at(g, kept[i], bad)) &&
         !isnan(value_at(g, kept[i], good));
  gsl_test(!ok, "drops: log(y) 0, l - l, cmp(l, l), select(1, x, l), select(0, l, x), l^0, 2l - 2l, "
           "select(l > 0, x, x) fail at y = -1 and answer at y = 2");
  /* what is defined everywhere still goes */
  gsl_test(nz_graph_op(g, NZ_GOP_MUL, x, zero) != zero || nz_graph_op(g, NZ_GOP_SUB, x, x) != zero ||
           nz_graph_select(g, one, x, y) != x || nz_graph_select(g, c, y, y) != y || nz_graph_powc(g, x, 0.0) != one,
           "drops: x 0, x - x, select(1, x, y), select(c, y, y), x^0 of inputs still simplify");
  gsl_test(!nz_graph_total(g, nz_graph_op(g, NZ_GOP_MUL, nz_graph_fn(g, NZ_FN_SIN, x), y)) ||
           nz_graph_total(g, nz_graph_fn(g, NZ_FN_ABS, x)) || nz_graph_total(g, nz_graph_fn(g, NZ_FN_EXP, x)) ||
           nz_graph_total(g, nz_graph_op(g, NZ_GOP_DIV, one, x)),
           "total: sin(x) y is defined everywhere; abs (singular at 0), exp (overflow), 1/x are not");
  nz_graph_free(g);
}

/* The guards of a plan: ties of cmp and sign and singular points of the
 * smooth roots fire exactly there, never for fixed inputs. */
static void check_guards(void)
{
  nz_graph *g = nz_graph_new();
  int t = nz_graph_input(g, 0), p = nz_graph_input(g, 1), x = nz_graph_input(g, 2);
  int zero = nz_graph_const(g, 0.0);
  int tie = nz_graph_select(g, nz_graph_cmp(g, NZ_CMP_GT, t, zero), x, zero);
  int sg = nz_graph_op(g, NZ_GOP_MUL, nz_graph_fn(g, NZ_FN_SIGN, x), x);
  int fixed = nz_graph_select(g, nz_graph_cmp(g, NZ_CMP_GT, p, zero), x, zero);
  int sq = nz_graph_op(g, NZ_GOP_MUL, nz_graph_powc(g, x, 1.5), nz_graph_fn(g, NZ_FN_SQRT, t));
  int outs[] = { tie, sg, fixed, sq };
  int smooth[] = { sq };
  nz_graph_guards *gd = nz_graph_guards_new(g, outs, 4, smooth, 1, 1, 1);
  int n = nz_graph_guards_count(gd), all[16];
  memcpy(all, outs, sizeof outs);
  memcpy(all + 4, nz_graph_guards_nodes(gd), (size_t)n * sizeof(int));
  nz_graph_plan *pl = nz_graph_plan_new(g, all, 4 + n);
  static const struct { double t, p, x; int fire; } cases[] = {
    { 0.5, 1.0, 0.7, 0 }, { 0.0, 1.0, 0.7, 1 }, { 0.5, 1.0, 0.0, 1 }, { 0.5, 0.0, 0.7, 0 },
    { 0.5, -1.0, 0.7, 0 }, { 1e-300, 1.0, 1e-300, 0 },
  };
  int ok = n == 3 && pl;   /* cmp(t, 0), sign(x), x^1.5, sqrt(t) read t, 0 and x */
  for (size_t i = 0; ok && i < sizeof cases / sizeof cases[0]; i++) {
    double in[3] = { cases[i].t, cases[i].p, cases[i].x }, out[16];
    const char *what = NULL;
    ok = nz_graph_eval(pl, in, out) == NZ_OK && nz_graph_guards_fire(gd, out + 4, &what) == cases[i].fire &&
         (!cases[i].fire || what != NULL);
  }
  gsl_test(!ok, "guards: a tie of cmp(t, 0) at t = 0, of sign(x) at x = 0, x^1.5 and sqrt(t) at 0 hand "
           "the evaluation to the jets; cmp(p, 0) on a fixed input never does (%d values read)", n);
  nz_graph_plan_free(pl);
  nz_graph_guards_free(gd);
  nz_graph_free(g);
}

/* Branches decided by rounding (graph_rounding.h).  With w = 1.3 the sum
 * w - 0.3 w - 0.7 w is 0 in real arithmetic and a residue in doubles; its
 * running bound, by hand: 0.3 w and 0.7 w each carry u |value|, their
 * differences add u |value| each, so the bound is at least u (0.39 + 0.91 +
 * 0.91) and covers the residue; atan2 of it with x = -1 is on the cut.  The
 * same with 0.69 w leaves 0.013, far from its rounding: no branch (the
 * graph built exact, as a recording is: gathering like terms would fold
 * the first sum to 0 itself).  A
 * comparison q > 0.5 at q = 0.5 + 1e-12 is not rounding's, but lies within a
 * tolerance of 1e-10 of its switch. */
static void check_rounding(void)
{
  nz_graph *g = nz_graph_new();
  nz_graph_set_exact(g, 1);       /* as a user's function is recorded: no like terms gathered */
  int w = nz_graph_input(g, 0), q = nz_graph_input(g, 1);
  int c3 = nz_graph_const(g, 0.3), c7 = nz_graph_const(g, 0.7), c69 = nz_graph_const(g, 0.69), m1 = nz_graph_const(g, -1.0);
  int r = nz_graph_op(g, NZ_GOP_SUB, nz_graph_op(g, NZ_GOP_SUB, w, nz_graph_op(g, NZ_GOP_MUL, c3, w)),
                      nz_graph_op(g, NZ_GOP_MUL, c7, w));
  int far = nz_graph_op(g, NZ_GOP_SUB, nz_graph_op(g, NZ_GOP_SUB, w, nz_graph_op(g, NZ_GOP_MUL, c3, w)),
                        nz_graph_op(g, NZ_GOP_MUL, c69, w));
  int cut = nz_graph_op(g, NZ_GOP_ATAN2, r, m1), away = nz_graph_op(g, NZ_GOP_ATAN2, far, m1);
  int cmp = nz_graph_cmp(g, NZ_CMP_GT, q, nz_graph_const(g, 0.5));
  double in[2] = { 1.3, 0.5 + 1e-12 };
  double residue = (1.3 - 0.3 * 1.3) - 0.7 * 1.3, u = DBL_EPSILON / 2;
  nz_rounding_branch b;
  int found = nz_graph_rounding_branch(g, &cut, 1, in, 0.0, &b);
  gsl_test(found != 1 || b.node != cut || b.decider != r || b.value != residue || !b.rounding,
           "rounding: atan2(w - 0.3 w - 0.7 w, -1) on its cut by rounding (residue %.3g, found %d)", residue, found);
  gsl_test(found == 1 && !(b.bound >= fabs(residue) && b.bound >= u * (0.39 + 0.91 + 0.91)),
           "rounding: its bound %.3g covers the residue and the hand bound %.3g", b.bound, u * 2.21);
  gsl_test(nz_graph_rounding_branch(g, &away, 1, in, 0.0, &b) != 0, "rounding: with 0.69 w no branch is rounding's");
  gsl_test(nz_graph_rounding_branch(g, &cmp, 1, in, 0.0, &b) != 0, "rounding: q > 0.5 at 0.5 + 1e-12 is not rounding's");
  found = nz_graph_rounding_branch(g, &cmp, 1, in, 1e-10, &b);
  gsl_test(found != 1 || b.rounding || b.value != in[1] - 0.5,
           "rounding: ... but lies within 1e-10 of its switch (found %d, value %.3g)", found, found == 1 ? b.value : 0.0);
  int roots[2] = { away, cut };
  found = nz_graph_rounding_branch(g, roots, 2, in, 0.0, &b);
  gsl_test(found != 1 || b.node != cut, "rounding: among several roots the branch of the one that flips");
  nz_graph_free(g);
}

int main(void)
{
  gsl_test_verbose(1);
  G = nz_graph_new();
  check_folding();
  check_sharing();
  check_simplify();
  check_exact();
  check_drops();
  check_guards();
  check_like_terms();
  check_branches();
  check_rounding();
  check_doubles();
  check_jets();
  check_mixed_shapes();
  check_derivatives();
  check_copies();
  check_eta();
  check_failures();
  check_plans_and_time();
  check_series_jets();
  check_series_failures();
  check_series_taylor();
  time_series();
  for (int i = 0; i < NIN; i++) nz_jet_free(jin[i]);
  for (int i = 0; i < POOL; i++) nz_jet_free(pool[i]);
  nz_graph_free(G);
  return gsl_test_summary();
}
