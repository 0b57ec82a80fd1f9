/* lua_contact.c - the contacts of a system for Lua (see lua_contact.h):
 *   contacts_new(def, {nb, orders, contacts = {{gap, slip, slip2, speed, e,
 *                mu, mu_s}, ..}, names = {...}, rtol, atol}) -> cs
 *       gap, slip (slip2 and speed: an isotropic cone's second slip
 *       velocity and |v_t|) are 1-based constraint numbers of the system
 *       def (its constraints: nb bilateral first, then the contacts'
 *       functions), orders the classification of all of them; rtol, atol
 *       the run's tolerances
 *   contacts_transition(cs, def, t, q, qd, trigger) -> qd+, report, q+
 *       trigger: the contact event (1-based, 2j - 1 normal, 2j friction)
 *       that brought the run here, or 0 at the start; report = {impact,
 *       changed, zeno = {contact, time} | nil, contacts = {{from, to,
 *       impact, zeno, share, gap, vn_before, vn_after, vt_before, vt_after,
 *       Pn, Pt, lambda_n, lambda_t}, ...}} with the states as words (vt_*,
 *       Pt and lambda_t are numbers, or {x, y} for an isotropic cone)
 *   contacts_event(cs, def, e, t, y) -> g         (e 1-based)
 *   contacts_mode(cs) -> {"open" | "closed" | "stick" | "slip+" | "slip-", ...}
 *   contacts_set_mode(cs, {...}) ; contacts_reset(cs)
 *   contacts_kinematics(cs, def, t, q, qd) -> {{gap, vn, vt, size}, ...}
 *   contacts_accel(cs, def, t, q, qd) -> qdd, lambda
 * Every failure is raised here with the contact's name and the state. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <lauxlib.h>
#include "lua/lua_contact.h"
#include "lua/lua_util.h"
#include "mech/contact.h"

#define NZ_CONTACTS_METATABLE "nz.contacts"

typedef struct contacts_box {
  nz_contacts *c;
  int k, n, nc;
  int *iso;                          /* n: which contacts have an isotropic cone (user value 1) */
} contacts_box;

static const char *const STATE_NAMES[] = { "open", "closed", "stick", "slip+", "slip-", "slip", NULL };

struct nz_contacts *nz_lua_tocontacts(lua_State *L, int idx)
{
  contacts_box *b = luaL_testudata(L, idx, NZ_CONTACTS_METATABLE);
  return b ? b->c : NULL;
}

int nz_lua_contacts_failed(const struct nz_contacts *c) { return c && nz_contacts_failure(c)->kind != NZ_CONTACT_OK; }

static contacts_box *check_box(lua_State *L, int idx)
{
  contacts_box *b = luaL_checkudata(L, idx, NZ_CONTACTS_METATABLE);
  if (!b->c) luaL_error(L, "these contacts have been freed");
  return b;
}

static int contacts_gc(lua_State *L)
{
  contacts_box *b = luaL_checkudata(L, 1, NZ_CONTACTS_METATABLE);
  if (b->c) {
    lua_pushnil(L);
    lua_rawsetp(L, LUA_REGISTRYINDEX, b->c);   /* its names */
  }
  nz_contacts_free(b->c);
  b->c = NULL;
  return 0;
}

