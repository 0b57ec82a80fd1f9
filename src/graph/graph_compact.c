/* graph_compact.c - compact code for a plan on doubles: the nodes grouped
 * into blocks of like operations, each block one loop that reads its
 * operands by index (graph_native_gen.h).
 *
 * Why.  Straight-line code (graph_native.c) writes one statement per node:
 * the fastest code, but the compiler's work grows with the statements
 * (parsing, dead-store elimination and register allocation over functions
 * of thousands of them: about 0.17 ms of cc time per node at -O1), so a
 * plan of 40,000 nodes costs seconds of compiling.  Compact code is the
 * interpreter's loop (graph_plan.c) with the dispatch compiled away: one loop
 * per block, its operands read through index tables that the loader writes
 * into the object (native_tables.h), so the source grows with the number
 * of blocks, not of nodes, and compiles in a fraction of a second for any
 * plan.  Each node costs two more loads (its operands' indices) than in
 * straight-line code.  The idea is heyoka's compact mode (Biscani and
 * Izzo: for large expressions, loops over blocks of like operations whose
 * operands come from index arrays, instead of one unrolled line per node).
 *
 * The layout.  One array of values v, the object's workspace w: the inputs
 * the nodes read (v[i] = in[IN[i]], copied at each call), the constants
 * (written once, when the workspace is made), a 0.0 (for padding), then the
 * computed nodes in the order they run: by level (1 + the highest level of
 * their operands, so that the nodes of one level never read each other),
 * then by operation, so that a level is a few long blocks.  Block j of n
 * nodes of a binary operation computes
 *   for (i = 0; i < n; i++) z[i] = v[A[i]] op v[B[i]];
 * and moves z, A and B on by n.  Each node's formula is the straight-line
 * code's (the same helpers, the same operations in the same order), so the
 * values are the same bit for bit.
 *
 * Refusals: the same nodes as straight-line code are tested (their slots
 * listed in a table, CHK), with the same rule: t * 0.0 is 0 for a finite t. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "graph/graph_native_gen.h"

/* Blocks per generated function. */
#define BLOCKS_PER_PART 24

/* One computed node in the order the code runs it. */
typedef struct cnode {
  int level, key, id;
  double p;   /* the exponent of a power: a block has one */
} cnode;

static int cnode_cmp(const void *x, const void *y)
{
  const cnode *u = x, *w = y;
  if (u->level != w->level) return u->level < w->level ? -1 : 1;
  if (u->key != w->key) return u->key < w->key ? -1 : 1;
  if (u->p != w->p) return u->p < w->p ? -1 : 1;
  return (u->id > w->id) - (u->id < w->id);
}

static int same_block(const cnode *u, const cnode *w) { return u->level == w->level && u->key == w->key && u->p == w->p; }

static int is_small_integer(double p) { return p == floor(p) && fabs(p) <= 1e9; }

/* The operation and function of a node: nodes of one key share a loop. */
static int node_key(const nz_gnode *nd)
{
  return nd->op * 64 + (nd->op == NZ_GOP_FN || nd->op == NZ_GOP_CMP ? nd->fn : 0);
}

/* The formula of a node on x (first operand), y (second), c (condition):
 * graph_native.c's emit_node, on named operands. */
static void formula(const nz_gnode *nd, char *e, size_t en)
{
  switch (nd->op) {
  case NZ_GOP_ADD: snprintf(e, en, "x + y"); break;
  case NZ_GOP_SUB: snprintf(e, en, "x - y"); break;
  case NZ_GOP_MUL: snprintf(e, en, "x * y"); break;
  case NZ_GOP_DIV: snprintf(e, en, "x / y"); break;
  case NZ_GOP_NEG: snprintf(e, en, "-x"); break;
  case NZ_GOP_POW: snprintf(e, en, "nzn_pow(x, y)"); break;
  case NZ_GOP_ATAN2: snprintf(e, en, "atan2(x, y)"); break;
  case NZ_GOP_HYPOT: snprintf(e, en, "nzn_hypot(x, y)"); break;
  case NZ_GOP_FN: snprintf(e, en, "%s(x)", nz_native_fn_name(nd->fn)); break;
  case NZ_GOP_CMP: snprintf(e, en, "%s(x, y)", nz_native_cmp_name(nd->fn)); break;
  case NZ_GOP_SELECT: snprintf(e, en, "nzn_select(c, x, y)"); break;
  case NZ_GOP_POWC: {
    double p = nd->v;
    char pl[64];
    if (p == 0.0) snprintf(e, en, "1.0");
    else if (p > 0.0 && is_small_integer(p)) snprintf(e, en, "nzn_powi(x, %uu)", (unsigned)p);
    else {
      nz_native_literal(pl, sizeof pl, p);
      snprintf(e, en, "nzn_powc(x, %s, %d)", pl, is_small_integer(p));
    }
    break;
  }
  default: snprintf(e, en, "NAN"); break;   /* refused before */
  }
}

