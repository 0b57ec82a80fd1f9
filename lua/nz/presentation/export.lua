-- nz/presentation/export.lua - sys:export{lang = "c" | "python" | "octave", file = ...}:
-- the equations of motion as code that runs without nzlua.  The code is the
-- recorded graph written out node by node (straight-line code: a shared
-- subexpression is computed once), for
--   M (k x k) and h (k) of M q'' + h = A^T lambda,
--   per constraint of order m <= 2 (linear at the acceleration level): its
--   row A = dPhi/dq^(m) and the rest b of Phi^(2-m) = A q'' + b,
--   the constraint values Phi_r,
--   and, for the Jacobian of the first-order right-hand side, the
--   derivatives of all of these along each q_j and q'_j.
-- Around them each language gets the same small driver: the saddle-point
-- system [M -A^T; A 0] [q''; lambda] = [-h; -b] solved by LU with partial
-- pivoting, f(t, y) = (q', q''), its Jacobian from the derivative of that
-- solve (K dz = dr - dK z), and on request a main that integrates and prints
-- CSV: "t,<coords>,<coords>'" and one row per dt from t0 to t1 (C: GSL's
-- rk8pd; Python: a Dormand-Prince stepper written out, NumPy only; Octave:
-- ode45).  Constraints are kept at the acceleration level only, so their
-- drift is the integrator's error (as in nzlua without projection).
local constraints = require "nz.model.constraints"
local formula = require "nz.base.formula"
local options = require "nz.base.options"

local M = {}

local function fail(sys, ...) require("nz.base.where").method_error("export", sys, ...) end

-- ------------------------------------------------------------------ --
-- The graph outputs to write

-- The node ids of everything the code needs, in a table of named lists.
local function outputs(sys, jacobian)
  local e = sys.engine
  local c = e.recording
  if not c then fail(sys, "the system is not recorded (made with compile = false): there is no graph to export") end
  local k, np = sys.k, #(e.recording_params or {})
  local function input(j, i) return 1 + np + j * k + (i - 1) end
  local in_lua = require("nz.model.record").mass_bias_in_lua(sys)
  if in_lua then fail(sys, "nothing to export: %s. Only recorded functions can be exported", in_lua) end
  local ids = c:mass_bias_outputs(k)
  if not ids then fail(sys, "M and h could not be built from the recording: a piece of T, V or Q runs in Lua (print(sys) says why)") end
  local out = { M = {}, h = {}, A = {}, b = {}, phi = {} }
  for n = 1, k * k do out.M[n] = ids[n] end
  for i = 1, k do out.h[i] = ids[k * k + i] end
  local orders, linear = {}, {}
  if sys.nc > 0 then orders, linear = constraints.orders(sys) end
  local one = c:const(1)
  -- d/dt along the motion: t -> 1, q^(j) -> q^(j+1) (constraints receive q to q''')
  local motion = { [0] = one }
  if sys.nc > 0 then for j = 0, 2 do for i = 1, k do motion[input(j, i)] = c:slot(j + 1, i) end end end
  for r = 1, sys.nc do
    local m = orders[r]
    if m > 2 then fail(sys, "constraint %d is of order %d: export covers constraints on q, q' and q'' (order 0, 1, 2)", r, m) end
    if m == 2 and not linear[r] then
      fail(sys, "constraint %d is nonlinear in q'' (as Hamel's): its accelerations need Newton's method at every step, "
        .. "which the export does not write yet; nzlua integrates it (sys:simulate)", r)
    end
    local phi = c:piece_outputs("constraints", r)
    if #phi == 0 then fail(sys, "constraint %d runs in Lua (print(sys) says why): it cannot be exported", r) end
    out.phi[r] = phi[1]
    local row = {}
    for i = 1, k do row[i] = c:derivative(phi[1], { [input(m, i)] = one }) end
    out.A[r] = row
    local d = phi[1]
    for _ = 1, 2 - m do d = c:derivative(d, motion) end
    out.b[r] = d   -- evaluated with q'' = 0 (the code sets it): A q'' drops out
  end
  out.orders = orders
  if jacobian then
    -- along q_j (s = 0) and q'_j (s = 1): dM, dh, dA, db
    out.d = {}
    for s = 0, 1 do
      for j = 1, k do
        local dir = { [input(s, j)] = one }
        local dd = { M = {}, h = {}, A = {}, b = {} }
        for n, x in ipairs(out.M) do dd.M[n] = c:derivative(x, dir) end
        for n, x in ipairs(out.h) do dd.h[n] = c:derivative(x, dir) end
        for r = 1, sys.nc do
          dd.A[r] = {}
          for i = 1, k do dd.A[r][i] = c:derivative(out.A[r][i], dir) end
          dd.b[r] = c:derivative(out.b[r], dir)
        end
        out.d[s * k + j] = dd
      end
    end
  end
  return out
end

-- The nodes the outputs need, in the graph's (topological) order.
local function needed(nodes, roots)
  local need, stack = {}, {}
  for _, r in ipairs(roots) do stack[#stack + 1] = r end
  while #stack > 0 do
    local x = table.remove(stack)
    if not need[x] then
      need[x] = true
      local op = nodes.op[x + 1]
      if op ~= "const" and op ~= "input" then
        for _, f in ipairs{ "a", "b", "c" } do
          local y = nodes[f][x + 1]
          if y >= 0 and not (f == "b" and op == "powc") then stack[#stack + 1] = y end
        end
      end
    end
  end
  local list = {}
  for x in pairs(need) do list[#list + 1] = x end
  table.sort(list)
  return list
end

-- ------------------------------------------------------------------ --
-- Languages

local function num(v)
  if v ~= v then return "NAN" end
  if v == math.huge then return "INFINITY" elseif v == -math.huge then return "-INFINITY" end
  local s = formula.number(v)
  if not s:find("[%.eEn]") then s = s .. ".0" end
  return s
end

local C = {
  ext = "c", comment = "//", var = function(x) return "v" .. x end,
  decl = function(name, expr) return ("  const double %s = %s;"):format(name, expr) end,
  num = num,
  fn = { exp = "exp", log = "log", sqrt = "sqrt", sin = "sin", cos = "cos", tan = "tan", asin = "asin", acos = "acos",
    atan = "atan", sinh = "sinh", cosh = "cosh", tanh = "tanh", abs = "fabs" },
  sign = function(a) return ("((%s > 0) - (%s < 0))"):format(a, a) end,
  pow = function(a, b) return ("pow(%s, %s)"):format(a, b) end,
  atan2 = function(a, b) return ("atan2(%s, %s)"):format(a, b) end,
  hypot = function(a, b) return ("hypot(%s, %s)"):format(a, b) end,
  cmp = function(op, a, b)
    return ("(%s %s %s ? 1.0 : 0.0)"):format(a, ({ lt = "<", le = "<=", gt = ">", ge = ">=", eq = "==", ne = "!=" })[op], b)
  end,
  select = function(c, a, b) return ("(%s != 0 ? %s : %s)"):format(c, a, b) end,
  index = function(v, i) return ("%s[%d]"):format(v, i - 1) end,
}

local PY = {
  ext = "py", comment = "#", var = function(x) return "v" .. x end,
  decl = function(name, expr) return ("    %s = %s"):format(name, expr) end,
  num = function(v)
    if v ~= v then return "math.nan" end
    if math.abs(v) == math.huge then return (v > 0 and "" or "-") .. "math.inf" end
    local s = formula.number(v)
    if not s:find("[%.eEn]") then s = s .. ".0" end
    return s
  end,
  fn = { exp = "math.exp", log = "math.log", sqrt = "math.sqrt", sin = "math.sin", cos = "math.cos", tan = "math.tan",
    asin = "math.asin", acos = "math.acos", atan = "math.atan", sinh = "math.sinh", cosh = "math.cosh", tanh = "math.tanh",
    abs = "abs" },
  sign = function(a) return ("((%s > 0) - (%s < 0))"):format(a, a) end,
  pow = function(a, b) return ("%s ** %s"):format(a, b) end,
  atan2 = function(a, b) return ("math.atan2(%s, %s)"):format(a, b) end,
  hypot = function(a, b) return ("math.hypot(%s, %s)"):format(a, b) end,
  cmp = function(op, a, b)
    return ("(1.0 if %s %s %s else 0.0)"):format(a, ({ lt = "<", le = "<=", gt = ">", ge = ">=", eq = "==", ne = "!=" })[op], b)
  end,
  select = function(c, a, b) return ("(%s if %s != 0 else %s)"):format(a, c, b) end,
  index = function(v, i) return ("%s[%d]"):format(v, i - 1) end,
}

local OCT = {
  ext = "m", comment = "%", var = function(x) return "v" .. x end,
  decl = function(name, expr) return ("  %s = %s;"):format(name, expr) end,
  num = function(v)
    if v ~= v then return "NaN" end
    if math.abs(v) == math.huge then return (v > 0 and "" or "-") .. "Inf" end
    return formula.number(v)
  end,
  fn = { exp = "exp", log = "log", sqrt = "sqrt", sin = "sin", cos = "cos", tan = "tan", asin = "asin", acos = "acos",
    atan = "atan", sinh = "sinh", cosh = "cosh", tanh = "tanh", abs = "abs" },
  sign = function(a) return ("sign(%s)"):format(a) end,
  pow = function(a, b) return ("%s ^ %s"):format(a, b) end,
  atan2 = function(a, b) return ("atan2(%s, %s)"):format(a, b) end,
  hypot = function(a, b) return ("hypot(%s, %s)"):format(a, b) end,
  cmp = function(op, a, b)
    return ("double(%s %s %s)"):format(a, ({ lt = "<", le = "<=", gt = ">", ge = ">=", eq = "==", ne = "~=" })[op], b)
  end,
  select = function(c, a, b) return ("ifelse_(%s, %s, %s)"):format(c, a, b) end,
  index = function(v, i) return ("%s(%d)"):format(v, i) end,
}
M.languages = { c = C, python = PY, octave = OCT }

-- Straight-line code for the nodes `list`: one line per node; inputs read
-- from t, params, q, qd, qdd (qdd = 0 where the caller says).
local function body(L, sys, nodes, list, np, names)
  local k = sys.k
  local lines = {}
  local function v(x)
    local op = nodes.op[x + 1]
    if op == "const" then return L.num(nodes.v[x + 1]) end
    return L.var(x)
  end
  for _, x in ipairs(list) do
    local op, a, b, cc = nodes.op[x + 1], nodes.a[x + 1], nodes.b[x + 1], nodes.c[x + 1]
    local e
    if op == "const" then e = nil
    elseif op == "input" then
      if a == 0 then e = "t"
      elseif a <= np then e = "p_" .. names[a]
      else
        local s = a - 1 - np
        local j, i = s // k, s % k + 1
        e = j <= 2 and L.index(({ "q", "qd", "qdd" })[j + 1], i) or "0.0"   -- q''' and above: 0 (b's q''' terms vanish)
      end
    elseif op == "add" then e = ("%s + %s"):format(v(a), v(b))
    elseif op == "sub" then e = ("%s - %s"):format(v(a), v(b))
    elseif op == "mul" then e = ("%s * %s"):format(v(a), v(b))
    elseif op == "div" then e = ("%s / %s"):format(v(a), v(b))
    elseif op == "neg" then e = ("-%s"):format(v(a))
    elseif op == "powc" then
      local p = nodes.v[x + 1]
      if p == 2 then e = ("%s * %s"):format(v(a), v(a))
      elseif p == 3 then e = ("%s * %s * %s"):format(v(a), v(a), v(a))
      elseif p == -1 then e = ("1.0 / %s"):format(v(a))
      elseif p == 0.5 then e = ("%s(%s)"):format(L.fn.sqrt, v(a))
      else e = L.pow(v(a), L.num(p)) end
    elseif op == "pow" then e = L.pow(v(a), v(b))
    elseif op == "fn" then
      local f = nodes.fn[x + 1]
      if f == "sign" then e = L.sign(v(a)) else e = ("%s(%s)"):format(assert(L.fn[f], f), v(a)) end
    elseif op == "atan2" then e = L.atan2(v(a), v(b))
    elseif op == "hypot" then e = L.hypot(v(a), v(b))
    elseif op == "cmp" then e = L.cmp(nodes.fn[x + 1], v(a), v(b))
    elseif op == "select" then e = L.select(v(cc), v(a), v(b))
    end
    if e then lines[#lines + 1] = L.decl(L.var(x), e) end
  end
  return lines, v
end

-- ------------------------------------------------------------------ --
-- C

-- The C file's fixed parts: the saddle-point solve and the right-hand side
-- (LU with partial pivoting, written out: the file needs only libm), the
-- Jacobian of the right-hand side, and a main that integrates with GSL.
local C_SOLVER = [=[
// LU with partial pivoting of the n x n matrix a (row-major), in place;
// 0, or -1 when a pivot is zero (a singular mass matrix or dependent
// constraints at this state).
static int nzx_lu(int n, double *a, int *piv)
{
  for (int c = 0; c < n; c++) {
    int p = c;
    for (int r = c + 1; r < n; r++) if (fabs(a[r * n + c]) > fabs(a[p * n + c])) p = r;
    piv[c] = p;
    if (a[p * n + c] == 0.0) return -1;
    if (p != c) for (int j = 0; j < n; j++) { double s = a[c * n + j]; a[c * n + j] = a[p * n + j]; a[p * n + j] = s; }
    for (int r = c + 1; r < n; r++) {
      double f = a[r * n + c] /= a[c * n + c];
      for (int j = c + 1; j < n; j++) a[r * n + j] -= f * a[c * n + j];
    }
  }
  return 0;
}

// Solves with the factor of nzx_lu: the row swaps first (the factor's rows
// were swapped whole, multipliers included), then L and U.
static void nzx_lu_solve(int n, const double *a, const int *piv, double *x)
{
  for (int c = 0; c < n; c++)
    if (piv[c] != c) { double s = x[c]; x[c] = x[piv[c]]; x[piv[c]] = s; }
  for (int c = 0; c < n; c++)
    for (int r = c + 1; r < n; r++) x[r] -= a[r * n + c] * x[c];
  for (int r = n - 1; r >= 0; r--) {
    for (int j = r + 1; j < n; j++) x[r] -= a[r * n + j] * x[j];
    x[r] /= a[r * n + r];
  }
}

// The saddle-point matrix K = [M -A^T; A 0] and right-hand side r = (-h, -b).
static void nzx_kkt(const double *M, const double *h, const double *A, const double *b, double *K, double *r)
{
  const int n = NZX_K + NZX_NC;
  memset(K, 0, sizeof(double) * n * n);
  for (int i = 0; i < NZX_K; i++) {
    for (int j = 0; j < NZX_K; j++) K[i * n + j] = M[i * NZX_K + j];
    r[i] = -h[i];
  }
  for (int c = 0; c < NZX_NC; c++) {
    for (int i = 0; i < NZX_K; i++) {
      K[i * n + NZX_K + c] = -A[c * NZX_K + i];
      K[(NZX_K + c) * n + i] = A[c * NZX_K + i];
    }
    r[NZX_K + c] = -b[c];
  }
}

// The accelerations q'' (k) and multipliers lambda (nc) at (t, q, q');
// 0, or -1 at a singular state.
int nzx_accel(double t, const double *q, const double *qd, double *qdd, double *lambda)
{
  enum { N = NZX_K + NZX_NC };
  double M[NZX_K * NZX_K], h[NZX_K], A[NZX_NC * NZX_K + 1], b[NZX_NC + 1], K[N * N], z[N];
  int piv[N];
  nzx_terms(t, q, qd, M, h, A, b);
  nzx_kkt(M, h, A, b, K, z);
  if (nzx_lu(N, K, piv)) return -1;
  nzx_lu_solve(N, K, piv, z);
  for (int i = 0; i < NZX_K; i++) qdd[i] = z[i];
  for (int c = 0; c < NZX_NC; c++) if (lambda) lambda[c] = z[NZX_K + c];
  return 0;
}

// The first-order right-hand side f(t, y) = (q', q''); 0, or -1 at a singular state.
int nzx_rhs(double t, const double *y, double *f)
{
  double lambda[NZX_NC + 1];
  for (int i = 0; i < NZX_K; i++) f[i] = y[NZX_K + i];
  return nzx_accel(t, y, y + NZX_K, f + NZX_K, lambda);
}

// The constraint values at (t, q, q') (their accelerations from the motion).
int nzx_constraints(double t, const double *q, const double *qd, double *phi)
{
  double qdd[NZX_K], lambda[NZX_NC + 1];
  if (nzx_accel(t, q, qd, qdd, lambda)) return -1;
  nzx_constraints_raw(t, q, qd, qdd, phi);
  return 0;
}
]=]

local C_JACOBIAN = [=[

// The Jacobian df/dy (dim x dim, row-major) at (t, y): the q' rows are the
// identity's; the q'' rows from the derivative of the saddle-point solve,
// K dz = dr - dK z, along each q_j and q'_j (the terms' derivatives exact,
// from the graph).  0, or -1 at a singular state.
int nzx_jacobian(double t, const double *y, double *J)
{
  enum { N = NZX_K + NZX_NC };
  const double *q = y, *qd = y + NZX_K;
  double M[NZX_K * NZX_K], h[NZX_K], A[NZX_NC * NZX_K + 1], b[NZX_NC + 1], K[N * N], z[N];
  double dM[NZX_K * NZX_K], dh[NZX_K], dA[NZX_NC * NZX_K + 1], db[NZX_NC + 1], dK[N * N], dr[N];
  int piv[N];
  nzx_terms(t, q, qd, M, h, A, b);
  nzx_kkt(M, h, A, b, K, z);
  if (nzx_lu(N, K, piv)) return -1;
  nzx_lu_solve(N, K, piv, z);
  memset(J, 0, sizeof(double) * NZX_DIM * NZX_DIM);
  for (int i = 0; i < NZX_K; i++) J[i * NZX_DIM + NZX_K + i] = 1.0;
  for (int j = 0; j < NZX_DIM; j++) {
    nzx_dterms[j](t, q, qd, dM, dh, dA, db);
    nzx_kkt(dM, dh, dA, db, dK, dr);
    for (int r = 0; r < N; r++) {
      double s = dr[r];
      for (int c = 0; c < N; c++) s -= dK[r * N + c] * z[c];
      dr[r] = s;
    }
    nzx_lu_solve(N, K, piv, dr);
    for (int i = 0; i < NZX_K; i++) J[(NZX_K + i) * NZX_DIM + j] = dr[i];
  }
  return 0;
}
]=]

local C_MAIN = [=[
#ifndef NZX_NO_MAIN
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>

static int gsl_rhs(double t, const double y[], double f[], void *params)
{
  (void)params;
  return nzx_rhs(t, y, f) ? GSL_EBADFUNC : GSL_SUCCESS;
}

// Integrates from the start below with GSL's rk8pd and prints CSV:
// t, the coordinates, their rates; one row per dt from t0 to t1.
int main(void)
{
  const double t0 = %s, t1 = %s, dt = %s, rtol = %s, atol = %s;
  double y[NZX_DIM] = { %s, %s };
  gsl_odeiv2_system sys = { gsl_rhs, NULL, NZX_DIM, NULL };
  gsl_odeiv2_driver *d = gsl_odeiv2_driver_alloc_y_new(&sys, gsl_odeiv2_step_rk8pd, dt < 1e-3 ? dt : 1e-3, atol, rtol);
  printf("t");
  for (int i = 0; i < NZX_K; i++) printf(",%%s", nzx_names[i]);
  for (int i = 0; i < NZX_K; i++) printf(",%%s'", nzx_names[i]);
  printf("\n");
  double t = t0;
  long n = (long)floor((t1 - t0) / dt + 0.5);
  for (long s = 0; s <= n; s++) {
    double ts = s == n ? t1 : t0 + (double)s * dt;
    if (s > 0) {
      int st = gsl_odeiv2_driver_apply(d, &t, ts, y);
      if (st != GSL_SUCCESS) { fprintf(stderr, "integration failed at t = %%g: %%s\n", t, gsl_strerror(st)); gsl_odeiv2_driver_free(d); return 1; }
    }
    printf("%%.17g", ts);
    for (int i = 0; i < NZX_DIM; i++) printf(",%%.17g", y[i]);
    printf("\n");
  }
  gsl_odeiv2_driver_free(d);
  return 0;
}
#endif
]=]

-- The C file's head: what it is, the coordinates, its includes, its sizes,
-- the names and the parameters.
local function c_header(sys, opts, add, names)
  local k, nc = sys.k, sys.nc
  add(("// %s: the equations of motion of '%s', written by nzlua's sys:export."):format(opts.file or "export.c", sys.name))
  add("// Self-contained: C99 and libm (GSL only for the main). Coordinates:")
  for i = 1, k do add(("//   q[%d] = %s, qd[%d] = %s'"):format(i - 1, sys.coords[i], i - 1, sys.coords[i])) end
  add("// M q'' + h = A^T lambda (the equations of every order n collected), the constraints")
  add("// closed at the acceleration level: A q'' + b = 0.  The state is y = (q, q').")
  add("#include <math.h>")
  add("#include <stdio.h>")
  add("#include <stdlib.h>")
  add("#include <string.h>")
  add("")
  add(("enum { NZX_K = %d, NZX_NC = %d, NZX_DIM = %d };"):format(k, nc, 2 * k))
  -- (not static: without a main nothing in the file reads it)
  add(("const char *const nzx_names[NZX_K] = { %s };"):format((function()
    local t = {}
    for i = 1, k do t[i] = ("%q"):format(sys.coords[i]) end
    return table.concat(t, ", ")
  end)()))
  if #names > 0 then
    add("// parameters (sys.params when exported); change them before calling")
    for _, n in ipairs(names) do add(("double p_%s = %s;"):format(n, num(sys.params[n]))) end
  end
end

-- One C function per group of outputs (M, h, A, b; the constraints'
-- values; their derivatives along each state component), each with its own
-- straight-line code.
local function c_functions(sys, out, nodes, add, np, names)
  local k, nc, L = sys.k, sys.nc, C
  local function emit(fname, sig, roots_named, qdd_zero)
    local roots = {}
    for _, r in ipairs(roots_named) do roots[#roots + 1] = r.id end
    local list = needed(nodes, roots)
    add(("static void %s(%s)"):format(fname, sig))
    add("{")
    if qdd_zero then
      add("  double qdd[NZX_K];")
      add("  memset(qdd, 0, sizeof qdd);")
    end
    -- every parameter marked used: a function of the state that reads only
    -- part of it compiles without -Wunused-parameter under -Wall -Wextra
    local used = {}
    for param in (sig .. ","):gmatch("([%a_][%w_]*)%s*,") do used[#used + 1] = ("(void)%s;"):format(param) end
    add("  " .. table.concat(used, " "))
    local lines, v = body(L, sys, nodes, list, np, names)
    for _, l in ipairs(lines) do add(l) end
    for _, r in ipairs(roots_named) do add(("  %s = %s;"):format(r.target, v(r.id))) end
    add("}")
    add("")
  end
  local function mb_roots(src, prefix)
    local rs = {}
    for n = 1, k * k do rs[#rs + 1] = { id = src.M[n], target = ("%sM[%d]"):format(prefix, n - 1) } end
    for i = 1, k do rs[#rs + 1] = { id = src.h[i], target = ("%sh[%d]"):format(prefix, i - 1) } end
    for r = 1, nc do
      for i = 1, k do rs[#rs + 1] = { id = src.A[r][i], target = ("%sA[%d]"):format(prefix, (r - 1) * k + i - 1) } end
      rs[#rs + 1] = { id = src.b[r], target = ("%sb[%d]"):format(prefix, r - 1) }
    end
    return rs
  end
  emit("nzx_terms", "double t, const double *q, const double *qd, double *M, double *h, double *A, double *b", mb_roots(out, ""), true)
  local phis = {}
  for r = 1, nc do phis[r] = { id = out.phi[r], target = ("phi[%d]"):format(r - 1) } end
  add("// The constraint values Phi_r(t, q, q', q''), to watch their drift.")
  emit("nzx_constraints_raw", "double t, const double *q, const double *qd, const double *qdd, double *phi", phis, false)
  if out.d then
    for j = 1, 2 * k do emit(("nzx_dterms_%d"):format(j - 1),
      "double t, const double *q, const double *qd, double *dM, double *dh, double *dA, double *db", mb_roots(out.d[j], "d"), true) end
  end
end

local function c_file(sys, out, nodes, opts)
  local k = sys.k
  local names = sys.engine.recording_params or {}
  local np = #names
  local w = {}
  local function add(s) w[#w + 1] = s end
  c_header(sys, opts, add, names)
  add("")
  c_functions(sys, out, nodes, add, np, names)
  add(C_SOLVER)
  if out.d then
    local calls = {}
    for j = 1, 2 * k do calls[j] = ("nzx_dterms_%d"):format(j - 1) end
    add(("static void (*const nzx_dterms[NZX_DIM])(double, const double *, const double *, double *, double *, double *, double *) = { %s };")
      :format(table.concat(calls, ", ")))
    add(C_JACOBIAN)
  end
  if opts.main then
    local m = opts.main
    local q0, qd0 = {}, {}
    for i = 1, k do q0[i], qd0[i] = num(m.q0[i]), num((m.qd0 or {})[i] or 0) end
    add(C_MAIN:format(num(m.t0 or 0), num(m.t1), num(m.dt), num(m.rtol or 1e-10), num(m.atol or 1e-10), table.concat(q0, ", "),
      table.concat(qd0, ", ")))
  end
  return table.concat(w, "\n") .. "\n"
end

-- ------------------------------------------------------------------ --
-- Python (NumPy) and Octave: the same functions, in one file each

-- The Python and Octave files' fixed parts: the saddle-point solve and the
-- right-hand side, the Jacobian, and a main (Dormand-Prince in Python, so
-- that NumPy is all it needs; ode45 in Octave).
local PY_SOLVER = [=[
def _kkt(M, h, A, b):
    n = K + NC
    Kk = np.zeros((n, n)); r = np.zeros(n)
    Kk[:K, :K] = M; Kk[:K, K:] = -A.T; Kk[K:, :K] = A
    r[:K] = -h; r[K:] = -b
    return Kk, r

def nzx_accel(t, q, qd):
    """q'' and the multipliers at (t, q, q')."""
    M, h, A, b = nzx_terms(t, q, qd)
    Kk, r = _kkt(M, h, A, b)
    z = np.linalg.solve(Kk, r)
    return z[:K], z[K:]

def nzx_rhs(t, y):
    """f(t, y) = (q', q'')."""
    y = np.asarray(y, dtype=float)
    qdd, _ = nzx_accel(t, y[:K], y[K:])
    return np.concatenate((y[K:], qdd))

def nzx_constraints(t, q, qd):
    qdd, _ = nzx_accel(t, q, qd)
    return nzx_constraints_raw(t, q, qd, qdd)
]=]

local PY_JACOBIAN = [=[

def nzx_jacobian(t, y):
    """df/dy from the derivative of the saddle-point solve (exact terms)."""
    y = np.asarray(y, dtype=float)
    q, qd = y[:K], y[K:]
    M, h, A, b = nzx_terms(t, q, qd)
    Kk, r = _kkt(M, h, A, b)
    z = np.linalg.solve(Kk, r)
    J = np.zeros((2 * K, 2 * K))
    J[:K, K:] = np.eye(K)
    for j, d in enumerate(_DTERMS):
        dK, dr = _kkt(*d(t, q, qd))
        J[K:, j] = np.linalg.solve(Kk, dr - dK @ z)[:K]
    return J
]=]

local PY_MAIN = [=[
def _dopri(f, t, y, t1, rtol, atol, h):
    """Dormand-Prince 5(4) with error control, from t to t1."""
    c = [0, 1/5, 3/10, 4/5, 8/9, 1, 1]
    a = [[], [1/5], [3/40, 9/40], [44/45, -56/15, 32/9],
         [19372/6561, -25360/2187, 64448/6561, -212/729],
         [9017/3168, -355/33, 46732/5247, 49/176, -5103/18656],
         [35/384, 0, 500/1113, 125/192, -2187/6784, 11/84]]
    e = [71/57600, 0, -71/16695, 71/1920, -17253/339200, 22/525, -1/40]
    while t < t1:
        h = min(h, t1 - t)
        ks = []
        for i in range(7):
            yi = y + h * sum(a[i][j] * ks[j] for j in range(i)) if i else y
            ks.append(f(t + c[i] * h, yi))
        y5 = y + h * sum(a[6][j] * ks[j] for j in range(6))
        err = h * sum(e[j] * ks[j] for j in range(7))
        sc = atol + rtol * np.maximum(np.abs(y), np.abs(y5))
        en = math.sqrt(np.mean((err / sc) ** 2))
        if en <= 1.0:
            t, y = t + h, y5
        h *= min(5.0, max(0.2, 0.9 * (en if en > 0 else 1e-10) ** -0.2))
    return y, h

def main():
    t0, t1, dt, rtol, atol = %s, %s, %s, %s, %s
    y = np.array([%s])
    print("t," + ",".join(NAMES) + "," + ",".join(n + "'" for n in NAMES))
    n = int(math.floor((t1 - t0) / dt + 0.5))
    h, t = min(dt, 1e-3), t0
    for s in range(n + 1):
        ts = t1 if s == n else t0 + s * dt
        if s > 0:
            y, h = _dopri(nzx_rhs, t, y, ts, rtol, atol, h)
            t = ts
        print(",".join(repr(float(v)) for v in [ts] + list(y)))

if __name__ == "__main__":
    main()
]=]

local OCTAVE_SOLVER = [=[
function [Kk, r] = kkt_(M, h, A, b)
  k = %d; nc = %d;
  Kk = zeros(k + nc); r = zeros(k + nc, 1);
  Kk(1:k, 1:k) = M;
  if nc > 0
    Kk(1:k, k+1:end) = -A'; Kk(k+1:end, 1:k) = A; r(k+1:end) = -b;
  end
  r(1:k) = -h;
end
function [qdd, lambda] = nzx_accel(t, q, qd)
  [M, h, A, b] = nzx_terms(t, q, qd);
  [Kk, r] = kkt_(M, h, A, b);
  z = Kk \ r;
  qdd = z(1:%d); lambda = z(%d+1:end);
end
function f = nzx_rhs(t, y)
  k = %d;
  qdd = nzx_accel(t, y(1:k), y(k+1:end));
  f = [y(k+1:end); qdd];
end]=]

local OCTAVE_MAIN = [=[
t0 = %s; t1 = %s; dt = %s;
n = round((t1 - t0) / dt);
ts = t0 + (0:n)' * dt; ts(end) = t1;
opts = odeset('RelTol', %s, 'AbsTol', %s);
[tt, yy] = ode45(@nzx_rhs, ts, [%s]', opts);
printf('%s\n');
for s = 1:numel(tt)
  printf('%%.17g', tt(s)); printf(',%%.17g', yy(s, :)); printf('\n');
end]=]

-- The Python file after the terms: the constraints, the solve, the
-- Jacobian and the main (emit writes a function of the graph's outputs).
local function python_tail(sys, out, opts, add, emit, phis)
  local k, L = sys.k, PY
  add("def nzx_constraints_raw(t, q, qd, qdd):")
  add("    phi = np.zeros(NC)")
  add("    return _phi_fill(t, q, qd, qdd, phi)")
  add("")
  emit("_phi_fill", "t, q, qd, qdd, phi", phis, false, "phi")
  add(PY_SOLVER)
  if out.d then
    local names_d = {}
    for j = 1, 2 * k do names_d[j] = ("nzx_dterms_%d"):format(j) end
    add(("_DTERMS = [%s]"):format(table.concat(names_d, ", ")))
    add(PY_JACOBIAN)
  end
  if opts.main then
    local m = opts.main
    local y0 = {}
    for i = 1, k do y0[i] = L.num(m.q0[i]) end
    for i = 1, k do y0[k + i] = L.num((m.qd0 or {})[i] or 0) end
    add(PY_MAIN:format(L.num(m.t0 or 0), L.num(m.t1), L.num(m.dt), L.num(m.rtol or 1e-10), L.num(m.atol or 1e-10), table.concat(y0, ", ")))
  end
end

-- The Octave file after the terms.
local function octave_tail(sys, opts, add, emit, phis)
  local k, nc, L = sys.k, sys.nc, OCT
  add(("function phi = nzx_constraints_raw(t, q, qd, qdd)\n  phi = zeros(%d, 1);\n  phi = phi_fill_(t, q, qd, qdd, phi);\nend"):format(nc))
  emit("phi_fill_", "t, q, qd, qdd, phi", phis, false, "phi")
  add(OCTAVE_SOLVER:format(k, nc, k, k, k))
  if opts.main then
    local m = opts.main
    local y0 = {}
    for i = 1, k do y0[i] = L.num(m.q0[i]) end
    for i = 1, k do y0[k + i] = L.num((m.qd0 or {})[i] or 0) end
    local head = { "t" }
    for i = 1, k do head[#head + 1] = sys.coords[i] end
    for i = 1, k do head[#head + 1] = sys.coords[i] .. "'" end
    add(OCTAVE_MAIN:format(L.num(m.t0 or 0), L.num(m.t1), L.num(m.dt), L.num(m.rtol or 1e-10), L.num(m.atol or 1e-10),
      table.concat(y0, "; "), (table.concat(head, ","):gsub("'", "''"))))   -- a quote doubled in Octave's strings
  end
end

local function script_file(sys, out, nodes, opts, L)
  local k, nc, e = sys.k, sys.nc, sys.engine
  local names = e.recording_params or {}
  local np = #names
  local py = L == PY
  local w = {}
  local function add(s) w[#w + 1] = s end
  local cm = L.comment
  add(("%s %s: the equations of motion of '%s', written by nzlua's sys:export."):format(cm, opts.file or ("export." .. L.ext), sys.name))
  add(("%s M q'' + h = A^T lambda, the constraints at the acceleration level A q'' + b = 0; y = (q, q')."):format(cm))
  for i = 1, k do add(("%s   q(%d) = %s"):format(cm, i, sys.coords[i])) end
  if py then
    add("import math")
    add("import sys as _sys")
    add("import numpy as np")
    add("")
    add(("K, NC = %d, %d"):format(k, nc))
    add(("NAMES = [%s]"):format((function() local t = {}; for i = 1, k do t[i] = ("%q"):format(sys.coords[i]) end; return table.concat(t, ", ") end)()))
    for _, n in ipairs(names) do add(("p_%s = %s"):format(n, L.num(sys.params[n]))) end
  else
    add("1;  % a script file: the functions below, then the main")
    add(("function r = ifelse_(c, a, b)\n  if c ~= 0\n    r = a;\n  else\n    r = b;\n  end\nend"))
    for _, n in ipairs(names) do add(("global p_%s; p_%s = %s;"):format(n, n, L.num(sys.params[n]))) end
  end
  local function emit(fname, args, roots_named, qdd_zero, results)
    local roots = {}
    for _, r in ipairs(roots_named) do roots[#roots + 1] = r.id end
    local list = needed(nodes, roots)
    if py then
      add(("def %s(%s):"):format(fname, args))
      for _, n in ipairs(names) do add(("    global p_%s"):format(n)) end
      if qdd_zero then add("    qdd = [0.0] * K") end
    else
      add(("function [%s] = %s(%s)"):format(results, fname, args))
      for _, n in ipairs(names) do add(("  global p_%s;"):format(n)) end
      if qdd_zero then add(("  qdd = zeros(%d, 1);"):format(k)) end
    end
    local lines, v = body(L, sys, nodes, list, np, names)
    for _, l in ipairs(lines) do add(l) end
    for _, r in ipairs(roots_named) do add((py and "    %s = %s" or "  %s = %s;"):format(r.target, v(r.id))) end
    if py then add(("    return %s"):format(results)) else add("end") end
    add("")
  end
  local function mb_roots(src)
    local rs = {}
    for i = 1, k do for j = 1, k do
      rs[#rs + 1] = { id = src.M[(i - 1) * k + j], target = py and ("M[%d, %d]"):format(i - 1, j - 1) or ("M(%d, %d)"):format(i, j) }
    end end
    for i = 1, k do rs[#rs + 1] = { id = src.h[i], target = py and ("h[%d]"):format(i - 1) or ("h(%d)"):format(i) } end
    for r = 1, nc do
      for i = 1, k do rs[#rs + 1] = { id = src.A[r][i], target = py and ("A[%d, %d]"):format(r - 1, i - 1) or ("A(%d, %d)"):format(r, i) } end
      rs[#rs + 1] = { id = src.b[r], target = py and ("b[%d]"):format(r - 1) or ("b(%d)"):format(r) }
    end
    return rs
  end
  local function terms(fname, src)
    if py then
      add(("def %s(t, q, qd):"):format(fname))
      add("    M = np.zeros((K, K)); h = np.zeros(K); A = np.zeros((NC, K)); b = np.zeros(NC)")
      add(("    return %s_fill(t, q, qd, M, h, A, b)"):format(fname))
      add("")
      emit(fname .. "_fill", "t, q, qd, M, h, A, b", mb_roots(src), true, "M, h, A, b")
    else
      add(("function [M, h, A, b] = %s(t, q, qd)"):format(fname))
      add(("  M = zeros(%d, %d); h = zeros(%d, 1); A = zeros(%d, %d); b = zeros(%d, 1);"):format(k, k, k, nc, k, nc))
      add(("  [M, h, A, b] = %s_fill(t, q, qd, M, h, A, b);"):format(fname))
      add("end")
      emit(fname .. "_fill", "t, q, qd, M, h, A, b", mb_roots(src), true, "M, h, A, b")
    end
  end
  terms("nzx_terms", out)
  if out.d then for j = 1, 2 * k do terms(("nzx_dterms_%d"):format(j), out.d[j]) end end
  local phis = {}
  for r = 1, nc do phis[r] = { id = out.phi[r], target = py and ("phi[%d]"):format(r - 1) or ("phi(%d)"):format(r) } end
  if py then python_tail(sys, out, opts, add, emit, phis) else octave_tail(sys, opts, add, emit, phis) end
  return table.concat(w, "\n") .. "\n"
end

-- ------------------------------------------------------------------ --

local OPTIONS = options.declare("sys:export", { "lang", "file", "main", "jacobian", "smooth" })
local MAIN_OPTIONS = options.declare("sys:export main", { "q0", "qd0", "t0", "t1", "dt", "rtol", "atol" })

function M.export(sys, opts)
  if type(opts) ~= "table" then fail(sys, "options expected: sys:export{ lang = \"c\", file = \"name.c\" [, main = {...}] }") end
  options.check(opts, OPTIONS, function(...) fail(sys, ...) end)
  local lang = opts.lang or "c"
  local L = M.languages[lang]
  if not L then fail(sys, "lang = '%s': one of \"c\", \"python\", \"octave\"", tostring(lang)) end
  if opts.main ~= nil then
    local m = opts.main
    if type(m) ~= "table" then fail(sys, "main: a table {q0 =, qd0 =, t1 =, dt = [, t0, rtol, atol]} expected") end
    options.check(m, MAIN_OPTIONS, function(fmt, ...) fail(sys, "main: " .. fmt, ...) end)
    if type(m.q0) ~= "table" or #m.q0 ~= sys.k then fail(sys, "main.q0: %d numbers expected", sys.k) end
    if m.qd0 ~= nil and (type(m.qd0) ~= "table" or #m.qd0 ~= sys.k) then fail(sys, "main.qd0: %d numbers expected", sys.k) end
    if type(m.t1) ~= "number" or type(m.dt) ~= "number" or m.dt <= 0 or m.t1 <= (m.t0 or 0) then
      fail(sys, "main.t1 and main.dt: numbers with t1 > t0 and dt > 0 expected")
    end
  end
  -- unilateral contacts have events and impacts the exported code does not:
  -- refused, or with smooth = true the system without them, said first
  local laws = sys.contact and require("nz.presentation.contact_laws")
  if laws and not opts.smooth then fail(sys, "%s", laws.export_refusal(sys)) end
  local jac = opts.jacobian ~= false
  local out = outputs(sys, jac)
  local nodes = sys.engine.recording:nodes()
  local text = lang == "c" and c_file(sys, out, nodes, opts) or script_file(sys, out, nodes, opts, L)
  if laws then text = ("%s %s\n"):format(L.comment, laws.export_note(sys)) .. text end
  if opts.file then
    local f, err = io.open(opts.file, "w")
    if not f then fail(sys, "cannot write %s: %s", opts.file, tostring(err)) end
    f:write(text)
    f:close()
    return opts.file
  end
  return text
end

return M
