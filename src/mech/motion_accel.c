/* motion_accel.c - which solve gives q'' at a state (see motion_accel.h). */
#include <string.h>
#include "mech/contact.h"
#include "mech/motion_accel.h"

int nz_motion_accel(const nz_system *s, const nz_motion_setup *a, double t, const double *q, const double *qd,
                    const double *guess, double *qdd, double *lambda, nz_motion_outcome *out)
{
  int st;
  out->failed = NZ_MOTION_OK;
  if (a->contacts) {
    st = nz_contacts_accel(a->contacts, s, t, q, qd, qdd, lambda);
    if (st) out->failed = NZ_MOTION_FAILED_CONTACTS;
    return st;
  }
  if (a->nc == 0) {
    st = nz_accel(s, t, q, qd, a->opt.rcond_min, qdd, &out->mass);
    if (st == NZ_ESINGULAR) out->failed = NZ_MOTION_FAILED_MASS;
    return st;
  }
  nz_accel_options opt = a->opt;
  if (guess) {                     /* stay on the branch of the last root */
    opt.guess_qdd = guess;
    opt.guess_lambda = guess + a->k;
  }
  int *involved = out->rep.involved;
  double *A = out->rep.A;
  memset(&out->rep, 0, sizeof out->rep);
  out->rep.involved = involved;    /* read by the error that names dependent constraints */
  out->rep.A = A;
  if (involved) memset(involved, 0, (size_t)a->nc * sizeof(int));
  st = nz_accel_constrained(s, a->orders, a->linear, t, q, qd, &opt, qdd, lambda, &out->rep);
  if (st == NZ_ESINGULAR || st == NZ_EARG) out->failed = NZ_MOTION_FAILED_CONSTRAINTS;
  return st;
}
