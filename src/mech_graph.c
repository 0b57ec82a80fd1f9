/* mech_graph.c - a system's recorded pieces behind nz_evaluator, and the
 * mass matrix and bias derived from them (mech_graph.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mech_graph.h"

typedef struct compiled_piece {
  int n;                  /* outputs: 0 when the piece is not compiled */
  int *nodes;
  nz_graph_plan *plan;
} compiled_piece;

struct nz_compiled {
  int k, np, nc, nslots, ninputs;
  nz_graph *g;
  double *params;                      /* np current values */
  compiled_piece piece[NZ_PIECE_COUNT];   /* PHI unused: see phi */
  compiled_piece *phi;                 /* nc constraints */
  /* Evaluation scratch, sized once: input pointers and parameter jets. */
  const nz_jet **in, **din;
  nz_jet **pjet;                       /* np constant jets of order pcap */
  int pcap;
  /* Mass and bias on doubles (built on first use; built = -1 if impossible). */
  int mb_built;
  nz_graph_plan *mb_plan;
  double *mb_in, *mb_out;
  char failure[160];
};

nz_compiled *nz_compiled_new(int k, int np, int nc, int nslots)
{
  if (k < 1 || np < 0 || nc < 0) return NULL;
  if (nslots < 2) nslots = 2;
  nz_compiled *c = calloc(1, sizeof *c);
  if (!c) return NULL;
  c->k = k; c->np = np; c->nc = nc; c->nslots = nslots;
  c->ninputs = 1 + np + nslots * k;
  c->g = nz_graph_new();
  c->params = calloc((size_t)np + 1, sizeof(double));
  c->phi = calloc((size_t)nc + 1, sizeof(compiled_piece));
  c->in = calloc((size_t)c->ninputs, sizeof(nz_jet *));
  c->din = calloc((size_t)c->ninputs, sizeof(nz_jet *));
  c->pjet = calloc((size_t)np + 1, sizeof(nz_jet *));
  c->pcap = -1;
  if (!c->g || !c->params || !c->phi || !c->in || !c->din || !c->pjet) {
    nz_compiled_free(c);
    return NULL;
  }
  return c;
}

static void piece_clear(compiled_piece *p)
{
  free(p->nodes);
  nz_graph_plan_free(p->plan);
  memset(p, 0, sizeof *p);
}

void nz_compiled_free(nz_compiled *c)
{
  if (!c) return;
  for (int p = 0; p < NZ_PIECE_COUNT; p++) piece_clear(&c->piece[p]);
  for (int r = 0; c->phi && r < c->nc; r++) piece_clear(&c->phi[r]);
  for (int p = 0; c->pjet && p < c->np; p++) nz_jet_free(c->pjet[p]);
  nz_graph_plan_free(c->mb_plan);
  free(c->mb_in);
  free(c->phi);
  free(c->pjet);
  free(c->in);
  free(c->din);
  free(c->params);
  nz_graph_free(c->g);
  free(c);
}

nz_graph *nz_compiled_graph(nz_compiled *c) { return c->g; }
double *nz_compiled_params(nz_compiled *c) { return c->params; }
int nz_compiled_nparams(const nz_compiled *c) { return c->np; }
const char *nz_compiled_failure(const nz_compiled *c) { return c->failure; }

int nz_compiled_input_slot(const nz_compiled *c, int j, int i)
{
  return 1 + c->np + j * c->k + i;
}

static compiled_piece *piece_of(const nz_compiled *c, nz_piece piece, int index)
{
  if (piece == NZ_PIECE_PHI) return index >= 0 && index < c->nc ? &c->phi[index] : NULL;
  return piece >= 0 && piece < NZ_PIECE_COUNT ? (compiled_piece *)&c->piece[piece] : NULL;
}

int nz_compiled_set_piece(nz_compiled *c, nz_piece piece, int index, const int *nodes, int n)
{
  compiled_piece *p = piece_of(c, piece, index);
  if (!p || n != (piece == NZ_PIECE_Q ? c->k : 1)) return NZ_EARG;
  for (int o = 0; o < n; o++)
    if (nodes[o] < 0 || nodes[o] >= nz_graph_size(c->g)) return NZ_EARG;
  if (nz_graph_ninputs(c->g) > c->ninputs) return NZ_EARG;
  piece_clear(p);
  p->nodes = malloc((size_t)n * sizeof(int));
  if (!p->nodes) return NZ_ENOMEM;
  memcpy(p->nodes, nodes, (size_t)n * sizeof(int));
  p->plan = nz_graph_plan_new(c->g, nodes, n);
  if (!p->plan) { piece_clear(p); return NZ_ENOMEM; }
  p->n = n;
  return NZ_OK;
}

