/* native_object.h - generated C compiled by the system's C compiler into a
 * shared object, cached on disk under a hash of its source, and loaded
 * back with dlopen: the machinery shared by the code generators of
 * src/graph (graph_native.c: plans on doubles; series_native.c: series
 * built order by order).
 *
 * The compiler is $CC if set (words split on blanks, e.g. "ccache gcc"),
 * else "cc", run with -O2 (or the -O1 a caller asks for big sources;
 * $NZLUA_COPT overrides), -fPIC -shared -ffp-contract=off -fno-builtin
 * -fno-math-errno: a fused multiply-add, or sin(atan(x)) rewritten as
 * x / sqrt(1 + x^2), would round differently from the interpreter the code
 * stands in for; never -ffast-math.
 *
 * Files.  The cache holds <prefix>-<hash>.c and <prefix>-<hash>.so, hash =
 * 64-bit FNV-1a of the generator's version, the machine, the compiler
 * command and the source.  Both are written under unique temporary names
 * and renamed into place, so two processes compiling the same source at
 * once both succeed and the files are always whole.  The object names
 * itself (a string nzn_id holding the hash), so that loading checks it is
 * the object it is named after.  Nothing prunes the cache.
 *
 * Internal to src/graph.  Plain C: no Lua, no printing. */
#ifndef NZ_NATIVE_OBJECT_H
#define NZ_NATIVE_OBJECT_H

#include <stddef.h>

/* A growing string, for generating source: an allocation failure sets oom
 * and later calls do nothing. */
typedef struct nz_sbuf {
  char *s;
  size_t len, cap;
  int oom;
} nz_sbuf;
void nz_sb_printf(nz_sbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* A one-line reason into why[n] (why may be NULL). */
void nz_native_say(char *why, size_t n, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* v as a C expression that is exactly v: a hexadecimal literal, NAN,
 * HUGE_VAL or (-HUGE_VAL). */
void nz_native_literal(char *s, size_t n, double v);

typedef struct nz_native_object {
  void *dl;          /* dlopen's handle */
  void *entry;       /* the symbol asked for */
  double seconds;    /* generation to loading, 0 when it came from the cache */
  char *path;        /* the shared object's path (malloc'd) */
} nz_native_object;

/* The object of src: loaded from cache_dir (created if missing) when it is
 * there, else compiled (compile = 1) or refused (compile = 0, "not in the
 * cache").  version is the generator's (a new version never loads an old
 * object); prefix names the files; entry is the symbol to return; big asks
 * for -O1 (half the compile time of a huge source, the same speed).
 * t_start: when generating began (nz_native_now), for o->seconds.
 * 0, or -1 with a one-line reason in why. */
int nz_native_object_get(const char *src, const char *version, const char *prefix, const char *entry,
                         int big, int compile, const char *cache_dir, double t_start,
                         nz_native_object *o, char *why, size_t whylen);
void nz_native_object_close(nz_native_object *o);   /* and free its path */

/* A monotonic clock in seconds. */
double nz_native_now(void);

#endif
