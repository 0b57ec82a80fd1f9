/* lua_graph.c - recording a system's functions into a graph, for Lua.
 *
 * lua/nz/model/record.lua runs the user's functions on tracer values; every
 * operation on a tracer calls one of the methods below, which add a node
 * (folded and shared: graph.h) and return its id; cmp and select record the
 * branch functions (nz.gt, nz.ifelse, nz.max, ...).  The userdata owns the
 * nz_recording (mech_graph.h) and frees it with the collector. */
#include <lauxlib.h>
#include <string.h>
#include "lua/lua_graph.h"
#include "lua/lua_jet.h"

typedef struct recording_box { nz_recording *c; } recording_box;

nz_recording *nz_lua_torecording(lua_State *L, int idx)
{
  recording_box *b = luaL_testudata(L, idx, NZ_RECORDING_METATABLE);
  return b ? b->c : NULL;
}

static nz_recording *check(lua_State *L)
{
  recording_box *b = luaL_checkudata(L, 1, NZ_RECORDING_METATABLE);
  if (!b->c) luaL_error(L, "internal: a freed recording");
  return b->c;
}

/* A node id from Lua: a node of this graph, else an error. */
static int check_node(lua_State *L, nz_graph *g, int idx)
{
  lua_Integer id = luaL_checkinteger(L, idx);
  if (id < 0 || id >= nz_graph_size(g)) luaL_error(L, "internal: node %d is not in the graph", (int)id);
  return (int)id;
}

static int push_node(lua_State *L, int id)
{
  if (id < 0) return luaL_error(L, "not enough memory to record the graph");
  lua_pushinteger(L, id);
  return 1;
}

/* recording_new(k, np, nc, nslots) */
static int lg_new(lua_State *L)
{
  int k = (int)luaL_checkinteger(L, 1), np = (int)luaL_checkinteger(L, 2);
  int nc = (int)luaL_checkinteger(L, 3), nslots = (int)luaL_checkinteger(L, 4);
  recording_box *b = lua_newuserdatauv(L, sizeof *b, 0);
  b->c = NULL;
  luaL_setmetatable(L, NZ_RECORDING_METATABLE);
  if (!(b->c = nz_recording_new(k, np, nc, nslots))) return luaL_error(L, "not enough memory to record the graph");
  return 1;
}

/* tracer(mt): a new empty userdata with metatable mt.  The recorder's
 * tracers are userdata so that type(x) answers "userdata" for them as for
 * the jets the Lua evaluator passes (lua/nz/model/record.lua keeps their nodes). */
static int lg_tracer(lua_State *L)
{
  luaL_checktype(L, 1, LUA_TTABLE);
  lua_newuserdatauv(L, 0, 0);
  lua_pushvalue(L, 1);
  lua_setmetatable(L, -2);
  return 1;
}

static int lg_gc(lua_State *L)
{
  recording_box *b = luaL_checkudata(L, 1, NZ_RECORDING_METATABLE);
  nz_recording_free(b->c);
  b->c = NULL;
  return 0;
}

static int lg_const(lua_State *L)
{
  nz_recording *c = check(L);
  return push_node(L, nz_graph_const(nz_recording_graph(c), luaL_checknumber(L, 2)));
}

/* slot(j, i): slot j (0 = q, 0 <= j < nslots) of coordinate i (1-based);
 * frozen(i): the frozen velocity of coordinate i (mech_graph.h); time(): t;
 * param(p): parameter p (1-based).  Only the layout's inputs: a graph
 * whose inputs outgrow it would be read past the arrays the mechanics
 * sizes by the layout. */
static int lg_slot(lua_State *L)
{
  nz_recording *c = check(L);
  int j = (int)luaL_checkinteger(L, 2), i = (int)luaL_checkinteger(L, 3);
  luaL_argcheck(L, j >= 0 && j < nz_recording_nslots(c), 2, "no such slot in the recording");
  luaL_argcheck(L, i >= 1 && i <= nz_recording_ncoords(c), 3, "no such coordinate");
  return push_node(L, nz_graph_input(nz_recording_graph(c), nz_recording_input_slot(c, j, i - 1)));
}

