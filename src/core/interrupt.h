/* interrupt.h - a Ctrl-C request that long C loops (integration, work-
 * precision sweeps) poll, so that they stop cleanly, keep what they computed
 * and let the binding raise the interrupt object (nz.interrupted, see
 * nz_lua_raise_interrupt in lua_system.c).  The signal handler only sets the
 * flag: it never touches a Lua state or the core's data. */
#ifndef NZ_INTERRUPT_H
#define NZ_INTERRUPT_H
#include <signal.h>

extern volatile sig_atomic_t nz_interrupt_pending;

static inline void nz_interrupt_request(void) { nz_interrupt_pending = 1; }
static inline void nz_interrupt_clear(void) { nz_interrupt_pending = 0; }
static inline int nz_interrupt_requested(void) { return nz_interrupt_pending != 0; }

#endif
