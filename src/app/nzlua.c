/* nzlua.c - the nzlua program: an interactive session and a script runner
 * with the nz module preloaded.
 *
 * The design follows the standalone `lua` interpreter (lua.c): all work runs
 * under lua_pcall of one `pmain`; a message handler turns any error into text
 * with a traceback; Ctrl-C during a computation only installs a hook that
 * raises the interrupt object nz.interrupted inside the VM (and sets the
 * flag that C loops poll), and resets the signal so that a second Ctrl-C
 * really kills (session_call.c runs every call so); a line is first
 * tried as `return <line>` so that an expression prints its value; a syntax
 * error at <eof> means "keep reading".
 *
 * What it adds: readline with the callback interface, so that Ctrl-C at the
 * prompt discards the pending input instead of ending the session; history
 * kept across sessions in ~/.nzlua_history (NZLUA_HISTORY overrides), limited
 * to NZLUA_HISTORY_LINES entries; tab completion; readable printing of values;
 * tracebacks only for errors that came from inside functions.
 *
 * Exit status: 0, 1 when a script (or -e, -l, stdin) failed, and 130
 * (128 + SIGINT, the shell's convention) when Ctrl-C reached it, whether it
 * stopped the script or a computation that kept its partial result (simulate
 * returns the part computed, and the script may save it before it ends). */
#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/select.h>
#include <unistd.h>

#include <readline/readline.h>
#include <readline/history.h>

#include <lua.h>
#include <lauxlib.h>
#include <lualib.h>

#include "core/interrupt.h"
#include "graph/native_cache.h"
#include "lua/lua_util.h"
#include "lua/nz.h"
#include "app/repl_complete.h"
#include "app/session_call.h"
#include "app/kernel_io.h"

#define NZLUA_PROMPT "nz> "
#define NZLUA_PROMPT2 "nz>> "
#define NZLUA_HISTORY_LINES 1000
#define NZLUA_MAXINPUT 512
#define NZLUA_EXIT_INTERRUPTED (128 + SIGINT)

static const char *progname = "nzlua";
static int interactive_input = 0;   /* stdin is a terminal: use readline */
static int run_interrupted = 0;     /* Ctrl-C reached a script, -e or -l */

/* ------------------------------------------------------------------ */
/* Messages                                                             */

static void print_usage(FILE *f)
{
  fprintf(f,
          "usage: %s [options] [script [args]]\n"
          "Runs a Lua 5.4 script with the nz module (analytical mechanics with Taylor\n"
          "jets) preloaded, or opens an interactive session when no script is given.\n"
          "Options:\n"
          "  -e stat    execute string 'stat'\n"
          "  -i         enter interactive mode after running the script\n"
          "  -l mod     require library 'mod' into global 'mod'\n"
          "  -v         show version information\n"
          "  --cache-info   where the machine code of recorded systems is kept, its size\n"
          "  --cache-clear  remove that machine code (it is compiled again when needed)\n"
          "  --sweep-worker file\n"
          "             run the points of a sweep: 'file' returns {system =, run =};\n"
          "             points on stdin, one per line (name=value ...), result rows on\n"
          "             stdout in the same format (for GNU parallel; help(nz.sweep))\n"
          "  --install-kernel [--user | --prefix DIR] [--nzlua PATH] [--python PATH]\n"
          "             register the Jupyter kernel 'nzlua' (for every user, in\n"
          "             /usr/local/share/jupyter; --user: yours only; docs/kernel.md)\n"
          "  --kernel-io  speak the kernel's framed protocol on stdin and stdout\n"
          "             (what the Jupyter kernel starts; docs/kernel.md)\n"
          "  -h         show this help\n"
          "  --         stop handling options\n"
          "  -          stop handling options and execute stdin\n"
          "In a session, help() lists what nz offers; Ctrl-C interrupts a\n"
          "computation, Ctrl-D leaves.\n",
          progname);
}

static void l_message(const char *pname, const char *msg)
{
  if (pname) fprintf(stderr, "%s: ", pname);
  fprintf(stderr, "%s\n", msg);
  fflush(stderr);
}

static int report(lua_State *L, int status, int in_session)
{
  if (status != LUA_OK) {
    const char *msg = lua_tostring(L, -1);
    if (msg == NULL) msg = "(error object is not a string)";
    msg = nzlua_user_message(L, msg);
    l_message(in_session ? NULL : progname, msg);
    lua_settop(L, 0);
  }
  return status;
}