/* contacts_new(def, cfg) -> cs */
static int lc_new(lua_State *L)
{
  bound_system b;
  nz_lua_bind_system(L, 1, &b);
  luaL_checktype(L, 2, LUA_TTABLE);
  int k = b.sys.k, nc = b.sys.nc;
  int nb = (int)nz_lua_field_number(L, 2, "nb", 0.0);
  int *orders = lua_newuserdatauv(L, ((size_t)nc + 1) * sizeof(int), 0);
  nz_lua_field_ints(L, 2, "orders", nc, orders);
  lua_getfield(L, 2, "contacts");
  luaL_checktype(L, -1, LUA_TTABLE);
  int n = (int)luaL_len(L, -1);
  nz_contact_def *defs = lua_newuserdatauv(L, ((size_t)n + 1) * sizeof *defs, 0);
  for (int j = 0; j < n; j++) {
    lua_geti(L, -2, j + 1);
    luaL_checktype(L, -1, LUA_TTABLE);
    int top = lua_gettop(L);
    defs[j].gap = (int)nz_lua_field_number(L, top, "gap", 0.0) - 1;
    defs[j].slip = (int)nz_lua_field_number(L, top, "slip", 0.0) - 1;
    defs[j].slip2 = (int)nz_lua_field_number(L, top, "slip2", 0.0) - 1;
    defs[j].speed = (int)nz_lua_field_number(L, top, "speed", 0.0) - 1;
    defs[j].e = nz_lua_field_number(L, top, "e", 0.0);
    defs[j].mu = nz_lua_field_number(L, top, "mu", 0.0);
    defs[j].mu_s = nz_lua_field_number(L, top, "mu_s", defs[j].mu);
    lua_pop(L, 1);
  }
  nz_contacts_config cfg = { nc, nb, orders, n, defs, nz_lua_field_number(L, 2, "zeno_speed", 0.0), 0.0,
                             nz_lua_field_number(L, 2, "rtol", 0.0), nz_lua_field_number(L, 2, "atol", 0.0) };
  contacts_box *box = lua_newuserdatauv(L, sizeof *box, 1);
  memset(box, 0, sizeof *box);
  luaL_setmetatable(L, NZ_CONTACTS_METATABLE);
  box->k = k, box->n = n, box->nc = nc;
  box->iso = lua_newuserdatauv(L, ((size_t)n + 1) * sizeof(int), 0);
  for (int j = 0; j < n; j++) box->iso[j] = defs[j].slip2 >= 0;
  lua_setiuservalue(L, -2, 1);
  if (!(box->c = nz_contacts_new(k, &cfg)))
    return luaL_error(L, "internal: the contacts could not be made (a bad configuration, or no memory)");
  lua_getfield(L, 2, "names");        /* for the messages, under the contacts' address */
  lua_rawsetp(L, LUA_REGISTRYINDEX, box->c);
  return 1;
}

/* The name of contact j (0-based) of c, left on the stack. */
static const char *contact_name(lua_State *L, const nz_contacts *c, int j)
{
  lua_rawgetp(L, LUA_REGISTRYINDEX, c);
  lua_geti(L, -1, j + 1);
  lua_remove(L, -2);
  const char *name = lua_tostring(L, -1);
  return name ? name : "?";
}

