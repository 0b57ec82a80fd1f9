/* lua_constraints.h - constraints for Lua (constrained.h): functions added to core.mech. */
#ifndef NZ_LUA_CONSTRAINTS_H
#define NZ_LUA_CONSTRAINTS_H
#include <lua.h>

/* Add the functions to the table on top of the stack (lua_nz.c only). */
void nz_lua_open_constraints(lua_State *L);

#endif
