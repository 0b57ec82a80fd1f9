/* lua_system.c - the mechanics (mech.h) for Lua.
 *
 * The Lua class (lua/nz/system.lua) validates a system and hands these
 * functions its definition table `def`:
 *   def.k, def.name, def.coords, def.params,
 *   def.F, def.T, def.V, def.Q, def.S   lists of functions (any may be empty),
 *   def.labels = {F = {...}, ...}       what to call each function in errors.
 * The evaluator calls the Lua functions under lua_pcall (a Lua error must
 * never longjmp through the C core or GSL), keeps the message, and the
 * binding raises it after the core has returned, with the system, the
 * function and the state. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <lauxlib.h>
#include "mech/constrained.h"
#include "core/linalg.h"
#include "lua/lua_dualjet.h"
#include "lua/lua_graph.h"
#include "lua/lua_jet.h"
#include "lua/lua_system.h"
#include "lua/lua_util.h"
#include "mech/mech.h"

static const char *const piece_fields[NZ_PIECE_COUNT] = { "F", "T", "V", "Q", "S", "constraints" };


static void append_vector(luaL_Buffer *b, const char *name, nz_jet *const *v, int k)
{
  char num[40];
  luaL_addstring(b, name);
  luaL_addstring(b, " = {");
  for (int i = 0; i < k; i++) {
    nz_lua_fmt_num(num, sizeof num, v[i]->c[0]);
    if (i) luaL_addstring(b, ", ");
    luaL_addstring(b, num);
  }
  luaL_addstring(b, "}");
}

/* Keep "LABEL MESSAGE at t = .., q = {..}, qd = {..}" for the binding to
 * raise (nz_lua_raise_core): in the registry, under the evaluator's address,
 * as a Lua string of any length, so that a failure nested in user code that
 * called the mechanics again keeps its root cause whole. */
static void record_failure(lua_evaluator *ev, nz_piece piece, int index, const nz_jet *t,
                           nz_jet *const *const *levels, int nlevels, const char *what)
{
  lua_State *L = ev->L;
  luaL_Buffer b;
  char num[40];
  luaL_buffinit(L, &b);
  lua_getfield(L, ev->def, "labels");
  lua_getfield(L, -1, piece_fields[piece]);
  lua_geti(L, -1, index);
  const char *label = lua_tostring(L, -1);
  lua_pop(L, 3);
  luaL_addstring(&b, label ? label : piece_fields[piece]);
  if (what[0]) {
    luaL_addstring(&b, " ");
    luaL_addstring(&b, what);
  }
  nz_lua_fmt_num(num, sizeof num, t->c[0]);
  luaL_addstring(&b, " at t = ");
  luaL_addstring(&b, num);
  luaL_addstring(&b, ", ");
  append_vector(&b, "q", levels[0], ev->k);
  if (nlevels > 1) {
    luaL_addstring(&b, ", ");
    append_vector(&b, "qd", levels[1], ev->k);
  }
  luaL_pushresult(&b);
  lua_rawsetp(L, LUA_REGISTRYINDEX, ev);
}

/* Message handler of the calls of user functions: notes where in the
 * user's code the error happened, in the registry under where_key, for
 * note_error to read as soon as lua_pcall returns (the error itself is left
 * as it is).  A light C function: pushing it allocates nothing. */
static const char where_key = 0;

static int user_error_handler(lua_State *L)
{
  char where[sizeof ((lua_evaluator *)0)->where];
  if (nz_lua_is_interrupt(L, 1)) return 1;
  nz_lua_user_location(L, 1, where, sizeof where);
  lua_pushstring(L, where);
  lua_rawsetp(L, LUA_REGISTRYINDEX, &where_key);
  return 1;
}

/* Move what user_error_handler noted into ev->where. */
static void take_location(lua_evaluator *ev)
{
  lua_State *L = ev->L;
  lua_rawgetp(L, LUA_REGISTRYINDEX, &where_key);
  const char *where = lua_tostring(L, -1);
  snprintf(ev->where, sizeof ev->where, "%s", where ? where : "");
  lua_pop(L, 1);
  lua_pushnil(L);
  lua_rawsetp(L, LUA_REGISTRYINDEX, &where_key);
}

/* The user's message without the "file:line:" that ev->where already says. */
static const char *strip_location(const lua_evaluator *ev, const char *msg)
{
  size_t n = strlen(ev->where);
  if (n > 0 && strncmp(msg, ev->where, n) == 0 && msg[n] == ' ') return msg + n + 1;
  return msg;
}

/* Where a user function was defined ("file:line:"), for a bad result. */
static void definition_location(lua_State *L, int fn, char *where, size_t n)
{
  lua_Debug ar;
  where[0] = '\0';
  lua_pushvalue(L, fn);
  lua_getinfo(L, ">S", &ar);
  if (ar.linedefined > 0 && !nz_lua_library_source(ar.source))
    snprintf(where, n, "%s:%d:", ar.short_src, ar.linedefined);
}

/* out += j (a jet of at least out's order; an eta-part may be of lower
 * order: its missing coefficients are zero, as the graph's are). */
static int accumulate_jet(const nz_jet *j, nz_jet *out, int eta, const char **why)
{
  if (j->order < out->order && !eta) {
    *why = "returned a jet of lower order than its arguments (make constants numbers, not jets)";
    return 0;
  }
  int K = j->order < out->order ? j->order : out->order;
  for (int d = -1; d < out->ntan && d < j->ntan; d++) {
    const double *src = d < 0 ? j->c : nz_jet_tangent(j, d);
    double *dst = d < 0 ? out->c : nz_jet_tangent(out, d);
    for (int c = 0; c <= K; c++) {
      if (!isfinite(src[c])) { *why = "returned a value that is not finite (NaN or inf)"; return 0; }
      dst[c] += src[c];
    }
  }
  return 1;
}

