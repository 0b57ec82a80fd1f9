/* native_cache.c - the cache directory of compiled objects and the files in
 * it: where it is, whether it is trusted, each object's checks and trailer,
 * the size bound, emptying it (the rules: native_object.h). */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <pwd.h>
#include <ctype.h>
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
#include "graph/native_elf.h"

void nz_native_say(char *why, size_t n, const char *fmt, ...)
{
  if (!why || !n) return;
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(why, n, fmt, ap);
  va_end(ap);
}

/* ------------------------------------------------------------------ */
/* Notices and settings                                                 */

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

/* A setting from the environment, read strictly: a value it does not
 * accept is refused (the default is used), one above its largest clamped,
 * each with one notice line, said once per value and process. */
typedef struct setting {
  const char *name;   /* the environment variable */
  const char *what;   /* what it accepts, for the notice */
  double def, max;
  int bytes;          /* a size: K, M, G or T may follow the number */
  int whole;          /* a whole number */
  char seen[80];      /* the value last read (its first bytes), and what it gave */
  double value;
} setting;

static setting cache_max = { "NZLUA_CACHE_MAX", "a size in bytes (a positive number, K, M, G or T may follow)",
                             100.0 * 1024 * 1024, 1024.0 * 1024 * 1024 * 1024, 1, 0, "", 0 };
static setting cc_timeout = { "NZLUA_CC_TIMEOUT", "a number of seconds (positive)", 300, 86400, 0, 0, "", 0 };
static setting cc_jobs = { "NZLUA_CC_JOBS", "a whole number of compiles at once (1 or more)", 2, 64, 0, 1, "", 0 };

/* v as the setting writes it: 100M, 1T, 300. */
static void shown(const setting *s, double v, char *out, size_t n)
{
  static const char units[] = "KMGT";
  int u = -1;
  while (s->bytes && u < 3 && v >= 1024 && fmod(v, 1024) == 0) v /= 1024, u++;
  snprintf(out, n, u < 0 ? "%.15g" : "%.15g%c", v, u < 0 ? 0 : units[u]);
}

/* The value of e as the setting reads it; *clamped when it was above the
 * largest; NAN when it is refused. */
static double parse_setting(const setting *s, const char *e, int *clamped)
{
  char *end;
  *clamped = 0;
  errno = 0;
  double v = strtod(e, &end);
  if (end == e || isspace((unsigned char)*e) || isnan(v)) return NAN;
  if (s->bytes && *end) {
    const char *u = strchr("KMGT", toupper((unsigned char)*end));
    if (!u) return NAN;
    v *= pow(1024.0, (double)(u - "KMGT" + 1));
    end++;
  }
  if (*end || v <= 0 || (s->whole && !isinf(v) && v != floor(v))) return NAN;
  if (v > s->max) {   /* inf and 1e400 (strtod's HUGE_VAL) too */
    *clamped = 1;
    return s->max;
  }
  return s->bytes ? floor(v) > 0 ? floor(v) : NAN : v;
}

static double setting_value(setting *s)
{
  const char *e = getenv(s->name);
  if (!e || !*e) return s->def;
  /* a value already read gives what it gave, without a second notice (a
   * value longer than seen is known by its first bytes) */
  if (s->seen[0] && !strncmp(s->seen, e, sizeof s->seen - 1)) return s->value;
  int clamped;
  double v = parse_setting(s, e, &clamped);
  char used[40], largest[40];
  shown(s, isnan(v) ? s->def : v, used, sizeof used);
  shown(s, s->max, largest, sizeof largest);
  if (isnan(v))
    nz_native_notice("%s='%.40s' is not %s: the default, %s, is used", s->name, e, s->what, used);
  else if (clamped)
    nz_native_notice("%s='%.40s' is more than the largest accepted, %s: %s is used", s->name, e, largest, used);
  s->value = isnan(v) ? s->def : v;
  snprintf(s->seen, sizeof s->seen, "%s", e);
  return s->value;
}

long long nz_native_cache_limit(void) { return (long long)setting_value(&cache_max); }

double nz_native_cc_timeout(void) { return setting_value(&cc_timeout); }

int nz_native_cc_jobs(void) { return (int)setting_value(&cc_jobs); }

/* ------------------------------------------------------------------ */
/* The directory                                                        */