/* The loop of one block of n nodes like nd: its results from v[z], its
 * operands' indices from the tables at a (b, c). */
static void emit_block(nz_sbuf *b, const nz_gnode *nd, int n, int z, size_t a, size_t bb, size_t c)
{
  char e[160];
  formula(nd, e, sizeof e);
  int binary = !nz_native_unary(nd->op), select = nd->op == NZ_GOP_SELECT;
  nz_sb_printf(b, "  { const int32_t *A = nzc_T + %zu", a);
  if (binary) nz_sb_printf(b, ", *B = nzc_T + %zu", bb);
  if (select) nz_sb_printf(b, ", *C = nzc_T + %zu", c);
  nz_sb_printf(b, ";\n    _Pragma(\"GCC unroll 4\") for (int i = 0; i < %d; i++) { const double x = v[A[i]]%s%s; v[%d + i] = %s; } }\n", n,
               binary ? ", y = v[B[i]]" : "", select ? ", c = v[C[i]]" : "", z, e);
}

/* The computed nodes in running order (by level, then kind); their count. */
static int schedule(const nz_native_gen *G, cnode *order, int *level)
{
  const nz_gnode *nd = G->nd;
  int nr = 0;
  for (int id = 0; id <= G->top; id++) {
    level[id] = 0;
    if (!G->need[id] || !nz_native_computed(nd[id].op)) continue;
    int l = level[nd[id].a];
    if (!nz_native_unary(nd[id].op) && level[nd[id].b] > l) l = level[nd[id].b];
    if (nd[id].op == NZ_GOP_SELECT && level[nd[id].c] > l) l = level[nd[id].c];
    level[id] = l + 1;
    order[nr++] = (cnode){ l + 1, node_key(&nd[id]), id, nd[id].op == NZ_GOP_POWC ? nd[id].v : 0.0 };
  }
  qsort(order, (size_t)nr, sizeof *order, cnode_cmp);
  return nr;
}

/* The tables: IN, then per computed node A (and B, C), CHK, OUT; offsets of
 * each into off[].  slot[id] is the node's place in v. */
static void fill_tables(const nz_native_gen *G, const cnode *order, int nr, const int *slot, int zero,
                        const int *outputs, int n, nz_ctab *t, size_t off[6])
{
  const nz_gnode *nd = G->nd;
  off[0] = t->n;
  for (int id = 0; id <= G->top; id++)
    if (G->need[id] && nd[id].op == NZ_GOP_INPUT) nz_ctab_push(t, nd[id].a);
  int kinds[3] = { 0, 1, 2 };   /* a, b, c */
  for (int k = 0; k < 3; k++) {
    off[1 + k] = t->n;
    for (int i = 0; i < nr; i++) {
      const nz_gnode *x = &nd[order[i].id];
      if (kinds[k] == 0) nz_ctab_push(t, slot[x->a]);
      else if (kinds[k] == 1 && !nz_native_unary(x->op)) nz_ctab_push(t, slot[x->b]);
      else if (kinds[k] == 2 && x->op == NZ_GOP_SELECT) nz_ctab_push(t, slot[x->c]);
    }
  }
  off[4] = t->n;
  size_t nchk = 0;
  for (int i = 0; i < nr; i++)
    if (G->check[order[i].id]) nz_ctab_push(t, slot[order[i].id]), nchk++;
  for (; nchk % 4; nchk++) nz_ctab_push(t, zero);
  off[5] = t->n;
  for (int r = 0; r < n; r++) nz_ctab_push(t, slot[outputs[r]]);
}

