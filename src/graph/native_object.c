/* native_object.c - compiling generated C into a cached shared object and
 * loading it back (see native_object.h). */
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <spawn.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include "graph/native_object.h"

extern char **environ;

void nz_native_say(char *why, size_t n, const char *fmt, ...)
{
  if (!why || !n) return;
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(why, n, fmt, ap);
  va_end(ap);
}

void nz_native_literal(char *s, size_t n, double v)
{
  if (isnan(v)) snprintf(s, n, "NAN");
  else if (isinf(v)) snprintf(s, n, v < 0 ? "(-HUGE_VAL)" : "HUGE_VAL");
  else snprintf(s, n, "(%a)", v);
}

void nz_sb_printf(nz_sbuf *b, const char *fmt, ...)
{
  if (b->oom) return;
  for (;;) {
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(b->s ? b->s + b->len : NULL, b->s ? b->cap - b->len : 0, fmt, ap);
    va_end(ap);
    if (k < 0) { b->oom = 1; return; }
    if (b->s && b->len + (size_t)k < b->cap) { b->len += (size_t)k; return; }
    size_t cap = b->cap ? b->cap : 1 << 16;
    while (cap < b->len + (size_t)k + 1) cap *= 2;
    char *s = realloc(b->s, cap);
    if (!s) { b->oom = 1; return; }
    b->s = s;
    b->cap = cap;
  }
}

#define MAXWORDS 48

/* $CC split into words, then the flags: argv ready but for the last four
 * slots (-o out src -lm NULL).  Returns the count, or -1. */
static int compiler_argv(char *buf, size_t n, char **argv, const char *opt)
{
  const char *cc = getenv("CC");
  if (!cc || !*cc) cc = "cc";
  if (strlen(cc) >= n) return -1;
  strcpy(buf, cc);
  int k = 0;
  char *save = NULL;
  for (char *s = strtok_r(buf, " \t", &save); s; s = strtok_r(NULL, " \t", &save)) {
    if (k == MAXWORDS - 12) return -1;
    argv[k++] = s;
  }
  if (!k) return -1;
  static const char *const flags[] = { "-fPIC", "-shared", "-ffp-contract=off", "-fno-builtin", "-fno-math-errno", "-g0", "-w" };
  const char *o = getenv("NZLUA_COPT");   /* e.g. -O1, to measure */
  argv[k++] = (char *)(o && *o ? o : opt);
  for (size_t i = 0; i < sizeof flags / sizeof flags[0]; i++) argv[k++] = (char *)flags[i];
  return k;
}

static uint64_t fnv(uint64_t h, const char *s)
{
  for (; *s; s++) {
    h ^= (unsigned char)*s;
    h *= 0x100000001b3ULL;
  }
  return h;
}

double nz_native_now(void)
{
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* mkdir -p, 0700 for what it creates. */
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
    if (mkdir(p, 0700) && errno != EEXIST) {
      nz_native_say(why, whylen, "cannot create the cache directory '%s': %s (set NZLUA_CACHE to a writable directory)",
          p, strerror(errno));
      return -1;
    }
    *s = c;
    if (!c) break;
  }
  struct stat st;
  if (stat(dir, &st) || !S_ISDIR(st.st_mode)) {
    nz_native_say(why, whylen, "cache directory '%s' is not a directory (set NZLUA_CACHE to a writable directory)", dir);
    return -1;
  }
  return 0;
}

static int write_all(int fd, const char *s, size_t n)
{
  while (n) {
    ssize_t k = write(fd, s, n);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return -1;
    s += k;
    n -= (size_t)k;
  }
  return 0;
}

/* The first line of the compiler's messages that says "error" (or the
 * first line), for why[]. */
