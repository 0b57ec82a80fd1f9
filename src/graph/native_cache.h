/* native_cache.h - the cache of compiled objects, as the rest of nzlua sees
 * it: where it is, whether it can be trusted, how big it is, emptying it.
 * The rules (trust, integrity, size) are written out in native_object.h.
 *
 * Plain C: never includes lua.h, never prints. */
#ifndef NZ_NATIVE_CACHE_H
#define NZ_NATIVE_CACHE_H

#include <stddef.h>

/* The cache directory: $NZLUA_CACHE, else $XDG_CACHE_HOME/nzlua (when
 * absolute), else $HOME/.cache/nzlua (when absolute).  Written into buf[n];
 * returns buf, or NULL with the reason in why (no usable variable: there is
 * no cache, and no fallback under /tmp). */
const char *nz_native_cache_dir(char *buf, size_t n, char *why, size_t whylen);

/* What is in it: objects, their bytes, the size limit; trusted = 1 when
 * machine code would be loaded from it (else why says why not).  0, or -1
 * with the reason (no directory). */
typedef struct nz_native_cache_stat {
  int objects, sources, others;
  long long bytes, limit;
  int trusted;
  char why[300];
} nz_native_cache_stat;
int nz_native_cache_info(const char *dir, nz_native_cache_stat *st, char *why, size_t whylen);

/* Remove every file nzlua wrote there (objects, kept sources, locks,
 * temporaries); nothing else.  The count removed, or -1 with the reason. */
int nz_native_cache_clear(const char *dir, char *why, size_t whylen);

/* The size limit in bytes ($NZLUA_CACHE_MAX, default 100 MB). */
long long nz_native_cache_limit(void);

/* Where one-line notices go (an object found damaged and removed): the
 * binding prints them; NULL drops them. */
void nz_native_set_notice(void (*fn)(const char *line));

#endif
