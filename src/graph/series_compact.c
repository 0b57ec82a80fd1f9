/* series_compact.c - compact code for the series of a plan (series_gen.h):
 * the computed slots grouped into blocks of one kernel, each block a loop
 * whose slots' series come from index tables.
 *
 * Straight-line code (series_native.c) writes one call per slot with its
 * series as constants; the compiler spends about a millisecond per slot on
 * it (a plan of 40,000 slots: minutes).  Compact code writes one loop per
 * block (the idea of heyoka's compact mode, as graph_compact.c for plans
 * on doubles), its slots' series read from tables the loader writes into
 * the object (native_tables.h): the source grows with the blocks, not the
 * slots.  A slot's kernel is the same C as in straight-line code
 * (nz_series_emit_kernel, on table entries instead of constants), so the
 * coefficients are the same bit for bit.
 *
 * The order: slots by level (1 + the highest level of their operands'
 * series; inputs and constants are level 0), then by kernel (and exponent
 * of x^n).  Slots of one level never read each other, so any order among
 * them gives the same numbers; the plan's own order groups a level by
 * graph operation, which splits into kernels (a product by a constant is a
 * scaling) and would make short blocks.
 *
 * Failures: the slots whose series no slot reads are tested, as in
 * straight-line code (series_native.c explains why those suffice), in a
 * last part that reads their series from a table. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "graph/series_gen.h"

/* Blocks per generated function (a compiler slows down on a function of
 * hundreds of loops). */
#define BLOCKS_PER_PART 24

typedef struct sorder {
  int level, kernel, i;
  unsigned n;
} sorder;

static int sorder_cmp(const void *x, const void *y)
{
  const sorder *u = x, *w = y;
  if (u->level != w->level) return u->level < w->level ? -1 : 1;
  if (u->kernel != w->kernel) return u->kernel < w->kernel ? -1 : 1;
  if (u->n != w->n) return u->n < w->n ? -1 : 1;
  return (u->i > w->i) - (u->i < w->i);
}

static int same_block(const sorder *u, const sorder *w)
{
  return u->level == w->level && u->kernel == w->kernel && u->n == w->n;
}

/* Which operands a kernel reads besides z and a. */
static int reads_b(int k)
{
  return k == NZ_SK_ADD || k == NZ_SK_SUB || k == NZ_SK_MUL || k == NZ_SK_DIV || k == NZ_SK_POW ||
         k == NZ_SK_ATAN2 || k == NZ_SK_HYPOT;
}
static int reads_aux(int k)
{
  return k == NZ_SK_POWI || k == NZ_SK_POW || k == NZ_SK_SIN || k == NZ_SK_COS || k == NZ_SK_SINH ||
         k == NZ_SK_COSH || k == NZ_SK_TAN || k == NZ_SK_TANH || k == NZ_SK_ATAN || k == NZ_SK_ASIN ||
         k == NZ_SK_ACOS || k == NZ_SK_ATAN2 || k == NZ_SK_HYPOT;
}
static int reads_v(int k) { return k == NZ_SK_SCALE || k == NZ_SK_DIVC || k == NZ_SK_POWR || k == NZ_SK_HYPOT; }

/* The slots in running order; -1 when memory ran out. */
static int schedule(const nz_series_slot *slots, int n, int nseries, sorder *order)
{
  int *level = calloc((size_t)nseries + 1, sizeof *level);
  if (!level) return -1;
  for (int i = 0; i < n; i++) {   /* the plan's order is topological */
    const nz_series_slot *r = &slots[i];
    int l = level[r->a] > level[r->b] ? level[r->a] : level[r->b];
    level[r->z] = l + 1;
    order[i] = (sorder){ l + 1, r->kernel, i, r->kernel == NZ_SK_POWI ? r->n : 0 };
  }
  free(level);
  qsort(order, (size_t)n, sizeof *order, sorder_cmp);
  return 0;
}

