/* graph_guard.c - ties and singular points a plan on doubles hands to the
 * jets (graph_guard.h). */
#include <math.h>
#include <stdlib.h>
#include "graph/graph_guard.h"

enum { G_EQUAL, G_ZERO, G_UNIT, G_BOTH_ZERO };

typedef struct guard {
  int kind;
  int a, b;            /* positions in nodes[] (b = a when unused) */
  const char *what;
} guard;

struct nz_graph_guards {
  guard *list;
  int n;
  int *nodes;          /* the operands whose values the guards read */
  int nnodes;
};

void nz_graph_guards_free(nz_graph_guards *gd)
{
  if (!gd) return;
  free(gd->list);
  free(gd->nodes);
  free(gd);
}

int nz_graph_guards_count(const nz_graph_guards *gd) { return gd ? gd->nnodes : 0; }
const int *nz_graph_guards_nodes(const nz_graph_guards *gd) { return gd ? gd->nodes : NULL; }

/* The position of node x among the values read, added once. */
static int value_of(nz_graph_guards *gd, int *pos, int x)
{
  if (pos[x] < 0) {
    pos[x] = gd->nnodes;
    gd->nodes[gd->nnodes++] = x;
  }
  return pos[x];
}

static void add(nz_graph_guards *gd, int *pos, int kind, int a, int b, const char *what)
{
  guard *q = &gd->list[gd->n++];
  q->kind = kind;
  q->a = value_of(gd, pos, a);
  q->b = value_of(gd, pos, b);
  q->what = what;
}

/* The singular point of node nd, when it has one the jets refuse (jet.c's
 * nz_jet_apply, nz_jet_pow, nz_jet_atan2, nz_jet_hypot): its kind, or -1. */
static int singular_kind(const nz_gnode *nd, const char **what)
{
  if (nd->op == NZ_GOP_FN) {
    switch (nd->fn) {
    case NZ_FN_SQRT: *what = "'sqrt' at 0, where it is not differentiable"; return G_ZERO;
    case NZ_FN_ABS: *what = "'abs' at 0, where it is not differentiable"; return G_ZERO;
    case NZ_FN_ASIN: *what = "'asin' at +-1, where it is not differentiable"; return G_UNIT;
    case NZ_FN_ACOS: *what = "'acos' at +-1, where it is not differentiable"; return G_UNIT;
    default: return -1;
    }
  }
  if (nd->op == NZ_GOP_POWC && nd->v > 0.0 && nd->v != floor(nd->v)) {
    *what = "'pow' at 0 with a fractional exponent, where it is not differentiable";
    return G_ZERO;
  }
  if (nd->op == NZ_GOP_ATAN2) { *what = "'atan2' at (0, 0), where it is not differentiable"; return G_BOTH_ZERO; }
  if (nd->op == NZ_GOP_HYPOT) { *what = "'hypot' at (0, 0), where it is not differentiable"; return G_BOTH_ZERO; }
  return -1;
}

nz_graph_guards *nz_graph_guards_new(const nz_graph *g, const int *outs, int n, const int *smooth,
                                     int nsmooth, int fixed_lo, int fixed_hi)
{
  const nz_gnode *nd = nz_graph_nodes(g);
  int top = -1;
  for (int o = 0; o < n; o++) if (outs[o] > top) top = outs[o];
  for (int o = 0; o < nsmooth; o++) if (smooth[o] > top) top = smooth[o];
  nz_graph_guards *gd = calloc(1, sizeof *gd);
  /* need: 1 under an output, 2 also under a smooth root; moves: depends
   * on an input that is not fixed */
  char *need = calloc((size_t)top + 2, 1), *moves = calloc((size_t)top + 2, 1);
  int *pos = malloc(((size_t)top + 2) * sizeof(int));
  if (gd) {
    gd->list = malloc(((size_t)top + 2) * sizeof(guard));
    gd->nodes = malloc(2 * ((size_t)top + 2) * sizeof(int));
  }
  if (!gd || !need || !moves || !pos || !gd->list || !gd->nodes) {
    free(need); free(moves); free(pos);
    nz_graph_guards_free(gd);
    return NULL;
  }
  for (int o = 0; o < n; o++) need[outs[o]] = 1;
  for (int o = 0; o < nsmooth; o++) need[smooth[o]] = 2;
  for (int x = top; x >= 0; x--) {
    pos[x] = -1;
    if (!need[x] || nd[x].op == NZ_GOP_CONST || nd[x].op == NZ_GOP_INPUT) continue;
    if (nd[x].a >= 0 && need[nd[x].a] < need[x]) need[nd[x].a] = need[x];
    if (nd[x].b >= 0 && need[nd[x].b] < need[x]) need[nd[x].b] = need[x];
    if (nd[x].c >= 0 && need[nd[x].c] < need[x]) need[nd[x].c] = need[x];
  }
  for (int x = 0; x <= top; x++) {
    const nz_gnode *e = &nd[x];
    if (!need[x] || e->op == NZ_GOP_CONST) continue;
    if (e->op == NZ_GOP_INPUT) { moves[x] = e->a < fixed_lo || e->a > fixed_hi; continue; }
    moves[x] = moves[e->a] || (e->b >= 0 && moves[e->b]) || (e->c >= 0 && moves[e->c]);
    if (!moves[x]) continue;
    const char *what = NULL;
    int kind;
    if (e->op == NZ_GOP_CMP) add(gd, pos, G_EQUAL, e->a, e->b, "a tie of a comparison (nz.gt, nz.max, ...)");
    else if (e->op == NZ_GOP_FN && e->fn == NZ_FN_SIGN) add(gd, pos, G_ZERO, e->a, e->a, "a tie of nz.sign at 0");
    else if (need[x] == 2 && (kind = singular_kind(e, &what)) >= 0)
      add(gd, pos, kind, e->a, kind == G_BOTH_ZERO ? e->b : e->a, what);
  }
  free(need);
  free(moves);
  free(pos);
  return gd;
}

int nz_graph_guards_fire(const nz_graph_guards *gd, const double *v, const char **what)
{
  for (int i = 0; gd && i < gd->n; i++) {
    const guard *q = &gd->list[i];
    double a = v[q->a], b = v[q->b];
    int fire = q->kind == G_EQUAL ? a == b
             : q->kind == G_ZERO ? a == 0.0
             : q->kind == G_UNIT ? fabs(a) == 1.0
             : a == 0.0 && b == 0.0;
    if (fire) {
      if (what) *what = q->what;
      return 1;
    }
  }
  return 0;
}