/* A call as the session makes it; a Ctrl-C that reached it sets the exit
 * status. */
static int docall(lua_State *L, int narg, int nres)
{
  int interrupted = 0;
  int status = nzlua_docall(L, narg, nres, &interrupted);
  if (interrupted) run_interrupted = 1;
  return status;
}

static void print_version(void)
{
  printf("nzlua %s (nz module %s, %s)  analytical mechanics with Taylor jets\n", NZ_VERSION,
         NZ_VERSION, LUA_RELEASE);
  fflush(stdout);
}

/* ------------------------------------------------------------------ */
/* Running chunks                                                       */

static int dochunk(lua_State *L, int status)
{
  if (status == LUA_OK) status = docall(L, 0, 0);
  return report(L, status, 0);
}

static int dofile(lua_State *L, const char *name)
{
  return dochunk(L, luaL_loadfile(L, name));
}

static int dostring(lua_State *L, const char *s, const char *name)
{
  return dochunk(L, luaL_loadbuffer(L, s, strlen(s), name));
}

/* -l mod: require it into global mod. */
static int dolibrary(lua_State *L, const char *name)
{
  lua_getglobal(L, "require");
  lua_pushstring(L, name);
  int status = docall(L, 1, 1);
  if (status == LUA_OK) lua_setglobal(L, name);
  return report(L, status, 0);
}

static int pushargs(lua_State *L)
{
  if (lua_getglobal(L, "arg") != LUA_TTABLE) luaL_error(L, "'arg' is not a table");
  int n = (int)luaL_len(L, -1);
  luaL_checkstack(L, n + 3, "too many arguments to script");
  int i;
  for (i = 1; i <= n; i++) lua_rawgeti(L, -i, i);
  lua_remove(L, -i);
  return n;
}

static int handle_script(lua_State *L, char **argv)
{
  const char *fname = argv[0];
  if (strcmp(fname, "-") == 0 && strcmp(argv[-1], "--") != 0) fname = NULL;   /* stdin */
  int status = luaL_loadfile(L, fname);
  if (status == LUA_OK) {
    int n = pushargs(L);
    status = docall(L, n, LUA_MULTRET);
  }
  return report(L, status, 0);
}

/* ------------------------------------------------------------------ */
/* Reading lines                                                        */

static char *history_path = NULL;

static void history_open(void)
{
  const char *env = getenv("NZLUA_HISTORY");
  const char *home = getenv("HOME");
  if (env && *env) history_path = strdup(env);
  else if (home && *home) {
    size_t n = strlen(home) + sizeof "/.nzlua_history";
    history_path = malloc(n);
    if (history_path) snprintf(history_path, n, "%s/.nzlua_history", home);
  }
  using_history();
  stifle_history(NZLUA_HISTORY_LINES);
  /* A statement typed over several lines is one entry: each entry is written
   * after a timestamp line, and what follows a timestamp up to the next one
   * is read back as one entry (readline 8: history_multiline_entries). */
  history_comment_char = '#';   /* the timestamps' mark: without it readline writes none */
  history_write_timestamps = 1;
  history_multiline_entries = 1;
  if (!history_path) return;
  FILE *f = fopen(history_path, "a");   /* append_history needs the file to exist */
  if (f) fclose(f);
  read_history(history_path);
  history_truncate_file(history_path, NZLUA_HISTORY_LINES);
}

static void history_add(const char *chunk)
{
  if (!interactive_input || !*chunk) return;
  add_history(chunk);
  if (history_path) append_history(1, history_path);
}

static void history_close(void)
{
  if (history_path) history_truncate_file(history_path, NZLUA_HISTORY_LINES);
  free(history_path);
  history_path = NULL;
}

/* readline's callback interface under select(), so that SIGINT (which
 * interrupts select) discards the line instead of killing the session. */
static char *rl_result;
static int rl_finished;
static volatile sig_atomic_t prompt_interrupted;

static void on_prompt_sigint(int sig)
{
  (void)sig;
  prompt_interrupted = 1;
}

static void on_line(char *line)
{
  rl_result = line;
  rl_finished = 1;
  rl_callback_handler_remove();
}

enum { READ_OK, READ_EOF, READ_INTERRUPTED };

