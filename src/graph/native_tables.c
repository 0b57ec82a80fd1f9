/* native_tables.c - the index tables of compact code (native_tables.h). */
#include <dlfcn.h>
#include <stdlib.h>
#include <string.h>
#include "graph/native_tables.h"

int nz_native_compact(int size, int threshold)
{
  const char *e = getenv("NZLUA_COMPACT");
  if (e && !strcmp(e, "0")) return 0;
  if (e && !strcmp(e, "1")) return 1;
  return size > threshold;
}

size_t nz_ctab_push(nz_ctab *t, int32_t x)
{
  if (t->n == t->cap) {
    size_t cap = t->cap ? 2 * t->cap : 1024;
    int32_t *v = t->oom ? NULL : realloc(t->v, cap * sizeof *v);
    if (!v) {
      t->oom = 1;
      return t->n;
    }
    t->v = v;
    t->cap = cap;
  }
  t->v[t->n] = x;
  return t->n++;
}

/* FNV-1a over the entries' bytes from two offset bases (independent
 * enough for naming: the second also folds the position in). */
static void table_hashes(const nz_ctab *t, uint64_t *h1, uint64_t *h2)
{
  uint64_t a = 0xcbf29ce484222325ULL, b = 0x84222325cbf29ce4ULL;
  for (size_t i = 0; i < t->n; i++) {
    uint32_t x = (uint32_t)t->v[i];
    for (int k = 0; k < 4; k++) {
      a = (a ^ ((x >> (8 * k)) & 0xff)) * 0x100000001b3ULL;
      b = (b ^ ((x >> (8 * k)) & 0xff) ^ (i & 0xff)) * 0x100000001b3ULL;
    }
  }
  *h1 = a;
  *h2 = b;
}

void nz_ctab_declare(nz_sbuf *b, const nz_ctab *t)
{
  uint64_t h1, h2;
  table_hashes(t, &h1, &h2);
  nz_sb_printf(b, "#include <stdint.h>\n/* index tables: %zu entries, written by the loader; hashes %016llx %016llx */\n"
                  "int32_t nzc_T[%zu];\n", t->n, (unsigned long long)h1, (unsigned long long)h2,
               t->n ? t->n : 1);
}

int nz_ctab_fill(void *dl, const nz_ctab *t, char *why, size_t whylen)
{
  int32_t *T = dl ? dlsym(dl, "nzc_T") : NULL;
  if (!T) {
    nz_native_say(why, whylen, "a compact object without its index table");
    return -1;
  }
  if (t->n) memcpy(T, t->v, t->n * sizeof *T);
  return 0;
}

void nz_ctab_free(nz_ctab *t)
{
  free(t->v);
  memset(t, 0, sizeof *t);
}