int nz_compiled_has(const nz_compiled *c, nz_piece piece, int index)
{
  const compiled_piece *p = piece_of(c, piece, index);
  return p && p->n > 0;
}

int nz_compiled_piece_nodes(const nz_compiled *c, nz_piece piece, int index)
{
  const compiled_piece *p = piece_of(c, piece, index);
  return p && p->n > 0 ? nz_graph_plan_nodes(p->plan) : 0;
}

/* The parameters as constant jets of (at least) this order. */
static int param_jets(nz_compiled *c, int order)
{
  if (order > c->pcap) {
    for (int p = 0; p < c->np; p++) {
      nz_jet_free(c->pjet[p]);
      if (!(c->pjet[p] = nz_jet_alloc(order, 0))) return NZ_ENOMEM;
    }
    c->pcap = order;
  }
  for (int p = 0; p < c->np; p++) {
    nz_jet_init(c->pjet[p], order, 0);
    nz_jet_set_constant(c->pjet[p], c->params[p]);
  }
  return NZ_OK;
}

static void describe_failure(nz_compiled *c, const nz_graph_plan *plan, int st)
{
  int node;
  nz_gop op;
  nz_jet_fn fn;
  double x;
  nz_graph_plan_failure(plan, &node, &op, &fn, &x);
  const char *name = op == NZ_GOP_FN && fn < NZ_FN_COUNT ? nz_jet_fn_names[fn]
                   : op < NZ_GOP_COUNT ? nz_gop_names[op] : "?";
  snprintf(c->failure, sizeof c->failure, "%s of %.17g failed (status %d, node %d)", name, x, st,
           node);
}

int nz_compiled_eval(void *ctx, nz_piece piece, int index, const nz_jet *t,
                     nz_jet *const *const *levels, int nlevels, nz_jet *const *out,
                     const nz_direction *dir)
{
  nz_compiled *c = ctx;
  compiled_piece *p = piece_of(c, piece, index);
  if (!p || p->n == 0) return NZ_EARG;
  int st = param_jets(c, t->order);
  if (st) return st;
  c->in[0] = t;
  c->din[0] = dir ? dir->dt : NULL;
  for (int q = 0; q < c->np; q++) {
    c->in[1 + q] = c->pjet[q];
    c->din[1 + q] = NULL;
  }
  for (int j = 0; j < c->nslots; j++)
    for (int i = 0; i < c->k; i++) {
      int at = nz_compiled_input_slot(c, j, i);
      c->in[at] = j < nlevels ? levels[j][i] : NULL;
      c->din[at] = dir && j < nlevels ? dir->dlevels[j][i] : NULL;
    }
  st = nz_graph_eval_jets(p->plan, c->in, out, dir ? c->din : NULL, dir ? dir->dout : NULL);
  if (st) describe_failure(c, p->plan, st);
  return st;
}

/* ------------------------------------------------------------------ */
/* Mass matrix and bias, differentiated once                           */