static int read_interactive(const char *prompt, char **out)
{
  struct sigaction sa, old;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_prompt_sigint;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &old);           /* no SA_RESTART: select returns EINTR */
  prompt_interrupted = 0;
  rl_finished = 0;
  rl_result = NULL;
  int result = READ_OK;
  rl_callback_handler_install(prompt, on_line);
  while (!rl_finished) {
    fd_set fds;
    int fd = fileno(rl_instream ? rl_instream : stdin);
    FD_ZERO(&fds);
    FD_SET(fd, &fds);
    int r = select(fd + 1, &fds, NULL, NULL, NULL);
    if (r < 0) {
      if (errno == EINTR && !prompt_interrupted) continue;
      rl_free_line_state();
      rl_callback_sigcleanup();
      rl_callback_handler_remove();
      fputs("\n", stdout);
      result = prompt_interrupted ? READ_INTERRUPTED : READ_EOF;
      break;
    }
    rl_callback_read_char();
  }
  sigaction(SIGINT, &old, NULL);
  if (result == READ_OK && rl_result == NULL) result = READ_EOF;
  *out = rl_result;
  return result;
}

static int read_plain(const char *prompt, char **out)
{
  char buf[NZLUA_MAXINPUT];
  fputs(prompt, stdout);
  fflush(stdout);
  if (fgets(buf, sizeof buf, stdin) == NULL) return READ_EOF;
  size_t n = strlen(buf);
  if (n > 0 && buf[n - 1] == '\n') buf[n - 1] = '\0';
  *out = strdup(buf);
  return *out ? READ_OK : READ_EOF;
}

/* Push one line of input; returns READ_OK, READ_EOF or READ_INTERRUPTED. */
static int pushline(lua_State *L, int firstline)
{
  const char *prompt = firstline ? NZLUA_PROMPT : NZLUA_PROMPT2;
  char *line = NULL;
  int r = interactive_input ? read_interactive(prompt, &line) : read_plain(prompt, &line);
  if (r != READ_OK) return r;
  size_t n = strlen(line);
  if (firstline && line[0] == '=') lua_pushfstring(L, "return %s", line + 1);   /* 5.2 habit */
  else lua_pushlstring(L, line, n);
  free(line);
  return READ_OK;
}

/* Try the line as an expression whose value prints.  Not `return <line>`:
 * a call there is a tail call, which removes the typed chunk's frame, and
 * an error from a library function would then not start with "stdin:1:"
 * (nz/base/where.lua looks for the user's frame).  The values pass through a
 * function called after they are computed; the newline keeps a trailing
 * comment from swallowing the parenthesis. */
static int addreturn(lua_State *L)
{
  const char *line = lua_tostring(L, -1);
  const char *retline = lua_pushfstring(L, "return (function(...) return ... end)(%s\n)", line);
  int status = luaL_loadbuffer(L, retline, strlen(retline), "=stdin");
  if (status == LUA_OK) {
    lua_remove(L, -2);
    history_add(line);
  } else {
    lua_pop(L, 2);
  }
  return status;
}

static int incomplete(lua_State *L, int status)
{
  static const char eof_mark[] = "<eof>";
  const size_t marklen = sizeof eof_mark - 1;
  if (status == LUA_ERRSYNTAX) {
    size_t lmsg;
    const char *msg = lua_tolstring(L, -1, &lmsg);
    if (lmsg >= marklen && strcmp(msg + lmsg - marklen, eof_mark) == 0) {
      lua_pop(L, 1);
      return 1;
    }
  }
  return 0;
}

/* Read more lines while the chunk is incomplete. */
static int multiline(lua_State *L, int *read_status)
{
  for (;;) {
    size_t len;
    const char *line = lua_tolstring(L, 1, &len);
    int status = luaL_loadbuffer(L, line, len, "=stdin");
    if (!incomplete(L, status)) {
      history_add(line);
      *read_status = READ_OK;
      return status;
    }
    int r = pushline(L, 0);
    if (r != READ_OK) {
      *read_status = r;
      return status;
    }
    lua_pushliteral(L, "\n");
    lua_insert(L, -2);
    lua_concat(L, 3);
  }
}

/* Load one complete chunk: LUA_OK or an error status, with *eof set at the
 * end of input; an interrupted prompt loads nothing and asks again. */
