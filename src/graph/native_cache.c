/* native_cache.c - the cache directory of compiled objects and the files in
 * it: where it is, whether it is trusted, each object's checks and trailer,
 * the size bound, emptying it (the rules: native_object.h). */
#include <dirent.h>
#include <elf.h>
#include <errno.h>
#include <fcntl.h>
#include <link.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <time.h>
#include <unistd.h>
#include "graph/native_cache.h"
#include "graph/native_object.h"

/* ------------------------------------------------------------------ */
/* Settings and notices                                                 */

double nz_native_setting(const char *name, double def, int bytes)
{
  const char *e = getenv(name);
  if (!e || !*e) return def;
  char *end;
  double v = strtod(e, &end);
  if (bytes && *end) {
    double unit = 1;
    switch (*end) {
      case 'k': case 'K': unit = 1024.0; break;
      case 'm': case 'M': unit = 1024.0 * 1024.0; break;
      case 'g': case 'G': unit = 1024.0 * 1024.0 * 1024.0; break;
      default: return def;
    }
    v *= unit;
    end++;
  }
  return end != e && !*end && v > 0 ? v : def;
}

long long nz_native_cache_limit(void)
{
  return (long long)nz_native_setting("NZLUA_CACHE_MAX", 100.0 * 1024 * 1024, 1);
}

double nz_native_cc_timeout(void) { return nz_native_setting("NZLUA_CC_TIMEOUT", 300, 0); }

int nz_native_cc_jobs(void) { return (int)nz_native_setting("NZLUA_CC_JOBS", 2, 0); }

static void (*notice_fn)(const char *);

void nz_native_set_notice(void (*fn)(const char *line)) { notice_fn = fn; }

void nz_native_notice(const char *fmt, ...)
{
  if (!notice_fn) return;
  char line[700];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(line, sizeof line, fmt, ap);
  va_end(ap);
  notice_fn(line);
}

/* ------------------------------------------------------------------ */
/* The directory                                                        */

/* An absolute path from the environment variable, or NULL. */
static const char *absolute(const char *name)
{
  const char *e = getenv(name);
  return e && e[0] == '/' ? e : NULL;
}

const char *nz_native_cache_dir(char *buf, size_t n, char *why, size_t whylen)
{
  const char *e;
  int k;
  if ((e = getenv("NZLUA_CACHE")) && *e) k = snprintf(buf, n, "%s", e);
  else if ((e = absolute("XDG_CACHE_HOME"))) k = snprintf(buf, n, "%s/nzlua", e);
  else if ((e = absolute("HOME"))) k = snprintf(buf, n, "%s/.cache/nzlua", e);
  else {
    /* Never /tmp/nzlua-<uid>: anyone can create that name first. */
    nz_native_say(why, whylen, "no cache directory for machine code: HOME is not set to an absolute path, nor "
                  "NZLUA_CACHE or XDG_CACHE_HOME (set NZLUA_CACHE to a directory of your own to compile; the "
                  "interpreter runs meanwhile)");
    return NULL;
  }
  if (k < 0 || (size_t)k >= n) {
    nz_native_say(why, whylen, "the cache directory's path is too long (set NZLUA_CACHE to a shorter one)");
    return NULL;
  }
  return buf;
}

/* mkdir -p; what it creates is 0700 whatever the umask. */
static int make_dirs(const char *dir, char *why, size_t whylen)
{
  char p[4096];
  if (!*dir || strlen(dir) >= sizeof p) {
    nz_native_say(why, whylen, "cache directory '%s': empty or too long a path", dir);
    return -1;
  }
  strcpy(p, dir);
  for (char *s = p + 1;; s++) {
    if (*s != '/' && *s) continue;
    char c = *s;
    *s = 0;
    if (mkdir(p, 0700) == 0) {
      if (chmod(p, 0700)) {
        nz_native_say(why, whylen, "cannot set the mode of the new cache directory '%s': %s", p, strerror(errno));
        return -1;
      }
    } else if (errno != EEXIST) {
      nz_native_say(why, whylen, "cannot create the cache directory '%s': %s (set NZLUA_CACHE to a directory of "
                    "your own; the interpreter runs meanwhile)", p, strerror(errno));
      return -1;
    }
    *s = c;
    if (!c) break;
  }
  return 0;
}