static void compiler_message(const char *log, char *msg, size_t n)
{
  FILE *f = fopen(log, "r");
  char line[512], first[512] = "";
  msg[0] = 0;
  if (!f) return;
  while (fgets(line, sizeof line, f)) {
    line[strcspn(line, "\n")] = 0;
    if (!first[0]) snprintf(first, sizeof first, "%s", line);
    if (strstr(line, "error")) { snprintf(msg, n, "%s", line); break; }
  }
  if (!msg[0]) snprintf(msg, n, "%s", first);
  fclose(f);
}

/* Run argv with stdout and stderr into log; 0 when it exited 0. */
static int run_compiler(char **argv, const char *log, char *why, size_t whylen)
{
  posix_spawn_file_actions_t fa;
  pid_t pid;
  int st = 0, rc;
  if (posix_spawn_file_actions_init(&fa)) {
    nz_native_say(why, whylen, "cannot run the C compiler: out of memory");
    return -1;
  }
  posix_spawn_file_actions_addopen(&fa, 1, log, O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  rc = posix_spawnp(&pid, argv[0], &fa, NULL, argv, environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc) {
    nz_native_say(why, whylen, "cannot run the C compiler '%s': %s (set CC to a C compiler; the interpreter is used meanwhile)",
        argv[0], strerror(rc));
    return -1;
  }
  while (waitpid(pid, &st, 0) < 0) {
    if (errno == EINTR) continue;
    nz_native_say(why, whylen, "waiting for the C compiler '%s': %s", argv[0], strerror(errno));
    return -1;
  }
  if (WIFEXITED(st) && WEXITSTATUS(st) == 0) return 0;
  if (WIFEXITED(st) && WEXITSTATUS(st) == 127) {
    nz_native_say(why, whylen, "cannot run the C compiler '%s': not found (set CC to a C compiler; the interpreter is used meanwhile)",
        argv[0]);
    return -1;
  }
  char msg[600];
  compiler_message(log, msg, sizeof msg);
  if (WIFEXITED(st))
    nz_native_say(why, whylen, "the C compiler '%s' failed (exit status %d): %s", argv[0], WEXITSTATUS(st), msg);
  else
    nz_native_say(why, whylen, "the C compiler '%s' was killed by signal %d", argv[0], WIFSIGNALED(st) ? WTERMSIG(st) : 0);
  return -1;
}

/* Load so_path; check that it is the object of this hash. */
static int load(nz_native_object *o, const char *so_path, const char *hash, const char *entry, char *why,
                size_t whylen)
{
  void *dl = dlopen(so_path, RTLD_NOW | RTLD_LOCAL);
  if (!dl) {
    const char *e = dlerror();
    nz_native_say(why, whylen, "cannot load '%s': %s", so_path, e ? e : "dlopen failed");
    return -1;
  }
  const char *id = dlsym(dl, "nzn_id");
  void *ev = dlsym(dl, entry);
  if (!id || !ev || strcmp(id, hash) != 0) {
    nz_native_say(why, whylen, "'%s' is not the object it is named after", so_path);
    dlclose(dl);
    return -1;
  }
  o->dl = dl;
  o->entry = ev;
  return 0;
}

/* Write src under a temporary name, compile it, rename both into place. */
static int compile_into(const char *dir, const char *base, const char *src, char **argv, int k,
                        char *why, size_t whylen)
{
  size_t L = strlen(dir) + strlen(base) + 32;
  char *tc = malloc(L), *tso = malloc(L), *tlog = malloc(L), *fc = malloc(L), *fso = malloc(L);
  int rc = -1, fd = -1;
  if (!tc || !tso || !tlog || !fc || !fso) {
    nz_native_say(why, whylen, "out of memory");
    goto done;
  }
  snprintf(tc, L, "%s/%s-XXXXXX.c", dir, base);
  fd = mkstemps(tc, 2);
  if (fd < 0) {
    nz_native_say(why, whylen, "cannot write in the cache directory '%s': %s (set NZLUA_CACHE to a writable directory)",
        dir, strerror(errno));
    tc[0] = 0;
    goto done;
  }
  if (write_all(fd, src, strlen(src)) || close(fd)) {
    fd = -1;
    nz_native_say(why, whylen, "cannot write '%s': %s", tc, strerror(errno));
    goto done;
  }
  fd = -1;
  size_t tl = strlen(tc);
  snprintf(tso, L, "%.*s.so", (int)(tl - 2), tc);
  snprintf(tlog, L, "%.*s.log", (int)(tl - 2), tc);
  snprintf(fc, L, "%s/%s.c", dir, base);
  snprintf(fso, L, "%s/%s.so", dir, base);
  argv[k] = "-o";
  argv[k + 1] = tso;
  argv[k + 2] = tc;
  argv[k + 3] = "-lm";
  argv[k + 4] = NULL;
  if (run_compiler(argv, tlog, why, whylen)) goto done;
  if (rename(tso, fso)) {
    nz_native_say(why, whylen, "cannot rename '%s' to '%s': %s", tso, fso, strerror(errno));
    goto done;
  }
  if (rename(tc, fc) == 0) tc[0] = 0;   /* the source stays beside the object */
  rc = 0;
done:
  if (fd >= 0) close(fd);
  if (tc && tc[0]) unlink(tc);
  if (tso && tso[0]) unlink(tso);
  if (tlog && tlog[0]) unlink(tlog);
  free(tc);
  free(tso);
  free(tlog);
  free(fc);
  free(fso);
  return rc;
}


int nz_native_object_get(const char *src, const char *version, const char *prefix, const char *entry,
                         int big, int compile, const char *cache_dir, double t_start,
                         nz_native_object *o, char *why, size_t whylen)
{
  char ccbuf[2048], *argv[MAXWORDS], hash[17], base[64];
  memset(o, 0, sizeof *o);
  int k = compiler_argv(ccbuf, sizeof ccbuf, argv, big ? "-O1" : "-O2");
  if (k < 0) {
    nz_native_say(why, whylen, "CC is empty or too long a command");
    return -1;
  }
  /* The machine too: a cache shared between machines (a network home)
   * keeps one object per architecture. */
  struct utsname u;
  uint64_t h = fnv(fnv(0xcbf29ce484222325ULL, version), "\n");
  if (uname(&u) == 0) h = fnv(fnv(h, u.sysname), u.machine);
  for (int i = 0; i < k; i++) h = fnv(fnv(h, argv[i]), " ");
  h = fnv(h, src);
  snprintf(hash, sizeof hash, "%016llx", (unsigned long long)h);
  snprintf(base, sizeof base, "%s-%s", prefix, hash);
  if (make_dirs(cache_dir, why, whylen)) return -1;
  o->path = malloc(strlen(cache_dir) + strlen(base) + 8);
  if (!o->path) {
    nz_native_say(why, whylen, "out of memory");
    return -1;
  }
  sprintf(o->path, "%s/%s.so", cache_dir, base);
  int cached = access(o->path, R_OK) == 0 && load(o, o->path, hash, entry, NULL, 0) == 0;
  if (!cached && !compile) {
    nz_native_say(why, whylen, "not in the cache");
    goto fail;
  }
  if (!cached) {
    /* The object names itself, so that loading can check it. */
    nz_sbuf b = { 0 };
    nz_sb_printf(&b, "%s\nconst char nzn_id[] = \"%s\";\n", src, hash);
    int rc = b.oom ? -1 : compile_into(cache_dir, base, b.s, argv, k, why, whylen);
    if (b.oom) nz_native_say(why, whylen, "out of memory");
    free(b.s);
    if (rc || load(o, o->path, hash, entry, why, whylen)) goto fail;
  }
  o->seconds = cached ? 0.0 : nz_native_now() - t_start;
  return 0;
fail:
  nz_native_object_close(o);
  return -1;
}

void nz_native_object_close(nz_native_object *o)
{
  if (o->dl) dlclose(o->dl);
  free(o->path);
  memset(o, 0, sizeof *o);
}