static int loadline(lua_State *L, int *eof)
{
  *eof = 0;
  for (;;) {
    lua_settop(L, 0);
    int r = pushline(L, 1);
    if (r == READ_EOF) { *eof = 1; return LUA_OK; }
    if (r == READ_INTERRUPTED) continue;
    int status = addreturn(L);
    if (status == LUA_OK) {
      lua_remove(L, 1);                 /* the line; the chunk stays */
      return status;
    }
    status = multiline(L, &r);
    if (r == READ_EOF) { *eof = 1; return LUA_OK; }
    if (r == READ_INTERRUPTED) continue;
    lua_remove(L, 1);
    return status;
  }
}

/* Push nz.repl's function `name` (plain `fallback` when the module cannot
 * be loaded, or nil). */
static void push_repl_function(lua_State *L, const char *name, const char *fallback)
{
  lua_getglobal(L, "require");
  lua_pushliteral(L, "nz.session.repl");
  if (lua_pcall(L, 1, 1, 0) != LUA_OK || !lua_istable(L, -1)) {
    lua_pop(L, 1);
    if (fallback) lua_getglobal(L, fallback);
    else lua_pushnil(L);
  } else {
    lua_getfield(L, -1, name);
    lua_remove(L, -2);
  }
}

/* Before each chunk: nz.repl forgets what the previous chunk's functions
 * printed themselves (so that a value kept from them and typed later shows). */
static void begin_chunk(lua_State *L)
{
  push_repl_function(L, "begin", NULL);
  if (lua_isfunction(L, -1)) {
    if (lua_pcall(L, 0, 0, 0) != LUA_OK) lua_pop(L, 1);
  } else {
    lua_pop(L, 1);
  }
}

/* Print the values left by a chunk with nz.repl's printer. */
static void print_results(lua_State *L)
{
  int n = lua_gettop(L);
  if (n == 0) return;
  luaL_checkstack(L, LUA_MINSTACK, "too many results to print");
  push_repl_function(L, "print", "print");
  lua_insert(L, 1);
  if (lua_pcall(L, n, 0, 0) != LUA_OK)
    l_message(progname, lua_pushfstring(L, "error calling 'print' (%s)", lua_tostring(L, -1)));
}

static void do_repl(lua_State *L)
{
  int eof = 0;
  run_interrupted = 0;      /* the session decides the exit status now */
  if (interactive_input) {
    history_open();
    nz_complete_install(L);
  }
  for (;;) {
    int status = loadline(L, &eof);
    if (eof) break;
    if (status == LUA_OK) {
      begin_chunk(L);
      status = docall(L, 0, LUA_MULTRET);
    }
    if (status == LUA_OK) print_results(L);
    else report(L, status, 1);
    run_interrupted = 0;
  }
  lua_settop(L, 0);
  fputs("\n", stdout);
  fflush(stdout);
  if (interactive_input) history_close();
}

/* ------------------------------------------------------------------ */
/* Arguments                                                            */

enum { HAS_ERROR = 1, HAS_I = 2, HAS_V = 4, HAS_E = 8, HAS_H = 16, HAS_W = 32, HAS_CACHE = 64, HAS_KERNEL = 128,
       HAS_INSTALL = 256 };

/* --install-kernel's own options start here in argv (lua/nz/session/kernel.lua reads them). */
static int install_kernel_args = 0;

/* --sweep-worker FILE: the file of the sweep whose points stdin brings. */
static const char *sweep_worker_file = NULL;
static const char *cache_option = NULL;   /* --cache-info or --cache-clear */

/* A notice of the cache's (a setting refused or clamped) on stderr. */
static void cache_notice(const char *line)
{
  fprintf(stderr, "%s: %s\n", progname, line);
}

/* nzlua --cache-info | --cache-clear: the machine code's cache
 * (src/graph/native_object.h).  0 on success. */