/* Why the directory open in fd is not trusted, or NULL. */
static int untrusted_dir(int fd, const char *dir, char *why, size_t whylen)
{
  struct stat st;
  if (fstat(fd, &st)) {
    nz_native_say(why, whylen, "cannot read the cache directory '%s': %s", dir, strerror(errno));
    return 1;
  }
  if (st.st_uid != geteuid()) {
    nz_native_say(why, whylen, "the cache directory '%s' belongs to another user (uid %lu): machine code is loaded "
                  "only from a directory of your own (set NZLUA_CACHE to one; the interpreter runs meanwhile)",
                  dir, (unsigned long)st.st_uid);
    return 1;
  }
  if (st.st_mode & (S_IWGRP | S_IWOTH)) {
    nz_native_say(why, whylen, "the cache directory '%s' can be written by %s (mode %04o): another user could plant "
                  "code there; machine code is not loaded from it (chmod go-w '%s', or set NZLUA_CACHE to a "
                  "directory of your own; the interpreter runs meanwhile)", dir,
                  (st.st_mode & S_IWOTH) ? "others" : "its group", (unsigned)(st.st_mode & 07777), dir);
    return 1;
  }
  return 0;
}

int nz_native_cache_open(const char *dir, int create, char *why, size_t whylen)
{
  if (create && make_dirs(dir, why, whylen)) return -1;
  int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) {
    nz_native_say(why, whylen, "cannot open the cache directory '%s': %s (set NZLUA_CACHE to a directory of your "
                  "own; the interpreter runs meanwhile)", dir, strerror(errno));
    return -1;
  }
  if (untrusted_dir(fd, dir, why, whylen)) {
    close(fd);
    return -1;
  }
  return fd;
}

/* ------------------------------------------------------------------ */
/* An object's checks                                                   */

static const char MAGIC[8] = { 'n', 'z', 'l', 'u', 'a', 0, 'o', '1' };

static void put64(unsigned char *p, uint64_t v)
{
  for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i));
}

static uint64_t get64(const unsigned char *p)
{
  uint64_t v = 0;
  for (int i = 7; i >= 0; i--) v = v << 8 | p[i];
  return v;
}

/* All n bytes read (out = 0) or written (out = 1) at offset at, through
 * interrupted calls; 0, or -1. */
static int transfer(int fd, void *buf, size_t n, off_t at, int out)
{
  unsigned char *p = buf;
  while (n) {
    ssize_t k = out ? pwrite(fd, p, n, at) : pread(fd, p, n, at);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return -1;
    p += k;
    n -= (size_t)k;
    at += k;
  }
  return 0;
}

static int read_at(int fd, void *buf, size_t n, off_t at) { return transfer(fd, buf, n, at, 0); }

int nz_native_write_at(int fd, const void *buf, size_t n, off_t at) { return transfer(fd, (void *)buf, n, at, 1); }

/* The checksum of the first n bytes: words folded in by a bijection of the
 * state each (xor, an odd multiplier, a shift-xor), so one damaged word
 * always changes the result and several almost always do.  Not a
 * cryptographic hash: it detects damage; trust comes from ownership. */
static int checksum(int fd, long long n, uint64_t *out)
{
  enum { CHUNK = 1 << 16 };
  unsigned char *buf = malloc(CHUNK);
  if (!buf) return -1;
  uint64_t h = 0x6a09e667f3bcc909ULL;
  for (long long at = 0; at < n;) {
    size_t len = n - at < CHUNK ? (size_t)(n - at) : CHUNK;
    if (read_at(fd, buf, len, (off_t)at)) { free(buf); return -1; }
    size_t i = 0;
    for (; i + 8 <= len; i += 8) {
      uint64_t w;
      memcpy(&w, buf + i, 8);
      h = (h ^ w) * 0x9e3779b97f4a7c15ULL;
      h ^= h >> 32;
    }
    for (; i < len; i++) {   /* only in the last chunk: CHUNK is a multiple of 8 */
      h = (h ^ buf[i]) * 0x100000001b3ULL;
      h ^= h >> 29;
    }
    at += (long long)len;
  }
  free(buf);
  h = (h ^ (uint64_t)n) * 0x9e3779b97f4a7c15ULL;
  *out = h ^ (h >> 31);
  return 0;
}