static int lg_frozen(lua_State *L)
{
  nz_recording *c = check(L);
  int i = (int)luaL_checkinteger(L, 2);
  luaL_argcheck(L, i >= 1 && i <= nz_recording_ncoords(c), 2, "no such coordinate");
  return push_node(L, nz_graph_input(nz_recording_graph(c), nz_recording_input_frozen(c, i - 1)));
}

/* nslots() -> the derivative slots of the layout (mech_graph.h) */
static int lg_nslots(lua_State *L)
{
  lua_pushinteger(L, nz_recording_nslots(check(L)));
  return 1;
}

static int lg_time(lua_State *L)
{
  return push_node(L, nz_graph_input(nz_recording_graph(check(L)), 0));
}

static int lg_param(lua_State *L)
{
  nz_recording *c = check(L);
  int p = (int)luaL_checkinteger(L, 2);
  luaL_argcheck(L, p >= 1 && p <= nz_recording_nparams(c), 2, "no such parameter");
  return push_node(L, nz_graph_input(nz_recording_graph(c), nz_recording_input_param(p - 1)));
}

static const char *const op_names[] = { "add", "sub", "mul", "div", "neg", "pow", "atan2", "hypot", NULL };
static const nz_gop op_codes[] = { NZ_GOP_ADD, NZ_GOP_SUB, NZ_GOP_MUL, NZ_GOP_DIV, NZ_GOP_NEG,
                                   NZ_GOP_POW, NZ_GOP_ATAN2, NZ_GOP_HYPOT };

/* op(name, a [, b]) */
static int lg_op(lua_State *L)
{
  nz_recording *c = check(L);
  nz_graph *g = nz_recording_graph(c);
  nz_gop op = op_codes[luaL_checkoption(L, 2, NULL, op_names)];
  int a = check_node(L, g, 3), b = op == NZ_GOP_NEG ? -1 : check_node(L, g, 4);
  return push_node(L, nz_graph_op(g, op, a, b));
}

/* fn(name, a): name one of the jets' unary functions (nz_jet_fn_names). */
static int lg_fn(lua_State *L)
{
  nz_recording *c = check(L);
  nz_graph *g = nz_recording_graph(c);
  const char *name = luaL_checkstring(L, 2);
  int a = check_node(L, g, 3);
  for (int f = 0; f < NZ_FN_COUNT; f++)
    if (strcmp(name, nz_jet_fn_names[f]) == 0) return push_node(L, nz_graph_fn(g, (nz_jet_fn)f, a));
  return luaL_error(L, "internal: no function '%s' in the graph", name);
}

/* cmp(kind, a, b): 1 where a kind b holds, else 0; kind lt le gt ge eq ne. */
static const char *const cmp_names[] = { "lt", "le", "gt", "ge", "eq", "ne", NULL };
static const nz_cmp cmp_codes[] = { NZ_CMP_LT, NZ_CMP_LE, NZ_CMP_GT, NZ_CMP_GE, NZ_CMP_EQ, NZ_CMP_NE };

static int lg_cmp(lua_State *L)
{
  nz_recording *c = check(L);
  nz_graph *g = nz_recording_graph(c);
  nz_cmp op = cmp_codes[luaL_checkoption(L, 2, NULL, cmp_names)];
  int a = check_node(L, g, 3), b = check_node(L, g, 4);
  return push_node(L, nz_graph_cmp(g, op, a, b));
}

/* select(c, a, b): a where c != 0, else b. */
static int lg_select(lua_State *L)
{
  nz_recording *c = check(L);
  nz_graph *g = nz_recording_graph(c);
  int cond = check_node(L, g, 2), a = check_node(L, g, 3), b = check_node(L, g, 4);
  return push_node(L, nz_graph_select(g, cond, a, b));
}

static int lg_powc(lua_State *L)
{
  nz_recording *c = check(L);
  nz_graph *g = nz_recording_graph(c);
  int a = check_node(L, g, 2);
  return push_node(L, nz_graph_powc(g, a, luaL_checknumber(L, 3)));
}

/* The constant value of a node, or nil. */
static int lg_constant(lua_State *L)
{
  nz_recording *c = check(L);
  nz_graph *g = nz_recording_graph(c);
  double v;
  if (nz_graph_is_const(g, check_node(L, g, 2), &v)) lua_pushnumber(L, v);
  else lua_pushnil(L);
  return 1;
}