static int docache(void)
{
  char dir[4096], why[400];
  nz_native_set_notice(cache_notice);
  if (!nz_native_cache_dir(dir, sizeof dir, why, sizeof why)) {
    fprintf(stderr, "%s: %s\n", progname, why);
    return 1;
  }
  if (!strcmp(cache_option, "--cache-clear")) {
    int n = nz_native_cache_clear(dir, why, sizeof why);
    if (n < 0) {
      fprintf(stderr, "%s: %s\n", progname, why);
      return 1;
    }
    printf("%s: removed %d file%s from the cache '%s'\n", progname, n, n == 1 ? "" : "s", dir);
    return 0;
  }
  nz_native_cache_stat st;
  if (nz_native_cache_info(dir, &st, why, sizeof why)) {
    fprintf(stderr, "%s: %s\n", progname, why);
    return 1;
  }
  printf("cache of machine code: %s\n", dir);
  if (!st.trusted) {   /* its files are not read */
    printf("  NOT trusted: %s\n", st.why);
    return 0;
  }
  printf("  %d object%s, %.1f MB in all (limit %.0f MB: NZLUA_CACHE_MAX; the least recently used go first)\n",
         st.objects, st.objects == 1 ? "" : "s", st.bytes / 1048576.0, st.limit / 1048576.0);
  if (st.sources) printf("  %d generated source%s kept (NZLUA_KEEP_C=1)\n", st.sources, st.sources == 1 ? "" : "s");
  printf("  trusted: yours alone, machine code is loaded from it\n");
  return 0;
}

/* Scan options; *first is the index of the script (or argc). */
static int collectargs(char **argv, int *first)
{
  int args = 0;
  for (int i = 1; argv[i] != NULL; i++) {
    *first = i;
    if (argv[i][0] != '-') return args;
    if (strcmp(argv[i], "--") == 0) { *first = i + 1; return args; }
    if (strcmp(argv[i], "-") == 0) return args;
    if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) args |= HAS_H;
    else if (strcmp(argv[i], "--version") == 0 || strcmp(argv[i], "-v") == 0) args |= HAS_V;
    else if (strcmp(argv[i], "-i") == 0) args |= HAS_I | HAS_V;
    else if (strcmp(argv[i], "--cache-info") == 0 || strcmp(argv[i], "--cache-clear") == 0) {
      cache_option = argv[i];
      args |= HAS_CACHE;
    } else if (strcmp(argv[i], "--kernel-io") == 0) {
      args |= HAS_KERNEL;
    } else if (strcmp(argv[i], "--install-kernel") == 0) {
      install_kernel_args = i + 1;        /* the rest are its options */
      for (*first = i + 1; argv[*first]; (*first)++) {}
      return args | HAS_INSTALL;
    } else if (strcmp(argv[i], "--sweep-worker") == 0) {
      if (argv[i + 1] == NULL) { *first = i; return HAS_ERROR; }
      sweep_worker_file = argv[++i];
      args |= HAS_W;
    }
    else if (strcmp(argv[i], "-e") == 0 || strcmp(argv[i], "-l") == 0) {
      if (argv[i][1] == 'e') args |= HAS_E;
      if (argv[i + 1] == NULL || argv[i + 1][0] == '-') { *first = i; return HAS_ERROR; }
      i++;
    } else {
      *first = i;
      return HAS_ERROR;
    }
  }
  for (*first = 1; argv[*first]; (*first)++) {}
  return args;
}

static int runargs(lua_State *L, char **argv, int n)
{
  for (int i = 1; i < n; i++) {
    if (strcmp(argv[i], "-e") == 0) {
      if (dostring(L, argv[++i], "=(command line)") != LUA_OK) return 0;
    } else if (strcmp(argv[i], "-l") == 0) {
      if (dolibrary(L, argv[++i]) != LUA_OK) return 0;
    }
  }
  return 1;
}

/* arg[0] is the script, arg[1..] its arguments, negative indices the rest. */
static void createargtable(lua_State *L, char **argv, int argc, int script)
{
  if (script == argc) script = 0;
  int narg = argc - (script + 1);
  lua_createtable(L, narg, script + 1);
  for (int i = 0; i < argc; i++) {
    lua_pushstring(L, argv[i]);
    lua_rawseti(L, -2, i - script);
  }
  lua_setglobal(L, "arg");
}

/* nzlua --sweep-worker FILE (lua/nz/motion/sweep.lua's worker). */
static int dosweepworker(lua_State *L)
{
  lua_getglobal(L, "require");
  lua_pushliteral(L, "nz.motion.sweep");
  int status = docall(L, 1, 1);
  if (status == LUA_OK) {
    lua_getfield(L, -1, "worker");
    lua_remove(L, -2);
    lua_pushstring(L, sweep_worker_file);
    status = docall(L, 1, 0);
  }
  return report(L, status, 0);
}