int nz_lua_contacts_raise(lua_State *L, const nz_contacts *c, bound_system *b)
{
  const nz_contact_report_failure *f = nz_contacts_failure(c);
  int k = b->sys.k;
  if (f->kind == NZ_CONTACT_EVAL) return nz_lua_raise_core(L, b, f->status ? f->status : NZ_EFUNC, "simulate");
  const char *name = f->contact >= 0 ? contact_name(L, c, f->contact) : NULL;   /* (below the buffer) */
  luaL_Buffer msg;
  luaL_buffinit(L, &msg);
  lua_pushfstring(L, "system '%s': ", nz_lua_system_name(L, b->ev.def));
  luaL_addvalue(&msg);
  char num[64], num2[64];
  switch (f->kind) {
  case NZ_CONTACT_PAINLEVE:
    nz_lua_fmt_num(num, sizeof num, f->value);
    nz_lua_fmt_num(num2, sizeof num2, f->an);
    lua_pushfstring(L, "contact '%s': Painleve's paradox", name);
    luaL_addvalue(&msg);
    nz_lua_add_state(&msg, f->t, f->q, f->qd, k);
    lua_pushfstring(L, ": it slides, and with its friction its normal effective mass J M^-1 (J - mu s D)^T is %s "
                    "times the frictionless one, not positive: %s (its normal acceleration without a contact force "
                    "is %s); lower mu (the paradox needs a large one), or model the contact's compliance",
                    num, f->an < 0.0 ? "no contact mode is consistent, neither lifting off nor a pushing force"
                                     : "two contact modes are consistent, lifting off and a pushing force, and the "
                                       "motion is not determined",
                    num2);
    luaL_addvalue(&msg);
    break;
  case NZ_CONTACT_SINGULAR:
    nz_lua_fmt_num(num, sizeof num, f->value);
    luaL_addstring(&msg, "the contacts held and the constraints are dependent");
    nz_lua_add_state(&msg, f->t, f->q, f->qd, k);
    lua_pushfstring(L, " (the saddle point's reciprocal condition is %s) and their rows do not keep each other: "
                    "the rows held ask for accelerations no force can give; check the constraints beside the contacts", num);
    luaL_addvalue(&msg);
    break;
  case NZ_CONTACT_INDETERMINATE:
    nz_lua_fmt_num(num, sizeof num, f->value);
    lua_pushfstring(L, "contact '%s' slides while its normal force is not determined (dependent contacts share "
                    "the load)", name);
    luaL_addvalue(&msg);
    nz_lua_add_state(&msg, f->t, f->q, f->qd, k);
    lua_pushfstring(L, ", and how the load is shared changes the motion (a unit of normal force moved onto it "
                    "changes q'' by %s of its friction's own effect: the friction's moments differ): the rigid "
                    "model does not determine the motion; leave a redundant contact out, or give the friction "
                    "the same slip direction at every contact", num);
    luaL_addvalue(&msg);
    break;
  case NZ_CONTACT_SERIES:
    lua_pushfstring(L, "contact '%s' starts to slide from rest (its isotropic cone)", name ? name : "?");
    luaL_addvalue(&msg);
    nz_lua_add_state(&msg, f->t, f->q, f->qd, k);
    luaL_addstring(&msg, ": method 'taylor' cannot start there, the series of its slip speed |v_t| being singular "
                         "at zero; take a GSL stepper for this run (method = 'rk8pd')");
    break;
  case NZ_CONTACT_CONE:
    luaL_addstring(&msg, "the friction cones' complementarity problem did not settle");
    nz_lua_add_state(&msg, f->t, f->q, f->qd, k);
    lua_pushfstring(L, " (at contact '%s'): the pyramid turned along its friction four times without a solution "
                    "the cone itself holds", name ? name : "?");
    luaL_addvalue(&msg);
    break;
  case NZ_CONTACT_MASS:
    nz_lua_fmt_num(num, sizeof num, f->value);
    luaL_addstring(&msg, "the mass matrix M is singular or not positive definite");
    nz_lua_add_state(&msg, f->t, f->q, f->qd, k);
    lua_pushfstring(L, " (its reciprocal condition is %s): check T near this state", num);
    luaL_addvalue(&msg);
    break;
  case NZ_CONTACT_LCP:
    luaL_addstring(&msg, "no consistent contact mode was found");
    nz_lua_add_state(&msg, f->t, f->q, f->qd, k);
    if (name) {
      lua_pushfstring(L, " (at contact '%s')", name);
      luaL_addvalue(&msg);
    }
    luaL_addstring(&msg, ": Lemke's algorithm ended on a ray (the complementarity problem of the contact forces "
                         "has no solution it can find)");
    break;
  case NZ_CONTACT_GRADIENT:
    lua_pushfstring(L, "contact '%s': its gap's gradient dPhi/dq vanishes where it touches", name ? name : "?");
    luaL_addvalue(&msg);
    nz_lua_add_state(&msg, f->t, f->q, f->qd, k);
    nz_lua_fmt_num(num, sizeof num, f->value);
    lua_pushfstring(L, " (%s of the largest it had in the run): there is no normal direction there; write the gap "
                    "as a distance whose gradient does not vanish (not q^3, nor x^2 - a^2 at a = 0, whose gradient "
                    "is 0 where they are 0)", num);
    luaL_addvalue(&msg);
    break;
  default:
    luaL_addstring(&msg, "the contacts failed");
    nz_lua_add_state(&msg, f->t, f->q, f->qd, k);
  }
  luaL_pushresult(&msg);
  return nz_lua_raise_located(L);
}

/* The start of every call (cs, def, t, q, qd): bind the system and read. */
static contacts_box *begin(lua_State *L, bound_system *b, double *t, double **q)
{
  contacts_box *box = check_box(L, 1);
  nz_lua_bind_system(L, 2, b);
  if (b->sys.k != box->k || b->sys.nc != box->nc) luaL_error(L, "internal: the contacts belong to another system");
  *t = luaL_checknumber(L, 3);
  *q = lua_newuserdatauv(L, 2 * (size_t)box->k * sizeof(double), 0);
  nz_lua_read_vector(L, 4, box->k, *q, "q", 0, "simulate");
  nz_lua_read_vector(L, 5, box->k, *q + box->k, "qd", 0, "simulate");
  return box;
}

