/* graph_rounding.h - where a graph's value is decided by rounding: the
 * values of its nodes with a running bound of their rounding errors
 * (Wilkinson's running error analysis), and the first branch whose choice
 * lies within that bound.
 *
 * A right-hand side built from such a branch flips with the last bits of
 * the state: atan2(w - 0.3 w - 0.7 w, -1) is +pi or -pi by the sign of a
 * rounding residue, sign(qd) at a velocity that is zero up to rounding.  An
 * adaptive integrator then shrinks its steps towards nothing, since every
 * step sees a jump; the stepping loop asks this, when a run's steps have
 * collapsed, to name the operation that flips.
 *
 * The bound of each node is that of its computed value against the same
 * expression in exact arithmetic from the same inputs (taken as exact):
 * for + and -, e = ea + eb + u |z|; for *, |a| eb + |b| ea + ea eb + u |z|;
 * for /, (ea + |z| eb) / (|b| - eb) + u |z|; for a function, the largest
 * change of its value over the operands' intervals (their ends), plus 2 u
 * |z|.  u is the unit roundoff.  A branch's choice is within rounding when
 * the number that decides it lies within its bound: a comparison's a - b,
 * sign's operand, atan2's y where x < 0 (its cut), a selection's condition.
 * Given a tolerance, a branch whose deciding number lies within it of its
 * switch is named too: a jump of the model itself (sign(q') at a velocity
 * that reverses), which the steps straddle as they shrink. */
#ifndef NZ_GRAPH_ROUNDING_H
#define NZ_GRAPH_ROUNDING_H

#include "graph/graph.h"

typedef struct nz_rounding_branch {
  int node;               /* the branch's node                                */
  int decider;            /* the node whose value decides it (its operand)    */
  double value, bound;    /* that value and its rounding bound                */
  double a, b;            /* the branch's operands' values                    */
  int rounding;           /* 1: within rounding; 0: within the tolerance only   */
} nz_rounding_branch;

/* The nodes the roots need, evaluated at the inputs in (t, the parameters,
 * the state's slots: as the plans number them), in topological order; the
 * first branch whose deciding number lies within its rounding bound, or
 * within tol (>= 0), of its switch into *out.  Returns 1 when one was
 * found, 0 when none, -1 when memory ran out or a node failed (a domain
 * error: then no branch is named). */
int nz_graph_rounding_branch(const nz_graph *g, const int *roots, int nroots, const double *in, double tol,
                             nz_rounding_branch *out);

#endif
