/* compensated.h - sums that lose nothing: error-free transformations and
 * numbers of double length (hi + lo), for the long runs where the rounding
 * of a sum repeated 1e8 times would otherwise add up (a state updated by
 * its increment every step, a time advanced by its step).
 *
 * Knuth's two-sum (The Art of Computer Programming, vol. 2, 4.2.2,
 * Theorem B): s = fl(a + b) and e with a + b = s + e exactly, whatever the
 * magnitudes, in six additions and no branch.  A double-length number
 * x = hi + lo (|lo| <= ulp(hi) / 2, hi the rounded value) takes an addend d
 * as Neumaier's and Kahan-Babuska's summation do: the two-sum of hi and d,
 * its error gathered into lo, then renormalized (Dekker's fast two-sum,
 * exact because |s| >= |lo| after the sum).  A fused multiply-add or a
 * reassociation would break the identities: the build is ISO C (-std=c11,
 * which contracts nothing) without -ffast-math. */
#ifndef NZ_COMPENSATED_H
#define NZ_COMPENSATED_H

/* s = fl(a + b), *err = a + b - s exactly. */
static inline double nz_two_sum(double a, double b, double *err)
{
  double s = a + b, bp = s - a;
  *err = (a - (s - bp)) + (b - bp);
  return s;
}

/* hi + lo += d, the result renormalized (hi its rounded value). */
static inline void nz_dd_add(double *hi, double *lo, double d)
{
  double e, s = nz_two_sum(*hi, d, &e);
  double l = *lo + e, h = s + l;
  *lo = l - (h - s);
  *hi = h;
}

#endif