/* out += the value at idx (a number or a jet of at least out's order). */
static int accumulate(lua_State *L, int idx, nz_jet *out, const char **why)
{
  if (lua_type(L, idx) == LUA_TNUMBER) {
    double v = lua_tonumber(L, idx);
    if (!isfinite(v)) { *why = "returned a value that is not finite"; return 0; }
    out->c[0] += v;
    return 1;
  }
  nz_jet *j = nz_lua_tojet(L, idx);
  if (!j) { *why = "returned something that is neither a number nor a jet"; return 0; }
  return accumulate_jet(j, out, 0, why);
}

static void push_jet_copy(lua_State *L, const nz_jet *j)
{
  nz_jet *z = nz_lua_newjet(L, j->order, j->ntan);
  nz_jet_copy(z, j);
}

static void push_jet_list(lua_State *L, nz_jet *const *v, int k)
{
  lua_createtable(L, k, 0);
  for (int i = 0; i < k; i++) {
    push_jet_copy(L, v[i]);
    lua_rawseti(L, -2, i + 1);
  }
}

/* The testing hook of the arguments along a direction (core.mech.
 * argument_hook(f), f = nil to remove it): f() is called before each
 * dualjet is made, inside the protected call that builds the arguments, so
 * that tests can raise an error or the interrupt where building them can
 * fail (running out of memory) and check that nothing unwinds through the
 * C core.  Testing only. */
static const char argument_hook_key = 0;

static int ls_argument_hook(lua_State *L)
{
  lua_settop(L, 1);
  if (!lua_isnil(L, 1)) luaL_checktype(L, 1, LUA_TFUNCTION);
  lua_rawsetp(L, LUA_REGISTRYINDEX, &argument_hook_key);
  return 0;
}

/* With a direction, an argument is the dualjet v + eta d (lua_dualjet.c);
 * `hook` (stack index, 0: none) is called first. */
static void push_dual_copy(lua_State *L, int hook, const nz_jet *v, const nz_jet *d)
{
  if (hook) {
    lua_pushvalue(L, hook);
    lua_call(L, 0, 0);
  }
  nz_lua_push_dualjet(L, v, d);
}

/* What lua_eval asks of build_arguments. */
typedef struct eval_call {
  lua_evaluator *ev;
  const nz_jet *t;
  nz_jet *const *const *levels;
  int nlevels;
  const nz_direction *dir;
} eval_call;

/* Pushes the arguments shared by every function of the piece: t, q[, qd,
 * ...], params; along a direction, dualjets v + eta d.  It runs under
 * lua_pcall: building them allocates (memory may run out) and may call the
 * testing hook, and no Lua error may unwind through the C core and GSL
 * frames below lua_eval. */
static int build_arguments(lua_State *L)
{
  const eval_call *c = lua_touserdata(L, 1);
  lua_evaluator *ev = c->ev;
  const nz_direction *dir = c->dir;
  lua_settop(L, 2);                       /* the call, the definition table */
  luaL_checkstack(L, c->nlevels + 8, "building the arguments of a user function");
  int hook = 0;
  if (dir && lua_rawgetp(L, LUA_REGISTRYINDEX, &argument_hook_key) != LUA_TNIL) hook = lua_gettop(L);
  else if (dir) lua_pop(L, 1);
  if (dir) push_dual_copy(L, hook, c->t, dir->dt);
  else push_jet_copy(L, c->t);
  for (int lv = 0; lv < c->nlevels; lv++) {
    if (!dir) {
      push_jet_list(L, c->levels[lv], ev->k);
      continue;
    }
    lua_createtable(L, ev->k, 0);
    for (int i = 0; i < ev->k; i++) {
      push_dual_copy(L, hook, c->levels[lv][i], dir->dlevels[lv][i]);
      lua_rawseti(L, -2, i + 1);
    }
  }
  lua_getfield(L, 2, "params");
  if (hook) lua_remove(L, hook);
  lua_remove(L, 2);
  lua_remove(L, 1);
  return lua_gettop(L);
}

/* Add a result at idx into out and, along a direction, its eta-part into
 * dout: a dualjet's d, zero for a number or a jet; 0 and *why on a bad
 * value. */
static int accumulate_result(lua_State *L, int idx, nz_jet *out, nz_jet *dout, const char **why)
{
  const nz_jet *v, *d;
  if (dout && nz_lua_todualjet(L, idx, &v, &d))
    return accumulate_jet(v, out, 0, why) && accumulate_jet(d, dout, 1, why);
  return accumulate(L, idx, out, why);
}

/* A call that did not return: the interrupt, or a message to keep. */
/* What to do about the two mistakes a newcomer makes first, said after the
 * message: math.cos (numbers only) applied to a jet, and a coordinate read
 * by name (q.th) where q is a list.  Pushes the hint ("" when neither
 * applies). */
static void error_hint(lua_State *L, lua_evaluator *ev, const char *msg)
{
  const char *fn = strstr(msg, "bad argument #1 to '");
  if (fn && (strstr(msg, "got nz.jet") || strstr(msg, "got nz.dualjet") || strstr(msg, "got table"))) {
    char name[32];
    fn += strlen("bad argument #1 to '");
    size_t n = strcspn(fn, "'");
    if (n > 0 && n < sizeof name) {
      memcpy(name, fn, n);
      name[n] = 0;
      lua_pushfstring(L, " (math.%s works on numbers only: write nz.%s(...), or %s(...) in the session)", name, name, name);
      return;
    }
  }
  const char *field = strstr(msg, "(field '");
  if (field && strstr(msg, "nil value")) {
    field += strlen("(field '");
    size_t n = strcspn(field, "'");
    lua_getfield(L, ev->def, "coords");
    for (int i = 1; lua_istable(L, -1) && i <= ev->k; i++) {
      lua_geti(L, -1, i);
      size_t len;
      const char *c = lua_tolstring(L, -1, &len);
      int same = c && len == n && strncmp(c, field, n) == 0;
      lua_pop(L, 1);
      if (same) {
        lua_pushfstring(L, " (q, qd, ... are lists indexed by number: '%s' is q[%d], qd[%d])", c, i, i);
        lua_remove(L, -2);   /* the coordinates' table */
        return;
      }
    }
    lua_pop(L, 1);
  }
  lua_pushliteral(L, "");
}

