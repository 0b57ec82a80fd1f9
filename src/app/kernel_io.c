/* kernel_io.c - nzlua --kernel-io: the session as framed requests and
 * replies, for the Jupyter kernel (jupyter/nzlua_kernel.py, an ipykernel
 * wrapper kernel, starts nzlua this way and speaks to it over the pipes).
 *
 * Every message either way is a frame (docs/kernel.md):
 *
 *     NZ <kind> <nfields>\n
 *     <name> <length>\n<length bytes>\n        (nfields times)
 *
 * Binary-safe (a GIF is a field like any other) and read without a JSON
 * parser on either side.  What a request means and what answers it is
 * lua/nz/session/kernel.lua's; this file moves the frames, makes everything the
 * process prints a frame, and lends Lua the session's way of running a
 * chunk (app/session_call.h: Ctrl-C, that is SIGINT from the kernel's stop
 * button, interrupts it exactly as at the prompt).
 *
 * The frames have descriptors of their own, duplicated from 0 and 1 when
 * the mode begins: descriptor 1 then points at 2, so that a child process
 * (gnuplot, the compiler, os.execute) that writes to its stdout lands in
 * stderr, never inside a frame, and descriptor 0 reads /dev/null, so that
 * io.read in a cell sees the end of its input instead of the requests.
 * The C library's stdout and stderr become streams (glibc's fopencookie)
 * whose writes are "stream" frames: print, io.write, printf, and the
 * progress bars of long runs reach the notebook as they are written. */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <lua.h>
#include <lauxlib.h>

#include "app/kernel_io.h"
#include "app/session_call.h"
#include "app/repl_complete.h"

#define FRAME_MAGIC "NZ"
#define FRAME_MAX_FIELDS 64
#define FRAME_MAX_LINE 256
#define FRAME_MAX_FIELD (16 * 1024 * 1024)   /* bytes of one field of a request */
#define FRAME_MAX_BYTES (64 * 1024 * 1024)   /* bytes of all the fields of one request */

static FILE *proto_in = NULL;   /* requests */
static FILE *proto_out = NULL;  /* replies, streams, displays */

/* Write one field: "<name> <length>\n<bytes>\n". */
static void put_field(const char *name, const char *data, size_t len)
{
  fprintf(proto_out, "%s %zu\n", name, len);
  if (len) fwrite(data, 1, len, proto_out);
  fputc('\n', proto_out);
}

/* A "stream" frame: what the process wrote to stdout or stderr. */
static ssize_t stream_write(void *cookie, const char *buf, size_t size)
{
  const char *name = cookie;
  if (size == 0) return 0;
  fprintf(proto_out, FRAME_MAGIC " stream 2\n");
  put_field("name", name, strlen(name));
  put_field("text", buf, size);
  if (fflush(proto_out) != 0) return -1;
  return (ssize_t)size;
}

static int cloexec_dup(int fd)
{
  return fcntl(fd, F_DUPFD_CLOEXEC, 3);
}

int nz_kernel_io_begin(char *why, size_t n)
{
  int in = cloexec_dup(0), out = cloexec_dup(1);
  if (in < 0 || out < 0) {
    snprintf(why, n, "cannot duplicate stdin and stdout for the protocol: %s", strerror(errno));
    return -1;
  }
  int null = open("/dev/null", O_RDONLY);
  if (null < 0 || dup2(null, 0) < 0 || dup2(2, 1) < 0) {
    snprintf(why, n, "cannot redirect stdin and stdout: %s", strerror(errno));
    return -1;
  }
  close(null);
  proto_in = fdopen(in, "r");
  proto_out = fdopen(out, "w");
  cookie_io_functions_t io = { .read = NULL, .write = stream_write, .seek = NULL, .close = NULL };
  FILE *o = fopencookie((void *)"stdout", "w", io);
  FILE *e = fopencookie((void *)"stderr", "w", io);
  if (!proto_in || !proto_out || !o || !e) {
    snprintf(why, n, "cannot open the protocol's streams: %s", strerror(errno));
    return -1;
  }
  /* as a terminal: stdout by lines (print flushes anyway), stderr at once */
  setvbuf(o, NULL, _IOLBF, BUFSIZ);
  setvbuf(e, NULL, _IONBF, 0);
  stdout = o;   /* glibc's stdout and stderr are variables (the manual says so) */
  stderr = e;
  return 0;
}

/* ------------------------------------------------------------------ */
/* What lua/nz/session/kernel.lua gets                                          */

/* The line read before a malformed frame was given up: the next frame's
 * header, read while skipping the bad one's rest (empty: none). */
