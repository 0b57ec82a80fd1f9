/* native_cache.h - the cache of compiled objects: as the rest of nzlua sees
 * it (where it is, whether it can be trusted, how big it is, emptying it),
 * then the cache's files as native_object.c handles them (the trusted
 * directory's descriptor, each object's checks and trailer, the bound, the
 * settings).  The rules (trust, integrity, size) are written out in
 * native_object.h.
 *
 * Plain C: never includes lua.h, never prints (notices go to the callback
 * nz_native_set_notice). */
#ifndef NZ_NATIVE_CACHE_H
#define NZ_NATIVE_CACHE_H

#include <stddef.h>
#include <sys/types.h>

/* The cache directory: $NZLUA_CACHE, else $XDG_CACHE_HOME/nzlua, else
 * $HOME/.cache/nzlua, each only when it is an absolute path (a relative
 * NZLUA_CACHE or XDG_CACHE_HOME is ignored, with one notice line, as the
 * XDG specification says of the latter: it would name another directory in
 * every working directory).  Written into buf[n]; returns buf, or NULL with
 * the reason in why (no usable variable: there is no cache, and no
 * fallback under /tmp). */
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

/* Remove every file nzlua wrote there (objects whose trailer says they are
 * nzlua's, kept sources, locks, temporaries); nothing else, and nothing at
 * all from a directory that is not trusted.  The count removed, or -1 with
 * the reason. */
int nz_native_cache_clear(const char *dir, char *why, size_t whylen);

/* The size limit in bytes ($NZLUA_CACHE_MAX, default 100 MB). */
long long nz_native_cache_limit(void);

/* Where one-line notices go (an object found damaged and removed, a
 * setting refused or clamped): the binding prints them; NULL drops them. */
void nz_native_set_notice(void (*fn)(const char *line));

/* -- The cache's files, for native_object.c ------------------------------ */

/* A one-line reason into why[n] (why may be NULL). */
void nz_native_say(char *why, size_t n, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* Bytes of the trailer after the compiler's output. */
#define NZ_NATIVE_TRAILER 40

/* A descriptor of the cache directory dir when it is trusted, else -1 with
 * the reason.  dir is walked from '/' one component at a time through
 * descriptors (symbolic links resolved along the way, each checked where
 * it lies): every directory passed must be root's or the user's and
 * writable by neither group nor others, unless it is sticky and what is
 * taken from it is the user's own; the cache directory itself must be the
 * user's and writable by no one else.  With create, missing directories
 * are made (mkdirat, then fchmod 0700 on the descriptor of what was made). */
int nz_native_cache_open(const char *dir, int create, char *why, size_t whylen);
/* The object called name in the directory dfd, for the key: 1 with *fd
 * open on it (O_NOFOLLOW) when it passes every check (owner, mode, a regular
 * file, the trailer, the checksum, the ELF segments inside the file, nothing
 * that runs on load: native_elf.h; its modification time is set to now, for
 * the least-recently-used rule); 0 when there is none; -1 when it is there
 * but fails, why saying what. */
int nz_native_cache_check(int dfd, const char *name, const char *key, int *fd, char *why, size_t whylen);
/* The compiler's output open in fd, of the user's: check that it is a
 * whole shared object that runs nothing on load, append the trailer for
 * key, make it 0600, fsync it.  0, or -1 with the reason (-2 when the
 * object was refused for what it would run or load: native_elf.h). */
int nz_native_cache_seal(int fd, const char *key, char *why, size_t whylen);
/* After a compile: temporaries and locks left by dead workers removed,
 * then objects, least recently used first, until the cache is under its
 * limit (never keep, the one just made). */
void nz_native_cache_prune(int dfd, const char *keep);
/* Remove the directory name in dfd where a compile ran, with the files in
 * it (the source, the object, the compiler's messages and temporaries).
 * 0, or -1 with errno. */
int nz_native_cache_remove_temp(int dfd, const char *name);
/* A one-line notice to the binding's callback. */
void nz_native_notice(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* Seconds a compiler may run before it is stopped ($NZLUA_CC_TIMEOUT,
 * default 300), and compile workers at once per process ($NZLUA_CC_JOBS,
 * default 2).  A value that is not what the setting accepts is refused,
 * one out of range clamped, each with one notice line. */
double nz_native_cc_timeout(void);
int nz_native_cc_jobs(void);

#endif