/* The last message nz_lua_raise_core raised, in the registry: a user
 * function that called the mechanics again (T asking for sys:energy, a
 * force for sys:accel) and let its error through hands back the engine's
 * own message, which already names the system, the function and the
 * state; wrapped once per level it repeated them (40 levels: 2.5 kB). */
static const char engine_error_key = 0;
#define NESTED_NOTE " (nested "

/* The error object's text: a string (or number) as it is; another value by
 * its __tostring, else by its type. */
static const char *error_text(lua_State *L, int idx)
{
  if (lua_type(L, idx) == LUA_TSTRING || lua_type(L, idx) == LUA_TNUMBER) return lua_tostring(L, idx);
  if (luaL_getmetafield(L, idx, "__tostring") != LUA_TNIL) {
    lua_pop(L, 1);
    luaL_tolstring(L, idx, NULL);       /* pushed, then put in the object's place */
    lua_replace(L, idx < 0 ? idx - 1 : idx);
    return lua_tostring(L, idx);
  }
  lua_pushfstring(L, "an error object of type %s (give error() a string, or the object a __tostring)",
                  luaL_typename(L, idx));
  lua_replace(L, idx < 0 ? idx - 1 : idx);
  return lua_tostring(L, idx);
}

static void note_error(lua_evaluator *ev, const eval_call *c, nz_piece piece, int index,
                       const char *doing)
{
  lua_State *L = ev->L;
  if (nz_lua_is_interrupt(L, -1)) {
    ev->interrupted = 1;
    return;
  }
  take_location(ev);
  lua_rawgetp(L, LUA_REGISTRYINDEX, &engine_error_key);
  int nested = lua_type(L, -2) == LUA_TSTRING && lua_rawequal(L, -1, -2);
  lua_pop(L, 1);
  if (nested) {
    /* The root cause, whole and once, and the outermost call once: each
     * level replaces the note of the level below, "(nested N deep; the
     * outermost call: V at t = .., q = ..)", by its own. */
    size_t len;
    const char *msg = lua_tolstring(L, -1, &len), *note = NULL;
    for (const char *p = strstr(msg, NESTED_NOTE); p; p = strstr(p + 1, NESTED_NOTE)) note = p;
    int depth = note ? atoi(note + strlen(NESTED_NOTE)) + 1 : 1;
    lua_pushlstring(L, msg, note ? (size_t)(note - msg) : len);
    record_failure(ev, piece, index, c->t, c->levels, c->nlevels, "");   /* "LABEL  at t = .." in the registry */
    lua_rawgetp(L, LUA_REGISTRYINDEX, ev);
    const char *outer = lua_tostring(L, -1);
    lua_pushfstring(L, "%s%s%d deep; the outermost call: %s)", lua_tostring(L, -2), NESTED_NOTE, depth,
                    outer ? outer : "");
    lua_rawsetp(L, LUA_REGISTRYINDEX, ev);
    lua_pop(L, 2);
    ev->passthrough = 1;
    return;
  }
  const char *msg = error_text(L, -1);
  error_hint(L, ev, msg);   /* pushes the hint, "" when none */
  lua_pushfstring(L, "%s: %s%s", doing, strip_location(ev, msg), lua_tostring(L, -1));
  lua_remove(L, -2);
  record_failure(ev, piece, index, c->t, c->levels, c->nlevels, lua_tostring(L, -1));
}

static int lua_eval(void *vctx, nz_piece piece, int index, const nz_jet *t,
                    nz_jet *const *const *levels, int nlevels, nz_jet *const *out,
                    const nz_direction *dir)
{
  lua_evaluator *ev = vctx;
  lua_State *L = ev->L;
  int top = lua_gettop(L), status = NZ_OK;
  int nout = piece == NZ_PIECE_Q ? ev->k : 1;
  const char *why = NULL;
  for (int o = 0; o < nout; o++) {
    nz_jet_init(out[o], out[o]->order, out[o]->ntan);
    if (dir) nz_jet_init(dir->dout[o], out[o]->order, out[o]->ntan);
  }
  if (!lua_checkstack(L, 2 * nlevels + 16)) return NZ_ENOMEM;   /* never raise here */
  eval_call call = { ev, t, levels, nlevels, dir };
  lua_pushcfunction(L, user_error_handler);
  lua_pushcfunction(L, build_arguments);
  lua_pushlightuserdata(L, &call);
  lua_pushvalue(L, ev->def);
  if (lua_pcall(L, 2, LUA_MULTRET, top + 1) != LUA_OK) {
    note_error(ev, &call, piece, index + 1, "could not build the arguments");
    lua_settop(L, top);
    return NZ_EFUNC;
  }
  int handler = top + 1, argbase = top + 2;
  int nargs = nlevels + 2;

  lua_getfield(L, ev->def, piece_fields[piece]);
  int list = lua_gettop(L);
  lua_Integer first = 1, nf = luaL_len(L, list);
  if (piece == NZ_PIECE_PHI) first = nf = index + 1;    /* one constraint */
  for (lua_Integer f = first; f <= nf && status == NZ_OK; f++) {
    lua_geti(L, list, f);
    for (int a = 0; a < nargs; a++) lua_pushvalue(L, argbase + a);
    if (lua_pcall(L, nargs, 1, handler) != LUA_OK) {
      note_error(ev, &call, piece, (int)f, "raised an error");
      status = NZ_EFUNC;
      break;
    }
    int res = lua_gettop(L);
    if (piece == NZ_PIECE_Q) {
      if (!lua_istable(L, res)) {
        why = "must return a table of forces, one per coordinate";
      } else if (luaL_len(L, res) != ev->k) {
        lua_pushfstring(L, "returned %d forces for %d coordinates", (int)luaL_len(L, res), ev->k);
        why = lua_tostring(L, -1);
      } else {
        for (int o = 0; o < nout && !why; o++) {
          lua_geti(L, res, o + 1);
          accumulate_result(L, lua_gettop(L), out[o], dir ? dir->dout[o] : NULL, &why);
          lua_pop(L, 1);
        }
      }
    } else {
      accumulate_result(L, res, out[0], dir ? dir->dout[0] : NULL, &why);
    }
    if (why) {
      lua_geti(L, list, f);
      definition_location(L, lua_gettop(L), ev->where, sizeof ev->where);
      record_failure(ev, piece, (int)f, t, levels, nlevels, why);
      status = NZ_EFUNC;
    }
    lua_settop(L, list);
  }
  lua_settop(L, top);
  return status;
}

