/* native_object.c - compiling generated C into a shared object in a worker
 * process, and loading a checked object back (the rules: native_object.h;
 * the cache's files: native_cache.c). */
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <sys/types.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>
#include "core/interrupt.h"
#include "graph/native_elf.h"
#include "graph/native_object.h"

extern char **environ;

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

double nz_native_now(void)
{
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* ------------------------------------------------------------------ */
/* The compiler: its command, its identity                              */

#define MAXWORDS 48

/* $CC split into words (*ncc of them), then the flags: argv ready but for
 * the last five slots (-o out src -lm NULL).  Returns the count, or -1. */
static int compiler_argv(char *buf, size_t n, char **argv, const char *opt, int *ncc)
{
  const char *cc = getenv("CC");
  if (!cc || !*cc) cc = "cc";
  if (strlen(cc) >= n) return -1;
  strcpy(buf, cc);
  int k = 0;
  char *save = NULL;
  for (char *s = strtok_r(buf, " \t", &save); s; s = strtok_r(NULL, " \t", &save)) {
    if (k == MAXWORDS - 14) return -1;
    argv[k++] = s;
  }
  if (!k) return -1;
  *ncc = k;
  /* -nostartfiles: gcc's start files would add a constructor (frame_dummy)
   * and _init/_fini, and no object that runs code on load is loaded
   * (native_elf.h); generated code needs none of them. */
  static const char *const flags[] = { "-fPIC", "-shared", "-nostartfiles", "-ffp-contract=off", "-fno-builtin",
                                       "-fno-math-errno", "-g0", "-w" };
  const char *o = getenv("NZLUA_COPT");   /* e.g. -O1, to measure */
  argv[k++] = (char *)(o && *o ? o : opt);
  for (size_t i = 0; i < sizeof flags / sizeof flags[0]; i++) argv[k++] = (char *)flags[i];
  return k;
}

/* A flag that lets the compiler round differently from the interpreter
 * (machine code must give its results bit for bit), or NULL. */
static const char *unsafe_flag(char **argv, int k)
{
  static const char *const bad[] = { "-Ofast", "-ffast-math", "-funsafe-math-optimizations",
                                     "-fassociative-math", "-freciprocal-math", "-ffinite-math-only",
                                     "-fno-signed-zeros", "-ffp-contract=fast", "-ffp-contract=on",
                                     "-fcx-limited-range", "-mrecip" };
  for (int i = 0; i < k; i++)
    for (size_t j = 0; j < sizeof bad / sizeof bad[0]; j++)
      if (!strncmp(argv[i], bad[j], strlen(bad[j]))) return argv[i];
  return NULL;
}

static uint64_t fnv(uint64_t h, const char *s, size_t n)
{
  for (size_t i = 0; i < n; i++) {
    h ^= (unsigned char)s[i];
    h *= 0x100000001b3ULL;
  }
  return h;
}

static uint64_t fnvs(uint64_t h, const char *s) { return fnv(h, s, strlen(s)); }

/* Wait for pid until deadline (a monotonic time; <= 0: forever); on
 * timeout kill its process group.  The status, or -1 (timeout, or an
 * error: *timed_out tells which). */
static int wait_child(pid_t pid, double deadline, int *timed_out)
{
  int st;
  *timed_out = 0;
  for (;;) {
    pid_t r = waitpid(pid, &st, deadline > 0 ? WNOHANG : 0);
    if (r == pid) return st;
    if (r < 0 && errno != EINTR) return -1;
    if (r == 0) {
      if (nz_native_now() > deadline) {
        kill(-pid, SIGKILL);
        kill(pid, SIGKILL);
        while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {}
        *timed_out = 1;
        return -1;
      }
      struct timespec ts = { 0, 5000000 };
      nanosleep(&ts, NULL);
    }
  }
}

/* The environment with TMPDIR=. (malloc'd; the strings are environ's), or
 * NULL. */
static char **with_tmpdir(void)
{
  static char tmpdir[] = "TMPDIR=.";
  size_t n = 0;
  while (environ[n]) n++;
  char **env = malloc((n + 2) * sizeof *env);
  if (!env) return NULL;
  size_t k = 0;
  for (size_t i = 0; i < n; i++)
    if (strncmp(environ[i], "TMPDIR=", 7)) env[k++] = environ[i];
  env[k++] = tmpdir;
  env[k] = NULL;
  return env;
}

/* Run argv (in a process group of its own, so that a timeout kills the
 * compiler's own children too) with stdin from /dev/null and stdout and
 * stderr into the descriptor out; in the directory open in cwd when cwd >=
 * 0, with TMPDIR set to it (the compiler's own temporaries there too).
 * The exit status, or -1 with why. */
static int run(char **argv, int out, int cwd, double seconds, char *why, size_t whylen)
{
  posix_spawn_file_actions_t fa;
  posix_spawnattr_t at;
  pid_t pid;
  if (posix_spawn_file_actions_init(&fa)) {
    nz_native_say(why, whylen, "cannot run the C compiler: out of memory");
    return -1;
  }
  posix_spawnattr_init(&at);
  posix_spawnattr_setflags(&at, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&at, 0);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&fa, out, 1);
  posix_spawn_file_actions_adddup2(&fa, out, 2);
  char **env = environ;
  if (cwd >= 0) {
    posix_spawn_file_actions_addfchdir_np(&fa, cwd);
    env = with_tmpdir();
  }
  int rc = env ? posix_spawnp(&pid, argv[0], &fa, &at, argv, env) : ENOMEM;
  if (env != environ) free(env);
  posix_spawn_file_actions_destroy(&fa);
  posix_spawnattr_destroy(&at);
  if (rc) {
    nz_native_say(why, whylen, "cannot run the C compiler '%s': %s (set CC to a C compiler; the interpreter runs "
                  "meanwhile)", argv[0], strerror(rc));
    return -1;
  }
  int timed_out, st = wait_child(pid, nz_native_now() + seconds, &timed_out);
  if (timed_out) {
    nz_native_say(why, whylen, "the C compiler '%s' ran longer than %g s and was stopped (NZLUA_CC_TIMEOUT sets the "
                  "limit; the interpreter runs meanwhile)", argv[0], seconds);
    return -1;
  }
  if (st < 0) {
    nz_native_say(why, whylen, "waiting for the C compiler '%s': %s", argv[0], strerror(errno));
    return -1;
  }
  if (WIFEXITED(st) && WEXITSTATUS(st) == 127) {
    nz_native_say(why, whylen, "cannot run the C compiler '%s': not found (set CC to a C compiler; the interpreter "
                  "runs meanwhile)", argv[0]);
    return -1;
  }
  return st;
}