/* Graph nodes of M (k x k) then h (k), into out[k k + k]; -1 on failure. */
static int build_mass_bias(nz_compiled *c, int *out)
{
  nz_graph *g = c->g;
  int k = c->k, n = nz_graph_ninputs(g) > c->ninputs ? nz_graph_ninputs(g) : c->ninputs;
  int *dir = malloc((size_t)n * sizeof(int));
  int *grad = malloc((size_t)(3 * k) * sizeof(int));
  int ok = dir && grad;
  int one = nz_graph_const(g, 1.0), zero = nz_graph_const(g, 0.0);
  if (one < 0 || zero < 0) ok = 0;
  int F = c->piece[NZ_PIECE_F].n ? c->piece[NZ_PIECE_F].nodes[0] : zero;
  int *gq = grad, *gqd = grad + k, *tmp = grad + 2 * k;
  /* dF/dq_i and dF/dq'_i, one seed each */
  for (int i = 0; ok && i < k; i++)
    for (int s = 0; s < 2 && ok; s++) {
      for (int a = 0; a < n; a++) dir[a] = -1;
      dir[nz_compiled_input_slot(c, s, i)] = one;
      int d = nz_graph_derivative(g, F, dir);
      if (d < 0) ok = 0;
      else (s ? gqd : gq)[i] = d;
    }
  /* M_ij = d(dF/dq'_i)/dq'_j */
  for (int j = 0; ok && j < k; j++) {
    for (int a = 0; a < n; a++) dir[a] = -1;
    dir[nz_compiled_input_slot(c, 1, j)] = one;
    if (nz_graph_derivatives(g, gqd, k, dir, tmp)) ok = 0;
    for (int i = 0; ok && i < k; i++) out[i * k + j] = tmp[i];
  }
  /* d/dt (dF/dq'_i) with q'' = 0: along t -> 1, q -> q' */
  if (ok) {
    for (int a = 0; a < n; a++) dir[a] = -1;
    dir[0] = one;
    for (int j = 0; j < k; j++) dir[nz_compiled_input_slot(c, 1, j)] = -1;
    for (int j = 0; j < k && ok; j++)
      if ((dir[nz_compiled_input_slot(c, 0, j)] = nz_graph_input(g, nz_compiled_input_slot(c, 1, j))) < 0)
        ok = 0;
    if (ok && nz_graph_derivatives(g, gqd, k, dir, tmp)) ok = 0;
  }
  /* h = d/dt dF/dq' - dF/dq + dV/dq - Q */
  int V = c->piece[NZ_PIECE_V].n ? c->piece[NZ_PIECE_V].nodes[0] : -1;
  for (int i = 0; ok && i < k; i++) {
    int h = nz_graph_op(g, NZ_GOP_SUB, tmp[i], gq[i]);
    if (V >= 0 && h >= 0) {
      for (int a = 0; a < n; a++) dir[a] = -1;
      dir[nz_compiled_input_slot(c, 0, i)] = one;
      int dV = nz_graph_derivative(g, V, dir);
      h = dV < 0 ? -1 : nz_graph_op(g, NZ_GOP_ADD, h, dV);
    }
    if (c->piece[NZ_PIECE_Q].n && h >= 0) h = nz_graph_op(g, NZ_GOP_SUB, h, c->piece[NZ_PIECE_Q].nodes[i]);
    if (h < 0) ok = 0;
    out[k * k + i] = h;
  }
  free(dir);
  free(grad);
  return ok ? 0 : -1;
}

static int mass_bias_ready(nz_compiled *c)
{
  if (c->mb_built) return c->mb_built > 0;
  c->mb_built = -1;
  /* Every piece that enters M and h must be compiled: F (when the system
   * has T or L pieces), V, Q; the caller (the binding) only installs this
   * hook when they are. */
  int k = c->k, nout = k * k + k;
  int *out = malloc((size_t)nout * sizeof(int));
  if (!out) return 0;
  if (build_mass_bias(c, out) == 0) {
    c->mb_plan = nz_graph_plan_new(c->g, out, nout);
    c->mb_in = malloc((size_t)(c->ninputs + nout) * sizeof(double));
    if (c->mb_plan && c->mb_in) {
      c->mb_out = c->mb_in + c->ninputs;
      c->mb_built = 1;
    }
  }
  free(out);
  return c->mb_built > 0;
}

int nz_compiled_mass_bias(void *ctx, double t, const double *q, const double *qd, double *M,
                          double *h)
{
  nz_compiled *c = ctx;
  if (!mass_bias_ready(c)) return NZ_EARG;
  int k = c->k;
  double *in = c->mb_in;
  memset(in, 0, (size_t)c->ninputs * sizeof(double));
  in[0] = t;
  memcpy(in + 1, c->params, (size_t)c->np * sizeof(double));
  memcpy(in + nz_compiled_input_slot(c, 0, 0), q, (size_t)k * sizeof(double));
  memcpy(in + nz_compiled_input_slot(c, 1, 0), qd, (size_t)k * sizeof(double));
  int st = nz_graph_eval(c->mb_plan, in, c->mb_out);
  if (st) {
    /* Let the jet path run: it says which function failed, and where. */
    describe_failure(c, c->mb_plan, st);
    return NZ_EARG;
  }
  memcpy(M, c->mb_out, (size_t)k * (size_t)k * sizeof(double));
  memcpy(h, c->mb_out + k * k, (size_t)k * sizeof(double));
  return NZ_OK;
}

int nz_compiled_mass_bias_nodes(const nz_compiled *c)
{
  return c->mb_built > 0 ? nz_graph_plan_nodes(c->mb_plan) : 0;
}
