/* lua_contact.h - unilateral contacts for Lua (mech/contact.h): a userdata
 * "nz.contacts" (the contacts of a system, their mode and history, and
 * their names kept as its user value) made by lua/nz/motion/contact_run.lua for a
 * run, handed to the integrators (core.mech.ode_new{contacts = ...}), and
 * functions added to core.mech. */
#ifndef NZ_LUA_CONTACT_H
#define NZ_LUA_CONTACT_H
#include <lua.h>
#include "lua/lua_system.h"

struct nz_contacts;

/* The contacts at idx, or NULL when idx holds no nz.contacts. */
struct nz_contacts *nz_lua_tocontacts(lua_State *L, int idx);

/* 1 when the contacts' last call failed (nz_contacts_failure). */
int nz_lua_contacts_failed(const struct nz_contacts *c);

/* Raise the failure of the contacts c (made by contacts_new, whose names
 * the registry keeps under c; the system b, bound from its definition
 * table): Painleve's paradox, dependent contacts, no consistent mode, a gap
 * without a gradient, each with the contact's name and the state; a failed
 * user function as its own error. */
int nz_lua_contacts_raise(lua_State *L, const struct nz_contacts *c, bound_system *b);

/* Add the functions to the table on top of the stack (lua_nz.c only). */
void nz_lua_open_contact(lua_State *L);

#endif