/* A tangential quantity: a number, or {x, y} for an isotropic cone. */
static void push_tangent(lua_State *L, const double *v, int iso)
{
  if (iso) nz_lua_push_vector(L, v, 2);
  else lua_pushnumber(L, v[0]);
}

static void push_change(lua_State *L, const nz_contact_change *c, int iso)
{
  lua_createtable(L, 0, 14);
  lua_pushstring(L, STATE_NAMES[c->from]);
  lua_setfield(L, -2, "from");
  lua_pushstring(L, STATE_NAMES[c->to]);
  lua_setfield(L, -2, "to");
  lua_pushboolean(L, c->impact);
  lua_setfield(L, -2, "impact");
  lua_pushboolean(L, c->zeno);
  lua_setfield(L, -2, "zeno");
  lua_pushboolean(L, c->share);
  lua_setfield(L, -2, "share");
  const struct { const char *name; double v; } nums[] = {
    { "gap", c->gap }, { "vn_before", c->vn_before }, { "vn_after", c->vn_after }, { "Pn", c->Pn },
    { "lambda_n", c->lambda_n },
  };
  for (size_t i = 0; i < sizeof nums / sizeof nums[0]; i++) {
    lua_pushnumber(L, nums[i].v);
    lua_setfield(L, -2, nums[i].name);
  }
  const struct { const char *name; const double *v; } tans[] = {
    { "vt_before", c->vt_before }, { "vt_after", c->vt_after }, { "Pt", c->Pt }, { "lambda_t", c->lambda_t },
  };
  for (size_t i = 0; i < sizeof tans / sizeof tans[0]; i++) {
    push_tangent(L, tans[i].v, iso);
    lua_setfield(L, -2, tans[i].name);
  }
}

/* contacts_transition(cs, def, t, q, qd, trigger) -> qd+, report, q+ (q
 * and qd+ put on what the new mode holds) */
static int lc_transition(lua_State *L)
{
  lua_settop(L, 6);
  bound_system b;
  double t, *y;
  contacts_box *box = begin(L, &b, &t, &y);
  int trigger = (int)luaL_optinteger(L, 6, 0) - 1, n = box->n, k = box->k;
  nz_contact_change *ch = lua_newuserdatauv(L, (size_t)n * sizeof *ch, 0);
  nz_contact_report rep;
  memset(&rep, 0, sizeof rep);
  rep.c = ch;
  int st = nz_contacts_transition(box->c, &b.sys, t, y, y + k, trigger, &rep);
  if (st) return nz_lua_contacts_raise(L, box->c, &b);
  nz_lua_push_vector(L, y + k, k);
  lua_createtable(L, 0, 4);
  lua_pushboolean(L, rep.impact);
  lua_setfield(L, -2, "impact");
  lua_pushboolean(L, rep.changed);
  lua_setfield(L, -2, "changed");
  if (rep.zeno_contact >= 0) {
    lua_createtable(L, 0, 2);
    lua_pushinteger(L, rep.zeno_contact + 1);
    lua_setfield(L, -2, "contact");
    lua_pushnumber(L, rep.zeno_time);
    lua_setfield(L, -2, "time");
    lua_setfield(L, -2, "zeno");
  }
  lua_createtable(L, n, 0);
  for (int j = 0; j < n; j++) {
    push_change(L, &ch[j], box->iso[j]);
    lua_rawseti(L, -2, j + 1);
  }
  lua_setfield(L, -2, "contacts");
  nz_lua_push_vector(L, y, k);
  return 3;
}