/* nzlua --install-kernel [options]: lua/nz/session/kernel.lua's install, given
 * the options and this program's own path (written into the kernel spec). */
static int doinstallkernel(lua_State *L, char **argv, int argc)
{
  char exe[4096];
  ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
  exe[n > 0 ? n : 0] = '\0';
  lua_getglobal(L, "require");
  lua_pushliteral(L, "nz.session.kernel");
  int status = docall(L, 1, 1);
  if (status == LUA_OK) {
    lua_getfield(L, -1, "install");
    lua_remove(L, -2);
    lua_createtable(L, argc - install_kernel_args, 1);
    for (int i = install_kernel_args; i < argc; i++) {
      lua_pushstring(L, argv[i]);
      lua_rawseti(L, -2, i - install_kernel_args + 1);
    }
    lua_pushstring(L, exe);
    lua_setfield(L, -2, "program");
    status = docall(L, 1, 0);
  }
  return report(L, status, 0);
}

/* The session's environment: nz as a global, its functions unprefixed. */
static void open_nz(lua_State *L)
{
  luaL_requiref(L, "nz", luaopen_nz, 1);
  lua_getglobal(L, "require");
  lua_pushliteral(L, "nz.session.repl");
  lua_call(L, 1, 1);
  lua_getfield(L, -1, "install_globals");
  lua_pushglobaltable(L);
  lua_pushvalue(L, -4);
  lua_call(L, 2, 0);
  lua_pop(L, 2);
}

static int pmain(lua_State *L)
{
  int argc = (int)lua_tointeger(L, 1);
  char **argv = lua_touserdata(L, 2);
  int script = argc;
  int args = collectargs(argv, &script);
  luaL_checkversion(L);
  if (args == HAS_ERROR) {
    fprintf(stderr, "%s: unrecognized option or missing argument '%s'\n", progname, argv[script]);
    print_usage(stderr);
    return 0;
  }
  if (args & HAS_H) {
    print_usage(stdout);
    lua_pushboolean(L, 1);
    return 1;
  }
  if (args & HAS_V) print_version();
  if (args & HAS_CACHE) {
    lua_pushboolean(L, docache() == 0);
    return 1;
  }
  if (args & HAS_KERNEL) {
    /* before the libraries: io.stdout must be the stream that makes frames */
    char why[256];
    if (nz_kernel_io_begin(why, sizeof why) != 0) {
      l_message(progname, why);
      return 0;
    }
  }
  luaL_openlibs(L);
  open_nz(L);
  if (args & HAS_INSTALL) {
    lua_pushboolean(L, doinstallkernel(L, argv, argc) == LUA_OK);
    return 1;
  }
  if (args & HAS_KERNEL) {
    lua_pushboolean(L, nz_kernel_io_serve(L) == LUA_OK);
    return 1;
  }
  createargtable(L, argv, argc, script);
  if (!runargs(L, argv, script)) return 0;
  if (script < argc && handle_script(L, argv + script) != LUA_OK) return 0;
  if (args & HAS_W) {
    if (dosweepworker(L) != LUA_OK) return 0;
  } else if (args & HAS_I) {
    do_repl(L);
  } else if (script == argc && !(args & (HAS_E | HAS_V))) {
    if (isatty(0)) {
      print_version();
      puts("Type help() for what nz offers, help(name) for one entry; Ctrl-C interrupts a computation, Ctrl-D (or os.exit()) leaves.");
      do_repl(L);
    } else if (dofile(L, NULL) != LUA_OK) {
      return 0;
    }
  }
  lua_pushboolean(L, 1);
  return 1;
}

int main(int argc, char **argv)
{
  lua_State *L = luaL_newstate();
  if (L == NULL) {
    l_message(argv[0], "cannot create state: not enough memory");
    return EXIT_FAILURE;
  }
  interactive_input = isatty(0);
  rl_catch_signals = 0;
  lua_gc(L, LUA_GCGEN, 0, 0);
  lua_pushcfunction(L, pmain);
  lua_pushinteger(L, argc);
  lua_pushlightuserdata(L, argv);
  int status = lua_pcall(L, 2, 1, 0);
  int result = lua_toboolean(L, -1);
  report(L, status, 0);
  lua_close(L);
  if (run_interrupted) return NZLUA_EXIT_INTERRUPTED;
  return (result && status == LUA_OK) ? EXIT_SUCCESS : EXIT_FAILURE;
}