/* The first size bytes of fd hold a whole shared object of this machine's
 * class: its program headers and every loaded segment, and its section
 * headers, lie inside them (a truncated object faults inside dlopen). */
static int elf_whole(int fd, long long size, char *why, size_t whylen)
{
  ElfW(Ehdr) e;
  if (size < (long long)sizeof e || read_at(fd, &e, sizeof e, 0) || memcmp(e.e_ident, ELFMAG, SELFMAG)) {
    nz_native_say(why, whylen, "not a shared object (%lld bytes, no ELF header)", size);
    return -1;
  }
  if (e.e_ident[EI_CLASS] != (sizeof(void *) == 8 ? ELFCLASS64 : ELFCLASS32) || e.e_type != ET_DYN ||
      e.e_phentsize != sizeof(ElfW(Phdr))) {
    nz_native_say(why, whylen, "not a shared object of this machine's kind");
    return -1;
  }
  long long ph_end = (long long)e.e_phoff + (long long)e.e_phnum * e.e_phentsize;
  long long sh_end = e.e_shnum ? (long long)e.e_shoff + (long long)e.e_shnum * e.e_shentsize : 0;
  if (ph_end > size || sh_end > size) {
    nz_native_say(why, whylen, "truncated: %lld bytes, its headers reach byte %lld", size,
                  ph_end > sh_end ? ph_end : sh_end);
    return -1;
  }
  for (int i = 0; i < e.e_phnum; i++) {
    ElfW(Phdr) ph;
    if (read_at(fd, &ph, sizeof ph, (off_t)(e.e_phoff + (size_t)i * sizeof ph))) {
      nz_native_say(why, whylen, "cannot read its program header %d", i);
      return -1;
    }
    if (ph.p_type == PT_LOAD && (long long)(ph.p_offset + ph.p_filesz) > size) {
      nz_native_say(why, whylen, "truncated: %lld bytes, a segment reaches byte %lld", size,
                    (long long)(ph.p_offset + ph.p_filesz));
      return -1;
    }
  }
  return 0;
}

/* A regular file of the user's that neither group nor others can write. */
static int untrusted_file(const struct stat *st, char *why, size_t whylen)
{
  if (!S_ISREG(st->st_mode)) nz_native_say(why, whylen, "is not a regular file");
  else if (st->st_uid != geteuid()) nz_native_say(why, whylen, "belongs to another user (uid %lu)", (unsigned long)st->st_uid);
  else if (st->st_mode & (S_IWGRP | S_IWOTH))
    nz_native_say(why, whylen, "can be written by group or others (mode %04o)", (unsigned)(st->st_mode & 07777));
  else return 0;
  return 1;
}

int nz_native_cache_check(int dfd, const char *name, const char *key, int *fdp, char *why, size_t whylen)
{
  /* O_NONBLOCK: a FIFO planted under the name must not hang the open. */
  int fd = openat(dfd, name, O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    if (errno == ENOENT) return 0;
    if (errno == ELOOP) nz_native_say(why, whylen, "is a symbolic link");
    else nz_native_say(why, whylen, "cannot be opened: %s", strerror(errno));
    return -1;
  }
  struct stat st;
  unsigned char t[NZ_NATIVE_TRAILER];
  uint64_t h = 0;
  if (fstat(fd, &st)) {
    nz_native_say(why, whylen, "cannot be read: %s", strerror(errno));
    goto bad;
  }
  if (untrusted_file(&st, why, whylen)) goto bad;
  long long size = (long long)st.st_size, payload = size - NZ_NATIVE_TRAILER;
  if (payload < 64 || read_at(fd, t, sizeof t, (off_t)payload) || memcmp(t, MAGIC, 8)) {
    nz_native_say(why, whylen, "is damaged: %lld bytes without nzlua's trailer (truncated, or not written by nzlua)",
                  size);
    goto bad;
  }
  if (memcmp(t + 8, key, 16)) {
    nz_native_say(why, whylen, "is not the object it is named after (its trailer names %.16s)", (const char *)t + 8);
    goto bad;
  }
  if ((long long)get64(t + 24) != payload) {
    nz_native_say(why, whylen, "is damaged: %lld bytes where its trailer says %lld", payload,
                  (long long)get64(t + 24));
    goto bad;
  }
  if (checksum(fd, payload, &h) || h != get64(t + 32)) {
    nz_native_say(why, whylen, "is damaged: its content does not match its checksum");
    goto bad;
  }
  char ewhy[200];
  if (elf_whole(fd, payload, ewhy, sizeof ewhy)) {
    nz_native_say(why, whylen, "is damaged: %s", ewhy);
    goto bad;
  }
  futimens(fd, NULL);   /* used now: the least-recently-used rule */
  *fdp = fd;
  return 1;
bad:
  close(fd);
  return -1;
}