/* contacts_event(cs, def, e, t, y) -> g */
static int lc_event(lua_State *L)
{
  contacts_box *box = check_box(L, 1);
  bound_system b;
  nz_lua_bind_system(L, 2, &b);
  int e = (int)luaL_checkinteger(L, 3) - 1;
  luaL_argcheck(L, e >= 0 && e < 2 * box->n, 3, "no such contact event");
  double t = luaL_checknumber(L, 4), g;
  double *y = lua_newuserdatauv(L, 2 * (size_t)box->k * sizeof(double), 0);
  luaL_checktype(L, 5, LUA_TTABLE);
  for (int i = 0; i < 2 * box->k; i++) {   /* q, qd: the start of a state that may hold more */
    lua_geti(L, 5, i + 1);
    y[i] = luaL_checknumber(L, -1);
    lua_pop(L, 1);
  }
  int st = nz_contacts_event(box->c, &b.sys, e, t, y, &g);
  if (st) return nz_lua_contacts_raise(L, box->c, &b);
  lua_pushnumber(L, g);
  return 1;
}

/* contacts_mode(cs) -> {state, ...} */
static int lc_mode(lua_State *L)
{
  contacts_box *box = check_box(L, 1);
  int *m = lua_newuserdatauv(L, (size_t)box->n * sizeof(int), 0);
  nz_contacts_get_mode(box->c, m);
  lua_createtable(L, box->n, 0);
  for (int j = 0; j < box->n; j++) {
    lua_pushstring(L, STATE_NAMES[m[j]]);
    lua_rawseti(L, -2, j + 1);
  }
  return 1;
}

/* contacts_set_mode(cs, {state, ...}) */
static int lc_set_mode(lua_State *L)
{
  contacts_box *box = check_box(L, 1);
  luaL_checktype(L, 2, LUA_TTABLE);
  int *m = lua_newuserdatauv(L, (size_t)box->n * sizeof(int), 0);
  for (int j = 0; j < box->n; j++) {
    lua_geti(L, 2, j + 1);
    m[j] = luaL_checkoption(L, -1, NULL, STATE_NAMES);
    lua_pop(L, 1);
  }
  if (nz_contacts_set_mode(box->c, m)) return luaL_error(L, "a contact without friction cannot stick or slide");
  return 0;
}

static int lc_reset(lua_State *L)
{
  nz_contacts_reset(check_box(L, 1)->c);
  return 0;
}

/* contacts_kinematics(cs, def, t, q, qd) -> {{gap, vn, vt, size}, ...} */
static int lc_kinematics(lua_State *L)
{
  lua_settop(L, 5);
  bound_system b;
  double t, *y;
  contacts_box *box = begin(L, &b, &t, &y);
  double *out = lua_newuserdatauv(L, 4 * (size_t)box->n * sizeof(double), 0);
  if (nz_contacts_kinematics(box->c, &b.sys, t, y, y + box->k, out)) return nz_lua_contacts_raise(L, box->c, &b);
  lua_createtable(L, box->n, 0);
  for (int j = 0; j < box->n; j++) {
    nz_lua_push_vector(L, out + 4 * j, 4);
    lua_rawseti(L, -2, j + 1);
  }
  return 1;
}

/* contacts_accel(cs, def, t, q, qd) -> qdd, lambda (the current mode) */
static int lc_accel(lua_State *L)
{
  lua_settop(L, 5);
  bound_system b;
  double t, *y;
  contacts_box *box = begin(L, &b, &t, &y);
  double *out = lua_newuserdatauv(L, ((size_t)box->k + (size_t)box->nc) * sizeof(double), 0);
  if (nz_contacts_accel(box->c, &b.sys, t, y, y + box->k, out, out + box->k)) return nz_lua_contacts_raise(L, box->c, &b);
  nz_lua_push_vector(L, out, box->k);
  nz_lua_push_vector(L, out + box->k, box->nc);
  return 2;
}

static const luaL_Reg contact_functions[] = {
  { "contacts_new", lc_new }, { "contacts_transition", lc_transition }, { "contacts_event", lc_event },
  { "contacts_mode", lc_mode }, { "contacts_set_mode", lc_set_mode }, { "contacts_reset", lc_reset },
  { "contacts_kinematics", lc_kinematics }, { "contacts_accel", lc_accel }, { NULL, NULL }
};

void nz_lua_open_contact(lua_State *L)
{
  nz_lua_gc_metatable(L, NZ_CONTACTS_METATABLE, contacts_gc);
  luaL_setfuncs(L, contact_functions, 0);
}
