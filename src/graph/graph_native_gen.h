/* graph_native_gen.h - what the two emitters of a plan on doubles share
 * (graph_native.c writes straight-line code, graph_compact.c compact code):
 * the analysis of the graph (which nodes the outputs need, which are tested
 * for finiteness) and the scalar helpers the generated code calls.
 * Internal to src/graph. */
#ifndef NZ_GRAPH_NATIVE_GEN_H
#define NZ_GRAPH_NATIVE_GEN_H

#include "graph/graph.h"
#include "graph/native_object.h"
#include "graph/native_tables.h"

/* The graph as the emitters see it.  need[id]: the outputs need node id;
 * check[id]: its value is tested for finiteness (graph_native.c's header
 * comment: only the nodes a strict consumer does not test); the outputs of
 * each node linked from out_head[id] through out_next[r]. */
typedef struct nz_native_gen {
  const nz_gnode *nd;
  int top;
  char *need, *check;
  int *out_head, *out_next;
  int nodes, ncheck, maxin, bad_const;
  int compact;   /* the emitter: 1 compact (graph_compact.c), 0 straight-line */
  nz_sbuf *b;
  /* straight-line code only: the function of each computed node, the last
   * function that reads it, its place in w[] */
  int *chunk, *last, *wslot;
  int nw, nchunks;
} nz_native_gen;

/* The scalar kernels of graph_impl.h that are not one libm call, as C source. */
extern const char nz_native_helpers[];

static inline int nz_native_computed(int op) { return op != NZ_GOP_CONST && op != NZ_GOP_INPUT; }
static inline int nz_native_unary(int op) { return op == NZ_GOP_NEG || op == NZ_GOP_POWC || op == NZ_GOP_FN; }
/* The C function of an nz_jet_fn (NULL: not supported), of an nz_cmp. */
const char *nz_native_fn_name(int fn);
const char *nz_native_cmp_name(int op);

/* What compact code needs besides its source: the index tables the
 * loader writes into the object (native_tables.h), and the workspace's
 * size and first doubles (the constants, at slots con_at ..). */
typedef struct nz_compact_data {
  nz_ctab tab;
  double *con;
  int ncon, con_at;
  size_t nwork;
} nz_compact_data;

/* Compact code for the needed nodes of G (graph_compact.c): loops over
 * blocks of like operations reading operands by index, the entry nzn_eval
 * as straight-line code's, into G->b; the tables and the workspace into
 * *d (freed by nz_compact_data_free, also after a failure). */
void nz_native_emit_compact(nz_native_gen *G, const int *outputs, int n, nz_compact_data *d);
void nz_compact_data_free(nz_compact_data *d);

#endif