/* The evaluator of a system with a recording: a compiled piece runs on its
 * graph in C; a piece that is not compiled, or whose graph fails at this
 * state (a domain error, say), runs in Lua, which then either gives the
 * value or raises the error with the user's function and line. */
static int hybrid_eval(void *vctx, nz_piece piece, int index, const nz_jet *t,
                       nz_jet *const *const *levels, int nlevels, nz_jet *const *out,
                       const nz_direction *dir)
{
  bound_system *b = vctx;
  if (nz_recording_has(b->comp, piece, index) &&
      nz_recording_eval(b->comp, piece, index, t, levels, nlevels, out, dir) == NZ_OK)
    return NZ_OK;
  return lua_eval(&b->ev, piece, index, t, levels, nlevels, out, dir);
}

/* ------------------------------------------------------------------ */
/* The system's evaluator                                               */

/* What a system is to the mechanics, made once per definition table and
 * kept in it (def.evaluator, a userdata the collector frees with the
 * table): the pieces it has, the slots of its constraints, its recording
 * and the hooks on it.  A call binds it to the Lua state and the stack slot
 * of def (nz_lua_bind_system: a bound_system on the C stack), so that a user
 * function that calls the mechanics again (a force that asks for sys:accel)
 * gets a frame of its own while sharing the object. */
typedef struct system_object {
  const void *def;            /* the table it was made for (a copy is another system) */
  nz_system sys;              /* ev is set at binding */
  struct nz_recording *comp;  /* def.recording, kept alive by def */
  const void *comp_box;       /* def.recording's userdata, kept alive by the object's user value */
  int np;                     /* parameters of the recording */
  int absent;                 /* names of params its functions read while absent */
} system_object;

static const char *const SYSTEM_OBJECT = "nz.evaluator";
/* The registry's copy of the object's metatable under a light key: telling
 * an object from another userdata costs a pointer comparison per call
 * instead of a lookup by name (sys:accel of a small system: 5 % of it). */
static const char object_metatable_key = 0;

/* The recording at def.recording, if any, and its hooks. */
static void object_recording(lua_State *L, int def, system_object *o)
{
  if (lua_getfield(L, def, "recording") != LUA_TUSERDATA || !(o->comp = nz_lua_torecording(L, -1))) {
    lua_pop(L, 1);
    return;
  }
  o->comp_box = lua_touserdata(L, -1);
  lua_setiuservalue(L, -2, 1);   /* the object (below it) keeps the recording alive */
  o->np = nz_recording_nparams(o->comp);
  if (lua_getfield(L, def, "params_absent") == LUA_TTABLE) o->absent = (int)lua_rawlen(L, -1);
  lua_pop(L, 1);
  if (lua_getfield(L, def, "recorded_mass_bias") == LUA_TBOOLEAN && lua_toboolean(L, -1)) {
    o->sys.mass_bias = nz_recording_mass_bias;
    o->sys.accel = nz_recording_accel;
    o->sys.free_rhs = nz_recording_free_rhs;
    o->sys.native_ready = nz_recording_all_native;
    o->sys.series = nz_recording_series;
  }
  lua_pop(L, 1);
  o->sys.constraint_row = nz_recording_constraint_row;
  o->sys.mass_bias_ctx = o->comp;
}

/* Make def's evaluator object (left on the stack). */
static system_object *object_new(lua_State *L, int def)
{
  system_object *o = lua_newuserdatauv(L, sizeof *o, 1);
  memset(o, 0, sizeof *o);
  if (luaL_newmetatable(L, SYSTEM_OBJECT)) {
    lua_pushstring(L, SYSTEM_OBJECT);
    lua_setfield(L, -2, "__name");
  }
  lua_pushvalue(L, -1);
  lua_rawsetp(L, LUA_REGISTRYINDEX, &object_metatable_key);
  lua_setmetatable(L, -2);
  o->def = lua_topointer(L, def);
  lua_getfield(L, def, "k");
  o->sys.k = (int)lua_tointeger(L, -1);
  lua_pop(L, 1);
  if (o->sys.k < 1) luaL_error(L, "internal: system definition without coordinates");
  for (int p = 0; p < NZ_PIECE_COUNT; p++) {
    if (lua_getfield(L, def, piece_fields[p]) == LUA_TTABLE && luaL_len(L, -1) > 0) {
      o->sys.has |= 1u << p;
      if (p == NZ_PIECE_PHI) o->sys.nc = (int)luaL_len(L, -1);
    }
    lua_pop(L, 1);
  }
  /* The slots each constraint asks for (lua/nz/system.lua): an int array
   * {n, levels...} kept alive by def. */
  if (lua_getfield(L, def, "constraint_levels") == LUA_TUSERDATA) {
    const int *lv = lua_touserdata(L, -1);
    o->sys.nlevels = lv[0];
    o->sys.levels = lv + 1;
  }
  lua_pop(L, 1);
  object_recording(L, def, o);
  return o;
}

/* def's evaluator object: made at the first call, made again when def is a
 * copy of another definition or its recording changed (record.lua's
 * differential check makes a copy without it). */
static system_object *system_object_of(lua_State *L, int def)
{
  system_object *o = NULL;
  if (lua_getfield(L, def, "evaluator") == LUA_TUSERDATA && lua_getmetatable(L, -1)) {
    lua_rawgetp(L, LUA_REGISTRYINDEX, &object_metatable_key);
    if (lua_rawequal(L, -1, -2)) o = lua_touserdata(L, -3);
    lua_pop(L, 2);
  }
  lua_pop(L, 1);
  if (o && o->def == lua_topointer(L, def)) {
    /* the same recording: the very userdata the object keeps alive */
    int same = lua_getfield(L, def, "recording") == LUA_TUSERDATA ? lua_touserdata(L, -1) == o->comp_box && o->comp
                                                                   : o->comp == NULL;
    lua_pop(L, 1);
    if (same) return o;
  }
  o = object_new(L, def);
  lua_setfield(L, def, "evaluator");
  return o;
}

