/* graph_guard.h - where a plan on doubles must hand an evaluation to the
 * jets, so that the recorded graph answers as the function in Lua does.
 *
 * A plan on doubles sees values only.  Two things the jets decide by more:
 *   - a tie of a branch: cmp(a, b) with a == b, sign(x) at x == 0.  The
 *     jets break it by the first Taylor coefficient in which the two sides
 *     differ (jet.h's branch rule), which doubles cannot see;
 *   - a singular point in a function the mechanics differentiates (T, L, V,
 *     a constraint): sqrt and abs at 0, asin and acos at +-1, x^p at 0 for
 *     a fractional p, atan2 and hypot at (0, 0).  The jets refuse them
 *     there ("'sqrt' is not differentiable at 0"); a derivative built on
 *     the graph may well be finite there (d x^1.5 = 1.5 x^0.5).
 * A guard set lists the nodes whose values tell (the operands of those
 * nodes); the caller adds them to the plan's outputs and, after each
 * evaluation, asks nz_graph_guards_fire whether to take the jets' path.
 * Nodes that do not move along the motion (constants, and the inputs the
 * caller names fixed: the parameters) never need a guard: the jets would
 * tie on them to the last coefficient too. */
#ifndef NZ_GRAPH_GUARD_H
#define NZ_GRAPH_GUARD_H

#include "graph/graph.h"

typedef struct nz_graph_guards nz_graph_guards;

/* Guards for a plan of outputs outs[0..n-1]: ties under any output,
 * singular points under the nodes smooth[0..nsmooth-1] (the functions the
 * jets evaluate with derivatives).  Inputs fixed_lo..fixed_hi do not move.
 * NULL when out of memory. */
nz_graph_guards *nz_graph_guards_new(const nz_graph *g, const int *outs, int n, const int *smooth,
                                     int nsmooth, int fixed_lo, int fixed_hi);
void nz_graph_guards_free(nz_graph_guards *gd);   /* NULL is harmless */
/* The nodes to add to the plan's outputs (after its own), and how many. */
int nz_graph_guards_count(const nz_graph_guards *gd);
const int *nz_graph_guards_nodes(const nz_graph_guards *gd);
/* Given their values (in that order): 0, or 1 when the evaluation meets a
 * tie or a singular point and must be left to the jets; *what then says
 * which ("a tie of cmp", ...) for a message. */
int nz_graph_guards_fire(const nz_graph_guards *gd, const double *values, const char **what);

#endif
