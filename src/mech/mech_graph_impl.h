/* mech_graph_impl.h - inside mech_graph.c and mech_graph_series.c: the
 * recorded system (struct nz_recording), its plans on doubles that switch to
 * machine code (dplan), and the few functions the series of the motion
 * (mech_graph_series.c) shares with the rest.  Internal to src/mech. */
#ifndef NZ_MECH_GRAPH_IMPL_H
#define NZ_MECH_GRAPH_IMPL_H

#include "graph/graph_guard.h"
#include "graph/graph_native.h"
#include "graph/series_native.h"
#include "core/linalg.h"
#include "mech/mech_graph.h"

/* A plan on doubles that runs as machine code (graph_native.h): in auto
 * mode its compile starts in the background once interpreting it has cost
 * a sixteenth of what compiling would (start, below) and the plan switches
 * to the object when it is ready, between two evaluations (the results are
 * the same bit for bit); at once when its object is cached; at its first
 * use, waiting for the compiler, with native on; never with native off or
 * when compiling fails (the reason is kept for graph_info). */
typedef struct dplan {
  nz_graph_plan *plan;
  int *outs, nout;
  nz_native *native;      /* the loaded object (NULL: interpreted) */
  nz_native *compiling;   /* a compile under way in the background */
  double work;            /* nodes interpreted so far */
  double start;           /* ... before its compile starts (auto mode) */
  unsigned polls;         /* evaluations since the compile was last polled */
  int tried, used;
  /* The plan's series (Taylor's method) as machine code, on the same
   * policy: node coefficients interpreted so far, whether it was tried. */
  nz_series_native *ser, *ser_compiling;
  double ser_work;
  int ser_tried, ser_looked, ser_used;
} dplan;

typedef struct compiled_piece {
  int n;                  /* outputs: 0 when the piece is not compiled */
  int *nodes;
  nz_graph_plan *plan;
} compiled_piece;

struct nz_recording {
  int k, np, nc, nslots, ninputs;
  nz_graph *g;
  double *params;                      /* np current values */
  compiled_piece piece[NZ_PIECE_COUNT];   /* PHI unused: see phi */
  compiled_piece *phi;                 /* nc constraints */
  /* Evaluation scratch, sized once: input pointers and parameter jets. */
  const nz_jet **in, **din;
  nz_jet **pjet;                       /* np constant jets of order pcap */
  int pcap;
  /* Mass and bias on doubles (built on first use; built = -1 if impossible);
   * the guards read the plan's outputs after its own mb_nout
   * (graph_guard.h: ties and singular points go to the jets). */
  int mb_built, mb_nout;
  dplan *mb_plan;
  nz_graph_guards *mb_guards;
  double *mb_in, *mb_out;
  /* Native code: mode (-1 auto, 0 off, 1 on), plans compiled, seconds
   * compiling took and how many of them runs waited, why the last attempt
   * failed; plans (and series) evaluated so far and how many of those run
   * as machine code, compiles under way. */
  int native_mode, native_count, native_series;
  double native_seconds, native_waited;
  char native_why[300];
  int plans_used, plans_native, series_used, series_native, compiling;
  /* nz_recording_accel's workspace: A (k x k), rhs (k), the solver's. */
  double *acc_A, *acc_rhs, *acc_work;
  /* With a constant M, q'' = -M^-1 h as a plan of its own (M^-1's entries
   * are constants of the graph), and F, V checked: one pass per call;
   * m_info is the solve info of the one factorization of M. */
  dplan *acc_plan;
  nz_graph_guards *acc_guards;
  int acc_nout;
  nz_solve_info m_info;
  double *acc_out;
  /* Constraint rows on doubles: plan of (r, m) at rows[3 r + m] (built = 1,
   * or -1 when it cannot be built), outputs D^0..D^K Phi then A. */
  dplan **rows;
  signed char *rows_built;
  nz_graph_guards **row_guards;
  double **row_outs;                   /* each row plan's outputs, guards' after */
  double *row_in;
  /* nz_recording_motion_series's workspace, for series up to ts_cap + 1
   * coefficients of q (grown, never shrunk): the inputs' coefficient
   * (ninputs), M_0's factor and the solver's work, a right-hand side (k),
   * q''s coefficients ((ts_cap - 1) k), and the series of M's entries. */
  int ts_cap;
  double *ts_in, *ts_L, *ts_work, *ts_rhs, *ts_qdd;
  const double **ts_M;
  double **ts_inp;   /* the plan's input series, written in place (ninputs) */
  struct cseries *cs;   /* nz_recording_constrained_series's plans and workspace */
  int *ts_pos;       /* input numbers of q_i, of q_i', output numbers of q_i'' (3k) */
  char failure[160];
};

/* A plan on doubles of outputs outs[0..n-1] of g (NULL when it cannot be
 * made), and its end. */
dplan *nz_dplan_new(const nz_graph *g, const int *outs, int n);
void nz_dplan_free(dplan *d);
/* After a begin of d's series to order N: its machine code (mech_graph.c's
 * policy for plans on doubles, in node coefficients). */
void nz_dplan_series_native(nz_recording *c, dplan *d, int N, const nz_series_ode2 *ode2);
/* c->failure says which node of plan failed with status st. */
void nz_recording_describe_failure(nz_recording *c, const nz_graph_plan *plan, int st);
/* The plan of M and h on doubles, built on first use: nonzero when it is. */
int nz_recording_mass_bias_ready(nz_recording *c);
/* Does node root depend on an input numbered lo..hi? */
int nz_graph_reads_inputs(const nz_graph *g, int root, int lo, int hi);
/* Constraint row r of order m's plan outputs (mech_graph.c): D^0..D^K Phi,
 * then dD^K Phi/dq''_i; 0 or -1. */
int nz_recording_build_row(nz_recording *c, int r, int m, int *out);
/* The constrained series' plans and workspace freed (mech_graph_series.c). */
void nz_recording_constrained_series_free(nz_recording *c);

#endif