/* A parameter declared as a number (a named number of params when the
 * system was made) must still be a finite number: the value at the top of
 * the stack, its name below it.  Raises, naming it, for NaN, an infinity,
 * nil or anything else (a numeric string too: T and V would do arithmetic
 * on it), so that `sys.params.g = 0/0` is said here, at the user's line,
 * and not met later as a NaN deep inside V. */
static void check_param(lua_State *L, int def)
{
  double v = lua_tonumber(L, -1);
  if (lua_type(L, -1) == LUA_TNUMBER && isfinite(v)) return;
  const char *name = lua_tostring(L, -2), *sys = nz_lua_system_name(L, def);
  if (lua_type(L, -1) == LUA_TNUMBER)
    nz_lua_error(L, "system '%s': params.%s is %s%s: set sys.params.%s to a finite number (every function of the "
                 "system reads it as one)", sys, name, isnan(v) ? "NaN" : v > 0 ? "inf" : "-inf",
                 isnan(v) ? " (a NaN comes from an earlier computation, such as 0/0 or inf - inf)" : "", name);
  const char *what = lua_isnil(L, -1) ? "nil (removed, or never set again)"
                   : lua_type(L, -1) == LUA_TSTRING ? lua_pushfstring(L, "the string \"%s\"", lua_tostring(L, -1))
                   : lua_pushfstring(L, "a %s", luaL_typename(L, -1));
  nz_lua_error(L, "system '%s': params.%s is %s, and it was a number when the system was made (its functions "
               "read it as one): set sys.params.%s to a finite number", sys, name, what, name);
}

/* Every parameter declared as a number (def.param_names, lua/nz/system.lua)
 * is still one: checked once per call of the mechanics (each binding binds
 * once; a run once per chunk of steps), not per evaluation. */
static void check_params(lua_State *L, int def)
{
  if (lua_getfield(L, def, "param_names") != LUA_TTABLE || lua_rawlen(L, -1) == 0) {
    lua_pop(L, 1);
    return;
  }
  lua_getfield(L, def, "params");
  lua_Integer n = (lua_Integer)lua_rawlen(L, -2);
  for (lua_Integer p = 1; p <= n && lua_istable(L, -1); p++) {
    lua_rawgeti(L, -2, p);
    lua_pushvalue(L, -1);
    lua_gettable(L, -3);
    check_param(L, def);
    lua_pop(L, 2);
  }
  lua_pop(L, 2);
}

/* The recording's parameters take their current values from def.params
 * (def.recording_params lists their names in input order), each checked. */
static void read_params(lua_State *L, int def, struct nz_recording *comp, int np)
{
  double *pv = nz_recording_params(comp);
  lua_getfield(L, def, "recording_params");
  lua_getfield(L, def, "params");
  for (int p = 0; p < np; p++) {
    lua_geti(L, -2, p + 1);
    lua_pushvalue(L, -1);
    lua_gettable(L, -3);
    check_param(L, def);
    pv[p] = lua_tonumber(L, -1);
    lua_pop(L, 2);
  }
  lua_pop(L, 2);
}

/* Is one of the names the recorded functions read while it was absent from
 * params (def.params_absent: `p.c or 1`) there now?  Then the recording
 * would miss it: lua/nz/model/record.lua records again. */
static int params_added(lua_State *L, int def)
{
  int added = 0;
  lua_getfield(L, def, "params_absent");
  lua_getfield(L, def, "params");
  lua_Integer n = lua_istable(L, -2) && lua_istable(L, -1) ? (lua_Integer)lua_rawlen(L, -2) : 0;
  for (lua_Integer i = 1; i <= n && !added; i++) {
    lua_rawgeti(L, -2, i);
    added = lua_gettable(L, -2) != LUA_TNIL;
    lua_pop(L, 1);
  }
  lua_pop(L, 2);
  return added;
}

void nz_lua_bind_system(lua_State *L, int def, bound_system *b)
{
  luaL_checktype(L, def, LUA_TTABLE);
  def = lua_absindex(L, def);
  system_object *o = system_object_of(L, def);
  if (o->absent && params_added(L, def)) {
    lua_getfield(L, def, "record_again");
    lua_pushvalue(L, def);
    lua_call(L, 1, 0);
    o = system_object_of(L, def);
  }
  b->sys = o->sys;
  b->comp = o->comp;
  b->ev.L = L;
  b->ev.def = def;
  b->ev.k = o->sys.k;
  b->ev.where[0] = '\0';
  b->ev.interrupted = 0;
  b->ev.passthrough = 0;
  /* The recorded parameters are the declared ones (both: the named numbers
   * of params when the system was made), checked as they are read. */
  if (!b->comp || o->np == 0) check_params(L, def);
  if (b->comp) {
    if (o->np > 0) read_params(L, def, b->comp, o->np);
    b->sys.ev.eval = hybrid_eval;
    b->sys.ev.ctx = b;
  } else {
    b->sys.ev.eval = lua_eval;
    b->sys.ev.ctx = &b->ev;
  }
}

/* Raise the error of a failed core call, with the system's name; a failed
 * user function's error starts with the user's file:line. */
