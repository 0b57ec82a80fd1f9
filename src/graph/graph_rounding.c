/* graph_rounding.c - where a graph's value is decided by rounding (see
 * graph_rounding.h). */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include "graph/graph_rounding.h"

#define U (DBL_EPSILON / 2)

/* The largest change of node nd's value z over its operands' intervals
 * [a - ea, a + ea] and [b - eb, b + eb], taken at their ends (the
 * functions of a graph are monotone over intervals as small as rounding,
 * except across a jump, which the ends see). */
static double spread(const nz_gnode *nd, double a, double ea, double b, double eb, double z)
{
  double worst = 0.0;
  for (int i = -1; i <= 1; i++)
    for (int j = -1; j <= 1; j++) {
      double w;
      if (nz_graph_scalar(nd, a + i * ea, b + j * eb, &w) != NZ_OK) return INFINITY;
      worst = fmax(worst, fabs(w - z));
    }
  return worst;
}

/* The rounding bound of node nd's value z from its operands'. */
static double bound_of(const nz_gnode *nd, double a, double ea, double b, double eb, double z)
{
  double az = fabs(z);
  switch (nd->op) {
  case NZ_GOP_ADD:
  case NZ_GOP_SUB: return ea + eb + U * az;
  case NZ_GOP_MUL: return fabs(a) * eb + fabs(b) * ea + ea * eb + U * az;
  case NZ_GOP_DIV: return fabs(b) > eb ? (ea + az * eb) / (fabs(b) - eb) + U * az : INFINITY;
  case NZ_GOP_NEG: return ea;
  case NZ_GOP_CMP: return 0.0;   /* 0 or 1: its own flip is the branch's */
  default: return spread(nd, a, ea, b, eb, z) + 2 * U * az;
  }
}

/* The number that decides branch node nd's choice (*d, its rounding bound
 * *de, its node *decider); 0 when nd is no branch, or one whose switch is
 * out of reach (atan2 away from its cut). */
static int decided_by(const nz_gnode *nd, const double *v, const double *e, int *decider, double *d, double *de)
{
  switch (nd->op) {
  case NZ_GOP_CMP:
    *decider = nd->a, *d = v[nd->a] - v[nd->b], *de = e[nd->a] + e[nd->b];
    return 1;
  case NZ_GOP_FN:
    *decider = nd->a, *d = v[nd->a], *de = e[nd->a];
    return nd->fn == NZ_FN_SIGN;
  case NZ_GOP_ATAN2:   /* atan2(a, b): the cut where b < 0 and a changes sign */
    *decider = nd->a, *d = v[nd->a], *de = e[nd->a];
    return v[nd->b] - e[nd->b] < 0.0;
  case NZ_GOP_SELECT:
    *decider = nd->c, *d = v[nd->c], *de = e[nd->c];
    return 1;
  default: return 0;
  }
}

/* Node x at values v with bounds e; 0, or -1 when it fails. */
static int eval_node(const nz_gnode *nd, int x, const double *in, double *v, double *e)
{
  double a = nd->a >= 0 ? v[nd->a] : 0.0, b = nd->b >= 0 ? v[nd->b] : 0.0;
  double ea = nd->a >= 0 ? e[nd->a] : 0.0, eb = nd->b >= 0 ? e[nd->b] : 0.0;
  switch (nd->op) {
  case NZ_GOP_CONST: v[x] = nd->v, e[x] = 0.0; return 0;
  case NZ_GOP_INPUT: v[x] = in[nd->a], e[x] = 0.0; return 0;
  case NZ_GOP_SELECT:
    v[x] = v[nd->c] != 0.0 ? a : b;
    e[x] = v[nd->c] != 0.0 ? ea : eb;
    return 0;
  default:
    if (nz_graph_scalar(nd, a, b, &v[x]) != NZ_OK) return -1;
    e[x] = bound_of(nd, a, ea, b, eb, v[x]);
    return 0;
  }
}

int nz_graph_rounding_branch(const nz_graph *g, const int *roots, int nroots, const double *in, double tol,
                             nz_rounding_branch *out)
{
  int n = nz_graph_size(g);
  const nz_gnode *nodes = nz_graph_nodes(g);
  double *v = malloc(2 * (size_t)n * sizeof(double) + 1);
  unsigned char *need = calloc((size_t)n + 1, 1);
  if (!v || !need) {
    free(v);
    free(need);
    return -1;
  }
  double *e = v + n;
  for (int r = 0; r < nroots; r++)
    if (roots[r] >= 0 && roots[r] < n) need[roots[r]] = 1;
  for (int x = n - 1; x >= 0; x--) {   /* operands have smaller ids */
    if (!need[x]) continue;
    const nz_gnode *nd = &nodes[x];
    if (nd->op == NZ_GOP_CONST || nd->op == NZ_GOP_INPUT) continue;
    if (nd->a >= 0) need[nd->a] = 1;
    if (nd->b >= 0) need[nd->b] = 1;
    if (nd->op == NZ_GOP_SELECT && nd->c >= 0) need[nd->c] = 1;
  }
  int found = 0;
  for (int x = 0; x < n && found == 0; x++) {
    if (!need[x]) continue;
    const nz_gnode *nd = &nodes[x];
    if (eval_node(nd, x, in, v, e)) {
      found = -1;
      break;
    }
    int decider;
    double d, de;
    if (!decided_by(nd, v, e, &decider, &d, &de)) continue;
    int rounding = de > 0.0 && fabs(d) <= de;
    if (rounding || fabs(d) <= tol) {
      *out = (nz_rounding_branch){ x, decider, d, de, nd->a >= 0 ? v[nd->a] : 0.0, nd->b >= 0 ? v[nd->b] : 0.0,
                                   rounding };
      found = 1;
    }
  }
  free(v);
  free(need);
  return found;
}