int nz_native_cache_seal(int fd, const char *key, char *why, size_t whylen)
{
  struct stat st;
  if (fstat(fd, &st) || !S_ISREG(st.st_mode) || st.st_uid != geteuid()) {
    nz_native_say(why, whylen, "the compiler's output is not a regular file of yours");
    return -1;
  }
  char ewhy[200];
  if (elf_whole(fd, (long long)st.st_size, ewhy, sizeof ewhy)) {
    nz_native_say(why, whylen, "the C compiler exited 0 but its output is not a whole shared object (%s)", ewhy);
    return -1;
  }
  unsigned char t[NZ_NATIVE_TRAILER];
  uint64_t h;
  memcpy(t, MAGIC, 8);
  memcpy(t + 8, key, 16);
  put64(t + 24, (uint64_t)st.st_size);
  if (checksum(fd, (long long)st.st_size, &h)) {
    nz_native_say(why, whylen, "cannot read the compiler's output: %s", strerror(errno));
    return -1;
  }
  put64(t + 32, h);
  if (nz_native_write_at(fd, t, sizeof t, st.st_size) || fchmod(fd, 0600) || fsync(fd)) {
    nz_native_say(why, whylen, "cannot write the object in the cache: %s", strerror(errno));
    return -1;
  }
  return 0;
}

/* ------------------------------------------------------------------ */
/* The files nzlua writes there: size, pruning, clearing                */

enum { KIND_OTHER, KIND_OBJECT, KIND_SOURCE, KIND_LOCK, KIND_TEMP };

/* <prefix>-<16 hex digits><rest>, the prefix "nz" and a letter: what kind
 * of file (KIND_OTHER: not nzlua's). */
static int file_kind(const char *name)
{
  if (strncmp(name, "nz", 2) || name[2] < 'a' || name[2] > 'z' || name[3] != '-') return KIND_OTHER;
  for (int i = 4; i < 20; i++)
    if (!((name[i] >= '0' && name[i] <= '9') || (name[i] >= 'a' && name[i] <= 'f'))) return KIND_OTHER;
  const char *rest = name + 20;
  if (!strcmp(rest, ".so")) return KIND_OBJECT;
  if (!strcmp(rest, ".c")) return KIND_SOURCE;
  if (!strcmp(rest, ".lock")) return KIND_LOCK;
  if (!strncmp(rest, ".tmp-", 5)) return KIND_TEMP;
  return KIND_OTHER;
}

typedef struct entry {
  char name[64];
  long long size;
  struct timespec mtime;
} entry;

static int older(const void *a, const void *b)
{
  const entry *x = a, *y = b;
  if (x->mtime.tv_sec != y->mtime.tv_sec) return x->mtime.tv_sec < y->mtime.tv_sec ? -1 : 1;
  return (x->mtime.tv_nsec > y->mtime.tv_nsec) - (x->mtime.tv_nsec < y->mtime.tv_nsec);
}

/* The source kept beside an object (NZLUA_KEEP_C), removed with it. */
static void unlink_with_source(int dfd, const char *object)
{
  char c[64];
  unlinkat(dfd, object, 0);
  snprintf(c, sizeof c, "%.*s.c", (int)strlen(object) - 3, object);
  unlinkat(dfd, c, 0);
}