int nz_lua_raise_core(lua_State *L, bound_system *b, int st, const char *fname)
{
  const char *name = nz_lua_system_name(L, b->ev.def);
  if (b->ev.interrupted) return nz_lua_raise_interrupt(L);
  if (st == NZ_EFUNC) {
    lua_rawgetp(L, LUA_REGISTRYINDEX, &b->ev);
    lua_pushnil(L);
    lua_rawsetp(L, LUA_REGISTRYINDEX, &b->ev);
    if (b->ev.passthrough && lua_type(L, -1) == LUA_TSTRING) {   /* a nested call's error, with its note */
      lua_pushvalue(L, -1);
      lua_rawsetp(L, LUA_REGISTRYINDEX, &engine_error_key);
      return lua_error(L);
    }
    const char *msg = lua_tostring(L, -1);
    /* where the function failed when it is the user's; else the user's call */
    char where[512];
    if (b->ev.where[0]) snprintf(where, sizeof where, "%s", b->ev.where);
    else nz_lua_user_location(L, 0, where, sizeof where);
    lua_pushfstring(L, "%s%ssystem '%s': %s", where, where[0] ? " " : "", name, msg ? msg : "a function failed");
    /* remembered: a user function that lets it through is seen to (note_error) */
    lua_pushvalue(L, -1);
    lua_rawsetp(L, LUA_REGISTRYINDEX, &engine_error_key);
    return lua_error(L);
  }
  if (st == NZ_ENOMEM) return nz_lua_error(L, "system '%s': not enough memory in '%s'", name, fname);
  return nz_lua_error(L, "system '%s': '%s' failed (status %d)", name, fname, st);
}

/* Arguments (def, ..., t, q, qd, qdd, higher) from `at` on: the state levels. */
typedef struct state_buf {
  double *data;
  const double *levels[NZ_MAX_LEVELS];
  int n;
} state_buf;

static void read_state(lua_State *L, int at, int k, state_buf *s, const char *fname)
{
  int extra = 0;
  if (lua_istable(L, at + 3)) extra = (int)luaL_len(L, at + 3);
  if (extra > NZ_MAX_LEVELS - 3) nz_lua_error(L, "bad argument to '%s' (too many higher derivatives)", fname);
  s->n = 3 + extra;
  s->data = lua_newuserdatauv(L, (size_t)s->n * (size_t)k * sizeof(double), 0);
  static const char *const names[] = { "q", "qd", "qdd" };
  for (int j = 0; j < 3; j++) {
    s->levels[j] = s->data + (size_t)j * (size_t)k;
    nz_lua_read_vector(L, at + j, k, (double *)s->levels[j], names[j], j == 2, fname);
  }
  for (int j = 0; j < extra; j++) {
    lua_geti(L, at + 3, j + 1);
    s->levels[3 + j] = s->data + (size_t)(3 + j) * (size_t)k;
    nz_lua_read_vector(L, lua_gettop(L), k, (double *)s->levels[3 + j], "higher derivative", 0, fname);
    lua_pop(L, 1);
  }
}

static int check_order(lua_State *L, int idx, int lo, const char *fname)
{
  lua_Integer n = luaL_checkinteger(L, idx);
  if (n < lo || n > NZ_MAX_EQ_ORDER)
    return (int)nz_lua_error(L, "bad argument #1 to '%s' (order between %d and %d expected, got %I)",
                           fname, lo, NZ_MAX_EQ_ORDER, (lua_Integer)n);
  return (int)n;
}

/* ------------------------------------------------------------------ */
/* Core functions                                                       */

double *nz_lua_bind_tq_qd(lua_State *L, int nargs, bound_system *b, int nvec, int nmat, double *t,
                          const char *fname)
{
  lua_settop(L, nargs);   /* optional arguments read as nil, scratch above */
  nz_lua_bind_system(L, 1, b);
  size_t k = (size_t)b->sys.k;
  double *buf = lua_newuserdatauv(L, ((2 + (size_t)nvec) * k + (size_t)nmat * k * k) * sizeof(double), 0);
  nz_lua_read_tq_qd(L, b->sys.k, t, buf, buf + k, fname);
  return buf;
}

/* residual(def, form, n, t, q, qd, qdd, higher, want_terms) -> r [, terms] */
static int ls_residual(lua_State *L)
{
  lua_settop(L, 9);   /* optional arguments read as nil, scratch above */
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  int form = luaL_checkoption(L, 2, NULL, nz_form_names);
  int n = check_order(L, 3, 1, "residual");
  double t = luaL_checknumber(L, 4);
  int k = b.sys.k, want_terms = lua_toboolean(L, 9);
  state_buf s;
  read_state(L, 5, k, &s, "residual");
  double *buf = lua_newuserdatauv(L, 4 * (size_t)k * sizeof(double), 0);
  nz_terms terms = { buf + k, buf + 2 * k, buf + 3 * k };
  if (form == NZ_FORM_WASSMUTH && n < 2)
    return nz_lua_error(L, "system '%s': Wassmuth's form needs n >= 2 (got %d)", nz_lua_system_name(L, 1), n);
  if (form == NZ_FORM_WASSMUTH && !nz_system_has(&b.sys, NZ_PIECE_S))
    return nz_lua_error(L, "system '%s': Wassmuth's form needs the acceleration energy S: build "
                      "the system from particles (bodies = {...}) or give S", nz_lua_system_name(L, 1));
  int st = nz_residual(&b.sys, form, n, t, s.levels, s.n, buf, want_terms ? &terms : NULL);
  if (st) return nz_lua_raise_core(L, &b, st, "residual");
  nz_lua_push_vector(L, buf, k);
  if (!want_terms) return 1;
  lua_createtable(L, 0, 3);
  nz_lua_push_vector(L, terms.dFn, k);
  lua_setfield(L, -2, "dFn");
  nz_lua_push_vector(L, terms.dFq, k);
  lua_setfield(L, -2, "dFq");
  nz_lua_push_vector(L, terms.force, k);
  lua_setfield(L, -2, "force");
  return 2;
}

/* operator(def, which, m, t, q, qd, qdd, higher) with which in N, E, top,
 * partial (the last accepts m = 0) */