/* The path in the environment variable: an absolute one, else NULL (a
 * relative one said once as ignored). */
static const char *absolute(const char *name, const char *suffix)
{
  static char said[2][200];
  const char *e = getenv(name);
  if (!e || !*e) return NULL;
  if (e[0] == '/') return e;
  char (*last)[200] = &said[!strcmp(name, "XDG_CACHE_HOME")];
  if (strlen(e) >= sizeof *last || strcmp(*last, e)) {
    nz_native_notice("%s='%.100s' is not an absolute path: ignored (it would name another cache in every working "
                     "directory; give the whole path%s)", name, e, suffix);
    snprintf(*last, sizeof *last, "%s", e);
  }
  return NULL;
}

const char *nz_native_cache_dir(char *buf, size_t n, char *why, size_t whylen)
{
  const char *e;
  int k;
  if ((e = absolute("NZLUA_CACHE", ""))) k = snprintf(buf, n, "%s", e);
  else if ((e = absolute("XDG_CACHE_HOME", ", or set NZLUA_CACHE"))) k = snprintf(buf, n, "%s/nzlua", e);
  else if ((e = getenv("HOME")) && e[0] == '/') k = snprintf(buf, n, "%s/.cache/nzlua", e);
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

/* "'name' (uid N)", or "uid N" when the system has no name for it. */
static void owner(uid_t uid, char *s, size_t n)
{
  struct passwd pw, *r = NULL;
  char buf[1024];
  if (getpwuid_r(uid, &pw, buf, sizeof buf, &r) == 0 && r)
    snprintf(s, n, "'%s' (uid %lu)", r->pw_name, (unsigned long)uid);
  else
    snprintf(s, n, "uid %lu", (unsigned long)uid);
}

#define WHY_OTHER "another user could move the cache under nzlua's feet; machine code is not loaded through it (set " \
                  "NZLUA_CACHE to a path whose directories are yours or root's; the interpreter runs meanwhile)"

/* The walk of a cache path: where it is, what it has passed. */
typedef struct path_walk {
  const char *dir;     /* the cache directory walked to */
  int fd;              /* the directory reached */
  char at[4096];       /* its path, for messages */
  int open_to_others;  /* it is sticky and others may write in it */
  char bad[400];       /* why it may not be passed (empty: it may) */
  int links;           /* symbolic links followed */
} path_walk;

/* Whether the directory reached (its stat st, named w->at) may be passed
 * on the way: root's or the user's, and writable by no one else unless
 * sticky (then what is taken from it must be the user's).  Why not goes
 * into w->bad: the cache directory itself has rules of its own. */
static void note_step(path_walk *w, const struct stat *st)
{
  char who[300];
  int open = (st->st_mode & (S_IWGRP | S_IWOTH)) != 0;
  w->bad[0] = 0;
  w->open_to_others = open;
  if (st->st_uid != 0 && st->st_uid != geteuid()) {
    owner(st->st_uid, who, sizeof who);
    nz_native_say(w->bad, sizeof w->bad, "the directory '%s' on the cache's path belongs to %s: " WHY_OTHER, w->at,
                  who);
  } else if (open && !(st->st_mode & S_ISVTX)) {
    nz_native_say(w->bad, sizeof w->bad, "the directory '%s' on the cache's path can be written by %s (mode %04o) "
                  "and is not sticky: " WHY_OTHER, w->at, (st->st_mode & S_IWOTH) ? "others" : "its group",
                  (unsigned)(st->st_mode & 07777));
  }
}

/* What was taken from a sticky directory others may write (its owner uid,
 * its path w->at) must be the user's: no one else can then rename it. */
static int foreign_in_open_dir(path_walk *w, uid_t uid, char *why, size_t whylen)
{
  if (!w->open_to_others || uid == geteuid()) return 0;
  char who[300];
  owner(uid, who, sizeof who);
  nz_native_say(why, whylen, "'%s' on the cache's path belongs to %s and lies in a directory others can write: "
                WHY_OTHER, w->at, who);
  return 1;
}

/* The cache directory itself: the user's, writable by no one else. */
static int untrusted_dir(const struct stat *st, const char *dir, char *why, size_t whylen)
{
  char who[300];
  if (st->st_uid != geteuid()) {
    owner(st->st_uid, who, sizeof who);
    nz_native_say(why, whylen, "the cache directory '%s' belongs to another user, %s: machine code is loaded only "
                  "from a directory of your own (set NZLUA_CACHE to one; the interpreter runs meanwhile)", dir, who);
    return 1;
  }
  if (st->st_mode & (S_IWGRP | S_IWOTH)) {
    nz_native_say(why, whylen, "the cache directory '%s' can be written by %s (mode %04o): another user could plant "
                  "code there; machine code is not loaded from it (chmod go-w '%s', or set NZLUA_CACHE to a "
                  "directory of your own; the interpreter runs meanwhile)", dir,
                  (st->st_mode & S_IWOTH) ? "others" : "its group", (unsigned)(st->st_mode & 07777), dir);
    return 1;
  }
  return 0;
}

/* w->at with the component c (of n bytes) added, or removed for "..". */
static void path_step(path_walk *w, const char *c, size_t n)
{
  size_t len = strlen(w->at);
  if (n == 2 && !strncmp(c, "..", 2)) {
    while (len > 1 && w->at[len - 1] != '/') len--;
    w->at[len > 1 ? len - 1 : 1] = 0;
  } else {
    snprintf(w->at + len, sizeof w->at - len, "%s%.*s", len > 1 ? "/" : "", (int)n, c);
  }
}

/* Restart the walk at '/' (the start, or an absolute link's target). */
static int walk_root(path_walk *w, char *why, size_t whylen)
{
  int fd = open("/", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  struct stat st;
  if (w->fd >= 0) close(w->fd);
  w->fd = fd;
  strcpy(w->at, "/");
  if (fd < 0 || fstat(fd, &st)) {
    nz_native_say(why, whylen, "cannot open '/': %s", strerror(errno));
    return -1;
  }
  note_step(w, &st);
  return 0;
}

/* The component c of the directory w->fd opened, made when create is set
 * and it is missing: mkdirat, then opened without following a link and set
 * to 0700 on its descriptor (the umask may have taken bits).  The new
 * descriptor, or -1 with errno. */
static int open_component(path_walk *w, const char *c, int create)
{
  int fd = openat(w->fd, c, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd >= 0 || errno != ENOENT || !create) return fd;
  if (mkdirat(w->fd, c, 0700) && errno != EEXIST) return -1;
  int made = errno != EEXIST;
  fd = openat(w->fd, c, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  struct stat st;
  if (fd >= 0 && made && fstat(fd, &st) == 0 && st.st_uid == geteuid() && fchmod(fd, 0700)) {
    int e = errno;
    close(fd);
    errno = e;
    return -1;
  }
  return fd;
}

/* A symbolic link c in w->fd: checked (from a sticky directory, the
 * user's), its target spliced in front of what is left to walk (rest, of
 * restlen bytes).  0, or -1 with why. */
static int follow_link(path_walk *w, const char *c, char *rest, size_t restlen, char *why, size_t whylen)
{
  char target[4096];
  struct stat st;
  ssize_t k = readlinkat(w->fd, c, target, sizeof target - 1);
  if (k < 0 || fstatat(w->fd, c, &st, AT_SYMLINK_NOFOLLOW)) {
    path_step(w, c, strlen(c));
    nz_native_say(why, whylen, "cannot use the cache directory '%s': '%s' on its path is not a directory (set "
                  "NZLUA_CACHE to a directory of your own; the interpreter runs meanwhile)", w->dir, w->at);
    return -1;
  }
  if (w->open_to_others && st.st_uid != geteuid()) {
    path_step(w, c, strlen(c));
    foreign_in_open_dir(w, st.st_uid, why, whylen);
    return -1;
  }
  if (++w->links > 40 || (size_t)k + strlen(rest) + 2 > restlen) {
    nz_native_say(why, whylen, "too many symbolic links on the cache's path (at '%s')", w->at);
    return -1;
  }
  memmove(rest + k + 1, rest, strlen(rest) + 1);
  memcpy(rest, target, (size_t)k);
  rest[k] = '/';
  return target[0] == '/' ? walk_root(w, why, whylen) : 0;
}

/* One component c of the path, from w->fd (which must be passable): a
 * directory entered, or a symbolic link followed.  0, or -1 with why. */
static int walk_component(path_walk *w, const char *c, char *rest, size_t restlen, int create, char *why,
                          size_t whylen)
{
  struct stat st;
  if (w->bad[0]) {
    nz_native_say(why, whylen, "%s", w->bad);
    return -1;
  }
  int fd = open_component(w, c, create);
  if (fd < 0 && (errno == ELOOP || errno == ENOTDIR)) return follow_link(w, c, rest, restlen, why, whylen);
  path_step(w, c, strlen(c));
  if (fd < 0) {
    int e = errno;
    nz_native_say(why, whylen, "cannot %s the cache directory '%s': %s (set NZLUA_CACHE to a directory of your own; "
                  "the interpreter runs meanwhile)", create ? "create" : "open", w->at, strerror(e));
    errno = e;
    return -1;
  }
  int from_open = w->open_to_others && strcmp(c, "..");
  close(w->fd);
  w->fd = fd;
  if (fstat(fd, &st)) {
    nz_native_say(why, whylen, "cannot read the directory '%s': %s", w->at, strerror(errno));
    return -1;
  }
  if (from_open && foreign_in_open_dir(w, st.st_uid, why, whylen)) return -1;
  note_step(w, &st);
  return 0;
}

int nz_native_cache_open(const char *dir, int create, char *why, size_t whylen)
{
  char rest[8192];
  path_walk w = { .dir = dir, .fd = -1 };
  if (dir[0] != '/' || strlen(dir) >= 4096) {
    nz_native_say(why, whylen, "the cache directory '%s' is not an absolute path of at most 4095 bytes", dir);
    return -1;
  }
  snprintf(rest, sizeof rest, "%s", dir);
  if (walk_root(&w, why, whylen)) goto fail;
  /* rest holds what is left to walk; a link's target goes in front of it */
  for (;;) {
    char *c = rest;
    while (*c == '/') c++;
    if (!*c) break;
    size_t n = strcspn(c, "/");
    char comp[256];
    if (n >= sizeof comp) {
      nz_native_say(why, whylen, "a name on the cache's path is too long");
      goto fail;
    }
    memcpy(comp, c, n);
    comp[n] = 0;
    memmove(rest, c + n, strlen(c + n) + 1);
    if (strcmp(comp, ".") && walk_component(&w, comp, rest, sizeof rest, create, why, whylen)) goto fail;
  }
  struct stat st;
  if (fstat(w.fd, &st) || untrusted_dir(&st, dir, why, whylen)) goto fail;
  return w.fd;
fail:;
  int e = errno;   /* ENOENT: the directory is not there (nz_native_cache_info) */
  if (w.fd >= 0) close(w.fd);
  errno = e;
  return -1;
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
    if (nz_native_read_at(fd, buf, len, at)) { free(buf); return -1; }
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
  if (payload < 64 || nz_native_read_at(fd, t, sizeof t, payload) || memcmp(t, MAGIC, 8)) {
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
  if (nz_native_elf_whole(fd, payload, ewhy, sizeof ewhy)) {
    nz_native_say(why, whylen, "is damaged: %s", ewhy);
    goto bad;
  }
  if (nz_native_elf_inert(fd, payload, ewhy, sizeof ewhy)) {
    nz_native_say(why, whylen, "%s, which nzlua's objects never have: not loaded", ewhy);
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
  if (nz_native_elf_whole(fd, (long long)st.st_size, ewhy, sizeof ewhy)) {
    nz_native_say(why, whylen, "the C compiler exited 0 but its output is not a whole shared object (%s)", ewhy);
    return -1;
  }
  if (nz_native_elf_inert(fd, (long long)st.st_size, ewhy, sizeof ewhy)) {
    nz_native_say(why, whylen, "the C compiler's output %s, which nzlua's objects never have (does CC add code of "
                  "its own?): refused and removed, never loaded", ewhy);
    return -2;
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

/* The file name in dfd (of that kind, its lstat in *st) is nzlua's, made
 * by this user: an object whose trailer names the key in its name, a
 * source that begins as the generators' do, an empty lock, a directory of
 * a compile under way. */
static int ours(int dfd, const char *name, int kind, struct stat *st)
{
  if (kind == KIND_OTHER || fstatat(dfd, name, st, AT_SYMLINK_NOFOLLOW) || st->st_uid != geteuid()) return 0;
  if (kind == KIND_TEMP) return S_ISDIR(st->st_mode);
  if (!S_ISREG(st->st_mode)) return 0;
  if (kind == KIND_LOCK) return st->st_size == 0;
  static const char source_mark[] = "/* Generated by nzlua (";
  unsigned char head[NZ_NATIVE_TRAILER];
  size_t n = kind == KIND_OBJECT ? NZ_NATIVE_TRAILER : sizeof source_mark - 1;
  long long at = kind == KIND_OBJECT ? (long long)st->st_size - NZ_NATIVE_TRAILER : 0;
  int fd = openat(dfd, name, O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  int ok = fd >= 0 && at >= 0 && nz_native_read_at(fd, head, n, at) == 0 &&
           (kind == KIND_OBJECT ? !memcmp(head, MAGIC, 8) && !memcmp(head + 8, name + 4, 16)
                                : !memcmp(head, source_mark, n));
  if (fd >= 0) close(fd);
  return ok;
}

int nz_native_cache_remove_temp(int dfd, const char *name)
{
  int fd = openat(dfd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  DIR *d = fd >= 0 ? fdopendir(fd) : NULL;
  if (!d) {
    if (fd >= 0) close(fd);
    return -1;
  }
  struct dirent *de;
  while ((de = readdir(d)))
    if (strcmp(de->d_name, ".") && strcmp(de->d_name, "..")) unlinkat(fd, de->d_name, 0);
  closedir(d);
  return unlinkat(dfd, name, AT_REMOVEDIR);
}

/* Remove a file of nzlua's (of that kind) from dfd. */
static int remove_ours(int dfd, const char *name, int kind)
{
  return kind == KIND_TEMP ? nz_native_cache_remove_temp(dfd, name) : unlinkat(dfd, name, 0);
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

/* A directory stream over dfd (which stays open), or NULL. */
static DIR *list_dir(int dfd)
{
  int dup_fd = fcntl(dfd, F_DUPFD_CLOEXEC, 0);
  DIR *d = dup_fd >= 0 ? fdopendir(dup_fd) : NULL;
  if (!d && dup_fd >= 0) close(dup_fd);
  return d;
}

void nz_native_cache_prune(int dfd, const char *keep)
{
  DIR *d = list_dir(dfd);
  if (!d) return;
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
    if (strlen(de->d_name) >= sizeof objs->name || !ours(dfd, de->d_name, kind, &st)) continue;
    if ((kind == KIND_TEMP || kind == KIND_LOCK) && difftime(now, st.st_mtime) > stale) {
      remove_ours(dfd, de->d_name, kind);
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

/* Every file of nzlua's in the trusted directory dir, one call each:
 * count[kind] and bytes; remove them too when clear is set.  0, 1 when dir
 * does not exist (nothing in it), -1 with why (not trusted: nothing is
 * read or removed). */
static int walk(const char *dir, int clear, int count[5], long long *bytes, char *why, size_t whylen)
{
  int dfd = nz_native_cache_open(dir, 0, why, whylen);
  if (dfd < 0) return errno == ENOENT ? 1 : -1;
  DIR *d = list_dir(dfd);
  if (!d) {
    nz_native_say(why, whylen, "cannot read the cache directory '%s': %s", dir, strerror(errno));
    close(dfd);
    return -1;
  }
  struct dirent *de;
  while ((de = readdir(d))) {
    int kind = file_kind(de->d_name);
    struct stat st;
    if (!ours(dfd, de->d_name, kind, &st)) continue;
    if (clear && remove_ours(dfd, de->d_name, kind)) continue;
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
  int r = walk(dir, 0, count, &st->bytes, st->why, sizeof st->why);
  st->trusted = r >= 0;   /* one not made yet is empty, and made trusted */
  if (r > 0) st->why[0] = 0;
  (void)why, (void)whylen;
  st->objects = count[KIND_OBJECT];
  st->sources = count[KIND_SOURCE];
  st->others = count[KIND_LOCK] + count[KIND_TEMP];
  return 0;
}

int nz_native_cache_clear(const char *dir, char *why, size_t whylen)
{
  int count[5] = { 0 };
  long long bytes = 0;
  int r = walk(dir, 1, count, &bytes, why, whylen);
  if (r < 0) return -1;
  return count[KIND_OBJECT] + count[KIND_SOURCE] + count[KIND_LOCK] + count[KIND_TEMP];
}
