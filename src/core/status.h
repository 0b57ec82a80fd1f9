/* status.h - the status codes of the C core, in one place.
 *
 * Every function of the core that can fail returns one of these (as an
 * nz_status or as an int holding one); NZ_OK is 0 everywhere.  The jet
 * codes describe why an operation on series has no value; the codes from
 * 100 up are those of the layers above (mechanics, linear algebra, the
 * evaluator), numbered apart so that a jet code passed up through them
 * keeps its meaning.  Detail beyond the code travels beside it: the
 * evaluator's message (NZ_EFUNC), nz_solve_info (NZ_ESINGULAR), the
 * failure reports of constrained.h and ode.h.  The bindings turn a code
 * into an error message (lua/lua_jet.c for jets, lua/lua_util.c for the
 * rest).
 *
 * Outcomes that are not failures, or that say which part failed, have their
 * own enums next to the code that produces them: nz_accel_failure
 * (mech/constrained.h), nz_ode_failure_kind (ode/ode.h), nz_run_status
 * (ode/ode_run.h). */
#ifndef NZ_STATUS_H
#define NZ_STATUS_H

typedef enum nz_status {
  NZ_OK = 0,
  /* Jets (jets/jet.h) and everything that evaluates them. */
  NZ_EDOM,      /* argument outside the function's domain (log(-1))            */
  NZ_ESING,     /* defined, but not differentiable there (sqrt(0) with K >= 1) */
  NZ_EZERODIV,  /* division by a series whose constant term is zero            */
  NZ_ERANGE,    /* the result overflows (a coefficient is infinite)            */
  NZ_ENOMEM,
  NZ_ENAN,      /* a coefficient of the result is NaN and none is infinite     */
  /* The layers above the jets. */
  NZ_EFUNC = 100,     /* a user function failed; the evaluator holds the message  */
  NZ_EARG = 101,      /* a request the system cannot answer (e.g. no S for Wassmuth) */
  NZ_ESINGULAR = 102  /* singular or ill-conditioned matrix                       */
} nz_status;

#endif