static char pending[FRAME_MAX_LINE];

/* The next line of the requests into line[n]; 0 at the end of the input. */
static int next_line(char *line, size_t n)
{
  if (pending[0]) {
    snprintf(line, n, "%s", pending);
    pending[0] = 0;
    return 1;
  }
  return fgets(line, (int)n, proto_in) != NULL;
}

/* A count written in decimal digits alone, from 0 to max, into *out; 0, or
 * -1 (a sign, a fraction, an exponent, letters, or more than max). */
static int parse_count(const char *s, long long max, long long *out)
{
  long long v = 0;
  if (*s < '0' || *s > '9') return -1;
  for (; *s >= '0' && *s <= '9'; s++) {
    if (v > max / 10 || 10 * v > max - (*s - '0')) return -1;
    v = 10 * v + (*s - '0');
  }
  if (*s && *s != '\n') return -1;
  *out = v;
  return 0;
}

/* A malformed frame: its rest skipped (the lines up to the next that
 * starts a frame, kept in pending), then false and the message. */
static int malformed(lua_State *L, const char *fmt, ...)
{
  char line[FRAME_MAX_LINE];
  va_list ap;
  va_start(ap, fmt);
  lua_pushboolean(L, 0);
  lua_pushvfstring(L, fmt, ap);
  va_end(ap);
  while (fgets(line, sizeof line, proto_in))
    if (!strncmp(line, FRAME_MAGIC " ", 3)) {
      snprintf(pending, sizeof pending, "%s", line);
      break;
    }
  return 2;
}

/* One field's header "<name> <length>" (line) parsed into name[64] and
 * *len (at most room); 0, or -1 with the reason in why[n]. */
static int field_header(const char *line, char *name, long long *len, long long room, char *why, size_t n)
{
  const char *sp = strchr(line, ' ');
  size_t k = sp ? (size_t)(sp - line) : 0;
  const char *digits = sp ? sp + 1 : "";
  size_t nd = strspn(digits, "0123456789");
  if (!sp || k == 0 || k > 63)
    snprintf(why, n, "'<name> <length>' expected");
  else if (nd == 0 || (digits[nd] && digits[nd] != '\n'))
    snprintf(why, n, "its length is not a count of bytes (decimal digits alone)");
  else if (parse_count(digits, room, len))
    snprintf(why, n, "its length %.*s is more than the cap (%d bytes a field, %d bytes a frame)", (int)(nd > 40 ? 40 : nd),
             digits, FRAME_MAX_FIELD, FRAME_MAX_BYTES);
  else {
    memcpy(name, line, k);
    name[k] = 0;
    return 0;
  }
  return -1;
}

/* read() -> kind, {name = value, ...}; or false and a message for a
 * malformed frame (skipped: the next read starts at the next frame); or
 * nil at the end of the input.  Numbers in a frame are decimal digits
 * alone; a field is at most FRAME_MAX_FIELD bytes and a frame's fields
 * FRAME_MAX_BYTES together, so that a length is refused before anything
 * is allocated for it. */
static int k_read(lua_State *L)
{
  char line[FRAME_MAX_LINE], kind[64];
  long long nfields;
  if (!next_line(line, sizeof line)) return 0;
  const char *sp = strchr(line + 3, ' ');
  size_t kn = sp ? (size_t)(sp - line - 3) : 0;
  if (strncmp(line, FRAME_MAGIC " ", 3) || kn == 0 || kn > 63 || parse_count(sp + 1, FRAME_MAX_FIELDS, &nfields))
    return malformed(L, "a frame must start with 'NZ <kind> <nfields>' (nfields from 0 to %d), got '%s'",
                     FRAME_MAX_FIELDS, (line[strcspn(line, "\n")] = 0, line));
  memcpy(kind, line + 3, kn);
  kind[kn] = 0;
  lua_pushstring(L, kind);
  lua_createtable(L, 0, (int)nfields);
  long long room = FRAME_MAX_BYTES;
  for (int i = 0; i < nfields; i++) {
    char name[64];
    long long len;
    if (!next_line(line, sizeof line))
      return malformed(L, "field %d of a '%s' frame: the input ends", i + 1, kind);
    char why[200];
    if (field_header(line, name, &len, room < FRAME_MAX_FIELD ? room : FRAME_MAX_FIELD, why, sizeof why))
      return malformed(L, "field %d of a '%s' frame: %s", i + 1, kind, why);
    room -= len;
    luaL_Buffer b;
    char *p = luaL_buffinitsize(L, &b, (size_t)len);
    if (fread(p, 1, (size_t)len, proto_in) != (size_t)len || fgetc(proto_in) != '\n')
      return malformed(L, "field '%s' of a '%s' frame ends early", name, kind);
    luaL_pushresultsize(&b, (size_t)len);
    lua_setfield(L, -2, name);
  }
  return 2;
}

