/* lua_points.h - a trajectory's output points as C arrays (functions added
 * to core.mech): a userdata "nz.points" holding, per point, q, q', q'' and
 * the multipliers, which the stepping loop's binding (lua_ode.c) appends to
 * and lua/nz/motion/trajectory.lua reads as rows and columns on demand. */
#ifndef NZ_LUA_POINTS_H
#define NZ_LUA_POINTS_H
#include <lua.h>

typedef struct nz_points nz_points;

/* The points of the trajectory at stack index tr (its field _points), made
 * for k coordinates and nc multipliers when it has none yet; raises when
 * they were made for other sizes. */
nz_points *nz_lua_points_of(lua_State *L, int tr, int k, int nc);
/* One point appended: y holds q then q' (2k), acc q'' then the multipliers
 * (k + nc).  Raises when there is no memory for it. */
void nz_lua_points_push(lua_State *L, nz_points *p, const double *y, const double *acc);
void nz_lua_open_points(lua_State *L);

#endif