void nz_native_emit_compact(nz_native_gen *G, const int *outputs, int n, nz_compact_data *d)
{
  const nz_gnode *nd = G->nd;
  size_t m = (size_t)G->top + 2;
  int *slot = malloc(m * sizeof *slot), *level = malloc(m * sizeof *level);
  cnode *order = malloc(((size_t)G->nodes + 1) * sizeof *order);
  d->con = malloc(m * sizeof *d->con);
  if (!slot || !level || !order || !d->con) {
    G->b->oom = 1;
    goto done;
  }
  int nin = 0;
  for (int id = 0; id <= G->top; id++) {   /* inputs, then constants, in id order */
    if (G->need[id] && nd[id].op == NZ_GOP_INPUT) slot[id] = nin++;
  }
  d->con_at = nin;
  for (int id = 0; id <= G->top; id++)
    if (G->need[id] && nd[id].op == NZ_GOP_CONST) {
      slot[id] = nin + d->ncon;
      d->con[d->ncon++] = nd[id].v;
    }
  int zero = nin + d->ncon, base = zero + 1;
  d->con[d->ncon++] = 0.0;   /* the padding's 0.0 */
  int nr = schedule(G, order, level);
  for (int i = 0; i < nr; i++) slot[order[i].id] = base + i;
  size_t off[6];
  fill_tables(G, order, nr, slot, zero, outputs, n, &d->tab, off);
  size_t nchk = off[5] - off[4];
  d->nwork = (size_t)base + (size_t)nr;

  nz_sbuf *b = G->b;
  nz_ctab_declare(b, &d->tab);
  /* the blocks in functions of BLOCKS_PER_PART (a compiler's passes slow
   * down on one function of hundreds of loops: tree PRE, at -O2) */
  int part = 0, inpart = 0;
  size_t ia = off[1], ib = off[2], ic = off[3];
  for (int i = 0; i < nr;) {
    int j = i;
    while (j < nr && same_block(&order[j], &order[i])) j++;
    if (inpart == 0)
      nz_sb_printf(b, "\nstatic NZN_NOINLINE void nzn_part%d(double *restrict v)\n{\n", part);
    const nz_gnode *x = &nd[order[i].id];
    emit_block(b, x, j - i, base + i, ia, ib, ic);
    ia += (size_t)(j - i);
    if (!nz_native_unary(x->op)) ib += (size_t)(j - i);
    if (x->op == NZ_GOP_SELECT) ic += (size_t)(j - i);
    if (++inpart == BLOCKS_PER_PART || j == nr) {
      nz_sb_printf(b, "}\n");
      part++;
      inpart = 0;
    }
    i = j;
  }
  nz_sb_printf(b, "\nint nzn_eval(const double *restrict in, double *restrict out, double *restrict w);\n"
                  "int nzn_eval(const double *restrict in, double *restrict out, double *restrict w)\n{\n"
                  "  double *restrict v = w;\n");
  if (G->bad_const) nz_sb_printf(b, "  return 1;   /* a constant is not finite */\n");
  nz_sb_printf(b, "  for (int i = 0; i < %d; i++) v[i] = in[nzc_T[%zu + i]];\n", nin, off[0]);
  for (int p = 0; p < part; p++) nz_sb_printf(b, "  nzn_part%d(v);\n", p);
  nz_sb_printf(b, "  const int32_t *CHK = nzc_T + %zu, *OUT = nzc_T + %zu;\n"
                  "  double c0 = 0.0, c1 = 0.0, c2 = 0.0, c3 = 0.0;\n"
                  "  for (int i = 0; i < %zu; i += 4) {\n"
                  "    c0 += v[CHK[i]] * 0.0; c1 += v[CHK[i + 1]] * 0.0;\n"
                  "    c2 += v[CHK[i + 2]] * 0.0; c3 += v[CHK[i + 3]] * 0.0;\n  }\n"
                  "  for (int r = 0; r < %d; r++) out[r] = v[OUT[r]];\n"
                  "  return !((c0 + c1) + (c2 + c3) == 0.0);\n}\n", off[4], off[5], nchk, n);
  if (d->tab.oom) b->oom = 1;
done:
  free(slot);
  free(level);
  free(order);
}

void nz_compact_data_free(nz_compact_data *d)
{
  nz_ctab_free(&d->tab);
  free(d->con);
  memset(d, 0, sizeof *d);
}