static const char *const piece_names[] = { "F", "T", "V", "Q", "S", "constraints", NULL };

/* Read a list of node ids at idx into ids (at most n). */
static int read_nodes(lua_State *L, int idx, nz_graph *g, int *ids, int n)
{
  luaL_checktype(L, idx, LUA_TTABLE);
  int len = (int)luaL_len(L, idx);
  if (len > n) luaL_error(L, "internal: %d nodes given, at most %d", len, n);
  for (int o = 0; o < len; o++) {
    lua_geti(L, idx, o + 1);
    ids[o] = check_node(L, g, -1);
    lua_pop(L, 1);
  }
  return len;
}

/* set_piece(piece, index (1-based), {nodes}) */
static int lg_set_piece(lua_State *L)
{
  nz_recording *c = check(L);
  nz_graph *g = nz_recording_graph(c);
  nz_piece piece = (nz_piece)luaL_checkoption(L, 2, NULL, piece_names);
  int index = (int)luaL_checkinteger(L, 3) - 1;
  int n = (int)luaL_len(L, 4);
  int *ids = lua_newuserdatauv(L, (size_t)(n + 1) * sizeof(int), 0);
  n = read_nodes(L, 4, g, ids, n);
  int st = nz_recording_set_piece(c, piece, index, ids, n);
  if (st == NZ_ENOMEM) return luaL_error(L, "not enough memory to record the graph");
  if (st) return luaL_error(L, "internal: piece %s %d: wrong shape", piece_names[piece], index + 1);
  return 0;
}

/* info() -> {nodes = graph size, pieces = {F = n, ..., constraints = {..}}, mass_bias = n} */
static int lg_info(lua_State *L)
{
  nz_recording *c = check(L);
  lua_createtable(L, 0, 4);
  lua_pushinteger(L, nz_graph_size(nz_recording_graph(c)));
  lua_setfield(L, -2, "nodes");
  lua_pushinteger(L, nz_recording_mass_bias_nodes(c));
  lua_setfield(L, -2, "mass_bias_nodes");
  double secs;
  const char *why;
  lua_pushinteger(L, nz_recording_native(c, &secs, &why));
  lua_setfield(L, -2, "native_plans");
  lua_pushinteger(L, nz_recording_native_series(c));
  lua_setfield(L, -2, "native_series");
  lua_pushnumber(L, secs);
  lua_setfield(L, -2, "native_seconds");
  lua_pushnumber(L, nz_recording_native_waited(c));
  lua_setfield(L, -2, "native_waited");
  lua_pushinteger(L, nz_recording_native_compiling(c));
  lua_setfield(L, -2, "native_compiling");
  lua_pushinteger(L, nz_recording_native_mode(c));
  lua_setfield(L, -2, "native_mode");
  if (why) {
    lua_pushstring(L, why);
    lua_setfield(L, -2, "native_why");
  }
  return 1;
}

/* native_wait(): wait for the compiles under way (a Ctrl-C stops the wait). */
static int lg_native_wait(lua_State *L)
{
  nz_recording_native_wait(check(L));
  return 0;
}

/* ------------------------------------------------------------------ */
/* Reading the graph (lua/nz/base/formula.lua: sys:show and sys:export)      */

/* nodes([from]) -> {op = {...}, fn = {...}, a = {...}, b = {...}, v = {...},
 * c = {...}}: every node from `from` (0-based, default 0) on, by id + 1:
 * op and fn as names (fn: the function of FN, the comparison of CMP, else
 * false), a, b, c operand ids (-1 unused; a = the input number of INPUT),
 * v the constant (CONST) or the exponent (POWC). */
