/* native_tables.h - the index tables of compact code (graph_compact.c for
 * plans on doubles, series_compact.c for series), and the choice between
 * compact and straight-line code.  Internal to src/graph.
 *
 * Compact code reads its operands through tables of integers.  Written into
 * the C source, a table of 100,000 entries costs the compiler more than the
 * code around it (parsing, and passes that try to fold loads from a
 * constant array); so the source declares the table as an array the object
 * owns, uninitialized (`int32_t nzc_T[n];`: no bytes in the file, nothing
 * to parse), and the loader writes its entries after loading, from the
 * graph the source was generated from.  The source carries two independent
 * 64-bit hashes of the entries in a comment, so that the cache's key (a
 * hash of the source: native_object.h) names the tables too: an object is
 * only ever loaded by a generator that holds the very tables it was made
 * for.  Two loads of one object (dlopen shares it) write the same entries. */
#ifndef NZ_NATIVE_TABLES_H
#define NZ_NATIVE_TABLES_H

#include <stddef.h>
#include <stdint.h>
#include "graph/native_object.h"

/* Plans of more computed nodes than this, and series of more computed
 * slots than that, get compact code.  Measured on the n-link pendulum from
 * bodies (bench/scale.lua prints both emitters; processor time): as
 * straight-line code a plan costs the compiler about 0.2 ms per node (the
 * 64-link pendulum's M and h, 39,915 nodes: 8.4 s at -O1) and evaluates 2x
 * faster than compact code (9.9 against 21 us), which compiles in about a
 * second at any size; so straight-line code while its compile stays a few
 * seconds.  A series costs about 1 ms of cc per slot as straight-line code
 * (2,663 slots: 3.8 s; 39,915: 41 s), and compact code runs it faster
 * from some 2,000 slots on (2,663: 134 against 168 us for 20 orders;
 * 9,959: 0.58 against 1.15 ms), 10 % slower at 763 and 20 % at 235. */
#define NZ_NATIVE_COMPACT_NODES 20000
#define NZ_SERIES_COMPACT_SLOTS 1000

/* Compact code for `size` nodes or slots?  size > threshold, unless
 * $NZLUA_COMPACT is 0 (never: straight-line code) or 1 (always). */
int nz_native_compact(int size, int threshold);

/* A growing table of int32 entries (an allocation failure sets oom). */
typedef struct nz_ctab {
  int32_t *v;
  size_t n, cap;
  int oom;
} nz_ctab;

/* Append x; returns its index. */
size_t nz_ctab_push(nz_ctab *t, int32_t x);
/* The declaration of the table and the comment with its hashes. */
void nz_ctab_declare(nz_sbuf *b, const nz_ctab *t);
/* After loading the object dl: its table filled with t's entries.  0, or -1
 * with why (the object has no table of that size). */
int nz_ctab_fill(void *dl, const nz_ctab *t, char *why, size_t whylen);
void nz_ctab_free(nz_ctab *t);

#endif