/* One block: slots order[0..cnt) of one kernel, their tables appended. */
static void emit_block(nz_sbuf *b, const nz_series_slot *slots, const sorder *order, int cnt, nz_ctab *t)
{
  int kernel = order[0].kernel;
  const char *names[5] = { "Z", "A", "B", "W", "I" };
  int want[5] = { 1, kernel != NZ_SK_STEP, reads_b(kernel), reads_aux(kernel), reads_v(kernel) };
  nz_sb_printf(b, "  {");
  for (int f = 0; f < 5; f++) {
    if (!want[f]) continue;
    nz_sb_printf(b, " const int32_t *%s = nzc_T + %zu;", names[f], t->n);
    for (int j = 0; j < cnt; j++) {
      const nz_series_slot *r = &slots[order[j].i];
      nz_ctab_push(t, f == 0 ? r->z : f == 1 ? r->a : f == 2 ? r->b : f == 3 ? r->aux : order[j].i);
    }
  }
  nz_sb_printf(b, "\n  for (int j = 0; j < %d; j++) {\n", cnt);
  nz_series_ref ref = { "Z[j]", "A[j]", want[2] ? "B[j]" : "A[j]", { "W[j]", "W[j] + 1", "W[j] + 2", "W[j] + 3" },
                        "v[I[j]]", "v[I[j]]", order[0].n };
  nz_series_emit_kernel(b, kernel, &ref);
  nz_sb_printf(b, "  } }\n");
}

static void part_head(nz_sbuf *b, int part)
{
  nz_sb_printf(b, "\nstatic NZS_NOINLINE double nzs_part%d(int k, int L, double *restrict S, double *restrict v, "
                  "void (*const *K)(void))\n{\n  const size_t l = (size_t)L;\n  int bad = 0;\n"
                  "  (void)v; (void)K;\n", part);
}

int nz_series_emit_compact(nz_sbuf *b, const nz_series_slot *slots, int n, int nseries, const char *used,
                           nz_ctab *tab)
{
  sorder *order = malloc(((size_t)n + 1) * sizeof *order);
  nz_sbuf body = { 0 };
  int part = 0, inpart = 0;
  if (!order || schedule(slots, n, nseries, order)) {
    free(order);
    b->oom = 1;
    return 0;
  }
  for (int i = 0; i < n;) {
    int j = i;
    while (j < n && same_block(&order[j], &order[i])) j++;
    if (inpart == 0) part_head(&body, part);
    emit_block(&body, slots, order + i, j - i, tab);
    if (++inpart == BLOCKS_PER_PART || j == n) {
      nz_sb_printf(&body, "  return bad ? NAN : 0.0;\n}\n");
      part++;
      inpart = 0;
    }
    i = j;
  }
  /* the tests: the series no slot reads, padded to a multiple of 4 by
   * repeating the last */
  size_t chk = tab->n, nchk = 0;
  for (int i = 0; i < n; i++)
    if (!used[slots[i].z]) nz_ctab_push(tab, slots[i].z), nchk++;
  for (; nchk % 4 && nchk > 0; nchk++) nz_ctab_push(tab, tab->v[tab->n - 1]);
  part_head(&body, part);
  nz_sb_printf(&body, "  const int32_t *CHK = nzc_T + %zu;\n  double c0 = 0.0, c1 = 0.0, c2 = 0.0, c3 = 0.0;\n"
                      "  for (int j = 0; j < %zu; j += 4) {\n"
                      "    c0 += SER(CHK[j])[k] * 0.0; c1 += SER(CHK[j + 1])[k] * 0.0;\n"
                      "    c2 += SER(CHK[j + 2])[k] * 0.0; c3 += SER(CHK[j + 3])[k] * 0.0;\n  }\n"
                      "  (void)bad;\n  return (c0 + c1) + (c2 + c3);\n}\n", chk, nchk);
  part++;
  nz_ctab_declare(b, tab);   /* after the tables are whole: the hashes */
  nz_sb_printf(b, "%s", body.s ? body.s : "");
  if (body.oom || tab->oom) b->oom = 1;
  free(body.s);
  free(order);
  return part;
}
