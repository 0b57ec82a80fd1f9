/* test_util.h - what the C tests share: a seeded random generator and the
 * random graphs their timings run on.  Static inline functions: each test
 * is one program and uses what it needs. */
#ifndef NZ_TEST_UTIL_H
#define NZ_TEST_UTIL_H

#include <stdint.h>
#include "graph/graph.h"

/* xorshift64*, uniform in [0, 1); *s is the state (any nonzero seed). */
static inline double test_urand(uint64_t *s)
{
  *s ^= *s >> 12;
  *s ^= *s << 25;
  *s ^= *s >> 27;
  return (double)((*s * 2685821657736338717ULL) >> 11) / 9007199254740992.0;
}

/* A graph on 8 inputs grown to `size` nodes (or cap ids), each new node
 * using one of the `spread` latest (spread 1: a chain, every node waits for
 * the previous one) and a random earlier one: products, half sums, half
 * differences, and with `sines` a sine every tenth node.  Values stay in
 * [-1, 1] for inputs there.  ids receives the nodes; returns their count. */
static inline int test_random_graph(nz_graph *g, uint64_t *s, int size, int sines, int spread,
                                    int *ids, int cap)
{
  int n = 0, half = nz_graph_const(g, 0.5);
  for (int i = 0; i < 8; i++) ids[n++] = nz_graph_input(g, i);
  while (nz_graph_size(g) < size && n < cap) {
    int a = ids[n - 1 - (int)(test_urand(s) * (n < spread ? n : spread))];
    int b = ids[(int)(test_urand(s) * n)], k = (int)(test_urand(s) * 10), z;
    if (k == 9 && sines) z = nz_graph_fn(g, NZ_FN_SIN, nz_graph_op(g, NZ_GOP_ADD, a, b));
    else if (k < 4) z = nz_graph_op(g, NZ_GOP_MUL, a, b);
    else if (k < 7) z = nz_graph_op(g, NZ_GOP_MUL, nz_graph_op(g, NZ_GOP_ADD, a, b), half);
    else z = nz_graph_op(g, NZ_GOP_MUL, nz_graph_op(g, NZ_GOP_SUB, a, b), half);
    ids[n++] = z;
  }
  return n;
}

#endif
