/* jet.h - truncated Taylor series carrying tangent (dual) directions.
 *
 * A jet of order K with D tangent directions holds D + 1 series of order K:
 * the value series c_0..c_K (c_j = f^(j)(t0) / j!) and, for each direction d,
 * the series of the partial derivative of those coefficients along d.  The
 * arithmetic is that of truncated series whose coefficients are dual numbers
 * a + sum_d a_d eps_d with eps_d eps_e = 0: docs/theory.md §3 explains why the
 * mechanics needs both (T differentiated n times along the motion, then one
 * partial derivative with respect to q^(n)).  Plain dual numbers are K = 0.
 *
 * Plain C: this module never includes lua.h, never prints and never exits.
 * Functions return an nz_status; on failure the result is unspecified and the
 * caller (a binding) raises an error naming the function and the value.
 */
#ifndef NZ_JET_H
#define NZ_JET_H

#include <stddef.h>
#include "core/status.h"   /* nz_status: every status code of the core */

/* Limits, documented in nz.help(nz.jet). */
#define NZ_JET_MAX_ORDER 1024
#define NZ_JET_MAX_TANGENTS 1024

typedef struct nz_jet {
  int order;   /* K: the series hold coefficients 0..K          */
  int ntan;    /* D: number of tangent directions                */
  double c[];  /* (D + 1) blocks of K + 1: value, then tangent 0..D-1 */
} nz_jet;

/* The unary functions of nz_jet_apply. */
typedef enum nz_jet_fn {
  NZ_FN_EXP, NZ_FN_LOG, NZ_FN_SQRT, NZ_FN_SIN, NZ_FN_COS, NZ_FN_TAN,
  NZ_FN_ASIN, NZ_FN_ACOS, NZ_FN_ATAN, NZ_FN_SINH, NZ_FN_COSH, NZ_FN_TANH,
  NZ_FN_ABS,
  NZ_FN_SIGN,   /* -1, 0, +1 by the branch rule of nz_jet_compare; derivatives 0 */
  NZ_FN_COUNT
} nz_jet_fn;

extern const char *const nz_jet_fn_names[NZ_FN_COUNT];

/* Storage: nz_jet_bytes gives the size of a jet of that shape, so that a
 * binding can place it in memory it owns (a Lua userdata). */
size_t nz_jet_bytes(int order, int ntan);
void nz_jet_init(nz_jet *z, int order, int ntan);   /* set shape, zero all */
nz_jet *nz_jet_alloc(int order, int ntan);         /* NULL if out of memory */
void nz_jet_free(nz_jet *z);                       /* NULL is harmless */
void nz_jet_copy(nz_jet *z, const nz_jet *a);      /* same shape required */

/* NZ_OK when every coefficient of x (value and tangents) is finite, else
 * NZ_ERANGE if one is infinite, NZ_ENAN if one is NaN and none infinite.
 * Every operation below ends with this check, so a jet that an operation
 * returns with NZ_OK is finite throughout. */
nz_status nz_jet_check_finite(const nz_jet *x);

/* Workspace length (in doubles) every operation on jets of order K needs. */
size_t nz_jet_work_len(int order);

static inline double *nz_jet_value(nz_jet *z) { return z->c; }
/* Tangent series d (0-based), or NULL if the jet has no such direction. */
static inline double *nz_jet_tangent(const nz_jet *z, int d)
{
  return d < z->ntan ? (double *)z->c + (size_t)(d + 1) * (size_t)(z->order + 1) : NULL;
}

/* The shape of a result: the lower order (a truncated series is only known to
 * the lower order) and the larger tangent count (a missing direction is zero). */
void nz_jet_result_shape(const nz_jet *a, const nz_jet *b, int *order, int *ntan);

/* Make z the variable t0 + (t - t0) of its order; with seed >= 0, its tangent
 * along direction `seed` is 1 (the derivative with respect to t0). */
void nz_jet_set_variable(nz_jet *z, double t0, int seed);
void nz_jet_set_constant(nz_jet *z, double v);

/* Arithmetic.  z has the result shape of its operands and aliases none of them;
 * w is a workspace of nz_jet_work_len(z->order) doubles. */
nz_status nz_jet_add(nz_jet *z, const nz_jet *a, const nz_jet *b);
nz_status nz_jet_sub(nz_jet *z, const nz_jet *a, const nz_jet *b);
nz_status nz_jet_mul(nz_jet *z, const nz_jet *a, const nz_jet *b, double *w);
nz_status nz_jet_div(nz_jet *z, const nz_jet *a, const nz_jet *b, double *w);
nz_status nz_jet_neg(nz_jet *z, const nz_jet *a);
nz_status nz_jet_scale(nz_jet *z, const nz_jet *a, double s);      /* s a */
nz_status nz_jet_offset(nz_jet *z, const nz_jet *a, double s);     /* a + s */
nz_status nz_jet_apply(nz_jet *z, nz_jet_fn f, const nz_jet *x, double *w);
nz_status nz_jet_pow(nz_jet *z, const nz_jet *x, double p, double *w);     /* x^p */
nz_status nz_jet_pow_jet(nz_jet *z, const nz_jet *x, const nz_jet *y, double *w);
nz_status nz_jet_atan2(nz_jet *z, const nz_jet *y, const nz_jet *x, double *w);
nz_status nz_jet_hypot(nz_jet *z, const nz_jet *a, const nz_jet *b, double *w);

/* Branches that a recorded graph can hold: a comparison gives a
 * number, a selection picks a whole operand, so no C or Lua `if` on a traced
 * value is needed.
 *
 * The branch rule.  Near t0 a series a(t) lies above b(t) for t slightly
 * greater than t0 when the first coefficient in which they differ is larger
 * in a: the value series are compared lexicographically, c_0 first, then
 * c_1, ..., up to z's order.  At a tie in value the series that grows wins,
 * which is the branch the motion takes for t > t0 (x = t - t0 against 0 at
 * t0: x > 0 holds).  Series equal in every known coefficient are equal.
 * Tangent series are not compared: the result of a comparison is a step,
 * whose derivative is 0 wherever it is defined. */
typedef enum nz_cmp { NZ_CMP_LT, NZ_CMP_LE, NZ_CMP_GT, NZ_CMP_GE, NZ_CMP_EQ, NZ_CMP_NE } nz_cmp;

/* z = 1 where a op b holds, else 0, as a constant series (every other
 * coefficient and every tangent 0).  z has the result shape of a and b and
 * may alias either.  NZ_ENAN when a compared coefficient is NaN. */
nz_status nz_jet_compare(nz_jet *z, nz_cmp op, const nz_jet *a, const nz_jet *b);

/* z = a when c's value c_0 != 0, else b: the whole jet, tangents included,
 * in z's shape (z's order must not exceed the chosen operand's; a direction
 * the chosen operand lacks is zero).  c's value is read first, so z may
 * alias any operand.  NZ_ENAN when c_0 is NaN. */
nz_status nz_jet_select(nz_jet *z, const nz_jet *c, const nz_jet *a, const nz_jet *b);

#endif
