/* native_object.h - generated C compiled by the system's C compiler into a
 * shared object, kept in a cache on disk, checked, and loaded back: the one
 * place of nzlua that writes and runs machine code, shared by the code
 * generators of src/graph (graph_native.c: plans on doubles;
 * series_native.c: series built order by order).
 *
 * Trust.  Machine code runs as the user, so nothing another local user
 * controls may reach it (native_cache.h has the checks).  The cache
 * directory is walked from '/' through descriptors: every directory on the
 * way is root's or the user's and writable by no one else unless it is
 * sticky and the next step is the user's own (OpenSSH's rule for
 * authorized_keys); the cache directory is the user's alone.  An object is
 * loaded only when the file itself is a regular file of the user's that
 * neither group nor others can write.  The compiler runs in a private
 * directory made under the checked directory's descriptor and is given
 * relative names, so no path it sees can be moved.  The object is opened
 * with O_NOFOLLOW, checked on the open descriptor, refused if it would run
 * or load code when loaded (native_elf.h: constructors, IFUNC resolvers,
 * libraries other than libc and libm, text relocations, an executable
 * stack; nzlua links with -nostartfiles so its objects have none) and
 * loaded from that descriptor (/proc/self/fd/N), so the file checked is the
 * file loaded.  There is no fallback under /tmp: without an absolute
 * $NZLUA_CACHE, $XDG_CACHE_HOME or $HOME there is no cache and the
 * interpreter runs.  Directories are made 0700 (mkdirat, then fchmod on
 * the new directory's descriptor) and objects written 0600 whatever the
 * umask.
 *
 * Integrity.  Every object carries a trailer of 40 bytes appended after the
 * compiler's output: a magic, the key it is named after, the length of the
 * shared object before the trailer and a 64-bit checksum of those bytes.
 * Before loading, the trailer is read, the checksum recomputed and the ELF
 * headers' segments checked to lie inside the file (a truncated object
 * would fault with SIGBUS inside dlopen; a flipped bit with SIGILL later).
 * An object that fails is removed and compiled again, with one notice
 * line.  Objects are written under a temporary name, fsync'ed and renamed
 * into place (then the directory fsync'ed), so a crash or a power loss
 * leaves either nothing or a whole object.  The checksum guards against
 * damage, not against an attacker: trust comes from ownership and modes.
 *
 * Key.  The file's name is <prefix>-<16 hex digits>.so, the digits a 64-bit
 * hash of the generator's version, the machine (uname), the compiler's
 * words and flags, the compiler's identity (what `$CC --version` prints, so
 * a CC that now points at another compiler does not reuse an old object)
 * and the source.
 *
 * The compiler is $CC if set (words split on blanks, e.g. "ccache gcc"),
 * else "cc", run with -O2 (or the -O1 a caller asks for big sources;
 * $NZLUA_COPT overrides), -fPIC -shared -nostartfiles -ffp-contract=off
 * -fno-builtin -fno-math-errno: a fused multiply-add, or sin(atan(x)) rewritten as
 * x / sqrt(1 + x^2), would round differently from the interpreter the code
 * stands in for.  Flags that break that promise (-Ofast, -ffast-math,
 * -funsafe-math-optimizations, ...) in CC or NZLUA_COPT are refused.
 *
 * Time.  A compile runs in a worker process (forked, in a session of its
 * own so that Ctrl-C at the terminal does not kill it), which takes a lock
 * file for the key (two processes needing the same object share one
 * compile), runs the compiler under a time limit ($NZLUA_CC_TIMEOUT
 * seconds, default 300, at most 86400), writes the object and bounds the cache; the
 * caller goes on and polls.  A worker whose caller has exited finishes
 * alone: a short run still leaves its object for the next one.  At most
 * $NZLUA_CC_JOBS workers (default 2) run at once per process; more wait
 * their turn.
 *
 * Size.  After each compile the cache is kept under $NZLUA_CACHE_MAX bytes
 * (default 100 MB, at most 1 TB; suffixes K, M, G, T), the least recently used objects
 * removed first (loading an object marks it used).  The generated source is
 * removed unless NZLUA_KEEP_C=1.
 *
 * Internal to src/graph (graph_native.h has the public face).  Plain C: no
 * Lua, no printing (notices go to the callback nz_native_set_notice). */
#ifndef NZ_NATIVE_OBJECT_H
#define NZ_NATIVE_OBJECT_H

#include <stddef.h>
#include <sys/types.h>
#include "graph/native_cache.h"

/* A growing string, for generating source: an allocation failure sets oom
 * and later calls do nothing. */
typedef struct nz_sbuf {
  char *s;
  size_t len, cap;
  int oom;
} nz_sbuf;
void nz_sb_printf(nz_sbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* v as a C expression that is exactly v: a hexadecimal literal, NAN,
 * HUGE_VAL or (-HUGE_VAL). */
void nz_native_literal(char *s, size_t n, double v);

struct nz_native_job;

typedef struct nz_native_object {
  void *dl;          /* dlopen's handle (NULL while compiling) */
  void *entry;       /* the symbol asked for */
  double seconds;    /* the compile's wall time, 0 when it came from the cache */
  double waited;     /* of which the caller waited (a compile asked to wait) */
  char *path;        /* the shared object's path (malloc'd) */
  struct nz_native_job *job;   /* a compile under way */
} nz_native_object;

/* How nz_native_object_get may obtain an object that is not in the cache. */
enum {
  NZ_NATIVE_LOOKUP = 0,      /* not at all: "not in the cache" */
  NZ_NATIVE_WAIT = 1,        /* compile it now and wait */
  NZ_NATIVE_BACKGROUND = 2   /* start compiling it and return at once */
};

/* The object of src: loaded from cache_dir when it is there and passes the
 * checks, else obtained as `how` says.  version is the generator's (a new
 * version never loads an old object); prefix names the files; entry is the
 * symbol to return; big asks for -O1.  t_start: when generating began
 * (nz_native_now).  Returns 0 with the object loaded, 1 when a background
 * compile is under way (poll with nz_native_object_ready), -1 with a
 * one-line reason in why. */
int nz_native_object_get(const char *src, const char *version, const char *prefix, const char *entry,
                         int big, int how, const char *cache_dir, double t_start,
                         nz_native_object *o, char *why, size_t whylen);
/* A background compile: 0 once the object is loaded, 1 while it is under
 * way (or waiting for a free worker), -1 with the reason when it failed.
 * wait = 1 blocks until it is done (a Ctrl-C request, nz_interrupt, stops
 * the wait and returns 1). */
int nz_native_object_ready(nz_native_object *o, int wait, char *why, size_t whylen);
/* Unload, or forget a compile under way (its worker finishes the cache
 * entry alone), and free the path. */
void nz_native_object_close(nz_native_object *o);

/* A monotonic clock in seconds. */
double nz_native_now(void);

#endif