static int lg_nodes(lua_State *L)
{
  nz_recording *c = check(L);
  const nz_graph *g = nz_recording_graph(c);
  int n = nz_graph_size(g), from = (int)luaL_optinteger(L, 2, 0);
  const nz_gnode *nd = nz_graph_nodes(g);
  static const char *const fields[] = { "op", "fn", "a", "b", "v", "c" };
  lua_createtable(L, 0, 6);
  for (int f = 0; f < 6; f++) {
    lua_createtable(L, n > from ? n - from : 0, 0);
    for (int x = from; x < n; x++) {
      const nz_gnode *e = &nd[x];
      switch (f) {
      case 0: lua_pushstring(L, nz_gop_names[e->op]); break;
      case 1:
        if (e->op == NZ_GOP_FN) lua_pushstring(L, nz_jet_fn_names[e->fn]);
        else if (e->op == NZ_GOP_CMP) lua_pushstring(L, cmp_names[e->fn]);   /* in nz_cmp order */
        else lua_pushboolean(L, 0);
        break;
      case 2: lua_pushinteger(L, e->a); break;
      case 3: lua_pushinteger(L, e->b); break;
      case 4: lua_pushnumber(L, e->v); break;
      default: lua_pushinteger(L, e->c); break;
      }
      lua_rawseti(L, -2, x + 1);
    }
    lua_setfield(L, -2, fields[f]);
  }
  return 1;
}

/* A list of n node ids on the stack. */
static void push_ids(lua_State *L, const int *ids, int n)
{
  lua_createtable(L, n, 0);
  for (int i = 0; i < n; i++) {
    lua_pushinteger(L, ids[i]);
    lua_rawseti(L, -2, i + 1);
  }
}

/* mass_bias_outputs() -> {M (k k, row-major), h (k)} node ids, or nil when
 * M and h cannot be built from the recording */
static int lg_mass_bias_outputs(lua_State *L)
{
  nz_recording *c = check(L);
  int k = (int)luaL_checkinteger(L, 2);
  int *out = lua_newuserdatauv(L, ((size_t)k * (size_t)k + (size_t)k) * sizeof(int), 0);
  if (nz_recording_mass_bias_outputs(c, out)) { lua_pushnil(L); return 1; }
  push_ids(L, out, k * k + k);
  return 1;
}

/* piece_outputs(piece, index (1-based)) -> {node ids} (empty: not recorded) */
static int lg_piece_outputs(lua_State *L)
{
  nz_recording *c = check(L);
  nz_piece piece = (nz_piece)luaL_checkoption(L, 2, NULL, piece_names);
  int index = (int)luaL_optinteger(L, 3, 1) - 1;
  int n = nz_recording_piece_outputs(c, piece, index, NULL, 0);   /* how many: Q has k */
  int *out = lua_newuserdatauv(L, (size_t)(n > 0 ? n : 1) * sizeof(int), 0);
  nz_recording_piece_outputs(c, piece, index, out, n);
  push_ids(L, out, n);
  return 1;
}

/* derivative(root, {[input number] = node}) -> the node of d root along the
 * inputs' motion (inputs not listed do not move); builds nodes in the graph */
static int lg_derivative(lua_State *L)
{
  nz_recording *c = check(L);
  nz_graph *g = nz_recording_graph(c);
  int root = check_node(L, g, 2);
  luaL_checktype(L, 3, LUA_TTABLE);
  int n = nz_graph_ninputs(g);
  int *dir = lua_newuserdatauv(L, (size_t)(n > 0 ? n : 1) * sizeof(int), 0);
  for (int i = 0; i < n; i++) {
    lua_geti(L, 3, i);
    dir[i] = lua_isnil(L, -1) ? -1 : check_node(L, g, -1);
    lua_pop(L, 1);
  }
  return push_node(L, nz_graph_derivative(g, root, dir));
}

/* copy(src, {roots}, {[input number of src] = node}) -> {nodes}: the roots
 * of src's graph built again in this one, the inputs listed replaced by
 * the nodes given, the others by the inputs of the same number (src may
 * be this recording: a substitution).  The inputs of src must fit this
 * layout. */