/* write(kind, {name1, value1, name2, value2, ...}): fields in that order.
 * What print and io.write left in stdout's buffer goes first. */
static int k_write(lua_State *L)
{
  const char *kind = luaL_checkstring(L, 1);
  luaL_checktype(L, 2, LUA_TTABLE);
  lua_Integer n = luaL_len(L, 2);
  if (n % 2 != 0) return luaL_argerror(L, 2, "pairs of name and value expected");
  for (lua_Integer i = 1; i <= n; i++) {
    if (lua_geti(L, 2, i) != LUA_TSTRING && !lua_isnumber(L, -1))
      return luaL_error(L, "kernel-io: field %d of a '%s' frame is not a string", (int)i, kind);
    lua_pop(L, 1);
  }
  fflush(stdout);
  fprintf(proto_out, FRAME_MAGIC " %s %d\n", kind, (int)(n / 2));
  for (lua_Integer i = 1; i <= n; i += 2) {
    size_t len;
    lua_geti(L, 2, i);
    lua_geti(L, 2, i + 1);
    const char *name = lua_tostring(L, -2);
    const char *value = lua_tolstring(L, -1, &len);
    put_field(name, value, len);
    lua_pop(L, 2);
  }
  fflush(proto_out);
  return 0;
}

/* run(f, ...) -> true, interrupted, results... | false, interrupted, message:
 * f called as the session calls a chunk (Ctrl-C = SIGINT interrupts it),
 * its error as the session prints it. */
static int k_run(lua_State *L)
{
  luaL_checktype(L, 1, LUA_TFUNCTION);
  int interrupted = 0;
  int status = nzlua_docall(L, lua_gettop(L) - 1, LUA_MULTRET, &interrupted);
  fflush(stdout);
  if (status == LUA_OK) {
    int nres = lua_gettop(L);
    luaL_checkstack(L, 2, "too many results");
    lua_pushboolean(L, 1);
    lua_pushboolean(L, interrupted);
    lua_rotate(L, 1, 2);
    return nres + 2;
  }
  const char *msg = lua_tostring(L, -1);
  lua_pushboolean(L, 0);
  lua_pushboolean(L, interrupted);
  nzlua_user_message(L, msg ? msg : "(error object is not a string)");
  return 3;
}

/* complete(line, cursor) -> {candidates}, start: the session's Tab on the
 * word that ends at byte `cursor`, which starts after byte `start`. */
static int k_complete(lua_State *L)
{
  size_t len;
  const char *line = luaL_checklstring(L, 1, &len);
  lua_Integer cursor = luaL_checkinteger(L, 2);
  if (cursor < 0 || (size_t)cursor > len) cursor = (lua_Integer)len;
  size_t start = nz_complete_word_start(line, (size_t)cursor);
  lua_pushlstring(L, line + start, (size_t)cursor - start);
  nz_complete_push(L, lua_tostring(L, -1));
  lua_pushinteger(L, (lua_Integer)start);
  return 2;
}

int nz_kernel_io_serve(lua_State *L)
{
  static const luaL_Reg host[] = {
    { "read", k_read }, { "write", k_write }, { "run", k_run }, { "complete", k_complete }, { NULL, NULL }
  };
  /* Waiting for a request, SIGINT is ignored: the kernel sends it only
   * while a cell runs, and one that comes a moment late must not end the
   * process (nzlua_docall installs the session's handler for each cell). */
  nzlua_set_idle_sigint(SIG_IGN);
  lua_getglobal(L, "require");
  lua_pushliteral(L, "nz.session.kernel");
  lua_call(L, 1, 1);
  lua_getfield(L, -1, "serve");
  lua_remove(L, -2);
  luaL_newlib(L, host);
  /* the library itself, handed down: kernel.lua sits below the face that
   * require "nz" loads */
  lua_getglobal(L, "require");
  lua_pushliteral(L, "nz");
  lua_call(L, 1, 1);
  lua_setfield(L, -2, "nz");
  if (lua_pcall(L, 1, 0, 0) != LUA_OK) {
    fprintf(stderr, "nzlua: kernel-io: %s\n", lua_tostring(L, -1));
    return LUA_ERRRUN;
  }
  return LUA_OK;
}