static int ls_operator(lua_State *L)
{
  lua_settop(L, 8);   /* optional arguments read as nil, scratch above */
  static const char *const which_names[] = { "N", "E", "top", "partial", NULL };
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  int which = luaL_checkoption(L, 2, NULL, which_names);
  int m = check_order(L, 3, which == 3 ? 0 : 1, "operator");
  double t = luaL_checknumber(L, 4);
  int k = b.sys.k;
  state_buf s;
  read_state(L, 5, k, &s, "operator");
  double *out = lua_newuserdatauv(L, (size_t)k * sizeof(double), 0);
  int st = which == 0 ? nz_operator_N(&b.sys, m, t, s.levels, s.n, out)
         : which == 1 ? nz_operator_E(&b.sys, m, t, s.levels, s.n, out)
         : which == 2 ? nz_top_coefficient(&b.sys, m, t, s.levels, s.n, out)
                      : nz_partial(&b.sys, m, t, s.levels, s.n, out);
  if (st) return nz_lua_raise_core(L, &b, st, "operator");
  nz_lua_push_vector(L, out, k);
  return 1;
}

/* mass_bias(def, t, q, qd) -> M, h */
static int ls_mass_bias(lua_State *L)
{
  bound_system b;
  double t, *q = nz_lua_bind_tq_qd(L, 4, &b, 1, 1, &t, "mass");
  int k = b.sys.k;
  double *qd = q + k, *h = q + 2 * k, *M = q + 3 * k;
  int st = nz_mass_bias(&b.sys, t, q, qd, M, h);
  if (st) return nz_lua_raise_core(L, &b, st, "mass");
  nz_lua_push_matrix(L, M, k);
  nz_lua_push_vector(L, h, k);
  return 2;
}

/* Solve M qdd = -h into qdd and push it (out > 0: into the table at that
 * stack index, pushed again), or raise (accel and accel_try). */
static int push_accel(lua_State *L, bound_system *b, double t, const double *q, const double *qd,
                      double rcond_min, double *qdd, int out)
{
  nz_solve_info info;
  int st = nz_accel(&b->sys, t, q, qd, rcond_min, qdd, &info);
  if (st == NZ_ESINGULAR) return nz_lua_raise_singular_mass(L, 1, t, q, qd, b->sys.k, &info);
  if (st) return nz_lua_raise_core(L, b, st, "accel");
  if (out > 0) {
    for (int i = 0; i < b->sys.k; i++) {
      lua_pushnumber(L, qdd[i]);
      lua_rawseti(L, out, i + 1);
    }
    lua_pushvalue(L, out);
  } else nz_lua_push_vector(L, qdd, b->sys.k);
  return 1;
}

/* accel(def, t, q, qd [, rcond_min]) -> qdd: solves M qdd = -h by Cholesky. */
static int ls_accel(lua_State *L)
{
  bound_system b;
  double t, *q = nz_lua_bind_tq_qd(L, 5, &b, 1, 0, &t, "accel");
  int k = b.sys.k;
  return push_accel(L, &b, t, q, q + k, luaL_optnumber(L, 5, NZ_RCOND_MIN), q + 2 * k, 0);
}

/* The output table of sys:accel's options at stack index opts: 0 for no
 * options, the stack index of opts.out (pushed) when opts is {out = a
 * plain table} and nothing else, -1 for anything else (the checks in Lua
 * say what is wrong with it). */
static int accel_out(lua_State *L, int opts)
{
  if (lua_isnoneornil(L, opts)) return 0;
  if (lua_type(L, opts) != LUA_TTABLE || lua_getmetatable(L, opts)) return -1;
  lua_pushnil(L);
  int keys = 0;
  while (keys < 2 && lua_next(L, opts)) {
    keys++;
    lua_pop(L, 1);
  }
  if (keys == 2) lua_pop(L, 1);   /* the key lua_next left */
  if (keys != 1 || lua_getfield(L, opts, "out") != LUA_TTABLE || lua_getmetatable(L, -1)) return -1;
  return lua_gettop(L);
}

/* accel_try(def, t, q, qd [, opts]) -> qdd, or nil when t, q, qd or opts
 * is not what accel reads (sys:accel then checks them in Lua and says what
 * is wrong): the fast path of sys:accel, whose checks in Lua cost more than
 * the accelerations of a small system (1.5 us of 3 for the 8-link
 * pendulum).  With opts = {out = table}, qdd is written into that table
 * (entries 1 .. k), which is returned: a loop that passes the same options
 * again makes no table per call. */
static int ls_accel_try(lua_State *L)
{
  bound_system b;
  double small[3 * 32], *q = small;
  lua_settop(L, 5);
  int out = accel_out(L, 5);
  nz_lua_bind_system(L, 1, &b);
  int k = b.sys.k;
  if (k > 32) q = lua_newuserdatauv(L, 3 * (size_t)k * sizeof(double), 0);
  double *qd = q + k, *qdd = qd + k, t = lua_tonumber(L, 2);
  if (out < 0 || lua_type(L, 2) != LUA_TNUMBER || !isfinite(t) || !nz_lua_try_vector(L, 3, k, q) ||
      !nz_lua_try_vector(L, 4, k, qd)) {
    lua_pushnil(L);
    return 1;
  }
  return push_accel(L, &b, t, q, qd, NZ_RCOND_MIN, qdd, out);
}

/* energy(def, t, q, qd) -> T (nil without T), V, F, H */
static int ls_energy(lua_State *L)
{
  bound_system b;
  double t, T, V, F, H, *buf = nz_lua_bind_tq_qd(L, 4, &b, 0, 0, &t, "energy");
  int k = b.sys.k;
  int st = nz_energy(&b.sys, t, buf, buf + k, &T, &V, &F, &H);
  if (st) return nz_lua_raise_core(L, &b, st, "energy");
  if (isnan(T)) lua_pushnil(L);
  else lua_pushnumber(L, T);
  lua_pushnumber(L, V);
  lua_pushnumber(L, F);
  lua_pushnumber(L, H);
  return 4;
}

