/* jet_eta.h - the rule of each jet operation along a second infinitesimal.
 *
 * A state direction is carried through an evaluation as a second nilpotent
 * eta (eta^2 = 0): every quantity is v + eta d, v and d jets.  For
 * z = f(a, b) the eta-part is dz = f_a(a, b) da + f_b(a, b) db, computed in
 * jet arithmetic over the eta-part's shape.  These rules live here, once,
 * for the two evaluators that carry a direction: the graph's plans on jets
 * (graph/graph_jets.c) and the Lua evaluator's dualjets (lua/lua_dualjet.c), so
 * that they agree formula for formula.
 *
 * Eta-parts may have a lower order and more tangents than the values: the
 * linear kernels below work over the result's shape (a missing coefficient
 * or tangent of an operand is zero, an extra one is dropped), and so may
 * every rule's operands.
 *
 * Plain C: never includes lua.h; functions return an nz_status.
 */
#ifndef NZ_JET_ETA_H
#define NZ_JET_ETA_H

#include "jets/jet.h"

/* z = s x + c (c on the constant term) over z's shape.  With c = 0 and
 * equal shapes this is nz_jet_scale, with s = 1 nz_jet_offset. */
nz_status nz_jet_affine(nz_jet *z, const nz_jet *x, double s, double c);

/* z = x / c coefficientwise over z's shape (nz_jet_div by a constant
 * series); NZ_EZERODIV when c is 0. */
nz_status nz_jet_div_const(nz_jet *z, const nz_jet *x, double c);

/* Copy src (NULL: zero) into z over z's shape. */
void nz_jet_copy_fit(nz_jet *z, const nz_jet *src);

/* The operations that have an eta rule (NZ_ETA_NONE: none, NZ_EDOM). */
typedef enum nz_eta_op {
  NZ_ETA_NONE, NZ_ETA_ADD, NZ_ETA_SUB, NZ_ETA_NEG, NZ_ETA_MUL, NZ_ETA_DIV, NZ_ETA_POWC,
  NZ_ETA_POW, NZ_ETA_FN, NZ_ETA_ATAN2, NZ_ETA_HYPOT
} nz_eta_op;

/* One operation z = op(a, b) as evaluated on jets. */
typedef struct nz_eta_args {
  nz_eta_op op;
  nz_jet_fn fn;              /* NZ_ETA_FN: the function */
  double p;                  /* NZ_ETA_POWC: the exponent */
  const nz_jet *a, *b, *z;   /* operands (b unused by unary ops) and z's value */
  const nz_jet *da, *db;     /* their eta-parts, NULL where zero */
  int ca, cb;                /* a, b a constant series: MUL scales by its c_0, DIV divides */
} nz_eta_args;

/* The eta-part of x->z into ez (the shape of ez chosen by the caller).
 * tmp: four jets with room for ez's shape (reshaped here); w: a workspace of
 * nz_jet_work_len of the highest order involved.  Both eta-parts NULL: zero. */
nz_status nz_jet_eta(nz_jet *ez, const nz_eta_args *x, nz_jet *const tmp[4], double *w);

#endif