/* What `$CC --version` prints (and its status), hashed: a CC that now
 * names another compiler makes other keys.  Asked once per process and CC
 * (about 2 ms). */
static uint64_t compiler_identity(char **argv, int ncc)
{
  static char last_cc[2048];
  static uint64_t last;
  static int known;
  const char *cc = getenv("CC");
  if (!cc) cc = "";
  if (known && !strcmp(cc, last_cc)) return last;
  uint64_t h = 0xcbf29ce484222325ULL;
  char *av[MAXWORDS];
  for (int i = 0; i < ncc; i++) av[i] = argv[i];
  av[ncc] = "--version";
  av[ncc + 1] = NULL;
  FILE *tmp = tmpfile();
  int st = tmp ? run(av, fileno(tmp), -1, 30, NULL, 0) : -1;
  if (tmp) {
    char buf[4096];
    size_t n;
    rewind(tmp);
    while ((n = fread(buf, 1, sizeof buf, tmp)) > 0) h = fnv(h, buf, n);
    fclose(tmp);
  }
  h = fnv(h, (const char *)&st, sizeof st);
  snprintf(last_cc, sizeof last_cc, "%s", cc);
  last = h;
  known = 1;
  return h;
}

/* The first line of the compiler's messages that says "error" (or the
 * first line) into msg; 1 when a line says the disk is full. */