static int lg_copy(lua_State *L)
{
  nz_recording *c = check(L);
  recording_box *b = luaL_checkudata(L, 2, NZ_RECORDING_METATABLE);
  if (!b->c) return luaL_error(L, "internal: a freed recording");
  nz_graph *g = nz_recording_graph(c), *src = nz_recording_graph(b->c);
  int n = (int)luaL_len(L, 3), ni = nz_graph_ninputs(src);
  luaL_checktype(L, 4, LUA_TTABLE);
  int *ids = lua_newuserdatauv(L, 2 * (size_t)(n + 1) * sizeof(int), 0), *out = ids + n + 1;
  n = read_nodes(L, 3, src, ids, n);
  int *map = lua_newuserdatauv(L, (size_t)(ni + 1) * sizeof(int), 0);
  for (int i = 0; i < ni; i++) {
    lua_geti(L, 4, i);
    map[i] = lua_isnil(L, -1) ? -1 : check_node(L, g, -1);
    lua_pop(L, 1);
  }
  /* unmapped inputs keep their numbers: within this layout */
  int layout = nz_recording_input_frozen(c, nz_recording_ncoords(c) - 1) + 1;
  for (int i = 0; i < ni; i++)
    if (map[i] < 0 && i >= layout) return luaL_error(L, "internal: input %d is outside the layout", i);
  if (nz_graph_copy(g, src, ids, n, map, out)) return luaL_error(L, "not enough memory to record the graph");
  push_ids(L, out, n);
  return 1;
}

/* piece_nodes(piece, index (1-based)) -> nodes its evaluation visits */
static int lg_piece_nodes(lua_State *L)
{
  nz_recording *c = check(L);
  nz_piece piece = (nz_piece)luaL_checkoption(L, 2, NULL, piece_names);
  lua_pushinteger(L, nz_recording_piece_nodes(c, piece, (int)luaL_optinteger(L, 3, 1) - 1));
  return 1;
}

/* eval({nodes}, {inputs by number, 0-based: [0] = t}) -> {values} or nil, message:
 * the doubles path, for checking a recording against the function. */
static int lg_eval(lua_State *L)
{
  nz_recording *c = check(L);
  nz_graph *g = nz_recording_graph(c);
  int n = (int)luaL_len(L, 2);
  int ni = nz_graph_ninputs(g);
  int *ids = lua_newuserdatauv(L, (size_t)(n + 1) * sizeof(int), 0);
  double *in = lua_newuserdatauv(L, (size_t)(ni + n + 1) * sizeof(double), 0);
  double *out = in + ni;
  n = read_nodes(L, 2, g, ids, n);
  luaL_checktype(L, 3, LUA_TTABLE);
  for (int i = 0; i < ni; i++) {
    lua_geti(L, 3, i);
    in[i] = lua_tonumber(L, -1);
    lua_pop(L, 1);
  }
  nz_graph_plan *p = nz_graph_plan_new(g, ids, n);
  if (!p) return luaL_error(L, "not enough memory to evaluate the graph");
  nz_status st = nz_graph_eval(p, in, out);
  nz_graph_plan_free(p);
  if (st) {
    lua_pushnil(L);
    lua_pushfstring(L, "status %d", (int)st);
    return 2;
  }
  lua_createtable(L, n, 0);
  for (int o = 0; o < n; o++) {
    lua_pushnumber(L, out[o]);
    lua_rawseti(L, -2, o + 1);
  }
  return 1;
}

/* The jets of the table at idx by input number (0-based), for a graph of
 * ni inputs: a number is a constant jet of order K (made on the stack,
 * where it stays while used), nil NULL (an input the nodes must not read,
 * or one that does not move). */
static void input_jets(lua_State *L, int idx, int ni, int K, const nz_jet **in)
{
  for (int i = 0; i < ni; i++) {
    lua_geti(L, idx, i);
    nz_jet *j = nz_lua_tojet(L, -1);
    if (!j && lua_type(L, -1) == LUA_TNUMBER) {
      double v = lua_tonumber(L, -1);
      j = nz_lua_newjet(L, K, 0);
      nz_jet_set_constant(j, v);
      lua_remove(L, -2);
    }
    in[i] = j;
  }
}

/* eval_jets({nodes}, {inputs by number, 0-based: jets or numbers} [,
 * {directions by number}]) -> {jets} [, {eta-parts}], or nil, message: the
 * jets path, for checking a recording against the function on jets with
 * tangents and along a state direction (lua/nz/model/record.lua).  The outputs
 * have the lowest order of the jet inputs and their most tangents. */