void nz_native_cache_prune(int dfd, const char *keep)
{
  int dup_fd = fcntl(dfd, F_DUPFD_CLOEXEC, 0);
  DIR *d = dup_fd >= 0 ? fdopendir(dup_fd) : NULL;
  if (!d) {
    if (dup_fd >= 0) close(dup_fd);
    return;
  }
  entry *objs = NULL;
  size_t n = 0, cap = 0;
  long long total = 0, limit = nz_native_cache_limit();
  /* A worker is stopped after NZLUA_CC_TIMEOUT: a temporary or a lock much
   * older than that was left by one that died. */
  double stale = 2 * nz_native_cc_timeout();
  if (stale < 3600) stale = 3600;
  time_t now = time(NULL);
  struct dirent *de;
  while ((de = readdir(d))) {
    int kind = file_kind(de->d_name);
    struct stat st;
    if (kind == KIND_OTHER || strlen(de->d_name) >= sizeof objs->name ||
        fstatat(dfd, de->d_name, &st, AT_SYMLINK_NOFOLLOW) || st.st_uid != geteuid())
      continue;
    if ((kind == KIND_TEMP || kind == KIND_LOCK) && difftime(now, st.st_mtime) > stale) {
      unlinkat(dfd, de->d_name, 0);
      continue;
    }
    if (kind != KIND_OBJECT) continue;
    if (n == cap) {
      entry *e = realloc(objs, (cap = cap ? 2 * cap : 64) * sizeof *e);
      if (!e) break;
      objs = e;
    }
    memcpy(objs[n].name, de->d_name, strlen(de->d_name) + 1);   /* shorter than name: checked above */
    objs[n].size = (long long)st.st_size;
    objs[n].mtime = st.st_mtim;
    total += objs[n].size;
    n++;
  }
  closedir(d);
  if (total > limit) {
    qsort(objs, n, sizeof *objs, older);
    for (size_t i = 0; i < n && total > limit; i++) {
      if (keep && !strcmp(objs[i].name, keep)) continue;
      unlink_with_source(dfd, objs[i].name);
      total -= objs[i].size;
    }
  }
  free(objs);
}

/* Every file of nzlua's in dir (owned by the user), one call each:
 * count[kind] and bytes; remove them too when clear is set. */
static int walk(const char *dir, int clear, int count[5], long long *bytes, char *why, size_t whylen)
{
  int dfd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0) {
    nz_native_say(why, whylen, "cannot open the cache directory '%s': %s", dir, strerror(errno));
    return -1;
  }
  int dup_fd = fcntl(dfd, F_DUPFD_CLOEXEC, 0);
  DIR *d = dup_fd >= 0 ? fdopendir(dup_fd) : NULL;
  if (!d) {
    nz_native_say(why, whylen, "cannot read the cache directory '%s': %s", dir, strerror(errno));
    if (dup_fd >= 0) close(dup_fd);
    close(dfd);
    return -1;
  }
  struct dirent *de;
  while ((de = readdir(d))) {
    int kind = file_kind(de->d_name);
    struct stat st;
    if (kind == KIND_OTHER || fstatat(dfd, de->d_name, &st, AT_SYMLINK_NOFOLLOW) || st.st_uid != geteuid()) continue;
    if (clear && unlinkat(dfd, de->d_name, 0)) continue;
    count[kind]++;
    *bytes += (long long)st.st_size;
  }
  closedir(d);
  close(dfd);
  return 0;
}

int nz_native_cache_info(const char *dir, nz_native_cache_stat *st, char *why, size_t whylen)
{
  int count[5] = { 0 };
  memset(st, 0, sizeof *st);
  st->limit = nz_native_cache_limit();
  int fd = nz_native_cache_open(dir, 0, st->why, sizeof st->why);
  st->trusted = fd >= 0;
  if (fd >= 0) close(fd);
  struct stat ds;
  if (stat(dir, &ds) && errno == ENOENT) {   /* not made yet: empty */
    st->why[0] = 0;
    st->trusted = 1;
    return 0;
  }
  if (walk(dir, 0, count, &st->bytes, why, whylen)) return -1;
  st->objects = count[KIND_OBJECT];
  st->sources = count[KIND_SOURCE];
  st->others = count[KIND_LOCK] + count[KIND_TEMP];
  return 0;
}

int nz_native_cache_clear(const char *dir, char *why, size_t whylen)
{
  int count[5] = { 0 };
  long long bytes = 0;
  struct stat ds;
  if (stat(dir, &ds) && errno == ENOENT) return 0;
  if (walk(dir, 1, count, &bytes, why, whylen)) return -1;
  return count[KIND_OBJECT] + count[KIND_SOURCE] + count[KIND_LOCK] + count[KIND_TEMP];
}