/* energy_terms(def, t, q, qd, qdd) -> dL/dt, T0, T1, d/dt(T1 + 2 T0) */
static int ls_energy_terms(lua_State *L)
{
  bound_system b;
  double t, dLdt, T0, T1, rate, *buf = nz_lua_bind_tq_qd(L, 5, &b, 1, 0, &t, "energy_terms");
  int k = b.sys.k;
  nz_lua_read_vector(L, 5, k, buf + 2 * k, "qdd", 1, "energy_terms");
  int st = nz_lagrangian_time_partial(&b.sys, t, buf, buf + k, &dLdt);
  if (!st) st = nz_kinetic_parts(&b.sys, t, buf, buf + k, buf + 2 * k, &T0, &T1, &rate);
  if (st) return nz_lua_raise_core(L, &b, st, "energy_terms");
  lua_pushnumber(L, dLdt);
  lua_pushnumber(L, T0);
  lua_pushnumber(L, T1);
  lua_pushnumber(L, rate);
  return 4;
}

/* piece(def, name, index, t, levels [, dt, dlevels]) -> outs [, douts]:
 * one evaluation of a piece ("F", "T", "V", "Q", "S", "constraints";
 * index 1-based) on jets, through the system's evaluator (its graph, or
 * Lua), optionally along a state direction.  For tests that compare the
 * two evaluators (tests/graph_diff_spec.lua).  levels: a list of lists of
 * k jets; outputs have the lowest order and the most tangents of the
 * arguments. */
static const char *const piece_options[] = { "F", "T", "V", "Q", "S", "constraints", NULL };

static void read_jet_levels(lua_State *L, int idx, int k, int nlev, nz_jet ***store)
{
  for (int j = 0; j < nlev; j++) {
    if (lua_geti(L, idx, j + 1) != LUA_TTABLE) luaL_error(L, "piece: level %d must be a list of jets", j + 1);
    for (int i = 0; i < k; i++) {
      lua_geti(L, -1, i + 1);
      store[j][i] = nz_lua_checkjet(L, -1);
      lua_pop(L, 1);     /* the level table keeps it alive */
    }
    lua_pop(L, 1);       /* the levels table keeps the level alive */
  }
}

static int ls_piece(lua_State *L)
{
  lua_settop(L, 7);
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  int k = b.sys.k;
  nz_piece piece = (nz_piece)luaL_checkoption(L, 2, NULL, piece_options);
  int index = (int)luaL_checkinteger(L, 3) - 1;
  nz_jet *t = nz_lua_checkjet(L, 4);
  luaL_checktype(L, 5, LUA_TTABLE);
  int nlev = (int)luaL_len(L, 5), with_dir = !lua_isnil(L, 6);
  if (nlev < 1 || nlev > NZ_MAX_LEVELS) return luaL_error(L, "piece: 1 to %d levels expected", NZ_MAX_LEVELS);
  nz_jet ***lv = lua_newuserdatauv(L, 2 * (size_t)nlev * sizeof(nz_jet **), 0);
  nz_jet **cells = lua_newuserdatauv(L, 2 * (size_t)nlev * (size_t)k * sizeof(nz_jet *), 0);
  for (int j = 0; j < 2 * nlev; j++) lv[j] = cells + (size_t)j * (size_t)k;
  read_jet_levels(L, 5, k, nlev, lv);
  int order = t->order, ntan = t->ntan;
  for (int j = 0; j < nlev; j++)
    for (int i = 0; i < k; i++) {
      if (lv[j][i]->order < order) order = lv[j][i]->order;
      if (lv[j][i]->ntan > ntan) ntan = lv[j][i]->ntan;
    }
  nz_direction dir = { 0 };
  if (with_dir) {
    dir.dt = nz_lua_checkjet(L, 6);
    luaL_checktype(L, 7, LUA_TTABLE);
    if ((int)luaL_len(L, 7) != nlev) return luaL_error(L, "piece: dlevels must have as many levels as levels");
    read_jet_levels(L, 7, k, nlev, lv + nlev);
  }
  int nout = piece == NZ_PIECE_Q ? k : 1;
  lua_createtable(L, nout, 0);
  int outs = lua_gettop(L);
  lua_createtable(L, nout, 0);
  int douts = lua_gettop(L);
  nz_jet **o = lua_newuserdatauv(L, 2 * (size_t)nout * sizeof(nz_jet *), 0);
  for (int r = 0; r < nout; r++) {
    o[r] = nz_lua_newjet(L, order, ntan);
    lua_rawseti(L, outs, r + 1);
    o[nout + r] = nz_lua_newjet(L, order, ntan);
    lua_rawseti(L, douts, r + 1);
  }
  dir.dout = o + nout;
  dir.dlevels = (nz_jet *const *const *)(lv + nlev);
  int st = b.sys.ev.eval(b.sys.ev.ctx, piece, index, t, (nz_jet *const *const *)lv, nlev, o,
                         with_dir ? &dir : NULL);
  if (st) return nz_lua_raise_core(L, &b, st, "piece");
  lua_pushvalue(L, outs);
  if (!with_dir) return 1;
  lua_pushvalue(L, douts);
  return 2;
}

/* jet:derivative() lives with the jets; the forms' names are data. */
static int ls_forms(lua_State *L)
{
  lua_createtable(L, NZ_FORM_COUNT, 0);
  for (int f = 0; f < NZ_FORM_COUNT; f++) {
    lua_pushstring(L, nz_form_names[f]);
    lua_rawseti(L, -2, f + 1);
  }
  return 1;
}

static const luaL_Reg system_functions[] = {
  { "residual", ls_residual }, { "operator", ls_operator }, { "mass_bias", ls_mass_bias },
  { "accel", ls_accel }, { "accel_try", ls_accel_try }, { "energy", ls_energy }, { "forms", ls_forms },
  { "energy_terms", ls_energy_terms }, { "piece", ls_piece }, { "argument_hook", ls_argument_hook },
  { NULL, NULL }
};

/* Add the functions to the table on top of the stack (core.mech, made by
 * lua_nz.c, the only registrar). */
void nz_lua_open_system(lua_State *L)
{
  luaL_setfuncs(L, system_functions, 0);
  lua_pushinteger(L, NZ_MAX_EQ_ORDER);
  lua_setfield(L, -2, "max_order");
  lua_pushnumber(L, NZ_RCOND_MIN);
  lua_setfield(L, -2, "rcond_min");
}