static int compiler_message(int log, char *msg, size_t n)
{
  char line[512], first[512] = "";
  int full = 0;
  msg[0] = 0;
  FILE *f = fdopen(dup(log), "r");
  if (!f) return 0;
  rewind(f);
  while (fgets(line, sizeof line, f)) {
    line[strcspn(line, "\n")] = 0;
    if (strstr(line, "No space left on device")) full = 1;
    if (!first[0]) snprintf(first, sizeof first, "%s", line);
    if (!msg[0] && strstr(line, "error")) snprintf(msg, n, "%s", line);
  }
  if (!msg[0]) snprintf(msg, n, "%s", first);
  fclose(f);
  return full;
}

/* The disk under dir is (nearly) full. */
static int disk_full(const char *dir)
{
  struct statvfs v;
  return statvfs(dir, &v) == 0 && (double)v.f_bavail * (double)v.f_frsize < 64.0 * 1024;
}

/* ------------------------------------------------------------------ */
/* A compile (inside the worker)                                        */

/* A new directory <base>.tmp-<pid>-<n> in dfd for one compile, 0700 and
 * the user's: opened (without following a link) into *fd, its name into
 * name[n].  0, or -1 with errno. */
static int private_dir(int dfd, const char *base, int *fd, char *name, size_t n)
{
  static unsigned counter;
  for (int tries = 0;; tries++) {
    snprintf(name, n, "%s.tmp-%ld-%u", base, (long)getpid(), counter++);
    if (mkdirat(dfd, name, 0700) == 0) break;
    if (errno != EEXIST || tries == 99) {
      name[0] = 0;
      return -1;
    }
  }
  struct stat st;
  *fd = openat(dfd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (*fd < 0 || fstat(*fd, &st)) return -1;
  if (st.st_uid != geteuid()) {
    errno = EPERM;
    return -1;
  }
  return fchmod(*fd, 0700);
}

/* The compiler's failure (status st, its messages in logfd) said in why. */
static void compiler_failed(int st, int logfd, const char *dir, char **argv, char *why, size_t whylen)
{
  char msg[600];
  int full = compiler_message(logfd, msg, sizeof msg);
  if (full || disk_full(dir))
    nz_native_say(why, whylen, "No space left on device in the cache directory '%s': the C compiler could not "
                  "write the object (free some space, or empty the cache with nzlua --cache-clear)", dir);
  else if (!WIFEXITED(st))
    nz_native_say(why, whylen, "the C compiler '%s' was killed by signal %d", argv[0], WTERMSIG(st));
  else if (!msg[0])
    nz_native_say(why, whylen, "the C compiler '%s' failed (exit status %d) and printed nothing", argv[0],
                  WEXITSTATUS(st));
  else
    nz_native_say(why, whylen, "the C compiler '%s' failed (exit status %d): %s", argv[0], WEXITSTATUS(st), msg);
}

/* Write src, compile it, seal the object and rename it into place as
 * <base>.so (the source too, as <base>.c, with NZLUA_KEEP_C=1).  The
 * compiler never sees a path that another user could move: it runs in a
 * directory of its own made under dfd, reached through dfd's descriptor,
 * given the relative names src.c and out.so; the object is then opened,
 * checked, sealed and renamed through the descriptors.  0, -1 with the
 * reason, or -2 when the object was refused for what it would run. */
static int compile_into(int dfd, const char *dir, const char *base, const char *key, const char *src, char **argv,
                        int k, char *why, size_t whylen)
{
  char tmp[96], final[96];
  int pfd = -1, cfd = -1, sofd = -1, logfd = -1, rc = -1;
  const char *keep_c = getenv("NZLUA_KEEP_C");
  tmp[0] = 0;
  if (private_dir(dfd, base, &pfd, tmp, sizeof tmp) ||
      (cfd = openat(pfd, "src.c", O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600)) < 0 ||
      (logfd = openat(pfd, "log", O_RDWR | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600)) < 0) {
    nz_native_say(why, whylen, "cannot write in the cache directory '%s': %s", dir, strerror(errno));
    goto done;
  }
  if (nz_native_write_at(cfd, src, strlen(src), 0) || close(cfd)) {
    cfd = -1;
    nz_native_say(why, whylen, "cannot write the generated C in the cache directory '%s': %s", dir, strerror(errno));
    goto done;
  }
  cfd = -1;
  argv[k] = "-o";
  argv[k + 1] = "out.so";
  argv[k + 2] = "src.c";
  argv[k + 3] = "-lm";
  argv[k + 4] = NULL;
  int st = run(argv, logfd, pfd, nz_native_cc_timeout(), why, whylen);
  if (st < 0) goto done;
  if (!WIFEXITED(st) || WEXITSTATUS(st) != 0) {
    compiler_failed(st, logfd, dir, argv, why, whylen);
    goto done;
  }
  sofd = openat(pfd, "out.so", O_RDWR | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (sofd < 0) {
    nz_native_say(why, whylen, "the C compiler '%s' exited 0 but wrote no object", argv[0]);
    goto done;
  }
  if ((rc = nz_native_cache_seal(sofd, key, why, whylen)) < 0) {
    if (rc == -1 && disk_full(dir))
      nz_native_say(why, whylen, "No space left on device in the cache directory '%s' (free some space, or empty "
                    "the cache with nzlua --cache-clear)", dir);
    goto done;
  }
  rc = -1;
  snprintf(final, sizeof final, "%s.so", base);
  if (renameat(pfd, "out.so", dfd, final)) {
    nz_native_say(why, whylen, "cannot rename the object into place in '%s': %s", dir, strerror(errno));
    goto done;
  }
  if (keep_c && !strcmp(keep_c, "1")) {
    snprintf(final, sizeof final, "%s.c", base);
    renameat(pfd, "src.c", dfd, final);
  }
  fsync(dfd);   /* the rename itself survives a power loss */
  rc = 0;
done:
  if (cfd >= 0) close(cfd);
  if (sofd >= 0) close(sofd);
  if (logfd >= 0) close(logfd);
  if (pfd >= 0) close(pfd);
  if (tmp[0]) nz_native_cache_remove_temp(dfd, tmp);
  return rc;
}

/* ------------------------------------------------------------------ */
/* Loading a checked object                                             */

/* dlopen the object open in fd through /proc/self/fd/N.  The loader
 * hands back an object it already has under the same name, and a name
 * stays with an object for as long as it is loaded (also as an alias,
 * when a second load found the same file): a descriptor number reused
 * after its file was closed would then load the wrong object.  So every
 * load goes through a path of its own: /proc/self/fd, then one segment per
 * bit of a counter ("/." for 0, "/../fd" for 1), then N; all of them name
 * the same directory. */
static void *open_fd(int fd, char *why, size_t whylen)
{
  static unsigned long loads;
  char path[512];
  int k = snprintf(path, sizeof path, "/proc/self/fd");
  for (unsigned long c = loads++; c; c >>= 1) k += snprintf(path + k, sizeof path - (size_t)k, (c & 1) ? "/../fd" : "/.");
  snprintf(path + k, sizeof path - (size_t)k, "/%d", fd);
  void *dl = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (!dl) {
    const char *e = dlerror();
    nz_native_say(why, whylen, "cannot load it: %s", e ? e : "dlopen failed");
  }
  return dl;
}

/* Open cache_dir (trusted), check the object <base>.so and load it.  1
 * loaded, 0 absent, -1 failed; *damaged when the file was there but failed
 * its checks (it is then removed, and why says what was wrong). */
static int load(const char *cache_dir, const char *base, const char *key, const char *entry,
                nz_native_object *o, int *damaged, char *why, size_t whylen)
{
  char name[96], fwhy[300];
  int fd = -1, dfd = nz_native_cache_open(cache_dir, 1, why, whylen);
  *damaged = 0;
  if (dfd < 0) return -1;
  snprintf(name, sizeof name, "%s.so", base);
  int ok = nz_native_cache_check(dfd, name, key, &fd, fwhy, sizeof fwhy);
  if (ok < 0) {
    *damaged = 1;
    unlinkat(dfd, name, 0);
    nz_native_say(why, whylen, "the cached object '%s/%s' %s", cache_dir, name, fwhy);
  }
  close(dfd);
  if (ok <= 0) return ok;
  void *dl = open_fd(fd, fwhy, sizeof fwhy);
  close(fd);
  if (!dl) {
    nz_native_say(why, whylen, "the cached object '%s/%s': %s", cache_dir, name, fwhy);
    return -1;
  }
  const char *id = dlsym(dl, "nzn_id");
  void *ev = dlsym(dl, entry);
  if (!id || !ev || strcmp(id, key) != 0) {
    nz_native_say(why, whylen, "'%s/%s' is not the object it is named after", cache_dir, name);
    dlclose(dl);
    return -1;
  }
  o->dl = dl;
  o->entry = ev;
  return 1;
}

/* ------------------------------------------------------------------ */
/* Workers                                                              */

typedef struct nz_native_job {
  int started;        /* its worker was started (else it waits for its turn) */
  int done, ok;       /* the worker has ended, and compiled the object */
  int refused;        /* or its object was refused for what it would run */
  char msg[700];      /* else why not */
  char *src;          /* the source, until the worker starts */
  char ccbuf[2048];   /* argv's words live here */
  char *argv[MAXWORDS];
  int k;
  char *dir, *entry;
  char base[64], key[17];
  double t_start;
} nz_native_job;

/* The workers of this process still running: the read end of each one's
 * pipe, and its job (NULL when the job was forgotten while it ran).  A
 * worker is a grandchild in a session of its own (the child that forked it
 * is reaped at once), so it never stays a zombie of this process and no
 * waitpid here can take another part's child; it reports through its pipe
 * ('0', or '1' and the reason) and its end closes the pipe. */
typedef struct worker_slot {
  int fd;
  nz_native_job *job;
} worker_slot;
static worker_slot workers[256];
static int nworkers;

/* Slot i's worker has spoken or ended: its report into its job, if any;
 * the slot dropped. */
static void collect(int i)
{
  worker_slot *w = &workers[i];
  char msg[701];
  ssize_t n;
  while ((n = read(w->fd, msg, sizeof msg - 1)) < 0 && errno == EINTR) {}
  msg[n > 0 ? n : 0] = 0;
  if (w->job) {
    w->job->done = 1;
    w->job->ok = msg[0] == '0';
    w->job->refused = msg[0] == '2';
    snprintf(w->job->msg, sizeof w->job->msg, "%s",
             msg[0] == '1' || msg[0] == '2' ? msg + 1 : "the compile's worker ended without a reason (killed?)");
  }
  close(w->fd);
  *w = workers[--nworkers];
}

/* Wait up to timeout ms (-1: forever) for slot i's worker; 1 when it has
 * reported (the slot is then collected), 0 when not yet, -1 on EINTR. */
static int await_slot(int i, int timeout)
{
  struct pollfd pf = { workers[i].fd, POLLIN, 0 };
  int r = poll(&pf, 1, timeout);
  if (r < 0) return errno == EINTR ? -1 : (collect(i), 1);
  if (r == 0) return 0;
  collect(i);
  return 1;
}

/* Collect what has ended; the number still running. */
static int running_workers(void)
{
  for (int i = 0; i < nworkers;)
    if (await_slot(i, 0) <= 0) i++;
  return nworkers;
}

static int slot_of(const nz_native_job *j)
{
  for (int i = 0; i < nworkers; i++)
    if (workers[i].job == j) return i;
  return -1;
}

/* The worker's body: the lock, the cache looked at again (another process
 * may have compiled it meanwhile), the compile, the bound. */
static int worker(nz_native_job *j, char *why, size_t whylen)
{
  int dfd = nz_native_cache_open(j->dir, 1, why, whylen);
  if (dfd < 0) return -1;
  char name[96];
  snprintf(name, sizeof name, "%s.lock", j->base);
  int lock = openat(dfd, name, O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (lock >= 0) while (flock(lock, LOCK_EX) && errno == EINTR) {}
  snprintf(name, sizeof name, "%s.so", j->base);
  int fd = -1, rc = 0;
  char fwhy[300];
  int have = nz_native_cache_check(dfd, name, j->key, &fd, fwhy, sizeof fwhy);
  if (have > 0) close(fd);
  else {
    if (have < 0) unlinkat(dfd, name, 0);
    rc = compile_into(dfd, j->dir, j->base, j->key, j->src, j->argv, j->k, why, whylen);
    if (rc == 0) nz_native_cache_prune(dfd, name);
  }
  if (lock >= 0) {
    snprintf(name, sizeof name, "%s.lock", j->base);
    unlinkat(dfd, name, 0);
    close(lock);
  }
  close(dfd);
  return rc;
}

static int start_worker(nz_native_job *j, char *why, size_t whylen)
{
  int p[2];
  if (running_workers() == (int)(sizeof workers / sizeof workers[0])) {
    nz_native_say(why, whylen, "too many compiles under way");
    return -1;
  }
  if (pipe2(p, O_CLOEXEC)) {
    nz_native_say(why, whylen, "cannot start a compile: %s", strerror(errno));
    return -1;
  }
  pid_t pid = fork();
  if (pid < 0) {
    nz_native_say(why, whylen, "cannot start a compile: %s", strerror(errno));
    close(p[0]);
    close(p[1]);
    return -1;
  }
  if (pid == 0) {
    /* A session of its own: Ctrl-C at the terminal stops the run, not the
     * compile that will serve the next one.  The grandchild works; this
     * child ends at once. */
    close(p[0]);
    setsid();
    if (fork() != 0) _exit(0);
    signal(SIGINT, SIG_DFL);
    signal(SIGPIPE, SIG_IGN);
    nz_native_set_notice(NULL);   /* the caller says what there is to say */
    char w[700] = "1";
    int rc = worker(j, w + 1, sizeof w - 1);
    if (rc == 0) strcpy(w, "0");
    if (rc == -2) w[0] = '2';   /* refused: the caller says so in a notice */
    if (write(p[1], w, strlen(w)) < 0) rc = 2;
    _exit(rc ? 1 : 0);
  }
  close(p[1]);
  int st;
  while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {}
  workers[nworkers++] = (worker_slot){ p[0], j };
  j->started = 1;
  free(j->src);
  j->src = NULL;
  return 0;
}

/* A job's worker goes on alone (its slot forgets the job). */
static void job_free(nz_native_job *j)
{
  if (!j) return;
  int i = slot_of(j);
  if (i >= 0) workers[i].job = NULL;
  free(j->src);
  free(j->dir);
  free(j->entry);
  free(j);
}

/* ------------------------------------------------------------------ */
/* The public face                                                      */

int nz_native_object_get(const char *src, const char *version, const char *prefix, const char *entry,
                         int big, int how, const char *cache_dir, double t_start,
                         nz_native_object *o, char *why, size_t whylen)
{
  nz_native_job *j = calloc(1, sizeof *j);
  memset(o, 0, sizeof *o);
  if (!j) {
    nz_native_say(why, whylen, "out of memory");
    return -1;
  }
  /* the settings read here, so that a notice about one comes from the
   * caller, never from a worker */
  nz_native_cc_timeout();
  nz_native_cc_jobs();
  nz_native_cache_limit();
  int ncc = 0;
  j->k = compiler_argv(j->ccbuf, sizeof j->ccbuf, j->argv, big ? "-O1" : "-O2", &ncc);
  if (j->k < 0) {
    nz_native_say(why, whylen, "CC is empty or too long a command");
    goto fail;
  }
  const char *bad = unsafe_flag(j->argv, j->k);
  if (bad) {
    nz_native_say(why, whylen, "'%s' in %s would let the compiler round differently from the interpreter (machine "
                  "code must give its results bit for bit): remove it (the interpreter runs meanwhile)", bad,
                  strstr(getenv("CC") ? getenv("CC") : "", bad) ? "CC" : "NZLUA_COPT");
    goto fail;
  }
  /* The key: the generator, the machine (a cache shared between machines
   * keeps one object per architecture), the compiler's words and identity,
   * the source. */
  struct utsname u;
  uint64_t h = fnvs(fnvs(0xcbf29ce484222325ULL, version), "\n");
  if (uname(&u) == 0) h = fnvs(fnvs(h, u.sysname), u.machine);
  for (int i = 0; i < j->k; i++) h = fnvs(fnvs(h, j->argv[i]), " ");
  uint64_t id = compiler_identity(j->argv, ncc);
  h = fnv(h, (const char *)&id, sizeof id);
  h = fnvs(h, src);
  snprintf(j->key, sizeof j->key, "%016llx", (unsigned long long)h);
  snprintf(j->base, sizeof j->base, "%s-%s", prefix, j->key);
  j->dir = strdup(cache_dir);
  j->entry = strdup(entry);
  o->path = malloc(strlen(cache_dir) + strlen(j->base) + 8);
  if (!j->dir || !j->entry || !o->path) {
    nz_native_say(why, whylen, "out of memory");
    goto fail;
  }
  sprintf(o->path, "%s/%s.so", cache_dir, j->base);
  int damaged, got = load(cache_dir, j->base, j->key, entry, o, &damaged, why, whylen);
  if (got > 0) {
    job_free(j);
    return 0;
  }
  if (damaged) nz_native_notice("%s: removed; it is compiled again", why);
  else if (got < 0) goto fail;   /* the directory is not trusted, or the object will not load */
  if (how == NZ_NATIVE_LOOKUP) {
    nz_native_say(why, whylen, "not in the cache");
    goto fail;
  }
  /* The object names itself, so that loading can check it. */
  nz_sbuf b = { 0 };
  nz_sb_printf(&b, "%s\nconst char nzn_id[] = \"%s\";\n", src, j->key);
  if (b.oom) {
    free(b.s);
    nz_native_say(why, whylen, "out of memory");
    goto fail;
  }
  j->src = b.s;
  j->t_start = t_start;
  o->job = j;
  if (how == NZ_NATIVE_BACKGROUND && running_workers() >= nz_native_cc_jobs()) return 1;
  if (start_worker(j, why, whylen)) {
    o->job = NULL;
    goto fail;
  }
  if (how == NZ_NATIVE_BACKGROUND) return 1;
  int r = nz_native_object_ready(o, 1, why, whylen);
  return r < 0 ? -1 : r;
fail:
  job_free(j);
  free(o->path);
  o->path = NULL;
  return -1;
}

int nz_native_object_ready(nz_native_object *o, int wait, char *why, size_t whylen)
{
  nz_native_job *j = o->job;
  if (o->dl) return 0;
  if (!j) {
    nz_native_say(why, whylen, "no object and no compile under way");
    return -1;
  }
  if (!j->started) {
    if (!wait && running_workers() >= nz_native_cc_jobs()) return 1;
    if (start_worker(j, why, whylen)) goto fail;
  }
  double t0 = nz_native_now();
  while (!j->done) {
    int i = slot_of(j), r = i < 0 ? 1 : await_slot(i, wait ? -1 : 0);
    if (r == 0) return 1;
    if (r < 0 && nz_interrupt_requested()) {
      o->waited += nz_native_now() - t0;
      return 1;   /* Ctrl-C: the run goes on interpreted, and stops */
    }
    if (i < 0 && !j->done) {
      nz_native_say(why, whylen, "lost the compile's worker");
      goto fail;
    }
  }
  if (wait) o->waited += nz_native_now() - t0;
  if (!j->ok) {
    nz_native_say(why, whylen, "%s", j->msg);
    if (j->refused) nz_native_notice("%s", j->msg);
    goto fail;
  }
  int damaged;
  if (load(j->dir, j->base, j->key, j->entry, o, &damaged, why, whylen) <= 0) {
    if (why && !why[0]) nz_native_say(why, whylen, "the compiled object is not in the cache");
    goto fail;
  }
  o->seconds = nz_native_now() - j->t_start;
  job_free(j);
  o->job = NULL;
  return 0;
fail:
  job_free(j);
  o->job = NULL;
  return -1;
}

void nz_native_object_close(nz_native_object *o)
{
  if (o->dl) dlclose(o->dl);
  job_free(o->job);   /* a compile under way finishes alone */
  free(o->path);
  memset(o, 0, sizeof *o);
}