static int lg_eval_jets(lua_State *L)
{
  nz_recording *c = check(L);
  nz_graph *g = nz_recording_graph(c);
  int n = (int)luaL_len(L, 2), ni = nz_graph_ninputs(g), K = -1, D = 0, dir = lua_istable(L, 4);
  luaL_checktype(L, 3, LUA_TTABLE);
  lua_settop(L, 4);
  int *ids = lua_newuserdatauv(L, (size_t)(n + 1) * sizeof(int), 0);
  n = read_nodes(L, 2, g, ids, n);
  const nz_jet **in = lua_newuserdatauv(L, 2 * (size_t)(ni + 1) * sizeof(nz_jet *), 0), **din = in + ni + 1;
  nz_jet **out = lua_newuserdatauv(L, 2 * (size_t)(n + 1) * sizeof(nz_jet *), 0), **dout = out + n + 1;
  for (int s = 3; s <= 3 + dir; s++)
    for (int i = 0; i < ni; i++) {
      lua_geti(L, s, i);
      const nz_jet *j = nz_lua_tojet(L, -1);
      if (j && s == 3 && (K < 0 || j->order < K)) K = j->order;
      if (j && j->ntan > D) D = j->ntan;
      lua_pop(L, 1);
    }
  if (K < 0) K = 0;
  luaL_checkstack(L, 2 * (ni + n) + 8, "evaluating a graph on jets");
  input_jets(L, 3, ni, K, in);
  if (dir) input_jets(L, 4, ni, K, din);
  lua_createtable(L, n, 0);
  int outs = lua_gettop(L);
  lua_createtable(L, n, 0);
  for (int o = 0; o < n; o++) {
    out[o] = nz_lua_newjet(L, K, D);
    lua_rawseti(L, outs, o + 1);
    dout[o] = nz_lua_newjet(L, K, D);
    lua_rawseti(L, outs + 1, o + 1);
  }
  nz_graph_plan *p = nz_graph_plan_new(g, ids, n);
  if (!p) return luaL_error(L, "not enough memory to evaluate the graph");
  nz_status st = nz_graph_eval_jets(p, in, out, dir ? din : NULL, dir ? dout : NULL);
  nz_graph_plan_free(p);
  if (st) {
    lua_pushnil(L);
    lua_pushfstring(L, "status %d", (int)st);
    return 2;
  }
  if (dir) return 2;
  lua_pushvalue(L, outs);
  return 1;
}

/* set_exact(true | false): build nodes as IEEE arithmetic computes the
 * expression (the recorder, while it runs a user's function), or
 * simplified (graph.h). */
static int lg_set_exact(lua_State *L)
{
  nz_graph_set_exact(nz_recording_graph(check(L)), lua_toboolean(L, 2));
  return 0;
}

/* set_native(true | false | nil): compile the plans on doubles at once,
 * never, or when they have earned it (mech_graph.h). */
static int lg_set_native(lua_State *L)
{
  nz_recording *c = check(L);
  nz_recording_set_native(c, lua_isnil(L, 2) ? -1 : lua_toboolean(L, 2));
  return 0;
}

static const luaL_Reg methods[] = {
  { "const", lg_const }, { "slot", lg_slot }, { "frozen", lg_frozen }, { "nslots", lg_nslots },
  { "time", lg_time }, { "param", lg_param }, { "copy", lg_copy },
  { "op", lg_op }, { "fn", lg_fn }, { "powc", lg_powc }, { "constant", lg_constant },
  { "cmp", lg_cmp }, { "select", lg_select },
  { "set_piece", lg_set_piece }, { "info", lg_info }, { "piece_nodes", lg_piece_nodes },
  { "eval", lg_eval }, { "eval_jets", lg_eval_jets }, { "set_native", lg_set_native }, { "native_wait", lg_native_wait },
  { "set_exact", lg_set_exact }, { "nodes", lg_nodes },
  { "mass_bias_outputs", lg_mass_bias_outputs }, { "piece_outputs", lg_piece_outputs }, { "derivative", lg_derivative },
  { NULL, NULL }
};

void nz_lua_open_graph(lua_State *L)
{
  if (luaL_newmetatable(L, NZ_RECORDING_METATABLE)) {
    lua_pushcfunction(L, lg_gc);
    lua_setfield(L, -2, "__gc");
    luaL_newlib(L, methods);
    lua_setfield(L, -2, "__index");
  }
  lua_pop(L, 1);
  lua_pushcfunction(L, lg_new);
  lua_setfield(L, -2, "recording_new");
  lua_pushcfunction(L, lg_tracer);
  lua_setfield(L, -2, "tracer");
}
